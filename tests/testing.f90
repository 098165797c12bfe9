!> The unit-test harness used when pFUnit is not installed (doc/guide/cases.md, "Unit
!> tests"): tests/pf2f90.py translates each tests/unit/test_<module>.pf into
!> Fortran that calls this module instead of pFUnit.  It offers the part of
!> pFUnit 4's API the .pf files use, with pFUnit's names and behaviour:
!>
!>  - a plain @test runs on process 0 of the run only (pFUnit runs serial
!>    tests "in a serial context"), the other processes wait;
!>  - an @mpitest(npes=[...]) runs once per entry of npes, on a
!>    sub-communicator of the first npes processes, and is named
!>    "<suite>.<test>[npes=N]"; MpiTestMethod gives it the communicator as
!>    an integer handle, as pFUnit built against the `mpi` module does;
!>  - assertions compare as pFUnit's do (assertEqual on reals: exact
!>    equality or |actual - expected| <= tolerance; assertRelativelyEqual:
!>    |actual - expected| <= tolerance |expected|, and a zero expected value
!>    fails; strings ignore leading and trailing blanks).
!>
!> One difference: pFUnit returns from a test at its first failed
!> assertion; here the test carries on, so that a failure on one process
!> cannot leave the others waiting in a collective call.  Either way the
!> test fails.  A failure on any process fails the test; the failing
!> process prints the message, process 0 prints one line per test.
module testing
  use, intrinsic :: iso_fortran_env, only: output_unit, error_unit
  use, intrinsic :: ieee_arithmetic, only: ieee_is_finite, ieee_is_nan, ieee_class, &
                                           operator(==)
  use kinds, only: wp
  use mpi_f08, only: MPI_Comm, MPI_Comm_rank, MPI_Comm_size, MPI_Comm_split, MPI_Comm_free, &
                     MPI_Allreduce, MPI_IN_PLACE, MPI_INTEGER, MPI_MAX, MPI_UNDEFINED
  implicit none
  private
  public :: MpiTestMethod, SourceLocation
  public :: assertTrue, assertFalse, assertEqual, assertRelativelyEqual
  public :: testing_init, testing_summary, run_test, run_mpi_test

  !> Where an assertion is in its .pf file (pFUnit's type of the same name).
  type :: SourceLocation
    character(len=64) :: file_name = ''
    integer :: line_number = 0
  end type SourceLocation

  !> What an @mpitest procedure receives: its sub-communicator.
  type :: MpiTestMethod
    private
    type(MPI_Comm) :: comm
    integer :: npes = 0, rank = 0
  contains
    procedure :: getMpiCommunicator, getNumProcesses, getProcessRank
  end type MpiTestMethod

  abstract interface
    subroutine serial_proc()
    end subroutine serial_proc
    subroutine mpi_proc(this)
      import :: MpiTestMethod
      class(MpiTestMethod), intent(inout) :: this
    end subroutine mpi_proc
  end interface

  !> The harness's state: the run's communicator, counters, the running test.
  type :: harness_t
    type(MPI_Comm) :: comm
    integer :: rank = 0, nranks = 1
    integer :: passed = 0, failed = 0
    logical :: current_failed = .false.
    character(len=160) :: test = ''
  end type harness_t
  type(harness_t), save :: h

  interface assertEqual
    module procedure assert_equal_int, assert_equal_str, assert_equal_real, &
                     assert_equal_real_1d
  end interface assertEqual

  interface assertRelativelyEqual
    module procedure assert_rel_real, assert_rel_real_1d
  end interface assertRelativelyEqual

contains

  ! ------------------------------------------------------------- running

  !> comm: the processes of the run (a duplicate of MPI_COMM_WORLD).
  subroutine testing_init(comm)
    type(MPI_Comm), intent(in) :: comm
    h%comm = comm
    call MPI_Comm_rank(comm, h%rank)
    call MPI_Comm_size(comm, h%nranks)
  end subroutine testing_init

  !> A plain @test: process 0 runs it (with the suite's @before and @after).
  subroutine run_test(suite, name, proc, set_up, tear_down)
    character(len=*), intent(in) :: suite, name
    procedure(serial_proc) :: proc
    procedure(serial_proc), optional :: set_up, tear_down
    call start(suite // '.' // name)
    if (h%rank == 0) then
      if (present(set_up)) call set_up()
      call proc()
      if (present(tear_down)) call tear_down()
    end if
    call finish()
  end subroutine run_test

  !> One instance of an @mpitest: the first npes processes run it on their
  !> own communicator.  More processes than the run has is a failure, as
  !> in pFUnit.
  subroutine run_mpi_test(suite, name, npes, proc, set_up, tear_down)
    character(len=*), intent(in) :: suite, name
    integer, intent(in) :: npes
    procedure(mpi_proc) :: proc
    procedure(mpi_proc), optional :: set_up, tear_down
    type(MpiTestMethod) :: t
    type(MPI_Comm) :: sub
    character(len=16) :: n
    write(n, '(i0)') npes
    call start(suite // '.' // name // '[npes=' // trim(n) // ']')
    if (npes > h%nranks) then
      if (h%rank == 0) call report('Insufficient processes to run this test.')
    else
      call MPI_Comm_split(h%comm, merge(0, MPI_UNDEFINED, h%rank < npes), h%rank, sub)
      if (h%rank < npes) then
        t%comm = sub
        t%npes = npes
        t%rank = h%rank
        if (present(set_up)) call set_up(t)
        call proc(t)
        if (present(tear_down)) call tear_down(t)
        call MPI_Comm_free(sub)
      end if
    end if
    call finish()
  end subroutine run_mpi_test

  subroutine start(name)
    character(len=*), intent(in) :: name
    h%test = name
    h%current_failed = .false.
  end subroutine start

  !> A failure on any process fails the test; process 0 prints the verdict.
  subroutine finish()
    integer :: flag(1)
    flag = merge(1, 0, h%current_failed)
    call MPI_Allreduce(MPI_IN_PLACE, flag, 1, MPI_INTEGER, MPI_MAX, h%comm)
    if (flag(1) /= 0) then
      h%failed = h%failed + 1
      if (h%rank == 0) write(output_unit, '(a)') '[FAIL] ' // trim(h%test)
    else
      h%passed = h%passed + 1
      if (h%rank == 0) write(output_unit, '(a)') '[ OK ] ' // trim(h%test)
    end if
    flush(output_unit)
  end subroutine finish

  !> Prints the closing line "N passed, N failed" and returns the failures.
  function testing_summary() result(nfailed)
    integer :: nfailed
    if (h%rank == 0) write(output_unit, '(i0,a,i0,a)') h%passed, ' passed, ', h%failed, ' failed'
    nfailed = h%failed
  end function testing_summary

  ! -------------------------------------------------------- MpiTestMethod

  !> The handle of the test's communicator (type(MPI_Comm)'s MPI_VAL).
  integer function getMpiCommunicator(this)
    class(MpiTestMethod), intent(in) :: this
    getMpiCommunicator = this%comm%MPI_VAL
  end function getMpiCommunicator

  integer function getNumProcesses(this)
    class(MpiTestMethod), intent(in) :: this
    getNumProcesses = this%npes
  end function getNumProcesses

  integer function getProcessRank(this)
    class(MpiTestMethod), intent(in) :: this
    getProcessRank = this%rank
  end function getProcessRank

  ! ----------------------------------------------------------- assertions

  subroutine report(msg, message, location)
    character(len=*), intent(in) :: msg
    character(len=*), intent(in), optional :: message
    type(SourceLocation), intent(in), optional :: location
    character(len=:), allocatable :: where, text
    character(len=16) :: r, l
    h%current_failed = .true.
    write(r, '(i0)') h%rank
    where = ''
    if (present(location)) then
      write(l, '(i0)') location%line_number
      where = ' at ' // trim(location%file_name) // ':' // trim(l)
    end if
    text = msg
    if (present(message)) text = message // ': ' // msg
    write(error_unit, '(a)') '  FAILED ' // trim(h%test) // ' (process ' // trim(r) // ')' // &
      where // ': ' // text
    flush(error_unit)
  end subroutine report

  subroutine assertTrue(condition, message, location)
    logical, intent(in) :: condition
    character(len=*), intent(in), optional :: message
    type(SourceLocation), intent(in), optional :: location
    if (.not. condition) call report('expected true', message, location)
  end subroutine assertTrue

  subroutine assertFalse(condition, message, location)
    logical, intent(in) :: condition
    character(len=*), intent(in), optional :: message
    type(SourceLocation), intent(in), optional :: location
    if (condition) call report('expected false', message, location)
  end subroutine assertFalse

  subroutine assert_equal_int(expected, actual, message, location)
    integer, intent(in) :: expected, actual
    character(len=*), intent(in), optional :: message
    type(SourceLocation), intent(in), optional :: location
    character(len=64) :: s
    if (expected /= actual) then
      write(s, '(a,i0,a,i0)') 'expected ', expected, ', actual ', actual
      call report(trim(s), message, location)
    end if
  end subroutine assert_equal_int

  !> Leading and trailing blanks (spaces, tabs) do not count, as in pFUnit.
  subroutine assert_equal_str(expected, actual, message, location)
    character(len=*), intent(in) :: expected, actual
    character(len=*), intent(in), optional :: message
    type(SourceLocation), intent(in), optional :: location
    if (strip(expected) /= strip(actual)) call report('expected "' // expected // &
                                                      '", actual "' // actual // '"', &
                                                      message, location)
  end subroutine assert_equal_str

  pure function strip(s) result(t)
    character(len=*), intent(in) :: s
    character(len=:), allocatable :: t
    integer :: i, j
    i = verify(s, ' ' // achar(9))
    j = verify(s, ' ' // achar(9), back=.true.)
    if (i == 0) then
      t = ''
    else
      t = s(i:j)
    end if
  end function strip

  subroutine assert_equal_real(expected, actual, tolerance, message, location)
    real(wp), intent(in) :: expected, actual, tolerance
    character(len=*), intent(in), optional :: message
    type(SourceLocation), intent(in), optional :: location
    character(len=160) :: s
    if (same_infinity(expected, actual)) return
    if (.not. (abs(actual - expected) <= tolerance)) then
      write(s, '(3(a,es24.16))') 'expected ', expected, ', actual ', actual, &
        ', tolerance ', tolerance
      call report(trim(s), message, location)
    end if
  end subroutine assert_equal_real

  subroutine assert_equal_real_1d(expected, actual, tolerance, message, location)
    real(wp), intent(in) :: expected(:), actual(:), tolerance
    character(len=*), intent(in), optional :: message
    type(SourceLocation), intent(in), optional :: location
    integer :: k
    character(len=200) :: s
    if (size(expected) /= size(actual)) then
      call report('arrays of different sizes', message, location)
      return
    end if
    do k = 1, size(expected)
      if (same_infinity(expected(k), actual(k))) cycle
      if (.not. (abs(actual(k) - expected(k)) <= tolerance)) then
        write(s, '(a,i0,3(a,es24.16))') 'element ', k, ': expected ', expected(k), &
          ', actual ', actual(k), ', tolerance ', tolerance
        call report(trim(s), message, location)
        return
      end if
    end do
  end subroutine assert_equal_real_1d

  !> pFUnit passes equal values before taking differences, for infinities
  !> (Inf - Inf is NaN); for finite values the tolerance test covers it.
  elemental logical function same_infinity(a, b)
    real(wp), intent(in) :: a, b
    same_infinity = .not. (ieee_is_finite(a) .or. ieee_is_nan(a)) .and. ieee_class(a) == ieee_class(b)
  end function same_infinity

  subroutine assert_rel_real(expected, actual, tolerance, message, location)
    real(wp), intent(in) :: expected, actual, tolerance
    character(len=*), intent(in), optional :: message
    type(SourceLocation), intent(in), optional :: location
    character(len=200) :: s
    if (abs(expected) <= 0) then
      call report('zero expected value in assertRelativelyEqual', message, location)
    else if (.not. (abs(actual - expected) <= tolerance * abs(expected))) then
      write(s, '(3(a,es24.16))') 'expected ', expected, ', actual ', actual, &
        ', relative tolerance ', tolerance
      call report(trim(s), message, location)
    end if
  end subroutine assert_rel_real

  subroutine assert_rel_real_1d(expected, actual, tolerance, message, location)
    real(wp), intent(in) :: expected(:), actual(:), tolerance
    character(len=*), intent(in), optional :: message
    type(SourceLocation), intent(in), optional :: location
    integer :: k
    character(len=200) :: s
    if (size(expected) /= size(actual)) then
      call report('arrays of different sizes', message, location)
      return
    end if
    if (any(abs(expected) <= 0)) then
      call report('zero expected value in assertRelativelyEqual', message, location)
      return
    end if
    do k = 1, size(expected)
      if (.not. (abs(actual(k) - expected(k)) <= tolerance * abs(expected(k)))) then
        write(s, '(a,i0,3(a,es24.16))') 'element ', k, ': expected ', expected(k), &
          ', actual ', actual(k), ', relative tolerance ', tolerance
        call report(trim(s), message, location)
        return
      end if
    end do
  end subroutine assert_rel_real_1d

end module testing
