!> Equations of state (E6): inverse pairs, known values, and the shared
!> linearisation dp/drho = c0^2 at rho0.
module test_eos
  use kinds, only: wp
  use eos, only: eos_t, eos_init, eos_pressure, eos_density, EOS_LINEAR, EOS_TAIT
  use testing, only: run_test, assert_equal, assert_relatively_equal
  implicit none
  private
  public :: suite_eos

contains

  subroutine suite_eos()
    call run_test('eos', 'inverse_pairs', inverse_pairs)
    call run_test('eos', 'known_values', known_values)
    call run_test('eos', 'sound_speed_at_rest', sound_speed)
  end subroutine suite_eos

  subroutine inverse_pairs()
    type(eos_t) :: e
    integer :: kind, k
    real(wp) :: p, rho
    do kind = EOS_LINEAR, EOS_TAIT
      e = eos_init(kind, 12.5_wp, 998.0_wp, 7.0_wp)
      do k = -9, 9
        p = 0.1_wp * k * 998.0_wp * 12.5_wp**2 / 7
        call assert_relatively_equal(p + 1e-300_wp, eos_pressure(e, eos_density(e, p)) &
          + 1e-300_wp, 1e-12_wp, 'p(rho(p)) = p')
        rho = 998.0_wp * (1 + 0.01_wp * k)
        call assert_relatively_equal(rho, eos_density(e, eos_pressure(e, rho)), 1e-13_wp, &
                                     'rho(p(rho)) = rho')
      end do
    end do
  end subroutine inverse_pairs

  subroutine known_values()
    type(eos_t) :: e
    e = eos_init(EOS_LINEAR, 10.0_wp, 1.0_wp, 7.0_wp)
    call assert_equal(0.5_wp, eos_pressure(e, 1.005_wp), 1e-13_wp, 'linear: c0^2 (rho - rho0)')
    call assert_equal(0.0_wp, eos_pressure(e, 1.0_wp), 0.0_wp, 'linear: p(rho0) = 0')
    e = eos_init(EOS_TAIT, 10.0_wp, 1.0_wp, 7.0_wp)
    ! (rho0 c0^2/gamma)((1.1)^7 - 1) = (100/7)(0.9487171) = 13.5531014286
    call assert_relatively_equal(13.553101428571447_wp, eos_pressure(e, 1.1_wp), 1e-13_wp, &
                                 'tait at rho = 1.1 rho0')
    call assert_equal(0.0_wp, eos_pressure(e, 1.0_wp), 0.0_wp, 'tait: p(rho0) = 0')
  end subroutine known_values

  !> Both laws have dp/drho = c0^2 at rho0 (so c0 means the same in both).
  subroutine sound_speed()
    type(eos_t) :: e
    integer :: kind
    real(wp) :: d
    d = 1e-6_wp
    do kind = EOS_LINEAR, EOS_TAIT
      e = eos_init(kind, 7.0_wp, 2.0_wp, 7.0_wp)
      call assert_relatively_equal(49.0_wp, (eos_pressure(e, 2 + d) - eos_pressure(e, 2 - d)) &
                                   / (2 * d), 1e-8_wp, 'dp/drho = c0^2 at rho0')
    end do
  end subroutine sound_speed

end module test_eos
