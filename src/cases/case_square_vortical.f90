!> The vortical square patch (2D): its group &square_vortical (side L, V0)
!> and the initial u = V0 (f(y) - e^-4), v = -V0 (f(x) - e^-4),
!> f(s) = exp(-(4s/L)^2) (doc/theory/ X4); the set-up, diagnostics and
!> reference solution are case_square's.
module case_square_vortical
  use kinds, only: wp
  use input_visit, only: visit_t
  use case_square, only: square_patch_t, SQ_VORTICAL
  implicit none
  private
  public :: square_vortical_t, square_vortical_case

  type, extends(square_patch_t) :: square_vortical_t
  contains
    procedure :: visit => square_vortical_visit
    procedure :: max_speed => square_vortical_max_speed
  end type square_vortical_t

contains

  !> The case at its defaults: L = V0 = 1.
  function square_vortical_case() result(c)
    type(square_vortical_t) :: c
    c%name = 'square_vortical'
    c%help = 'the vortical square patch (2D)'
    c%no_packing = 'the square patches are always on a lattice'
    c%no_symmetry = 'its only mirror line is y = -x, not a coordinate plane'
    c%dim = 2
    c%kind = SQ_VORTICAL
  end function square_vortical_case

  !> &square_vortical (input_visit); v0 is the patch's rate.
  subroutine square_vortical_visit(self, v)
    class(square_vortical_t), intent(inout) :: self
    type(visit_t), intent(inout) :: v
    call v%var('side', self%side, 'side L of the initial square, centred at the origin', &
               gt=0.0_wp)
    call v%var('v0', self%rate, 'V0: initial u = V0 (f(y) - e^-4), v = -V0 (f(x) - e^-4), ' // &
               'f(s) = exp(-(4s/L)^2)', gt=0.0_wp, &
               doc='V0: initial u = V0 (f(y) - e^-4), v = -V0 (f(x) - e^-4), f(s) = ' // &
                   'exp(-(4 s/L)^2); the pressure solves Laplacian p = 2 rho0 (32 V0/L^2)^2 ' // &
                   'x y f(x) f(y), p = 0 on the edges ([theory](../theory/solutions.md) X4)')
  end subroutine square_vortical_visit

  !> |u| = sqrt(2) V0 (1 - e^-4) at the centre.
  subroutine square_vortical_max_speed(self, speed, formula)
    class(square_vortical_t), intent(in) :: self
    real(wp), intent(out) :: speed
    character(len=:), allocatable, intent(out) :: formula
    speed = sqrt(2.0_wp) * self%rate * (1 - exp(-4.0_wp))
    formula = '&square_vortical sqrt(2) (1 - e^-4) v0'
  end subroutine square_vortical_max_speed

end module case_square_vortical
