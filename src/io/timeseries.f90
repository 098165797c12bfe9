!> The per-step time-series file timeseries.csv (doc/reference/output.md): one header
!> line naming the columns, then one row per sample, comma-separated, numbers
!> in ES format with 16 significant digits, a missing value as `nan`.
!>
!> Only rank 0 holds the rows: call every routine on every rank of the
!> communicator given to timeseries_init (other ranks ignore the values).
!> The rows live in memory; timeseries_flush rewrites the whole file under a
!> temporary name and renames it, so the file is complete or absent; the
!> caller flushes at each snapshot and at the end.  flush and load are
!> collective and return the same ok and errmsg on every rank.
module timeseries
  use, intrinsic :: ieee_arithmetic, only: ieee_is_nan, ieee_is_finite, ieee_value, &
                                           ieee_quiet_nan
  use kinds, only: wp
  use mpi_f08, only: MPI_Comm, MPI_Comm_rank
  use fileutil, only: text_buffer_t, text_append, write_file_atomic, agree_ok, file_exists
  implicit none
  private
  public :: timeseries_t, timeseries_init, timeseries_add, timeseries_flush
  public :: timeseries_load, timeseries_missing

  !> A time series being recorded.  text%s(1:text%n) is the whole file
  !> content (header line, then rows), kept on rank 0 only.
  type :: timeseries_t
    type(MPI_Comm) :: comm
    logical :: root = .false.
    character(len=:), allocatable :: path
    integer :: ncol = 0
    integer :: nrows = 0
    character(len=:), allocatable :: header   !< the header line, no newline
    type(text_buffer_t) :: text
  end type timeseries_t

  integer, parameter :: FIELD_LEN = 23   !< es23.15e3: -d.ddddddddddddddde+ddd

