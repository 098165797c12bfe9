!> The tables of doc/input.md: one markdown row per input variable, made
!> from its description (var_t) alone, so that the documentation is the
!> program's (config_write_input_tables writes them; `make input-doc`).
module input_tables
  use input_var, only: var_t, T_LOGICAL, LO_NONE, LO_GT, LO_GE, HI_NONE, HI_LT, HI_LE, CH_NONE
  use input_text, only: num_str, int_str
  implicit none
  private
  public :: TABLE_HEADER, table_row, lo_op, hi_op

  character(len=*), parameter :: TABLE_HEADER(2) = [character(len=49) :: &
    '| variable | type | default | allowed | meaning |', '|---|---|---|---|---|']

contains

  !> The row of v: `name` | type | `default` | allowed | meaning, with
  !> default the value's namelist text ('' for an array of probes: all 0.0)
  !> and words the allowed words of v%choices.
  function table_row(v, default, words) result(line)
    type(var_t), intent(in) :: v
    character(len=*), intent(in) :: default, words(:)
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
           md_cell(allowed(v, words)) // ' | ' // md_cell(meaning) // ' |'
  end function table_row

  !> What is allowed for v, as doc/input.md writes it: the words, the range
  !> (lo .. hi when both ends are included), then the rule, if any.
  function allowed(v, words) result(s)
    type(var_t), intent(in) :: v
    character(len=*), intent(in) :: words(:)
    character(len=:), allocatable :: s
    integer :: k
    s = ''
    if (v%choices /= CH_NONE) then
      do k = 1, size(words)
        if (k > 1) s = s // ', '
        s = s // "`'" // trim(words(k)) // "'`"
      end do
    else if (v%lo_rule == LO_GE .and. v%hi_rule == HI_LE) then
      s = num_str(v%lo) // ' .. ' // num_str(v%hi)
    else if (v%lo_rule /= LO_NONE .and. v%hi_rule /= HI_NONE) then
      s = num_str(v%lo) // lo_op(v%lo_rule) // trim(v%name) // hi_op(v%hi_rule) // num_str(v%hi)
    else if (v%lo_rule /= LO_NONE) then
      s = merge('> ', '>=', v%lo_rule == LO_GT)
      s = trim(s) // ' ' // num_str(v%lo)
    else if (v%hi_rule /= HI_NONE) then
      s = merge('< ', '<=', v%hi_rule == HI_LT)
      s = trim(s) // ' ' // num_str(v%hi)
    else if (v%type == T_LOGICAL) then
      s = '`.true.`, `.false.`'
    end if
    if (len_trim(v%rule) > 0) then
      if (len(s) > 0) s = s // ', '
      s = s // trim(v%rule)
    end if
  end function allowed

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

  !> ' < ' or ' <= ' for a lower bound rule (LO_GT, LO_GE).
  function lo_op(rule) result(s)
    integer, intent(in) :: rule
    character(len=:), allocatable :: s
    s = ' <= '
    if (rule == LO_GT) s = ' < '
  end function lo_op

  !> ' < ' or ' <= ' for an upper bound rule (HI_LT, HI_LE).
  function hi_op(rule) result(s)
    integer, intent(in) :: rule
    character(len=:), allocatable :: s
    s = ' <= '
    if (rule == HI_LT) s = ' < '
  end function hi_op

end module input_tables
