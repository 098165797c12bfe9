!> The set-up of a run: what one run carries besides the solver (run_t),
!> and the translation of a validated configuration into the solver's
!> parameters and the case's initial particles (packed, or read from a
!> packed run's snapshot), with the check that the solver can run them.
!> simulation runs it; run_report prints it.
module run_setup
  use, intrinsic :: iso_fortran_env, only: error_unit
  use, intrinsic :: ieee_arithmetic, only: ieee_is_finite, ieee_is_normal
  use kinds, only: wp, i8
  use particles, only: particles_t
  use config, only: config_t, config_dim, config_case
  use input_params, only: VISCOSITIES, DIFFUSIONS, PRESSURE_GRADIENTS
  use kernels, only: kernel_init, kernel_kind_of
  use eos, only: eos_init, EOS_LINEAR, EOS_TAIT
  use fluid_rhs, only: VISC_NONE, VISC_DELTA, VISC_MONAGHAN, DIFF_NONE, DIFF_MOLTENI, &
                       DIFF_ANTUONO, PGRAD_STANDARD, PGRAD_HIGHER_ORDER, PGRAD_RENORMALISED, &
                       DIV_STANDARD, DIV_RENORMALISED
  use solver, only: solver_t
  use decomposition, only: BALANCE_PARTICLES, BALANCE_PAIRS
  use integrators, only: SCHEME_RK4, SCHEME_PC2
  use case_base, only: case_t
  use parallel_env, only: parallel_env_t, par_sum, par_any, par_max, par_min
  use snapshot_io, only: xdmf_index_t
  use timeseries, only: timeseries_t
  use restart, only: restart_read
  use domain, only: DECOMP_SLAB, DECOMP_METIS, DECOMP_SFC
  use packing, only: packing_params_t, packing_report_t, pack_ball
  use placement, only: packed_volume
  use mirrors, only: mirror_copies, plane_weights
  implicit none
  private
  public :: run_t, setup, check_setup, par_any_fail

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
    real(wp) :: dx = 0                     !< the particle spacing of the set-up
    ! wall-clock times (s): the run's start, the longest step and the
    ! longest snapshot write (or restart read) so far
    real(wp) :: wall_start = 0, iter_max = 0, write_max = 0
  end type run_t

contains

  !> Translates the configuration into the solver's parameters and builds
  !> the case's initial particles (their spacing in run%dx).
  subroutine setup(cfg, env, s, run, ok)
    type(config_t), intent(in) :: cfg
    type(parallel_env_t), intent(in) :: env
    type(solver_t), intent(inout) :: s
    type(run_t), intent(inout) :: run
    logical, intent(out) :: ok
    real(wp) :: dx
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
    run%dx = dx
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
    allocate(w(n))
    w(:) = plane_weights(parts%x(:, 1:n), problem%mirror)
    ! (the weights are multiples of 1/8: their sum is exact in any order)
    vol = packed_volume(parts%dim, problem%pack_radius, 1_i8) / &
          (par_sum(env, sum(w)) * mirror_copies(problem%mirror))
    parts%m(1:n) = vol * w
    parts%rho(1:n) = 1
  end subroutine plane_volumes

  !> Collective check of a local ok flag: the lowest failing rank prints
  !> its message; returns .true. when every rank succeeded.
  function par_any_fail(env, ok, errmsg) result(all_ok)
    type(parallel_env_t), intent(in) :: env
    logical, intent(in) :: ok
    !> (unallocated where ok: a deferred-length message is set only on failure)
    character(len=:), allocatable, intent(in) :: errmsg
    logical :: all_ok
    real(wp) :: first
    ! the lowest failing rank says why: the same failure on every rank (a
    ! file all of them read) is said once
    first = par_min(env, merge(real(env%nranks, wp), real(env%rank, wp), ok))
    all_ok = first >= env%nranks
    if (.not. ok .and. env%rank == nint(first)) then
      if (allocated(errmsg)) then
        write(error_unit, '(a)') 'sph: error: ' // errmsg
      else
        write(error_unit, '(a)') 'sph: error: (no message)'
      end if
    end if
  end function par_any_fail

end module run_setup
