!> The exact ellipse / ellipsoid solution (DESIGN.md X1, X2) against the
!> tables of DESIGN.md, a 30-digit reference, its invariants, its scalings,
!> Euler's equations by finite differences, and its own step-size
!> convergence.
!>
!> The 17-digit references below come from an independent integration of
!> X1 in the original variables (a_k, alpha_k), not ln a_k, with mpmath's
!> odefun (Taylor series, 30 significant digits):
!>   f(t, y) = [alpha_k a_k, 2 Prho / a_k^2 - alpha_k^2],
!>   Prho = Sum alpha_k^2 / (2 Sum 1/a_k^2),  y(0) = [R.., alpha0..].
!> They agree with every digit of DESIGN.md's tables.
module test_exact_ellipse
  use kinds, only: wp, pi
  use exact_ellipse, only: ellipse_exact_t, ellipse_exact_init, ellipse_exact_at, &
                           ellipse_centre_pressure_rate, &
                           ellipse_centre_pressure, ellipse_pressure, ellipse_velocity, &
                           ellipse_map, ellipse_kinetic_energy
  use testing, only: run_test, assert_true, assert_equal, assert_relatively_equal
  implicit none
  private
  public :: suite_exact_ellipse

  ! 2D paper case alpha0 = (-1, 1), R = rho = 1, at t = 0.5, 1, 2.
  real(wp), parameter :: t2d(3) = [0.5_wp, 1.0_wp, 2.0_wp]
  real(wp), parameter :: ref2d_a1(3) = [0.62705250375249943_wp, 0.43946076796788585_wp, &
                                        0.27181407698137077_wp]
  real(wp), parameter :: ref2d_a2(3) = [1.5947627894245754_wp, 2.2755159797861098_wp, &
                                        3.6789853237385371_wp]
  real(wp), parameter :: ref2d_alpha2(3) = [0.82528265335591468_wp, 0.61021577360960191_wp, &
                                            0.38335826271771522_wp]
  real(wp), parameter :: ref2d_p(3) = [0.23194278703272828_wp, 0.069327210004594505_wp, &
                                       0.010799143630334359_wp]

