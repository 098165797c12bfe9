!> sph: weakly-compressible SPH for free-surface flows.
!>   mpirun -np P ./sph input/<case>.nml [group.variable=value ...]
program sph
  use, intrinsic :: iso_fortran_env, only: output_unit, error_unit
  use config, only: config_t, config_load, config_write_defaults, config_write_help, &
                    config_write_input_tables
  use parallel_env, only: parallel_env_t, par_start, par_stop
  use simulation, only: simulation_run
  use memory_usage, only: map_large_arrays
  implicit none
  type(parallel_env_t) :: env
  type(config_t) :: cfg
  character(len=:), allocatable :: path, errmsg, arg
  character(len=512), allocatable :: overrides(:)
  integer :: k, nargs, len_arg, status
  logical :: ok

  call map_large_arrays()
  env = par_start()
  nargs = command_argument_count()
  allocate(overrides(0))
  path = ''
  do k = 1, nargs
    call get_command_argument(k, length=len_arg)
    allocate(character(len=len_arg) :: arg)
    call get_command_argument(k, arg)
    select case (arg)
    case ('-h', '--help', '--defaults', '--input-tables')
      ! each prints and ends the run: an argument beside it would be ignored
      if (nargs /= 1) call fail(arg // ' takes no other argument (see ./sph --help)')
      if (env%rank == 0) then
        select case (arg)
        case ('--defaults')
          call config_write_defaults(output_unit)
        case ('--input-tables')
          call config_write_input_tables(output_unit)
        case default
          call print_usage(output_unit)
        end select
      end if
      call par_stop(env, 0)
    case default
      if (arg(1:min(1, len(arg))) == '-') then
        call fail('unknown option ' // arg // ' (see ./sph --help)')
      else if (len(path) == 0 .and. index(arg, '=') == 0) then
        path = arg
      else if (len(arg) > len(overrides)) then
        call fail('command-line override too long: ' // arg)
      else
        overrides = [character(len=len(overrides)) :: overrides, arg]
      end if
    end select
    deallocate(arg)
  end do
  if (len(path) == 0) call fail('no input file given (see ./sph --help)')

  call config_load(path, overrides, cfg, ok, errmsg)
  if (.not. ok) call fail(errmsg)

  call simulation_run(cfg, env, status)
  call par_stop(env, status)

contains

  !> An error every rank detected identically: rank 0 says it, all stop.
  subroutine fail(msg)
    character(len=*), intent(in) :: msg
    if (env%rank == 0) write(error_unit, '(a)') 'sph: error: ' // msg
    call par_stop(env, 2)
  end subroutine fail

  subroutine print_usage(u)
    integer, intent(in) :: u
    write(u, '(a)') 'usage: mpirun -np P ./sph INPUT.nml [group.variable=value ...]'
    write(u, '(a)') '       ./sph --defaults     print a complete input file with every default'
    write(u, '(a)') '       ./sph --input-tables print the tables of doc/reference/input.md (markdown)'
    write(u, '(a)') '       ./sph --help         print this help'
    write(u, '(a)') ''
    write(u, '(a)') 'Runs the case described by the namelist file INPUT.nml (see input/ and'
    write(u, '(a)') 'doc/reference/input.md).  Any variable can be overridden on the command line, e.g.'
    write(u, '(a)') '  ./sph input/circle2d.nml numerics.cfl=0.5 particles.n=5000 output.dir=runs/x'
    write(u, '(a)') 'Outputs go to output.dir: snap_NNNNN.h5 snapshots, snapshots.xdmf (open it'
    write(u, '(a)') 'in ParaView), timeseries.csv and the effective input, input.nml (doc/reference/output.md).'
    write(u, '(a)') ''
    call config_write_help(u)
  end subroutine print_usage

end program sph
