!> Equations of state (doc/theory/ E6) and their inverses.
module eos
  use kinds, only: wp
  implicit none
  private
  public :: eos_t, eos_init, eos_pressure, eos_density, EOS_LINEAR, EOS_TAIT

  integer, parameter :: EOS_LINEAR = 1   !< p = c0^2 (rho - rho0)
  integer, parameter :: EOS_TAIT = 2     !< p = (rho0 c0^2/gamma) ((rho/rho0)^gamma - 1)

  type :: eos_t
    integer :: kind = EOS_LINEAR
    real(wp) :: c0 = 10, rho0 = 1, gamma = 7
  end type eos_t

contains

  function eos_init(kind, c0, rho0, gamma) result(e)
    integer, intent(in) :: kind
    real(wp), intent(in) :: c0, rho0, gamma
    type(eos_t) :: e
    e = eos_t(kind, c0, rho0, gamma)
  end function eos_init

  pure elemental function eos_pressure(e, rho) result(p)
    type(eos_t), intent(in) :: e
    real(wp), intent(in) :: rho
    real(wp) :: p
    if (e%kind == EOS_TAIT) then
      p = e%rho0 * e%c0**2 / e%gamma * ((rho / e%rho0)**e%gamma - 1)
    else
      p = e%c0**2 * (rho - e%rho0)
    end if
  end function eos_pressure

  !> The inverse: density for pressure p.  For Tait, p must exceed
  !> -rho0 c0^2/gamma (the caller checks the result is finite and positive).
  pure elemental function eos_density(e, p) result(rho)
    type(eos_t), intent(in) :: e
    real(wp), intent(in) :: p
    real(wp) :: rho
    if (e%kind == EOS_TAIT) then
      rho = e%rho0 * (1 + e%gamma * p / (e%rho0 * e%c0**2))**(1 / e%gamma)
    else
      rho = e%rho0 + p / e%c0**2
    end if
  end function eos_density

end module eos
