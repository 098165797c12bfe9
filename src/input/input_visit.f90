!> The visit of an input's namelist groups.  Each group lists its variables
!> where its components live (input_params for the generic groups, each
!> case for its own), in the order of the written files, one call each:
!>
!>   call v%group('numerics', 'SPH discretisation and time stepping')
!>   call v%var('cfl', p%cfl, 'acoustic CFL number: ...', gt=0.0_wp, le=3.0_wp)
!>
!> The component gives the variable's type and shape, and its initial value
!> the default; the call gives the name, the bounds (gt, ge, lt, le), the
!> allowed words, the help and the documentation.  What a call does depends
!> on the visit: list the rows (var_t, with the value as text), read one
!> namelist item into its variable, or put a word-valued one in lower case.
module input_visit
  use kinds, only: wp
  use input_var, only: var_t, group_t, T_INT, T_REAL, T_STRING, T_LOGICAL, LO_GT, LO_GE, &
                       HI_LT, HI_LE
  use input_text, only: lower, quoted, real_str, real_list, int_str
  implicit none
  private
  public :: input_t, visit_t, list_input, read_input_item, normalise_input

  integer, parameter :: VISIT_LIST = 1, VISIT_READ = 2, VISIT_NORMALISE = 3

  !> An input made of namelist groups, which visit visits in order.
  type, abstract :: input_t
  contains
    procedure(visit_i), deferred :: visit
  end type input_t

  !> One visit of an input's groups (list_input, read_input_item,
  !> normalise_input).
  type :: visit_t
    private
    integer :: action = VISIT_LIST
    integer :: g = 0                           !< the group visited, counted from 1
    type(group_t), allocatable :: groups(:)    !< listed
    type(var_t), allocatable :: vars(:)        !< listed
    integer :: target_group = 0                !< read: the item's group and variable
    character(len=:), allocatable :: target_name
    !> read: the item as namelist text of y, '&item y(1,2) = 0.5 /'
    character(len=:), allocatable :: item
    integer :: ios = 0
    character(len=512) :: iomsg = ''
  contains
    procedure :: group => visit_group
    generic :: var => var_real, var_real1, var_real2, var_int, var_logical, var_string
    procedure, private :: var_real, var_real1, var_real2, var_int, var_logical, var_string
    procedure, private :: wanted, add
  end type visit_t

  abstract interface
    !> Visits the groups in order: for each, v%group, then v%var per variable.
    subroutine visit_i(self, v)
      import :: input_t, visit_t
      class(input_t), intent(inout) :: self
      type(visit_t), intent(inout) :: v
    end subroutine visit_i
  end interface

