!> The generic namelist groups (doc/reference/input.md): one derived type per
!> group, each component at its default, and the group's visit, which
!> declares each variable once (input_visit): name, bounds, allowed words,
!> help and documentation.  A new variable is its component here and its
!> line in the visit (doc/developer/recipes.md).  The cases see the groups
!> they need.
module input_params
  use kinds, only: wp
  use input_visit, only: visit_t
  implicit none
  private
  public :: run_params_t, particles_params_t, physics_params_t, numerics_params_t, &
            output_params_t, parallel_params_t, NAME_LEN, DIR_LEN_MAX, MAX_PROBES
  public :: VISCOSITIES, DIFFUSIONS, PRESSURE_GRADIENTS

  integer, parameter :: NAME_LEN = 32      !< length of the word-valued variables
  integer, parameter :: DIR_LEN_MAX = 255  !< longest output.dir allowed
  integer, parameter :: MAX_PROBES = 16    !< size of output.probes(3, :)

  ! The allowed words of the word-valued variables.
  character(len=NAME_LEN), parameter :: PLACEMENTS(*) = &
    [character(len=NAME_LEN) :: 'rings', 'lattice', 'packed']
  character(len=NAME_LEN), parameter :: EOS_NAMES(*) = &
    [character(len=NAME_LEN) :: 'linear', 'tait']
  character(len=NAME_LEN), parameter :: KERNEL_NAMES(*) = &
    [character(len=NAME_LEN) :: 'wendland_c2', 'cubic_spline', 'gaussian']
  character(len=NAME_LEN), parameter :: INTEGRATORS(*) = &
    [character(len=NAME_LEN) :: 'rk4', 'pc2']
  character(len=NAME_LEN), parameter :: VISCOSITIES(*) = &
    [character(len=NAME_LEN) :: 'delta', 'monaghan', 'none']
  character(len=NAME_LEN), parameter :: DIFFUSIONS(*) = &
    [character(len=NAME_LEN) :: 'molteni', 'antuono', 'none']
  character(len=NAME_LEN), parameter :: PRESSURE_GRADIENTS(*) = &
    [character(len=NAME_LEN) :: 'standard', 'higher_order', 'renormalised']
  character(len=NAME_LEN), parameter :: RENORMALISE_WHEN(*) = &
    [character(len=NAME_LEN) :: 'stage', 'step']
  character(len=NAME_LEN), parameter :: DIVERGENCES(*) = &
    [character(len=NAME_LEN) :: 'standard', 'renormalised']
  character(len=NAME_LEN), parameter :: DECOMPOSITIONS(*) = &
    [character(len=NAME_LEN) :: 'auto', 'slab', 'metis', 'sfc']
  character(len=NAME_LEN), parameter :: BALANCES(*) = &
    [character(len=NAME_LEN) :: 'particles', 'pairs']
  character(len=NAME_LEN), parameter :: SYMMETRIES(*) = &
    [character(len=NAME_LEN) :: 'none', 'x', 'y', 'z', 'xy', 'xz', 'yz', 'xyz']

  !> &run: what to run and for how long.
  type :: run_params_t
    character(len=NAME_LEN) :: case_name = 'circle2d'   !< namelist name: case
    real(wp) :: t_end = 2.0_wp
    integer :: max_steps = 0                             !< 0: no limit
    real(wp) :: progress_interval = 5.0_wp               !< wall-clock seconds
    real(wp) :: wall_limit = 0                           !< wall-clock seconds, 0: none
    character(len=DIR_LEN_MAX + 1) :: restart = ''       !< snapshot to continue from
  contains
    procedure :: visit => run_visit
  end type run_params_t

  !> &particles: the initial layout.
  type :: particles_params_t
    integer :: n = 20000                                 !< approximate count
    character(len=NAME_LEN) :: placement = 'rings'
    real(wp) :: h_over_dx = 2.0_wp
    !> resolution scaling (config_scaled): 0 for none
    real(wp) :: n_ref = 0
    real(wp) :: h_exponent = 0
    integer :: pack_iterations = 300                     !< doc/theory/packing.md
    character(len=DIR_LEN_MAX + 1) :: from = ''          !< snapshot of a packed distribution
    character(len=NAME_LEN) :: symmetry = 'none'         !< mirror planes (mirrors)
  contains
    procedure :: visit => particles_visit
  end type particles_params_t

  !> &physics: the fluid.
  type :: physics_params_t
    real(wp) :: rho0 = 1.0_wp
    real(wp) :: c0 = 10.0_wp
    real(wp) :: c0_exponent = 0                          !< resolution scaling of c0
    character(len=NAME_LEN) :: eos = 'linear'
    real(wp) :: gamma = 7.0_wp
  contains
    procedure :: visit => physics_visit
  end type physics_params_t

  !> &numerics: discretisation and time stepping.
  type :: numerics_params_t
    character(len=NAME_LEN) :: kernel = 'wendland_c2'
    character(len=NAME_LEN) :: integrator = 'rk4'
    real(wp) :: cfl = 1.5_wp
    real(wp) :: cfl_force = 0.25_wp
    real(wp) :: cfl_visc = 0.125_wp
    character(len=NAME_LEN) :: viscosity = 'delta'
    real(wp) :: alpha = 0.01_wp
    real(wp) :: alpha_exponent = 0                       !< resolution scaling of alpha
    logical :: visc_reconstruction = .false.        !< (R1)
    character(len=NAME_LEN) :: diffusion = 'molteni'
    real(wp) :: delta = 0.1_wp
    real(wp) :: delta_exponent = 0                       !< resolution scaling of delta
    real(wp) :: skin = 0.3_wp                            !< in units of h
    logical :: tensile = .false.                         !< (E7) tensile instability control
    real(wp) :: tensile_eps = 0.4_wp                     !< measured best with wendland_c2, h = 2 dx
    integer :: tensile_n = 4
    !> (E4) or the higher-order form (H1, doc/theory/)
    character(len=NAME_LEN) :: pressure_gradient = 'standard'
    character(len=NAME_LEN) :: renormalise = 'stage'     !< first pass every stage, or step
    character(len=NAME_LEN) :: divergence = 'standard'   !< (E1), or renormalised (E3)
    logical :: shifting = .false.                        !< (E8) particle shifting
    logical :: binned_sums = .false.                     !< (B1) order-independent sums
  contains
    procedure :: visit => numerics_visit
  end type numerics_params_t

  !> &output: where and what to write.
  type :: output_params_t
    !> One character longer than allowed, so that a longer value is caught
    !> rather than silently cut.
    character(len=DIR_LEN_MAX + 1) :: dir = 'runs/circle2d'
    real(wp) :: dt = 0.1_wp
    integer :: probe_every = 1
    logical :: probe_quadratic = .false.                 !< (D5) instead of (D4)
    logical :: snapshots = .true.
    logical :: mirror = .false.                          !< whole-body snapshots
    integer :: n_probes = 1
    real(wp) :: probes(3, MAX_PROBES) = 0.0_wp           !< probe k at probes(:, k)
  contains
    procedure :: visit => output_visit
  end type output_params_t

  !> &parallel: the domain decomposition across MPI ranks.
  type :: parallel_params_t
    character(len=NAME_LEN) :: decomposition = 'auto'
    character(len=NAME_LEN) :: balance = 'particles'
    real(wp) :: imbalance_threshold = 0.1_wp
  contains
    procedure :: visit => parallel_visit
  end type parallel_params_t

