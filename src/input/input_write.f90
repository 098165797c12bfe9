!> An input (input_visit's input_t) written out from its rows: a commented
!> namelist file that reads back exactly (`--defaults`, the run's
!> input.nml), the reference of `--help`, and the tables of
!> doc/reference/input.md (`--input-tables`).
module input_write
  use input_text, only: pad, int_str, list_items, joined
  use input_tables, only: TABLE_HEADER, table_row, allowed_text
  use input_var, only: var_t, group_t
  use input_visit, only: input_t, list_input
  implicit none
  private
  public :: write_input, write_help, write_tables

contains

  !> Writes x as a namelist file with every group and variable, each with a
  !> comment saying what it is and what is allowed; it reads back to x
  !> exactly.  title: the lines of the comment at the top.
  subroutine write_input(x, unit, title)
    class(input_t), intent(in) :: x
    integer, intent(in) :: unit
    character(len=*), intent(in) :: title(:)
    type(group_t), allocatable :: groups(:)
    type(var_t), allocatable :: vars(:)
    character(len=40), allocatable :: items(:)
    character(len=:), allocatable :: count_text
    integer :: g, k, p, n, in_use
    logical :: first

    call list_input(x, groups, vars)
    do k = 1, size(title)
      write(unit, '(a)') trim('! ' // title(k))
    end do
    do g = 1, size(groups)
      write(unit, '(a)') '', '! ' // groups(g)%help, '&' // trim(groups(g)%name)
      do k = 1, size(vars)
        associate(v => vars(k))
        if (v%group /= g) cycle
        if (v%dims(2) > 0) then
          ! one line per column in use or set (the rest stay zero)
          n = v%dims(1)
          items = list_items(v%value, n * v%dims(2))
          count_text = value_in(vars, g, v%count)
          read(count_text, *) in_use
          first = .true.
          do p = 1, v%dims(2)
            if (p > max(1, in_use) .and. all(items((p - 1) * n + 1:p * n) == '0.0')) cycle
            call write_item(unit, trim(v%name) // '(1:' // int_str(n) // ',' // int_str(p) // &
                            ')', joined(items((p - 1) * n + 1:p * n)), v, first)
            first = .false.
          end do
        else
          call write_item(unit, trim(v%name), v%value, v, .true.)
        end if
        end associate
      end do
      write(unit, '(a)') '/'
    end do
  end subroutine write_input

  !> The reference of `sph --help`: every variable of x (at its defaults)
  !> as group.variable = default with what is allowed.
  subroutine write_help(x, unit)
    class(input_t), intent(in) :: x
    integer, intent(in) :: unit
    type(group_t), allocatable :: groups(:)
    type(var_t), allocatable :: vars(:)
    character(len=:), allocatable :: text, lhs
    integer :: k
    call list_input(x, groups, vars)
    do k = 1, size(vars)
      lhs = trim(groups(vars(k)%group)%name) // '.' // trim(vars(k)%name)
      text = vars(k)%value
      if (vars(k)%dims(2) > 0) then
        lhs = lhs // '(1:' // int_str(vars(k)%dims(1)) // ',k)'
        text = joined(list_items(text, vars(k)%dims(1)))
      end if
      write(unit, '(a)') '  ' // pad(lhs // ' = ' // text, 40) // ' ' // allowed_text(vars(k))
    end do
  end subroutine write_help

  !> The tables of doc/reference/input.md (markdown): for each group of x (at
  !> its defaults) a line `&group` and the table of its variables.
  subroutine write_tables(x, unit)
    class(input_t), intent(in) :: x
    integer, intent(in) :: unit
    type(group_t), allocatable :: groups(:)
    type(var_t), allocatable :: vars(:)
    integer :: g, k
    call list_input(x, groups, vars)
    do g = 1, size(groups)
      write(unit, '(a)') '&' // trim(groups(g)%name), (trim(TABLE_HEADER(k)), k = 1, 2)
      do k = 1, size(vars)
        if (vars(k)%group == g) write(unit, '(a)') table_row(vars(k), vars(k)%value)
      end do
      write(unit, '(a)') ''
    end do
  end subroutine write_tables

  !> One line `  name = value   ! what it is (allowed: ...)`.
  subroutine write_item(unit, name, text, v, with_comment)
    integer, intent(in) :: unit
    character(len=*), intent(in) :: name, text
    type(var_t), intent(in) :: v
    logical, intent(in) :: with_comment
    character(len=:), allocatable :: line
    line = '  ' // name // ' = ' // text
    if (with_comment) line = pad(line, 36) // '  ! ' // trim(v%help) // ' (allowed: ' // &
                             allowed_text(v) // ')'
    write(unit, '(a)') line
  end subroutine write_item

  !> The value of variable `name` of group g.
  function value_in(vars, g, name) result(text)
    type(var_t), intent(in) :: vars(:)
    integer, intent(in) :: g
    character(len=*), intent(in) :: name
    character(len=:), allocatable :: text
    integer :: k
    text = ''
    do k = 1, size(vars)
      if (vars(k)%group == g .and. vars(k)%name == name) text = vars(k)%value
    end do
  end function value_in

end module input_write