contains

  !> The groups of x and their variables, each with its value.
  subroutine list_input(x, groups, vars)
    class(input_t), intent(in) :: x
    type(group_t), allocatable, intent(out) :: groups(:)
    type(var_t), allocatable, intent(out) :: vars(:)
    class(input_t), allocatable :: copy
    type(visit_t) :: v
    allocate(copy, source=x)   ! a listing changes nothing, but a visit may change
    allocate(v%groups(0), v%vars(0))
    call copy%visit(v)
    call move_alloc(v%groups, groups)
    call move_alloc(v%vars, vars)
  end subroutine list_input

  !> Reads the namelist item `name = value` of group g into x; name is in
  !> lower case and may carry an index, as in probes(1,2).  ios /= 0 (iomsg
  !> says why) leaves x as it was.
  subroutine read_input_item(x, g, name, value, ios, iomsg)
    class(input_t), intent(inout) :: x
    integer, intent(in) :: g
    character(len=*), intent(in) :: name, value
    integer, intent(out) :: ios
    character(len=*), intent(inout) :: iomsg
    type(visit_t) :: v
    integer :: k
    k = scan(name, '( ')
    if (k == 0) k = len(name) + 1
    v%action = VISIT_READ
    v%target_group = g
    v%target_name = name(1:k - 1)
    v%item = '&item y' // name(k:) // ' = ' // value // ' /'
    v%ios = 1
    v%iomsg = 'no such variable'
    call x%visit(v)
    ios = v%ios
    iomsg = v%iomsg
  end subroutine read_input_item

  !> Word-valued variables in lower case without leading blanks, as Fortran
  !> compares names ('Gaussian' is 'gaussian').
  subroutine normalise_input(x)
    class(input_t), intent(inout) :: x
    type(visit_t) :: v
    v%action = VISIT_NORMALISE
    call x%visit(v)
  end subroutine normalise_input

  !> Starts the variables of group `name`.
  subroutine visit_group(v, name, help)
    class(visit_t), intent(inout) :: v
    character(len=*), intent(in) :: name, help
    v%g = v%g + 1
    if (v%action == VISIT_LIST) v%groups = [v%groups, group_t(name, help)]
  end subroutine visit_group

  ! One procedure per kind of component.  Each lists its row, or reads the
  ! item through a namelist of one variable, y, holding a copy, so that a
  ! failed read changes nothing.

  subroutine var_real(v, name, x, help, gt, ge, lt, le, rule, doc)
    class(visit_t), intent(inout) :: v
    character(len=*), intent(in) :: name, help
    real(wp), intent(inout) :: x
    real(wp), intent(in), optional :: gt, ge, lt, le
    character(len=*), intent(in), optional :: rule, doc
    type(var_t) :: r
    real(wp) :: y
    namelist /item/ y
    select case (v%action)
    case (VISIT_LIST)
      r = new_row(v, name, T_REAL, [0, 0], help, rule, doc)
      if (present(gt)) call set_lo(r, LO_GT, gt)
      if (present(ge)) call set_lo(r, LO_GE, ge)
      if (present(lt)) call set_hi(r, HI_LT, lt)
      if (present(le)) call set_hi(r, HI_LE, le)
      call v%add(r, real_str(x))
    case (VISIT_READ)
      if (.not. v%wanted(name)) return
      y = x
      read(v%item, nml=item, iostat=v%ios, iomsg=v%iomsg)
      if (v%ios == 0) x = y
    end select
  end subroutine var_real

  subroutine var_real1(v, name, x, help, rule, doc)
    class(visit_t), intent(inout) :: v
    character(len=*), intent(in) :: name, help
    real(wp), intent(inout) :: x(:)
    character(len=*), intent(in), optional :: rule, doc
    real(wp), allocatable :: y(:)
    namelist /item/ y
    select case (v%action)
    case (VISIT_LIST)
      call v%add(new_row(v, name, T_REAL, [size(x), 0], help, rule, doc), real_list(x))
    case (VISIT_READ)
      if (.not. v%wanted(name)) return
      y = x
      read(v%item, nml=item, iostat=v%ios, iomsg=v%iomsg)
      if (v%ios == 0) x = y
    end select
  end subroutine var_real1

  !> count: the variable of the group saying how many columns are in use
  !> (the written files give those and any other that is set).
  subroutine var_real2(v, name, x, help, count, rule, doc)
    class(visit_t), intent(inout) :: v
    character(len=*), intent(in) :: name, help, count
    real(wp), intent(inout) :: x(:, :)
    character(len=*), intent(in), optional :: rule, doc
    type(var_t) :: r
    real(wp), allocatable :: y(:, :)
    namelist /item/ y
    select case (v%action)
    case (VISIT_LIST)
      r = new_row(v, name, T_REAL, shape(x), help, rule, doc)
      r%count = count
      call v%add(r, real_list(reshape(x, [size(x)])))
    case (VISIT_READ)
      if (.not. v%wanted(name)) return
      y = x
      read(v%item, nml=item, iostat=v%ios, iomsg=v%iomsg)
      if (v%ios == 0) x = y
    end select
  end subroutine var_real2

  subroutine var_int(v, name, x, help, ge, le, rule, doc)
    class(visit_t), intent(inout) :: v
    character(len=*), intent(in) :: name, help
    integer, intent(inout) :: x
    integer, intent(in), optional :: ge, le
    character(len=*), intent(in), optional :: rule, doc
    type(var_t) :: r
    integer :: y
    namelist /item/ y
    select case (v%action)
    case (VISIT_LIST)
      r = new_row(v, name, T_INT, [0, 0], help, rule, doc)
      if (present(ge)) call set_lo(r, LO_GE, real(ge, wp))
      if (present(le)) call set_hi(r, HI_LE, real(le, wp))
      call v%add(r, int_str(x))
    case (VISIT_READ)
      if (.not. v%wanted(name)) return
      y = x
      read(v%item, nml=item, iostat=v%ios, iomsg=v%iomsg)
      if (v%ios == 0) x = y
    end select
  end subroutine var_int

  subroutine var_logical(v, name, x, help, doc)
    class(visit_t), intent(inout) :: v
    character(len=*), intent(in) :: name, help
    logical, intent(inout) :: x
    character(len=*), intent(in), optional :: doc
    logical :: y
    namelist /item/ y
    select case (v%action)
    case (VISIT_LIST)
      call v%add(new_row(v, name, T_LOGICAL, [0, 0], help, doc=doc), &
                 trim(merge('.true. ', '.false.', x)))
    case (VISIT_READ)
      if (.not. v%wanted(name)) return
      y = x
      read(v%item, nml=item, iostat=v%ios, iomsg=v%iomsg)
      if (v%ios == 0) x = y
    end select
  end subroutine var_logical

  !> words: the allowed words (a word-valued variable), else any string
  !> (rule says what is allowed).  Read into a wider copy, then cut to x:
  !> a string one character longer than allowed (output.dir) then shows a
  !> value too long to the checks, whatever its length.
  subroutine var_string(v, name, x, help, words, rule, doc)
    class(visit_t), intent(inout) :: v
    character(len=*), intent(in) :: name, help
    character(len=*), intent(inout) :: x
    character(len=*), intent(in), optional :: words(:), rule, doc
    type(var_t) :: r
    character(len=4 * len(x)) :: y
    namelist /item/ y
    select case (v%action)
    case (VISIT_LIST)
      r = new_row(v, name, T_STRING, [0, 0], help, rule, doc)
      if (present(words)) then
        deallocate(r%words)
        allocate(r%words(size(words)))
        r%words = words
      end if
      call v%add(r, quoted(x))
    case (VISIT_READ)
      if (.not. v%wanted(name)) return
      y = x
      read(v%item, nml=item, iostat=v%ios, iomsg=v%iomsg)
      if (v%ios == 0) x = y(1:len(x))
    case (VISIT_NORMALISE)
      if (present(words)) x = lower(adjustl(x))
    end select
  end subroutine var_string

  function new_row(v, name, type, dims, help, rule, doc) result(r)
    type(visit_t), intent(in) :: v
    character(len=*), intent(in) :: name, help
    integer, intent(in) :: type, dims(2)
    character(len=*), intent(in), optional :: rule, doc
    type(var_t) :: r
    r%group = v%g
    r%name = name
    r%type = type
    r%dims = dims
    r%help = help
    if (present(rule)) r%rule = rule
    if (present(doc)) r%doc = doc
    allocate(r%words(0))
  end function new_row

  subroutine set_lo(r, rule, lo)
    type(var_t), intent(inout) :: r
    integer, intent(in) :: rule
    real(wp), intent(in) :: lo
    r%lo_rule = rule
    r%lo = lo
  end subroutine set_lo

  subroutine set_hi(r, rule, hi)
    type(var_t), intent(inout) :: r
    integer, intent(in) :: rule
    real(wp), intent(in) :: hi
    r%hi_rule = rule
    r%hi = hi
  end subroutine set_hi

  subroutine add(v, r, value)
    class(visit_t), intent(inout) :: v
    type(var_t), intent(in) :: r
    character(len=*), intent(in) :: value
    v%vars = [v%vars, r]
    v%vars(size(v%vars))%value = value
  end subroutine add

  logical function wanted(v, name)
    class(visit_t), intent(in) :: v
    character(len=*), intent(in) :: name
    wanted = v%g == v%target_group .and. name == v%target_name
  end function wanted

end module input_visit
