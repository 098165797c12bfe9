!> The description of one input variable, var_t, and of a group, group_t.
!> Rows are not written by hand: each group lists its variables, one call
!> of input_visit's visit_t%var each, and a listing visit makes the rows
!> from those calls.  The reading, the range checks, the comments of the
!> written files, `--help` and the tables of doc/reference/input.md
!> (`--input-tables`) come from the rows.
module input_var
  use kinds, only: wp
  implicit none
  private
  public :: var_t, group_t, T_INT, T_REAL, T_STRING, T_LOGICAL, LO_NONE, LO_GT, LO_GE, &
            HI_NONE, HI_LT, HI_LE, WORD_LEN

  ! Variable types and bound rules.
  integer, parameter :: T_INT = 1, T_REAL = 2, T_STRING = 3, T_LOGICAL = 4
  integer, parameter :: LO_NONE = 0, LO_GT = 1, LO_GE = 2
  integer, parameter :: HI_NONE = 0, HI_LT = 1, HI_LE = 2
  integer, parameter :: WORD_LEN = 32   !< length of an allowed word

  !> A namelist group: its name and a line saying what it is for.
  type :: group_t
    character(len=WORD_LEN) :: name
    character(len=:), allocatable :: help
  end type group_t

  !> A variable of a group, with its value when listed from an input.
  type :: var_t
    integer :: group = 0                 !< index of its group in the visit's order
    character(len=20) :: name = ''
    integer :: type = T_REAL             !< T_*
    integer :: dims(2) = 0               !< array extents, 0 for none (a scalar: both 0)
    integer :: lo_rule = LO_NONE, hi_rule = HI_NONE   !< lo < x, lo <= x, x < hi, x <= hi
    real(wp) :: lo = 0, hi = 0
    character(len=WORD_LEN), allocatable :: words(:)  !< the allowed words, none if free
    character(len=60) :: rule = ''       !< what is allowed when no range or list says it
    character(len=110) :: help = ''      !< what the variable is (--help, --defaults)
    !> the documentation's fuller text (doc/reference/input.md, markdown); help when empty
    character(len=700) :: doc = ''
    !> a two-dimensional array: the variable of its group counting the columns in use
    character(len=20) :: count = ''
    character(len=:), allocatable :: value   !< the value as namelist text that reads back exactly
  end type var_t

end module input_var
