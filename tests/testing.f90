!> A small test harness whose names mirror pFUnit (pFUnit is not packaged for Debian: README).
!>
!> A test is a procedure without arguments, run by run_test(suite, name, proc).
!> Assertions record failures on the calling rank; run_test reduces them over
!> the communicator so that a failure on any rank fails the test everywhere.
!> Pass lines come from rank 0 only; a failing rank prints its own context.
module testing
  use, intrinsic :: iso_fortran_env, only: output_unit, error_unit
  use kinds, only: wp, i8
  use mpi_f08, only: MPI_Comm, MPI_Comm_rank, MPI_Comm_size, MPI_Allreduce, &
                     MPI_IN_PLACE, MPI_INTEGER, MPI_MAX
  implicit none
  private
  public :: testing_init, testing_summary, run_test, skip_test, test_comm
  public :: assert_true, assert_equal, assert_relatively_equal, same_bits

  abstract interface
    subroutine test_proc()
    end subroutine test_proc
  end interface

  !> The harness's state: counters and the test being run.
  type :: harness_t
    type(MPI_Comm) :: comm
    integer :: rank = 0, nranks = 1
    integer :: passed = 0, failed = 0, skipped = 0
    logical :: current_failed = .false., current_skipped = .false.
    character(len=64) :: suite = '', test = ''
  end type harness_t
  type(harness_t), save :: h

  interface assert_equal
    module procedure assert_equal_int, assert_equal_str, assert_equal_real, &
                     assert_equal_real_array
  end interface assert_equal

  interface assert_relatively_equal
    module procedure assert_rel_real, assert_rel_real_array
  end interface assert_relatively_equal

