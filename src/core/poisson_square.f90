!> The Dirichlet Poisson problem on a square (doc/theory/ X5): Laplacian p = f
!> on [-L/2, L/2]^2 with p = 0 on the edges, solved on a uniform grid by
!> FFTW's type-I discrete sine transform, then interpolated to any point.
!>
!> Grid: n interior nodes per direction, x_i = -L/2 + i hg, hg = L/(n + 1),
!> i = 1..n; the edge nodes i = 0 and n + 1 carry p = 0.  The sine series of
!> the sampled f, f_ij = Sum_{m,k} b_mk sin(m pi i/(n+1)) sin(k pi j/(n+1)),
!> has b_mk = Y_mk/(n+1)^2 with Y the 2D RODFT00 transform of f (FFTW's
!> RODFT00 carries a factor 2 per direction).  Two ways to invert the
!> Laplacian on each mode:
!>  - POISSON_SPECTRAL (default): the continuous operator, divide b_mk by
!>    -(k_m^2 + k_k^2), k_m = m pi/L.  Exact for the sine series of f: the
!>    error at the nodes is only that of representing f by n x n sine modes.
!>  - POISSON_FD2: the 5-point Laplacian, whose eigenvalues are
!>    -(4/hg^2)(sin^2(m pi/(2(n+1))) + sin^2(k pi/(2(n+1)))): second order.
!> With a right-hand side that does not vanish on the edges (both square
!> patches) the odd extension of f jumps at the edges and p has r^2 log r
!> corner singularities, so neither converges faster than hg^2; both do
!> converge at exactly that rate (error ratio 4.00 per halving of hg).
!> Measured maximum errors at 4 points against the series, 1024 intervals:
!> rotating square (f constant) spectral 1.6e-7, FD2 1.1e-7 rho omega^2 L^2
!> (FD2's own error partly cancels the aliasing of the jump there); vortical
!> patch (f smooth, small jump) spectral 5.4e-8, FD2 6.1e-7 rho V0^2.  The
!> spectral inversion is the default: its error comes from the edges only.
!>
!> Interpolation: 4-point Lagrange (cubic) in each direction on the nodes
!> including the zero edge values; beyond the edges the stencil uses the
!> odd reflection p(-x) = -p(x), which is the sine series' own extension
!> (continuous with its first derivative), so the interpolant stays third
!> order up to the edges.
module poisson_square
  use, intrinsic :: iso_c_binding, only: c_ptr, c_int, c_double
  use kinds, only: wp, pi
  use fftw3, only: fftw_plan_r2r_2d, fftw_execute_r2r, fftw_destroy_plan, &
                   FFTW_RODFT00, FFTW_ESTIMATE
  implicit none
  private
  public :: poisson_square_t, poisson_square_nodes, poisson_square_solve, poisson_square_eval
  public :: POISSON_SPECTRAL, POISSON_FD2, POISSON_DEFAULT_N

  integer, parameter :: POISSON_SPECTRAL = 1, POISSON_FD2 = 2
  !> Default interior nodes per direction: n + 1 = 1024 intervals (FFTW's
  !> RODFT00 of size n runs an FFT of size 2(n + 1)); about 40 ms, 8 MB.
  integer, parameter :: POISSON_DEFAULT_N = 1023

  !> A solution on the grid, ready for interpolation.
  type :: poisson_square_t
    real(wp) :: side = 1
    integer :: n = 0
    real(wp) :: hg = 1                    !< grid spacing side/(n + 1)
    real(wp), allocatable :: p(:, :)      !< p(-1:n+2, -1:n+2): nodes, edges and odd reflections
  end type poisson_square_t

contains

  !> The n interior node coordinates -L/2 + i L/(n + 1), i = 1..n (the same
  !> in x and y): sample f there for poisson_square_solve.
  pure function poisson_square_nodes(side, n) result(x)
    real(wp), intent(in) :: side
    integer, intent(in) :: n
    real(wp) :: x(n)
    integer :: i
    x = [(-0.5_wp * side + i * side / (n + 1), i = 1, n)]
  end function poisson_square_nodes

  !> Solves Laplacian p = f on the square of side `side` centred at 0 with
  !> p = 0 on its edges; f(i, j) is the right-hand side at the interior node
  !> (x_i, y_j) of poisson_square_nodes(side, size(f, 1)).  `method` is
  !> POISSON_SPECTRAL (default) or POISSON_FD2.
  subroutine poisson_square_solve(side, f, ps, method)
    real(wp), intent(in) :: side
    real(wp), intent(in) :: f(:, :)
    type(poisson_square_t), intent(out) :: ps
    integer, intent(in), optional :: method
    real(c_double), allocatable :: a(:, :), b(:, :)
    real(wp), allocatable :: lam(:)
    type(c_ptr) :: plan
    integer :: n, i, j, how
    how = POISSON_SPECTRAL
    if (present(method)) how = method
    n = size(f, 1)
    if (size(f, 2) /= n .or. n < 1) error stop 'poisson_square_solve: f must be n x n, n >= 1'
    ps%side = side
    ps%n = n
    ps%hg = side / (n + 1)
    allocate(a(n, n), b(n, n), lam(n))
    ! one plan serves both transforms (RODFT00 is its own inverse up to 2(n+1))
    plan = fftw_plan_r2r_2d(int(n, c_int), int(n, c_int), a, b, FFTW_RODFT00, FFTW_RODFT00, &
                            FFTW_ESTIMATE)
    a = f
    call fftw_execute_r2r(plan, a, b)
    ! eigenvalue of the 1D operator on mode m (negated): k_m^2 or its 5-point form
    do i = 1, n
      if (how == POISSON_FD2) then
        lam(i) = (2 / ps%hg * sin(0.5_wp * pi * i / (n + 1)))**2
      else
        lam(i) = (pi * i / side)**2
      end if
    end do
    ! b holds Y = 4 Sum f sin sin; p = RODFT00(-Y/(lam_m + lam_k)) / (2(n+1))^2
    do j = 1, n
      do i = 1, n
        a(i, j) = -b(i, j) / (lam(i) + lam(j))
      end do
    end do
    call fftw_execute_r2r(plan, a, b)
    call fftw_destroy_plan(plan)
    allocate(ps%p(-1:n + 2, -1:n + 2))
    ps%p = 0
    ps%p(1:n, 1:n) = b / (2.0_wp * (n + 1))**2
    ! odd reflection across the edges (the edge rows 0 and n+1 stay 0)
    ps%p(-1, 1:n) = -ps%p(1, 1:n)
    ps%p(n + 2, 1:n) = -ps%p(n, 1:n)
    ps%p(:, -1) = -ps%p(:, 1)
    ps%p(:, n + 2) = -ps%p(:, n)
  end subroutine poisson_square_solve

  !> p at the point (x, y) of the closed square, by 4 x 4-point Lagrange
  !> interpolation (bicubic) on the grid.  Points outside are clamped to the
  !> nearest point of the square.
  pure function poisson_square_eval(ps, x, y) result(p)
    type(poisson_square_t), intent(in) :: ps
    real(wp), intent(in) :: x, y
    real(wp) :: p, wx(4), wy(4)
    integer :: i0, j0, j
    call stencil(ps, x, i0, wx)
    call stencil(ps, y, j0, wy)
    p = 0
    do j = 1, 4
      p = p + wy(j) * sum(wx * ps%p(i0 - 1:i0 + 2, j0 - 2 + j))
    end do
  end function poisson_square_eval

  !> The cell [i0, i0 + 1] of coordinate s and the cubic Lagrange weights of
  !> the nodes i0 - 1 .. i0 + 2.
  pure subroutine stencil(ps, s, i0, w)
    type(poisson_square_t), intent(in) :: ps
    real(wp), intent(in) :: s
    integer, intent(out) :: i0
    real(wp), intent(out) :: w(4)
    real(wp) :: q, t
    q = (s + 0.5_wp * ps%side) / ps%hg
    q = max(0.0_wp, min(real(ps%n + 1, wp), q))
    i0 = min(int(q), ps%n)
    t = q - i0
    w(1) = -t * (t - 1) * (t - 2) / 6
    w(2) = (t + 1) * (t - 1) * (t - 2) / 2
    w(3) = -(t + 1) * t * (t - 2) / 2
    w(4) = (t + 1) * t * (t - 1) / 6
  end subroutine stencil

end module poisson_square
