!> One run from a validated configuration: set up the case, step to the end
!> time, write snapshots and the time series, print progress and the final
!> comparison with the exact solution.
module simulation
  use, intrinsic :: iso_fortran_env, only: output_unit, error_unit
  use kinds, only: wp, i8
  use particles, only: particles_t, particles_permute
  use memory_usage, only: peak_memory_mb
  use neighbours, only: neighbour_counts
  use config, only: config_t, config_dim, config_echo, config_case, config_scaled, &
                    config_resolution_scale
  use input_params, only: VISCOSITIES, DIFFUSIONS, PRESSURE_GRADIENTS
  use, intrinsic :: ieee_arithmetic, only: ieee_is_nan, ieee_is_finite, ieee_is_normal
  use kernels, only: kernel_init, kernel_kind_of
  use eos, only: eos_init, EOS_LINEAR, EOS_TAIT
  use fluid_rhs, only: VISC_NONE, VISC_DELTA, VISC_MONAGHAN, DIFF_NONE, DIFF_MOLTENI, &
                       DIFF_ANTUONO, PGRAD_STANDARD, PGRAD_HIGHER_ORDER, PGRAD_RENORMALISED, &
                       DIV_STANDARD, DIV_RENORMALISED
  use solver, only: solver_t, solver_init, solver_step, solver_evaluate, solver_time_step, &
                    solver_flow_fields, solver_sync_halo, step_history_t, solver_history, &
                    solver_restore, solver_timing_t
  use decomposition, only: BALANCE_PARTICLES, BALANCE_PAIRS, decomp_partners
  use integrators, only: SCHEME_RK4, SCHEME_PC2
  use diagnostics, only: kinetic_energy, total_mass, total_momentum, probe_pressure, &
                         probe_pressure_quadratic, &
                         find_bad_particle
  use case_base, only: case_t, case_fields_t, case_flow_t
  use parallel_env, only: parallel_env_t, par_sum, par_any, par_max, par_min, wall_time
  use fileutil, only: make_directory, join_path, rename_file, temp_path, file_exists
  use snapshot_io, only: snapshot_field_t, snapshot_source_t, snapshot_write, &
                         snapshot_filename, xdmf_index_t, xdmf_init
  use particle_io, only: particles_snapshot_fields, particles_whole_body
  use timeseries, only: timeseries_t, timeseries_init, timeseries_add, timeseries_flush, &
                        timeseries_load
  use restart, only: restart_read, restart_index_history, snapshot_number, restart_info_t, &
                     history_attributes, mirror_attributes
  use signals, only: signals_install, signals_caught, signal_name
  use domain, only: DECOMP_SLAB, DECOMP_METIS, DECOMP_SFC
  use packing, only: packing_params_t, packing_report_t, pack_ball
  use placement, only: packed_volume
  use mirrors, only: mirror_copies, mirror_word, plane_weights
  implicit none
  private
  public :: simulation_run, EXIT_CHECKPOINT

  !> The exit code of a run stopped early with a checkpoint (a signal or
  !> run.wall_limit): sysexits' EX_TEMPFAIL, "try again", for job scripts
  integer, parameter :: EXIT_CHECKPOINT = 75
  character(len=*), parameter :: CHECKPOINT_FILE = 'checkpoint.h5'

  !> Everything one run carries besides the solver.
  type :: run_t
    class(case_t), allocatable :: problem
    type(timeseries_t) :: ts
    type(xdmf_index_t) :: xdmf
    character(len=:), allocatable :: dir
    integer :: n_snapshots = 0
    integer :: n_probes = 0
    real(wp) :: probes(3, 16) = 0
    logical :: probe_quadratic = .false.   !< (D5) instead of (D4)
    integer(i8) :: n_global = 0
    real(wp) :: imb_sum = 0, imb_max = 0   !< imbalance statistics over the samples
    integer :: imb_n = 0
    type(packing_params_t) :: pack
    type(packing_report_t) :: pack_report
  end type run_t

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
    real(wp) :: t, dt, dx, t_next_out, wall0, wall_last, dt_est, t_end, tol, t0_run
    real(wp) :: wall_start, wall_iter, iter_max, write_max, w
    integer :: step, dim, i_bad, k_out, step0, signum
    logical :: ok, done, snap_now, restarting, have_series
    character(len=:), allocatable :: errmsg, reason
    character(len=160) :: line
    type(config_t) :: cfg
    type(restart_info_t) :: info
    type(step_history_t) :: history

    status = 0
    wall_start = wall_time()
    write_max = 0      ! the longest snapshot write (or restart read) so far
    call signals_install()
    cfg = config_scaled(cfg_in)
    dim = config_dim(cfg)
    t_end = cfg%run%t_end
    tol = 1e-12_wp * max(1.0_wp, t_end)
    t = 0
    step = 0
    restarting = len_trim(cfg%run%restart) > 0
    call setup(cfg, env, s, run, dx, ok)
    if (.not. ok) then
      status = 2
      return
    end if
    if (restarting) then
      ! the snapshot's particles replace the initial ones; nothing is
      ! written before it has been read and checked
      w = wall_time()
      call restart_read(env, trim(cfg%run%restart), trim(cfg%run%case_name), dim, s%parts, &
                        t, step, ok, errmsg, info, mirror=run%problem%mirror)
      write_max = wall_time() - w
      if (ok .and. t >= t_end - tol) then
        ok = .false.
        ! (errmsg is of deferred length: written through a buffer)
        write(line, '(a,es12.5,a,es12.5,a)') ''': the snapshot is at t = ', t, &
          ', not before &run t_end = ', t_end, ': nothing to do (raise run.t_end)'
        errmsg = '&run restart = ''' // trim(cfg%run%restart) // trim(line)
      end if
      if (.not. par_any_fail(env, ok, errmsg)) then
        status = 2
        return
      end if
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
    if (.not. par_any_fail(env, ok, errmsg)) then
      status = 2
      return
    end if

    ! output directory, the echoed input, the time series and the index
    run%dir = trim(cfg%output%dir)
    call make_directory(run%dir, ok, errmsg)
    if (.not. ok) errmsg = '&output dir = ''' // run%dir // ''': ' // errmsg // &
                           ' (allowed: a directory that exists or can be created, writable)'
    if (.not. par_any_fail(env, ok, errmsg)) then
      status = 2                 ! bad input: nothing has been written
      return
    end if
    if (env%rank == 0) call echo_input(cfg_in, join_path(run%dir, 'input.nml'), ok, errmsg)
    if (.not. par_any_fail(env, ok, errmsg)) then
      status = 1
      return
    end if
    call xdmf_init(run%xdmf, join_path(run%dir, 'snapshots.xdmf'))
    call timeseries_init(run%ts, env%comm, join_path(run%dir, 'timeseries.csv'), &
                         column_names(run, dim))
    if (restarting) then
      ! continue the history of the run directory: earlier snapshots stay in
      ! the index, time-series rows up to the restart time are kept
      call restart_index_history(env, run%dir, run%n_snapshots, run%xdmf, ok, errmsg)
      have_series = file_exists(join_path(run%dir, 'timeseries.csv'))
      if (ok .and. have_series) &       ! collective: every rank sees the same file
        call timeseries_load(run%ts, join_path(run%dir, 'timeseries.csv'), t, ok, errmsg)
      if (.not. par_any_fail(env, ok, errmsg)) then
        status = 1
        return
      end if
    end if

    call print_start(cfg, env, s, run, dx, dt_est)
    if (restarting) then
      ! the largest acceleration of the step before (that of the evaluation
      ! just made when the file does not say it)
      history%a_max = s%a_local
      if (info%has_accel) history%a_max = info%accel_max
      call solver_restore(s, history)
      if (env%rank == 0) write(output_unit, '(a,es12.5,a,i0,a)') '  restarted from ' // &
        trim(cfg%run%restart) // ' at t = ', t, ', step ', step, ''
    else
      call sample(run, env, s, t, step, 0.0_wp, warn_empty_probes=.true.)
      w = wall_time()
      call write_snapshot(cfg, env, s, run, t, step, ok)
      if (.not. ok) then
        status = 1
        return
      end if
      write_max = wall_time() - w
    end if
    ! output times are k output.dt (a product, not a running sum, so a
    ! restarted run finds the same ones)
    k_out = int(t / cfg%output%dt + 1e-9_wp)
    t_next_out = (k_out + 1) * cfg%output%dt
    wall0 = wall_time()
    wall_last = wall0
    t0_run = t
    ! traffic and time per step: the set-up's migration, first halo and
    ! first evaluation not counted
    s%dc%words_sent = 0
    s%dc%messages_sent = 0
    s%dc%comm_time = 0
    s%timing = solver_timing_t()
    step0 = step
    iter_max = 0
    done = t >= t_end - tol .or. (cfg%run%max_steps > 0 .and. step >= cfg%run%max_steps)

    do while (.not. done)
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

      if (mod(step, cfg%output%probe_every) == 0 .or. done) call sample(run, env, s, t, step, dt)
      snap_now = t >= t_next_out - tol .or. done
      if (snap_now) then
        do while ((k_out + 1) * cfg%output%dt <= t + tol)
          k_out = k_out + 1
        end do
        t_next_out = (k_out + 1) * cfg%output%dt
        ! case fields (e.g. vorticity) may use the halo copies: bring them
        ! to the end of the step
        call solver_sync_halo(s, env)
        w = wall_time()
        call write_snapshot(cfg, env, s, run, t, step, ok)
        if (.not. ok) then
          status = 1
          return
        end if
        write_max = max(write_max, wall_time() - w)
        ! a run restarted from this snapshot starts with a fresh list: so
        ! does this one, and both go on identically
        s%lm%force_rebuild = .true.
      end if
      if (wall_time() - wall_last >= cfg%run%progress_interval .or. done) then
        wall_last = wall_time()
        call print_progress(env, step, t, dt, t0_run, t_end, wall_last - wall0, s%dc%imbalance)
      end if
      iter_max = max(iter_max, wall_time() - wall_iter)

      ! a stop requested by a signal, or the wall-clock limit reached before
      ! the next step and a checkpoint could be done (2x the longest so far)
      if (.not. done) then
        signum = signals_caught()
        w = wall_time()
        ok = cfg%run%wall_limit <= 0 .or. &
             w - wall_start + 2 * (iter_max + write_max) < cfg%run%wall_limit
        if (par_any(env, signum /= 0 .or. .not. ok)) then
          signum = nint(par_max(env, real(signum, wp)))
          reason = 'run.wall_limit'
          if (signum /= 0) reason = signal_name(signum)
          call write_checkpoint(env, s, run, t, step, ok)
          status = 1
          if (ok) then
            call print_stopped(env, reason, run%dir, step, t)
            status = EXIT_CHECKPOINT
          end if
          return
        end if
      end if
    end do

    call print_end(env, s, run, step - step0, wall_time() - wall0)
    call run%problem%summary(env, output_unit, t, s%parts, s%rhs%kernel)
  end subroutine simulation_run

  !> Translates the configuration into the solver's parameters and builds
  !> the case's initial particles.
  subroutine setup(cfg, env, s, run, dx, ok)
    type(config_t), intent(in) :: cfg
    type(parallel_env_t), intent(in) :: env
    type(solver_t), intent(inout) :: s
    type(run_t), intent(inout) :: run
    real(wp), intent(out) :: dx
    logical, intent(out) :: ok
    integer :: dim, kernel_kind
    ok = .true.
    dim = config_dim(cfg)
    s%eos = eos_init(merge(EOS_TAIT, EOS_LINEAR, cfg%physics%eos == 'tait'), &
                     cfg%physics%c0, cfg%physics%rho0, cfg%physics%gamma)
    call config_case(cfg, run%problem)
    ! the planes' images come with the halo; the list's fit is the body's
    s%dc%halo%mirror = run%problem%mirror
    s%lm%mirror = run%problem%mirror
    call run%problem%setup(cfg%particles, cfg%physics, s%eos, s%parts, dx, &
                           [env%rank, env%nranks])
    if (len_trim(cfg%particles%from) > 0) then
      call read_packed(cfg, env, run%problem, s, dx, ok)
      if (.not. ok) return
    end if
    kernel_kind = kernel_kind_of(trim(cfg%numerics%kernel))
    s%rhs%dim = dim
    s%rhs%kernel = kernel_init(kernel_kind, dim, cfg%particles%h_over_dx * dx)
    s%rhs%c0 = cfg%physics%c0
    s%rhs%rho0 = cfg%physics%rho0
    s%rhs%alpha = cfg%numerics%alpha
    s%rhs%reconstruct = cfg%numerics%visc_reconstruction
    s%rhs%delta = cfg%numerics%delta
    s%rhs%tensile_eps = merge(cfg%numerics%tensile_eps, 0.0_wp, cfg%numerics%tensile)
    s%rhs%tensile_n = cfg%numerics%tensile_n
    s%rhs%tensile_dx = dx
    s%rhs%pressure_gradient = code_of(cfg%numerics%pressure_gradient, PRESSURE_GRADIENTS, &
                                      [PGRAD_STANDARD, PGRAD_HIGHER_ORDER, PGRAD_RENORMALISED])
    s%rhs%divergence = merge(DIV_RENORMALISED, DIV_STANDARD, &
                             cfg%numerics%divergence == 'renormalised')
    s%shifting = cfg%numerics%shifting
    s%rhs%binned = cfg%numerics%binned_sums
    s%renormalise_per_step = cfg%numerics%renormalise == 'step'
    s%shift_dx = dx
    s%rhs%viscosity = code_of(cfg%numerics%viscosity, VISCOSITIES, &
                              [VISC_DELTA, VISC_MONAGHAN, VISC_NONE])
    s%rhs%diffusion = code_of(cfg%numerics%diffusion, DIFFUSIONS, &
                              [DIFF_MOLTENI, DIFF_ANTUONO, DIFF_NONE])
    s%integ%scheme = merge(SCHEME_PC2, SCHEME_RK4, cfg%numerics%integrator == 'pc2')
    s%cfl = cfg%numerics%cfl
    s%cfl_force = cfg%numerics%cfl_force
    s%cfl_visc = cfg%numerics%cfl_visc
    s%lm%skin_min = cfg%numerics%skin * s%rhs%kernel%h
    select case (cfg%parallel%decomposition)
    case ('metis')
      s%dc%method = DECOMP_METIS
    case ('sfc')
      s%dc%method = DECOMP_SFC
    case ('slab')
      s%dc%method = DECOMP_SLAB
    case default
      ! auto: slabs have the fewest copies and partners on few ranks; beyond
      ! 4 they grow as P and the curve's pieces win (doc/developer/parallel.md)
      s%dc%method = merge(DECOMP_SLAB, DECOMP_SFC, env%nranks <= 4)
    end select
    s%dc%balance = merge(BALANCE_PAIRS, BALANCE_PARTICLES, cfg%parallel%balance == 'pairs')
    s%dc%imbalance_threshold = cfg%parallel%imbalance_threshold
    run%n_probes = cfg%output%n_probes
    run%probes = cfg%output%probes
    run%probe_quadratic = cfg%output%probe_quadratic
    if (dim == 2) run%probes(3, :) = 0
    if (run%problem%pack_radius > 0 .and. len_trim(cfg%particles%from) == 0 .and. &
        len_trim(cfg%run%restart) == 0) then
      run%pack%radius = run%problem%pack_radius
      run%pack%slab = run%problem%pack_slab
      run%pack%dx = dx
      run%pack%max_iterations = cfg%particles%pack_iterations
      call pack_ball(s, env, run%pack, run%pack_report)
      call plane_volumes(env, run%problem, s%parts)
      call run%problem%initial_state(s%eos, s%parts)
      ! the run starts afresh on the packed particles
      s%lm%n_rebuilds = 0
      s%dc%n_balances = 0
      s%dc%n_migrated = 0
      s%dc%comm_time = 0
    end if
  end subroutine setup

  !> The code of a choice the input has already validated: codes(k) for
  !> names(k) == name (the names in input_params' order).
  integer function code_of(name, names, codes) result(code)
    character(len=*), intent(in) :: name, names(:)
    integer, intent(in) :: codes(:)
    integer :: k
    if (size(codes) /= size(names)) error stop 'code_of: one code per name'
    k = findloc(names, name, dim=1)
    if (k == 0) error stop 'code_of: a choice the input validation let through'
    code = codes(k)
  end function code_of

  !> particles.from: the packed particles are the initial positions
  !> (position_initial) of a snapshot of a packed run of the same case,
  !> read on any number of ranks; each gets the volume |Omega|/N of the
  !> packing and the case's initial state (doc/theory/packing.md).  Nothing is
  !> written if the file does not fit (ok false, message on rank 0).
  subroutine read_packed(cfg, env, problem, s, dx, ok)
    type(config_t), intent(in) :: cfg
    type(parallel_env_t), intent(in) :: env
    class(case_t), intent(inout) :: problem
    type(solver_t), intent(inout) :: s
    real(wp), intent(out) :: dx
    logical, intent(out) :: ok
    character(len=:), allocatable :: errmsg
    real(wp) :: t, r_max, radius, n_file
    integer :: step, n, dim
    character(len=24) :: count
    dim = s%parts%dim
    radius = problem%pack_radius
    call restart_read(env, trim(cfg%particles%from), trim(cfg%run%case_name), dim, s%parts, &
                      t, step, ok, errmsg, variable='&particles from', mirror=problem%mirror)
    if (ok) then
      n = s%parts%n
      s%parts%x(:, 1:n) = s%parts%x0(:, 1:n)
      r_max = 0
      if (n > 0) r_max = sqrt(maxval(sum(s%parts%x(:, 1:n)**2, dim=1)))
      if (par_max(env, r_max) > radius) then
        ok = .false.
        errmsg = '&particles from = ''' // trim(cfg%particles%from) // ''': its initial ' // &
                 'positions reach outside the radius of this case'
      end if
      ! (S1) h/dx, c0, alpha and delta scale with particles.n: it must be
      ! the file's count (to the packing's rounding, under 1 % measured)
      n_file = par_sum(env, real(n, wp)) * mirror_copies(problem%mirror)
      if (ok .and. cfg%particles%n_ref > 0 .and. &
          abs(n_file - cfg%particles%n) > 0.02_wp * cfg%particles%n) then
        ok = .false.
        write(count, '(i0)') nint(n_file, i8)
        errmsg = '&particles from = ''' // trim(cfg%particles%from) // ''' holds ' // &
                 trim(count) // ' particles, but with &particles n_ref > 0 the resolution ' // &
                 'scaling takes h/dx, c0, alpha and delta from &particles n: set n to ' // &
                 'the file''s count'
      end if
    end if
    if (.not. par_any_fail(env, ok, errmsg)) then
      ok = .false.
      return
    end if
    dx = packed_volume(dim, radius, nint(par_sum(env, real(s%parts%n, wp)), i8) * &
                       mirror_copies(problem%mirror))**(1 / real(dim, wp))
    call plane_volumes(env, problem, s%parts)
    call problem%initial_state(s%eos, s%parts)
  end subroutine read_packed

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
  !> then the time series is flushed so both describe the same moment.
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

  !> Says why the run stopped, where its checkpoint is and the command that
  !> continues it: this process's own arguments (any run.restart replaced)
  !> under mpirun with the same number of ranks (any other works too).
  subroutine print_stopped(env, reason, dir, step, t)
    type(parallel_env_t), intent(in) :: env
    character(len=*), intent(in) :: reason, dir
    integer, intent(in) :: step
    real(wp), intent(in) :: t
    character(len=:), allocatable :: cmd, arg, path
    character(len=16) :: np
    integer :: k, length
    if (env%rank /= 0) return
    path = join_path(dir, CHECKPOINT_FILE)
    write(np, '(i0)') env%nranks
    cmd = 'mpirun -np ' // trim(np)
    do k = 0, command_argument_count()
      call get_command_argument(k, length=length)
      allocate(character(len=length) :: arg)
      call get_command_argument(k, arg)
      if (index(arg, 'run.restart=') /= 1) cmd = cmd // ' ' // shell_quoted(arg)
      deallocate(arg)
    end do
    cmd = cmd // ' ' // shell_quoted('run.restart=' // path)
    write(output_unit, '(a,i0,a,es12.5,a)') 'sph: stopped by ' // reason // ' after step ', &
      step, ' (t = ', t, '); checkpoint written to ' // path
    write(output_unit, '(a)') '  continue with: ' // cmd
    flush(output_unit)
  end subroutine print_stopped

  !> word as one shell word: as it is when it is made of safe characters,
  !> else in single quotes (a quote inside written '\'').
  function shell_quoted(word) result(q)
    character(len=*), intent(in) :: word
    character(len=:), allocatable :: q
    character(len=*), parameter :: SAFE = 'abcdefghijklmnopqrstuvwxyzABCDEFGHIJKLMNOPQRSTUVWXYZ' // &
                                          '0123456789_./=:,+-@%'
    integer :: k
    if (len(word) > 0 .and. verify(word, SAFE) == 0) then
      q = word
      return
    end if
    q = "'"
    do k = 1, len(word)
      if (word(k:k) == "'") then
        q = q // "'\''"
      else
        q = q // word(k:k)
      end if
    end do
    q = q // "'"
  end function shell_quoted

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

  !> Collective check of a local ok flag: the lowest failing rank prints
  !> its message; returns .true. when every rank succeeded.
  function par_any_fail(env, ok, errmsg) result(all_ok)
    type(parallel_env_t), intent(in) :: env
    logical, intent(in) :: ok
    character(len=*), intent(in) :: errmsg
    logical :: all_ok
    real(wp) :: first
    ! the lowest failing rank says why: the same failure on every rank (a
    ! file all of them read) is said once
    first = par_min(env, merge(real(env%nranks, wp), real(env%rank, wp), ok))
    all_ok = first >= env%nranks
    if (.not. ok .and. env%rank == nint(first)) write(error_unit, '(a)') 'sph: error: ' // errmsg
  end function par_any_fail

  subroutine print_start(cfg, env, s, run, dx, dt)
    type(config_t), intent(in) :: cfg
    type(parallel_env_t), intent(in) :: env
    type(solver_t), intent(in) :: s
    type(run_t), intent(in) :: run
    real(wp), intent(in) :: dx, dt
    real(wp) :: listed, in_range
    integer(i8) :: n_listed, n_in_range
    call neighbour_counts(s%lm%nl, s%parts%n, s%parts%x, s%rhs%kernel%support**2, n_listed, &
                          n_in_range)
    listed = par_sum(env, real(n_listed, wp)) / max(run%n_global, 1_i8)
    in_range = par_sum(env, real(n_in_range, wp)) / max(run%n_global, 1_i8)
    if (env%rank /= 0) return
    write(output_unit, '(a)') 'sph: case ' // trim(cfg%run%case_name) // ', output in ' // run%dir
    write(output_unit, '(a,i0,a,i0,a,es10.3,a,es10.3,a,f5.2,a)') '  particles ', run%n_global, &
      '  dim ', s%parts%dim, '  dx ', dx, '  h ', s%rhs%kernel%h, '  (h/dx ', &
      cfg%particles%h_over_dx, ')'
    write(output_unit, '(a,f8.2,a,f6.4,a,f8.1,a,f8.1,a)') '  c0 ', s%rhs%c0, '  Mach ', &
      s%umax / s%rhs%c0, '  neighbours per particle ', in_range, ' (', listed, ' in the list)'
    write(output_unit, '(a)') '  kernel ' // trim(cfg%numerics%kernel) // ', integrator ' // &
      trim(cfg%numerics%integrator) // ', viscosity ' // trim(cfg%numerics%viscosity) // &
      ', diffusion ' // trim(cfg%numerics%diffusion)
    if (cfg%particles%n_ref > 0) write(output_unit, '(a,es10.3,4(a,f8.4),a,f6.3,4(a,f7.3),a)') &
      '  resolution scaling from n_ref ', cfg%particles%n_ref, ': h/dx ', &
      cfg%particles%h_over_dx, ', c0 ', cfg%physics%c0, ', alpha ', cfg%numerics%alpha, &
      ', delta ', cfg%numerics%delta, ' (exponents of (n/n_ref)^(1/dim) = ', &
      config_resolution_scale(cfg), ': ', &
      cfg%particles%h_exponent, ', ', cfg%physics%c0_exponent, ', ', &
      cfg%numerics%alpha_exponent, ', ', cfg%numerics%delta_exponent, ')'
    if (len_trim(cfg%particles%from) > 0) write(output_unit, '(a)') &
      '  packed particles from ' // trim(cfg%particles%from)
    if (run%pack_report%iterations > 0) write(output_unit, '(a,i0,a,f7.2,a,i0,a,es9.2,a,i0,a)') &
      '  packed in ', run%pack_report%iterations, ' iterations, ', run%pack_report%wall, &
      ' s (', run%pack_report%rebuilds, ' list builds, last move ', &
      run%pack_report%last_move, ' dx, ', run%pack_report%clipped, ' moves clipped)'
    write(output_unit, '(a,es10.3,a,es10.3,a,es10.3,a,es10.3,a,es10.3,a)') '  dt ', dt, &
      ' = min(acoustic ', s%dt_cfl, ', force ', s%dt_force, ', viscous ', s%dt_visc, &
      ', diffusive ', s%dt_diff, ')'
    write(output_unit, '(a,f10.4,a,i0,a)') '  end time ', cfg%run%t_end, ', about ', &
      nint(cfg%run%t_end / dt), ' steps'
    flush(output_unit)
  end subroutine print_start

  subroutine print_progress(env, step, t, dt, t_start, t_end, wall, imbalance)
    type(parallel_env_t), intent(in) :: env
    integer, intent(in) :: step
    real(wp), intent(in) :: t, dt, t_start, t_end, wall, imbalance
    real(wp) :: eta
    if (env%rank /= 0) return
    eta = 0
    if (t > t_start) eta = wall * (t_end - t) / (t - t_start)
    if (env%nranks > 1) then
      write(output_unit, '(a,i8,a,f10.5,a,es10.3,a,f9.1,a,f9.1,a,f6.3)') 'step ', step, &
        '  t ', t, '  dt ', dt, '  wall ', wall, ' s  ETA ', eta, ' s  imbalance ', imbalance
    else
      write(output_unit, '(a,i8,a,f10.5,a,es10.3,a,f9.1,a,f9.1,a)') 'step ', step, '  t ', t, &
        '  dt ', dt, '  wall ', wall, ' s  ETA ', eta, ' s'
    end if
    flush(output_unit)
  end subroutine print_progress

  subroutine print_end(env, s, run, steps, wall)
    type(parallel_env_t), intent(in) :: env
    type(solver_t), intent(in) :: s
    type(run_t), intent(in) :: run
    integer, intent(in) :: steps
    real(wp), intent(in) :: wall
    real(wp) :: comm, mem_max, mem_total, listed, in_range, halo, partners, partners_max, &
                words, words_max, messages, pairs, t(5), rate, across, images
    integer(i8) :: n_listed, n_in_range
    integer :: k
    comm = par_max(env, s%dc%comm_time)
    ! what the decomposition costs in copies and messages (doc/developer/parallel.md)
    halo = par_sum(env, real(s%parts%n_halo - s%dc%halo%n_images, wp)) / max(run%n_global, 1_i8)
    partners = par_sum(env, real(decomp_partners(s%dc), wp)) / env%nranks
    partners_max = par_max(env, real(decomp_partners(s%dc), wp))
    words = par_sum(env, s%dc%words_sent) / env%nranks
    words_max = par_max(env, s%dc%words_sent)
    messages = par_sum(env, real(s%dc%messages_sent, wp)) / env%nranks
    ! listed pairs with at least one owned particle: those across a cut are
    ! held (and evaluated) on both ranks
    pairs = par_sum(env, real(s%lm%nl%n_pairs, wp)) / max(run%n_global, 1_i8)
    ! where the time went: the largest share over the ranks of each part
    t = [s%timing%pairs, s%timing%rebuild, s%timing%check, s%dc%comm_time, s%timing%integrate]
    do k = 1, 5
      t(k) = par_max(env, t(k)) / max(wall, 1e-9_wp)
    end do
    rate = par_sum(env, s%timing%pair_visits / max(s%timing%pairs, 1e-9_wp)) / env%nranks
    mem_max = par_max(env, peak_memory_mb())
    mem_total = par_sum(env, peak_memory_mb())
    call neighbour_counts(s%lm%nl, s%parts%n, s%parts%x, s%rhs%kernel%support**2, n_listed, &
                          n_in_range)
    listed = par_sum(env, real(n_listed, wp)) / max(run%n_global, 1_i8)
    in_range = par_sum(env, real(n_in_range, wp)) / max(run%n_global, 1_i8)
    across = par_sum(env, real(s%n_across, wp))
    images = par_sum(env, real(s%dc%halo%n_images, wp)) / max(run%n_global, 1_i8)
    if (env%rank /= 0) return
    write(output_unit, '(a,i0,a,f10.2,a,es10.3,a,es10.3,a,i0,a)') 'done: ', steps, ' steps in ', &
      wall, ' s, ', wall / max(steps, 1), ' s/step, ', &
      real(run%n_global, wp) * steps / max(wall, 1e-9_wp), ' particle-steps/s on ', &
      env%nranks, ' rank(s)'
    write(output_unit, '(a,i0,a,i0,a,i0,a,f6.2,a,f9.1,a,f9.1,a)') &
      '  right-hand sides ', s%n_evaluations, ', list rebuilds ', s%lm%n_rebuilds, &
      ', snapshots ', run%n_snapshots, ' (skin ', s%lm%skin / s%rhs%kernel%h, &
      ' h), peak memory ', mem_max, ' MB per rank (max), ', mem_total, ' MB in all'
    write(output_unit, '(a,f8.1,a,f8.1,a)') '  neighbours per particle: ', listed, &
      ' in the list, ', in_range, ' within the kernel support'
    if (run%problem%mirror /= 0) write(output_unit, '(a,f8.4,a,i0,a)') &
      '  mirror planes ' // mirror_word(run%problem%mirror) // ': ', images, &
      ' images per particle (at the last list build); ', nint(across, i8), &
      ' times a particle traded places with its image (M4)'
    write(output_unit, '(a,5(f5.1,a),es10.3,a)') '  time (largest rank): pair passes ', &
      100 * t(1), ' %, list rebuilds ', 100 * t(2), ' %, validity test ', 100 * t(3), &
      ' %, communication ', 100 * t(4), ' %, integration ', 100 * t(5), ' %; ', rate, &
      ' listed pairs per second per rank in the passes'

    if (env%nranks > 1) write(output_unit, '(a,f6.3,a,f6.3,a,i0,a,i0,a,f5.1,a)') &
      '  imbalance (max/mean particles) mean ', run%imb_sum / max(run%imb_n, 1), ', max ', &
      run%imb_max, ', re-balanced ', s%dc%n_balances, ' times, ', s%dc%n_migrated, &
      ' migrations, communication ', 100 * comm / max(wall, 1e-9_wp), ' % of the wall time'
    if (env%nranks > 1) write(output_unit, '(a,f8.4,a,f6.2,a,i0,a,es10.3,a,es10.3,a,f8.2,a)') &
      '  halo: ', halo, ' copies per particle, ', partners, ' partner ranks per rank (max ', &
      nint(partners_max), '); sent per rank and step ', 8 * words / max(steps, 1), &
      ' bytes (max ', 8 * words_max / max(steps, 1), '), ', messages / max(steps, 1), &
      ' messages'
    if (env%nranks > 1) write(output_unit, '(a,f8.4,a,f6.2,a)') '  pairs evaluated ', &
      pairs / max(listed / 2, 1e-300_wp), ' times the one-rank count (', &
      100 * (pairs / max(listed / 2, 1e-300_wp) - 1), ' % across the cuts, twice)'
    flush(output_unit)
  end subroutine print_end

  !> The set-up is one the solver can run: at least MIN_PARTICLES particles,
  !> a finite state and first right-hand side, a time step that is a normal
  !> positive number.  Lengths, densities or speeds far from order one
  !> (e.g. c0 = 1e200, radius = 1e-300) fail here, before any output,
  !> instead of as a blow-up after the first snapshot.
  subroutine check_setup(env, s, n_global, dt, ok, errmsg)
    type(parallel_env_t), intent(in) :: env
    type(solver_t), intent(in) :: s
    integer(i8), intent(in) :: n_global
    real(wp), intent(in) :: dt
    logical, intent(out) :: ok
    character(len=:), allocatable, intent(inout) :: errmsg
    integer, parameter :: MIN_PARTICLES = 50       ! particles.n's own lower bound
    character(len=200) :: line
    integer :: n
    n = s%parts%n
    ok = .not. par_any(env, .not. (all(ieee_is_finite(s%parts%x(:, 1:n))) .and. &
                                   all(ieee_is_finite(s%parts%u(:, 1:n))) .and. &
                                   all(ieee_is_finite(s%parts%rho(1:n))) .and. &
                                   all(ieee_is_finite(s%du(:, 1:n))) .and. &
                                   all(ieee_is_finite(s%drho(1:n)))))
    if (n_global < MIN_PARTICLES) then
      write(line, '(a,i0,a,i0,a)') 'the set-up placed ', n_global, ' particles (at least ', &
        MIN_PARTICLES, ' are needed)'
      ok = .false.
    else if (.not. ok .or. .not. (ieee_is_normal(dt) .and. dt > 0)) then
      write(line, '(a,es11.3e3,a,es11.3e3,a,es11.3e3,a)') 'the initial state or its first ' // &
        'right-hand side is not finite (h = ', s%rhs%kernel%h, ', c0 = ', s%rhs%c0, &
        ', time step ', dt, ')'
      ok = .false.
    end if
    if (.not. ok) errmsg = trim(line) // ': the lengths, densities and speeds of the ' // &
      'case and &physics must stay within the range of double precision (scale them ' // &
      'to order one)'
  end subroutine check_setup

  !> (M5) The packed particles' volumes |Omega| / N_eff times their plane
  !> weights (1, or 2^-k on k planes), N_eff the whole body's count:
  !> the copies times the sum of the weights; rho = 1 for initial_state.
  subroutine plane_volumes(env, problem, parts)
    type(parallel_env_t), intent(in) :: env
    class(case_t), intent(in) :: problem
    type(particles_t), intent(inout) :: parts
    real(wp), allocatable :: w(:)
    real(wp) :: vol
    integer :: n
    n = parts%n
    w = plane_weights(parts%x(:, 1:n), problem%mirror)
    ! (the weights are multiples of 1/8: their sum is exact in any order)
    vol = packed_volume(parts%dim, problem%pack_radius, 1_i8) / &
          (par_sum(env, sum(w)) * mirror_copies(problem%mirror))
    parts%m(1:n) = vol * w
    parts%rho(1:n) = 1
  end subroutine plane_volumes

  !> A state that is no longer finite: say where and when, on every rank
  !> that has such a particle; earlier outputs stay as they were.
  subroutine report_blow_up(s, step, t, i_bad, mirror)
    type(solver_t), intent(in) :: s
    integer, intent(in) :: step, i_bad, mirror
    real(wp), intent(in) :: t
    integer :: k
    character(len=:), allocatable :: what
    if (i_bad > 0) then
      what = 'the state is no longer finite'
      do k = 1, 3
        if (btest(mirror, k - 1) .and. .not. s%parts%x(k, i_bad) >= 0) &
          what = 'a particle crossed the mirror plane ' // 'xyz'(k:k) // ' = 0'
      end do
      write(error_unit, '(a,i0,a,es12.5,a,i0,a,3es12.4,a,3es12.4,a,es12.4)') &
        'sph: error: ' // what // ' at step ', step, ', t = ', t, &
        ': particle id ', s%parts%id(i_bad), ' at x = ', s%parts%x(:, i_bad), &
        ', u = ', s%parts%u(:, i_bad), ', rho = ', s%parts%rho(i_bad)
      write(error_unit, '(a)') '  (try a smaller numerics.cfl; outputs up to the last ' // &
        'snapshot are intact)'
    end if
  end subroutine report_blow_up

end module simulation
