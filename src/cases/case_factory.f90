!> The registry of the cases: one line per case.  config reads each case's
!> own group and offers its name for run.case; the order here is the order
!> of the groups in written input files.
module case_factory
  use case_base, only: case_t, case_slot_t
  use case_circle2d, only: circle2d_case
  use case_ellipsoid3d, only: ellipsoid3d_case
  use case_square_rotation, only: square_rotation_case
  use case_square_vortical, only: square_vortical_case
  implicit none
  private
  public :: register_cases

contains

  !> Every case at its defaults.
  subroutine register_cases(cases)
    type(case_slot_t), allocatable, intent(out) :: cases(:)
    allocate(cases(0))
    call register(cases, circle2d_case())
    call register(cases, ellipsoid3d_case())
    call register(cases, square_rotation_case())
    call register(cases, square_vortical_case())
  end subroutine register_cases

  subroutine register(cases, c)
    type(case_slot_t), allocatable, intent(inout) :: cases(:)
    class(case_t), intent(in) :: c
    type(case_slot_t), allocatable :: grown(:)
    integer :: k
    allocate(grown(size(cases) + 1))
    do k = 1, size(cases)
      call move_alloc(cases(k)%c, grown(k)%c)
    end do
    allocate(grown(size(grown))%c, source=c)
    call move_alloc(grown, cases)
  end subroutine register

end module case_factory