contains

  ! The variables of each group in the order of the written files.

  subroutine run_visit(p, v, case_names)
    class(run_params_t), intent(inout) :: p
    type(visit_t), intent(inout) :: v
    character(len=*), intent(in) :: case_names(:)   !< the allowed values of case
    call v%group('run', 'what to run and for how long')
    call v%var('case', p%case_name, 'the test case; its own group sets its geometry', &
               words=case_names, &
               doc='the test case. Its own group, of the same name (`&circle2d` for ' // &
                   '`circle2d`), sets its geometry and initial flow')
    call v%var('t_end', p%t_end, 'end time (read as t A0 with the non-dimensional defaults)', &
               gt=0.0_wp)
    call v%var('max_steps', p%max_steps, 'stop after this many steps, 0 for no limit (a ' // &
               'final snapshot is written then)', ge=0)
    call v%var('progress_interval', p%progress_interval, 'wall-clock seconds between ' // &
               'progress lines', gt=0.0_wp)
    call v%var('wall_limit', p%wall_limit, 'wall-clock seconds the run may take; it stops ' // &
               'in time with a checkpoint (0: no limit)', ge=0.0_wp, &
               doc='wall-clock seconds the run may take (the job''s time limit less a ' // &
                   'margin for the start of mpirun): it stops early enough to write ' // &
                   '`checkpoint.h5` and exits with code 75; 0: no limit ' // &
                   '(doc/guide/restarts.md, "Stopping and continuing")')
    call v%var('restart', p%restart, 'snapshot or checkpoint to continue the run from, e.g. ' // &
               'runs/circle2d/snap_00010.h5 (empty: none)', &
               rule='empty, or an existing snapshot file of the same case', &
               doc='continue the run from this snapshot (`runs/circle2d/snap_00010.h5`) ' // &
                   'or checkpoint (`runs/circle2d/checkpoint.h5`), with any number of ranks; ' // &
                   'the snapshot numbering, XDMF index and time series in `output.dir` ' // &
                   'continue (doc/guide/restarts.md)')
  end subroutine run_visit

  subroutine particles_visit(p, v)
    class(particles_params_t), intent(inout) :: p
    type(visit_t), intent(inout) :: v
    call v%group('particles', 'the initial particle layout')
    call v%var('n', p%n, 'approximate number of particles; the spacing dx follows from it', &
               ge=50, le=2000000000)
    call v%var('placement', p%placement, 'rings: concentric (shells); lattice: a clipped ' // &
               'square (cubic); packed: relaxed (doc/theory/packing.md)', words=PLACEMENTS, &
               doc='`rings`: concentric rings (3D: shells) of spacing dx; `lattice`: ' // &
                   'square (cubic) lattice clipped to the body; `packed`: relaxed into a ' // &
                   'uniform, isotropic arrangement with a sharp surface (circle2d and ' // &
                   'ellipsoid3d only, [packing](../theory/packing.md); both input files use ' // &
                   'it). The square patches are always on a lattice of nint(sqrt(n)) x ' // &
                   'nint(sqrt(n)) particles and refuse `packed`')
    call v%var('h_over_dx', p%h_over_dx, 'smoothing length h over particle spacing dx', &
               ge=1.0_wp, le=8.0_wp, &
               doc='smoothing length h over particle spacing dx (at `n_ref` particles ' // &
                   'when `n_ref > 0`)')
    call v%var('n_ref', p%n_ref, 'resolution scaling: h_over_dx, c0, alpha, delta hold at ' // &
               'this count; 0: none (doc/studies/convergence.md)', ge=0.0_wp, &
               doc='resolution scaling (doc/theory/scaling.md, S1): `h_over_dx`, `c0`, ' // &
                   '`alpha` and `delta` hold as given at `n_ref` particles and scale with s ' // &
                   '= (n/n_ref)^(1/dim) = dx_ref/dx by their exponents; 0: no scaling. The ' // &
                   'run prints the values it uses; the echoed `input.nml` keeps the given ' // &
                   'ones')
    call v%var('h_exponent', p%h_exponent, 'with n_ref > 0: h/dx = h_over_dx ' // &
               '(n/n_ref)^(h_exponent/dim)', ge=0.0_wp, le=1.0_wp)
    call v%var('pack_iterations', p%pack_iterations, 'most iterations of the packing ' // &
               '(placement = ''packed'')', ge=1, le=100000, &
               doc='most iterations of the packing (`placement = ''packed''`); it stops ' // &
                   'earlier when every move is below 1e-4 dx')
    call v%var('from', p%from, 'snapshot whose initial positions are the packed particles ' // &
               '(empty: pack anew)', &
               rule='empty, or a snapshot of a packed run of the same case', &
               doc='reuse a packed distribution: the initial positions ' // &
                   '(`position_initial`) of any snapshot of a packed run of the same case, ' // &
                   'e.g. `runs/e1M/snap_00000.h5`, instead of packing again; dx follows from ' // &
                   'its particle count and `n` is not used, except with `n_ref > 0`, whose ' // &
                   'scaling takes h/dx, c0, alpha and delta from `n`: then `n` must be the ' // &
                   'file''s count (within 2 %)')
    call v%var('symmetry', p%symmetry, 'mirror planes x = 0, y = 0, z = 0 by their normals: ' // &
               'the run holds the part x_k >= 0 (doc/theory/mirrors.md)', words=SYMMETRIES, &
               doc='mirror planes through the centre, named by their normal axes ' // &
                   '(`''xyz''`: the three coordinate planes): the run holds the part of the ' // &
                   'body with x_k >= 0 on each, and the particles near a plane see their ' // &
                   'mirror images as neighbours, so that the part moves as the whole body ' // &
                   'would; a particle may lie on a plane, with its share of the mass (M5, ' // &
                   '[mirrors](../theory/mirrors.md)). `n` stays the whole body''s count; the ' // &
                   'run holds about n / 2^(planes). circle2d and ellipsoid3d only, with ' // &
                   '`lattice` or `packed` and without shifting')
  end subroutine particles_visit

  subroutine physics_visit(p, v)
    class(physics_params_t), intent(inout) :: p
    type(visit_t), intent(inout) :: v
    call v%group('physics', 'the fluid')
    call v%var('rho0', p%rho0, 'reference density', gt=0.0_wp)
    call v%var('c0', p%c0, 'speed of sound (at n_ref particles when scaled); at least 3 ' // &
               'times the largest initial speed of the case', gt=0.0_wp)
    call v%var('c0_exponent', p%c0_exponent, 'with particles.n_ref > 0: c0 = c0 ' // &
               '(n/n_ref)^(c0_exponent/dim)', ge=0.0_wp, le=2.0_wp)
    call v%var('eos', p%eos, 'equation of state: linear p = c0^2 (rho - rho0), tait p = ' // &
               'rho0 c0^2/gamma ((rho/rho0)^gamma - 1)', words=EOS_NAMES)
    call v%var('gamma', p%gamma, 'Tait exponent, used only by eos = ''tait''', ge=1.0_wp)
  end subroutine physics_visit

  subroutine numerics_visit(p, v)
    class(numerics_params_t), intent(inout) :: p
    type(visit_t), intent(inout) :: v
    call v%group('numerics', 'SPH discretisation and time stepping')
    call v%var('kernel', p%kernel, 'smoothing kernel (the Gaussian is truncated at 3h)', &
               words=KERNEL_NAMES)
    call v%var('integrator', p%integrator, 'rk4: classical 4th-order Runge-Kutta; pc2: ' // &
               '2-stage predictor-corrector', words=INTEGRATORS)
    call v%var('cfl', p%cfl, 'acoustic CFL number: dt <= cfl h / (c0 + Umax)', &
               gt=0.0_wp, le=3.0_wp)
    call v%var('cfl_force', p%cfl_force, 'force condition: dt <= cfl_force sqrt(h / max|a|)', &
               gt=0.0_wp)
    call v%var('cfl_visc', p%cfl_visc, 'viscous condition: dt <= cfl_visc h^2 / nu', gt=0.0_wp)
    call v%var('viscosity', p%viscosity, 'artificial viscosity: delta (delta-SPH form alpha ' // &
               'h c0 rho0 ...), monaghan, or none', words=VISCOSITIES)
    call v%var('alpha', p%alpha, 'artificial viscosity coefficient', ge=0.0_wp, le=1.0_wp)
    call v%var('visc_reconstruction', p%visc_reconstruction, 'viscosity on u_ji less its ' // &
               'linear part from the strain rates of i and j: none on a linear velocity ' // &
               'field', &
               doc='the viscosity acts on u_ji less its linear part, reconstructed from ' // &
                   'the renormalised strain rates of i and j ' // &
                   '([theory](../theory/equations.md) R1): zero on any linear velocity ' // &
                   'field, also at the free surface. Its sums join the first pass where L_i ' // &
                   'is computed, else one more pass')
    call v%var('alpha_exponent', p%alpha_exponent, 'with particles.n_ref > 0: alpha = alpha ' // &
               '(n/n_ref)^(alpha_exponent/dim)', ge=-2.0_wp, le=2.0_wp, &
               doc='with `particles.n_ref > 0`: alpha = `alpha` s^`alpha_exponent` (-1: ' // &
                   'alpha proportional to dx)')
    call v%var('diffusion', p%diffusion, 'density diffusion: molteni (delta-SPH without ' // &
               'gradient correction), antuono (with it), or none', words=DIFFUSIONS, &
               doc='density diffusion: delta-SPH without gradient correction ' // &
                   '(`molteni`), with the renormalised density gradient (`antuono`), or none')
    call v%var('delta', p%delta, 'density diffusion coefficient', ge=0.0_wp, le=1.0_wp)
    call v%var('delta_exponent', p%delta_exponent, 'with particles.n_ref > 0: delta = delta ' // &
               '(n/n_ref)^(delta_exponent/dim)', ge=-2.0_wp, le=2.0_wp)
    call v%var('skin', p%skin, 'smallest neighbour-list skin in units of h (widened when a ' // &
               'step needs more)', ge=0.0_wp, le=2.0_wp, &
               doc='smallest neighbour-list skin, in units of h; the list is rebuilt ' // &
                   'when an unlisted pair could come within the support during the next step ' // &
                   '(affine-motion test), and a rebuild widens the skin when one step''s ' // &
                   'motion needs more (see doc/studies/numerics.md)')
    call v%var('tensile', p%tensile, 'tensile instability control (Monaghan 2000): a ' // &
               'repulsion between particles under negative pressure', &
               doc='tensile instability control (Monaghan 2000, ' // &
                   '[theory](../theory/equations.md) E7): a repulsion -Sum_j m_j (R_i + R_j) ' // &
                   '(W_ij/W(dx))^n grad_i W_ij between particles under negative pressure. ' // &
                   'Needed by the square patches unless `shifting` keeps the particles ' // &
                   'regular (both square inputs use shifting, which measured better: ' // &
                   'doc/studies/numerics.md)')
    call v%var('tensile_eps', p%tensile_eps, 'tensile control strength: R_i = tensile_eps ' // &
               '|p_i|/rho_i^2 where p_i < 0', gt=0.0_wp, le=1.0_wp, &
               doc='R_i = tensile_eps |p_i|/rho_i^2 where p_i < 0, else 0. 0.4 is the ' // &
                   'best measured with `wendland_c2` at h = 2 dx: 0.2 (Monaghan''s value) ' // &
                   'lets the rotating square open voids, 0.5 and more compress its core ' // &
                   '(doc/studies/numerics.md)')
    call v%var('tensile_n', p%tensile_n, 'tensile control exponent n of (W_ij/W(dx))^n', &
               ge=1, le=8)
    call v%var('pressure_gradient', p%pressure_gradient, 'standard: (p_i + p_j); ' // &
               'higher_order: L_i (p_j - p_i) inside; renormalised: (p_i L_i + p_j L_j), ' // &
               'keeps energy', words=PRESSURE_GRADIENTS, &
               doc='`standard`: -(1/rho_i) Sum_j (p_i + p_j) grad_i W_ij V_j (E4), ' // &
                   'conservative; `higher_order` (H1): inside the fluid (lambda >= 0.9) 0.9 ' // &
                   'times -(1/rho_i) L_i Sum_j (p_j - p_i) grad_i W_ij V_j with p = 0 on ' // &
                   'free-surface particles (lambda < 0.55) plus 0.1 times E4; E4 for lambda ' // &
                   '<= 0.7, blended between. Not conservative; use it with `divergence = ' // &
                   '''renormalised''` (alone it lost 17 % of the rotating square''s kinetic ' // &
                   'energy); `renormalised` (H2): -(1/rho_i) Sum_j (p_i B_i + p_j B_j) ' // &
                   'grad_i W_ij V_j, B = L ramped to I for lambda from 0.55 to 0.4, the ' // &
                   'adjoint of the renormalised divergence (required; it uses B too): ' // &
                   'kinetic plus internal energy kept (doc/theory/)')
    call v%var('divergence', p%divergence, 'velocity divergence of the continuity equation: ' // &
               'standard, or renormalised (exact for linear u)', words=DIVERGENCES, &
               doc='velocity divergence of the continuity equation (E1): `standard` ' // &
                   'Sum_j V_j (u_j - u_i) . grad_i W_ij; `renormalised` Sum_j V_j (u_j - ' // &
                   'u_i) . (L_i grad_i W_ij), exact for linear velocity fields also at the ' // &
                   'free surface (L_i the renormalisation matrix, E3), 55 % more time a ' // &
                   'step. Momentum and angular momentum stay exactly conserved either way. ' // &
                   'The renormalised form cut the velocity error of circle2d and ellipsoid3d ' // &
                   '1.2 to 3.7 times (doc/studies/numerics.md)')
    call v%var('renormalise', p%renormalise, 'L_i and lambda_i of the renormalised ' // &
               'operators at every stage, or once a step (doc/studies/numerics.md)', &
               words=RENORMALISE_WHEN, &
               doc='when the renormalised operators compute L_i and lambda_i: at every ' // &
                   'RK4 stage, or once a step for all its stages (27 % less time a step on ' // &
                   'ellipsoid3d, errors unchanged: [numerics](../studies/numerics.md))')
    call v%var('shifting', p%shifting, 'particle shifting after each step (delta-plus-SPH, ' // &
               'Sun et al. 2017), none on the free surface', &
               doc='particle shifting after each step (delta-plus-SPH, Sun et al. 2017, ' // &
                   '[theory](../theory/equations.md) E8): dr_i = -CFL Ma (2h)^2 Sum_j [1 + ' // &
                   '0.2 (W_ij/W(dx))^4] grad_i W_ij V_j, none on the free surface (lambda < ' // &
                   '0.55), only tangential near it (lambda < 0.9). Positions only. Keeps the ' // &
                   'square patches in one piece without the tensile control (on in both ' // &
                   'square inputs); breaks the Lagrangian map (circle2d''s position error ' // &
                   'doubles): off by default')
    call v%var('binned_sums', p%binned_sums, 'pair sums independent of the partners'' order: ' // &
               'symmetric cases stay exactly symmetric', &
               doc='each pair term is rounded onto two fixed grids and summed exactly ' // &
                   '([theory](../theory/operators.md) B1), so that a particle''s sums do not ' // &
                   'depend on the order of its partners: the square patches, symmetric under ' // &
                   'a rotation or a mirror, then stay symmetric to the last bit. The ' // &
                   'standard operators only (with shifting, the tensile control and either ' // &
                   'viscosity); the general, scalar pair loop: 2.1 times the time of a step')
  end subroutine numerics_visit

  subroutine output_visit(p, v)
    class(output_params_t), intent(inout) :: p
    type(visit_t), intent(inout) :: v
    call v%group('output', 'run directory, snapshots, time series and pressure probes')
    call v%var('dir', p%dir, 'run directory', &
               rule='a non-empty path of at most 255 characters')
    call v%var('dt', p%dt, 'snapshot interval (a snapshot is always written at t = 0 and at ' // &
               'the end)', gt=0.0_wp)
    call v%var('probe_every', p%probe_every, 'a time-series row every this many steps', ge=1)
    call v%var('snapshots', p%snapshots, 'write HDF5 snapshots at all')
    call v%var('probe_quadratic', p%probe_quadratic, 'probes fit a quadratic to the ' // &
               'pressures in the support (exact for quadratic p) instead of the Shepard ' // &
               'mean', &
               doc='the probes fit a quadratic polynomial to the particle pressures ' // &
                   'within the kernel support by weighted least squares ' // &
                   '([theory](../theory/diagnostics.md) D5): exact for a quadratic pressure ' // &
                   'field, where the Shepard mean (D4) is off by O(h^2) (0.56 (h/R)^2 P at ' // &
                   'the centre of the circular patch)')
    call v%var('mirror', p%mirror, 'with particles.symmetry: snapshots hold the whole body ' // &
               '(the part and its reflections) instead of the part', &
               doc='with `particles.symmetry`: every snapshot holds the whole body, the ' // &
                   'part followed by its reflections (for ParaView), instead of the part ' // &
                   'alone; a restart from it reads the part ' // &
                   '([mirrors](../theory/mirrors.md)). Checkpoints always hold the part')
    call v%var('n_probes', p%n_probes, 'number of pressure probes', ge=0, le=MAX_PROBES)
    call v%var('probes', p%probes, 'probe k at probes(1:3,k); the third component is ' // &
               'ignored in 2D', count='n_probes', &
               rule='finite numbers', &
               doc='probe k is at `probes(1:3,k)`, k = 1..n_probes. The third component ' // &
                   'is ignored in 2D')
  end subroutine output_visit

  subroutine parallel_visit(p, v)
    class(parallel_params_t), intent(inout) :: p
    type(visit_t), intent(inout) :: v
    call v%group('parallel', 'the domain decomposition across MPI ranks ' // &
                 '(doc/developer/parallel.md)')
    call v%var('decomposition', p%decomposition, 'auto (slab up to 4 ranks, else sfc), ' // &
               'slab, METIS partition of cells, or sfc (pieces of a Hilbert curve)', &
               words=DECOMPOSITIONS, &
               doc='`auto`: `slab` on up to 4 ranks, `sfc` on more (the measured ' // &
                   'choice, doc/developer/parallel.md); `slab`: slabs along the longest axis ' // &
                   'of the particle cloud; `metis`: a METIS partition of the graph of ' // &
                   'occupied cells; `sfc`: the cells in the order of a Hilbert space-filling ' // &
                   'curve, cut into pieces of equal work')
    call v%var('balance', p%balance, 'work measure for the balance: particle count or ' // &
               'listed pairs', words=BALANCES, &
               doc='the work to balance: particle counts, or each particle''s number of ' // &
                   'listed pairs')
    call v%var('imbalance_threshold', p%imbalance_threshold, 're-balance when max/mean work ' // &
               'exceeds 1 + this', gt=0.0_wp, le=10.0_wp, &
               doc='re-balance (at a neighbour-list rebuild) when max/mean work exceeds ' // &
                   '1 + this')
  end subroutine parallel_visit

end module input_params
