!> Prototype problem 1: the stretching free-surface circular patch (2D,
!> `circle2d`) and sphere (3D, `ellipsoid3d`), with the exact solution X1
!> recorded beside the SPH values.  This is what the two cases share; their
!> own groups are in case_circle2d and case_ellipsoid3d.
!>
!> Initial state (paper eq. 1, doc/theory/ X1): u_k = alpha_k x_k,
!> p = P(0) (1 - |x|^2/R^2), rho from the inverse equation of state,
!> m = rho times the particle's area (volume).
module case_stretching
  use kinds, only: wp, i8
  use case_base, only: case_t, case_fields_t, case_flow_t
  use input_params, only: particles_params_t, physics_params_t
  use kernels, only: kernel_t
  use particles, only: particles_t, particles_allocate
  use placement, only: place_ball, ball_spacing, packed_volume
  use mirrors, only: mirror_copies, plane_slabs
  use eos, only: eos_t, eos_density
  use exact_ellipse, only: ellipse_exact_t, ellipse_exact_init, ellipse_exact_at, &
                           ellipse_centre_pressure, ellipse_map, ellipse_velocity, &
                           ellipse_pressure, ellipse_centre_pressure_rate
  use placement, only: PLACE_RINGS, PLACE_LATTICE, PLACE_PACKED
  use diagnostics, only: fitted_semi_axes, probe_pressure, kinetic_energy
  use parallel_env, only: parallel_env_t, par_sum_array
  use, intrinsic :: ieee_arithmetic, only: ieee_is_nan
  implicit none
  private
  public :: stretching_t

  !> The case, its exact solution and the running means of its errors.
  !> radius, a0, rates and prepared are set by the concrete case.
  type, abstract, extends(case_t) :: stretching_t
    real(wp) :: radius = 1, a0 = 1, rho0 = 1
    real(wp) :: rates(3) = 0            !< alpha_k(0) / A0
    real(wp) :: p0 = 0                  !< P(0), exact centre pressure at t = 0
    type(ellipse_exact_t) :: ex
    logical :: prepared = .false.       !< (I1) the compressible correction of u0
    ! running sums over samples (for the paper's time-averaged errors)
    integer :: n_samples = 0
    real(wp) :: sum_axis_err = 0, sum_pos_err = 0, sum_vel_err = 0, sum_p_err = 0
    integer :: n_p_samples = 0
    ! the last sample's errors
    real(wp) :: axis_err(3) = 0, pos_err = 0, vel_err = 0, ke_exact = 0, ke_start = -1
  contains
    procedure :: setup => stretching_setup
    procedure :: initial_state => stretching_initial_state
    procedure :: columns => stretching_columns
    procedure :: sample => stretching_sample
    procedure :: fields => stretching_fields
    procedure :: field => stretching_field
    procedure :: summary => stretching_summary
  end type stretching_t

contains

  !> Places this rank's share of the particles (the placement generates it
  !> alone) and sets their initial state; the first list build moves them
  !> to their owners.
  subroutine stretching_setup(self, particles, physics, eos, parts, dx, share)
    class(stretching_t), intent(inout) :: self
    type(particles_params_t), intent(in) :: particles
    type(physics_params_t), intent(in) :: physics
    type(eos_t), intent(in) :: eos
    type(particles_t), intent(inout) :: parts
    real(wp), intent(out) :: dx
    integer, intent(in) :: share(2)
    real(wp), allocatable :: x(:, :), vol(:)
    integer :: i, np, place, first, n_total
    integer(i8) :: n_whole
    select case (particles%placement)
    case ('lattice')
      place = PLACE_LATTICE
    case ('packed')
      place = PLACE_PACKED
    case default
      place = PLACE_RINGS
    end select
    self%rho0 = physics%rho0
    call ellipse_exact_init(self%ex, self%dim, self%rho0, self%radius, &
                            self%a0 * self%rates(1:self%dim))
    self%p0 = ellipse_centre_pressure(self%ex)
    dx = ball_spacing(self%dim, self%radius, particles%n, place)
    ! (M6) a plane the flow approaches gets the deeper slab
    self%pack_slab = plane_slabs(self%rates)
    call place_ball(self%dim, self%radius, dx, place, x, vol, share, first, n_total, &
                    self%mirror, n_whole, self%pack_slab)
    np = size(vol)
    ! packed: equal volumes |Omega|/N, dx the spacing that goes with them
    ! (N the whole body's: the part's count times the copies, M5 a point
    ! on a plane half as often)
    if (place == PLACE_PACKED) then
      dx = packed_volume(self%dim, self%radius, n_whole)**(1 / real(self%dim, wp))
      self%pack_radius = self%radius
    end if
    call particles_allocate(parts, self%dim, max(np, 1))
    parts%n = np
    do i = 1, np
      parts%x(:, i) = x(:, i)
      parts%m(i) = vol(i)
      parts%rho(i) = 1
      parts%id(i) = first + i - 1
    end do
    call stretching_initial_state(self, eos, parts)
  end subroutine stretching_setup

  !> The initial state at the current positions x of the owned particles
  !> (paper eq. 1, X1) with particle spacing dx: x0 = x, u_k = alpha_k(0) x_k, p = P(0) (1 - |x|^2/R^2),
  !> rho from the inverse equation of state, m = rho V with the particle's
  !> volume V = m/rho of the state it replaces.
  subroutine stretching_initial_state(self, eos, parts)
    class(stretching_t), intent(inout) :: self
    type(eos_t), intent(in) :: eos
    type(particles_t), intent(inout) :: parts
    real(wp) :: p, vol, kappa, r2
    integer :: i, d
    d = self%dim
    ! (I1) the prepared start: div u = -(dP/dt)(0) (1 - r^2/R^2) / (rho0 c0^2)
    kappa = 0
    if (self%prepared) then
      call ellipse_exact_at(self%ex, 0.0_wp)
      kappa = ellipse_centre_pressure_rate(self%ex) / (eos%rho0 * eos%c0**2)
    end if
    do i = 1, parts%n
      vol = parts%m(i) / parts%rho(i)
      parts%x0(:, i) = parts%x(:, i)
      r2 = sum(parts%x(:, i)**2)
      parts%u(:, i) = self%a0 * self%rates * parts%x(:, i) &
                      - kappa * (1.0_wp / d - r2 / ((d + 2) * self%radius**2)) * parts%x(:, i)
      p = self%p0 * (1 - r2 / self%radius**2)
      parts%p(i) = p
      parts%rho(i) = eos_density(eos, p)
      parts%m(i) = parts%rho(i) * vol
    end do
  end subroutine stretching_initial_state

  !> Time-series columns this case adds after the generic ones.
  subroutine stretching_columns(self, names)
    class(stretching_t), intent(in) :: self
    character(len=32), allocatable, intent(out) :: names(:)
    character(len=1), parameter :: ax(3) = ['1', '2', '3']
    integer :: k, d
    d = self%dim
    allocate(names(0))
    names = [character(len=32) :: 'kinetic_energy_exact', 'p_centre_exact']
    names = [character(len=32) :: names, ('semi_axis_' // ax(k), k = 1, d)]
    names = [character(len=32) :: names, ('semi_axis_' // ax(k) // '_exact', k = 1, d)]
    names = [character(len=32) :: names, ('semi_axis_' // ax(k) // '_error', k = 1, d)]
    names = [character(len=32) :: names, 'rms_position_error', 'rms_velocity_error']
  end subroutine stretching_columns

  !> Values of the case's columns at time t.  The pressure interpolated at
  !> the centre enters the running mean of the pressure error.
  !>  - kinetic_energy_exact: KE of these particles moving with the exact
  !>    flow, Sum 1/2 m |alpha(t) x_exact|^2 (constant in time);
  !>  - semi_axis_k: fitted to the particles' second moments; _exact: a_k(t);
  !>    _error: fitted SPH axis over the same fit of the exact positions,
  !>    minus 1 (removes the fit's small bias on a discrete sample);
  !>  - rms_position_error: RMS |x - x_exact| / R over particles, with
  !>    x_exact the exact Lagrangian map of the particle's initial position;
  !>  - rms_velocity_error: RMS |u - alpha x| / (A0 R), exact velocity at the
  !>    particle's own position.
  subroutine stretching_sample(self, env, t, parts, kernel, values)
    class(stretching_t), intent(inout) :: self
    type(parallel_env_t), intent(in) :: env
    real(wp), intent(in) :: t
    type(particles_t), intent(in) :: parts
    type(kernel_t), intent(in) :: kernel
    real(wp), allocatable, intent(out) :: values(:)
    real(wp), allocatable :: xe(:, :)
    real(wp) :: s(4), fit(3), fit_exact(3), ue(3), a_over_r(3), p_centre
    integer :: i, n, d
    associate(st => self)
    p_centre = probe_pressure(env, parts, kernel, [0.0_wp, 0.0_wp, 0.0_wp], st%mirror)
    if (st%ke_start < 0) st%ke_start = kinetic_energy(env, parts, st%mirror)
    n = parts%n
    d = st%dim
    call ellipse_exact_at(st%ex, t)
    allocate(xe(3, max(n, 1)))
    a_over_r = st%ex%a / st%radius
    s = 0
    do i = 1, n
      xe(:, i) = parts%x0(:, i) * a_over_r
      ue = st%ex%alpha * parts%x(:, i)
      s(1) = s(1) + sum((parts%x(:, i) - xe(:, i))**2)
      s(2) = s(2) + sum((parts%u(:, i) - ue)**2)
      s(3) = s(3) + 0.5_wp * parts%m(i) * sum((st%ex%alpha * xe(:, i))**2)
      s(4) = s(4) + 1
    end do
    call par_sum_array(env, s)
    s(3) = s(3) * mirror_copies(st%mirror)    ! the whole body's
    fit = fitted_semi_axes(env, d, n, parts%m, parts%x, st%mirror)
    fit_exact = fitted_semi_axes(env, d, n, parts%m, xe, st%mirror)
    st%pos_err = sqrt(s(1) / s(4)) / st%radius
    st%vel_err = sqrt(s(2) / s(4)) / (st%a0 * st%radius)
    st%ke_exact = s(3)
    st%axis_err = 0
    st%axis_err(1:d) = fit(1:d) / fit_exact(1:d) - 1
    values = [st%ke_exact, ellipse_centre_pressure(st%ex), fit(1:d), st%ex%a(1:d), &
              st%axis_err(1:d), st%pos_err, st%vel_err]
    st%n_samples = st%n_samples + 1
    st%sum_axis_err = st%sum_axis_err + maxval(abs(st%axis_err(1:d)))
    st%sum_pos_err = st%sum_pos_err + st%pos_err
    st%sum_vel_err = st%sum_vel_err + st%vel_err
    if (.not. ieee_is_nan(p_centre)) then   ! a particle was near the centre
      st%sum_p_err = st%sum_p_err + abs(p_centre - ellipse_centre_pressure(st%ex)) / st%p0
      st%n_p_samples = st%n_p_samples + 1
    end if
    end associate
  end subroutine stretching_sample

  !> Extra snapshot fields: exact Lagrangian positions, the exact velocity
  !> and pressure at each particle's position, the free-surface indicator
  !> `free_surface_lambda` (E9); the exact semi-axes and centre pressure as
  !> attributes.
  subroutine stretching_fields(self, t, f)
    class(stretching_t), intent(inout) :: self
    real(wp), intent(in) :: t
    type(case_fields_t), intent(out) :: f
    call ellipse_exact_at(self%ex, t)
    f%vector_names = [character(len=32) :: 'position_exact', 'velocity_exact']
    f%scalar_names = [character(len=32) :: 'pressure_exact', 'free_surface_lambda']
    f%attr_names = [character(len=32) :: 'semi_axes_exact_1', 'semi_axes_exact_2', &
                    'semi_axes_exact_3', 'p_centre_exact']
    f%attr_values = [self%ex%a, ellipse_centre_pressure(self%ex)]
  end subroutine stretching_fields

  !> The values of one of the fields stretching_fields names.
  subroutine stretching_field(self, t, name, parts, flow, v, s)
    class(stretching_t), intent(inout) :: self
    real(wp), intent(in) :: t
    character(len=*), intent(in) :: name
    type(particles_t), intent(in) :: parts
    type(case_flow_t), intent(in) :: flow
    real(wp), allocatable, intent(out) :: v(:, :), s(:)
    integer :: i, n
    n = parts%n
    call ellipse_exact_at(self%ex, t)
    select case (name)
    case ('position_exact')
      allocate(v(3, n))
      do i = 1, n
        v(:, i) = ellipse_map(self%ex, parts%x0(:, i))
      end do
    case ('velocity_exact')
      allocate(v(3, n))
      do i = 1, n
        v(:, i) = ellipse_velocity(self%ex, parts%x(:, i))
      end do
    case ('pressure_exact')
      allocate(s(n))
      do i = 1, n
        s(i) = ellipse_pressure(self%ex, parts%x(:, i))
      end do
    case ('free_surface_lambda')
      s = flow%lambda(1:n)
    case default
      error stop 'stretching_field: no field ' // name
    end select
  end subroutine stretching_field

  !> The closing summary of errors against the exact solution (rank 0 prints).
  subroutine stretching_summary(self, env, unit, t, parts, kernel)
    class(stretching_t), intent(inout) :: self
    type(parallel_env_t), intent(in) :: env
    integer, intent(in) :: unit
    real(wp), intent(in) :: t
    type(particles_t), intent(in) :: parts
    type(kernel_t), intent(in) :: kernel
    real(wp) :: pc, ke, p_centre
    integer :: k
    character(len=1), parameter :: ax(3) = ['x', 'y', 'z']
    ke = kinetic_energy(env, parts, self%mirror)
    p_centre = probe_pressure(env, parts, kernel, [0.0_wp, 0.0_wp, 0.0_wp], self%mirror)
    if (env%rank /= 0) return
    associate(st => self, ke_start => self%ke_start)
    call ellipse_exact_at(st%ex, t)
    pc = ellipse_centre_pressure(st%ex)
    write(unit, '(a)') ''
    write(unit, '(a,f8.4,a)') 'Errors against the exact solution at t A0 = ', t * st%a0, ':'
    do k = 1, st%dim
      write(unit, '(2x,a,a,f10.6,a,f10.6,a,f8.3,a)') 'semi-axis ', ax(k), st%ex%a(k), &
        ' exact, ', st%ex%a(k) * (1 + st%axis_err(k)), ' SPH: error', 100 * st%axis_err(k), ' %'
    end do
    write(unit, '(2x,a,f8.3,a)') 'RMS position error (vs Lagrangian map) / R   ', &
      100 * st%pos_err, ' %'
    write(unit, '(2x,a,f8.3,a)') 'RMS velocity error / (A0 R)                  ', &
      100 * st%vel_err, ' %'
    write(unit, '(2x,a,f8.3,a)') 'kinetic energy change since t = 0            ', &
      100 * (ke / ke_start - 1), ' %'
    write(unit, '(2x,a,f8.3,a,es11.4,a,es11.4,a)') 'centre pressure error (raw) / P(0)           ', &
      100 * (p_centre - pc) / st%p0, ' %  (SPH ', p_centre, ', exact ', pc, ')'
    if (st%n_samples > 0) then
      write(unit, '(a,i0,a)') 'Time-averaged over ', st%n_samples, ' samples:'
      write(unit, '(2x,a,f8.3,a)') 'max semi-axis error    ', 100 * st%sum_axis_err / st%n_samples, ' %'
      write(unit, '(2x,a,f8.3,a)') 'RMS position error     ', 100 * st%sum_pos_err / st%n_samples, ' %'
      write(unit, '(2x,a,f8.3,a)') 'RMS velocity error     ', 100 * st%sum_vel_err / st%n_samples, ' %'
      if (st%n_p_samples > 0) write(unit, '(2x,a,f8.3,a)') &
        'centre pressure (raw)  ', 100 * st%sum_p_err / st%n_p_samples, ' % of P(0)'
    end if
    end associate
  end subroutine stretching_summary

end module case_stretching
