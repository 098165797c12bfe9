!> The Dirichlet Poisson solver on the square (DESIGN.md X3-X5) against
!> references computed here without it:
!>  - rotating square, Laplacian p = 2 rho omega^2 (X3): the double series
!>    of DESIGN.md summed over n in closed form, an exponentially convergent
!>    single series (L = rho = omega = 1, x* = x + 1/2):
!>      p = x*(x* - 1) + Sum_{m odd} 8/(m pi)^3 sin(m pi x*) cosh(m pi y)/cosh(m pi/2)
!>    (from p = x*(x* - 1) plus the harmonic function that cancels it on
!>    y = +-1/2); the test also checks it against the double series itself;
!>  - vortical patch, Laplacian p = 2 rho (32 V0/L^2)^2 x y f(x) f(y) (X4,
!>    corrected): DESIGN.md's values, and a reference computed with numpy:
!>    sine coefficients of 32 s f(s) by Simpson's rule on 20,000 intervals,
!>    1600 x 1600 modes, p(0.25, 0.25) = -0.22945174776874602 (it changes
!>    by 4e-10 from 800 to 1600 modes).
!> Convergence: the right-hand sides do not vanish on the edges, so the
!> error falls as hg^2 (module header); the tests check the rate.
module test_poisson_square
  use kinds, only: wp, pi
  use poisson_square, only: poisson_square_t, poisson_square_nodes, poisson_square_solve, &
                            poisson_square_eval, POISSON_SPECTRAL, POISSON_FD2
  use testing, only: run_test, assert_true, assert_equal, assert_relatively_equal
  implicit none
  private
  public :: suite_poisson_square

  real(wp), parameter :: VORT_REF = -0.22945174776874602_wp   !< p0(1/4, 1/4), numpy series
  !> Probe points: A, the two tabulated points of X3, and an off-grid point.
  real(wp), parameter :: PTS(2, 4) = reshape([0.0_wp, 0.0_wp, 0.25_wp, 0.0_wp, &
                                              0.25_wp, 0.25_wp, 0.1234_wp, -0.3071_wp], [2, 4])

