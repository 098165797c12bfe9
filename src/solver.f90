!> The time stepper: particle state, neighbour list management, stage
!> evaluation and the integrators (DESIGN.md section 3).
module solver
  use kinds, only: wp, i8
  use particles, only: particles_t, particles_permute
  use neighbours, only: neighbour_list_t, neighbour_build, cell_sort_permutation, &
                        max_displacement
  use eos, only: eos_t, eos_pressure
  use fluid_rhs, only: rhs_params_t, rhs_density_gradient, rhs_evaluate, DIFF_ANTUONO, &
                       VISC_NONE
  use parallel_env, only: parallel_env_t, par_max, par_min
  implicit none
  private
  public :: solver_t, solver_init, solver_step, solver_evaluate, solver_rebuild, &
            solver_time_step, SCHEME_RK4, SCHEME_PC2

  integer, parameter :: SCHEME_RK4 = 1   !< (T1) classical 4th-order Runge-Kutta
  integer, parameter :: SCHEME_PC2 = 2   !< (T2) 2-stage predictor-corrector

  type :: solver_t
    type(particles_t) :: parts
    type(rhs_params_t) :: rhs
    type(eos_t) :: eos
    type(neighbour_list_t) :: nl
    integer :: scheme = SCHEME_RK4
    real(wp) :: cfl = 1.5_wp, cfl_force = 0.25_wp, cfl_visc = 0.125_wp
    real(wp) :: skin_min = 0      !< smallest skin distance of the list (absolute)
    real(wp) :: skin = 0          !< skin of the current list
    real(wp) :: nu = 0            !< kinematic viscosity equivalent to the artificial one
    real(wp), allocatable :: drho(:), du(:, :), grad_rho(:, :)
    real(wp), allocatable :: xs(:, :), us(:, :), rhos(:)   !< state at the start of a step
    real(wp), allocatable :: xa(:, :), ua(:, :), rhoa(:)   !< RK4 accumulators
    integer :: n_rebuilds = 0
    integer :: n_evaluations = 0
    real(wp) :: umax = 0, amax = 0     !< global maxima at the start of the last step
    real(wp) :: dt_cfl = 0, dt_force = 0, dt_visc = 0  !< the limits of the last step
  end type solver_t

