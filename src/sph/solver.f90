!> The time stepper: the particle state, the evaluation of a stage (halo
!> refresh, pressure, the passes of the right-hand side), the time step
!> (doc/theory/ T3), the step and the shifting (E8).  Its parts by
!> concern: the neighbour list and when to rebuild it in list_manager, the
!> domain decomposition in decomposition, the integrators (T1, T2) in
!> integrators.
module solver
  use kinds, only: wp, i8
  use particles, only: particles_t, particles_permute
  use neighbours, only: cell_sort_permutation
  use list_manager, only: list_manager_t, list_radius, list_check, list_build, list_pair_work, &
                          list_origin
  use eos, only: eos_t, eos_pressure
  use pair_rows, only: rhs_work_t
  use fluid_rhs, only: rhs_params_t, rhs_evaluate, rhs_shift, rhs_reconstructs, DIFF_ANTUONO, &
                       DIFF_NONE, VISC_NONE, PGRAD_HIGHER_ORDER, PGRAD_RENORMALISED, &
                       DIV_RENORMALISED
  use first_pass, only: rhs_renormalisation, rhs_strain_rate
  use parallel_env, only: parallel_env_t, par_max, wall_time
  use decomposition, only: decomposition_t, decomp_redistribute, decomp_halo_build, &
                           decomp_refresh, decomp_refresh_field, decomp_measure, BALANCE_PAIRS
  use mirrors, only: REFLECT_SCALAR, REFLECT_VECTOR, REFLECT_SYM6, hold_normal
  use integrators, only: integrator_t, integrator_reserve, integrator_stages, integrator_advance
  implicit none
  private
  public :: solver_t, solver_init, solver_step, solver_evaluate, solver_rebuild, solver_flow_fields, &
            solver_time_step, solver_sync_halo
  public :: step_history_t, solver_history, solver_restore, solver_timing_t

  !> (T3) the diffusive limit dt <= CFL_DIFF h/(delta c0), below the measured
  !> onset of instability (delta c0 dt/h: stable at 0.33, unstable at 0.45
  !> in 2D; 0.50 and 0.62 in 3D; RK4, Wendland C2); never binding at the
  !> defaults (delta = 0.1 allows 3 h/c0, the largest acoustic step)
  real(wp), parameter :: CFL_DIFF = 0.3_wp

  !> Where this rank's time goes (wall seconds since the last reset): the
  !> pair passes of the right-hand sides (first pass and main pass), the list
  !> rebuilds (re-balancing, sort, list build; their messages are in the
  !> decomposition's comm_time), the validity test, the integrator's
  !> updates; and the listed pairs the passes visited.
  type :: solver_timing_t
    real(wp) :: pairs = 0, rebuild = 0, check = 0, integrate = 0
    real(wp) :: pair_visits = 0
  end type solver_timing_t

  !> What a step takes from the steps before it besides the particles and
  !> their reference positions (particles_t%xref): the list's skin, the
  !> largest acceleration of the last right-hand side (both enter the
  !> validity test) and whether a rebuild is due.  A checkpoint stores it,
  !> so that the run it continues goes on exactly as without the stop.
  type :: step_history_t
    real(wp) :: skin = 0
    real(wp) :: a_max = 0
    logical :: force_rebuild = .false.
  end type step_history_t

  type :: solver_t
    type(particles_t) :: parts
    type(rhs_params_t) :: rhs
    type(eos_t) :: eos
    type(list_manager_t) :: lm        !< the neighbour list, its skin and validity test
    type(integrator_t) :: integ       !< the scheme and its work arrays
    type(decomposition_t) :: dc       !< domain, halo and balancing
    type(rhs_work_t) :: rw            !< work arrays of the right-hand side, kept
    real(wp) :: cfl = 1.5_wp, cfl_force = 0.25_wp, cfl_visc = 0.125_wp
    real(wp) :: nu = 0            !< kinematic viscosity equivalent to the artificial one
    real(wp), allocatable :: drho(:), du(:, :), grad_rho(:, :)
    !> (E9) the free-surface indicator lambda_i from the first pass (one
    !> row, so that the halo exchange of fields serves it)
    real(wp), allocatable :: lambda(:, :)
    !> L_i = M_i^-1 of the first pass (xx, yy, zz, xy, xz, yz), reused by
    !> the renormalised operators of the second
    real(wp), allocatable :: lmat(:, :)
    !> (R1) the strain rate of the reconstructed viscosity (owned and halo)
    real(wp), allocatable :: strain(:, :)
    !> (E8) particle shifting after each step: on/off, the spacing dx of
    !> W(dx), the shifts of the last step and the largest of them (global)
    logical :: shifting = .false.
    real(wp) :: shift_dx = 0
    real(wp), allocatable :: dr(:, :)
    real(wp) :: shift_max = 0
    integer :: n_evaluations = 0
    !> (M4) particles that traded places with their mirror image
    integer(i8) :: n_across = 0
    real(wp) :: umax = 0, amax = 0     !< global maxima at the start of the last step
    real(wp) :: a_local = 0            !< this rank's largest |du| of the last right-hand side
    real(wp) :: dt_cfl = 0, dt_force = 0, dt_visc = 0, dt_diff = 0  !< the limits of the last step
    !> L_i and lambda_i of the first pass at the first stage of a step only,
    !> kept for its other stages (numerics.renormalise = 'step'); without
    !> the Antuono diffusion, whose density gradient changes with rho
    logical :: renormalise_per_step = .false.
    logical :: first_stage = .true.            !< the evaluation is a step's first
    type(solver_timing_t) :: timing
  end type solver_t

contains

  !> Sizes the work arrays for the particles already in s%parts and builds
  !> the first neighbour list.  A run continued from a checkpoint passes the
  !> history `resume` it stored: the list is then built as it was, at the
  !> reference positions s%parts%xref with the stored skin, so that the
  !> validity test goes on as without the stop (the sums themselves do not
  !> depend on which list holds their pairs: they run in canonical order
  !> over the pairs within the support).
  subroutine solver_init(s, env, resume)
    type(solver_t), intent(inout) :: s
    type(parallel_env_t), intent(in) :: env
    type(step_history_t), intent(in), optional :: resume
    call ensure_capacity(s)
    ! nu = alpha h c0 / (2 (dim + 2)) for the delta-SPH form (E5: alpha h c0/8 in 2D)
    s%nu = 0
    if (s%rhs%viscosity /= VISC_NONE) &
      s%nu = s%rhs%alpha * s%rhs%kernel%h * s%rhs%c0 / (2 * (s%parts%dim + 2))
    if (present(resume)) then
      s%lm%skin = resume%skin
      call swap_positions(s%parts)        ! x: the reference positions
      call solver_rebuild(s, env, resume=.true.)
    else
      s%lm%skin = s%lm%skin_min
      call solver_rebuild(s, env)
    end if
  end subroutine solver_init

  !> The rest of the history h, after the first evaluation of a continued
  !> run (which sets its own largest acceleration).
  subroutine solver_restore(s, h)
    type(solver_t), intent(inout) :: s
    type(step_history_t), intent(in) :: h
    s%a_local = h%a_max
    s%lm%force_rebuild = h%force_rebuild
  end subroutine solver_restore

  !> The history of the next step (collective).
  function solver_history(s, env) result(h)
    type(solver_t), intent(in) :: s
    type(parallel_env_t), intent(in) :: env
    type(step_history_t) :: h
    h%skin = s%lm%skin
    h%a_max = par_max(env, s%a_local)
    h%force_rebuild = s%lm%force_rebuild
  end function solver_history

  subroutine swap_positions(parts)
    type(particles_t), intent(inout) :: parts
    real(wp), allocatable :: tmp(:, :)
    call move_alloc(parts%x, tmp)
    call move_alloc(parts%xref, parts%x)
    call move_alloc(tmp, parts%xref)
  end subroutine swap_positions

  !> Work arrays as large as the particle arrays (which migration and the
  !> halo may have grown), each only where an option reads it: one column
  !> otherwise (the standard operators need 4 of the 23 reals a particle
  !> that every option together needs).
  subroutine ensure_capacity(s)
    type(solver_t), intent(inout) :: s
    integer :: cap
    logical :: first_pass
    cap = size(s%parts%rho)
    call integrator_reserve(s%integ, cap)
    first_pass = solver_first_pass(s)
    if (allocated(s%drho)) then
      if (size(s%drho) >= cap) return
      deallocate(s%drho, s%du, s%grad_rho, s%lambda, s%lmat, s%dr, s%strain)
    end if
    allocate(s%drho(cap), s%du(3, cap))
    allocate(s%grad_rho(3, merge(cap, 1, s%rhs%diffusion == DIFF_ANTUONO)))
    allocate(s%lambda(1, merge(cap, 1, first_pass .or. s%shifting)))
    allocate(s%lmat(6, merge(cap, 1, first_pass)), s%dr(3, merge(cap, 1, s%shifting)))
    allocate(s%strain(6, merge(cap, 1, rhs_reconstructs(s%rhs))))
    s%drho = 0; s%du = 0; s%grad_rho = 0; s%lambda = 0; s%lmat = 0; s%dr = 0; s%strain = 0
  end subroutine ensure_capacity

  !> Whether the right-hand side has a first pass (E3, E9: M_i, L_i,
  !> lambda_i): the Antuono diffusion, the higher-order and the adjoint
  !> pressure gradients, R1 and the renormalised divergence need it.
  pure logical function solver_first_pass(s) result(yes)
    type(solver_t), intent(in) :: s
    yes = s%rhs%diffusion == DIFF_ANTUONO .or. &
          s%rhs%pressure_gradient == PGRAD_HIGHER_ORDER .or. &
          s%rhs%pressure_gradient == PGRAD_RENORMALISED .or. &
          rhs_reconstructs(s%rhs) .or. s%rhs%divergence == DIV_RENORMALISED
  end function solver_first_pass

  !> Re-balances the decomposition when needed (first build, or imbalance
  !> above the threshold), migrates particles to their owners, sorts the
  !> owned ones by cell (memory locality), brings in the halo copies within
  !> the list radius and rebuilds the neighbour list (list_build); the owned
  !> positions become the reference of the validity test.  With resume, x
  !> holds the reference positions and xref the current ones, which trade
  !> places after the build (solver_init with a history to resume).
  subroutine solver_rebuild(s, env, resume)
    type(solver_t), intent(inout) :: s
    type(parallel_env_t), intent(in) :: env
    logical, intent(in), optional :: resume
    integer, allocatable :: perm(:)
    real(wp), allocatable :: w(:)
    real(wp) :: radius, origin(3)
    integer :: ntot
    logical :: resuming
    resuming = .false.
    if (present(resume)) resuming = resume
    radius = list_radius(s%lm, s%rhs%kernel%support)
    associate(pt => s%parts)
      call work(w)
      call decomp_redistribute(s%dc, env, pt, w, radius, s%lm%n_rebuilds == 0)
      allocate(perm(pt%n))
      ! the list's canonical order (most of its ranges then map to
      ! consecutive slots: neighbour_row); the owned positions keep their
      ! lower corner through the sort, so the list reuses it
      origin = list_origin(env, pt%n, pt%x)
      call cell_sort_permutation(pt%dim, pt%n, pt%x, radius, perm, origin, pt%id(1:pt%n))
      call particles_permute(pt, perm)
      call decomp_halo_build(s%dc, env, pt, radius)
      call ensure_capacity(s)
      ntot = pt%n + pt%n_halo
      call list_build(s%lm, env, pt%dim, pt%n, ntot, pt%x, pt%id, s%rhs%kernel%support, origin)
      if (resuming) then
        call swap_positions(pt)
      else
        pt%xref(:, 1:pt%n) = pt%x(:, 1:pt%n)
      end if
      call work(w)
      call decomp_measure(s%dc, env, w)
    end associate

  contains

    !> Work of each owned particle: 1, or its number of pairs in the list.
    subroutine work(w)
      real(wp), allocatable, intent(out) :: w(:)
      allocate(w(s%parts%n))
      w = 1
      if (s%dc%balance == BALANCE_PAIRS .and. s%lm%nl%n_rows > 0) call list_pair_work(s%lm, w)
    end subroutine work

  end subroutine solver_rebuild

  !> One right-hand-side evaluation at the current state: halo copies
  !> refreshed, pressure from the equation of state, then the optional
  !> first pass (E3: the renormalised density gradient of the Antuono
  !> diffusion; E9: the free-surface indicator for the higher-order pressure
  !> gradient, which imposes p = 0 on free-surface partners), its halo
  !> values exchanged in turn, then (E1-E7).  The renormalised divergence
  !> needs the first pass too, for L_i; so does R1, whose strain rate is
  !> summed in it where it computes L_i (else strain_rate's own pass).
  subroutine solver_evaluate(s, env)
    type(solver_t), intent(inout) :: s
    type(parallel_env_t), intent(in) :: env
    integer :: ntot
    logical :: antuono, corrected, first_pass, fresh, recon, adjoint
    real(wp) :: t0, c0
    antuono = s%rhs%diffusion == DIFF_ANTUONO
    corrected = s%rhs%pressure_gradient == PGRAD_HIGHER_ORDER
    adjoint = s%rhs%pressure_gradient == PGRAD_RENORMALISED
    recon = rhs_reconstructs(s%rhs)
    first_pass = solver_first_pass(s)
    ! the stage's own L_i, or (renormalise_per_step) the step's first one
    fresh = antuono .or. s%first_stage .or. .not. s%renormalise_per_step
    associate(pt => s%parts)
      call decomp_refresh(s%dc, env, pt)
      ntot = pt%n + pt%n_halo
      pt%p(1:ntot) = eos_pressure(s%eos, pt%rho(1:ntot))
      t0 = wall_time()
      c0 = s%dc%comm_time
      s%timing%pair_visits = s%timing%pair_visits + real(s%lm%nl%n_pairs, wp) * &
                             merge(2, 1, first_pass .and. fresh)
      if (first_pass .and. .not. fresh) then
        if (recon) call strain_rate(s, env)
        call rhs_evaluate(s%rhs, pt%n, ntot, pt%x, pt%u, pt%rho, pt%m, pt%p, s%grad_rho, &
                          s%lm%nl, s%drho, s%du, s%lambda(1, :), s%lmat, s%rw, s%strain)
      else if (first_pass) then
        ! (R1) the strain rate's sums in the same pass
        if (antuono .and. recon) then
          call rhs_renormalisation(s%rhs, pt%n, ntot, pt%x, pt%rho, pt%m, s%lm%nl, &
                                   s%lambda(1, :), lmat=s%lmat, grad_rho=s%grad_rho, work=s%rw, &
                                   u=pt%u, strain=s%strain)
        else if (antuono) then
          call rhs_renormalisation(s%rhs, pt%n, ntot, pt%x, pt%rho, pt%m, s%lm%nl, &
                                   s%lambda(1, :), lmat=s%lmat, grad_rho=s%grad_rho, work=s%rw)
        else if (recon) then
          call rhs_renormalisation(s%rhs, pt%n, ntot, pt%x, pt%rho, pt%m, s%lm%nl, &
                                   s%lambda(1, :), lmat=s%lmat, work=s%rw, u=pt%u, &
                                   strain=s%strain)
        else
          call rhs_renormalisation(s%rhs, pt%n, ntot, pt%x, pt%rho, pt%m, s%lm%nl, &
                                   s%lambda(1, :), lmat=s%lmat, work=s%rw)
        end if
        if (antuono) call decomp_refresh_field(s%dc, env, pt%n, s%grad_rho, REFLECT_VECTOR)
        ! the lambda of halo partners: (H1) p = 0 on free-surface ones, (H2)
        ! B_j from L_j and lambda_j
        if (corrected .or. adjoint) &
          call decomp_refresh_field(s%dc, env, pt%n, s%lambda, REFLECT_SCALAR)
        if (adjoint) call decomp_refresh_field(s%dc, env, pt%n, s%lmat, REFLECT_SYM6)
        if (recon) call decomp_refresh_field(s%dc, env, pt%n, s%strain, REFLECT_SYM6)
        call rhs_evaluate(s%rhs, pt%n, ntot, pt%x, pt%u, pt%rho, pt%m, pt%p, s%grad_rho, &
                          s%lm%nl, s%drho, s%du, s%lambda(1, :), s%lmat, s%rw, s%strain)
      else
        call rhs_evaluate(s%rhs, pt%n, ntot, pt%x, pt%u, pt%rho, pt%m, pt%p, s%grad_rho, &
                          s%lm%nl, s%drho, s%du, work=s%rw)
      end if
      ! the passes, less the exchanges between them (in comm_time)
      s%timing%pairs = s%timing%pairs + (wall_time() - t0) - (s%dc%comm_time - c0)
      s%a_local = 0
      if (pt%n > 0) s%a_local = sqrt(maxval(sum(s%du(:, 1:pt%n)**2, dim=1)))
    end associate
    s%n_evaluations = s%n_evaluations + 1
  end subroutine solver_evaluate

  !> (R1) The strain rate of the owned particles at the current velocities
  !> with the L_i kept from an earlier stage (renormalise once a step), then
  !> of the halo copies from their owners.
  subroutine strain_rate(s, env)
    type(solver_t), intent(inout) :: s
    type(parallel_env_t), intent(in) :: env
    integer :: ntot
    associate(pt => s%parts)
      ntot = pt%n + pt%n_halo
      call rhs_strain_rate(s%rhs, pt%n, ntot, pt%x, pt%u, pt%rho, pt%m, s%lm%nl, s%lmat, &
                           s%strain, s%rw)
      call decomp_refresh_field(s%dc, env, pt%n, s%strain, REFLECT_SYM6)
      s%timing%pair_visits = s%timing%pair_visits + real(s%lm%nl%n_pairs, wp)
    end associate
  end subroutine strain_rate

  !> Brings the halo copies to the current state (positions, velocities,
  !> densities and pressures), e.g. before a snapshot whose fields use them.
  subroutine solver_sync_halo(s, env)
    type(solver_t), intent(inout) :: s
    type(parallel_env_t), intent(in) :: env
    integer :: ntot
    call decomp_refresh(s%dc, env, s%parts)
    ntot = s%parts%n + s%parts%n_halo
    s%parts%p(s%parts%n + 1:ntot) = eos_pressure(s%eos, s%parts%rho(s%parts%n + 1:ntot))
  end subroutine solver_sync_halo

  !> Fields of the flow for the snapshots, on the solver's list in its
  !> canonical order (bitwise the same on any number of ranks): lambda(n),
  !> the free-surface indicator (E9), and in 2D omega(n) = dv/dx - du/dy,
  !> the vorticity of the renormalised velocity gradient (E2, E3; exact
  !> for a linear velocity; L_i = I where lambda_i < LAMBDA_MIN).  The
  !> halo copies must be current (solver_sync_halo) and the list valid at
  !> the positions (it is at the end of a step).  omega is empty in 3D.
  subroutine solver_flow_fields(s, lambda, omega)
    type(solver_t), intent(inout) :: s     !< its work arrays serve as scratch
    real(wp), allocatable, intent(out) :: lambda(:), omega(:)
    real(wp), allocatable :: lam(:), g(:, :)
    integer :: n, ntot
    n = s%parts%n
    ntot = n + s%parts%n_halo
    allocate(lam(max(ntot, 1)), g(3, max(ntot, 1)))
    associate(pt => s%parts)
      if (pt%dim == 2) then
        call rhs_renormalisation(s%rhs, n, ntot, pt%x, pt%rho, pt%m, s%lm%nl, lam, &
                                 grad_rho=g, work=s%rw, phi=pt%u(2, 1:ntot))
        omega = g(1, 1:n)
        call rhs_renormalisation(s%rhs, n, ntot, pt%x, pt%rho, pt%m, s%lm%nl, lam, &
                                 grad_rho=g, work=s%rw, phi=pt%u(1, 1:ntot))
        omega = omega - g(2, 1:n)
      else
        call rhs_renormalisation(s%rhs, n, ntot, pt%x, pt%rho, pt%m, s%lm%nl, lam, work=s%rw)
        allocate(omega(0))
      end if
    end associate
    lambda = lam(1:n)
  end subroutine solver_flow_fields

  !> (T3) dt = min(cfl h/(c0 + Umax), cfl_force sqrt(h/max|a|), cfl_visc h^2/nu,
  !> CFL_DIFF h/(delta c0)) from the velocities and the accelerations in s%du.
  subroutine solver_time_step(s, env, dt)
    type(solver_t), intent(inout) :: s
    type(parallel_env_t), intent(in) :: env
    real(wp), intent(out) :: dt
    real(wp) :: h
    integer :: n
    n = s%parts%n
    h = s%rhs%kernel%h
    s%umax = 0
    s%amax = 0
    if (n > 0) then
      s%umax = sqrt(maxval(sum(s%parts%u(:, 1:n)**2, dim=1)))
      s%amax = sqrt(maxval(sum(s%du(:, 1:n)**2, dim=1)))
    end if
    s%umax = par_max(env, s%umax)
    s%amax = par_max(env, s%amax)
    s%dt_cfl = s%cfl * h / (s%rhs%c0 + s%umax)
    s%dt_force = huge(1.0_wp)
    if (s%amax > 0) s%dt_force = s%cfl_force * sqrt(h / s%amax)
    s%dt_visc = huge(1.0_wp)
    if (s%nu > 0) s%dt_visc = s%cfl_visc * h**2 / s%nu
    ! the density diffusion (E2) is explicit too
    s%dt_diff = huge(1.0_wp)
    if (s%rhs%diffusion /= DIFF_NONE .and. s%rhs%delta > 0) &
      s%dt_diff = CFL_DIFF * h / (s%rhs%delta * s%rhs%c0)
    dt = min(s%dt_cfl, s%dt_force, s%dt_visc, s%dt_diff)
  end subroutine solver_time_step

  !> Advances the state by one step of at most dt_limit; returns the dt taken:
  !> the list rebuilt unless it holds every pair the step can bring within
  !> the support (list_check), the first stage evaluated, the time step
  !> (T3), the remaining stages of the integrator, then the pressure and the
  !> optional shifting (E8).
  subroutine solver_step(s, env, dt_limit, dt)
    type(solver_t), intent(inout) :: s
    type(parallel_env_t), intent(in) :: env
    real(wp), intent(in) :: dt_limit
    real(wp), intent(out) :: dt
    integer :: n, stage
    logical :: rebuild
    real(wp) :: t0, c0
    t0 = wall_time()
    call list_check(s%lm, env, s%parts%dim, s%parts%n, s%parts%xref, s%parts%x, s%parts%u, &
                    s%a_local, s%parts%id, s%rhs%kernel%support, s%cfl * s%rhs%kernel%h, &
                    s%rhs%c0, rebuild)
    s%timing%check = s%timing%check + (wall_time() - t0)
    if (rebuild) then
      t0 = wall_time()
      c0 = s%dc%comm_time
      call solver_rebuild(s, env)
      s%timing%rebuild = s%timing%rebuild + (wall_time() - t0) - (s%dc%comm_time - c0)
    end if
    n = s%parts%n      ! migration may have changed it

    s%first_stage = .true.
    call solver_evaluate(s, env)
    s%first_stage = .false.
    call solver_time_step(s, env, dt)
    ! the list holds every pair that comes within the support up to dt_valid
    dt = min(dt, dt_limit, s%lm%dt_valid)

    do stage = 1, integrator_stages(s%integ)
      if (stage > 1) call solver_evaluate(s, env)
      if (s%lm%mirror /= 0) call hold_on_planes(s%parts, n, s%lm%mirror, s%du)
      t0 = wall_time()
      call integrator_advance(s%integ, stage, dt, n, s%parts%x, s%parts%u, s%parts%rho, &
                              s%du, s%drho)
      s%timing%integrate = s%timing%integrate + (wall_time() - t0)
    end do
    s%parts%p(1:n) = eos_pressure(s%eos, s%parts%rho(1:n))
    if (s%lm%mirror /= 0) call take_images_across(s%parts, n, s%lm%mirror, s%n_across)
    if (s%shifting) call shift_particles(s, env, dt)
  end subroutine solver_step

  !> A particle on a mirror plane (x_k = 0) stays on it: its images balance
  !> its normal acceleration, which round-off would not leave exactly 0.
  subroutine hold_on_planes(parts, n, mask, du)
    type(particles_t), intent(in) :: parts
    integer, intent(in) :: n, mask
    real(wp), intent(inout) :: du(:, :)
    integer :: i
    do i = 1, n
      call hold_normal(parts%x(:, i), mask, du(:, i))
    end do
  end subroutine hold_on_planes

  !> (M4) A particle that crossed a mirror plane in the step (it and its
  !> image passed through each other) trades places with its image, which is
  !> on the part's side: the whole body is the same set of particles, only
  !> relabelled.  Its initial position is reflected with it, so that the
  !> Lagrangian map stays its own.
  subroutine take_images_across(parts, n, mask, count)
    type(particles_t), intent(inout) :: parts
    integer, intent(in) :: n, mask
    integer(i8), intent(inout) :: count     !< trades so far, on this rank
    integer :: i, k
    do k = 1, 3
      if (.not. btest(mask, k - 1)) cycle
      do i = 1, n
        if (parts%x(k, i) < 0) then
          parts%x(k, i) = -parts%x(k, i)
          parts%u(k, i) = -parts%u(k, i)
          parts%x0(k, i) = -parts%x0(k, i)
          count = count + 1
        end if
      end do
    end do
  end subroutine take_images_across

  !> (E8) Particle shifting after a step of dt: the halo copies are brought
  !> to the end of the step, then every owned particle moves by
  !>   dr_i = -CFL Ma (2h)^2 Sum_j [1 + 0.2 (W_ij/W(dx))^4] g V_j
  !> (fluid_rhs: rhs_shift, with its free-surface treatment), where
  !> Ma = Umax/c0 and CFL = dt (c0 + Umax)/h is the acoustic Courant number
  !> of the step taken (numerics.cfl unless the step was shortened), Umax
  !> the one of the step's time-step limit.  Positions only: velocities,
  !> densities and masses are not changed, so momentum is not either.  The
  !> list stays valid: it covered the step, and the validity test of the
  !> next step counts the shift.
  subroutine shift_particles(s, env, dt)
    type(solver_t), intent(inout) :: s
    type(parallel_env_t), intent(in) :: env
    real(wp), intent(in) :: dt
    real(wp) :: h, coef, dmax
    integer :: n, ntot
    n = s%parts%n
    h = s%rhs%kernel%h
    call decomp_refresh(s%dc, env, s%parts)
    ntot = n + s%parts%n_halo
    coef = (dt * (s%rhs%c0 + s%umax) / h) * (s%umax / s%rhs%c0) * (2 * h)**2
    call rhs_shift(s%rhs, n, ntot, s%parts%x, s%parts%rho, s%parts%m, s%lm%nl, coef, &
                   s%shift_dx, s%dr, s%lambda(1, :), s%rw)
    s%parts%x(:, 1:n) = s%parts%x(:, 1:n) + s%dr(:, 1:n)
    dmax = 0
    if (n > 0) dmax = sqrt(maxval(sum(s%dr(:, 1:n)**2, dim=1)))
    s%shift_max = par_max(env, dmax)
  end subroutine shift_particles

end module solver
