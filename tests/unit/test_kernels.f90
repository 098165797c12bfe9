!> Kernels against analytic integrals: on a fine lattice, sum_j W V_j = 1 and
!> sum_j V_j grad_i W_ij (x_j - x_i)^T = I (the moments that make SPH exact
!> for constants and linear fields), and F = W'/r against a finite difference.
module test_kernels
  use kinds, only: wp
  use kernels, only: kernel_t, kernel_init, kernel_w, kernel_f, kernel_w_list, kernel_f_list, &
                     KERNEL_WENDLAND_C2, KERNEL_CUBIC_SPLINE, KERNEL_GAUSSIAN
  use testing, only: run_test, assert_equal, assert_true
  implicit none
  private
  public :: suite_kernels

contains

  subroutine suite_kernels()
    call run_test('kernels', 'moments_2d', moments_2d)
    call run_test('kernels', 'moments_3d', moments_3d)
    call run_test('kernels', 'gradient_factor_matches_derivative', gradient_factor)
    call run_test('kernels', 'compact_support', compact_support)
    call run_test('kernels', 'list_forms_match_pointwise', list_forms)
  end subroutine suite_kernels

  !> Lattice sums over spacing dx = h/m around the origin: sum W dV, the
  !> first moment sum F x dV, and the second moment -sum F x x^T dV.
  subroutine lattice_moments(k, m, w0, g1, m2)
    type(kernel_t), intent(in) :: k
    integer, intent(in) :: m
    real(wp), intent(out) :: w0, g1(3), m2(3, 3)
    real(wp) :: dx, dv, x(3), r, f
    integer :: i, j, l, n, lz
    dx = k%h / m
    dv = dx**k%dim
    n = ceiling(k%support / dx) + 1
    lz = merge(n, 0, k%dim == 3)
    w0 = 0; g1 = 0; m2 = 0
    do l = -lz, lz
      do j = -n, n
        do i = -n, n
          ! offset by half a cell so that no point sits on the origin
          x = [(i + 0.5_wp) * dx, (j + 0.5_wp) * dx, merge((l + 0.5_wp) * dx, 0.0_wp, k%dim == 3)]
          r = norm2(x)
          f = kernel_f(k, r)
          w0 = w0 + kernel_w(k, r) * dv
          g1 = g1 + f * x * dv
          m2 = m2 - f * spread(x, 2, 3) * spread(x, 1, 3) * dv
        end do
      end do
    end do
  end subroutine lattice_moments

  subroutine check_kernel(kind, dim, m, tol, label)
    integer, intent(in) :: kind, dim, m
    real(wp), intent(in) :: tol
    character(len=*), intent(in) :: label
    type(kernel_t) :: k
    real(wp) :: w0, g1(3), m2(3, 3), ident(3, 3)
    integer :: a
    k = kernel_init(kind, dim, 0.37_wp)
    call lattice_moments(k, m, w0, g1, m2)
    ident = 0
    do a = 1, dim
      ident(a, a) = 1
    end do
    call assert_equal(1.0_wp, w0, tol, label // ' sum W V')
    call assert_equal([0.0_wp, 0.0_wp, 0.0_wp], g1, tol / k%h, label // ' sum grad W V')
    call assert_equal(reshape(ident, [9]), reshape(m2, [9]), tol, label // ' second moment')
  end subroutine check_kernel

  ! Lattice sums of smooth compact functions converge fast: at h/dx = 8 (2D)
  ! and 6 (3D) Wendland C2 matches the integrals to 1.2e-6 (2D).  The
  ! cubic spline (W''' jumps) and the truncated Gaussian (F jumps by 2e-4 of
  ! its peak at 3h) converge at a lower order: measured 1.6e-5 and 3e-5 at
  ! these spacings, so they get 1e-4, still far below any wrong constant.
  subroutine moments_2d()
    call check_kernel(KERNEL_WENDLAND_C2, 2, 8, 1e-5_wp, 'wendland 2d')
    call check_kernel(KERNEL_CUBIC_SPLINE, 2, 8, 1e-4_wp, 'cubic 2d')
    call check_kernel(KERNEL_GAUSSIAN, 2, 8, 1e-4_wp, 'gaussian 2d')
  end subroutine moments_2d

  subroutine moments_3d()
    call check_kernel(KERNEL_WENDLAND_C2, 3, 6, 1e-5_wp, 'wendland 3d')
    call check_kernel(KERNEL_CUBIC_SPLINE, 3, 6, 1e-4_wp, 'cubic 3d')
    call check_kernel(KERNEL_GAUSSIAN, 3, 6, 1e-4_wp, 'gaussian 3d')
  end subroutine moments_3d

  subroutine gradient_factor()
    integer :: kind, dim, i
    type(kernel_t) :: k
    real(wp) :: r, d, fd
    do dim = 2, 3
      do kind = 1, 3
        k = kernel_init(kind, dim, 0.5_wp)
        do i = 1, 29
          r = 0.034_wp * i
          if (r >= k%support) exit
          d = 1e-6_wp
          fd = (kernel_w(k, r + d) - kernel_w(k, r - d)) / (2 * d)
          call assert_equal(fd / r, kernel_f(k, r), 1e-6_wp * k%norm / k%h**2, 'F = W''/r')
        end do
      end do
    end do
  end subroutine gradient_factor

  subroutine compact_support()
    integer :: kind, dim
    type(kernel_t) :: k
    do dim = 2, 3
      do kind = 1, 3
        k = kernel_init(kind, dim, 0.5_wp)
        call assert_true(abs(kernel_w(k, k%support * (1 + 1e-12_wp))) < tiny(1.0_wp) .and. &
                         abs(kernel_f(k, k%support * (1 + 1e-12_wp))) < tiny(1.0_wp), &
                         'zero outside the support')
        call assert_true(abs(kernel_w(k, k%support * (1 - 1e-9_wp))) < 1e-10_wp * k%norm, &
                         'continuous to zero at the support radius')
      end do
    end do
  end subroutine compact_support

  !> kernel_w_list and kernel_f_list (the vectorised forms used in the pair
  !> loops) give kernel_w and kernel_f to round-off inside the support, for
  !> every kernel and dimension.
  subroutine list_forms()
    integer, parameter :: n = 200
    integer :: kinds(3), kind, dim, l, q
    type(kernel_t) :: k
    real(wp) :: r2(n), w(n), f(n)
    kinds = [KERNEL_WENDLAND_C2, KERNEL_CUBIC_SPLINE, KERNEL_GAUSSIAN]
    do dim = 2, 3
      do l = 1, 3
        kind = kinds(l)
        k = kernel_init(kind, dim, 0.7_wp)
        r2 = [((k%support * (q - 0.5_wp) / n)**2, q = 1, n)]
        call kernel_w_list(k, n, r2, w)
        call kernel_f_list(k, n, r2, f)
        call assert_equal(kernel_w(k, sqrt(r2)), w, 1e-13_wp * kernel_w(k, 0.0_wp), &
                          'kernel_w_list against kernel_w')
        call assert_equal(kernel_f(k, sqrt(r2)), f, 1e-13_wp * abs(kernel_f(k, 1e-3_wp)), &
                          'kernel_f_list against kernel_f')
      end do
    end do
  end subroutine list_forms

end module test_kernels
