!> Prototype problems 2 and 3: the free-surface square patches of side L,
!> centred at the origin, on a square lattice of spacing dx.
!>
!>  - `square_rotation` (paper eq. 2, doc/theory/ X3): rigid rotation
!>    u = omega y, v = -omega x; Laplacian p0 = 2 rho omega^2, p0 = 0 on the
!>    edges.  Conserves kinetic energy (KE0 = rho omega^2 L^4/12) and angular
!>    momentum; symmetric under rotation by 90 degrees.  The negative
!>    pressure makes it the test of the tensile instability control (E7).
!>  - `square_vortical` (paper eq. 3 corrected, doc/theory/ X4):
!>    u = V0 (f(y) - e^-4), v = -V0 (f(x) - e^-4), f(s) = exp(-(4 s/L)^2);
!>    Laplacian p0 = 2 rho V0^2 f'(x) f'(y) = 2 rho (32 V0/L^2)^2 x y f(x) f(y).
!>    Symmetric under the reflection (x, y) -> (-y, -x); its net momentum is
!>    not zero (u >= 0, v <= 0 everywhere): the patch drifts along (1, -1).
!>    The free surface folds and reconnects (paper: t V0/L about 1.2).
!>
!> The initial pressure comes from the Poisson solver (poisson_square) on a
!> grid of 1024 intervals (error below 2e-7 rho omega^2 L^2, 1e-7 rho V0^2),
!> the density from the inverse equation of state, the mass rho dx^2.
!> Particle (i, j), i, j = 1..n_side, starts at x = -L/2 + (i - 1/2) dx,
!> y = -L/2 + (j - 1/2) dx and has the global id i + (j - 1) n_side; the
!> lattice is mapped onto itself by the symmetry S of the case, which pairs
!> each particle with its partner (symmetry error below).
module case_square
  use kinds, only: wp, pi
  use case_base, only: case_t, case_fields_t, case_flow_t, keep_share
  use input_params, only: particles_params_t, physics_params_t
  use kernels, only: kernel_t, kernel_init, kernel_kind_of
  use particles, only: particles_t, particles_allocate
  use eos, only: eos_t, eos_density
  use poisson_square, only: poisson_square_t, poisson_square_nodes, poisson_square_solve, &
                            poisson_square_eval, POISSON_DEFAULT_N
  use diagnostics, only: probe_pressure, kinetic_energy, total_momentum
  use flow_diagnostics, only: angular_momentum, gather_by_id, symmetry_error, topology_t, &
                              fluid_topology
  use spectrum, only: dominant_frequency
  use parallel_env, only: parallel_env_t
  use, intrinsic :: ieee_arithmetic, only: ieee_is_nan
  implicit none
  private
  public :: square_patch_t, vortical_velocity, vortical_vorticity, SQ_ROTATION, SQ_VORTICAL

  integer, parameter :: SQ_ROTATION = 1, SQ_VORTICAL = 2

  !> Lowest frequency searched for the acoustic peak of p_A, as a fraction
  !> of the lowest acoustic mode c0/(sqrt(2) L) (X6): the filter's cut-off.
  !> A fixed 0.8 omega let the slow rise that the detrend leaves win over
  !> the acoustic peak at 90,000 particles (1.20 omega found, f0 4.95).
  real(wp), parameter :: F_MIN_OVER_F0 = 0.5_wp
  !> Smallest cavity, in units of L^2: the reconnecting free surface of the
  !> vortical patch encloses voids of 2.7 % of L^2 within 0.1 L/V0 (10,000
  !> particles), while gaps opened between particles under tension stay
  !> below 0.7 % (flow_diagnostics: fluid_topology).
  real(wp), parameter :: CAVITY_AREA = 0.01_wp
  !> Interval between evaluations of the topology, in units of 1/omega or
  !> L/V0: 1 % of the time scale.  Evaluated at every sample it cost a third
  !> of the run time at 10,000 particles (up to 10 ms a sample as the
  !> patch spreads over a larger box).
  real(wp), parameter :: TOPOLOGY_INTERVAL = 0.01_wp

  !> A square patch, its reference values and the running diagnostics.
  !> kind, side and rate are set by the concrete case.
  type, abstract, extends(case_t) :: square_patch_t
    integer :: kind = SQ_ROTATION
    real(wp) :: side = 1, rate = 1      !< L; omega (rotation) or V0 (vortical)
    real(wp) :: rho0 = 1, c0 = 10, dx = 1
    integer :: n_side = 0, n_global = 0
    integer, allocatable :: partner(:)  !< by id: the particle that started at S x0
    real(wp) :: sym(2, 2) = 0           !< the symmetry S
    real(wp) :: p_centre0 = 0           !< p_A(0) from the Poisson solution
    real(wp) :: p_quarter0 = 0          !< p0(L/4, L/4) from the Poisson solution
    real(wp) :: ke_ref = 0              !< rotation: rho omega^2 L^4/12
    !> the initial kinetic energy, angular momentum, momentum and topology,
    !> from the whole lattice at setup (so that they stay those of t = 0
    !> in a run restarted later)
    real(wp) :: ke_start = 0, lz_start = 0, mom_start(3) = 0
    ! symmetry error and topology at the last sample, and the first changes
    real(wp) :: sym_rms = 0, sym_max = 0
    type(topology_t) :: topo, topo0
    real(wp) :: t_split = -1, t_hole = -1, t_cavity = -1
    real(wp) :: t_topo = 0              !< time of the last topology evaluation
    real(wp) :: time_unit = 1           !< 1/omega or L/V0
    integer :: n_samples = 0
    ! the centre pressure history (rotation), for its spectrum
    integer :: n_hist = 0
    real(wp), allocatable :: t_hist(:), p_hist(:)
  contains
    procedure :: setup => square_setup
    procedure :: columns => square_columns
    procedure :: sample => square_sample
    procedure :: fields => square_fields
    procedure :: field => square_field
    procedure :: summary => square_summary
  end type square_patch_t