contains

  !> Sizes the work arrays for the particles already in s%parts and builds
  !> the first neighbour list.
  subroutine solver_init(s, env)
    type(solver_t), intent(inout) :: s
    type(parallel_env_t), intent(in) :: env
    integer :: cap
    cap = size(s%parts%rho)
    allocate(s%drho(cap), s%du(3, cap), s%grad_rho(3, cap))
    allocate(s%xs(3, cap), s%us(3, cap), s%rhos(cap), s%xa(3, cap), s%ua(3, cap), s%rhoa(cap))
    s%drho = 0; s%du = 0; s%grad_rho = 0
    s%skin = s%skin_min
    ! nu = alpha h c0 / (2 (dim + 2)) for the delta-SPH form (E5: alpha h c0/8 in 2D)
    s%nu = 0
    if (s%rhs%viscosity /= VISC_NONE) &
      s%nu = s%rhs%alpha * s%rhs%kernel%h * s%rhs%c0 / (2 * (s%parts%dim + 2))
    call solver_rebuild(s, env)
  end subroutine solver_init

  !> Sorts the owned particles by cell (memory locality) and rebuilds the
  !> neighbour list on the grid aligned on the global lower corner of the
  !> particles, which every rank computes alike.
  subroutine solver_rebuild(s, env)
    type(solver_t), intent(inout) :: s
    type(parallel_env_t), intent(in) :: env
    integer, allocatable :: perm(:)
    real(wp) :: radius, origin(3)
    integer :: k, ntot
    associate(pt => s%parts)
      radius = s%rhs%kernel%support + s%skin
      allocate(perm(pt%n))
      call cell_sort_permutation(pt%dim, pt%n, pt%x, radius, perm)
      call particles_permute(pt, perm)
      ntot = pt%n + pt%n_halo
      do k = 1, 3
        origin(k) = huge(1.0_wp)
        if (ntot > 0) origin(k) = minval(pt%x(k, 1:ntot))
        origin(k) = par_min(env, origin(k))
      end do
      call neighbour_build(s%nl, pt%dim, pt%n, ntot, pt%x, pt%id, radius, origin)
    end associate
    s%n_rebuilds = s%n_rebuilds + 1
  end subroutine solver_rebuild

  !> One right-hand-side evaluation at the current state: pressure from the
  !> equation of state, then the optional density-gradient pass, then (E1-E5).
  subroutine solver_evaluate(s)
    type(solver_t), intent(inout) :: s
    integer :: ntot
    associate(pt => s%parts)
      ntot = pt%n + pt%n_halo
      pt%p(1:ntot) = eos_pressure(s%eos, pt%rho(1:ntot))
      if (s%rhs%diffusion == DIFF_ANTUONO) &
        call rhs_density_gradient(s%rhs, pt%n, ntot, pt%x, pt%rho, pt%m, s%nl, s%grad_rho)
      call rhs_evaluate(s%rhs, pt%n, ntot, pt%x, pt%u, pt%rho, pt%m, pt%p, s%grad_rho, &
                        s%nl, s%drho, s%du)
    end associate
    s%n_evaluations = s%n_evaluations + 1
  end subroutine solver_evaluate

  !> (T3) dt = min(cfl h/(c0 + Umax), cfl_force sqrt(h/max|a|), cfl_visc h^2/nu)
  !> from the velocities and the accelerations in s%du.
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
    dt = min(s%dt_cfl, s%dt_force, s%dt_visc)
  end subroutine solver_time_step

  !> Advances the state by one step of at most dt_limit; returns the dt taken.
  !> A pair outside the list can come within the kernel support only after
  !> one of its particles has moved half the skin.  A step moves a particle
  !> at most about dt_cfl Umax = cfl h Umax/(c0 + Umax) (1.25 covers the
  !> speed-up within the step), so the list is rebuilt when the displacement
  !> since the last build plus that reach could exceed half the skin, and a
  !> rebuild widens the skin when needed so that the list always covers at
  !> least the coming step (numerics.skin is the minimum).
  subroutine solver_step(s, env, dt_limit, dt)
    type(solver_t), intent(inout) :: s
    type(parallel_env_t), intent(in) :: env
    real(wp), intent(in) :: dt_limit
    real(wp), intent(out) :: dt
    real(wp) :: moved, reach, umax
    integer :: n
    n = s%parts%n
    moved = par_max(env, max_displacement(s%nl, s%parts%x))
    umax = 0
    if (n > 0) umax = sqrt(maxval(sum(s%parts%u(:, 1:n)**2, dim=1)))
    umax = par_max(env, umax)
    reach = 1.25_wp * s%cfl * s%rhs%kernel%h * umax / (s%rhs%c0 + umax)
    if (2 * (moved + reach) >= s%skin) then
      s%skin = max(s%skin_min, 2.2_wp * reach)
      call solver_rebuild(s, env)
    end if

    call solver_evaluate(s)
    call solver_time_step(s, env, dt)
    dt = min(dt, dt_limit)

    associate(x => s%parts%x, u => s%parts%u, rho => s%parts%rho, &
              du => s%du, drho => s%drho)
      s%xs(:, 1:n) = x(:, 1:n)
      s%us(:, 1:n) = u(:, 1:n)
      s%rhos(1:n) = rho(1:n)
      select case (s%scheme)
      case (SCHEME_RK4)
        ! k1 at y0; y1 = y0 + dt/2 k1
        s%xa(:, 1:n) = s%xs(:, 1:n) + dt / 6 * u(:, 1:n)
        s%ua(:, 1:n) = s%us(:, 1:n) + dt / 6 * du(:, 1:n)
        s%rhoa(1:n) = s%rhos(1:n) + dt / 6 * drho(1:n)
        call half_stage(0.5_wp * dt)
        ! k2 at y1; y2 = y0 + dt/2 k2
        call solver_evaluate(s)
        call accumulate(dt / 3)
        call half_stage(0.5_wp * dt)
        ! k3 at y2; y3 = y0 + dt k3
        call solver_evaluate(s)
        call accumulate(dt / 3)
        call half_stage(dt)
        ! k4 at y3; y = y0 + dt/6 (k1 + 2 k2 + 2 k3 + k4)
        call solver_evaluate(s)
        x(:, 1:n) = s%xa(:, 1:n) + dt / 6 * u(:, 1:n)
        u(:, 1:n) = s%ua(:, 1:n) + dt / 6 * du(:, 1:n)
        rho(1:n) = s%rhoa(1:n) + dt / 6 * drho(1:n)
      case (SCHEME_PC2)
        ! predictor to the half step, derivatives there, then the corrector;
        ! positions advance with the mean of the old and new velocities
        call half_stage(0.5_wp * dt)
        call solver_evaluate(s)
        rho(1:n) = s%rhos(1:n) + dt * drho(1:n)
        u(:, 1:n) = s%us(:, 1:n) + dt * du(:, 1:n)
        x(:, 1:n) = s%xs(:, 1:n) + 0.5_wp * dt * (s%us(:, 1:n) + u(:, 1:n))
      end select
    end associate
    s%parts%p(1:n) = eos_pressure(s%eos, s%parts%rho(1:n))

  contains

    !> y = y0 + tau k, with k = (u, du, drho) of the current stage; x first,
    !> while u still holds the stage velocity.
    subroutine half_stage(tau)
      real(wp), intent(in) :: tau
      s%parts%x(:, 1:n) = s%xs(:, 1:n) + tau * s%parts%u(:, 1:n)
      s%parts%u(:, 1:n) = s%us(:, 1:n) + tau * s%du(:, 1:n)
      s%parts%rho(1:n) = s%rhos(1:n) + tau * s%drho(1:n)
    end subroutine half_stage

    subroutine accumulate(w)
      real(wp), intent(in) :: w
      s%xa(:, 1:n) = s%xa(:, 1:n) + w * s%parts%u(:, 1:n)
      s%ua(:, 1:n) = s%ua(:, 1:n) + w * s%du(:, 1:n)
      s%rhoa(1:n) = s%rhoa(1:n) + w * s%drho(1:n)
    end subroutine accumulate

  end subroutine solver_step

end module solver
