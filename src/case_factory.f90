!> Picks the case implementation for run.case.
module case_factory
  use case_base, only: case_t
  use case_stretching, only: stretching_t
  use case_square, only: square_patch_t
  implicit none
  private
  public :: make_case

contains

  !> The case named `name` (a name config has validated).
  subroutine make_case(name, c)
    character(len=*), intent(in) :: name
    class(case_t), allocatable, intent(out) :: c
    select case (name)
    case ('circle2d', 'ellipsoid3d')
      allocate(stretching_t :: c)
    case ('square_rotation', 'square_vortical')
      allocate(square_patch_t :: c)
    case default
      error stop 'make_case: unknown case (config should have rejected it)'
    end select
  end subroutine make_case

end module case_factory