contains

  !> Places the n_side^2 particles (n_side = nint(sqrt(particles.n))) and
  !> sets u from the case's field, p from the Poisson solution, rho from the
  !> inverse equation of state and m = rho dx^2.  particles.placement is
  !> not used: the squares are always on a lattice.
  subroutine square_setup(self, particles, physics, eos, parts, dx, share)
    class(square_patch_t), intent(inout) :: self
    type(particles_params_t), intent(in) :: particles
    type(physics_params_t), intent(in) :: physics
    type(eos_t), intent(in) :: eos
    type(particles_t), intent(inout) :: parts
    real(wp), intent(out) :: dx
    integer, intent(in) :: share(2)
    type(poisson_square_t) :: ps
    real(wp), allocatable :: f(:, :), xn(:), g(:)
    real(wp) :: x, y, p, xr(2)
    integer :: i, j, id, ng
    self%dim = 2
    self%rho0 = physics%rho0
    self%c0 = physics%c0
    associate(l => self%side, rate => self%rate, rho0 => self%rho0, ns => self%n_side)
    ns = max(4, nint(sqrt(real(particles%n, wp))))
    dx = l / ns
    self%dx = dx
    self%n_global = ns**2

    ! the initial pressure: Laplacian p0 = f, p0 = 0 on the edges
    ng = POISSON_DEFAULT_N
    allocate(f(ng, ng), xn(ng), g(ng))
    xn = poisson_square_nodes(l, ng)
    if (self%kind == SQ_ROTATION) then
      f = 2 * rho0 * rate**2                     ! (X3)
    else
      g = -rate * dfdx(xn, l)                    ! -V0 f'(x) = V0 (32/L^2) x f(x)
      do j = 1, ng
        do i = 1, ng
          f(i, j) = 2 * rho0 * g(i) * g(j)       ! (X4) 2 rho V0^2 f'(x) f'(y)
        end do
      end do
    end if
    call poisson_square_solve(l, f, ps)
    self%p_centre0 = poisson_square_eval(ps, 0.0_wp, 0.0_wp)
    self%p_quarter0 = poisson_square_eval(ps, 0.25_wp * l, 0.25_wp * l)
    self%ke_ref = rho0 * rate**2 * l**4 / 12
    self%time_unit = 1 / rate
    if (self%kind == SQ_VORTICAL) self%time_unit = l / rate

    ! the lattice; S maps particle (i, j) onto its partner
    call particles_allocate(parts, 2, ns**2)
    parts%n = ns**2
    allocate(self%partner(ns**2))
    if (self%kind == SQ_ROTATION) then
      self%sym = reshape([0.0_wp, 1.0_wp, -1.0_wp, 0.0_wp], [2, 2])   ! (x, y) -> (-y, x)
    else
      self%sym = reshape([0.0_wp, -1.0_wp, -1.0_wp, 0.0_wp], [2, 2])  ! (x, y) -> (-y, -x)
    end if
    do j = 1, ns
      do i = 1, ns
        id = i + (j - 1) * ns
        ! centred on the origin, so that -x and -y are lattice points exactly
        x = (i - 0.5_wp * (ns + 1)) * dx
        y = (j - 0.5_wp * (ns + 1)) * dx
        parts%x(:, id) = [x, y, 0.0_wp]
        parts%x0(:, id) = parts%x(:, id)
        if (self%kind == SQ_ROTATION) then
          parts%u(:, id) = [rate * y, -rate * x, 0.0_wp]
          self%partner(id) = (ns + 1 - j) + (i - 1) * ns
        else
          parts%u(:, id) = vortical_velocity(x, y, l, rate)
          self%partner(id) = (ns + 1 - j) + (ns - i) * ns
        end if
        ! the same value on every point of an orbit of S (p is symmetric
        ! but its series, summed at different points, not to the last bit)
        xr = orbit_representative(self%sym, [x, y])
        p = poisson_square_eval(ps, xr(1), xr(2))
        parts%p(id) = p
        parts%rho(id) = eos_density(eos, p)
        parts%m(id) = parts%rho(id) * dx**2
        parts%id(id) = id
      end do
    end do
    ! references at t = 0: every rank holds the whole lattice here
    associate(mp => parts%m(1:ns**2), xp => parts%x(:, 1:ns**2), up => parts%u(:, 1:ns**2))
      self%ke_start = 0.5_wp * sum(mp * (up(1, :)**2 + up(2, :)**2))
      self%lz_start = sum(mp * (xp(1, :) * up(2, :) - xp(2, :) * up(1, :)))
      self%mom_start = [sum(mp * up(1, :)), sum(mp * up(2, :)), 0.0_wp]
      self%topo0 = fluid_topology(xp(1:2, :), dx, CAVITY_AREA * l**2)
    end associate
    end associate
    ! the references above need the whole lattice (2D, at most some 10^5
    ! particles): the share is kept afterwards
    call keep_share(parts, share)
  end subroutine square_setup

  !> The point of the orbit {x, S x, S^2 x, ...} of x under the symmetry S
  !> (entries 0 and +-1: exact) that is largest in (x, then y).
  pure function orbit_representative(sym, x) result(r)
    real(wp), intent(in) :: sym(2, 2), x(2)
    real(wp) :: r(2), y(2)
    integer :: k
    r = x
    y = x
    do k = 1, 3
      y = [sym(1, 1) * y(1) + sym(1, 2) * y(2), sym(2, 1) * y(1) + sym(2, 2) * y(2)]
      if (y(1) > r(1) .or. (.not. y(1) < r(1) .and. y(2) > r(2))) r = y
    end do
  end function orbit_representative

  !> f'(s) for f(s) = exp(-(4 s/L)^2).
  elemental function dfdx(s, l) result(d)
    real(wp), intent(in) :: s, l
    real(wp) :: d
    d = -32 * s / l**2 * exp(-(4 * s / l)**2)
  end function dfdx

  !> The vortical patch's initial velocity (X4) at (x, y).
  pure function vortical_velocity(x, y, l, v0) result(u)
    real(wp), intent(in) :: x, y, l, v0
    real(wp) :: u(3)
    u = [v0 * (exp(-(4 * y / l)**2) - exp(-4.0_wp)), &
         -v0 * (exp(-(4 * x / l)**2) - exp(-4.0_wp)), 0.0_wp]
  end function vortical_velocity

  !> Its vorticity dv/dx - du/dy = -V0 (f'(x) + f'(y)), carried unchanged
  !> by each fluid particle in inviscid 2D flow.
  elemental function vortical_vorticity(x, y, l, v0) result(w)
    real(wp), intent(in) :: x, y, l, v0
    real(wp) :: w
    w = -v0 * (dfdx(x, l) + dfdx(y, l))
  end function vortical_vorticity

  !> Time-series columns (doc/reference/output.md).
  subroutine square_columns(self, names)
    class(square_patch_t), intent(in) :: self
    character(len=32), allocatable, intent(out) :: names(:)
    allocate(names(0))
    if (self%kind == SQ_ROTATION) &
      names = [character(len=32) :: 'p_centre', 'p_centre_initial', 'kinetic_energy_ref']
    names = [character(len=32) :: names, 'angular_momentum', 'symmetry_error', &
             'symmetry_error_max', 'fluid_components', 'fluid_holes', 'fluid_cavities', &
             'largest_hole_area', 'largest_component_share']
  end subroutine square_columns

  !> Values of the columns at time t:
  !>  - p_centre: pressure at A (Shepard interpolation); p_centre_initial:
  !>    p_A(0) of the Poisson solution; kinetic_energy_ref: rho omega^2 L^4/12;
  !>  - angular_momentum: Sum m (x v - y u);
  !>  - symmetry_error(_max): RMS (largest) over particles of
  !>    |x_partner - S x| / dx (module header);
  !>  - fluid_components, fluid_holes, fluid_cavities, largest_hole_area
  !>    (/ L^2), largest_component_share: topology of the fluid region
  !>    (flow_diagnostics: fluid_topology), evaluated at the first sample and
  !>    then at most every TOPOLOGY_INTERVAL time units (between, the last
  !>    values are repeated).
  !> The first time each count differs from its initial value is recorded
  !> for the summary.
  subroutine square_sample(self, env, t, parts, kernel, values)
    class(square_patch_t), intent(inout) :: self
    type(parallel_env_t), intent(in) :: env
    real(wp), intent(in) :: t
    type(particles_t), intent(in) :: parts
    type(kernel_t), intent(in) :: kernel
    real(wp), allocatable, intent(out) :: values(:)
    real(wp), allocatable :: xg(:, :)
    real(wp) :: lz, p_centre
    lz = angular_momentum(env, parts)
    call gather_by_id(env, parts, parts%x, 2, self%n_global, xg)
    call symmetry_error(xg, self%partner, self%sym, self%dx, self%sym_rms, self%sym_max)
    ! the topology costs more than the rest of a sample: at most every
    ! TOPOLOGY_INTERVAL time units (1/omega or L/V0)
    if (self%n_samples == 0 .or. t >= self%t_topo + TOPOLOGY_INTERVAL * self%time_unit) then
      self%topo = fluid_topology(xg, self%dx, CAVITY_AREA * self%side**2)
      self%t_topo = t
      if (self%t_split < 0 .and. self%topo%components /= self%topo0%components) self%t_split = t
      if (self%t_hole < 0 .and. self%topo%holes /= self%topo0%holes) self%t_hole = t
      if (self%t_cavity < 0 .and. self%topo%cavities /= self%topo0%cavities) self%t_cavity = t
    end if
    self%n_samples = self%n_samples + 1
    allocate(values(0))
    if (self%kind == SQ_ROTATION) then
      p_centre = probe_pressure(env, parts, kernel, [0.0_wp, 0.0_wp, 0.0_wp])
      call record(self, t, p_centre)
      values = [p_centre, self%p_centre0, self%ke_ref]
    end if
    values = [values, lz, self%sym_rms, self%sym_max, real(self%topo%components, wp), &
              real(self%topo%holes, wp), real(self%topo%cavities, wp), &
              self%topo%largest_hole / self%side**2, 0.001_wp * self%topo%largest_share]
  end subroutine square_sample

  !> Appends (t, p) to the centre-pressure history (a NaN, no particle near
  !> the centre, is left out).
  subroutine record(self, t, p)
    class(square_patch_t), intent(inout) :: self
    real(wp), intent(in) :: t, p
    real(wp), allocatable :: tmp(:)
    if (ieee_is_nan(p)) return
    if (.not. allocated(self%t_hist)) allocate(self%t_hist(1024), self%p_hist(1024))
    if (self%n_hist == size(self%t_hist)) then
      allocate(tmp(2 * self%n_hist))
      tmp(1:self%n_hist) = self%t_hist
      call move_alloc(tmp, self%t_hist)
      allocate(tmp(2 * self%n_hist))
      tmp(1:self%n_hist) = self%p_hist
      call move_alloc(tmp, self%p_hist)
    end if
    self%n_hist = self%n_hist + 1
    self%t_hist(self%n_hist) = t
    self%p_hist(self%n_hist) = p
  end subroutine record

  !> Snapshot fields: `vorticity`, the SPH curl of the velocity
  !> (solver_flow_fields), `vorticity_initial`, the
  !> vorticity each particle started with, which an inviscid 2D flow keeps
  !> (-2 omega for the rotating square), and `free_surface_lambda`, the
  !> free-surface indicator (E9: below 0.55 on the free surface).  Attribute time_scaled: t omega
  !> (rotation) or t V0/L (vortical); rotation also p_centre_initial,
  !> kinetic_energy_ref.
  subroutine square_fields(self, t, f)
    class(square_patch_t), intent(inout) :: self
    real(wp), intent(in) :: t
    type(case_fields_t), intent(out) :: f
    f%scalar_names = [character(len=32) :: 'vorticity', 'vorticity_initial', &
                      'free_surface_lambda']
    allocate(f%vector_names(0))
    if (self%kind == SQ_ROTATION) then
      f%attr_names = [character(len=32) :: 'time_scaled', 'p_centre_initial', &
                      'kinetic_energy_ref']
      f%attr_values = [t * self%rate, self%p_centre0, self%ke_ref]
    else
      f%attr_names = [character(len=32) :: 'time_scaled']
      f%attr_values = [t * self%rate / self%side]
    end if
  end subroutine square_fields

  !> The values of one of the fields square_fields names (none depends on t).
  subroutine square_field(self, t, name, parts, flow, v, s)
    class(square_patch_t), intent(inout) :: self
    real(wp), intent(in) :: t
    character(len=*), intent(in) :: name
    type(particles_t), intent(in) :: parts
    type(case_flow_t), intent(in) :: flow
    real(wp), allocatable, intent(out) :: v(:, :), s(:)
    integer :: n
    n = parts%n
    select case (name)
    case ('vorticity')
      s = flow%omega(1:n)
    case ('vorticity_initial')
      if (self%kind == SQ_ROTATION) then
        allocate(s(n))
        s = -2 * self%rate
      else
        s = vortical_vorticity(parts%x0(1, 1:n), parts%x0(2, 1:n), self%side, self%rate)
      end if
    case ('free_surface_lambda')
      s = flow%lambda(1:n)
    case default
      error stop 'square_field: no field ' // name
    end select
    if (.false.) v = reshape([t], [1, 1])   ! (the interface's v and t, unused here)
  end subroutine square_field

  !> The closing summary (rank 0 prints; collective).
  subroutine square_summary(self, env, unit, t, parts, kernel)
    class(square_patch_t), intent(inout) :: self
    type(parallel_env_t), intent(in) :: env
    integer, intent(in) :: unit
    real(wp), intent(in) :: t
    type(particles_t), intent(in) :: parts
    type(kernel_t), intent(in) :: kernel
    real(wp) :: ke, lz, mom(3), p_centre, f0, freq, scale_p, ts
    integer :: j, k
    character(len=:), allocatable :: tunit
    ke = kinetic_energy(env, parts)
    lz = angular_momentum(env, parts)
    mom = total_momentum(env, parts)
    p_centre = probe_pressure(env, parts, kernel, [0.0_wp, 0.0_wp, 0.0_wp])
    if (env%rank /= 0) return
    associate(l => self%side, rate => self%rate, rho0 => self%rho0)
    write(unit, '(a)') ''
    if (self%kind == SQ_ROTATION) then
      scale_p = rho0 * rate**2 * l**2
      f0 = self%c0 / (sqrt(2.0_wp) * l)
      write(unit, '(a,f8.4,a,i0,a,f8.5,a)') 'Rotating square at t omega = ', t * rate, &
        ' (', self%n_global, ' particles, dx = ', self%dx / l, ' L):'
      write(unit, '(2x,a,f10.6,a,f10.6,a)') 'pressure at A: initial ', &
        self%p_centre0 / scale_p, ' (series -0.147343), now (raw) ', p_centre / scale_p, &
        ' rho omega^2 L^2'
      ! the acoustic frequency of p_A in windows of 1/omega: the first one
      ! against the lowest mode of the square, the later ones as the patch
      ! deforms (its core shrinks and the frequency rises)
      freq = window_frequency(self, 0.0_wp, 1 / rate)
      if (freq > 0) then
        write(unit, '(2x,a,f8.4,a,f8.4,a,f7.2,a)') 'dominant frequency of raw p_A over ' // &
          '0 <= t omega <= 1: ', freq / rate, ' omega; lowest acoustic mode c0/(sqrt(2) L) = ', &
          f0 / rate, ' omega: ', 100 * (freq / f0 - 1), ' %'
      else
        write(unit, '(2x,a)') 'dominant frequency of raw p_A: too few samples (it needs ' // &
          '32 over 0 <= t omega <= 1: t_end >= 1/omega and a small output.probe_every)'
      end if
      k = 1
      do while (k < 16)
        if (.not. window_frequency(self, k / rate, (k + 1) / rate) > 0) exit
        k = k + 1
      end do
      if (k > 1) write(unit, '(2x,a,15f7.3)') 'later, in windows of 1/omega: ', &
        (window_frequency(self, j / rate, (j + 1) / rate) / rate, j = 1, k - 1)
      write(unit, '(2x,a,f8.5,a,f8.3,a)') 'kinetic energy / KE0 (rho omega^2 L^4/12) ', &
        ke / self%ke_ref, ', change since t = 0 ', 100 * (ke / self%ke_start - 1), ' %'
      write(unit, '(2x,a,es10.3)') 'angular momentum: relative change since t = 0 ', &
        (lz - self%lz_start) / abs(self%lz_start)
      write(unit, '(2x,a,es10.3,a,es10.3,a)') '4-fold symmetry error: RMS ', self%sym_rms, &
        ' dx, largest ', self%sym_max, ' dx'
    else
      scale_p = rho0 * rate**2
      write(unit, '(a,f8.4,a,i0,a,f8.5,a)') 'Vortical square at t V0/L = ', t * rate / l, &
        ' (', self%n_global, ' particles, dx = ', self%dx / l, ' L):'
      write(unit, '(2x,a,f10.6,a)') 'initial pressure p0(L/4, L/4) ', &
        self%p_quarter0 / scale_p, ' rho V0^2 (doc/theory/ X4: -0.229452)'
      write(unit, '(2x,a,f8.3,a)') 'kinetic energy change since t = 0 ', &
        100 * (ke / self%ke_start - 1), ' %'
      write(unit, '(2x,a,es10.3,a)') 'angular momentum change since t = 0 ', &
        (lz - self%lz_start) / (rho0 * rate * l**3), ' rho V0 L^3'
      write(unit, '(2x,a,2f10.6,a,2f10.6,a)') 'momentum ', mom(1:2) / (rho0 * rate * l**2), &
        ' rho V0 L^2 (initial ', self%mom_start(1:2) / (rho0 * rate * l**2), ')'
      write(unit, '(2x,a,es10.3,a,es10.3,a)') 'mirror-symmetry error: RMS ', self%sym_rms, &
        ' dx, largest ', self%sym_max, ' dx'
    end if
    write(unit, '(2x,a,i0,a,i0,a,i0,a,f6.1,a)') 'fluid region: ', self%topo%components, &
      ' component(s), ', self%topo%holes, ' hole(s), ', self%topo%cavities, &
      ' cavities; the largest component holds ', 0.1_wp * self%topo%largest_share, &
      ' % of the particles'
    if (self%kind == SQ_ROTATION) then
      tunit = 't omega'
      ts = rate
    else
      tunit = 't V0/L'
      ts = rate / l
    end if
    call print_first(unit, 'first cavity (reconnection of the free surface)', &
                     self%t_cavity, self%topo0%cavities, tunit, ts, self%kind == SQ_VORTICAL)
    call print_first(unit, 'first hole of any size', self%t_hole, self%topo0%holes, &
                     tunit, ts, .false.)
    call print_first(unit, 'first split of the fluid region', self%t_split, &
                     self%topo0%components, tunit, ts, .false.)
    end associate
  end subroutine square_summary

  !> Dominant frequency (dominant_frequency, above F_MIN_OVER_F0 f0)
  !> of the recorded p_A over t0 <= t <= t1; 0 unless the record covers the
  !> window with at least 32 samples.
  function window_frequency(self, t0, t1) result(freq)
    class(square_patch_t), intent(in) :: self
    real(wp), intent(in) :: t0, t1
    real(wp) :: freq, eps
    integer :: i0, i1
    freq = 0
    if (self%n_hist < 32) return
    eps = 1e-9_wp * (t1 - t0)
    if (self%t_hist(self%n_hist) < t1 - eps) return
    i0 = 1
    do while (self%t_hist(i0) < t0 - eps)
      i0 = i0 + 1
    end do
    i1 = i0
    do while (i1 < self%n_hist)
      if (self%t_hist(i1 + 1) > t1 + eps) exit
      i1 = i1 + 1
    end do
    if (i1 - i0 + 1 < 32) return
    freq = dominant_frequency(self%t_hist(i0:i1), self%p_hist(i0:i1), &
                              F_MIN_OVER_F0 * self%c0 / (sqrt(2.0_wp) * self%side))
  end function window_frequency

  !> "what at t omega = 1.2345" (time t_first scaled by ts, named tunit),
  !> with the paper's reconnection time when `paper`.
  subroutine print_first(unit, what, t_first, initial, tunit, ts, paper)
    integer, intent(in) :: unit, initial
    character(len=*), intent(in) :: what, tunit
    real(wp), intent(in) :: t_first, ts
    logical, intent(in) :: paper
    if (t_first < 0) then
      write(unit, '(2x,a,i0,a)') what // ': none (initial count ', initial, ')'
    else if (paper) then
      write(unit, '(2x,a,f8.4,a)') what // ' at ' // tunit // ' = ', t_first * ts, &
        ' (paper: about 1.2)'
    else
      write(unit, '(2x,a,f8.4)') what // ' at ' // tunit // ' = ', t_first * ts
    end if
  end subroutine print_first

end module case_square
