!> Text helpers of the input reader: the one form of an error message,
!> quoting, number formatting that reads back exactly, the edit distance
!> behind "did you mean" hints, and the character classes of names.  Shared
!> by config and the cases, which describe their own input variables.
module input_text
  use, intrinsic :: ieee_arithmetic, only: ieee_is_finite, ieee_is_nan
  use kinds, only: wp, i8
  implicit none
  private
  public :: fail, closest, allowed_words, joined, quoted_list, quoted, shown_value, unquoted, &
            value_is_bare, base_name, word_at, name_end_at, is_letter, is_name_char, lower, &
            pad, os_reason, int_str, num_str, real_list, real_str, list_items

  interface int_str
    module procedure int_str_default, int_str_i8
  end interface int_str

contains

  !> The one way an error message is made: "origin: what (line N)hint".
  !> origin is the file or 'command line'; the line only if known (> 0);
  !> hint says what is allowed or what to do.
  subroutine fail(err, origin, what, line, hint)
    character(len=:), allocatable, intent(inout) :: err
    character(len=*), intent(in) :: origin, what
    integer, intent(in) :: line
    character(len=*), intent(in) :: hint
    err = origin // ': ' // what
    if (line > 0) err = err // ' (line ' // int_str(line) // ')'
    err = err // hint
  end subroutine fail

  !> The candidate closest to word by edit distance if it is close enough to
  !> be a typo (at most a third of the word's letters, at least 1), else ''.
  function closest(word, candidates) result(best)
    character(len=*), intent(in) :: word
    character(len=*), intent(in) :: candidates(:)
    character(len=:), allocatable :: best
    integer :: k, d, dmin
    best = ''
    dmin = max(1, len_trim(word) / 3) + 1
    do k = 1, size(candidates)
      d = edit_distance(trim(word), trim(candidates(k)))
      if (d < dmin) then
        dmin = d
        best = trim(candidates(k))
      end if
    end do
  end function closest

  !> Levenshtein distance (insertions, deletions, substitutions).
  pure integer function edit_distance(a, b) result(d)
    character(len=*), intent(in) :: a, b
    integer :: prev(0:len(b)), cur(0:len(b)), i, j
    prev = [(j, j = 0, len(b))]
    do i = 1, len(a)
      cur(0) = i
      do j = 1, len(b)
        cur(j) = min(prev(j) + 1, cur(j - 1) + 1, &
                     prev(j - 1) + merge(0, 1, a(i:i) == b(j:j)))
      end do
      prev = cur
    end do
    d = prev(len(b))
  end function edit_distance

  !> "'a', 'b', 'c'".
  function allowed_words(list) result(s)
    character(len=*), intent(in) :: list(:)
    character(len=:), allocatable :: s
    s = joined(quoted_list(list))
  end function allowed_words

  !> "x1, x2, x3" (each without its trailing blanks).
  function joined(items) result(s)
    character(len=*), intent(in) :: items(:)
    character(len=:), allocatable :: s
    integer :: k
    s = ''
    do k = 1, size(items)
      if (k > 1) s = s // ', '
      s = s // trim(items(k))
    end do
  end function joined

  function quoted_list(list) result(q)
    character(len=*), intent(in) :: list(:)
    character(len=len(list) + 2), allocatable :: q(:)
    integer :: k
    allocate(q(size(list)))
    do k = 1, size(list)
      q(k) = quoted(list(k))
    end do
  end function quoted_list

  !> s (without trailing blanks) in single quotes, inner quotes doubled.
  function quoted(s) result(q)
    character(len=*), intent(in) :: s
    character(len=:), allocatable :: q
    integer :: i
    q = ''''
    do i = 1, len_trim(s)
      q = q // s(i:i)
      if (s(i:i) == '''') q = q // ''''
    end do
    q = q // ''''
  end function quoted

  !> An item's value as the user wrote it, for messages: without the
  !> surrounding blanks and a trailing separator.
  function shown_value(value) result(s)
    character(len=*), intent(in) :: value
    character(len=:), allocatable :: s
    s = trim(adjustl(value))
    if (len(s) > 0) then
      if (s(len(s):len(s)) == ',' .or. s(len(s):len(s)) == ';') s = trim(s(1:len(s) - 1))
    end if
  end function shown_value

  !> value with every quoted part blanked.
  function unquoted(value) result(s)
    character(len=*), intent(in) :: value
    character(len=len(value)) :: s
    character(len=1) :: quote
    integer :: i
    s = value
    quote = ' '
    do i = 1, len(value)
      if (quote /= ' ') then
        if (value(i:i) == quote) quote = ' '
        s(i:i) = ' '
      else if (value(i:i) == '''' .or. value(i:i) == '"') then
        quote = value(i:i)
        s(i:i) = ' '
      end if
    end do
  end function unquoted

  !> A value written without quotes, e.g. circle2d rather than 'circle2d'.
  logical function value_is_bare(value)
    character(len=*), intent(in) :: value
    character(len=:), allocatable :: s
    s = shown_value(value)
    value_is_bare = .true.
    if (len(s) > 0) value_is_bare = s(1:1) /= '''' .and. s(1:1) /= '"'
  end function value_is_bare

  !> The name without its index: 'probes' for 'probes(1,2)'.
  function base_name(name) result(s)
    character(len=*), intent(in) :: name
    character(len=:), allocatable :: s
    integer :: k
    k = index(name, '(')
    if (k == 0) k = len(name) + 1
    s = lower(trim(adjustl(name(1:k - 1))))
  end function base_name

  !> The blank-delimited word at buf(pos:), at most 40 characters.
  function word_at(buf, pos) result(s)
    character(len=*), intent(in) :: buf
    integer, intent(in) :: pos
    character(len=:), allocatable :: s
    integer :: last
    last = index(buf(pos:), ' ') + pos - 2
    if (last < pos) last = len(buf)
    s = buf(pos:min(last, pos + 39))
  end function word_at

  !> The last position of the name starting at buf(pos:) (pos - 1 if none).
  integer function name_end_at(buf, pos)
    character(len=*), intent(in) :: buf
    integer, intent(in) :: pos
    name_end_at = pos - 1
    do while (name_end_at < len(buf))
      if (.not. is_name_char(buf(name_end_at + 1:name_end_at + 1))) exit
      name_end_at = name_end_at + 1
    end do
  end function name_end_at

  logical function is_letter(ch)
    character(len=1), intent(in) :: ch
    is_letter = (ch >= 'a' .and. ch <= 'z') .or. (ch >= 'A' .and. ch <= 'Z')
  end function is_letter

  logical function is_name_char(ch)
    character(len=1), intent(in) :: ch
    is_name_char = is_letter(ch) .or. (ch >= '0' .and. ch <= '9') .or. ch == '_'
  end function is_name_char

  function lower(s) result(t)
    character(len=*), intent(in) :: s
    character(len=len(s)) :: t
    integer :: i
    t = s
    do i = 1, len(s)
      if (s(i:i) >= 'A' .and. s(i:i) <= 'Z') t(i:i) = achar(iachar(s(i:i)) + 32)
    end do
  end function lower

  !> s padded with blanks to at least n characters.
  function pad(s, n) result(t)
    character(len=*), intent(in) :: s
    integer, intent(in) :: n
    character(len=max(len(s), n)) :: t
    t = s
  end function pad

  !> The system's reason from gfortran's "Cannot open file 'x': reason".
  function os_reason(iomsg) result(s)
    character(len=*), intent(in) :: iomsg
    character(len=:), allocatable :: s
    integer :: k
    k = index(iomsg, ''': ', back=.true.)
    s = trim(iomsg(k + 1:))
    if (k > 0) s = trim(iomsg(k + 3:))
  end function os_reason

  function int_str_default(k) result(s)
    integer, intent(in) :: k
    character(len=:), allocatable :: s
    character(len=24) :: buf
    write(buf, '(i0)') k
    s = trim(buf)
  end function int_str_default

  function int_str_i8(k) result(s)
    integer(i8), intent(in) :: k
    character(len=:), allocatable :: s
    character(len=24) :: buf
    write(buf, '(i0)') k
    s = trim(buf)
  end function int_str_i8

  !> A bound: a whole number as an integer ("3"), else as real_str.
  function num_str(x) result(s)
    real(wp), intent(in) :: x
    character(len=:), allocatable :: s
    if (abs(x) < 1.0e15_wp .and. .not. abs(x - aint(x)) > 0) then
      s = int_str(nint(x, i8))
    else
      s = real_str(x)
    end if
  end function num_str

  !> "x1, x2, x3".
  function real_list(x) result(s)
    real(wp), intent(in) :: x(:)
    character(len=:), allocatable :: s
    integer :: k
    s = ''
    do k = 1, size(x)
      if (k > 1) s = s // ', '
      s = s // real_str(x(k))
    end do
  end function real_list

  !> The n comma-separated items of text (the value of an array), trimmed:
  !> real_list's inverse as text.
  function list_items(text, n) result(items)
    character(len=*), intent(in) :: text
    integer, intent(in) :: n
    character(len=40) :: items(n)
    integer :: k, start, comma
    items = ''
    start = 1
    do k = 1, n
      comma = index(text(start:), ',')
      if (comma == 0) comma = len(text) - start + 2
      items(k) = adjustl(text(start:start + comma - 2))
      start = start + comma
      if (start > len(text)) exit
    end do
  end function list_items

  !> The shortest decimal text that reads back as exactly x: 0.1, 2.0,
  !> -1.0, 1.0e-12 (so that echoed files reproduce the configuration).
  function real_str(x) result(s)
    real(wp), intent(in) :: x
    character(len=:), allocatable :: s
    character(len=40) :: buf, fmt
    character(len=:), allocatable :: digits, int_part, frac
    real(wp) :: y
    integer :: d, e, k, ios
    if (ieee_is_nan(x)) then
      s = 'NaN'
      return
    else if (.not. ieee_is_finite(x)) then
      s = 'Infinity'
      if (x < 0) s = '-Infinity'
      return
    end if
    ! The fewest significant digits (d + 1) that give x back; 17 always do.
    do d = 1, 16
      write(fmt, '(a,i0,a)') '(es40.', d, 'e3)'
      write(buf, fmt) x
      read(buf, *, iostat=ios) y
      if (ios == 0 .and. transfer(y, 0_i8) == transfer(x, 0_i8)) exit
    end do
    buf = adjustl(buf)
    k = index(buf, 'E')
    read(buf(k + 1:), *) e
    digits = ''
    do d = 1, k - 1
      if (buf(d:d) >= '0' .and. buf(d:d) <= '9') digits = digits // buf(d:d)
    end do
    do while (len(digits) > 1)
      if (digits(len(digits):len(digits)) /= '0') exit
      digits = digits(1:len(digits) - 1)
    end do
    if (e >= -4 .and. e < 16) then
      if (e < 0) then
        int_part = '0'
        frac = repeat('0', -e - 1) // digits
      else if (len(digits) <= e + 1) then
        int_part = digits // repeat('0', e + 1 - len(digits))
        frac = '0'
      else
        int_part = digits(1:e + 1)
        frac = digits(e + 2:)
      end if
      s = int_part // '.' // frac
    else
      frac = digits(2:)
      if (len(frac) == 0) frac = '0'
      s = digits(1:1) // '.' // frac // 'e' // int_str(e)
    end if
    if (buf(1:1) == '-') s = '-' // s
  end function real_str

end module input_text
