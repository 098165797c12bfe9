!> Requests to stop from the operating system: SIGTERM and SIGINT (what batch
!> schedulers send at the time limit, and Ctrl-C) and SIGUSR1 (which mpirun
!> passes on to every rank, and schedulers can send ahead of the limit) are
!> caught and remembered; the time loop asks after each step and stops with
!> a checkpoint (simulation.f90, doc/guide/restarts.md "Stopping and continuing").
!> The handler then restores the default action, so a second signal of the
!> same kind ends the process at once.
!>
!> The caught signal is the code's one mutable module variable: a signal
!> handler has nowhere else to leave it.
module signals
  use, intrinsic :: iso_c_binding, only: c_int, c_funptr, c_funloc, c_null_funptr
  implicit none
  private
  public :: signals_install, signals_caught, signal_name, signal_raise
  public :: SIGINT, SIGTERM, SIGUSR1

  !> Linux's numbers (x86-64, ARM): SIGINT and SIGTERM are POSIX's 2 and 15
  integer(c_int), parameter :: SIGINT = 2, SIGUSR1 = 10, SIGTERM = 15

  !> the first signal caught, 0 for none
  integer(c_int), volatile, save :: caught = 0

  interface
    !> C's signal(2): the handler, or SIG_DFL as a null pointer
    function c_signal(signum, handler) bind(C, name='signal') result(previous)
      import :: c_int, c_funptr
      integer(c_int), value :: signum
      type(c_funptr), value :: handler
      type(c_funptr) :: previous
    end function c_signal
    function c_raise(signum) bind(C, name='raise') result(status)
      import :: c_int
      integer(c_int), value :: signum
      integer(c_int) :: status
    end function c_raise
  end interface

contains

  !> Catches SIGTERM, SIGINT and SIGUSR1 from now on.
  subroutine signals_install()
    type(c_funptr) :: previous
    previous = c_signal(SIGTERM, c_funloc(on_signal))
    previous = c_signal(SIGINT, c_funloc(on_signal))
    previous = c_signal(SIGUSR1, c_funloc(on_signal))
  end subroutine signals_install

  !> The first signal caught since signals_install, 0 for none.
  integer function signals_caught() result(signum)
    signum = caught
  end function signals_caught

  !> Sends signal signum to this process (for the tests).
  subroutine signal_raise(signum)
    integer, intent(in) :: signum
    integer(c_int) :: status
    status = c_raise(int(signum, c_int))
  end subroutine signal_raise

  function signal_name(signum) result(name)
    integer, intent(in) :: signum
    character(len=:), allocatable :: name
    select case (signum)
    case (SIGINT)
      name = 'SIGINT'
    case (SIGTERM)
      name = 'SIGTERM'
    case (SIGUSR1)
      name = 'SIGUSR1'
    case default
      name = 'a signal'
    end select
  end function signal_name

  !> Only async-signal-safe work here: remember, and let the next signal
  !> of this kind take its default action (signal(2) is async-signal-safe).
  subroutine on_signal(signum) bind(C)
    integer(c_int), value :: signum
    type(c_funptr) :: previous
    if (caught == 0) caught = signum
    previous = c_signal(signum, c_null_funptr)
  end subroutine on_signal

end module signals
