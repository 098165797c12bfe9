!> The motion of the particles split into an affine part and a residual,
!> for the neighbour-list validity test (doc/studies/numerics.md, "When the list is
!> rebuilt").
!>
!> A list built at positions x0 with radius r_list = support + skin holds
!> every pair closer than r_list.  If now x_i = F x0_i + b + e_i with
!> |e_i| <= e_max, an unlisted pair (|x0_i - x0_j| > r_list) is at least
!>   s_min = sigma_min(F) r_list - 2 e_max
!> apart, sigma_min the smallest singular value of F (sym3).  The usual test
!> (displacement below half the skin) is the case F = I, b = 0; fitting F
!> and b makes translations, rotations and uniform strains cost nothing,
!> which is most of the motion of the prototype problems.  Every quantity
!> is computed from sums that do not depend on the number of ranks
!> (par_sum_exact), so every rank count rebuilds at the same steps and
!> results stay bitwise independent of the decomposition.  The fit may use
!> a sample chosen by global id (every stride-th): any F, b gives a valid
!> bound as long as e_max is the largest residual of all particles, which
!> it always is; the sample only makes F and b cheaper.
!>
!> With mirror planes (mirrors) the fit is the whole body's: the means and
!> the moments odd in a mirrored coordinate vanish over the part and its
!> images, so they are set to 0.  Then F commutes with every reflection R
!> and R b = b, an image's residual is R e_j, and the bound holds for the
!> pairs (i, image of j) with the part's e_max.
module affine_motion
  use kinds, only: wp, i8
  use parallel_env, only: parallel_env_t, par_sum_exact, par_max
  use sym3, only: invert_spd
  implicit none
  private
  public :: affine_fit

contains

  !> Least-squares fit y_i ~ A x_i + b over the particles of every rank
  !> (first dim components; the others of A and b are 0), and the largest
  !> residual e_max = max_i |y_i - A x_i - b| (global, over all particles).
  !> With id and stride, the fit uses only the particles whose global id is
  !> a multiple of stride.  A degenerate cloud (fewer than dim + 1
  !> independent points) gets A = 0, b = mean of y: still a valid
  !> decomposition, only a less useful one.  mirror: the planes' mask (the
  !> whole body's fit, see above).
  subroutine affine_fit(env, dim, n, x, y, a, b, e_max, id, stride, mirror)
    type(parallel_env_t), intent(in) :: env
    integer, intent(in) :: dim, n
    real(wp), intent(in) :: x(:, :), y(:, :)
    real(wp), intent(out) :: a(3, 3), b(3), e_max
    integer(i8), intent(in), optional :: id(:)
    integer(i8), intent(in), optional :: stride
    integer, intent(in), optional :: mirror
    real(wp), allocatable :: t(:, :)
    integer, allocatable :: pick(:)
    real(wp) :: xm(3), ym(3), cxx(3, 3), cyx(3, 3), s(15), ntot, m(3, 3), r2, ax
    integer, parameter :: P(6) = [1, 1, 1, 2, 2, 3], Q(6) = [1, 2, 3, 2, 3, 3]
    integer :: i, ii, k, l, ns, mask
    mask = 0
    if (present(mirror)) mask = mirror
    if (present(id) .and. present(stride)) then
      pick = pack([(i, i = 1, n)], mod(id(1:n), max(stride, 1_i8)) == 0)
    else
      pick = [(i, i = 1, n)]
    end if
    ns = size(pick)
    ! the means, then the centred moments (centring first avoids the
    ! cancellation in Sum x x^T - N xm xm^T for a cloud far from the origin)
    allocate(t(15, ns))
    do ii = 1, ns
      i = pick(ii)
      t(1:3, ii) = x(:, i)
      t(4:6, ii) = y(:, i)
      t(7, ii) = 1
    end do
    s(1:7) = par_sum_exact(env, t(1:7, :))
    ntot = s(7)
    xm = 0
    ym = 0
    if (ntot > 0) then
      xm = s(1:3) / ntot
      ym = s(4:6) / ntot
    end if
    do k = 1, 3
      if (.not. btest(mask, k - 1)) cycle
      xm(k) = 0
      ym(k) = 0
    end do
    do ii = 1, ns
      i = pick(ii)
      do k = 1, 6
        t(k, ii) = (x(P(k), i) - xm(P(k))) * (x(Q(k), i) - xm(Q(k)))
      end do
      do l = 1, 3
        do k = 1, 3
          t(6 + k + 3 * (l - 1), ii) = (y(k, i) - ym(k)) * (x(l, i) - xm(l))
        end do
      end do
    end do
    s = par_sum_exact(env, t)
    do k = 1, 6
      cxx(P(k), Q(k)) = s(k)
      cxx(Q(k), P(k)) = s(k)
    end do
    cyx = reshape(s(7:15), [3, 3])
    do l = 1, 3
      do k = 1, 3
        if (k /= l .and. (btest(mask, k - 1) .or. btest(mask, l - 1))) then
          cxx(k, l) = 0
          cyx(k, l) = 0
        end if
      end do
    end do
    a = 0
    if (invert_spd(dim, cxx, m)) a(1:dim, 1:dim) = matmul(cyx(1:dim, 1:dim), m(1:dim, 1:dim))
    b = 0
    b(1:dim) = ym(1:dim) - matmul(a(1:dim, 1:dim), xm(1:dim))
    ! written out: matmul on a run-time dim made a temporary per particle
    ! (an allocation each, 40,000 a step at 20,000 particles)
    e_max = 0
    do i = 1, n
      r2 = 0
      do k = 1, dim
        ax = 0
        do l = 1, dim
          ax = ax + a(k, l) * x(l, i)
        end do
        r2 = r2 + (y(k, i) - ax - b(k))**2
      end do
      e_max = max(e_max, r2)
    end do
    e_max = par_max(env, sqrt(e_max))
  end subroutine affine_fit

end module affine_motion
