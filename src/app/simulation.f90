!> One run from a validated configuration: set up the case, step to the end
!> time, write snapshots and the time series, print progress and the final
!> comparison with the exact solution.  simulation_run reads as the run
!> goes: set-up, then each step followed by its outputs and the check for a
!> requested stop, then the closing summaries.  The set-up's translation of
!> the input is run_setup's, the printed reports run_report's.
module simulation
  use, intrinsic :: iso_fortran_env, only: output_unit, error_unit
  use, intrinsic :: ieee_arithmetic, only: ieee_is_nan
  use kinds, only: wp, i8
  use particles, only: particles_t
  use config, only: config_t, config_dim, config_echo, config_scaled
  use solver, only: solver_t, solver_init, solver_step, solver_evaluate, solver_time_step, &
                    solver_flow_fields, solver_sync_halo, step_history_t, solver_history, &
                    solver_restore, solver_timing_t
  use diagnostics, only: kinetic_energy, total_mass, total_momentum, probe_pressure, &
                         probe_pressure_quadratic, find_bad_particle
  use case_base, only: case_t, case_fields_t, case_flow_t
  use parallel_env, only: parallel_env_t, par_sum, par_any, par_max, wall_time
  use fileutil, only: make_directory, join_path, rename_file, temp_path, file_exists
  use snapshot_io, only: snapshot_field_t, snapshot_source_t, snapshot_write, &
                         snapshot_filename, xdmf_init
  use particle_io, only: particles_snapshot_fields, particles_whole_body
  use timeseries, only: timeseries_init, timeseries_add, timeseries_flush, timeseries_load
  use restart, only: restart_read, restart_index_history, snapshot_number, restart_info_t, &
                     history_attributes, mirror_attributes
  use signals, only: signals_install, signals_caught, signal_name
  use mirrors, only: mirror_copies
  use run_setup, only: run_t, setup, check_setup, par_any_fail
  use run_report, only: print_start, print_progress, print_end, print_stopped, report_blow_up
  implicit none
  private
  public :: simulation_run, EXIT_CHECKPOINT

  !> The exit code of a run stopped early with a checkpoint (a signal or
  !> run.wall_limit): sysexits' EX_TEMPFAIL, "try again", for job scripts
  integer, parameter :: EXIT_CHECKPOINT = 75
  character(len=*), parameter :: CHECKPOINT_FILE = 'checkpoint.h5'

  !> The case's extra fields of a snapshot at time t, made one at a time
  !> as the snapshot writes them (case_t%field).
  type, extends(snapshot_source_t) :: case_source_t
    class(case_t), pointer :: problem => null()
    type(particles_t), pointer :: parts => null()
    type(case_flow_t), pointer :: flow => null()
    real(wp) :: t = 0
  contains
    procedure :: fill => case_source_fill
  end type case_source_t

