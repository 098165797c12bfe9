!> The stretching circular patch (2D): its group &circle2d (radius R, A0)
!> and the initial velocity u = -A0 x, v = A0 y (doc/theory/ X1); the
!> set-up, diagnostics and exact solution are case_stretching's.
module case_circle2d
  use kinds, only: wp
  use input_var, only: var_t, T_REAL, SCALAR, LO_GT, HI_NONE, CH_NONE
  use input_text, only: real_str
  use case_stretching, only: stretching_t
  implicit none
  private
  public :: circle2d_t, circle2d_case

  type, extends(stretching_t) :: circle2d_t
  contains
    procedure :: vars => circle2d_vars
    procedure :: read_group => circle2d_read_group
    procedure :: value_text => circle2d_value_text
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

  function circle2d_vars(self) result(vars)
    class(circle2d_t), intent(in) :: self
    type(var_t), allocatable :: vars(:)
    vars = [ &
      var_t(0, 'radius', T_REAL, SCALAR, LO_GT, HI_NONE, 0.0_wp, 0.0_wp, CH_NONE, '', &
            'radius R of the initial disc'), &
      var_t(0, 'a0', T_REAL, SCALAR, LO_GT, HI_NONE, 0.0_wp, 0.0_wp, CH_NONE, '', &
            'A0: initial velocity u = -A0 x, v = A0 y')]
  end function circle2d_vars

  subroutine circle2d_read_group(self, text, ios, iomsg)
    class(circle2d_t), intent(inout) :: self
    character(len=*), intent(in) :: text
    integer, intent(out) :: ios
    character(len=*), intent(inout) :: iomsg
    real(wp) :: radius, a0
    namelist /circle2d/ radius, a0
    radius = self%radius
    a0 = self%a0
    read(text, nml=circle2d, iostat=ios, iomsg=iomsg)
    if (ios /= 0) return
    self%radius = radius
    self%a0 = a0
  end subroutine circle2d_read_group

  function circle2d_value_text(self, name) result(text)
    class(circle2d_t), intent(in) :: self
    character(len=*), intent(in) :: name
    character(len=:), allocatable :: text
    select case (name)
    case ('radius')
      text = real_str(self%radius)
    case ('a0')
      text = real_str(self%a0)
    case default
      error stop 'circle2d: no variable ' // name
    end select
  end function circle2d_value_text

  !> u = -A0 x, v = A0 y: A0 R on the circle.
  subroutine circle2d_max_speed(self, speed, formula)
    class(circle2d_t), intent(in) :: self
    real(wp), intent(out) :: speed
    character(len=:), allocatable, intent(out) :: formula
    speed = self%a0 * self%radius
    formula = '&circle2d a0 radius'
  end subroutine circle2d_max_speed

end module case_circle2d
