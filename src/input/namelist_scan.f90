!> The scanner of namelist files: the file as one string with comments
!> blanked and a line number per character, the end of a group body and the
!> `name = value` items in it, all respecting quotes.  It catches what an
!> intrinsic namelist read would skip silently (see config).
module namelist_scan
  use input_text, only: fail, lower, name_end_at, is_letter, is_name_char, os_reason
  implicit none
  private
  public :: load_text, find_group_end, split_items

contains

  !> The file as one string buf with comments blanked and each line end made
  !> a blank; line_of(i) is the line of buf(i:i).
  subroutine load_text(path, buf, line_of, err)
    character(len=*), intent(in) :: path
    character(len=:), allocatable, intent(out) :: buf
    integer, allocatable, intent(out) :: line_of(:)
    character(len=:), allocatable, intent(inout) :: err
    character(len=:), allocatable :: line
    character(len=512) :: iomsg
    integer :: u, ios, nline
    logical :: is_dir, quote_open
    !> the control characters no text file holds (tab, CR and form feed
    !> are text)
    character(len=*), parameter :: CONTROL = achar(0) // achar(1) // achar(2) // achar(3) // &
      achar(4) // achar(5) // achar(6) // achar(7) // achar(8) // achar(11) // achar(14) // &
      achar(15) // achar(16) // achar(17) // achar(18) // achar(19) // achar(20) // &
      achar(21) // achar(22) // achar(23) // achar(24) // achar(25) // achar(26) // &
      achar(27) // achar(28) // achar(29) // achar(30) // achar(31) // achar(127)

    buf = ''
    allocate(line_of(0))
    if (len_trim(path) == 0) then
      call fail(err, 'command line', 'no input file given', 0, &
                ': give a namelist file, e.g. input/circle2d.nml')
      return
    end if
    ! gfortran opens a directory without complaint and reads it as empty.
    inquire(file=trim(path) // '/.', exist=is_dir)
    if (is_dir) then
      call fail(err, path, 'cannot open the file', 0, ': it is a directory')
      return
    end if
    open(newunit=u, file=path, status='old', action='read', form='formatted', &
         iostat=ios, iomsg=iomsg)
    if (ios /= 0) then
      call fail(err, path, 'cannot open the file', 0, ': ' // os_reason(iomsg))
      return
    end if
    nline = 0
    do
      call read_line(u, line, ios, iomsg)
      if (ios < 0) exit
      if (ios > 0) then
        call fail(err, path, 'cannot read the file', 0, ': ' // trim(iomsg))
        close(u)
        return
      end if
      nline = nline + 1
      ! a UTF-8 byte-order mark, which some editors write first: not text
      ! of the namelist, so dropped (it would reach a message unseen)
      if (nline == 1 .and. len(line) >= 3) then
        if (ichar(line(1:1)) == 239 .and. ichar(line(2:2)) == 187 .and. &
            ichar(line(3:3)) == 191) line = line(4:)
      end if
      ! a binary file: said, not echoed to the terminal
      if (scan(line, CONTROL) > 0) then
        call fail(err, path, 'is not a text file', nline, &
                  ': it holds a control character (a namelist file is text)')
        close(u)
        return
      end if
      call strip_comment(line, quote_open)
      if (quote_open) then
        call fail(err, path, 'a quoted string is not closed', nline, &
                  ': ' // trim(adjustl(line)))
        close(u)
        return
      end if
      buf = buf // line // ' '
      line_of = [line_of, spread(nline, 1, len(line) + 1)]
    end do
    close(u)
  end subroutine load_text

  !> One line of any length; ios < 0 at the end of the file.
  subroutine read_line(u, line, ios, iomsg)
    integer, intent(in) :: u
    character(len=:), allocatable, intent(out) :: line
    integer, intent(out) :: ios
    character(len=*), intent(inout) :: iomsg
    character(len=1024) :: chunk
    integer :: n
    line = ''
    do
      read(u, '(a)', advance='no', iostat=ios, iomsg=iomsg, size=n) chunk
      line = line // chunk(1:n)
      if (ios /= 0) exit
    end do
    if (is_iostat_eor(ios)) ios = 0
    ! A last line without a newline is still a line.
    if (is_iostat_end(ios) .and. len(line) > 0) ios = 0
  end subroutine read_line

  !> Tabs and a trailing carriage return become blanks and a `!` comment is
  !> blanked (quotes respected); quote_open if a quote is left open.
  subroutine strip_comment(line, quote_open)
    character(len=*), intent(inout) :: line
    logical, intent(out) :: quote_open
    character(len=1) :: quote, ch
    integer :: i
    quote = ' '
    do i = 1, len(line)
      ch = line(i:i)
      if (ch == achar(9) .or. ch == achar(13)) line(i:i) = ' '
      if (quote /= ' ') then
        if (ch == quote) quote = ' '
      else if (ch == '''' .or. ch == '"') then
        quote = ch
      else if (ch == '!') then
        line(i:) = ' '
        exit
      end if
    end do
    quote_open = quote /= ' '
  end subroutine strip_comment

  !> The end of group body starting at buf(from:): term is the position of
  !> its '/' (term_len 1) or '&end' (term_len 4); term_len = 0 if another
  !> group starts first (term at its '&'); term = 0 if the file ends first.
  subroutine find_group_end(buf, from, term, term_len)
    character(len=*), intent(in) :: buf
    integer, intent(in) :: from
    integer, intent(out) :: term, term_len
    character(len=1) :: quote, ch
    integer :: i
    term = 0
    term_len = 0
    quote = ' '
    do i = from, len(buf)
      ch = buf(i:i)
      if (quote /= ' ') then
        if (ch == quote) quote = ' '
      else if (ch == '''' .or. ch == '"') then
        quote = ch
      else if (ch == '/') then
        term = i
        term_len = 1
        return
      else if (ch == '&') then
        term = i
        if (lower(buf(i + 1:name_end_at(buf, i + 1))) == 'end') term_len = 4
        return
      end if
    end do
  end subroutine find_group_end

  !> The starts of the `name = value` items of a group body and the
  !> positions of their '=': an item starts at the name before an '='
  !> outside quotes (a name may carry an index, as in probes(1,2)).
  subroutine split_items(body, starts, eqs)
    character(len=*), intent(in) :: body
    integer, allocatable, intent(out) :: starts(:), eqs(:)
    character(len=1) :: quote, ch
    integer :: i, j
    allocate(starts(0), eqs(0))
    quote = ' '
    do i = 1, len(body)
      ch = body(i:i)
      if (quote /= ' ') then
        if (ch == quote) quote = ' '
      else if (ch == '''' .or. ch == '"') then
        quote = ch
      else if (ch == '=') then
        j = name_start(body, i)
        if (j > 0) then
          starts = [starts, j]
          eqs = [eqs, i]
        end if
      end if
    end do
  end subroutine split_items

  !> Where the name before the '=' at body(eq:eq) starts, 0 if there is no
  !> name (blanks and an index in parentheses, closed or not, may sit
  !> between).
  integer function name_start(body, eq)
    character(len=*), intent(in) :: body
    integer, intent(in) :: eq
    integer :: j, k, depth
    name_start = 0
    j = eq - 1
    do while (j >= 1)
      if (body(j:j) /= ' ') exit
      j = j - 1
    end do
    if (j < 1) return
    if (body(j:j) == ')') then
      depth = 0
      do while (j >= 1)
        if (body(j:j) == ')') depth = depth + 1
        if (body(j:j) == '(') depth = depth - 1
        if (depth == 0) exit
        j = j - 1
      end do
      j = j - 1
      do while (j >= 1)
        if (body(j:j) /= ' ') exit
        j = j - 1
      end do
    else if (scan(body(j:j), '0123456789:,') > 0) then
      ! an index left open, as in probes(1:3,2 = ...: the name with it, so
      ! that this item reports its malformed subscript, not the one before
      k = j
      do while (k > 1)
        if (scan(body(k:k), '0123456789:, ') == 0) exit
        k = k - 1
      end do
      if (body(k:k) == '(') then
        j = k - 1
        do while (j >= 1)
          if (body(j:j) /= ' ') exit
          j = j - 1
        end do
      end if
    end if
    do while (j >= 1)
      if (.not. is_name_char(body(j:j))) exit
      j = j - 1
    end do
    if (j + 1 > len(body)) return
    if (is_letter(body(j + 1:j + 1))) name_start = j + 1
  end function name_start

end module namelist_scan
