!> Exact incompressible solution of the free-surface ellipse (2D) and
!> ellipsoid (3D), doc/theory/ X1, X2; prototype problem 1 of the
!> paper.  The dimension is data: the same code serves dim = 2 and 3.
!>
!> (X1)  u_k = alpha_k(t) x_k,  Sum_k alpha_k = 0,
!>       p = P(t) (1 - Sum_k x_k^2 / a_k^2),
!>       a_k' = alpha_k a_k,  alpha_k' = 2 P / (rho a_k^2) - alpha_k^2,
!>       P / rho = Sum_k alpha_k^2 / (2 Sum_k 1 / a_k^2),
!>       a_k(0) = R,  alpha_k(0) given (paper 2D: A0 (-1, 1); X2 3D: A0 (-1, -1, 2)).
!>
!> What was verified before coding (and is tested in test_exact_ellipse):
!> - Momentum.  For u_k = alpha_k x_k (no sum), Du_k/Dt = d(alpha_k x_k)/dt
!>   + u_j d_j(alpha_k x_k) = (alpha_k' + alpha_k^2) x_k.  With the pressure
!>   above, -(1/rho) d_k p = 2 P x_k / (rho a_k^2).  Both are linear in x_k
!>   with one coefficient each, so Euler holds everywhere iff
!>   alpha_k' + alpha_k^2 = 2 P / (rho a_k^2): the alpha_k' equation.  The
!>   flow is irrotational and the pressure is a global quadratic, so no
!>   further compatibility condition arises.
!> - Incompressibility fixes P.  div u = Sum_k alpha_k must stay 0, so
!>   0 = Sum_k alpha_k' = (2 P/rho) Sum_k 1/a_k^2 - Sum_k alpha_k^2, i.e.
!>   P / rho = Sum_k alpha_k^2 / (2 Sum_k 1/a_k^2), the formula above.
!>   Then P(0) = rho A0^2 R^2 / 2 in 2D (-1, 1) and rho A0^2 R^2 in 3D (-1, -1, 2).
!> - Free surface.  The particle initially at x0 moves to x_k = x0_k a_k(t)/R:
!>   dx_k/dt = x0_k a_k'/R = alpha_k x_k = u_k.  So the ellipse
!>   Sum x_k^2/a_k^2 = 1 is material and p = 0 on it, as a free surface needs.
!> - Invariants.  d/dt ln(Prod a_k) = Sum alpha_k = 0, so Prod a_k = R^dim.
!>   Int_E x_k^2 dV = V a_k^2 / (dim + 2) over the ellipse E of volume V
!>   (V = pi a1 a2 in 2D, 4/3 pi a1 a2 a3 in 3D; checked on the disc: pi R^4/4,
!>   and the ball: 4 pi R^5/15), so the kinetic energy is
!>   KE = rho V / (2 (dim + 2)) Sum_k alpha_k^2 a_k^2, and
!>   d/dt Sum alpha_k^2 a_k^2 = 2 Sum alpha_k a_k^2 (alpha_k' + alpha_k^2)
!>   = (4 P/rho) Sum alpha_k = 0: KE is constant (pressure does no work at a
!>   p = 0 surface of an incompressible fluid).  Paper case: pi rho A0^2 R^4/4.
!>
!> Integration: classical RK4 on (s_k = ln(a_k/R), alpha_k), with
!> s_k' = alpha_k.  In these variables both Sum s_k (Prod a_k = R^dim) and
!> Sum alpha_k are linear invariants, which RK4 keeps to round-off.  Steps
!> lie on a fixed grid t_n = n h, h = 1 / (steps_per_unit max_k |alpha_k(0)|);
!> the state at the last grid point is cached and the remainder up to t is
!> one partial step.  A result therefore depends on t only (bitwise), not on
!> the order of the calls; a time before the cached grid point restarts
!> from t = 0.  Default 1000 steps per 1/A0: halving h changes a_k, alpha_k
!> and P by less than 1e-12 up to t A0 = 2 (unit test convergence_check), and
!> the results match a 30-digit Taylor-series integration (mpmath odefun)
!> to better than 1e-12 relative.
module exact_ellipse
  use kinds, only: wp, i8, pi
  implicit none
  private
  public :: ellipse_exact_t, ellipse_exact_init, ellipse_exact_at
  public :: ellipse_centre_pressure, ellipse_pressure, ellipse_velocity
  public :: ellipse_map, ellipse_kinetic_energy, ellipse_volume, ellipse_centre_pressure_rate

  !> Default number of RK4 steps per time unit 1/max|alpha_k(0)|.
  integer, parameter :: default_steps_per_unit = 1000

  !> The exact solution at the current time t.  Read a, alpha, t freely;
  !> the components after them are the integrator's cache.
  type :: ellipse_exact_t
    integer :: dim = 2                !< 2 or 3
    real(wp) :: rho = 1               !< density
    real(wp) :: radius = 1            !< R, initial radius of the circle / sphere
    real(wp) :: t = 0                 !< time of the current state
    real(wp) :: a(3) = 1              !< semi-axes a_k(t) (a(3) = R in 2D)
    real(wp) :: alpha(3) = 0          !< strain rates alpha_k(t) (alpha(3) = 0 in 2D)
    real(wp) :: alpha0(3) = 0         !< alpha_k(0)
    real(wp) :: h = 1                 !< RK4 step on the grid t_n = n h
    integer(i8) :: n_grid = 0         !< cached state is at t = n_grid h
    real(wp) :: s_grid(3) = 0         !< ln(a_k/R) at the grid point
    real(wp) :: alpha_grid(3) = 0     !< alpha_k at the grid point
  end type ellipse_exact_t

contains

  !> Sets up the solution at t = 0: a_k = radius, alpha_k = alpha0(k)
  !> (absolute units, A0 included; Sum alpha0 must be 0).  steps_per_unit
  !> (default 1000) is the RK4 resolution per 1/max|alpha0|.
  subroutine ellipse_exact_init(ex, dim, rho, radius, alpha0, steps_per_unit)
    type(ellipse_exact_t), intent(out) :: ex
    integer, intent(in) :: dim
    real(wp), intent(in) :: rho, radius, alpha0(:)
    integer, intent(in), optional :: steps_per_unit
    integer :: nsteps
    real(wp) :: rate
    if (dim /= 2 .and. dim /= 3) error stop 'ellipse_exact_init: dim must be 2 or 3'
    if (size(alpha0) < dim) error stop 'ellipse_exact_init: alpha0 needs dim entries'
    if (.not. (rho > 0 .and. radius > 0)) &
      error stop 'ellipse_exact_init: rho and radius must be positive'
    rate = maxval(abs(alpha0(1:dim)))
    if (abs(sum(alpha0(1:dim))) > 1e-12_wp * rate) &
      error stop 'ellipse_exact_init: Sum_k alpha0(k) must be 0 (incompressible)'
    nsteps = default_steps_per_unit
    if (present(steps_per_unit)) nsteps = steps_per_unit
    if (nsteps < 1) error stop 'ellipse_exact_init: steps_per_unit must be >= 1'
    ex%dim = dim
    ex%rho = rho
    ex%radius = radius
    ex%alpha0 = 0
    ex%alpha0(1:dim) = alpha0(1:dim)
    ! alpha0 = 0 is the fluid at rest: any step integrates it exactly.
    ex%h = 1
    if (rate > 0) ex%h = 1 / (nsteps * rate)
    call restart(ex)
  end subroutine ellipse_exact_init

  !> Advances (or, for an earlier time, recomputes from t = 0) the state to
  !> time t >= 0.
  subroutine ellipse_exact_at(ex, t)
    type(ellipse_exact_t), intent(inout) :: ex
    real(wp), intent(in) :: t
    integer(i8) :: n_target
    real(wp) :: s(3), alpha(3)
    if (.not. (t >= 0)) error stop 'ellipse_exact_at: t must be >= 0'
    n_target = int(t / ex%h, i8)
    if (n_target < ex%n_grid) call restart(ex)
    do while (ex%n_grid < n_target)
      call rk4_step(ex%dim, ex%h, ex%s_grid, ex%alpha_grid)
      ex%n_grid = ex%n_grid + 1
    end do
    ! Partial step from the grid point to t (possibly of length 0).
    s = ex%s_grid
    alpha = ex%alpha_grid
    call rk4_step(ex%dim, t - real(ex%n_grid, wp) * ex%h, s, alpha)
    ex%t = t
    ex%a = ex%radius
    ex%a(1:ex%dim) = ex%radius * exp(s(1:ex%dim))
    ex%alpha = 0
    ex%alpha(1:ex%dim) = alpha(1:ex%dim)
  end subroutine ellipse_exact_at

  !> P(t), the pressure at the centre: P = rho Sum alpha_k^2 / (2 Sum 1/a_k^2) (X1).
  pure function ellipse_centre_pressure(ex) result(p)
    type(ellipse_exact_t), intent(in) :: ex
    real(wp) :: p
    integer :: d
    d = ex%dim
    p = ex%rho * sum(ex%alpha(1:d)**2) / (2 * sum(1 / ex%a(1:d)**2))
  end function ellipse_centre_pressure

  !> dP/dt from P = rho N/D, N = Sum alpha_k^2, D = 2 Sum 1/a_k^2:
  !> N' = 2 Sum alpha_k alpha_k' with alpha_k' = 2P/(rho a_k^2) - alpha_k^2,
  !> D' = -4 Sum alpha_k/a_k^2 (a_k' = alpha_k a_k), P' = rho (N' D - N D')/D^2.
  pure function ellipse_centre_pressure_rate(ex) result(dp)
    type(ellipse_exact_t), intent(in) :: ex
    real(wp) :: dp, p, n, d, dn, dd
    integer :: k
    k = ex%dim
    p = ellipse_centre_pressure(ex)
    n = sum(ex%alpha(1:k)**2)
    d = 2 * sum(1 / ex%a(1:k)**2)
    dn = 2 * sum(ex%alpha(1:k) * (2 * p / (ex%rho * ex%a(1:k)**2) - ex%alpha(1:k)**2))
    dd = -4 * sum(ex%alpha(1:k) / ex%a(1:k)**2)
    dp = ex%rho * (dn * d - n * dd) / d**2
  end function ellipse_centre_pressure_rate

  !> p(x, t) = P (1 - Sum_k x_k^2/a_k^2) inside the ellipse; 0 outside it
  !> (there is no fluid there: the formula would give a negative value).
  !> x has dim or 3 entries; only the first dim are used.
  pure function ellipse_pressure(ex, x) result(p)
    type(ellipse_exact_t), intent(in) :: ex
    real(wp), intent(in) :: x(:)
    real(wp) :: p
    integer :: d
    d = ex%dim
    p = ellipse_centre_pressure(ex) * max(0.0_wp, 1 - sum((x(1:d) / ex%a(1:d))**2))
  end function ellipse_pressure

  !> u_k = alpha_k x_k (X1); x has dim or 3 entries (u(3) = 0 in 2D).
  pure function ellipse_velocity(ex, x) result(u)
    type(ellipse_exact_t), intent(in) :: ex
    real(wp), intent(in) :: x(:)
    real(wp) :: u(size(x))
    u = ex%alpha(1:size(x)) * x
  end function ellipse_velocity

  !> Exact position at t of the particle that was at x0 at t = 0:
  !> x_k = x0_k a_k(t) / R (x(3) = x0(3) in 2D).
  pure function ellipse_map(ex, x0) result(x)
    type(ellipse_exact_t), intent(in) :: ex
    real(wp), intent(in) :: x0(:)
    real(wp) :: x(size(x0))
    x = x0 * (ex%a(1:size(x0)) / ex%radius)
  end function ellipse_map

  !> Area (2D) or volume (3D) of the ellipse: pi a1 a2, 4/3 pi a1 a2 a3.
  pure function ellipse_volume(ex) result(v)
    type(ellipse_exact_t), intent(in) :: ex
    real(wp) :: v
    if (ex%dim == 2) then
      v = pi * ex%a(1) * ex%a(2)
    else
      v = 4 * pi * ex%a(1) * ex%a(2) * ex%a(3) / 3
    end if
  end function ellipse_volume

  !> Kinetic energy of the continuum, (rho/2) Sum_k alpha_k^2 Int_E x_k^2 dV
  !> = rho V Sum_k alpha_k^2 a_k^2 / (2 (dim + 2)); an invariant of X1
  !> (pi rho A0^2 R^4 / 4 in the paper's 2D case).
  pure function ellipse_kinetic_energy(ex) result(ke)
    type(ellipse_exact_t), intent(in) :: ex
    real(wp) :: ke
    integer :: d
    d = ex%dim
    ke = ex%rho * ellipse_volume(ex) * sum(ex%alpha(1:d)**2 * ex%a(1:d)**2) / (2 * (d + 2))
  end function ellipse_kinetic_energy

  !> Back to t = 0.
  subroutine restart(ex)
    type(ellipse_exact_t), intent(inout) :: ex
    ex%n_grid = 0
    ex%s_grid = 0
    ex%alpha_grid = ex%alpha0
    ex%t = 0
    ex%a = ex%radius
    ex%alpha = ex%alpha0
  end subroutine restart

  !> Right-hand side of X1 in s_k = ln(a_k/R): s_k' = alpha_k,
  !> alpha_k' = 2 (P/rho) / a_k^2 - alpha_k^2 with a_k = R e^(s_k).  Only the
  !> ratio a_k^2 / (Sum 1/a_j^2) enters, so R drops out.
  pure subroutine rhs(d, s, alpha, ds, dalpha)
    integer, intent(in) :: d
    real(wp), intent(in) :: s(3), alpha(3)
    real(wp), intent(out) :: ds(3), dalpha(3)
    real(wp) :: inv_a2(3), p_rho
    inv_a2 = 0
    inv_a2(1:d) = exp(-2 * s(1:d))
    p_rho = sum(alpha(1:d)**2) / (2 * sum(inv_a2(1:d)))
    ds = 0
    dalpha = 0
    ds(1:d) = alpha(1:d)
    dalpha(1:d) = 2 * p_rho * inv_a2(1:d) - alpha(1:d)**2
  end subroutine rhs

  !> One classical RK4 step (T1) of length dt.
  pure subroutine rk4_step(d, dt, s, alpha)
    integer, intent(in) :: d
    real(wp), intent(in) :: dt
    real(wp), intent(inout) :: s(3), alpha(3)
    real(wp) :: k1s(3), k2s(3), k3s(3), k4s(3), k1a(3), k2a(3), k3a(3), k4a(3)
    call rhs(d, s, alpha, k1s, k1a)
    call rhs(d, s + dt / 2 * k1s, alpha + dt / 2 * k1a, k2s, k2a)
    call rhs(d, s + dt / 2 * k2s, alpha + dt / 2 * k2a, k3s, k3a)
    call rhs(d, s + dt * k3s, alpha + dt * k3a, k4s, k4a)
    s = s + dt / 6 * (k1s + 2 * k2s + 2 * k3s + k4s)
    alpha = alpha + dt / 6 * (k1a + 2 * k2a + 2 * k3a + k4a)
  end subroutine rk4_step

end module exact_ellipse