contains

  subroutine testing_init(comm)
    type(MPI_Comm), intent(in) :: comm
    h%comm = comm
    call MPI_Comm_rank(comm, h%rank)
    call MPI_Comm_size(comm, h%nranks)
  end subroutine testing_init

  !> The communicator tests run on (the harness's duplicate of the world).
  function test_comm() result(comm)
    type(MPI_Comm) :: comm
    comm = h%comm
  end function test_comm

  subroutine run_test(suite, name, proc)
    character(len=*), intent(in) :: suite, name
    procedure(test_proc) :: proc
    integer :: flags(2)
    h%suite = suite
    h%test = name
    h%current_failed = .false.
    h%current_skipped = .false.
    call proc()
    flags = [merge(1, 0, h%current_failed), merge(1, 0, h%current_skipped)]
    call MPI_Allreduce(MPI_IN_PLACE, flags, 2, MPI_INTEGER, MPI_MAX, h%comm)
    if (flags(1) /= 0) then
      h%failed = h%failed + 1
      if (h%rank == 0) write(output_unit, '(a)') '[FAIL] ' // trim(suite) // '::' // trim(name)
    else if (flags(2) /= 0) then
      h%skipped = h%skipped + 1
      if (h%rank == 0) write(output_unit, '(a)') '[SKIP] ' // trim(suite) // '::' // trim(name)
    else
      h%passed = h%passed + 1
      if (h%rank == 0) write(output_unit, '(a)') '[ OK ] ' // trim(suite) // '::' // trim(name)
    end if
    flush(output_unit)
  end subroutine run_test

  !> Marks the running test as skipped (e.g. it needs more ranks than given).
  subroutine skip_test(reason)
    character(len=*), intent(in) :: reason
    h%current_skipped = .true.
    if (h%rank == 0) write(output_unit, '(a)') '  skipped: ' // reason
  end subroutine skip_test

  !> Prints the closing line and returns the number of failed tests.
  function testing_summary() result(nfailed)
    integer :: nfailed
    character(len=96) :: line
    if (h%skipped > 0) then
      write(line, '(i0,a,i0,a,i0,a)') h%passed, ' passed, ', h%failed, ' failed, ', &
        h%skipped, ' skipped'
    else
      write(line, '(i0,a,i0,a)') h%passed, ' passed, ', h%failed, ' failed'
    end if
    if (h%rank == 0) write(output_unit, '(a)') trim(line)
    nfailed = h%failed
  end function testing_summary

  subroutine report(msg)
    character(len=*), intent(in) :: msg
    character(len=16) :: r
    h%current_failed = .true.
    write(r, '(i0)') h%rank
    write(error_unit, '(a)') '  FAILED ' // trim(h%suite) // '::' // trim(h%test) // &
      ' (rank ' // trim(r) // '): ' // msg
    flush(error_unit)
  end subroutine report

  subroutine assert_true(cond, msg)
    logical, intent(in) :: cond
    character(len=*), intent(in) :: msg
    if (.not. cond) call report(msg)
  end subroutine assert_true

  subroutine assert_equal_int(expected, actual, msg)
    integer, intent(in) :: expected, actual
    character(len=*), intent(in) :: msg
    character(len=64) :: s
    if (expected /= actual) then
      write(s, '(a,i0,a,i0)') 'expected ', expected, ', actual ', actual
      call report(msg // ': ' // trim(s))
    end if
  end subroutine assert_equal_int

  subroutine assert_equal_str(expected, actual, msg)
    character(len=*), intent(in) :: expected, actual, msg
    if (expected /= actual) call report(msg // ': expected "' // expected // &
                                        '", actual "' // actual // '"')
  end subroutine assert_equal_str

  subroutine assert_equal_real(expected, actual, tolerance, msg)
    real(wp), intent(in) :: expected, actual, tolerance
    character(len=*), intent(in) :: msg
    character(len=160) :: s
    if (.not. (abs(actual - expected) <= tolerance)) then
      write(s, '(3(a,es24.16))') 'expected ', expected, ', actual ', actual, &
        ', tolerance ', tolerance
      call report(msg // ': ' // trim(s))
    end if
  end subroutine assert_equal_real

  subroutine assert_equal_real_array(expected, actual, tolerance, msg)
    real(wp), intent(in) :: expected(:), actual(:), tolerance
    character(len=*), intent(in) :: msg
    integer :: k
    character(len=200) :: s
    if (size(expected) /= size(actual)) then
      call report(msg // ': array sizes differ')
      return
    end if
    do k = 1, size(expected)
      if (.not. (abs(actual(k) - expected(k)) <= tolerance)) then
        write(s, '(a,i0,3(a,es24.16))') 'element ', k, ': expected ', expected(k), &
          ', actual ', actual(k), ', tolerance ', tolerance
        call report(msg // ': ' // trim(s))
        return
      end if
    end do
  end subroutine assert_equal_real_array

  subroutine assert_rel_real(expected, actual, rel_tol, msg)
    real(wp), intent(in) :: expected, actual, rel_tol
    character(len=*), intent(in) :: msg
    character(len=200) :: s
    if (.not. (abs(actual - expected) <= rel_tol * abs(expected))) then
      write(s, '(3(a,es24.16))') 'expected ', expected, ', actual ', actual, &
        ', relative tolerance ', rel_tol
      call report(msg // ': ' // trim(s))
    end if
  end subroutine assert_rel_real

  subroutine assert_rel_real_array(expected, actual, rel_tol, msg)
    real(wp), intent(in) :: expected(:), actual(:), rel_tol
    character(len=*), intent(in) :: msg
    integer :: k
    character(len=200) :: s
    if (size(expected) /= size(actual)) then
      call report(msg // ': array sizes differ')
      return
    end if
    do k = 1, size(expected)
      if (.not. (abs(actual(k) - expected(k)) <= rel_tol * abs(expected(k)))) then
        write(s, '(a,i0,3(a,es24.16))') 'element ', k, ': expected ', expected(k), &
          ', actual ', actual(k), ', relative tolerance ', rel_tol
        call report(msg // ': ' // trim(s))
        return
      end if
    end do
  end subroutine assert_rel_real_array

  !> Bit-for-bit equality of two real arrays (the decomposition-independence
  !> tests ask for it, not for closeness).
  pure logical function same_bits(a, b)
    real(wp), intent(in) :: a(:), b(:)
    same_bits = size(a) == size(b)
    if (same_bits) same_bits = all(transfer(a, 1_i8, size(a)) == transfer(b, 1_i8, size(b)))
  end function same_bits

end module testing
