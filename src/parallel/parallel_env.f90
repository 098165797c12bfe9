!> The communication layer: one communicator object, duplicated from the
!> world at start-up and passed down.  Physics modules never call MPI; they
!> call the reductions here on the parallel_env_t they are given.
module parallel_env
  use, intrinsic :: iso_fortran_env, only: error_unit, output_unit
  use, intrinsic :: iso_c_binding, only: c_int
  use kinds, only: wp, i8
  use mpi_f08, only: MPI_Comm, MPI_Init, MPI_Finalize, MPI_Comm_dup, MPI_Comm_free, &
                     MPI_Comm_rank, MPI_Comm_size, MPI_Allreduce, MPI_Abort, MPI_Barrier, &
                     MPI_Wtime, MPI_IN_PLACE, MPI_DOUBLE_PRECISION, MPI_INTEGER, MPI_INTEGER8, &
                     MPI_SUM, MPI_MAX, MPI_MIN, MPI_COMM_WORLD, MPI_Initialized, MPI_Bcast
  implicit none
  private
  public :: parallel_env_t, par_start, par_stop, par_from_comm, par_sum, par_sum_array, par_max, par_min, &
            par_sum_exact, par_any, par_barrier, par_abort, wall_time, exit_process, par_bcast_int

  !> The ranks running one simulation.
  type :: parallel_env_t
    type(MPI_Comm) :: comm
    integer :: rank = 0
    integer :: nranks = 1
  end type parallel_env_t

  interface
    subroutine c_exit(status) bind(c, name='exit')
      import :: c_int
      integer(c_int), value :: status
    end subroutine c_exit
  end interface