contains

  !> Runs the case described by cfg; status is the process exit code
  !> (0 success, 1 a failure during the run, 2 an input refused before
  !> anything was written, EXIT_CHECKPOINT stopped early with a checkpoint).
  subroutine simulation_run(cfg_in, env, status)
    !> the input as given; the run uses it with the resolution scaling applied
    type(config_t), intent(in) :: cfg_in
    type(parallel_env_t), intent(in) :: env
    integer, intent(out) :: status
    type(solver_t), target :: s        !< target: the snapshots view its particles
    type(run_t) :: run
    type(config_t) :: cfg
    real(wp) :: t, dt, dt_est, t_end, tol, t_next_out, t0_run, wall0, wall_last, wall_iter
    integer :: step, step0, i_bad, k_out
    logical :: ok, done
    character(len=:), allocatable :: errmsg, reason

    run%wall_start = wall_time()
    call signals_install()
    cfg = config_scaled(cfg_in)
    t_end = cfg%run%t_end
    tol = 1e-12_wp * max(1.0_wp, t_end)

    ! ---- set-up: the state to start from, the outputs, snapshot 0 ----
    call start_state(cfg, env, tol, s, run, t, step, dt_est, status)
    if (status /= 0) return
    call open_outputs(cfg_in, cfg, env, run, t, status)
    if (status /= 0) return
    call print_start(cfg, env, s, run, dt_est)
    if (len_trim(cfg%run%restart) > 0) then
      if (env%rank == 0) write(output_unit, '(a,es12.5,a,i0,a)') '  restarted from ' // &
        trim(cfg%run%restart) // ' at t = ', t, ', step ', step, ''
    else
      call sample(run, env, s, t, step, 0.0_wp, warn_empty_probes=.true.)
      call write_snapshot(cfg, env, s, run, t, step, ok)
      if (.not. ok) then
        status = 1
        return
      end if
    end if
    ! output times are k output.dt (a product, not a running sum, so a
    ! restarted run finds the same ones)
    k_out = int(t / cfg%output%dt + 1e-9_wp)
    t_next_out = (k_out + 1) * cfg%output%dt
    wall0 = wall_time()
    wall_last = wall0
    t0_run = t
    step0 = step
    ! traffic and time per step: the set-up's migration, first halo and
    ! first evaluation not counted
    s%dc%words_sent = 0
    s%dc%messages_sent = 0
    s%dc%comm_time = 0
    s%timing = solver_timing_t()
    done = t >= t_end - tol .or. (cfg%run%max_steps > 0 .and. step >= cfg%run%max_steps)

    do while (.not. done)
      ! ---- one step, to the next output time at most ----
      wall_iter = wall_time()
      call solver_step(s, env, min(t_next_out, t_end) - t, dt)
      step = step + 1
      ! the last step lands on the output time exactly (dt was clipped to it)
      if (abs(min(t_next_out, t_end) - (t + dt)) <= tol) then
        t = min(t_next_out, t_end)
      else
        t = t + dt
      end if
      done = t >= t_end - tol .or. (cfg%run%max_steps > 0 .and. step >= cfg%run%max_steps)
      i_bad = find_bad_particle(s%parts, run%problem%mirror)
      if (par_any(env, i_bad > 0)) then
        call report_blow_up(s, step, t, i_bad, run%problem%mirror)
        call timeseries_flush(run%ts, ok, errmsg)
        status = 1
        return
      end if

      ! ---- outputs: a row of the time series, a snapshot at an output time ----
      if (mod(step, cfg%output%probe_every) == 0 .or. done) call sample(run, env, s, t, step, dt)
      if (t >= t_next_out - tol .or. done) then
        do while ((k_out + 1) * cfg%output%dt <= t + tol)
          k_out = k_out + 1
        end do
        t_next_out = (k_out + 1) * cfg%output%dt
        ! case fields (e.g. vorticity) may use the halo copies: bring them
        ! to the end of the step
        call solver_sync_halo(s, env)
        call write_snapshot(cfg, env, s, run, t, step, ok)
        if (.not. ok) then
          status = 1
          return
        end if
        ! a run restarted from this snapshot starts with a fresh list: so
        ! does this one, and both go on identically
        s%lm%force_rebuild = .true.
      end if
      if (wall_time() - wall_last >= cfg%run%progress_interval .or. done) then
        wall_last = wall_time()
        call print_progress(env, step, t, dt, t0_run, t_end, wall_last - wall0, s%dc%imbalance)
      end if
      run%iter_max = max(run%iter_max, wall_time() - wall_iter)

      ! ---- a stop requested before the end: a checkpoint to go on from ----
      if (.not. done) then
        if (stop_requested(cfg, env, run, reason)) then
          call write_checkpoint(env, s, run, t, step, ok)
          status = 1
          if (ok) then
            call print_stopped(env, reason, join_path(run%dir, CHECKPOINT_FILE), step, t)
            status = EXIT_CHECKPOINT
          end if
          return
        end if
      end if
    end do

    ! ---- closing: the costs, then the case's comparison ----
    call print_end(env, s, run, step - step0, wall_time() - wall0)
    call run%problem%summary(env, output_unit, t, s%parts, s%rhs%kernel)
  end subroutine simulation_run

  !> The state the run starts from: the case's particles (setup), or those
  !> of the snapshot or checkpoint run.restart names, with its time, step
  !> and the history of the steps before; the solver built on them, and its
  !> first evaluation, whose time step dt_est the start reports.  status 2
  !> when the input is refused: nothing has been written.
  subroutine start_state(cfg, env, tol, s, run, t, step, dt_est, status)
    type(config_t), intent(in) :: cfg
    type(parallel_env_t), intent(in) :: env
    real(wp), intent(in) :: tol                  !< times closer than tol are one
    type(solver_t), intent(inout) :: s
    type(run_t), intent(inout) :: run
    real(wp), intent(out) :: t, dt_est
    integer, intent(out) :: step, status
    type(restart_info_t) :: info
    type(step_history_t) :: history
    character(len=:), allocatable :: errmsg
    character(len=160) :: line
    logical :: ok, restarting
    real(wp) :: w
    status = 2
    t = 0
    step = 0
    dt_est = 0
    restarting = len_trim(cfg%run%restart) > 0
    call setup(cfg, env, s, run, ok)
    if (.not. ok) return
    if (restarting) then
      ! the snapshot's particles replace the initial ones; nothing is
      ! written before it has been read and checked
      w = wall_time()
      call restart_read(env, trim(cfg%run%restart), trim(cfg%run%case_name), config_dim(cfg), &
                        s%parts, t, step, ok, errmsg, info, mirror=run%problem%mirror)
      run%write_max = wall_time() - w
      if (ok .and. t >= cfg%run%t_end - tol) then
        ok = .false.
        ! (errmsg is of deferred length: written through a buffer)
        write(line, '(a,es12.5,a,es12.5,a)') ''': the snapshot is at t = ', t, &
          ', not before &run t_end = ', cfg%run%t_end, ': nothing to do (raise run.t_end)'
        errmsg = '&run restart = ''' // trim(cfg%run%restart) // trim(line)
      end if
      if (.not. par_any_fail(env, ok, errmsg)) return
      run%n_snapshots = max(0, snapshot_number(trim(cfg%run%restart)) + 1)
      if (info%checkpoint) run%n_snapshots = max(0, info%snapshots_written)
      history%skin = info%list_skin
      history%force_rebuild = info%force_rebuild
    end if
    if (restarting .and. info%checkpoint) then
      call solver_init(s, env, resume=history)
    else
      call solver_init(s, env)
    end if
    run%n_global = nint(par_sum(env, real(s%parts%n, wp)), i8)

    ! first evaluation, before anything is written: the time-step limits to
    ! report, and a set-up whose scales the arithmetic cannot hold refused
    call solver_evaluate(s, env)
    call solver_time_step(s, env, dt_est)
    call check_setup(env, s, run%n_global, dt_est, ok, errmsg)
    if (.not. par_any_fail(env, ok, errmsg)) return
    if (restarting) then
      ! the largest acceleration of the step before (that of the evaluation
      ! just made when the file does not say it)
      history%a_max = s%a_local
      if (info%has_accel) history%a_max = info%accel_max
      call solver_restore(s, history)
    end if
    status = 0
  end subroutine start_state

  !> The output directory with the input echoed in it, the XDMF index and
  !> the time series; a restarted run (at time t) keeps the earlier
  !> snapshots in the index and the rows up to t.  status 2 when output.dir
  !> cannot be made (nothing written), 1 when a file cannot be written or read.
  subroutine open_outputs(cfg_in, cfg, env, run, t, status)
    type(config_t), intent(in) :: cfg_in       !< the input as given, echoed
    type(config_t), intent(in) :: cfg
    type(parallel_env_t), intent(in) :: env
    type(run_t), intent(inout) :: run
    real(wp), intent(in) :: t
    integer, intent(out) :: status
    character(len=:), allocatable :: errmsg
    logical :: ok, have_series
    status = 2                 ! bad input: nothing has been written
    run%dir = trim(cfg%output%dir)
    call make_directory(run%dir, ok, errmsg)
    if (.not. ok) errmsg = '&output dir = ''' // run%dir // ''': ' // errmsg // &
                           ' (allowed: a directory that exists or can be created, writable)'
    if (.not. par_any_fail(env, ok, errmsg)) return
    status = 1
    if (env%rank == 0) call echo_input(cfg_in, join_path(run%dir, 'input.nml'), ok, errmsg)
    if (.not. par_any_fail(env, ok, errmsg)) return
    call xdmf_init(run%xdmf, join_path(run%dir, 'snapshots.xdmf'))
    call timeseries_init(run%ts, env%comm, join_path(run%dir, 'timeseries.csv'), &
                         column_names(run, config_dim(cfg)))
    if (len_trim(cfg%run%restart) > 0) then
      ! continue the history of the run directory: earlier snapshots stay in
      ! the index, time-series rows up to the restart time are kept
      call restart_index_history(env, run%dir, run%n_snapshots, run%xdmf, ok, errmsg)
      have_series = file_exists(join_path(run%dir, 'timeseries.csv'))
      if (ok .and. have_series) &       ! collective: every rank sees the same file
        call timeseries_load(run%ts, join_path(run%dir, 'timeseries.csv'), t, ok, errmsg)
      if (.not. par_any_fail(env, ok, errmsg)) return
    end if
    status = 0
  end subroutine open_outputs

  !> Whether to stop before the next step, and why: a signal caught on any
  !> rank, or run.wall_limit about to be passed by the next step and a
  !> checkpoint (twice the longest of each so far).  Collective.
  logical function stop_requested(cfg, env, run, reason) result(requested)
    type(config_t), intent(in) :: cfg
    type(parallel_env_t), intent(in) :: env
    type(run_t), intent(in) :: run
    character(len=:), allocatable, intent(out) :: reason
    integer :: signum
    logical :: in_time
    real(wp) :: w
    signum = signals_caught()
    w = wall_time()
    in_time = cfg%run%wall_limit <= 0 .or. &
              w - run%wall_start + 2 * (run%iter_max + run%write_max) < cfg%run%wall_limit
    requested = par_any(env, signum /= 0 .or. .not. in_time)
    if (.not. requested) return
    signum = nint(par_max(env, real(signum, wp)))
    reason = 'run.wall_limit'
    if (signum /= 0) reason = signal_name(signum)
  end function stop_requested

  !> The columns of the time series: the run's, then the case's.
  function column_names(run, dim) result(names)
    type(run_t), intent(in) :: run
    integer, intent(in) :: dim
    character(len=32), allocatable :: names(:), case_names(:)
    character(len=1), parameter :: ax(3) = ['x', 'y', 'z']
    character(len=8) :: num
    integer :: k
    names = [character(len=32) :: 'time', 'step', 'dt', 'imbalance', 'kinetic_energy', 'mass']
    names = [character(len=32) :: names, ('momentum_' // ax(k), k = 1, dim)]
    do k = 1, run%n_probes
      write(num, '(i0)') k
      names = [character(len=32) :: names, 'p_probe_' // trim(num)]
    end do
    call run%problem%columns(case_names)
    names = [character(len=32) :: names, case_names]
  end function column_names

  !> One row of the time series.
  !> With warn_empty_probes, rank 0 says which probes have no particle
  !> within their support (nan in the time series): at the start, most
  !> likely a probe placed outside the fluid.
  subroutine sample(run, env, s, t, step, dt, warn_empty_probes)
    type(run_t), intent(inout) :: run
    type(parallel_env_t), intent(in) :: env
    type(solver_t), intent(in) :: s
    real(wp), intent(in) :: t, dt
    integer, intent(in) :: step
    logical, intent(in), optional :: warn_empty_probes
    real(wp), allocatable :: row(:), case_values(:)
    real(wp) :: mom(3), p_probe(16)
    integer :: k, dim, mirror
    dim = s%parts%dim
    mirror = run%problem%mirror
    mom = total_momentum(env, s%parts, mirror)
    p_probe = 0
    do k = 1, run%n_probes
      if (run%probe_quadratic) then
        p_probe(k) = probe_pressure_quadratic(env, s%parts, s%rhs%kernel, run%probes(:, k), &
                                              mirror)
      else
        p_probe(k) = probe_pressure(env, s%parts, s%rhs%kernel, run%probes(:, k), mirror)
      end if
    end do
    if (present(warn_empty_probes) .and. env%rank == 0) then
      do k = 1, run%n_probes
        if (warn_empty_probes .and. ieee_is_nan(p_probe(k))) &
          write(output_unit, '(a,i0,a,3(g0.6,1x),a)') 'sph: warning: probe ', k, ' at ', &
            run%probes(:, k), 'has no particle within its kernel support: its pressure ' // &
            'is nan until fluid reaches it (output.probes)'
      end do
      ! a position set beyond n_probes is kept (the echo of the input shows
      ! it) but not sampled: likely a forgotten n_probes
      do k = run%n_probes + 1, size(run%probes, 2)
        if (warn_empty_probes .and. any(abs(run%probes(:, k)) > 0)) &
          write(output_unit, '(a,i0,a,i0,a)') 'sph: warning: output.probes(1:3,', k, &
            ') is set but output.n_probes = ', run%n_probes, ': that probe is not sampled'
      end do
    end if
    call run%problem%sample(env, t, s%parts, s%rhs%kernel, case_values)
    row = [t, real(step, wp), dt, s%dc%imbalance, kinetic_energy(env, s%parts, mirror), &
           total_mass(env, s%parts, mirror), &
           mom(1:dim), p_probe(1:run%n_probes), case_values]
    call timeseries_add(run%ts, row)
    run%imb_sum = run%imb_sum + s%dc%imbalance
    run%imb_max = max(run%imb_max, s%dc%imbalance)
    run%imb_n = run%imb_n + 1
  end subroutine sample

  !> Snapshot number run%n_snapshots at time t, with the case's exact fields,
  !> then the time series is flushed so both describe the same moment (the
  !> longest such write in run%write_max).
  subroutine write_snapshot(cfg, env, s, run, t, step, ok)
    type(config_t), intent(in) :: cfg
    type(parallel_env_t), intent(in) :: env
    type(solver_t), intent(inout), target :: s     !< the snapshot views its particles
    type(run_t), intent(inout), target :: run      !< the source calls its case
    real(wp), intent(in) :: t
    integer, intent(in) :: step
    logical, intent(out) :: ok
    type(case_fields_t) :: f
    type(case_flow_t), target :: flow
    type(case_source_t) :: source
    type(snapshot_field_t), allocatable :: extra(:), fields(:)
    type(particles_t), target :: whole
    character(len=:), allocatable :: errmsg
    character(len=32), allocatable :: names(:)
    real(wp), allocatable :: values(:)
    integer :: k, nv, ns, mask
    real(wp) :: w
    w = wall_time()
    ok = .true.
    if (cfg%output%snapshots) then
      ! the step history a restart from this snapshot needs (restart.f90)
      call history_attributes(restart_info_t(accel_max=par_max(env, s%a_local)), names, values)
      call solver_flow_fields(s, flow%lambda, flow%omega)
      call run%problem%fields(t, f)
      nv = size(f%vector_names)
      ns = size(f%scalar_names)
      ! only their names here: the writer has each made (source) just
      ! before writing it and frees it after, so one is held at a time
      ! (all at once, a million particles on 2 ranks peaked at 423 MB a
      ! rank, against 381: doc/studies/ellipsoid3d.md)
      allocate(extra(nv + ns))
      do k = 1, nv
        extra(k)%name = trim(f%vector_names(k))
        extra(k)%computed = 'v'
      end do
      do k = 1, ns
        extra(nv + k)%name = trim(f%scalar_names(k))
        extra(nv + k)%computed = 's'
      end do
      source%problem => run%problem
      source%flow => flow
      source%t = t
      if (allocated(f%attr_names)) then
        names = [f%attr_names, names]
        values = [f%attr_values, values]
      end if
      mask = run%problem%mirror
      if (cfg%output%mirror) then
        ! (M3) the whole body: the part, then its reflections
        call particles_whole_body(s%parts, mask, whole)
        flow%lambda = [(flow%lambda(1:s%parts%n), k = 1, mirror_copies(mask))]
        source%parts => whole
      else
        source%parts => s%parts
      end if
      call particles_snapshot_fields(source%parts, extra, fields)
      call mirror_attributes(mask, merge(mirror_copies(mask), 1, cfg%output%mirror), names, &
                             values)
      call snapshot_write(env%comm, join_path(run%dir, snapshot_filename(run%n_snapshots)), &
                          t, step, s%parts%dim, trim(cfg%run%case_name), source%parts%n, fields, &
                          ok, errmsg, attr_names=names, attr_values=values, index=run%xdmf, &
                          source=source)
      if (.not. ok) then
        if (env%rank == 0) write(error_unit, '(a)') 'sph: error: ' // errmsg
        return
      end if
      run%n_snapshots = run%n_snapshots + 1
    end if
    call timeseries_flush(run%ts, ok, errmsg)
    if (.not. ok .and. env%rank == 0) write(error_unit, '(a)') 'sph: error: ' // errmsg
    run%write_max = max(run%write_max, wall_time() - w)
  end subroutine write_snapshot

  !> Makes the case's field field%name (snapshot_source_t).
  subroutine case_source_fill(self, field)
    class(case_source_t), intent(inout) :: self
    type(snapshot_field_t), intent(inout) :: field
    call self%problem%field(self%t, field%name, self%parts, self%flow, field%v, field%s)
  end subroutine case_source_fill

  !> The checkpoint of a run stopped early, output.dir/checkpoint.h5: the
  !> registered snapshot and checkpoint fields (the reference positions of
  !> the neighbour list among them) and the step history (solver:
  !> step_history_t), from which a restart goes on exactly as the run would
  !> have; it is not in the XDMF index.  The time series is flushed too.
  subroutine write_checkpoint(env, s, run, t, step, ok)
    type(parallel_env_t), intent(in) :: env
    type(solver_t), intent(in), target :: s        !< the checkpoint views its particles
    type(run_t), intent(inout) :: run
    real(wp), intent(in) :: t
    integer, intent(in) :: step
    logical, intent(out) :: ok
    type(snapshot_field_t), allocatable :: extra(:), fields(:)
    type(step_history_t) :: h
    character(len=:), allocatable :: errmsg
    character(len=32), allocatable :: names(:)
    real(wp), allocatable :: values(:)
    h = solver_history(s, env)
    call history_attributes(restart_info_t(checkpoint=.true., accel_max=h%a_max, &
                                           list_skin=h%skin, force_rebuild=h%force_rebuild, &
                                           snapshots_written=run%n_snapshots), names, values)
    call mirror_attributes(run%problem%mirror, 1, names, values)
    allocate(extra(0))
    call particles_snapshot_fields(s%parts, extra, fields, checkpoint=.true.)
    call snapshot_write(env%comm, join_path(run%dir, CHECKPOINT_FILE), t, step, s%parts%dim, &
                        trim(run%problem%name), s%parts%n, fields, ok, errmsg, &
                        attr_names=names, attr_values=values)
    if (ok) call timeseries_flush(run%ts, ok, errmsg)
    if (.not. ok .and. env%rank == 0) write(error_unit, '(a)') 'sph: error: ' // errmsg
  end subroutine write_checkpoint

  !> Writes the effective configuration beside the outputs (atomically).
  subroutine echo_input(cfg, path, ok, errmsg)
    type(config_t), intent(in) :: cfg
    character(len=*), intent(in) :: path
    logical, intent(out) :: ok
    character(len=:), allocatable, intent(out) :: errmsg
    character(len=:), allocatable :: tmp
    integer :: u, ios
    character(len=256) :: msg
    tmp = temp_path(path)
    open(newunit=u, file=tmp, status='replace', action='write', iostat=ios, iomsg=msg)
    ok = ios == 0
    if (.not. ok) then
      errmsg = 'cannot write ' // tmp // ': ' // trim(msg)
      return
    end if
    call config_echo(cfg, u)
    close(u)
    call rename_file(tmp, path, ok, errmsg)
  end subroutine echo_input

end module simulation