contains

  !> The value to pass for a missing sample (a quiet NaN, written `nan`).
  function timeseries_missing() result(x)
    real(wp) :: x
    x = ieee_value(x, ieee_quiet_nan)
  end function timeseries_missing

  !> Starts a time series written to `path` with the given column names
  !> (column 1 is the time).  Nothing is written until the first flush.
  !> Names are the program's, not the user's: a comma, quote, space or
  !> empty name is a programming error and stops the run.
  subroutine timeseries_init(ts, comm, path, columns)
    type(timeseries_t), intent(out) :: ts
    type(MPI_Comm), intent(in) :: comm
    character(len=*), intent(in) :: path
    character(len=*), intent(in) :: columns(:)
    integer :: rank, k
    if (size(columns) < 1) error stop 'timeseries_init: no columns'
    call MPI_Comm_rank(comm, rank)
    ts%comm = comm
    ts%root = rank == 0
    ts%path = path
    ts%ncol = size(columns)
    ts%nrows = 0
    ts%header = ''
    do k = 1, size(columns)
      if (len_trim(columns(k)) == 0 .or. scan(trim(columns(k)), ', "''') > 0) &
        error stop 'timeseries_init: a column name is empty or has a comma, quote or space'
      if (k > 1) ts%header = ts%header // ','
      ts%header = ts%header // trim(columns(k))
    end do
    if (ts%root) call text_append(ts%text, ts%header // new_line('a'))
  end subroutine timeseries_init

  !> Appends one row: values in column order (size = number of columns),
  !> a NaN for a missing value.  Ignored on ranks other than 0.
  subroutine timeseries_add(ts, values)
    type(timeseries_t), intent(inout) :: ts
    real(wp), intent(in) :: values(:)
    character(len=(FIELD_LEN + 1) * size(values)) :: row
    integer :: k, n
    if (size(values) /= ts%ncol) error stop 'timeseries_add: wrong number of values'
    if (.not. ts%root) return
    n = 0
    do k = 1, size(values)
      if (k > 1) then
        n = n + 1
        row(n:n) = ','
      end if
      call put_number(values(k), row, n)
    end do
    call text_append(ts%text, row(1:n) // new_line('a'))
    ts%nrows = ts%nrows + 1
  end subroutine timeseries_add

  !> Rewrites the whole file atomically (temporary name, then rename).
  !> Collective.
  subroutine timeseries_flush(ts, ok, errmsg)
    type(timeseries_t), intent(in) :: ts
    logical, intent(out) :: ok
    character(len=:), allocatable, intent(out) :: errmsg
    ok = .true.
    errmsg = ''
    if (ts%root) call write_file_atomic(ts%path, ts%text%s(1:ts%text%n), ok, errmsg)
    call agree_ok(ts%comm, ok, errmsg)
  end subroutine timeseries_flush

  !> Replaces the rows in memory by those of the existing file `path` whose
  !> time (column 1) is <= t_max (to within the 16-digit rounding of the
  !> file), for a restart that continues the series.  The file's header
  !> must name the same columns.  Rows are kept as written.  A missing file
  !> is an error.  Collective.
  subroutine timeseries_load(ts, path, t_max, ok, errmsg)
    type(timeseries_t), intent(inout) :: ts
    character(len=*), intent(in) :: path
    real(wp), intent(in) :: t_max
    logical, intent(out) :: ok
    character(len=:), allocatable, intent(out) :: errmsg
    ok = .true.
    errmsg = ''
    if (ts%root) call load_root(ok, errmsg)
    call agree_ok(ts%comm, ok, errmsg)

  contains

    subroutine load_root(good, msg)
      logical, intent(out) :: good
      character(len=:), allocatable, intent(out) :: msg
      character(len=:), allocatable :: content
      character(len=256) :: iomsg
      type(text_buffer_t) :: kept
      integer :: u, ios, size_bytes, first, last, line_no, nrows, c
      real(wp) :: t, limit
      good = .false.
      if (.not. file_exists(path)) then
        msg = 'timeseries_load: no file "' // path // '"'
        return
      end if
      open(newunit=u, file=path, access='stream', form='unformatted', status='old', &
           action='read', iostat=ios, iomsg=iomsg)
      if (ios == 0) inquire(unit=u, size=size_bytes)
      if (ios /= 0) then
        msg = 'timeseries_load: cannot open "' // path // '": ' // trim(iomsg)
        return
      end if
      allocate(character(len=size_bytes) :: content)
      if (size_bytes > 0) read(u, iostat=ios, iomsg=iomsg) content
      close(u)
      if (ios /= 0) then
        msg = 'timeseries_load: cannot read "' // path // '": ' // trim(iomsg)
        return
      end if
      ! rounding of the 16 significant digits is below 5e-16 relative
      limit = t_max + 1.0e-15_wp * abs(t_max)
      call text_append(kept, ts%header // new_line('a'))
      nrows = 0
      line_no = 0
      first = 1
      do while (first <= len(content))
        last = index(content(first:), new_line('a'))
        if (last == 0) then
          last = len(content)        ! a last line without newline
        else
          last = first + last - 1
        end if
        line_no = line_no + 1
        associate (line => content(first:last))
          if (line_no == 1) then
            if (trim(strip_eol(line)) /= ts%header) then
              msg = 'timeseries_load: the columns of "' // path // &
                    '" differ from this run''s: ' // trim(strip_eol(line))
              return
            end if
          else if (len_trim(strip_eol(line)) > 0) then
            c = index(line, ',') - 1
            if (c <= 0) c = len_trim(strip_eol(line))
            read(line(1:c), *, iostat=ios) t
            if (ios /= 0) then
              msg = 'timeseries_load: "' // path // '" has a malformed time in: ' // &
                    trim(strip_eol(line))
              return
            end if
            if (t <= limit) then
              call text_append(kept, trim(strip_eol(line)) // new_line('a'))
              nrows = nrows + 1
            end if
          end if
        end associate
        first = last + 1
      end do
      if (line_no == 0) then
        msg = 'timeseries_load: "' // path // '" is empty'
        return
      end if
      ts%text = kept
      ts%nrows = nrows
      good = .true.
      msg = ''
    end subroutine load_root

  end subroutine timeseries_load

  ! ---- internals ----

  !> Writes one number into row(n+1:), advancing n.
  subroutine put_number(x, row, n)
    real(wp), intent(in) :: x
    character(len=*), intent(inout) :: row
    integer, intent(inout) :: n
    character(len=FIELD_LEN) :: s
    if (ieee_is_nan(x)) then
      s = 'nan'
    else if (.not. ieee_is_finite(x)) then
      s = merge('inf ', '-inf', x > 0)
    else
      write(s, '(es23.15e3)') x
    end if
    s = adjustl(s)
    row(n+1:n+len_trim(s)) = trim(s)
    n = n + len_trim(s)
  end subroutine put_number

  !> A line without its newline (and carriage return, if any).
  pure function strip_eol(line) result(r)
    character(len=*), intent(in) :: line
    character(len=:), allocatable :: r
    integer :: n
    n = len(line)
    if (n > 0) then
      if (line(n:n) == new_line('a')) n = n - 1
    end if
    if (n > 0) then
      if (line(n:n) == achar(13)) n = n - 1
    end if
    r = line(1:n)
  end function strip_eol

end module timeseries