contains

  !> Initialises MPI and returns an environment on a duplicate of the world.
  function par_start() result(env)
    type(parallel_env_t) :: env
    call MPI_Init()
    call MPI_Comm_dup(MPI_COMM_WORLD, env%comm)
    call MPI_Comm_rank(env%comm, env%rank)
    call MPI_Comm_size(env%comm, env%nranks)
  end function par_start

  !> An environment on an existing communicator (tests).
  function par_from_comm(comm) result(env)
    type(MPI_Comm), intent(in) :: comm
    type(parallel_env_t) :: env
    env%comm = comm
    call MPI_Comm_rank(comm, env%rank)
    call MPI_Comm_size(comm, env%nranks)
  end function par_from_comm

  !> Frees the communicator, finalises MPI and exits with `status`.  Every
  !> rank must call it (an error all ranks detected, or the normal end).
  subroutine par_stop(env, status)
    type(parallel_env_t), intent(inout) :: env
    integer, intent(in) :: status
    flush(output_unit)
    flush(error_unit)
    call MPI_Comm_free(env%comm)
    call MPI_Finalize()
    call exit_process(status)
  end subroutine par_stop

  !> Ends the process with an exit status, without the compiler's STOP banner.
  subroutine exit_process(status)
    integer, intent(in) :: status
    call c_exit(int(status, c_int))
  end subroutine exit_process

  !> Stops every rank from one rank (an error only this rank saw).
  subroutine par_abort(env, msg)
    type(parallel_env_t), intent(in) :: env
    character(len=*), intent(in) :: msg
    logical :: init
    write(error_unit, '(a,i0,a)') 'sph: error on rank ', env%rank, ': ' // msg
    flush(error_unit)
    call MPI_Initialized(init)
    if (init) call MPI_Abort(env%comm, 1)
    call exit_process(1)
  end subroutine par_abort

  function par_sum(env, x) result(s)
    type(parallel_env_t), intent(in) :: env
    real(wp), intent(in) :: x
    real(wp) :: s
    s = x
    call MPI_Allreduce(MPI_IN_PLACE, s, 1, MPI_DOUBLE_PRECISION, MPI_SUM, env%comm)
  end function par_sum

  !> Sums an array element-wise over the ranks, in place.
  subroutine par_sum_array(env, x)
    type(parallel_env_t), intent(in) :: env
    real(wp), intent(inout) :: x(:)
    call MPI_Allreduce(MPI_IN_PLACE, x, size(x), MPI_DOUBLE_PRECISION, MPI_SUM, env%comm)
  end subroutine par_sum_array

  !> Column sums s(k) = Sum_i x(k, i) over every rank's columns that do not
  !> depend on how the columns are spread over the ranks or ordered: each
  !> term is rounded to a multiple of the quantum q_k = M_k N / 2^61 (M_k the
  !> largest |x(k, i)| anywhere, N the number of columns in all) and the
  !> multiples are summed exactly in 64-bit integers, which cannot overflow.
  !> The relative accuracy is about N 2^-61 of M_k: decisions taken on such
  !> sums are the same whatever the number of ranks.
  function par_sum_exact(env, x) result(s)
    type(parallel_env_t), intent(in) :: env
    real(wp), intent(in) :: x(:, :)
    real(wp) :: s(size(x, 1))
    real(wp) :: big(size(x, 1)), q(size(x, 1)), rq(size(x, 1))
    integer(i8) :: isum(size(x, 1)), ntot
    integer :: i, m
    m = size(x, 1)
    ntot = size(x, 2, kind=i8)
    call MPI_Allreduce(MPI_IN_PLACE, ntot, 1, MPI_INTEGER8, MPI_SUM, env%comm)
    big = 0
    do i = 1, size(x, 2)
      big = max(big, abs(x(:, i)))
    end do
    call MPI_Allreduce(MPI_IN_PLACE, big, m, MPI_DOUBLE_PRECISION, MPI_MAX, env%comm)
    q = big * real(max(ntot, 1_i8), wp) * 2.0_wp**(-61)
    rq = 0
    where (q > 0) rq = 1 / q
    ! rounds half away from zero like nint, without a library call per term
    isum = 0
    do i = 1, size(x, 2)
      isum = isum + int(x(:, i) * rq + sign(0.5_wp, x(:, i)), i8)
    end do
    call MPI_Allreduce(MPI_IN_PLACE, isum, m, MPI_INTEGER8, MPI_SUM, env%comm)
    s = real(isum, wp) * q
  end function par_sum_exact

  function par_max(env, x) result(s)
    type(parallel_env_t), intent(in) :: env
    real(wp), intent(in) :: x
    real(wp) :: s
    s = x
    call MPI_Allreduce(MPI_IN_PLACE, s, 1, MPI_DOUBLE_PRECISION, MPI_MAX, env%comm)
  end function par_max

  function par_min(env, x) result(s)
    type(parallel_env_t), intent(in) :: env
    real(wp), intent(in) :: x
    real(wp) :: s
    s = x
    call MPI_Allreduce(MPI_IN_PLACE, s, 1, MPI_DOUBLE_PRECISION, MPI_MIN, env%comm)
  end function par_min

  !> True on every rank if `flag` is true on any rank.
  function par_any(env, flag) result(any_flag)
    type(parallel_env_t), intent(in) :: env
    logical, intent(in) :: flag
    logical :: any_flag
    integer :: v
    v = merge(1, 0, flag)
    call MPI_Allreduce(MPI_IN_PLACE, v, 1, MPI_INTEGER, MPI_MAX, env%comm)
    any_flag = v /= 0
  end function par_any

  !> Broadcasts an integer array from rank 0.
  subroutine par_bcast_int(env, a)
    type(parallel_env_t), intent(in) :: env
    integer, intent(inout) :: a(:)
    call MPI_Bcast(a, size(a), MPI_INTEGER, 0, env%comm)
  end subroutine par_bcast_int

  subroutine par_barrier(env)
    type(parallel_env_t), intent(in) :: env
    call MPI_Barrier(env%comm)
  end subroutine par_barrier

  function wall_time() result(t)
    real(wp) :: t
    t = MPI_Wtime()
  end function wall_time

end module parallel_env
