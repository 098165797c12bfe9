!> dominant_frequency against synthetic signals whose frequency is known:
!> a sinusoid riding on a slow quadratic trend, sampled at uneven times (as
!> a time series of variable steps is), with a decaying amplitude and a
!> weaker second tone; and the edge cases.
module test_spectrum
  use kinds, only: wp, pi
  use spectrum, only: dominant_frequency
  use testing, only: run_test, assert_true, assert_equal
  implicit none
  private
  public :: suite_spectrum

contains

  subroutine suite_spectrum()
    call run_test('spectrum', 'tone_on_a_trend_uneven_samples', tone_on_trend)
    call run_test('spectrum', 'short_or_flat_records', short_records)
  end subroutine suite_spectrum

  !> y = -0.15 + 0.03 t - 0.004 t^2 + 0.01 e^-t/3 sin(2 pi f t) + 0.003
  !> sin(2 pi 2.3 f t) on t in [0, 4], 800 samples with steps varying by
  !> +-30 %: the peak is found within 0.5 % of f (record of 20 periods; a
  !> bin is 1/32 of f after zero padding, the interpolation does the rest).
  subroutine tone_on_trend()
    integer, parameter :: n = 800
    real(wp), parameter :: freqs(3) = [4.95_wp, 4.3_wp, 6.1_wp]
    real(wp) :: t(n), y(n), freq, f, r(n)
    integer :: k, trial
    do trial = 1, 3
      f = freqs(trial)
      call random_number(r)
      t(1) = 0
      do k = 2, n
        t(k) = t(k - 1) + (1 + 0.6_wp * (r(k) - 0.5_wp))
      end do
      t = t * 4 / t(n)
      y = -0.15_wp + 0.03_wp * t - 0.004_wp * t**2 + 0.01_wp * exp(-t / 3) * sin(2 * pi * f * t) &
          + 0.003_wp * sin(2 * pi * 2.3_wp * f * t)
      freq = dominant_frequency(t, y, 0.8_wp)
      call assert_equal(f, freq, 0.005_wp * f, 'dominant frequency')
    end do
  end subroutine tone_on_trend

  subroutine short_records()
    real(wp) :: t(5), y(5), tt(100), yy(100)
    integer :: k
    t = [(real(k, wp), k = 1, 5)]
    y = sin(t)
    call assert_equal(0.0_wp, dominant_frequency(t, y, 0.1_wp), 0.0_wp, 'fewer than 8 samples')
    tt = [(0.01_wp * k, k = 1, 100)]
    yy = sin(2 * pi * 3 * tt)
    ! f_min above the Nyquist frequency (50): no bin to search
    call assert_equal(0.0_wp, dominant_frequency(tt, yy, 60.0_wp), 0.0_wp, 'no bin above f_min')
  end subroutine short_records

end module test_spectrum
