!> The rotating square patch (2D): its group &square_rotation (side L,
!> omega) and the initial rigid rotation u = omega y, v = -omega x
!> (doc/theory/ X3); the set-up, diagnostics and reference solution are
!> case_square's.
module case_square_rotation
  use kinds, only: wp
  use input_visit, only: visit_t
  use case_square, only: square_patch_t, SQ_ROTATION
  implicit none
  private
  public :: square_rotation_t, square_rotation_case

  type, extends(square_patch_t) :: square_rotation_t
  contains
    procedure :: visit => square_rotation_visit
    procedure :: max_speed => square_rotation_max_speed
  end type square_rotation_t

contains

  !> The case at its defaults: L = omega = 1.
  function square_rotation_case() result(c)
    type(square_rotation_t) :: c
    c%name = 'square_rotation'
    c%help = 'the rotating square patch (2D)'
    c%no_packing = 'the square patches are always on a lattice'
    c%no_symmetry = 'the rotating square has no mirror plane'
    c%dim = 2
    c%kind = SQ_ROTATION
  end function square_rotation_case

  !> &square_rotation (input_visit); omega is the patch's rate.
  subroutine square_rotation_visit(self, v)
    class(square_rotation_t), intent(inout) :: self
    type(visit_t), intent(inout) :: v
    call v%var('side', self%side, 'side L of the initial square, centred at the origin', &
               gt=0.0_wp)
    call v%var('omega', self%rate, 'omega: initial rigid rotation u = omega y, v = -omega x', &
               gt=0.0_wp, &
               doc='omega: initial rigid rotation u = omega y, v = -omega x; the pressure ' // &
                   'solves Laplacian p = 2 rho0 omega^2, p = 0 on the edges')
  end subroutine square_rotation_visit

  !> u = omega (y, -x): omega L/sqrt(2) at the corners.
  subroutine square_rotation_max_speed(self, speed, formula)
    class(square_rotation_t), intent(in) :: self
    real(wp), intent(out) :: speed
    character(len=:), allocatable, intent(out) :: formula
    speed = self%rate * self%side / sqrt(2.0_wp)
    formula = '&square_rotation omega side/sqrt(2)'
  end subroutine square_rotation_max_speed

end module case_square_rotation
