!> The rotating square patch (2D): its group &square_rotation (side L,
!> omega) and the initial rigid rotation u = omega y, v = -omega x
!> (doc/theory/ X3); the set-up, diagnostics and reference solution are
!> case_square's.
module case_square_rotation
  use kinds, only: wp
  use input_var, only: var_t, T_REAL, SCALAR, LO_GT, HI_NONE, CH_NONE
  use input_text, only: real_str
  use case_square, only: square_patch_t, SQ_ROTATION
  implicit none
  private
  public :: square_rotation_t, square_rotation_case

  type, extends(square_patch_t) :: square_rotation_t
  contains
    procedure :: vars => square_rotation_vars
    procedure :: read_group => square_rotation_read_group
    procedure :: value_text => square_rotation_value_text
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

  function square_rotation_vars(self) result(vars)
    class(square_rotation_t), intent(in) :: self
    type(var_t), allocatable :: vars(:)
    vars = [ &
      var_t(0, 'side', T_REAL, SCALAR, LO_GT, HI_NONE, 0.0_wp, 0.0_wp, CH_NONE, '', &
            'side L of the initial square, centred at the origin'), &
      var_t(0, 'omega', T_REAL, SCALAR, LO_GT, HI_NONE, 0.0_wp, 0.0_wp, CH_NONE, '', &
            'omega: initial rigid rotation u = omega y, v = -omega x', &
            doc='omega: initial rigid rotation u = omega y, v = -omega x; the pressure ' // &
                'solves Laplacian p = 2 rho0 omega^2, p = 0 on the edges')]
    if (.false.) vars(1)%help = self%help
  end function square_rotation_vars

  subroutine square_rotation_read_group(self, text, ios, iomsg)
    class(square_rotation_t), intent(inout) :: self
    character(len=*), intent(in) :: text
    integer, intent(out) :: ios
    character(len=*), intent(inout) :: iomsg
    real(wp) :: side, omega
    namelist /square_rotation/ side, omega
    side = self%side
    omega = self%rate
    read(text, nml=square_rotation, iostat=ios, iomsg=iomsg)
    if (ios /= 0) return
    self%side = side
    self%rate = omega
  end subroutine square_rotation_read_group

  function square_rotation_value_text(self, name) result(text)
    class(square_rotation_t), intent(in) :: self
    character(len=*), intent(in) :: name
    character(len=:), allocatable :: text
    select case (name)
    case ('side')
      text = real_str(self%side)
    case default
      text = real_str(self%rate)
    end select
  end function square_rotation_value_text

  !> u = omega (y, -x): omega L/sqrt(2) at the corners.
  subroutine square_rotation_max_speed(self, speed, formula)
    class(square_rotation_t), intent(in) :: self
    real(wp), intent(out) :: speed
    character(len=:), allocatable, intent(out) :: formula
    speed = self%rate * self%side / sqrt(2.0_wp)
    formula = '&square_rotation omega side/sqrt(2)'
  end subroutine square_rotation_max_speed

end module case_square_rotation
