!> The neighbour list of the time stepper and when to rebuild it: its skin,
!> its build on a grid every rank aligns alike, and the affine validity test
!> (doc/studies/numerics.md, "When the list is rebuilt").
module list_manager
  use kinds, only: wp, i8
  use neighbours, only: neighbour_list_t, neighbour_build, neighbour_row, ROW_PAD
  use affine_motion, only: affine_fit
  use sym3, only: sigma_min
  use parallel_env, only: parallel_env_t, par_max, par_min, par_sum
  implicit none
  private
  public :: list_manager_t, list_radius, list_check, list_build, list_pair_work, list_origin

  !> particles in the affine fits of the validity test: enough for F and V
  !> to a small fraction of the residual, at a cost independent of N
  integer(i8), parameter :: FIT_SAMPLE = 16384
  !> the largest skin, in units of the kernel support
  real(wp), parameter :: SKIN_CAP = 0.25_wp

  type :: list_manager_t
    type(neighbour_list_t) :: nl
    real(wp) :: skin_min = 0      !< smallest skin distance of the list (absolute)
    real(wp) :: skin = 0          !< skin of the current list
    !> the time step the list stays valid for (list_check), huge if unbounded
    real(wp) :: dt_valid = huge(1.0_wp)
    integer :: n_rebuilds = 0
    logical :: force_rebuild = .false.   !< rebuild at the next check
    integer :: mirror = 0                !< the planes' mask (affine_fit)
  end type list_manager_t

