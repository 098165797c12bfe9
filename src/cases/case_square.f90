!> Prototype problems 2 and 3: the free-surface square patches of side L,
!> centred at the origin, on a square lattice of spacing dx.  What the two
!> cases share (the lattice, the initial pressure, the symmetry and topology
!> diagnostics) is square_patch_t's; each case's flow, extra columns and
!> summary are its own type's (case_square_rotation, case_square_vortical).
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
  use kinds, only: wp
  use case_base, only: case_t, case_fields_t, case_flow_t, keep_share, flow_field
  use input_params, only: particles_params_t, physics_params_t
  use kernels, only: kernel_t
  use particles, only: particles_t, particles_allocate
  use placement, only: place_square
  use eos, only: eos_t, eos_density
  use poisson_square, only: poisson_square_t, poisson_square_solve, poisson_square_eval, &
                            POISSON_DEFAULT_N
  use flow_diagnostics, only: angular_momentum, gather_by_id, symmetry_error, topology_t, &
                              fluid_topology
  use parallel_env, only: parallel_env_t
  implicit none
  private
  public :: square_patch_t, square_columns, square_sample, square_fields, square_topology_summary

  !> Smallest cavity, in units of L^2: the reconnecting free surface of the
  !> vortical patch encloses voids of 2.7 % of L^2 within 0.1 L/V0 (10,000
  !> particles), while gaps opened between particles under tension stay
  !> below 0.7 % (flow_diagnostics: fluid_topology).
  real(wp), parameter :: CAVITY_AREA = 0.01_wp
  !> Interval between evaluations of the topology, in units of the case's
  !> time_unit: 1 %.  Evaluated at every sample it cost a third of the run
  !> time at 10,000 particles (up to 10 ms a sample as the patch spreads
  !> over a larger box).
  real(wp), parameter :: TOPOLOGY_INTERVAL = 0.01_wp

  !> A square patch, its reference values and the running diagnostics.  A
  !> case says its flow (initial_velocity, pressure_source,
  !> initial_vorticity), its time unit and its symmetry `sym`.
  type, abstract, extends(case_t) :: square_patch_t
    real(wp) :: side = 1, rate = 1      !< L; omega (rotation) or V0 (vortical)
    real(wp) :: rho0 = 1, c0 = 10, dx = 1
    integer :: n_side = 0, n_global = 0
    integer, allocatable :: partner(:)  !< by id: the particle that started at S x0
    real(wp) :: sym(2, 2) = 0           !< the symmetry S (entries 0 and +-1)
    real(wp) :: p_centre0 = 0           !< p_A(0) from the Poisson solution
    real(wp) :: p_quarter0 = 0          !< p0(L/4, L/4) from the Poisson solution
    !> the initial kinetic energy, angular momentum, momentum and topology,
    !> from the whole lattice at setup (so that they stay those of t = 0
    !> in a run restarted later)
    real(wp) :: ke_start = 0, lz_start = 0, mom_start(3) = 0
    ! symmetry error and topology at the last sample, and the first changes
    real(wp) :: sym_rms = 0, sym_max = 0
    type(topology_t) :: topo, topo0
    real(wp) :: t_split = -1, t_hole = -1, t_cavity = -1
    real(wp) :: t_topo = 0              !< time of the last topology evaluation
    integer :: n_samples = 0
  contains
    procedure(velocity_i), deferred :: initial_velocity
    procedure(source_i), deferred :: pressure_source
    procedure(vorticity_i), deferred :: initial_vorticity
    procedure(time_unit_i), deferred :: time_unit
    procedure :: setup => square_setup
    procedure :: columns => square_columns
    procedure :: sample => square_sample
    procedure :: fields => square_fields
    procedure :: field => square_field
  end type square_patch_t

  abstract interface
    !> The initial velocity at (x, y).
    pure function velocity_i(self, x, y) result(u)
      import :: square_patch_t, wp
      class(square_patch_t), intent(in) :: self
      real(wp), intent(in) :: x, y
      real(wp) :: u(3)
    end function velocity_i

    !> The Laplacian of the initial pressure on the Poisson solver's grid of
    !> ng x ng nodes (poisson_square_nodes(side, ng) in each direction).
    function source_i(self, ng) result(f)
      import :: square_patch_t, wp
      class(square_patch_t), intent(in) :: self
      integer, intent(in) :: ng
      real(wp), allocatable :: f(:, :)
    end function source_i

    !> The initial vorticity at the initial positions x0(:, 1:n), which an
    !> inviscid 2D flow keeps on each particle.
    function vorticity_i(self, x0) result(w)
      import :: square_patch_t, wp
      class(square_patch_t), intent(in) :: self
      real(wp), intent(in) :: x0(:, :)
      real(wp), allocatable :: w(:)
    end function vorticity_i

    !> The case's time scale (1/omega, L/V0).
    pure function time_unit_i(self) result(t)
      import :: square_patch_t, wp
      class(square_patch_t), intent(in) :: self
      real(wp) :: t
    end function time_unit_i
  end interface

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
    real(wp), allocatable :: xl(:, :)
    real(wp) :: x, y, p, xr(2)
    integer :: i, j, id, s(2, 2)
    self%dim = 2
    self%rho0 = physics%rho0
    self%c0 = physics%c0
    associate(l => self%side, ns => self%n_side)
    call place_square(l, particles%n, xl, dx, ns)
    self%dx = dx
    self%n_global = ns**2

    ! the initial pressure: Laplacian p0 = f, p0 = 0 on the edges
    call poisson_square_solve(l, self%pressure_source(POISSON_DEFAULT_N), ps)
    self%p_centre0 = poisson_square_eval(ps, 0.0_wp, 0.0_wp)
    self%p_quarter0 = poisson_square_eval(ps, 0.25_wp * l, 0.25_wp * l)

    ! the lattice; S maps particle (i, j) onto its partner
    call particles_allocate(parts, 2, ns**2)
    parts%n = ns**2
    allocate(self%partner(ns**2))
    s = nint(self%sym)
    do j = 1, ns
      do i = 1, ns
        id = i + (j - 1) * ns
        x = xl(1, id)
        y = xl(2, id)
        parts%x(:, id) = xl(:, id)
        parts%x0(:, id) = parts%x(:, id)
        parts%u(:, id) = self%initial_velocity(x, y)
        self%partner(id) = image_id(s, i, j, ns)
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

  !> The id of the lattice point S x of point (i, j) of the n_side^2
  !> lattice: its index 2 i - n_side - 1 is proportional to x, so that S
  !> (entries 0 and +-1) maps indices exactly.
  pure integer function image_id(s, i, j, n_side)
    integer, intent(in) :: s(2, 2), i, j, n_side
    integer :: k(2)
    k = (matmul(s, [2 * i - n_side - 1, 2 * j - n_side - 1]) + n_side + 1) / 2
    image_id = k(1) + (k(2) - 1) * n_side
  end function image_id

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

  !> Time-series columns (doc/reference/output.md) both squares have.
  subroutine square_columns(self, names)
    class(square_patch_t), intent(in) :: self
    character(len=32), allocatable, intent(out) :: names(:)
    names = [character(len=32) :: 'angular_momentum', 'symmetry_error', &
             'symmetry_error_max', 'fluid_components', 'fluid_holes', 'fluid_cavities', &
             'largest_hole_area', 'largest_component_share']
  end subroutine square_columns

  !> Values of the columns at time t:
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
    real(wp) :: lz
    lz = angular_momentum(env, parts)
    call gather_by_id(env, parts, parts%x, 2, self%n_global, xg)
    call symmetry_error(xg, self%partner, self%sym, self%dx, self%sym_rms, self%sym_max)
    ! the topology costs more than the rest of a sample: at most every
    ! TOPOLOGY_INTERVAL time units
    if (self%n_samples == 0 .or. t >= self%t_topo + TOPOLOGY_INTERVAL * self%time_unit()) then
      self%topo = fluid_topology(xg, self%dx, CAVITY_AREA * self%side**2)
      self%t_topo = t
      if (self%t_split < 0 .and. self%topo%components /= self%topo0%components) self%t_split = t
      if (self%t_hole < 0 .and. self%topo%holes /= self%topo0%holes) self%t_hole = t
      if (self%t_cavity < 0 .and. self%topo%cavities /= self%topo0%cavities) self%t_cavity = t
    end if
    self%n_samples = self%n_samples + 1
    values = [lz, self%sym_rms, self%sym_max, real(self%topo%components, wp), &
              real(self%topo%holes, wp), real(self%topo%cavities, wp), &
              self%topo%largest_hole / self%side**2, 0.001_wp * self%topo%largest_share]
  end subroutine square_sample

  !> Snapshot fields: `vorticity`, the SPH curl of the velocity
  !> (solver_flow_fields), `vorticity_initial`, the vorticity each particle
  !> started with, which an inviscid 2D flow keeps, and
  !> `free_surface_lambda`, the free-surface indicator (E9: below 0.55 on
  !> the free surface); the attributes are the case's.
  subroutine square_fields(self, t, f)
    class(square_patch_t), intent(inout) :: self
    real(wp), intent(in) :: t
    type(case_fields_t), intent(out) :: f
    f%scalar_names = [character(len=32) :: 'vorticity', 'vorticity_initial', &
                      'free_surface_lambda']
    allocate(f%vector_names(0), f%attr_names(0), f%attr_values(0))
  end subroutine square_fields

  !> The values of one of the fields square_fields names (none depends on t).
  subroutine square_field(self, t, name, parts, flow, v, s)
    class(square_patch_t), intent(inout) :: self
    real(wp), intent(in) :: t
    character(len=*), intent(in) :: name
    type(particles_t), intent(in) :: parts
    type(case_flow_t), intent(in) :: flow
    real(wp), allocatable, intent(out) :: v(:, :), s(:)
    if (name == 'vorticity_initial') then
      s = self%initial_vorticity(parts%x0(:, 1:parts%n))
    else
      call flow_field(self, t, name, parts, flow, v, s)
    end if
  end subroutine square_field

  !> The closing summary's lines on the fluid region's topology, times
  !> scaled by ts and named tunit (e.g. 't omega'); with the paper's
  !> reconnection time when `paper` (rank 0).
  subroutine square_topology_summary(self, unit, tunit, ts, paper)
    class(square_patch_t), intent(in) :: self
    integer, intent(in) :: unit
    character(len=*), intent(in) :: tunit
    real(wp), intent(in) :: ts
    logical, intent(in) :: paper
    write(unit, '(2x,a,i0,a,i0,a,i0,a,f6.1,a)') 'fluid region: ', self%topo%components, &
      ' component(s), ', self%topo%holes, ' hole(s), ', self%topo%cavities, &
      ' cavities; the largest component holds ', 0.1_wp * self%topo%largest_share, &
      ' % of the particles'
    call print_first(unit, 'first cavity (reconnection of the free surface)', &
                     self%t_cavity, self%topo0%cavities, tunit, ts, paper)
    call print_first(unit, 'first hole of any size', self%t_hole, self%topo0%holes, &
                     tunit, ts, .false.)
    call print_first(unit, 'first split of the fluid region', self%t_split, &
                     self%topo0%components, tunit, ts, .false.)
  end subroutine square_topology_summary

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