contains

  subroutine suite_exact_ellipse()
    call run_test('exact_ellipse', 'table_2d', table_2d)
    call run_test('exact_ellipse', 'table_3d', table_3d)
    call run_test('exact_ellipse', 'initial_pressure', initial_pressure)
    call run_test('exact_ellipse', 'invariants', invariants)
    call run_test('exact_ellipse', 'kinetic_energy_by_quadrature', kinetic_energy_quadrature)
    call run_test('exact_ellipse', 'scaling_a0_r_rho', scaling)
    call run_test('exact_ellipse', 'convergence_check', convergence_check)
    call run_test('exact_ellipse', 'momentum_equation', momentum_equation)
    call run_test('exact_ellipse', 'material_free_surface', material_free_surface)
    call run_test('exact_ellipse', 'call_order_independent', call_order)
    call run_test('exact_ellipse', 'pressure_rate_against_differences', pressure_rate)
  end subroutine suite_exact_ellipse

  !> dP/dt (the prepared start I1 uses it at t = 0) against central
  !> differences of P(t) with step 1e-4/A0 (error about 1e-8 P(0) A0, the
  !> integrator's 1e-12 over 2e-4): zero at t = 0 in 2D (the rates (-1, 1)
  !> make P stationary there), -2 P(0) A0 in 3D (-1, -1, 2) at t = 0.
  subroutine pressure_rate()
    type(ellipse_exact_t) :: ex
    real(wp), parameter :: eps = 1e-4_wp
    real(wp) :: t, pp, pm, rate
    integer :: dim, k
    do dim = 2, 3
      do k = 0, 2
        if (dim == 2) call ellipse_exact_init(ex, 2, 1.0_wp, 1.0_wp, [-1.0_wp, 1.0_wp])
        if (dim == 3) call ellipse_exact_init(ex, 3, 1.0_wp, 1.0_wp, [-1.0_wp, -1.0_wp, 2.0_wp])
        t = 0.5_wp * k
        call ellipse_exact_at(ex, t)
        rate = ellipse_centre_pressure_rate(ex)
        if (k == 0) then
          ! P'(0) exact: rho (N' D - N D')/D^2 with a = R = 1: 2D N' = D' = 0;
          ! 3D N = 6, D = 6, N' = 2 Sum alpha (2P - alpha^2) = -12, D' = 0
          call assert_equal(merge(0.0_wp, -2.0_wp, dim == 2), rate, 1e-14_wp, 'P''(0)')
          cycle
        end if
        call ellipse_exact_at(ex, t + eps)
        pp = ellipse_centre_pressure(ex)
        call ellipse_exact_at(ex, t - eps)
        pm = ellipse_centre_pressure(ex)
        call assert_equal((pp - pm) / (2 * eps), rate, 1e-7_wp, 'P''(t) by differences')
      end do
    end do
  end subroutine pressure_rate

  ! DESIGN.md X1 table (6 digits): a/R and P/(rho A0^2 R^2) at t A0 = 0.5, 1, 2;
  ! then the 17-digit reference to 1e-10 relative.
  subroutine table_2d()
    type(ellipse_exact_t) :: ex
    real(wp), parameter :: tab_a(3) = [0.627053_wp, 0.439461_wp, 0.271814_wp]
    real(wp), parameter :: tab_p(3) = [0.231943_wp, 0.069327_wp, 0.010799_wp]
    integer :: i
    call ellipse_exact_init(ex, 2, 1.0_wp, 1.0_wp, [-1.0_wp, 1.0_wp])
    do i = 1, 3
      call ellipse_exact_at(ex, t2d(i))
      call assert_equal(tab_a(i), ex%a(1), 1e-6_wp, '2D a/R (table)')
      call assert_equal(tab_p(i), ellipse_centre_pressure(ex), 1e-6_wp, '2D P (table)')
      call assert_relatively_equal([ref2d_a1(i), ref2d_a2(i)], ex%a(1:2), 1e-10_wp, '2D a (ref)')
      call assert_relatively_equal([-ref2d_alpha2(i), ref2d_alpha2(i)], ex%alpha(1:2), &
                                   1e-10_wp, '2D alpha (ref)')
      call assert_relatively_equal(ref2d_p(i), ellipse_centre_pressure(ex), 1e-10_wp, &
                                   '2D P (ref)')
    end do
  end subroutine table_2d

  ! DESIGN.md X2 (5 digits) at t A0 = 1 for (-1,-1,2) and (1,1,-2), then the
  ! 17-digit reference.
  subroutine table_3d()
    type(ellipse_exact_t) :: ex
    real(wp) :: ra, rc, ral, rp
    call ellipse_exact_init(ex, 3, 1.0_wp, 1.0_wp, [-1.0_wp, -1.0_wp, 2.0_wp])
    call ellipse_exact_at(ex, 1.0_wp)
    call assert_equal([0.54708_wp, 0.54708_wp, 3.34112_wp], ex%a, 1e-5_wp, &
                      '3D (-1,-1,2) a (table)')
    call assert_equal(0.05874_wp, ellipse_centre_pressure(ex), 1e-5_wp, '3D (-1,-1,2) P (table)')
    ra = 0.54708385897963081_wp; rc = 3.3411209432525831_wp
    ral = 0.36413442233472639_wp; rp = 0.058740702892519213_wp
    call assert_relatively_equal([ra, ra, rc], ex%a, 1e-10_wp, '3D (-1,-1,2) a (ref)')
    call assert_relatively_equal([-ral, -ral, 2 * ral], ex%alpha, 1e-10_wp, &
                                 '3D (-1,-1,2) alpha (ref)')
    call assert_relatively_equal(rp, ellipse_centre_pressure(ex), 1e-10_wp, &
                                 '3D (-1,-1,2) P (ref)')

    call ellipse_exact_init(ex, 3, 1.0_wp, 1.0_wp, [1.0_wp, 1.0_wp, -2.0_wp])
    call ellipse_exact_at(ex, 1.0_wp)
    call assert_equal([2.56325_wp, 2.56325_wp, 0.15220_wp], ex%a, 1e-5_wp, &
                      '3D (1,1,-2) a (table)')
    ra = 2.5632518629299832_wp; rc = 0.15220097573453633_wp
    ral = 0.67335409023607628_wp; rp = 0.03128898296666964_wp
    call assert_relatively_equal([ra, ra, rc], ex%a, 1e-10_wp, '3D (1,1,-2) a (ref)')
    call assert_relatively_equal([ral, ral, -2 * ral], ex%alpha, 1e-10_wp, &
                                 '3D (1,1,-2) alpha (ref)')
    call assert_relatively_equal(rp, ellipse_centre_pressure(ex), 1e-10_wp, &
                                 '3D (1,1,-2) P (ref)')

    ! The fully triaxial field (-1, 1, 0).
    call ellipse_exact_init(ex, 3, 1.0_wp, 1.0_wp, [-1.0_wp, 1.0_wp, 0.0_wp])
    call ellipse_exact_at(ex, 1.0_wp)
    call assert_relatively_equal([0.36037873210903508_wp, 2.2092099655898788_wp, &
                                  1.2560411081271538_wp], ex%a, 1e-10_wp, '3D (-1,1,0) a (ref)')
    call assert_relatively_equal(0.076240839033729783_wp, ellipse_centre_pressure(ex), &
                                 1e-10_wp, '3D (-1,1,0) P (ref)')
  end subroutine table_3d

  ! P(0) = rho A0^2 R^2 / 2 (2D, A0 (-1,1)) and rho A0^2 R^2 (3D, A0 (-1,-1,2)),
  ! with values of rho, A0, R away from 1.
  subroutine initial_pressure()
    type(ellipse_exact_t) :: ex
    real(wp), parameter :: rho = 1000, a0 = 2.5_wp, r = 0.3_wp
    call ellipse_exact_init(ex, 2, rho, r, a0 * [-1.0_wp, 1.0_wp])
    call assert_relatively_equal(rho * a0**2 * r**2 / 2, ellipse_centre_pressure(ex), &
                                 1e-14_wp, '2D P(0)')
    call assert_relatively_equal(rho * a0**2 * r**2 / 2, ellipse_pressure(ex, [0.0_wp, 0.0_wp]), &
                                 1e-14_wp, '2D p(0, 0)')
    call ellipse_exact_init(ex, 3, rho, r, a0 * [-1.0_wp, -1.0_wp, 2.0_wp])
    call assert_relatively_equal(rho * a0**2 * r**2, ellipse_centre_pressure(ex), &
                                 1e-14_wp, '3D P(0)')
  end subroutine initial_pressure

  ! Prod a_k = R^dim, KE = KE(0), Sum alpha_k = 0, to 1e-10 relative; KE(0)
  ! = pi rho A0^2 R^4 / 4 (2D) and (rho/2) 6 A0^2 (4 pi R^5 / 15) (3D).
  subroutine invariants()
    type(ellipse_exact_t) :: ex
    real(wp), parameter :: rho = 2, a0 = 1.5_wp, r = 0.7_wp
    real(wp) :: ke0
    integer :: i
    call ellipse_exact_init(ex, 2, rho, r, a0 * [-1.0_wp, 1.0_wp])
    ke0 = ellipse_kinetic_energy(ex)
    call assert_relatively_equal(pi * rho * a0**2 * r**4 / 4, ke0, 1e-14_wp, '2D KE(0)')
    do i = 1, 3
      call ellipse_exact_at(ex, t2d(i) / a0)
      call assert_relatively_equal(r**2, product(ex%a(1:2)), 1e-10_wp, '2D Prod a')
      call assert_relatively_equal(ke0, ellipse_kinetic_energy(ex), 1e-10_wp, '2D KE')
      call assert_equal(0.0_wp, sum(ex%alpha(1:2)), 1e-10_wp * a0, '2D Sum alpha')
    end do
    call ellipse_exact_init(ex, 3, rho, r, a0 * [-1.0_wp, -1.0_wp, 2.0_wp])
    ke0 = ellipse_kinetic_energy(ex)
    call assert_relatively_equal(rho / 2 * 6 * a0**2 * 4 * pi * r**5 / 15, ke0, 1e-14_wp, &
                                 '3D KE(0)')
    call ellipse_exact_at(ex, 1 / a0)
    call assert_relatively_equal(r**3, product(ex%a), 1e-10_wp, '3D Prod a')
    call assert_relatively_equal(ke0, ellipse_kinetic_energy(ex), 1e-10_wp, '3D KE')
    call assert_equal(0.0_wp, sum(ex%alpha), 1e-10_wp * a0, '3D Sum alpha')
  end subroutine invariants

  ! The closed form of the kinetic energy against a quadrature of
  ! (rho/2)|u|^2 over the 2D ellipse at t A0 = 1: x = (a1 r cos th, a2 r sin th),
  ! dA = a1 a2 r dr dth.  Simpson in r is exact for the r^3 integrand and the
  ! trapezoid rule in th is exact for cos^2, so the two agree to round-off.
  subroutine kinetic_energy_quadrature()
    type(ellipse_exact_t) :: ex
    integer, parameter :: nr = 8, nth = 16
    real(wp) :: ke, w, rr, th, x(2), u(2)
    integer :: i, j
    call ellipse_exact_init(ex, 2, 1.3_wp, 0.8_wp, [-1.0_wp, 1.0_wp])
    call ellipse_exact_at(ex, 1.0_wp)
    ke = 0
    do i = 0, nr
      rr = real(i, wp) / nr
      w = merge(1.0_wp, merge(4.0_wp, 2.0_wp, mod(i, 2) == 1), i == 0 .or. i == nr) / (3 * nr)
      do j = 0, nth - 1
        th = 2 * pi * j / nth
        x = [ex%a(1) * rr * cos(th), ex%a(2) * rr * sin(th)]
        u = ellipse_velocity(ex, x)
        ke = ke + w * (2 * pi / nth) * ex%a(1) * ex%a(2) * rr * ex%rho / 2 * sum(u**2)
      end do
    end do
    call assert_relatively_equal(ke, ellipse_kinetic_energy(ex), 1e-13_wp, 'KE quadrature')
  end subroutine kinetic_energy_quadrature

  ! Time scales as 1/A0: the A0 = 2 solution at t is the A0 = 1 one at 2t,
  ! with alpha doubled and P x 4.  Lengths scale with R (a x 3, P x 9 for
  ! R = 3) and P with rho.
  subroutine scaling()
    type(ellipse_exact_t) :: e1, e2
    real(wp), parameter :: t = 0.6_wp
    call ellipse_exact_init(e1, 2, 1.0_wp, 1.0_wp, [-1.0_wp, 1.0_wp])
    call ellipse_exact_init(e2, 2, 1.0_wp, 1.0_wp, [-2.0_wp, 2.0_wp])
    call ellipse_exact_at(e1, 2 * t)
    call ellipse_exact_at(e2, t)
    call assert_relatively_equal(e1%a(1:2), e2%a(1:2), 1e-12_wp, 'A0 = 2: a')
    call assert_relatively_equal(2 * e1%alpha(1:2), e2%alpha(1:2), 1e-12_wp, 'A0 = 2: alpha')
    call assert_relatively_equal(4 * ellipse_centre_pressure(e1), ellipse_centre_pressure(e2), &
                                 1e-12_wp, 'A0 = 2: P')

    call ellipse_exact_init(e1, 3, 1.0_wp, 1.0_wp, [-1.0_wp, -1.0_wp, 2.0_wp])
    call ellipse_exact_init(e2, 3, 1.0_wp, 1.0_wp, [-2.0_wp, -2.0_wp, 4.0_wp])
    call ellipse_exact_at(e1, 2 * t)
    call ellipse_exact_at(e2, t)
    call assert_relatively_equal(e1%a, e2%a, 1e-12_wp, '3D A0 = 2: a')
    call assert_relatively_equal(4 * ellipse_centre_pressure(e1), ellipse_centre_pressure(e2), &
                                 1e-12_wp, '3D A0 = 2: P')

    call ellipse_exact_init(e1, 2, 1.0_wp, 1.0_wp, [-1.0_wp, 1.0_wp])
    call ellipse_exact_init(e2, 2, 5.0_wp, 3.0_wp, [-1.0_wp, 1.0_wp])
    call ellipse_exact_at(e1, t)
    call ellipse_exact_at(e2, t)
    call assert_relatively_equal(3 * e1%a(1:2), e2%a(1:2), 1e-12_wp, 'R = 3: a')
    call assert_relatively_equal(e1%alpha(1:2), e2%alpha(1:2), 1e-12_wp, 'R = 3: alpha')
    call assert_relatively_equal(5 * 9 * ellipse_centre_pressure(e1), &
                                 ellipse_centre_pressure(e2), 1e-12_wp, 'R = 3, rho = 5: P')
    call assert_relatively_equal(5 * 3.0_wp**4 * ellipse_kinetic_energy(e1), &
                                 ellipse_kinetic_energy(e2), 1e-12_wp, 'R = 3, rho = 5: KE')
  end subroutine scaling

  ! The default step (1000 per 1/A0) against half of it: a, alpha, P change
  ! by less than 1e-11 relative at t A0 = 2 (2D) and 1 (3D, both fields).
  ! RK4's error falls 16-fold per halving, so this bounds the default's own
  ! error by about 1e-11 too.
  subroutine convergence_check()
    call compare_steps(2, [-1.0_wp, 1.0_wp, 0.0_wp], 2.0_wp, '2D')
    call compare_steps(3, [-1.0_wp, -1.0_wp, 2.0_wp], 1.0_wp, '3D (-1,-1,2)')
    call compare_steps(3, [1.0_wp, 1.0_wp, -2.0_wp], 1.0_wp, '3D (1,1,-2)')
  end subroutine convergence_check

  subroutine compare_steps(dim, alpha0, t, label)
    integer, intent(in) :: dim
    real(wp), intent(in) :: alpha0(3), t
    character(len=*), intent(in) :: label
    type(ellipse_exact_t) :: e1, e2
    call ellipse_exact_init(e1, dim, 1.0_wp, 1.0_wp, alpha0(1:dim))
    call ellipse_exact_init(e2, dim, 1.0_wp, 1.0_wp, alpha0(1:dim), steps_per_unit=2000)
    call ellipse_exact_at(e1, t)
    call ellipse_exact_at(e2, t)
    call assert_relatively_equal(e2%a(1:dim), e1%a(1:dim), 1e-11_wp, label // ' a, h vs h/2')
    call assert_relatively_equal(e2%alpha(1:dim), e1%alpha(1:dim), 1e-11_wp, &
                                 label // ' alpha, h vs h/2')
    call assert_relatively_equal(ellipse_centre_pressure(e2), ellipse_centre_pressure(e1), &
                                 1e-11_wp, label // ' P, h vs h/2')
  end subroutine compare_steps

  ! Euler: Du_k/Dt = (alpha_k' + alpha_k^2) x_k must equal -(1/rho) d_k p.
  ! alpha' by a central difference in time (error ~ dt^2 alpha''' ~ 1e-9),
  ! grad p by a central difference in space (exact for a quadratic up to
  ! round-off ~ 1e-11), at points inside the ellipse at three times.
  subroutine momentum_equation()
    call check_momentum(2, [-1.0_wp, 1.0_wp, 0.0_wp], 1.7_wp, 0.9_wp)
    call check_momentum(3, [-1.0_wp, -1.0_wp, 2.0_wp], 1.3_wp, 1.1_wp)
    call check_momentum(3, [-1.0_wp, 1.0_wp, 0.0_wp], 0.6_wp, 2.0_wp)
  end subroutine momentum_equation

  subroutine check_momentum(dim, alpha0, rho, a0)
    integer, intent(in) :: dim
    real(wp), intent(in) :: alpha0(3), rho, a0
    real(wp), parameter :: times(3) = [0.3_wp, 1.0_wp, 1.7_wp]
    real(wp), parameter :: xi(3) = [0.31_wp, -0.42_wp, 0.27_wp]  ! inside the unit ball
    type(ellipse_exact_t) :: ex
    real(wp) :: t, dt, dx, x(dim), xp(dim), xm(dim), ap(3), am(3), dadt(3), accel(dim), &
                grad_p(dim)
    integer :: i, k
    call ellipse_exact_init(ex, dim, rho, 0.8_wp, a0 * alpha0(1:dim))
    do i = 1, 3
      t = times(i) / a0
      dt = 1e-4_wp / a0
      call ellipse_exact_at(ex, t + dt)
      ap = ex%alpha
      call ellipse_exact_at(ex, t - dt)
      am = ex%alpha
      dadt = (ap - am) / (2 * dt)
      call ellipse_exact_at(ex, t)
      x = xi(1:dim) * ex%a(1:dim)
      accel = (dadt(1:dim) + ex%alpha(1:dim)**2) * x
      do k = 1, dim
        dx = 1e-4_wp * ex%a(k)
        xp = x; xp(k) = x(k) + dx
        xm = x; xm(k) = x(k) - dx
        grad_p(k) = (ellipse_pressure(ex, xp) - ellipse_pressure(ex, xm)) / (2 * dx)
      end do
      call assert_equal(accel, -grad_p / rho, 1e-7_wp * maxval(abs(accel)), &
                        'Du/Dt = -grad p / rho')
    end do
  end subroutine check_momentum

  ! The map x0 -> x0 a(t)/R moves with the velocity (central difference in
  ! time) and carries the initial circle onto p = 0; inside p > 0, and the
  ! pressure is clipped to 0 outside.
  subroutine material_free_surface()
    type(ellipse_exact_t) :: ex
    real(wp), parameter :: r = 0.5_wp, t = 0.8_wp, dt = 1e-4_wp
    real(wp) :: x0(3), xp(3), xm(3), th, ph, p0
    integer :: j
    call ellipse_exact_init(ex, 3, 1.0_wp, r, [-1.0_wp, -1.0_wp, 2.0_wp])
    x0 = [0.1_wp, 0.2_wp, -0.15_wp]
    call ellipse_exact_at(ex, t + dt)
    xp = ellipse_map(ex, x0)
    call ellipse_exact_at(ex, t - dt)
    xm = ellipse_map(ex, x0)
    call ellipse_exact_at(ex, t)
    call assert_equal(ellipse_velocity(ex, ellipse_map(ex, x0)), (xp - xm) / (2 * dt), 1e-8_wp, &
                      'd(map)/dt = u(map)')
    p0 = ellipse_centre_pressure(ex)
    do j = 0, 6
      th = 0.45_wp * j
      ph = 0.9_wp * j + 0.1_wp
      x0 = r * [sin(th) * cos(ph), sin(th) * sin(ph), cos(th)]
      call assert_equal(0.0_wp, ellipse_pressure(ex, 0.999999_wp * ellipse_map(ex, x0)), &
                        1e-5_wp * p0, 'p = 0 on the mapped sphere')
      call assert_true(ellipse_pressure(ex, 0.99_wp * ellipse_map(ex, x0)) > 0, 'p > 0 inside')
      call assert_equal(0.0_wp, ellipse_pressure(ex, 1.01_wp * ellipse_map(ex, x0)), 0.0_wp, &
                        'p = 0 outside')
    end do
  end subroutine material_free_surface

  ! Calls in any order give bitwise the results of fresh objects (the RK4
  ! grid is fixed in time and a result depends on t only).
  subroutine call_order()
    real(wp), parameter :: times(8) = [1.0_wp, 0.3_wp, 2.0_wp, 0.5_wp, 0.5_wp, 1.7_wp, &
                                       0.0_wp, 1.2345_wp]
    type(ellipse_exact_t) :: ex, fresh
    integer :: i
    call ellipse_exact_init(ex, 3, 1.0_wp, 1.0_wp, [-1.0_wp, -1.0_wp, 2.0_wp])
    do i = 1, size(times)
      call ellipse_exact_at(ex, times(i))
      call ellipse_exact_init(fresh, 3, 1.0_wp, 1.0_wp, [-1.0_wp, -1.0_wp, 2.0_wp])
      call ellipse_exact_at(fresh, times(i))
      call assert_equal(fresh%a, ex%a, 0.0_wp, 'a, any call order')
      call assert_equal(fresh%alpha, ex%alpha, 0.0_wp, 'alpha, any call order')
      call assert_equal(times(i), ex%t, 0.0_wp, 'current time')
    end do
  end subroutine call_order

end module test_exact_ellipse