contains

  !> The radius of the next build: the kernel support plus the skin.
  pure real(wp) function list_radius(lm, support) result(r)
    type(list_manager_t), intent(in) :: lm
    real(wp), intent(in) :: support
    r = support + lm%skin
  end function list_radius

  !> rebuild: whether the list must be rebuilt before a step (collective):
  !> unless it surely holds every pair that comes within the kernel support
  !> during the step.
  !> Since its build at x0, x = F x0 + b + e (affine_motion), so unlisted
  !> pairs are at least s0 = sigma_min(F) r_list - 2 e_max apart.  Within
  !> the step (dt <= tau = cfl_h/(c0 + Umax), cfl_h = cfl h) the velocities
  !> u = V x + c + w move a pair at separation s apart by at most
  !> tau (|V| s + 2 w_max) + 4 tau^2 a_max (the stage velocities differ from
  !> u by at most dt a_max; 2 a_max allows the acceleration to double), so
  !> the list stays valid while
  !>   s0 (1 - tau |V|) - 2 tau w_max - 4 tau^2 a_max > support.
  !> A rebuild resets s0 to r_list and takes the skin that covers a few such
  !> steps (at least skin_min, at most SKIN_CAP support: a single particle
  !> flung off at a large acceleration must not swell every particle's list);
  !> lm%dt_valid is then the longest step the list covers, the largest
  !> tau' <= tau with s0' (1 - tau' |V|) - 2 tau' w_max - 4 tau'^2 a_max >
  !> support, which bounds the coming step.  The fits of F and V use sums
  !> that do not depend on the decomposition, so every rank count rebuilds
  !> at the same steps.  A rebuild is also due when lm%force_rebuild is set
  !> (after each snapshot, so that a run restarted from it goes through the
  !> same list history).  When due, the skin of the next build is set here.
  subroutine list_check(lm, env, dim, n, x_ref, x, u, a_local, id, support, cfl_h, c0, rebuild)
    type(list_manager_t), intent(inout) :: lm
    type(parallel_env_t), intent(in) :: env
    integer, intent(in) :: dim, n
    !> owned positions at the build, now and velocities now
    real(wp), intent(in) :: x_ref(:, :), x(:, :), u(:, :)
    !> this rank's largest acceleration of the last right-hand side
    real(wp), intent(in) :: a_local
    real(wp), intent(in) :: support, cfl_h, c0
    integer(i8), intent(in) :: id(:)
    logical, intent(out) :: rebuild
    real(wp) :: f(3, 3), v(3, 3), b(3), e_max, w_max, umax, amax, tau, growth, drift, s0
    integer(i8) :: stride
    ! F and V from about FIT_SAMPLE particles picked by id (affine_motion)
    stride = max(1_i8, nint(par_sum(env, real(n, wp)), i8) / FIT_SAMPLE)
    call affine_fit(env, dim, n, x_ref, x, f, b, e_max, id, stride, lm%mirror)
    call affine_fit(env, dim, n, x, u, v, b, w_max, id, stride, lm%mirror)
    umax = 0
    if (n > 0) umax = sqrt(maxval(sum(u(:, 1:n)**2, dim=1)))
    umax = par_max(env, umax)
    amax = par_max(env, a_local)
    tau = cfl_h / (c0 + umax)
    growth = tau * sqrt(sum(v**2))
    drift = 2 * tau * w_max + 4 * tau**2 * amax
    s0 = sigma_min(dim, f) * (support + lm%skin) - 2 * e_max
    rebuild = s0 * (1 - growth) - drift <= support .or. lm%force_rebuild
    if (rebuild) then
      lm%skin = max(lm%skin_min, min(SKIN_CAP * support, &
                    2.2_wp * (support * growth + drift) / max(1 - growth, 0.5_wp)))
      lm%force_rebuild = .false.
      s0 = support + lm%skin
    end if
    lm%dt_valid = valid_step(s0 - support, s0 * growth / tau + 2 * w_max, 4 * amax, tau)
  end subroutine list_check

  !> The largest t <= tau with c - b t - a t^2 > 0 (a, b >= 0, c > 0),
  !> less a margin of 1e-6 relative; tau itself when it qualifies.
  pure real(wp) function valid_step(c, b, a, tau) result(t)
    real(wp), intent(in) :: c, b, a, tau
    if (c - b * tau - a * tau**2 > 0) then
      t = tau
    else if (a > 0) then
      t = (1 - 1e-6_wp) * 2 * c / (b + sqrt(b**2 + 4 * a * c))
    else
      t = (1 - 1e-6_wp) * c / b
    end if
  end function valid_step

  !> Builds the list of radius list_radius on the grid aligned on the
  !> global lower corner of the owned particles, which every rank computes
  !> alike (collective); `origin`, when given, is that corner already
  !> computed (list_origin of the same owned positions).
  subroutine list_build(lm, env, dim, n, ntot, x, id, support, origin)
    type(list_manager_t), intent(inout) :: lm
    type(parallel_env_t), intent(in) :: env
    integer, intent(in) :: dim, n, ntot
    real(wp), intent(in) :: x(3, ntot), support
    integer(i8), intent(in) :: id(ntot)
    real(wp), intent(in), optional :: origin(3)
    real(wp) :: lo(3)
    if (present(origin)) then
      lo = origin
    else
      lo = list_origin(env, n, x)
    end if
    call neighbour_build(lm%nl, dim, n, ntot, x, id, list_radius(lm, support), lo)
    lm%n_rebuilds = lm%n_rebuilds + 1
  end subroutine list_build

  !> The origin of the list's grid: the global lower corner of the owned
  !> positions x(:, 1:n), the same on every rank (collective).
  function list_origin(env, n, x) result(origin)
    type(parallel_env_t), intent(in) :: env
    integer, intent(in) :: n
    real(wp), intent(in) :: x(:, :)
    real(wp) :: origin(3)
    integer :: k
    do k = 1, 3
      origin(k) = huge(1.0_wp)
      if (n > 0) origin(k) = minval(x(k, 1:n))
      origin(k) = par_min(env, origin(k))
    end do
  end function list_origin

  !> Work of each owned particle as its number of listed pairs (a pair of
  !> two owned particles counts for both).
  subroutine list_pair_work(lm, w)
    type(list_manager_t), intent(in) :: lm
    real(wp), intent(inout) :: w(:)
    integer :: kk, i, j, l, nn
    integer, allocatable :: jl(:)
    w = 0
    allocate(jl(lm%nl%longest + ROW_PAD))
    do kk = 1, lm%nl%n_rows
      i = lm%nl%row(kk)
      call neighbour_row(lm%nl, kk, jl, nn)
      do l = 1, nn
        j = jl(l)
        if (i <= size(w)) w(i) = w(i) + 1
        if (j <= size(w)) w(j) = w(j) + 1
      end do
    end do
  end subroutine list_pair_work

end module list_manager
