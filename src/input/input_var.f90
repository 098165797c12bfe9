!> The description of one input variable, var_t: the one place that says
!> what it is and what is allowed.  config keeps the rows of the generic
!> groups; each case gives the rows of its own group (case_base).  The range
!> checks, the comments of the written files, `--help` and the tables of
!> doc/reference/input.md (`--input-tables`) come from them.
module input_var
  use kinds, only: wp
  implicit none
  private
  public :: var_t, T_INT, T_REAL, T_STRING, T_LOGICAL, LO_NONE, LO_GT, LO_GE, &
            HI_NONE, HI_LT, HI_LE, CH_NONE, SCALAR

  ! Variable types, bound rules, and "no list of allowed words".
  integer, parameter :: T_INT = 1, T_REAL = 2, T_STRING = 3, T_LOGICAL = 4
  integer, parameter :: LO_NONE = 0, LO_GT = 1, LO_GE = 2
  integer, parameter :: HI_NONE = 0, HI_LT = 1, HI_LE = 2
  integer, parameter :: CH_NONE = 0
  integer, parameter :: SCALAR(2) = [0, 0]

  !> A variable of a group.
  type :: var_t
    integer :: group             !< index into config's groups (0 in a case's own rows)
    character(len=20) :: name
    integer :: type              !< T_*
    integer :: dims(2)           !< array extents, SCALAR for a scalar
    integer :: lo_rule, hi_rule  !< LO_*, HI_*: lo < x, lo <= x, x < hi, x <= hi
    real(wp) :: lo, hi
    integer :: choices           !< config's list of allowed words, CH_NONE if free
    character(len=60) :: rule    !< what is allowed when no range or list says it
    character(len=110) :: help   !< what the variable is (--help, --defaults)
    !> the documentation's fuller text (doc/reference/input.md, markdown); help when empty
    character(len=700) :: doc = ''
  end type var_t

end module input_var
