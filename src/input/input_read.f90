!> Reading an input (input_visit's input_t) from a namelist file and
!> command-line overrides `group.variable=value`, and the check of each
!> value against its row.  Every error is one message naming where, the
!> group, the variable, the offending value and what is allowed.
!>
!> A file is first cut into groups by a small scanner that respects quotes and
!> `!` comments, so that unknown, repeated or unclosed groups and text outside
!> any group are caught (gfortran would skip them silently).  Each group body
!> is then cut into its `name = value` items and each item is read on its own
!> by an internal namelist read: gfortran's iomsg does not say which item
!> failed, reading item by item does, and gives its line.  Overrides go
!> through the same item reader.  No output here, and no MPI: every rank
!> reads the same file the same way and reaches the same verdict.
module input_read
  use, intrinsic :: ieee_arithmetic, only: ieee_is_finite
  use kinds, only: wp
  use input_text, only: fail, closest, allowed_words, quoted_list, quoted, shown_value, &
                        unquoted, value_is_bare, base_name, word_at, name_end_at, lower, &
                        int_str, num_str, list_items
  use namelist_scan, only: load_text, find_group_end, split_items
  use input_tables, only: allowed_text
  use input_var, only: var_t, group_t, T_INT, T_REAL, T_STRING, T_LOGICAL, LO_NONE, LO_GT, &
                       LO_GE, HI_NONE, HI_LT, HI_LE
  use input_visit, only: input_t, list_input, read_input_item, normalise_input
  implicit none
  private
  public :: origin_t, read_input, check_values, origin_of

  ! How an item read ended.
  integer, parameter :: ITEM_OK = 0, ITEM_UNKNOWN = 1, ITEM_FAILED = 2

  !> Where a variable was last set: line of the file, or 0 for the command line.
  type :: origin_t
    character(len=60) :: key   !< 'group.name'
    integer :: line
  end type origin_t

contains

  !> Reads the namelist file `path` into x, which holds the defaults (groups
  !> may be left out), then applies the overrides in order, then puts the
  !> word-valued variables in lower case.  err is allocated with the message
  !> at the first error; origins say where each variable was last set.
  subroutine read_input(path, overrides, x, origins, err)
    character(len=*), intent(in) :: path
    character(len=*), intent(in) :: overrides(:)
    class(input_t), intent(inout) :: x
    type(origin_t), allocatable, intent(out) :: origins(:)
    character(len=:), allocatable, intent(inout) :: err
    type(group_t), allocatable :: groups(:)
    type(var_t), allocatable :: defaults(:)
    integer :: k
    call list_input(x, groups, defaults)
    allocate(origins(0))
    call read_file(path, groups, defaults, x, origins, err)
    if (allocated(err)) return
    do k = 1, size(overrides)
      call apply_override(overrides(k), groups, defaults, x, origins, err)
      if (allocated(err)) return
    end do
    call normalise_input(x)
  end subroutine read_input

  !> Every value on its own: in the range of its row, one of its words.
  !> Messages name where the value was set.
  subroutine check_values(x, path, origins, err)
    class(input_t), intent(in) :: x
    character(len=*), intent(in) :: path
    type(origin_t), intent(in) :: origins(:)
    character(len=:), allocatable, intent(inout) :: err
    type(group_t), allocatable :: groups(:)
    type(var_t), allocatable :: vars(:)
    character(len=:), allocatable :: origin, head, group
    real(wp) :: x_k
    integer :: k, line
    call list_input(x, groups, vars)
    do k = 1, size(vars)
      group = trim(groups(vars(k)%group)%name)
      call origin_of(origins, path, group // '.' // trim(vars(k)%name), origin, line)
      head = '&' // group // ' ' // trim(vars(k)%name) // ' = ' // vars(k)%value
      if (vars(k)%lo_rule /= LO_NONE .or. vars(k)%hi_rule /= HI_NONE) then
        read(vars(k)%value, *) x_k
        if (.not. in_range(vars(k), x_k)) then
          call fail(err, origin, head // ' is out of range', line, &
                    ': allowed ' // allowed_text(vars(k)))
          return
        end if
      else if (size(vars(k)%words) > 0) then
        if (.not. any(quoted_list(vars(k)%words) == vars(k)%value)) then
          call fail(err, origin, head // ' is not allowed', line, &
                    ': choose one of ' // allowed_words(vars(k)%words))
          return
        end if
      end if
    end do
  end subroutine check_values

  logical function in_range(v, x)
    type(var_t), intent(in) :: v
    real(wp), intent(in) :: x
    ! No comparison with a NaN: it would raise IEEE invalid (trapped in debug builds).
    in_range = ieee_is_finite(x)
    if (.not. in_range) return
    if (v%lo_rule == LO_GT) in_range = in_range .and. x > v%lo
    if (v%lo_rule == LO_GE) in_range = in_range .and. x >= v%lo
    if (v%hi_rule == HI_LT) in_range = in_range .and. x < v%hi
    if (v%hi_rule == HI_LE) in_range = in_range .and. x <= v%hi
  end function in_range

  ! ------------------------------------------------------------------------
  ! The file
  ! ------------------------------------------------------------------------

  !> Reads the groups of the file into x, recording where each variable
  !> was set.  err is allocated (with the message) on the first error.
  subroutine read_file(path, groups, vars, x, origins, err)
    character(len=*), intent(in) :: path
    type(group_t), intent(in) :: groups(:)
    type(var_t), intent(in) :: vars(:)
    class(input_t), intent(inout) :: x
    type(origin_t), allocatable, intent(inout) :: origins(:)
    character(len=:), allocatable, intent(inout) :: err
    character(len=:), allocatable :: buf
    integer, allocatable :: line_of(:)
    integer :: pos, name_end, term, term_len, g
    integer, allocatable :: first_line(:)
    character(len=:), allocatable :: name

    call load_text(path, buf, line_of, err)
    if (allocated(err)) return
    allocate(first_line(size(groups)), source=0)
    pos = 1
    do
      ! Outside a group only blanks and '&name' may appear.
      do while (pos <= len(buf))
        if (buf(pos:pos) /= ' ') exit
        pos = pos + 1
      end do
      if (pos > len(buf)) exit
      if (buf(pos:pos) /= '&') then
        call fail(err, path, 'text ''' // word_at(buf, pos) // ''' outside any namelist group', &
                  line_of(pos), ': a group is written &name ... / and a value containing ' // &
                  '''/'' must be in quotes')
        return
      end if
      name_end = name_end_at(buf, pos + 1)
      name = lower(buf(pos + 1:name_end))
      if (len(name) == 0) then
        call fail(err, path, '''&'' without a group name', line_of(pos), '')
        return
      end if
      g = group_index(groups, name)
      if (g == 0) then
        call fail(err, path, 'unknown namelist group &' // name, line_of(pos), &
                  unknown_group_hint(groups, name))
        return
      end if
      if (first_line(g) > 0) then
        call fail(err, path, '&' // name // ' appears twice', line_of(pos), &
                  ': it already appeared on line ' // int_str(first_line(g)) // &
                  '; give each group once')
        return
      end if
      first_line(g) = line_of(pos)
      call find_group_end(buf, name_end + 1, term, term_len)
      if (term == 0) then
        call fail(err, path, '&' // name // ' is not closed', line_of(pos), &
                  ': end it with ''/''')
        return
      else if (term_len == 0) then
        call fail(err, path, '&' // name // ' is not closed', line_of(pos), &
                  ': end it with ''/'' before &' // lower(word_at(buf, term + 1)) // &
                  ' on line ' // int_str(line_of(term)))
        return
      end if
      call read_group_body(g, buf(name_end + 1:term - 1), line_of(name_end + 1:term - 1), &
                           path, groups, vars, x, origins, err)
      if (allocated(err)) return
      pos = term + term_len
    end do
    ! an empty file would silently run every default: surely not meant
    if (all(first_line == 0)) call fail(err, path, 'holds no namelist group', 0, &
      ': the file is empty or only comments; give at least &run case = ''circle2d'' / ' // &
      '(./sph --defaults writes a complete file)')
  end subroutine read_file

  !> Reads the items of one group body (from the file) into x.
  subroutine read_group_body(g, body, line_of, path, groups, vars, x, origins, err)
    integer, intent(in) :: g
    character(len=*), intent(in) :: body
    integer, intent(in) :: line_of(:)
    character(len=*), intent(in) :: path
    type(group_t), intent(in) :: groups(:)
    type(var_t), intent(in) :: vars(:)
    class(input_t), intent(inout) :: x
    type(origin_t), allocatable, intent(inout) :: origins(:)
    character(len=:), allocatable, intent(inout) :: err
    integer, allocatable :: starts(:), eqs(:)
    character(len=40), allocatable :: plain(:)
    integer, allocatable :: plain_line(:)
    character(len=:), allocatable :: group, name, value, reason, hint, head
    integer :: i, last, status, line, k, v, e
    ! per array variable of the group, the line that set each element (0:
    ! none yet), in array element order, from elem_first(v)
    integer, allocatable :: elem_line(:), elem_first(:)
    logical, allocatable :: now(:)

    group = trim(groups(g)%name)
    allocate(elem_first(size(vars)), elem_line(0), now(0))
    do v = 1, size(vars)
      elem_first(v) = size(elem_line) + 1
      if (vars(v)%group == g .and. vars(v)%dims(1) > 0) &
        elem_line = [elem_line, spread(0, 1, element_count(vars(v)))]
    end do
    call split_items(body, starts, eqs)
    last = len(body)
    if (size(starts) > 0) last = starts(1) - 1
    if (len_trim(body(1:last)) > 0) then
      call fail(err, path, '&' // group // ': ''' // trim(adjustl(body(1:last))) &
                // ''' is not of the form name = value', line_of(max(1, verify(body, ' '))), '')
      return
    end if
    allocate(plain(0), plain_line(0))
    do i = 1, size(starts)
      last = len(body)
      if (i < size(starts)) last = starts(i + 1) - 1
      name = lower(trim(body(starts(i):eqs(i) - 1)))
      value = body(eqs(i) + 1:last)
      line = line_of(starts(i))
      ! A scalar or whole array set twice in one group is a slip, not intent.
      if (index(name, '(') == 0) then
        do k = size(plain), 1, -1
          if (plain(k) == name) exit
        end do
        if (k > 0) then
          call fail(err, path, '&' // group // ' ' // name // ' is set twice', &
                    line, ': it was already set on line ' // int_str(plain_line(k)) // &
                    '; keep one')
          return
        end if
        plain = [character(len=40) :: plain, name]
        plain_line = [plain_line, line]
      end if
      call read_item(g, name, value, groups, vars, x, status, reason, hint)
      if (status == ITEM_UNKNOWN) then
        call fail(err, path, reason, line, hint)
        return
      else if (status == ITEM_FAILED) then
        head = '&' // group // ' ' // name
        if (len(shown_value(value)) > 0) head = head // ' = ' // shown_value(value)
        call fail(err, path, head // ' ' // reason, line, hint)
        return
      end if
      ! An element of an array set twice is the same slip as a scalar
      v = var_index(vars, g, base_name(name))
      if (v > 0) then
        if (vars(v)%dims(1) > 0) then
          now = elements_set(vars(v), name, value, x)
          associate(seen => elem_line(elem_first(v):elem_first(v) + size(now) - 1))
          do e = 1, size(now)
            if (now(e) .and. seen(e) > 0) then
              call fail(err, path, '&' // group // ' ' // element_name(vars(v), e) // &
                        ' is set twice', line, ': it was already set on line ' // &
                        int_str(seen(e)) // '; keep one')
              return
            end if
          end do
          where (now) seen = line
          end associate
        end if
      end if
      call set_origin(origins, group // '.' // base_name(name), line)
    end do
  end subroutine read_group_body

  !> The elements of array variable v that the item `name = value`, read
  !> already without error, sets, in array element order: read once over
  !> zeros and once over ones, an element is set where both reads give the
  !> same value (the value text is exact).  Numeric arrays only: the inputs
  !> have no others.
  function elements_set(v, name, value, x) result(set)
    type(var_t), intent(in) :: v
    character(len=*), intent(in) :: name, value
    class(input_t), intent(in) :: x
    logical, allocatable :: set(:)
    class(input_t), allocatable :: x0, x1
    character(len=256) :: iomsg
    integer :: ios, n
    n = element_count(v)
    allocate(x0, source=x)
    allocate(x1, source=x)
    iomsg = ''
    call read_input_item(x0, v%group, trim(v%name), int_str(n) // '*0', ios, iomsg)
    call read_input_item(x1, v%group, trim(v%name), int_str(n) // '*1', ios, iomsg)
    call read_input_item(x0, v%group, name, value, ios, iomsg)
    call read_input_item(x1, v%group, name, value, ios, iomsg)
    set = list_items(value_of(x0, v), n) == list_items(value_of(x1, v), n)
  end function elements_set

  !> The value of variable v (a row of x's) in x.
  function value_of(x, v) result(text)
    class(input_t), intent(in) :: x
    type(var_t), intent(in) :: v
    character(len=:), allocatable :: text
    type(group_t), allocatable :: groups(:)
    type(var_t), allocatable :: vars(:)
    call list_input(x, groups, vars)
    text = vars(var_index(vars, v%group, trim(v%name)))%value
  end function value_of

  !> The number of elements of array variable v.
  pure integer function element_count(v)
    type(var_t), intent(in) :: v
    element_count = v%dims(1) * max(1, v%dims(2))
  end function element_count

  !> name(i) or name(i,k) of element e (in array element order) of v.
  function element_name(v, e) result(s)
    type(var_t), intent(in) :: v
    integer, intent(in) :: e
    character(len=:), allocatable :: s
    s = trim(v%name) // '(' // int_str(mod(e - 1, v%dims(1)) + 1)
    if (v%dims(2) > 0) s = s // ',' // int_str((e - 1) / v%dims(1) + 1)
    s = s // ')'
  end function element_name

  ! ------------------------------------------------------------------------
  ! Overrides
  ! ------------------------------------------------------------------------

  !> Applies one "group.variable=value" to x.  A string value without
  !> quotes gets them, so that output.dir=runs/x works ('/' would end the
  !> namelist input otherwise).
  subroutine apply_override(text, groups, vars, x, origins, err)
    character(len=*), intent(in) :: text
    type(group_t), intent(in) :: groups(:)
    type(var_t), intent(in) :: vars(:)
    class(input_t), intent(inout) :: x
    type(origin_t), allocatable, intent(inout) :: origins(:)
    character(len=:), allocatable, intent(inout) :: err
    character(len=*), parameter :: ORIGIN = 'command line'
    character(len=:), allocatable :: ov, lhs, gname, name, value, reason, hint
    integer, allocatable :: starts(:), eqs(:)
    integer :: eq, dot, g, v, status

    ov = trim(adjustl(text))
    eq = index(ov, '=')
    if (eq == 0) then
      call fail(err, ORIGIN, 'override ''' // ov // ''' has no ''=value''', 0, &
                ': write group.variable=value, e.g. numerics.cfl=0.5')
      return
    end if
    lhs = lower(trim(ov(1:eq - 1)))
    value = trim(adjustl(ov(eq + 1:)))
    dot = index(lhs, '.')
    if (dot == 0) then
      call fail(err, ORIGIN, 'override ''' // ov // ''' does not name a group', 0, &
                ': write group.variable=value' // group_guess(groups, vars, base_name(lhs), &
                                                               ov(eq:)))
      return
    end if
    gname = trim(adjustl(lhs(1:dot - 1)))
    name = trim(adjustl(lhs(dot + 1:)))
    g = group_index(groups, gname)
    if (g == 0) then
      call fail(err, ORIGIN, 'override ''' // ov // ''': unknown namelist group &' // gname, 0, &
                unknown_group_hint(groups, gname))
      return
    end if
    v = var_index(vars, g, base_name(name))
    if (v > 0) then
      if (vars(v)%type == T_STRING .and. len(value) > 0) then
        if (value(1:1) /= '''' .and. value(1:1) /= '"') value = quoted(value)
      end if
    end if
    ! One override sets one variable: "numerics.cfl=0.5 kernel='x'" is a slip.
    call split_items(name // '=' // value, starts, eqs)
    if (size(starts) > 1) then
      call fail(err, ORIGIN, 'override ''' // ov // ''' sets more than one variable', 0, &
                ': give one group.variable=value per override')
      return
    end if
    call read_item(g, name, value, groups, vars, x, status, reason, hint)
    if (status == ITEM_UNKNOWN) then
      call fail(err, ORIGIN, 'override ''' // ov // ''': ' // reason, 0, hint)
      return
    else if (status == ITEM_FAILED) then
      call fail(err, ORIGIN, ov // ' ' // reason, 0, hint)
      return
    end if
    call set_origin(origins, gname // '.' // base_name(name), 0)
  end subroutine apply_override

  !> For an override without a group: the group.variable it probably meant.
  function group_guess(groups, vars, name, rest) result(s)
    type(group_t), intent(in) :: groups(:)
    type(var_t), intent(in) :: vars(:)
    character(len=*), intent(in) :: name, rest
    character(len=:), allocatable :: s
    integer :: k, found
    s = ''
    found = 0
    do k = 1, size(vars)
      if (vars(k)%name /= name) cycle
      if (found > 0) return   ! in several groups: no single guess
      found = k
    end do
    if (found > 0) s = ', e.g. ' // trim(groups(vars(found)%group)%name) // '.' // name // rest
  end function group_guess

  ! ------------------------------------------------------------------------
  ! One item
  ! ------------------------------------------------------------------------

  !> Reads `name = value` of group g into x.  On failure, status /= ITEM_OK,
  !> reason says what went wrong (for ITEM_UNKNOWN, the whole clause "&g has
  !> no variable 'x'") and hint what to do (starting with ':' or ';', or
  !> empty).  vars: the rows, with the defaults as values.
  subroutine read_item(g, name, value, groups, vars, x, status, reason, hint)
    integer, intent(in) :: g
    character(len=*), intent(in) :: name, value
    type(group_t), intent(in) :: groups(:)
    type(var_t), intent(in) :: vars(:)
    class(input_t), intent(inout) :: x
    integer, intent(out) :: status
    character(len=:), allocatable, intent(out) :: reason, hint
    character(len=*), parameter :: NEUTRAL(4) = ['0  ', '0  ', "'' ", 'F  ']
    character(len=:), allocatable :: base
    class(input_t), allocatable :: trial
    character(len=512) :: iomsg
    real(wp) :: r
    integer :: v, ios

    base = base_name(name)
    hint = ''
    reason = ''
    status = ITEM_FAILED
    v = var_index(vars, g, base)
    if (v == 0) then
      status = ITEM_UNKNOWN
      reason = '&' // trim(groups(g)%name) // ' has no variable ''' // trim(name) // ''''
      hint = unknown_var_hint(groups, vars, g, base)
      return
    end if
    if (len_trim(shown_value(value)) == 0) then
      reason = 'has no value'
      hint = ': give one, or leave the variable out for its default (' // &
             default_text(vars(v)) // ')'
      return
    end if
    ! '/' ends namelist input: numerics.cfl=1/2 would silently read 1.
    if (scan(unquoted(value), '/') > 0) then
      reason = 'cannot be read as ' // type_text(vars(v))
      hint = ': a ''/'' outside quotes ends the namelist input'
      return
    end if
    ! gfortran reads any .word. by its first letter (.tomato. as true)
    if (vars(v)%type == T_LOGICAL) then
      select case (lower(trim(adjustl(shown_value(value)))))
      case ('.true.', '.false.', '.t.', '.f.', 't', 'f')
      case default
        reason = 'cannot be read as ' // type_text(vars(v))
        hint = ': write .true. or .false.'
        return
      end select
    end if
    call read_input_item(x, g, name, value, ios, iomsg)
    if (ios == 0) then
      status = ITEM_OK
      return
    end if
    if (index(name, '(') > 0) then
      ! A subscript that is not one (unbalanced, a stray ':'): said as such
      if (.not. subscript_ok(name(index(name, '(') + 1:))) then
        reason = 'has a malformed subscript'
        hint = ': write e.g. ' // base // '(1:3,2) = ...'
        return
      end if
      ! Is the index at fault rather than the value?  Try a value that fits.
      allocate(trial, source=x)
      call read_input_item(trial, g, name, trim(NEUTRAL(vars(v)%type)), ios, iomsg)
      if (ios /= 0) then
        if (vars(v)%dims(1) == 0) then
          reason = 'has an index, but ' // base // ' is not an array'
        else
          reason = 'has an index outside ' // base // shape_text(vars(v))
        end if
        return
      end if
    end if
    reason = 'cannot be read as ' // type_text(vars(v))
    select case (vars(v)%type)
    case (T_INT)
      read(value, *, iostat=ios) r
      if (verify(shown_value(value), '+-0123456789') == 0) then
        hint = ': it is too large'
        if (vars(v)%hi_rule /= HI_NONE) hint = hint // '; allowed ' // allowed_text(vars(v))
      else if (ios == 0) then
        hint = ': write a whole number'
        if (ieee_is_finite(r)) hint = hint // ', e.g. ' // num_str(anint(r))
      end if
    case (T_STRING)
      if (value_is_bare(value)) then
        hint = ': put it in quotes, e.g. ' // base // ' = ' // quoted(shown_value(value))
      else
        hint = ': give one string in quotes'
      end if
    case (T_LOGICAL)
      hint = ': write .true. or .false.'
    end select
  end subroutine read_item

  !> text is 'sub)' for a subscript: comma-separated whole numbers or
  !> ranges lo:hi, and the closing parenthesis.
  pure logical function subscript_ok(text) result(ok)
    character(len=*), intent(in) :: text
    character(len=:), allocatable :: inner, part
    integer :: k, start, n
    ok = .false.
    n = len_trim(text)
    if (n < 2) return
    if (text(n:n) /= ')') return
    inner = text(1:n - 1)
    if (verify(inner, '0123456789:, ') /= 0) return
    start = 1
    do k = 1, len(inner) + 1
      if (k <= len(inner)) then
        if (inner(k:k) /= ',') cycle
      end if
      ! one part: a number, or lo:hi with both
      part = trim(adjustl(inner(start:k - 1)))
      if (len(part) == 0) return
      if (part(1:1) == ':' .or. part(len(part):len(part)) == ':') return
      if (index(part, ':') /= index(part, ':', back=.true.)) return
      start = k + 1
    end do
    ok = .true.
  end function subscript_ok

  ! ------------------------------------------------------------------------
  ! Messages
  ! ------------------------------------------------------------------------

  !> The default of v (a row listed from the defaults) as text, for hints.
  function default_text(v) result(s)
    type(var_t), intent(in) :: v
    character(len=:), allocatable :: s
    if (v%dims(2) > 0) then
      s = 'all 0.0'
    else
      s = v%value
    end if
  end function default_text

  !> "; did you mean &numerics? The groups are &run, &particles, ...".
  function unknown_group_hint(groups, name) result(s)
    type(group_t), intent(in) :: groups(:)
    character(len=*), intent(in) :: name
    character(len=:), allocatable :: s
    character(len=:), allocatable :: best
    integer :: k
    best = closest(name, groups%name)
    s = '; the groups are'
    if (len(best) > 0) s = '; did you mean &' // best // '? The groups are'
    do k = 1, size(groups)
      s = s // ' &' // trim(groups(k)%name)
      if (k < size(groups)) s = s // ','
    end do
  end function unknown_group_hint

  !> "; did you mean 'cfl'? The variables of &numerics are kernel, ...".
  function unknown_var_hint(groups, vars, g, name) result(s)
    type(group_t), intent(in) :: groups(:)
    type(var_t), intent(in) :: vars(:)
    integer, intent(in) :: g
    character(len=*), intent(in) :: name
    character(len=:), allocatable :: s
    character(len=:), allocatable :: best
    integer :: k
    logical :: first
    best = closest(name, pack(vars%name, vars%group == g))
    s = '; the variables of &' // trim(groups(g)%name) // ' are'
    if (len(best) > 0) s = '; did you mean ''' // best // '''? The variables of &' // &
                           trim(groups(g)%name) // ' are'
    first = .true.
    do k = 1, size(vars)
      if (vars(k)%group /= g) cycle
      if (.not. first) s = s // ','
      s = s // ' ' // trim(vars(k)%name)
      first = .false.
    end do
  end function unknown_var_hint

  !> "a real number", "an integer", ... for "cannot be read as ...".
  function type_text(v) result(s)
    type(var_t), intent(in) :: v
    character(len=:), allocatable :: s
    select case (v%type)
    case (T_INT)
      s = 'an integer'
    case (T_REAL)
      s = 'a real number'
      if (v%dims(1) > 0) s = 'real numbers for ' // trim(v%name) // shape_text(v)
    case (T_STRING)
      s = 'a string'
    case default
      s = 'a logical'
    end select
  end function type_text

  !> The index ranges of an array variable, e.g. "(1:3, 1:16)".
  function shape_text(v) result(s)
    type(var_t), intent(in) :: v
    character(len=:), allocatable :: s
    s = '(1:' // int_str(v%dims(1))
    if (v%dims(2) > 0) s = s // ', 1:' // int_str(v%dims(2))
    s = s // ')'
  end function shape_text

  !> Where the value of variable `k` ('group.name') was last set, for a
  !> message: the command line, or the file and its line (0 if a default).
  subroutine origin_of(origins, path, k, origin, line)
    type(origin_t), intent(in) :: origins(:)
    character(len=*), intent(in) :: path, k
    character(len=:), allocatable, intent(out) :: origin
    integer, intent(out) :: line
    integer :: i
    origin = path
    line = 0
    do i = size(origins), 1, -1
      if (origins(i)%key /= k) cycle
      line = origins(i)%line
      if (line == 0) origin = 'command line'
      return
    end do
  end subroutine origin_of

  subroutine set_origin(origins, k, line)
    type(origin_t), allocatable, intent(inout) :: origins(:)
    character(len=*), intent(in) :: k
    integer, intent(in) :: line
    origins = [origins, origin_t(k, line)]
  end subroutine set_origin

  integer function group_index(groups, name)
    type(group_t), intent(in) :: groups(:)
    character(len=*), intent(in) :: name
    integer :: k
    group_index = 0
    do k = 1, size(groups)
      if (groups(k)%name == name) group_index = k
    end do
  end function group_index

  integer function var_index(vars, g, name)
    type(var_t), intent(in) :: vars(:)
    integer, intent(in) :: g
    character(len=*), intent(in) :: name
    integer :: k
    var_index = 0
    do k = 1, size(vars)
      if (vars(k)%group == g .and. vars(k)%name == name) var_index = k
    end do
  end function var_index

end module input_read
