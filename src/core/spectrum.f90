!> The dominant frequency of a sampled signal (doc/theory/ X6): the acoustic
!> oscillation of a probe pressure around its slow incompressible value.
!>
!> The samples (t_k, y_k), not necessarily evenly spaced, are resampled
!> linearly onto an even grid of at least as many points, the slow part is
!> removed by a least-squares quadratic in t, a Hann window tapers the ends,
!> and the power spectrum of the zero-padded record (8 times its length:
!> FFTW r2c) is searched for its highest peak above f_min.  A parabola
!> through the logarithm of the peak and its two neighbours places it
!> between the bins (exact for a Gaussian peak, which is what a Hann window
!> gives to within a fraction of a bin).
module spectrum
  use, intrinsic :: iso_c_binding, only: c_ptr, c_int, c_double, c_double_complex
  use kinds, only: wp
  use fftw3, only: fftw_plan_dft_r2c_1d, fftw_execute_dft_r2c, fftw_destroy_plan, FFTW_ESTIMATE
  implicit none
  private
  public :: dominant_frequency

  integer, parameter :: ZERO_PAD = 8

contains

  !> Frequency (cycles per unit time) of the highest spectral peak of y(t)
  !> above f_min; 0 when the record is too short (fewer than 8 samples or no
  !> bin above f_min).  t must increase.
  function dominant_frequency(t, y, f_min) result(freq)
    real(wp), intent(in) :: t(:), y(:), f_min
    real(wp) :: freq
    real(c_double), allocatable :: a(:)
    complex(c_double_complex), allocatable :: b(:)
    real(wp), allocatable :: yu(:), tu(:), pw(:)
    real(wp) :: span, dt, df, c(3), d, y1, y2, y3
    type(c_ptr) :: plan
    integer :: n, nu, nfft, k, kmin, kpk, j
    freq = 0
    n = size(t)
    if (n < 8) return
    span = t(n) - t(1)
    if (.not. span > 0) return
    ! even resampling, at least as fine as the average sample spacing
    nu = n
    dt = span / (nu - 1)
    allocate(tu(nu), yu(nu))
    j = 1
    do k = 1, nu
      tu(k) = t(1) + (k - 1) * dt
      do while (j < n - 1 .and. t(j + 1) < tu(k))
        j = j + 1
      end do
      d = t(j + 1) - t(j)
      if (d > 0) then
        yu(k) = y(j) + (y(j + 1) - y(j)) * (tu(k) - t(j)) / d
      else
        yu(k) = y(j)
      end if
    end do
    ! remove the slow part: least-squares quadratic in s = (t - mid)/span
    c = quadratic_fit((tu - 0.5_wp * (tu(1) + tu(nu))) / span, yu)
    do k = 1, nu
      d = (tu(k) - 0.5_wp * (tu(1) + tu(nu))) / span
      yu(k) = (yu(k) - (c(1) + c(2) * d + c(3) * d**2)) &
              * 0.5_wp * (1 - cos(2 * acos(-1.0_wp) * (k - 1) / (nu - 1)))   ! Hann
    end do
    nfft = ZERO_PAD * nu
    allocate(a(nfft), b(nfft / 2 + 1), pw(nfft / 2 + 1))
    plan = fftw_plan_dft_r2c_1d(int(nfft, c_int), a, b, FFTW_ESTIMATE)
    a = 0
    a(1:nu) = yu
    call fftw_execute_dft_r2c(plan, a, b)
    call fftw_destroy_plan(plan)
    pw = real(b, wp)**2 + aimag(b)**2
    df = 1 / (nfft * dt)
    kmin = max(2, ceiling(f_min / df) + 1)   ! bin k holds frequency (k - 1) df
    if (kmin >= size(pw)) return
    kpk = kmin - 1 + maxloc(pw(kmin:), dim=1)
    freq = (kpk - 1) * df
    if (kpk > 1 .and. kpk < size(pw)) then
      y1 = log(max(pw(kpk - 1), tiny(1.0_wp)))
      y2 = log(max(pw(kpk), tiny(1.0_wp)))
      y3 = log(max(pw(kpk + 1), tiny(1.0_wp)))
      d = y1 - 2 * y2 + y3
      if (d < 0) freq = freq + 0.5_wp * (y1 - y3) / d * df
    end if
  end function dominant_frequency

  !> Coefficients c of the least-squares fit c(1) + c(2) s + c(3) s^2.
  function quadratic_fit(s, y) result(c)
    real(wp), intent(in) :: s(:), y(:)
    real(wp) :: c(3), a(3, 4), f
    integer :: i, k
    do i = 1, 3
      do k = 1, 3
        a(i, k) = sum(s**(i + k - 2))
      end do
      a(i, 4) = sum(y * s**(i - 1))
    end do
    ! Gaussian elimination (the normal matrix is symmetric positive definite)
    do k = 1, 3
      do i = k + 1, 3
        f = a(i, k) / a(k, k)
        a(i, k:4) = a(i, k:4) - f * a(k, k:4)
      end do
    end do
    do i = 3, 1, -1
      c(i) = (a(i, 4) - sum(a(i, i + 1:3) * c(i + 1:3))) / a(i, i)
    end do
  end function quadratic_fit

end module spectrum