contains

  subroutine suite_poisson_square()
    call run_test('poisson_square', 'series_closed_form_matches_double_series', series_forms)
    call run_test('poisson_square', 'rotating_square_against_series_second_order', rotation)
    call run_test('poisson_square', 'rotating_square_tabulated_values_and_scaling', rotation_table)
    call run_test('poisson_square', 'fd2_operator_second_order', fd2_rate)
    call run_test('poisson_square', 'vortical_values_symmetry_convergence', vortical)
  end subroutine suite_poisson_square

  !> X3's closed-form single series at (x, y), L = rho = omega = 1.
  pure function rotation_series(x, y) result(p)
    real(wp), intent(in) :: x, y
    real(wp) :: p, xs, k
    integer :: m
    xs = x + 0.5_wp
    p = xs * (xs - 1)
    do m = 1, 199, 2   ! terms fall as exp(-m pi (1/2 - |y|)): 1e-40 at |y| = 1/4
      k = m * pi
      p = p + 8 / k**3 * sin(k * xs) * cosh(k * y) / cosh(0.5_wp * k)
    end do
  end function rotation_series

  !> The solution of the rotating square on n + 1 intervals (rho omega^2 L^2 = 1,
  !> side `side`, Laplacian p = 2 omega^2 rho).
  subroutine solve_rotation(n, method, ps, side, omega)
    integer, intent(in) :: n, method
    type(poisson_square_t), intent(out) :: ps
    real(wp), intent(in), optional :: side, omega
    real(wp), allocatable :: f(:, :)
    real(wp) :: l, w
    l = 1
    w = 1
    if (present(side)) l = side
    if (present(omega)) w = omega
    allocate(f(n, n))
    f = 2 * w**2
    call poisson_square_solve(l, f, ps, method)
  end subroutine solve_rotation

  !> Largest error at the probe points against the single series.
  function rotation_error(ps) result(e)
    type(poisson_square_t), intent(in) :: ps
    real(wp) :: e
    integer :: k
    e = 0
    do k = 1, size(PTS, 2)
      e = max(e, abs(poisson_square_eval(ps, PTS(1, k), PTS(2, k)) - &
                     rotation_series(PTS(1, k), PTS(2, k))))
    end do
  end function rotation_error

  ! The closed form is the X3 double series: summed over m, n odd up to
  ! 2001 the double series agrees to 1e-10 (its tail is about 1e-11 here).
  subroutine series_forms()
    integer, parameter :: m_max = 2001
    real(wp) :: sx(m_max), sy(m_max), p, k2
    integer :: m, n, k
    do k = 1, 3
      do m = 1, m_max, 2
        sx(m) = sin(m * pi * (PTS(1, k) + 0.5_wp))
        sy(m) = sin(m * pi * (PTS(2, k) + 0.5_wp))
      end do
      p = 0
      do n = 1, m_max, 2
        do m = 1, m_max, 2
          k2 = (m * pi)**2 + (n * pi)**2
          p = p - 32 / (m * n * pi**2 * k2) * sx(m) * sy(n)
        end do
      end do
      call assert_equal(rotation_series(PTS(1, k), PTS(2, k)), p, 1e-10_wp, &
                        'X3 double series against its closed form')
    end do
  end subroutine series_forms

  ! Spectral inversion on 128 .. 1024 intervals: the error falls by 4 per
  ! halving of the grid (measured 4.00: 1.02e-5, 2.54e-6, 6.36e-7, 1.59e-7),
  ! accepted orders 1.9 .. 2.1; 2.5e-7 at 1024 (measured 1.59e-7).
  subroutine rotation()
    real(wp) :: e(4)
    call rotation_rates(POISSON_SPECTRAL, e, 'second-order convergence')
    call assert_true(e(4) < 2.5e-7_wp, 'error at 1024 intervals')
  end subroutine rotation

  !> The errors of X3 on 128, 256, ... intervals (as many as size(e)) with
  !> the given method, each halving of the grid asserted to be second order
  !> (observed order in 1.9 .. 2.1).
  subroutine rotation_rates(method, e, msg)
    integer, intent(in) :: method
    real(wp), intent(out) :: e(:)
    character(len=*), intent(in) :: msg
    type(poisson_square_t) :: ps
    real(wp) :: order
    integer :: k
    do k = 1, size(e)
      call solve_rotation(2**(k + 6) - 1, method, ps)
      e(k) = rotation_error(ps)
    end do
    do k = 1, size(e) - 1
      order = log(e(k) / e(k + 1)) / log(2.0_wp)
      call assert_true(order > 1.9_wp .and. order < 2.1_wp, msg)
    end do
  end subroutine rotation_rates

  ! DESIGN.md X3 (6 digits): p_A = -0.147343, p(L/4, 0) = -0.114670,
  ! p(L/4, L/4) = -0.090572 rho omega^2 L^2; 4-fold symmetry; p scales as
  ! rho omega^2 L^2 (L = 2, omega = 3).
  subroutine rotation_table()
    type(poisson_square_t) :: ps
    real(wp), parameter :: tab(3) = [-0.147343_wp, -0.114670_wp, -0.090572_wp]
    integer :: k
    call solve_rotation(1023, POISSON_SPECTRAL, ps)
    do k = 1, 3
      call assert_equal(tab(k), poisson_square_eval(ps, PTS(1, k), PTS(2, k)), 1e-6_wp, &
                        'X3 tabulated value')
    end do
    call assert_equal(poisson_square_eval(ps, 0.1234_wp, -0.3071_wp), &
                      poisson_square_eval(ps, 0.3071_wp, 0.1234_wp), 1e-12_wp, &
                      'rotation by 90 degrees')
    call assert_equal(0.0_wp, poisson_square_eval(ps, 0.5_wp, 0.2_wp), 1e-15_wp, 'p = 0 on the edge')
    call solve_rotation(1023, POISSON_SPECTRAL, ps, side=2.0_wp, omega=3.0_wp)
    call assert_relatively_equal(-0.147343_wp * 9 * 4, poisson_square_eval(ps, 0.0_wp, 0.0_wp), &
                                 1e-5_wp, 'scaling with omega^2 L^2')
  end subroutine rotation_table

  ! The 5-point operator is second order too (measured errors 7.09e-6,
  ! 1.77e-6, 4.43e-7 at 128, 256, 512 intervals).
  subroutine fd2_rate()
    real(wp) :: e(3)
    call rotation_rates(POISSON_FD2, e, 'FD2 second order')
  end subroutine fd2_rate

  ! X4 with the corrected right-hand side: p0(L/4, L/4) = -0.229452,
  ! p0(L/4, -L/4) = +0.229452 (DESIGN.md, 6 digits), odd in x and in y, and
  ! second-order convergence to the numpy reference (measured errors 3.6e-6,
  ! 9.0e-7, 2.2e-7, 5.4e-8 at 128 .. 1024 intervals; the 5-point operator
  ! gives 6.1e-7 at 1024, so the spectral inversion is 10x better here).
  subroutine vortical()
    type(poisson_square_t) :: ps, ps_fd
    real(wp) :: e(4), order, x, y
    integer :: k
    do k = 1, 4
      call solve_vortical(2**(k + 6) - 1, POISSON_SPECTRAL, ps)
      e(k) = abs(poisson_square_eval(ps, 0.25_wp, 0.25_wp) - VORT_REF)
    end do
    do k = 1, 3
      order = log(e(k) / e(k + 1)) / log(2.0_wp)
      call assert_true(order > 1.8_wp .and. order < 2.2_wp, 'vortical: second order')
    end do
    call assert_true(e(4) < 1e-7_wp, 'vortical: error at 1024 intervals')
    call assert_equal(-0.229452_wp, poisson_square_eval(ps, 0.25_wp, 0.25_wp), 1e-6_wp, &
                      'X4 p0(L/4, L/4)')
    call assert_equal(0.229452_wp, poisson_square_eval(ps, 0.25_wp, -0.25_wp), 1e-6_wp, &
                      'X4 p0(L/4, -L/4)')
    do k = 1, 5
      x = 0.09_wp * k - 0.013_wp
      y = 0.41_wp - 0.07_wp * k
      call assert_equal(-poisson_square_eval(ps, x, y), poisson_square_eval(ps, -x, y), &
                        1e-12_wp, 'odd in x')
      call assert_equal(-poisson_square_eval(ps, x, y), poisson_square_eval(ps, x, -y), &
                        1e-12_wp, 'odd in y')
    end do
    call solve_vortical(1023, POISSON_FD2, ps_fd)
    call assert_true(abs(poisson_square_eval(ps_fd, 0.25_wp, 0.25_wp) - VORT_REF) > 5 * e(4), &
                     'spectral inversion beats the 5-point operator on a smooth f')
  end subroutine vortical

  subroutine solve_vortical(n, method, ps)
    integer, intent(in) :: n, method
    type(poisson_square_t), intent(out) :: ps
    real(wp), allocatable :: f(:, :), xn(:), g(:)
    integer :: i, j
    allocate(f(n, n), xn(n), g(n))
    xn = poisson_square_nodes(1.0_wp, n)
    g = 32 * xn * exp(-(4 * xn)**2)   ! -f'(x) with L = V0 = 1
    do j = 1, n
      do i = 1, n
        f(i, j) = 2 * g(i) * g(j)
      end do
    end do
    call poisson_square_solve(1.0_wp, f, ps, method)
  end subroutine solve_vortical

end module test_poisson_square
