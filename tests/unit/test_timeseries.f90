!> timeseries.csv: header and rows round trip through the text, 16
!> significant digits, `nan` for a missing value, flushes that leave no
!> temporary file, and a reload that keeps the rows up to a time (restart).
!> Every rank calls every routine; only rank 0 writes, every rank reads the
!> file back after the (collective) flush.
module test_timeseries
  use, intrinsic :: ieee_arithmetic, only: ieee_is_nan, ieee_value, ieee_positive_inf
  use kinds, only: wp
  use mpi_f08, only: MPI_Comm_rank, MPI_Bcast, MPI_Barrier, MPI_INTEGER, MPI_CHARACTER
  use testing, only: run_test, assert_true, assert_equal, test_comm
  use fileutil, only: make_temp_directory, join_path, temp_path, file_exists, remove_file, &
                      write_file_atomic
  use timeseries, only: timeseries_t, timeseries_init, timeseries_add, timeseries_flush, &
                        timeseries_load, timeseries_missing
  implicit none
  private
  public :: suite_timeseries

  character(len=16), parameter :: COLUMNS(3) = [character(len=16) :: &
    'time', 'kinetic_energy', 'p_probe_A']

contains

  subroutine suite_timeseries()
    call run_test('timeseries', 'header_rows_nan_round_trip', round_trip)
    call run_test('timeseries', 'flush_rewrites_whole_file_atomically', flush_again)
    call run_test('timeseries', 'load_keeps_rows_up_to_t_max', load_truncates)
    call run_test('timeseries', 'load_refuses_other_columns_or_no_file', load_errors)
  end subroutine suite_timeseries

  ! ---------------------------------------------------------------- helpers

  function shared_scratch(tag) result(dir)
    character(len=*), intent(in) :: tag
    character(len=:), allocatable :: dir
    integer :: rank, n
    call MPI_Comm_rank(test_comm(), rank)
    if (rank == 0) dir = make_temp_directory('/tmp/sph_test_' // tag // '_')
    n = 0
    if (rank == 0) n = len(dir)
    call MPI_Bcast(n, 1, MPI_INTEGER, 0, test_comm())
    if (rank /= 0) allocate(character(len=n) :: dir)
    if (n > 0) call MPI_Bcast(dir, n, MPI_CHARACTER, 0, test_comm())
  end function shared_scratch

  subroutine cleanup(dir, names)
    character(len=*), intent(in) :: dir, names(:)
    integer :: rank, k
    call MPI_Barrier(test_comm())
    call MPI_Comm_rank(test_comm(), rank)
    if (rank /= 0) return
    do k = 1, size(names)
      call remove_file(join_path(dir, trim(names(k))))
    end do
    call remove_file(dir)
  end subroutine cleanup

  !> The lines of a text file (without newlines); none if it cannot be read.
  subroutine read_lines(path, lines, n)
    character(len=*), intent(in) :: path
    character(len=256), intent(out) :: lines(:)
    integer, intent(out) :: n
    integer :: u, ios
    n = 0
    open(newunit=u, file=path, status='old', action='read', iostat=ios)
    if (ios /= 0) return
    do
      if (n == size(lines)) exit
      read(u, '(a)', iostat=ios) lines(n + 1)
      if (ios /= 0) exit
      n = n + 1
    end do
    close(u)
  end subroutine read_lines

  !> The comma-separated fields of a line parsed as reals (nan allowed).
  subroutine parse_row(line, values, nfields, ok)
    character(len=*), intent(in) :: line
    real(wp), intent(out) :: values(:)
    integer, intent(out) :: nfields
    logical, intent(out) :: ok
    integer :: first, c, ios
    ok = .true.
    nfields = 0
    first = 1
    do
      c = index(line(first:), ',')
      nfields = nfields + 1
      if (nfields > size(values)) then
        ok = .false.
        return
      end if
      if (c == 0) then
        read(line(first:), *, iostat=ios) values(nfields)
      else
        read(line(first:first + c - 2), *, iostat=ios) values(nfields)
      end if
      ok = ok .and. ios == 0
      if (c == 0) exit
      first = first + c
    end do
  end subroutine parse_row

  subroutine init_three_rows(ts, path)
    type(timeseries_t), intent(out) :: ts
    character(len=*), intent(in) :: path
    call timeseries_init(ts, test_comm(), path, COLUMNS)
    call timeseries_add(ts, [0.0_wp, 1.0_wp / 3.0_wp, -2.5e-7_wp])
    call timeseries_add(ts, [0.1_wp, 0.3330000000000001_wp, timeseries_missing()])
    call timeseries_add(ts, [0.2_wp, 1.0e200_wp, -1.0e-300_wp])
  end subroutine init_three_rows

  ! ------------------------------------------------------------------ tests

  subroutine round_trip()
    character(len=:), allocatable :: dir, path, errmsg
    character(len=256) :: lines(10)
    type(timeseries_t) :: ts
    real(wp) :: v(3)
    integer :: n, nf
    logical :: ok
    dir = shared_scratch('ts')
    path = join_path(dir, 'timeseries.csv')
    call init_three_rows(ts, path)
    call assert_true(.not. file_exists(path), 'nothing written before the first flush')
    call MPI_Barrier(test_comm())   ! no rank may flush before every rank has looked
    call timeseries_flush(ts, ok, errmsg)
    call assert_true(ok, 'flush: ' // errmsg)
    call assert_true(.not. file_exists(temp_path(path)), 'no temporary file left')
    call read_lines(path, lines, n)
    call assert_equal(4, n, 'header and three rows')
    call assert_equal('time,kinetic_energy,p_probe_A', trim(lines(1)), 'header')
    ! 16 significant digits in ES format
    call assert_equal('0.000000000000000E+000,3.333333333333333E-001,-2.500000000000000E-007', &
                      trim(lines(2)), 'first row as text')
    call assert_equal('1.000000000000000E-001,3.330000000000001E-001,nan', trim(lines(3)), &
                      'a missing value is written nan')
    call parse_row(lines(2), v, nf, ok)
    call assert_true(ok .and. nf == 3, 'first row parses into 3 numbers')
    call assert_equal([0.0_wp, 1.0_wp / 3.0_wp, -2.5e-7_wp], v, 1.0e-16_wp, 'first row values')
    call parse_row(lines(3), v, nf, ok)
    call assert_true(ok .and. nf == 3, 'second row parses')
    call assert_equal(0.3330000000000001_wp, v(2), 1.0e-16_wp, 'second row, 16 digits kept')
    call assert_true(ieee_is_nan(v(3)), 'nan reads back as NaN')
    call parse_row(lines(4), v, nf, ok)
    call assert_true(ok .and. nf == 3, 'third row parses')
    call assert_true(abs(v(2) / 1.0e200_wp - 1) < 1.0e-15_wp .and. &
                     abs(v(3) / (-1.0e-300_wp) - 1) < 1.0e-15_wp, 'three-digit exponents')
    call cleanup(dir, [character(len=16) :: 'timeseries.csv'])
  end subroutine round_trip

  subroutine flush_again()
    character(len=:), allocatable :: dir, path, errmsg
    character(len=256) :: lines(10)
    type(timeseries_t) :: ts
    integer :: n
    logical :: ok
    dir = shared_scratch('ts')
    path = join_path(dir, 'timeseries.csv')
    call init_three_rows(ts, path)
    call timeseries_flush(ts, ok, errmsg)
    call assert_true(ok, 'first flush: ' // errmsg)
    call timeseries_add(ts, [0.3_wp, 2.0_wp, ieee_value(1.0_wp, ieee_positive_inf)])
    call timeseries_add(ts, [0.4_wp, 2.5_wp, 3.0_wp])
    call timeseries_flush(ts, ok, errmsg)
    call assert_true(ok, 'second flush: ' // errmsg)
    call assert_true(.not. file_exists(temp_path(path)), 'no temporary file left')
    call read_lines(path, lines, n)
    call assert_equal(6, n, 'header and five rows after the second flush')
    call assert_equal('time,kinetic_energy,p_probe_A', trim(lines(1)), 'one header only')
    call assert_equal('3.000000000000000E-001,2.000000000000000E+000,inf', trim(lines(5)), &
                      'an infinity is written inf')
    call cleanup(dir, [character(len=16) :: 'timeseries.csv'])
  end subroutine flush_again

  !> A run writes rows at t = 0, 0.1, 0.2, 0.3, 0.4; a restart at t = 0.2
  !> (the snapshot's exact double, which the file shows rounded) keeps the
  !> first three rows verbatim and continues after them.
  subroutine load_truncates()
    character(len=:), allocatable :: dir, path, errmsg
    character(len=256) :: lines(10), before(10)
    type(timeseries_t) :: ts, restarted
    integer :: n, nb, rank
    logical :: ok
    call MPI_Comm_rank(test_comm(), rank)
    dir = shared_scratch('ts')
    path = join_path(dir, 'timeseries.csv')
    call init_three_rows(ts, path)
    call timeseries_add(ts, [0.3_wp, 2.0_wp, 1.0_wp])
    call timeseries_add(ts, [0.4_wp, 2.5_wp, 3.0_wp])
    call timeseries_flush(ts, ok, errmsg)
    call assert_true(ok, 'flush: ' // errmsg)
    call read_lines(path, before, nb)
    call timeseries_init(restarted, test_comm(), path, COLUMNS)
    call timeseries_load(restarted, path, 0.2_wp, ok, errmsg)
    call assert_true(ok, 'load: ' // errmsg)
    if (rank == 0) call assert_equal(3, restarted%nrows, 'rows with t <= 0.2 kept')
    call timeseries_add(restarted, [0.25_wp, 9.0_wp, 9.0_wp])
    call timeseries_flush(restarted, ok, errmsg)
    call assert_true(ok, 'flush after load: ' // errmsg)
    call read_lines(path, lines, n)
    call assert_equal(5, n, 'header, three kept rows, one new row')
    call assert_true(all(lines(1:4) == before(1:4)), 'kept rows unchanged')
    call assert_equal('2.500000000000000E-001,9.000000000000000E+000,9.000000000000000E+000', &
                      trim(lines(5)), 'new row after the kept ones')
    ! t_max below every time keeps only the header
    call timeseries_load(restarted, path, -1.0_wp, ok, errmsg)
    call assert_true(ok, 'load before the first row: ' // errmsg)
    if (rank == 0) call assert_equal(0, restarted%nrows, 'no rows kept')
    call cleanup(dir, [character(len=16) :: 'timeseries.csv'])
  end subroutine load_truncates

  subroutine load_errors()
    character(len=:), allocatable :: dir, path, errmsg
    type(timeseries_t) :: ts
    integer :: rank
    logical :: ok
    call MPI_Comm_rank(test_comm(), rank)
    dir = shared_scratch('ts')
    path = join_path(dir, 'timeseries.csv')
    call timeseries_init(ts, test_comm(), path, COLUMNS)
    call timeseries_load(ts, path, 1.0_wp, ok, errmsg)
    call assert_true(.not. ok .and. index(errmsg, 'no file') > 0, &
                     'a missing file is an error on every rank: ' // errmsg)
    ok = .true.
    if (rank == 0) call write_file_atomic(path, 'time,other' // new_line('a') // &
                                          '0.0,1.0' // new_line('a'), ok, errmsg)
    call MPI_Barrier(test_comm())
    call timeseries_load(ts, path, 1.0_wp, ok, errmsg)
    call assert_true(.not. ok .and. index(errmsg, 'columns') > 0, &
                     'other columns are refused on every rank: ' // errmsg)
    call cleanup(dir, [character(len=16) :: 'timeseries.csv'])
  end subroutine load_errors

end module test_timeseries
