!> The vortical square patch (2D): its group &square_vortical (side L, V0)
!> and the initial u = V0 (f(y) - e^-4), v = -V0 (f(x) - e^-4),
!> f(s) = exp(-(4s/L)^2) (doc/theory/ X4); the set-up, diagnostics and
!> reference solution are case_square's.
module case_square_vortical
  use kinds, only: wp
  use input_var, only: var_t, T_REAL, SCALAR, LO_GT, HI_NONE, CH_NONE
  use input_text, only: real_str
  use case_square, only: square_patch_t, SQ_VORTICAL
  implicit none
  private
  public :: square_vortical_t, square_vortical_case

  type, extends(square_patch_t) :: square_vortical_t
  contains
    procedure :: vars => square_vortical_vars
    procedure :: read_group => square_vortical_read_group
    procedure :: value_text => square_vortical_value_text
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

  function square_vortical_vars(self) result(vars)
    class(square_vortical_t), intent(in) :: self
    type(var_t), allocatable :: vars(:)
    vars = [ &
      var_t(0, 'side', T_REAL, SCALAR, LO_GT, HI_NONE, 0.0_wp, 0.0_wp, CH_NONE, '', &
            'side L of the initial square, centred at the origin'), &
      var_t(0, 'v0', T_REAL, SCALAR, LO_GT, HI_NONE, 0.0_wp, 0.0_wp, CH_NONE, '', &
            'V0: initial u = V0 (f(y) - e^-4), v = -V0 (f(x) - e^-4), f(s) = exp(-(4s/L)^2)', &
            doc='V0: initial u = V0 (f(y) - e^-4), v = -V0 (f(x) - e^-4), f(s) = exp(-(4 ' // &
                's/L)^2); the pressure solves Laplacian p = 2 rho0 (32 V0/L^2)^2 x y ' // &
                'f(x) f(y), p = 0 on the edges ([theory](../theory/solutions.md) X4)')]
    if (.false.) vars(1)%help = self%help
  end function square_vortical_vars

  subroutine square_vortical_read_group(self, text, ios, iomsg)
    class(square_vortical_t), intent(inout) :: self
    character(len=*), intent(in) :: text
    integer, intent(out) :: ios
    character(len=*), intent(inout) :: iomsg
    real(wp) :: side, v0
    namelist /square_vortical/ side, v0
    side = self%side
    v0 = self%rate
    read(text, nml=square_vortical, iostat=ios, iomsg=iomsg)
    if (ios /= 0) return
    self%side = side
    self%rate = v0
  end subroutine square_vortical_read_group

  function square_vortical_value_text(self, name) result(text)
    class(square_vortical_t), intent(in) :: self
    character(len=*), intent(in) :: name
    character(len=:), allocatable :: text
    select case (name)
    case ('side')
      text = real_str(self%side)
    case default
      text = real_str(self%rate)
    end select
  end function square_vortical_value_text

  !> |u| = sqrt(2) V0 (1 - e^-4) at the centre.
  subroutine square_vortical_max_speed(self, speed, formula)
    class(square_vortical_t), intent(in) :: self
    real(wp), intent(out) :: speed
    character(len=:), allocatable, intent(out) :: formula
    speed = sqrt(2.0_wp) * self%rate * (1 - exp(-4.0_wp))
    formula = '&square_vortical sqrt(2) (1 - e^-4) v0'
  end subroutine square_vortical_max_speed

end module case_square_vortical
