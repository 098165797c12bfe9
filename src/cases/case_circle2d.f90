!> The stretching circular patch (2D): its group &circle2d (radius R, A0)
!> and the initial velocity u = -A0 x, v = A0 y (doc/theory/ X1); the
!> set-up, diagnostics and exact solution are case_stretching's.
module case_circle2d
  use kinds, only: wp
  use input_visit, only: visit_t
  use case_stretching, only: stretching_t
  implicit none
  private
  public :: circle2d_t, circle2d_case

  type, extends(stretching_t) :: circle2d_t
  contains
    procedure :: visit => circle2d_visit
    procedure :: max_speed => circle2d_max_speed
  end type circle2d_t

contains

  !> The case at its defaults: R = A0 = 1, rates (-1, 1) in units of A0.
  function circle2d_case() result(c)
    type(circle2d_t) :: c
    c%name = 'circle2d'
    c%help = 'the stretching circular patch (2D)'
    c%no_packing = ''
    c%no_symmetry = ''
    c%dim = 2
    c%rates = [-1.0_wp, 1.0_wp, 0.0_wp]
  end function circle2d_case

  !> &circle2d (input_visit).
  subroutine circle2d_visit(self, v)
    class(circle2d_t), intent(inout) :: self
    type(visit_t), intent(inout) :: v
    call v%var('radius', self%radius, 'radius R of the initial disc', gt=0.0_wp)
    call v%var('a0', self%a0, 'A0: initial velocity u = -A0 x, v = A0 y', gt=0.0_wp)
  end subroutine circle2d_visit

  !> u = -A0 x, v = A0 y: A0 R on the circle.
  subroutine circle2d_max_speed(self, speed, formula)
    class(circle2d_t), intent(in) :: self
    real(wp), intent(out) :: speed
    character(len=:), allocatable, intent(out) :: formula
    speed = self%a0 * self%radius
    formula = '&circle2d a0 radius'
  end subroutine circle2d_max_speed

end module case_circle2d
