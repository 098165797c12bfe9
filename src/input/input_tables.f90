!> What a row (var_t) says in words: what is allowed, as messages, `--help`
!> and the written files say it, and the row of doc/reference/input.md's
!> tables, made from the description alone so that the documentation is the
!> program's (input_write: write_tables; `make input-doc`).
module input_tables
  use input_var, only: var_t, T_LOGICAL, LO_NONE, LO_GT, LO_GE, HI_NONE, HI_LT
  use input_text, only: num_str, int_str, allowed_words
  implicit none
  private
  public :: TABLE_HEADER, table_row, range_text, allowed_text

  character(len=*), parameter :: TABLE_HEADER(2) = [character(len=49) :: &
    '| variable | type | default | allowed | meaning |', '|---|---|---|---|---|']

contains

  !> The row of v: `name` | type | `default` | allowed | meaning, with
  !> default the value's namelist text (for a two-dimensional array: all 0.0).
  function table_row(v, default) result(line)
    type(var_t), intent(in) :: v
    character(len=*), intent(in) :: default
    character(len=:), allocatable :: line
    character(len=*), parameter :: TYPES(4) = [character(len=7) :: 'integer', 'real', &
                                                'string', 'logical']
    character(len=:), allocatable :: typ, text, meaning
    typ = trim(TYPES(v%type))
    if (v%dims(2) > 0) then
      typ = typ // '(' // int_str(v%dims(1)) // ',' // int_str(v%dims(2)) // ')'
      text = 'all `0.0`'
    else
      if (v%dims(1) > 0) typ = typ // '(' // int_str(v%dims(1)) // ')'
      text = '`' // default // '`'
    end if
    meaning = trim(v%doc)
    if (len(meaning) == 0) meaning = trim(v%help)
    line = '| `' // trim(v%name) // '` | ' // typ // ' | ' // text // ' | ' // &
           md_cell(allowed(v)) // ' | ' // md_cell(meaning) // ' |'
  end function table_row

  !> What is allowed for v, as doc/reference/input.md writes it: the words, the range
  !> (range_text, as the messages say it), then the rule, if any.
  function allowed(v) result(s)
    type(var_t), intent(in) :: v
    character(len=:), allocatable :: s
    integer :: k
    s = ''
    if (size(v%words) > 0) then
      do k = 1, size(v%words)
        if (k > 1) s = s // ', '
        s = s // "`'" // trim(v%words(k)) // "'`"
      end do
    else if (v%lo_rule /= LO_NONE .or. v%hi_rule /= HI_NONE) then
      s = range_text(v)
    else if (v%type == T_LOGICAL) then
      s = '`.true.`, `.false.`'
    end if
    if (len_trim(v%rule) > 0) then
      if (len(s) > 0) s = s // ', '
      s = s // trim(v%rule)
    end if
  end function allowed

  !> What is allowed for v, e.g. "0 < cfl <= 3" or "one of 'rk4', 'pc2'".
  function allowed_text(v) result(s)
    type(var_t), intent(in) :: v
    character(len=:), allocatable :: s
    if (size(v%words) > 0) then
      s = 'one of ' // allowed_words(v%words)
    else if (v%lo_rule /= LO_NONE .or. v%hi_rule /= HI_NONE) then
      s = range_text(v)
    else if (v%type == T_LOGICAL) then
      s = '.true. or .false.'
    else
      s = trim(v%rule)
    end if
  end function allowed_text

  !> s with every | escaped, for a markdown table cell.
  function md_cell(s) result(t)
    character(len=*), intent(in) :: s
    character(len=:), allocatable :: t
    integer :: k
    t = ''
    do k = 1, len(s)
      if (s(k:k) == '|') t = t // '\'
      t = t // s(k:k)
    end do
  end function md_cell

  !> The range of v as --help and the messages say it: lo < name <= hi,
  !> name >= lo, name < hi, ...; '' for a variable without bounds.
  function range_text(v) result(s)
    type(var_t), intent(in) :: v
    character(len=:), allocatable :: s
    character(len=:), allocatable :: name
    name = trim(v%name)
    if (v%lo_rule /= LO_NONE .and. v%hi_rule /= HI_NONE) then
      s = num_str(v%lo) // below(v%lo_rule == LO_GT) // name // below(v%hi_rule == HI_LT) // &
          num_str(v%hi)
    else if (v%lo_rule == LO_GT) then
      s = name // ' > ' // num_str(v%lo)
    else if (v%lo_rule == LO_GE) then
      s = name // ' >= ' // num_str(v%lo)
    else if (v%hi_rule /= HI_NONE) then
      s = name // below(v%hi_rule == HI_LT) // num_str(v%hi)
    else
      s = ''
    end if
  end function range_text

  !> ' < ' when strict, else ' <= '.
  function below(strict) result(s)
    logical, intent(in) :: strict
    character(len=:), allocatable :: s
    s = ' <= '
    if (strict) s = ' < '
  end function below

end module input_tables
