!> The input of a run (doc/input.md): Fortran namelist groups, one derived
!> type per group, command-line overrides `group.variable=value` and a
!> validation pass.  Every error is one message naming the group, the
!> variable, the offending value and what is allowed.
!>
!> A file is first cut into groups by a small scanner that respects quotes and
!> `!` comments, so that unknown, repeated or unclosed groups and text outside
!> any group are caught (gfortran would skip them silently).  Each group body
!> is then cut into its `name = value` items and each item is read on its own
!> by an internal namelist read of `&group item /`: gfortran's iomsg does not
!> say which item failed, reading item by item does, and gives its line.
!> Overrides go through the same item reader.  No output here: config_load
!> returns ok and one message; every rank reads the same file the same way.
module config
  use, intrinsic :: ieee_arithmetic, only: ieee_is_finite
  use kinds, only: wp, i8
  use input_text, only: fail, closest, allowed_words, quoted_list, quoted, shown_value, &
                        unquoted, value_is_bare, base_name, word_at, name_end_at, lower, pad, &
                        int_str, num_str, real_list, real_str
  use namelist_scan, only: load_text, find_group_end, split_items
  implicit none
  private
  public :: config_t, run_params_t, particles_params_t, physics_params_t, &
            numerics_params_t, output_params_t, circle2d_params_t, ellipsoid3d_params_t, &
            square_rotation_params_t, square_vortical_params_t, parallel_params_t
  public :: config_load, config_write_defaults, config_echo, config_write_help, config_dim
  public :: case_t, CASES, NAME_LEN, DIR_LEN_MAX, MAX_PROBES

  integer, parameter :: NAME_LEN = 32      !< length of the word-valued variables
  integer, parameter :: DIR_LEN_MAX = 255  !< longest output.dir allowed
  integer, parameter :: MAX_PROBES = 16    !< size of output.probes(3, :)

  !> A test case: its name (the value of run.case and the name of its own
  !> namelist group) and its dimension.
  type :: case_t
    character(len=NAME_LEN) :: name
    integer :: dim
  end type case_t

  !> The cases.  To add one: a row here, its group (G_*, GROUPS, its params
  !> type, a read_* routine, rows in VARS) and its branch in case_speed.
  type(case_t), parameter :: CASES(*) = [case_t('circle2d', 2), case_t('ellipsoid3d', 3), &
                                         case_t('square_rotation', 2), &
                                         case_t('square_vortical', 2)]

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
    [character(len=NAME_LEN) :: 'standard', 'higher_order']
  character(len=NAME_LEN), parameter :: RENORMALISE_WHEN(*) = &
    [character(len=NAME_LEN) :: 'stage', 'step']
  character(len=NAME_LEN), parameter :: DIVERGENCES(*) = &
    [character(len=NAME_LEN) :: 'standard', 'renormalised']
  character(len=NAME_LEN), parameter :: DECOMPOSITIONS(*) = &
    [character(len=NAME_LEN) :: 'slab', 'metis']
  character(len=NAME_LEN), parameter :: BALANCES(*) = &
    [character(len=NAME_LEN) :: 'particles', 'pairs']

  !> &run: what to run and for how long.
  type :: run_params_t
    character(len=NAME_LEN) :: case_name = 'circle2d'   !< namelist name: case
    real(wp) :: t_end = 2.0_wp
    integer :: max_steps = 0                             !< 0: no limit
    real(wp) :: progress_interval = 5.0_wp               !< wall-clock seconds
    character(len=DIR_LEN_MAX + 1) :: restart = ''       !< snapshot to continue from
  end type run_params_t

  !> &particles: the initial layout.
  type :: particles_params_t
    integer :: n = 20000                                 !< approximate count
    character(len=NAME_LEN) :: placement = 'rings'
    real(wp) :: h_over_dx = 2.0_wp
    integer :: pack_iterations = 300                     !< doc/packing.md
    character(len=DIR_LEN_MAX + 1) :: from = ''          !< snapshot of a packed distribution
  end type particles_params_t

  !> &physics: the fluid.
  type :: physics_params_t
    real(wp) :: rho0 = 1.0_wp
    real(wp) :: c0 = 10.0_wp
    character(len=NAME_LEN) :: eos = 'linear'
    real(wp) :: gamma = 7.0_wp
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
    character(len=NAME_LEN) :: diffusion = 'molteni'
    real(wp) :: delta = 0.1_wp
    real(wp) :: skin = 0.3_wp                            !< in units of h
    logical :: tensile = .false.                         !< (E7) tensile instability control
    real(wp) :: tensile_eps = 0.4_wp                     !< measured best with wendland_c2, h = 2 dx
    integer :: tensile_n = 4
    !> (E4) or the higher-order form (H1, doc/theory.md)
    character(len=NAME_LEN) :: pressure_gradient = 'standard'
    character(len=NAME_LEN) :: renormalise = 'stage'     !< first pass every stage, or step
    character(len=NAME_LEN) :: divergence = 'standard'   !< (E1), or renormalised (E3)
    logical :: shifting = .false.                        !< (E8) particle shifting
  end type numerics_params_t

  !> &output: where and what to write.
  type :: output_params_t
    !> One character longer than allowed, so that a longer value is caught
    !> rather than silently cut.
    character(len=DIR_LEN_MAX + 1) :: dir = 'runs/circle2d'
    real(wp) :: dt = 0.1_wp
    integer :: probe_every = 1
    logical :: snapshots = .true.
    integer :: n_probes = 1
    real(wp) :: probes(3, MAX_PROBES) = 0.0_wp           !< probe k at probes(:, k)
  end type output_params_t

  !> &circle2d: the stretching circular patch (2D).
  type :: circle2d_params_t
    real(wp) :: radius = 1.0_wp
    real(wp) :: a0 = 1.0_wp
  end type circle2d_params_t

  !> &ellipsoid3d: the stretching sphere (3D).
  type :: ellipsoid3d_params_t
    real(wp) :: radius = 1.0_wp
    real(wp) :: a0 = 1.0_wp
    real(wp) :: rates(3) = [-1.0_wp, -1.0_wp, 2.0_wp]   !< in units of a0
    logical :: prepared = .false.                        !< (I1) compressible start
  end type ellipsoid3d_params_t

  !> &square_rotation: the rotating square patch (2D).
  type :: square_rotation_params_t
    real(wp) :: side = 1.0_wp
    real(wp) :: omega = 1.0_wp
  end type square_rotation_params_t

  !> &square_vortical: the vortical square patch (2D).
  type :: square_vortical_params_t
    real(wp) :: side = 1.0_wp
    real(wp) :: v0 = 1.0_wp
  end type square_vortical_params_t

  !> &parallel: the domain decomposition across MPI ranks.
  type :: parallel_params_t
    character(len=NAME_LEN) :: decomposition = 'slab'
    character(len=NAME_LEN) :: balance = 'particles'
    real(wp) :: imbalance_threshold = 0.1_wp
  end type parallel_params_t

  !> The whole configuration; every component has its default.
  type :: config_t
    type(run_params_t) :: run
    type(particles_params_t) :: particles
    type(physics_params_t) :: physics
    type(numerics_params_t) :: numerics
    type(output_params_t) :: output
    type(circle2d_params_t) :: circle2d
    type(ellipsoid3d_params_t) :: ellipsoid3d
    type(square_rotation_params_t) :: square_rotation
    type(square_vortical_params_t) :: square_vortical
    type(parallel_params_t) :: parallel
  end type config_t

  !> A namelist group: its name and a line saying what it is for.
  type :: group_t
    character(len=16) :: name
    character(len=100) :: help
  end type group_t

  integer, parameter :: G_RUN = 1, G_PARTICLES = 2, G_PHYSICS = 3, G_NUMERICS = 4, &
                        G_OUTPUT = 5, G_CIRCLE2D = 6, G_ELLIPSOID3D = 7, &
                        G_SQUARE_ROTATION = 8, G_SQUARE_VORTICAL = 9, G_PARALLEL = 10
  type(group_t), parameter :: GROUPS(*) = [ &
    group_t('run', 'what to run and for how long'), &
    group_t('particles', 'the initial particle layout'), &
    group_t('physics', 'the fluid'), &
    group_t('numerics', 'SPH discretisation and time stepping'), &
    group_t('output', 'run directory, snapshots, time series and pressure probes'), &
    group_t('circle2d', 'the stretching circular patch (2D), used when run.case = ''circle2d'''), &
    group_t('ellipsoid3d', 'the stretching sphere (3D), used when run.case = ''ellipsoid3d'''), &
    group_t('square_rotation', &
            'the rotating square patch (2D), used when run.case = ''square_rotation'''), &
    group_t('square_vortical', &
            'the vortical square patch (2D), used when run.case = ''square_vortical'''), &
    group_t('parallel', 'the domain decomposition across MPI ranks (doc/parallel.md)')]

  ! Variable types, bound rules and lists of allowed words for the table VARS.
  integer, parameter :: T_INT = 1, T_REAL = 2, T_STRING = 3, T_LOGICAL = 4
  integer, parameter :: LO_NONE = 0, LO_GT = 1, LO_GE = 2
  integer, parameter :: HI_NONE = 0, HI_LT = 1, HI_LE = 2
  integer, parameter :: CH_NONE = 0, CH_CASE = 1, CH_PLACEMENT = 2, CH_EOS = 3, &
                        CH_KERNEL = 4, CH_INTEGRATOR = 5, CH_VISCOSITY = 6, CH_DIFFUSION = 7, &
                        CH_DECOMPOSITION = 8, CH_BALANCE = 9, CH_PRESSURE_GRADIENT = 10, &
                        CH_DIVERGENCE = 11, CH_RENORMALISE = 12
  integer, parameter :: SCALAR(2) = [0, 0]

  !> A variable of a group: the one place that says what it is and what is
  !> allowed.  The range checks, the comments of the written files and the
  !> help all come from here.
  type :: var_t
    integer :: group             !< index into GROUPS
    character(len=20) :: name
    integer :: type              !< T_*
    integer :: dims(2)           !< array extents, SCALAR for a scalar
    integer :: lo_rule, hi_rule  !< LO_*, HI_*: lo < x, lo <= x, x < hi, x <= hi
    real(wp) :: lo, hi
    integer :: choices           !< CH_*: the list of allowed words, CH_NONE if free
    character(len=60) :: rule    !< what is allowed when no range or list says it
    character(len=110) :: help   !< what the variable is
  end type var_t

  type(var_t), parameter :: VARS(*) = [ &
    var_t(G_RUN, 'case', T_STRING, SCALAR, LO_NONE, HI_NONE, 0.0_wp, 0.0_wp, CH_CASE, '', &
          'the test case; its own group sets its geometry'), &
    var_t(G_RUN, 't_end', T_REAL, SCALAR, LO_GT, HI_NONE, 0.0_wp, 0.0_wp, CH_NONE, '', &
          'end time (read as t A0 with the non-dimensional defaults)'), &
    var_t(G_RUN, 'max_steps', T_INT, SCALAR, LO_GE, HI_NONE, 0.0_wp, 0.0_wp, CH_NONE, '', &
          'stop after this many steps, 0 for no limit (a final snapshot is written then)'), &
    var_t(G_RUN, 'progress_interval', T_REAL, SCALAR, LO_GT, HI_NONE, 0.0_wp, 0.0_wp, &
          CH_NONE, '', 'wall-clock seconds between progress lines'), &
    var_t(G_RUN, 'restart', T_STRING, SCALAR, LO_NONE, HI_NONE, 0.0_wp, 0.0_wp, CH_NONE, &
          'empty, or an existing snapshot file of the same case', &
          'snapshot to continue the run from, e.g. runs/circle2d/snap_00010.h5 (empty: none)'), &
    var_t(G_PARTICLES, 'n', T_INT, SCALAR, LO_GE, HI_LE, 50.0_wp, 2000000000.0_wp, CH_NONE, &
          '', 'approximate number of particles; the spacing dx follows from it'), &
    var_t(G_PARTICLES, 'placement', T_STRING, SCALAR, LO_NONE, HI_NONE, 0.0_wp, 0.0_wp, &
          CH_PLACEMENT, '', 'rings: concentric rings (shells); lattice: square (cubic) ' // &
          'lattice clipped; packed: relaxed (doc/packing.md)'), &
    var_t(G_PARTICLES, 'h_over_dx', T_REAL, SCALAR, LO_GE, HI_LE, 1.0_wp, 4.0_wp, CH_NONE, &
          '', 'smoothing length h over particle spacing dx'), &
    var_t(G_PARTICLES, 'pack_iterations', T_INT, SCALAR, LO_GE, HI_LE, 1.0_wp, 100000.0_wp, &
          CH_NONE, '', 'most iterations of the packing (placement = ''packed'')'), &
    var_t(G_PARTICLES, 'from', T_STRING, SCALAR, LO_NONE, HI_NONE, 0.0_wp, 0.0_wp, CH_NONE, &
          'empty, or a snapshot of a packed run of the same case', &
          'snapshot whose initial positions are the packed particles (empty: pack anew)'), &
    var_t(G_PHYSICS, 'rho0', T_REAL, SCALAR, LO_GT, HI_NONE, 0.0_wp, 0.0_wp, CH_NONE, '', &
          'reference density'), &
    var_t(G_PHYSICS, 'c0', T_REAL, SCALAR, LO_GT, HI_NONE, 0.0_wp, 0.0_wp, CH_NONE, '', &
          'speed of sound; at least 3 times the largest initial speed of the case'), &
    var_t(G_PHYSICS, 'eos', T_STRING, SCALAR, LO_NONE, HI_NONE, 0.0_wp, 0.0_wp, CH_EOS, '', &
          'equation of state: linear p = c0^2 (rho - rho0), ' // &
          'tait p = rho0 c0^2/gamma ((rho/rho0)^gamma - 1)'), &
    var_t(G_PHYSICS, 'gamma', T_REAL, SCALAR, LO_GE, HI_NONE, 1.0_wp, 0.0_wp, CH_NONE, '', &
          'Tait exponent, used only by eos = ''tait'''), &
    var_t(G_NUMERICS, 'kernel', T_STRING, SCALAR, LO_NONE, HI_NONE, 0.0_wp, 0.0_wp, &
          CH_KERNEL, '', 'smoothing kernel (the Gaussian is truncated at 3h)'), &
    var_t(G_NUMERICS, 'integrator', T_STRING, SCALAR, LO_NONE, HI_NONE, 0.0_wp, 0.0_wp, &
          CH_INTEGRATOR, '', 'rk4: classical 4th-order Runge-Kutta; ' // &
          'pc2: 2-stage predictor-corrector'), &
    var_t(G_NUMERICS, 'cfl', T_REAL, SCALAR, LO_GT, HI_LE, 0.0_wp, 3.0_wp, CH_NONE, '', &
          'acoustic CFL number: dt <= cfl h / (c0 + Umax)'), &
    var_t(G_NUMERICS, 'cfl_force', T_REAL, SCALAR, LO_GT, HI_NONE, 0.0_wp, 0.0_wp, CH_NONE, &
          '', 'force condition: dt <= cfl_force sqrt(h / max|a|)'), &
    var_t(G_NUMERICS, 'cfl_visc', T_REAL, SCALAR, LO_GT, HI_NONE, 0.0_wp, 0.0_wp, CH_NONE, &
          '', 'viscous condition: dt <= cfl_visc h^2 / nu'), &
    var_t(G_NUMERICS, 'viscosity', T_STRING, SCALAR, LO_NONE, HI_NONE, 0.0_wp, 0.0_wp, &
          CH_VISCOSITY, '', 'artificial viscosity: delta (delta-SPH form alpha h c0 rho0 ...), ' &
          // 'monaghan, or none'), &
    var_t(G_NUMERICS, 'alpha', T_REAL, SCALAR, LO_GE, HI_LE, 0.0_wp, 1.0_wp, CH_NONE, '', &
          'artificial viscosity coefficient'), &
    var_t(G_NUMERICS, 'diffusion', T_STRING, SCALAR, LO_NONE, HI_NONE, 0.0_wp, 0.0_wp, &
          CH_DIFFUSION, '', 'density diffusion: molteni (delta-SPH without gradient ' // &
          'correction), antuono (with it), or none'), &
    var_t(G_NUMERICS, 'delta', T_REAL, SCALAR, LO_GE, HI_LE, 0.0_wp, 1.0_wp, CH_NONE, '', &
          'density diffusion coefficient'), &
    var_t(G_NUMERICS, 'skin', T_REAL, SCALAR, LO_GE, HI_LE, 0.0_wp, 2.0_wp, CH_NONE, '', &
          'smallest neighbour-list skin in units of h (widened when a step needs more)'), &
    var_t(G_NUMERICS, 'tensile', T_LOGICAL, SCALAR, LO_NONE, HI_NONE, 0.0_wp, 0.0_wp, &
          CH_NONE, '', 'tensile instability control (Monaghan 2000): a repulsion ' // &
          'between particles under negative pressure'), &
    var_t(G_NUMERICS, 'tensile_eps', T_REAL, SCALAR, LO_GT, HI_LE, 0.0_wp, 1.0_wp, CH_NONE, &
          '', 'tensile control strength: R_i = tensile_eps |p_i|/rho_i^2 where p_i < 0'), &
    var_t(G_NUMERICS, 'tensile_n', T_INT, SCALAR, LO_GE, HI_LE, 1.0_wp, 8.0_wp, CH_NONE, &
          '', 'tensile control exponent n of (W_ij/W(dx))^n'), &
    var_t(G_NUMERICS, 'pressure_gradient', T_STRING, SCALAR, LO_NONE, HI_NONE, 0.0_wp, &
          0.0_wp, CH_PRESSURE_GRADIENT, '', 'standard: the (p_i + p_j) form; higher_order: ' // &
          'the renormalised (p_j - p_i) form away from the free surface'), &
    var_t(G_NUMERICS, 'divergence', T_STRING, SCALAR, LO_NONE, HI_NONE, 0.0_wp, 0.0_wp, &
          CH_DIVERGENCE, '', 'velocity divergence of the continuity equation: standard, ' // &
          'or renormalised (exact for linear u)'), &
    var_t(G_NUMERICS, 'renormalise', T_STRING, SCALAR, LO_NONE, HI_NONE, 0.0_wp, 0.0_wp, &
          CH_RENORMALISE, '', 'L_i and lambda_i of the renormalised operators at every ' // &
          'stage, or once a step (doc/numerics.md)'), &
    var_t(G_NUMERICS, 'shifting', T_LOGICAL, SCALAR, LO_NONE, HI_NONE, 0.0_wp, 0.0_wp, &
          CH_NONE, '', 'particle shifting after each step (delta-plus-SPH, Sun et al. ' // &
          '2017), none on the free surface'), &
    var_t(G_OUTPUT, 'dir', T_STRING, SCALAR, LO_NONE, HI_NONE, 0.0_wp, 0.0_wp, CH_NONE, &
          'a non-empty path of at most 255 characters', 'run directory'), &
    var_t(G_OUTPUT, 'dt', T_REAL, SCALAR, LO_GT, HI_NONE, 0.0_wp, 0.0_wp, CH_NONE, '', &
          'snapshot interval (a snapshot is always written at t = 0 and at the end)'), &
    var_t(G_OUTPUT, 'probe_every', T_INT, SCALAR, LO_GE, HI_NONE, 1.0_wp, 0.0_wp, CH_NONE, &
          '', 'a time-series row every this many steps'), &
    var_t(G_OUTPUT, 'snapshots', T_LOGICAL, SCALAR, LO_NONE, HI_NONE, 0.0_wp, 0.0_wp, &
          CH_NONE, '', 'write HDF5 snapshots at all'), &
    var_t(G_OUTPUT, 'n_probes', T_INT, SCALAR, LO_GE, HI_LE, 0.0_wp, real(MAX_PROBES, wp), &
          CH_NONE, '', 'number of pressure probes'), &
    var_t(G_OUTPUT, 'probes', T_REAL, [3, MAX_PROBES], LO_NONE, HI_NONE, 0.0_wp, 0.0_wp, &
          CH_NONE, 'finite numbers', &
          'probe k at probes(1:3,k); the third component is ignored in 2D'), &
    var_t(G_CIRCLE2D, 'radius', T_REAL, SCALAR, LO_GT, HI_NONE, 0.0_wp, 0.0_wp, CH_NONE, '', &
          'radius R of the initial disc'), &
    var_t(G_CIRCLE2D, 'a0', T_REAL, SCALAR, LO_GT, HI_NONE, 0.0_wp, 0.0_wp, CH_NONE, '', &
          'A0: initial velocity u = -A0 x, v = A0 y'), &
    var_t(G_ELLIPSOID3D, 'radius', T_REAL, SCALAR, LO_GT, HI_NONE, 0.0_wp, 0.0_wp, CH_NONE, &
          '', 'radius R of the initial sphere'), &
    var_t(G_ELLIPSOID3D, 'a0', T_REAL, SCALAR, LO_GT, HI_NONE, 0.0_wp, 0.0_wp, CH_NONE, '', &
          'A0: the unit of the rates'), &
    var_t(G_ELLIPSOID3D, 'rates', T_REAL, [3, 0], LO_NONE, HI_NONE, 0.0_wp, 0.0_wp, CH_NONE, &
          'summing to zero within 1e-12, not all zero', &
          'initial velocity u_k = rates(k) A0 x_k (rates in units of A0)'), &
    var_t(G_ELLIPSOID3D, 'prepared', T_LOGICAL, SCALAR, LO_NONE, HI_NONE, 0.0_wp, 0.0_wp, &
          CH_NONE, '', 'add the compressible part of the start (I1, doc/numerics.md): ' // &
          'no acoustic mode from P''(0)'), &
    var_t(G_SQUARE_ROTATION, 'side', T_REAL, SCALAR, LO_GT, HI_NONE, 0.0_wp, 0.0_wp, &
          CH_NONE, '', 'side L of the initial square, centred at the origin'), &
    var_t(G_SQUARE_ROTATION, 'omega', T_REAL, SCALAR, LO_GT, HI_NONE, 0.0_wp, 0.0_wp, &
          CH_NONE, '', 'omega: initial rigid rotation u = omega y, v = -omega x'), &
    var_t(G_SQUARE_VORTICAL, 'side', T_REAL, SCALAR, LO_GT, HI_NONE, 0.0_wp, 0.0_wp, &
          CH_NONE, '', 'side L of the initial square, centred at the origin'), &
    var_t(G_SQUARE_VORTICAL, 'v0', T_REAL, SCALAR, LO_GT, HI_NONE, 0.0_wp, 0.0_wp, CH_NONE, &
          '', 'V0: initial u = V0 (f(y) - e^-4), v = -V0 (f(x) - e^-4), f(s) = exp(-(4s/L)^2)'), &
    var_t(G_PARALLEL, 'decomposition', T_STRING, SCALAR, LO_NONE, HI_NONE, 0.0_wp, 0.0_wp, &
          CH_DECOMPOSITION, '', 'slabs along the longest axis, or a METIS partition of cells'), &
    var_t(G_PARALLEL, 'balance', T_STRING, SCALAR, LO_NONE, HI_NONE, 0.0_wp, 0.0_wp, &
          CH_BALANCE, '', 'work measure for the balance: particle count or listed pairs'), &
    var_t(G_PARALLEL, 'imbalance_threshold', T_REAL, SCALAR, LO_GT, HI_LE, 0.0_wp, 10.0_wp, &
          CH_NONE, '', 're-balance when max/mean work exceeds 1 + this')]

  real(wp), parameter :: RATES_SUM_TOL = 1.0e-12_wp   !< incompressibility of the rates
  real(wp), parameter :: MACH_FACTOR = 3.0_wp          !< c0 >= MACH_FACTOR * max initial speed
  real(wp), parameter :: RK4_CFL_MAX = 2.5_wp          !< stability limit of rk4 in cfl
  real(wp), parameter :: PC2_CFL_MAX = 1.0_wp          !< stability limit of pc2 in cfl

  ! How an item read ended.
  integer, parameter :: ITEM_OK = 0, ITEM_UNKNOWN = 1, ITEM_FAILED = 2

  !> Where a variable was last set: line of the file, or 0 for the command line.
  type :: origin_t
    character(len=40) :: key   !< 'group.name'
    integer :: line
  end type origin_t

contains

  ! ------------------------------------------------------------------------
  ! Public API
  ! ------------------------------------------------------------------------

  !> Reads the namelist file `path` (groups may be left out: defaults), then
  !> applies the overrides ("group.variable=value") in order, then checks
  !> every value and their consistency.  ok = .false. with one message in
  !> errmsg at the first error; errmsg = '' when ok.
  subroutine config_load(path, overrides, cfg, ok, errmsg)
    character(len=*), intent(in) :: path
    character(len=*), intent(in) :: overrides(:)
    type(config_t), intent(out) :: cfg
    logical, intent(out) :: ok
    character(len=:), allocatable, intent(out) :: errmsg
    type(origin_t), allocatable :: origins(:)
    integer :: k

    ok = .false.
    allocate(origins(0))
    call read_file(path, cfg, origins, errmsg)
    if (allocated(errmsg)) return
    do k = 1, size(overrides)
      call apply_override(overrides(k), cfg, origins, errmsg)
      if (allocated(errmsg)) return
    end do
    call normalise_words(cfg)
    call validate(cfg, path, origins, errmsg)
    if (allocated(errmsg)) return
    ok = .true.
    errmsg = ''
  end subroutine config_load

  !> Writes a complete namelist file with every group and variable at its
  !> default, each with a comment saying what it is and what is allowed.
  subroutine config_write_defaults(unit)
    integer, intent(in) :: unit
    call write_config(config_t(), unit, [character(len=80) :: &
      'sph input file: every group and variable at its default (sph --defaults).', &
      'Fortran namelist syntax: strings in quotes, ''!'' starts a comment; any', &
      'group or variable may be left out, and any variable can be set on the', &
      'command line after the file as group.variable=value (doc/input.md).'])
  end subroutine config_write_defaults

  !> Writes the effective configuration as a namelist file (it reads back to
  !> the same configuration), for the run directory.
  subroutine config_echo(cfg, unit)
    type(config_t), intent(in) :: cfg
    integer, intent(in) :: unit
    call write_config(cfg, unit, [character(len=80) :: &
      'sph: the effective configuration of this run (input file and command-line', &
      'overrides); run it again with: sph <this file>'])
  end subroutine config_echo

  !> Writes a short reference of the input for `sph --help`: the syntax of
  !> the file and of the overrides, then every variable as group.variable =
  !> default with what is allowed.
  subroutine config_write_help(unit)
    integer, intent(in) :: unit
    type(config_t) :: defaults
    character(len=:), allocatable :: text, lhs
    real(wp) :: x
    integer :: k
    write(unit, '(a)') 'Input: a Fortran namelist file (doc/input.md) with the groups below;', &
      'any group or variable may be left out (defaults).  After the file, any number', &
      'of overrides group.variable=value, applied in order, e.g. numerics.cfl=0.5', &
      'output.dir=runs/x output.probes(1,2)=0.25 ellipsoid3d.rates=1,1,-2.', &
      'sph --defaults writes a complete input file with every default.', '', &
      'group.variable = default    allowed values'
    do k = 1, size(VARS)
      lhs = trim(GROUPS(VARS(k)%group)%name) // '.' // trim(VARS(k)%name)
      if (VARS(k)%dims(2) > 0) lhs = lhs // '(1:3,k)'
      call get_value(defaults, VARS(k), text, x)
      if (VARS(k)%dims(2) > 0) text = real_list(defaults%output%probes(:, 1))
      write(unit, '(a)') '  ' // pad(lhs // ' = ' // text, 40) // ' ' // allowed_text(VARS(k))
    end do
  end subroutine config_write_help

  !> The dimension of the selected case (2 or 3), 0 if the case is unknown.
  integer function config_dim(cfg)
    type(config_t), intent(in) :: cfg
    integer :: k
    config_dim = 0
    do k = 1, size(CASES)
      if (CASES(k)%name == cfg%run%case_name) config_dim = CASES(k)%dim
    end do
  end function config_dim

  ! ------------------------------------------------------------------------
  ! Reading the file
  ! ------------------------------------------------------------------------

  !> Reads the groups of the file into cfg, recording where each variable
  !> was set.  err is allocated (with the message) on the first error.
  subroutine read_file(path, cfg, origins, err)
    character(len=*), intent(in) :: path
    type(config_t), intent(inout) :: cfg
    type(origin_t), allocatable, intent(inout) :: origins(:)
    character(len=:), allocatable, intent(inout) :: err
    character(len=:), allocatable :: buf
    integer, allocatable :: line_of(:)
    integer :: pos, name_end, term, term_len, g, first_line(size(GROUPS))
    character(len=:), allocatable :: name

    call load_text(path, buf, line_of, err)
    if (allocated(err)) return
    first_line = 0
    pos = 1
    do
      ! Outside a group only blanks and '&name' may appear.
      do while (pos <= len(buf))
        if (buf(pos:pos) /= ' ') exit
        pos = pos + 1
      end do
      if (pos > len(buf)) exit
      if (buf(pos:pos) /= '&') then
        call fail(err, path, 'text ''' // word_at(buf, pos) // ''' outside any namelist group', &
                  line_of(pos), ': a group is written &name ... / and a value containing ' // &
                  '''/'' must be in quotes')
        return
      end if
      name_end = name_end_at(buf, pos + 1)
      name = lower(buf(pos + 1:name_end))
      if (len(name) == 0) then
        call fail(err, path, '''&'' without a group name', line_of(pos), '')
        return
      end if
      g = group_index(name)
      if (g == 0) then
        call fail(err, path, 'unknown namelist group &' // name, line_of(pos), &
                  unknown_group_hint(name))
        return
      end if
      if (first_line(g) > 0) then
        call fail(err, path, '&' // name // ' appears twice', line_of(pos), &
                  ': it already appeared on line ' // int_str(first_line(g)) // &
                  '; give each group once')
        return
      end if
      first_line(g) = line_of(pos)
      call find_group_end(buf, name_end + 1, term, term_len)
      if (term == 0) then
        call fail(err, path, '&' // name // ' is not closed', line_of(pos), &
                  ': end it with ''/''')
        return
      else if (term_len == 0) then
        call fail(err, path, '&' // name // ' is not closed', line_of(pos), &
                  ': end it with ''/'' before &' // lower(word_at(buf, term + 1)) // &
                  ' on line ' // int_str(line_of(term)))
        return
      end if
      call read_group_body(g, buf(name_end + 1:term - 1), line_of(name_end + 1:term - 1), &
                           path, cfg, origins, err)
      if (allocated(err)) return
      pos = term + term_len
    end do
  end subroutine read_file

  !> Reads the items of one group body (from the file) into cfg.
  subroutine read_group_body(g, body, line_of, path, cfg, origins, err)
    integer, intent(in) :: g
    character(len=*), intent(in) :: body
    integer, intent(in) :: line_of(:)
    character(len=*), intent(in) :: path
    type(config_t), intent(inout) :: cfg
    type(origin_t), allocatable, intent(inout) :: origins(:)
    character(len=:), allocatable, intent(inout) :: err
    integer, allocatable :: starts(:), eqs(:)
    character(len=40), allocatable :: plain(:)
    integer, allocatable :: plain_line(:)
    character(len=:), allocatable :: name, value, reason, hint, head
    integer :: i, last, status, line, k

    call split_items(body, starts, eqs)
    last = len(body)
    if (size(starts) > 0) last = starts(1) - 1
    if (len_trim(body(1:last)) > 0) then
      call fail(err, path, '&' // trim(GROUPS(g)%name) // ': ''' // trim(adjustl(body(1:last))) &
                // ''' is not of the form name = value', line_of(max(1, verify(body, ' '))), '')
      return
    end if
    allocate(plain(0), plain_line(0))
    do i = 1, size(starts)
      last = len(body)
      if (i < size(starts)) last = starts(i + 1) - 1
      name = lower(trim(body(starts(i):eqs(i) - 1)))
      value = body(eqs(i) + 1:last)
      line = line_of(starts(i))
      ! A scalar or whole array set twice in one group is a slip, not intent.
      if (index(name, '(') == 0) then
        do k = size(plain), 1, -1
          if (plain(k) == name) exit
        end do
        if (k > 0) then
          call fail(err, path, '&' // trim(GROUPS(g)%name) // ' ' // name // ' is set twice', &
                    line, ': it was already set on line ' // int_str(plain_line(k)) // &
                    '; keep one')
          return
        end if
        plain = [character(len=40) :: plain, name]
        plain_line = [plain_line, line]
      end if
      call read_item(g, name, value, cfg, status, reason, hint)
      if (status == ITEM_UNKNOWN) then
        call fail(err, path, reason, line, hint)
        return
      else if (status == ITEM_FAILED) then
        head = '&' // trim(GROUPS(g)%name) // ' ' // name
        if (len(shown_value(value)) > 0) head = head // ' = ' // shown_value(value)
        call fail(err, path, head // ' ' // reason, line, hint)
        return
      end if
      call set_origin(origins, trim(GROUPS(g)%name) // '.' // base_name(name), line)
    end do
  end subroutine read_group_body

  ! ------------------------------------------------------------------------
  ! Overrides
  ! ------------------------------------------------------------------------

  !> Applies one "group.variable=value" to cfg.  A string value without
  !> quotes gets them, so that output.dir=runs/x works ('/' would end the
  !> namelist input otherwise).
  subroutine apply_override(text, cfg, origins, err)
    character(len=*), intent(in) :: text
    type(config_t), intent(inout) :: cfg
    type(origin_t), allocatable, intent(inout) :: origins(:)
    character(len=:), allocatable, intent(inout) :: err
    character(len=*), parameter :: ORIGIN = 'command line'
    character(len=:), allocatable :: ov, lhs, gname, name, value, reason, hint
    integer, allocatable :: starts(:), eqs(:)
    integer :: eq, dot, g, v, status

    ov = trim(adjustl(text))
    eq = index(ov, '=')
    if (eq == 0) then
      call fail(err, ORIGIN, 'override ''' // ov // ''' has no ''=value''', 0, &
                ': write group.variable=value, e.g. numerics.cfl=0.5')
      return
    end if
    lhs = lower(trim(ov(1:eq - 1)))
    value = trim(adjustl(ov(eq + 1:)))
    dot = index(lhs, '.')
    if (dot == 0) then
      call fail(err, ORIGIN, 'override ''' // ov // ''' does not name a group', 0, &
                ': write group.variable=value' // group_guess(base_name(lhs), ov(eq:)))
      return
    end if
    gname = trim(adjustl(lhs(1:dot - 1)))
    name = trim(adjustl(lhs(dot + 1:)))
    g = group_index(gname)
    if (g == 0) then
      call fail(err, ORIGIN, 'override ''' // ov // ''': unknown namelist group &' // gname, 0, &
                unknown_group_hint(gname))
      return
    end if
    v = var_index(g, base_name(name))
    if (v > 0) then
      if (VARS(v)%type == T_STRING .and. len(value) > 0) then
        if (value(1:1) /= '''' .and. value(1:1) /= '"') value = quoted(value)
      end if
    end if
    ! One override sets one variable: "numerics.cfl=0.5 kernel='x'" is a slip.
    call split_items(name // '=' // value, starts, eqs)
    if (size(starts) > 1) then
      call fail(err, ORIGIN, 'override ''' // ov // ''' sets more than one variable', 0, &
                ': give one group.variable=value per override')
      return
    end if
    call read_item(g, name, value, cfg, status, reason, hint)
    if (status == ITEM_UNKNOWN) then
      call fail(err, ORIGIN, 'override ''' // ov // ''': ' // reason, 0, hint)
      return
    else if (status == ITEM_FAILED) then
      call fail(err, ORIGIN, ov // ' ' // reason, 0, hint)
      return
    end if
    call set_origin(origins, gname // '.' // base_name(name), 0)
  end subroutine apply_override

  !> For an override without a group: the group.variable it probably meant.
  function group_guess(name, rest) result(s)
    character(len=*), intent(in) :: name, rest
    character(len=:), allocatable :: s
    integer :: k, found
    s = ''
    found = 0
    do k = 1, size(VARS)
      if (VARS(k)%name /= name) cycle
      if (found > 0) return   ! in several groups: no single guess
      found = k
    end do
    if (found > 0) s = ', e.g. ' // trim(GROUPS(VARS(found)%group)%name) // '.' // name // rest
  end function group_guess

  ! ------------------------------------------------------------------------
  ! Reading one item
  ! ------------------------------------------------------------------------

  !> Reads `name = value` of group g into c through an internal namelist
  !> read.  On failure, status /= ITEM_OK, reason says what went wrong (for
  !> ITEM_UNKNOWN, the whole clause "&g has no variable 'x'") and hint what
  !> to do (starting with ':' or ';', or empty).
  subroutine read_item(g, name, value, c, status, reason, hint)
    integer, intent(in) :: g
    character(len=*), intent(in) :: name, value
    type(config_t), intent(inout) :: c
    integer, intent(out) :: status
    character(len=:), allocatable, intent(out) :: reason, hint
    character(len=*), parameter :: NEUTRAL(4) = ['0  ', '0  ', "'' ", 'F  ']
    character(len=:), allocatable :: base, group
    type(config_t) :: trial
    character(len=512) :: iomsg
    real(wp) :: x
    integer :: v, ios

    group = trim(GROUPS(g)%name)
    base = base_name(name)
    hint = ''
    reason = ''
    status = ITEM_FAILED
    v = var_index(g, base)
    if (v == 0) then
      status = ITEM_UNKNOWN
      reason = '&' // group // ' has no variable ''' // trim(name) // ''''
      hint = unknown_var_hint(g, base)
      return
    end if
    if (len_trim(shown_value(value)) == 0) then
      reason = 'has no value'
      hint = ': give one, or leave the variable out for its default (' // &
             default_text(VARS(v)) // ')'
      return
    end if
    ! '/' ends namelist input: numerics.cfl=1/2 would silently read 1.
    if (scan(unquoted(value), '/') > 0) then
      reason = 'cannot be read as ' // type_text(VARS(v))
      hint = ': a ''/'' outside quotes ends the namelist input'
      return
    end if
    call read_group(g, '&' // group // ' ' // name // ' = ' // value // ' /', c, ios, iomsg)
    if (ios == 0) then
      status = ITEM_OK
      return
    end if
    ! Is the index at fault rather than the value?  Try a value that fits.
    if (index(name, '(') > 0) then
      trial = c
      call read_group(g, '&' // group // ' ' // name // ' = ' // trim(NEUTRAL(VARS(v)%type)) &
                      // ' /', trial, ios, iomsg)
      if (ios /= 0) then
        if (VARS(v)%dims(1) == 0) then
          reason = 'has an index, but ' // base // ' is not an array'
        else
          reason = 'has an index outside ' // base // shape_text(VARS(v))
        end if
        return
      end if
    end if
    reason = 'cannot be read as ' // type_text(VARS(v))
    select case (VARS(v)%type)
    case (T_INT)
      read(value, *, iostat=ios) x
      if (verify(shown_value(value), '+-0123456789') == 0) then
        hint = ': it is too large'
        if (VARS(v)%hi_rule /= HI_NONE) hint = hint // '; allowed ' // allowed_text(VARS(v))
      else if (ios == 0) then
        hint = ': write a whole number'
        if (ieee_is_finite(x)) hint = hint // ', e.g. ' // num_str(anint(x))
      end if
    case (T_STRING)
      if (value_is_bare(value)) then
        hint = ': put it in quotes, e.g. ' // base // ' = ' // quoted(shown_value(value))
      else
        hint = ': give one string in quotes'
      end if
    case (T_LOGICAL)
      hint = ': write .true. or .false.'
    end select
  end subroutine read_item

  !> Reads namelist text '&group ... /' into the component of c for group g.
  subroutine read_group(g, text, c, ios, iomsg)
    integer, intent(in) :: g
    character(len=*), intent(in) :: text
    type(config_t), intent(inout) :: c
    integer, intent(out) :: ios
    character(len=*), intent(inout) :: iomsg
    select case (g)
    case (G_RUN)
      call read_run(text, c%run, ios, iomsg)
    case (G_PARTICLES)
      call read_particles(text, c%particles, ios, iomsg)
    case (G_PHYSICS)
      call read_physics(text, c%physics, ios, iomsg)
    case (G_NUMERICS)
      call read_numerics(text, c%numerics, ios, iomsg)
    case (G_OUTPUT)
      call read_output(text, c%output, ios, iomsg)
    case (G_CIRCLE2D)
      call read_circle2d(text, c%circle2d, ios, iomsg)
    case (G_ELLIPSOID3D)
      call read_ellipsoid3d(text, c%ellipsoid3d, ios, iomsg)
    case (G_SQUARE_ROTATION)
      call read_square_rotation(text, c%square_rotation, ios, iomsg)
    case (G_SQUARE_VORTICAL)
      call read_square_vortical(text, c%square_vortical, ios, iomsg)
    case (G_PARALLEL)
      call read_parallel(text, c%parallel, ios, iomsg)
    case default
      ios = 1
    end select
  end subroutine read_group

  ! One reader per group: the namelist needs local variables with the names
  ! the user writes.  Each starts from the current values, so an item
  ! changes only its own variable, and stores nothing if the read fails.

  subroutine read_run(text, p, ios, iomsg)
    character(len=*), intent(in) :: text
    type(run_params_t), intent(inout) :: p
    integer, intent(out) :: ios
    character(len=*), intent(inout) :: iomsg
    character(len=NAME_LEN) :: case
    character(len=4 * DIR_LEN_MAX) :: restart   ! wider than p%restart, as for output.dir
    real(wp) :: t_end, progress_interval
    integer :: max_steps
    namelist /run/ case, t_end, max_steps, progress_interval, restart
    case = p%case_name
    t_end = p%t_end
    max_steps = p%max_steps
    progress_interval = p%progress_interval
    restart = p%restart
    read(text, nml=run, iostat=ios, iomsg=iomsg)
    if (ios /= 0) return
    p%case_name = case
    p%t_end = t_end
    p%max_steps = max_steps
    p%progress_interval = progress_interval
    p%restart = restart(1:len(p%restart))
  end subroutine read_run

  subroutine read_particles(text, p, ios, iomsg)
    character(len=*), intent(in) :: text
    type(particles_params_t), intent(inout) :: p
    integer, intent(out) :: ios
    character(len=*), intent(inout) :: iomsg
    integer :: n
    character(len=NAME_LEN) :: placement
    character(len=4 * DIR_LEN_MAX) :: from   ! wider than p%from, as for output.dir
    real(wp) :: h_over_dx
    integer :: pack_iterations
    namelist /particles/ n, placement, h_over_dx, pack_iterations, from
    n = p%n
    placement = p%placement
    h_over_dx = p%h_over_dx
    pack_iterations = p%pack_iterations
    from = p%from
    read(text, nml=particles, iostat=ios, iomsg=iomsg)
    if (ios /= 0) return
    p%n = n
    p%placement = placement
    p%h_over_dx = h_over_dx
    p%pack_iterations = pack_iterations
    p%from = from(1:len(p%from))
  end subroutine read_particles

  subroutine read_physics(text, p, ios, iomsg)
    character(len=*), intent(in) :: text
    type(physics_params_t), intent(inout) :: p
    integer, intent(out) :: ios
    character(len=*), intent(inout) :: iomsg
    real(wp) :: rho0, c0, gamma
    character(len=NAME_LEN) :: eos
    namelist /physics/ rho0, c0, eos, gamma
    rho0 = p%rho0
    c0 = p%c0
    eos = p%eos
    gamma = p%gamma
    read(text, nml=physics, iostat=ios, iomsg=iomsg)
    if (ios /= 0) return
    p%rho0 = rho0
    p%c0 = c0
    p%eos = eos
    p%gamma = gamma
  end subroutine read_physics

  subroutine read_numerics(text, p, ios, iomsg)
    character(len=*), intent(in) :: text
    type(numerics_params_t), intent(inout) :: p
    integer, intent(out) :: ios
    character(len=*), intent(inout) :: iomsg
    character(len=NAME_LEN) :: kernel, integrator, viscosity, diffusion
    character(len=NAME_LEN) :: pressure_gradient, divergence, renormalise
    real(wp) :: cfl, cfl_force, cfl_visc, alpha, delta, skin, tensile_eps
    logical :: tensile, shifting
    integer :: tensile_n
    namelist /numerics/ kernel, integrator, cfl, cfl_force, cfl_visc, viscosity, alpha, &
                        diffusion, delta, skin, tensile, tensile_eps, tensile_n, &
                        pressure_gradient, divergence, shifting, renormalise
    kernel = p%kernel
    integrator = p%integrator
    cfl = p%cfl
    cfl_force = p%cfl_force
    cfl_visc = p%cfl_visc
    viscosity = p%viscosity
    alpha = p%alpha
    diffusion = p%diffusion
    delta = p%delta
    skin = p%skin
    tensile = p%tensile
    tensile_eps = p%tensile_eps
    tensile_n = p%tensile_n
    pressure_gradient = p%pressure_gradient
    divergence = p%divergence
    shifting = p%shifting
    renormalise = p%renormalise
    read(text, nml=numerics, iostat=ios, iomsg=iomsg)
    if (ios /= 0) return
    p%kernel = kernel
    p%integrator = integrator
    p%cfl = cfl
    p%cfl_force = cfl_force
    p%cfl_visc = cfl_visc
    p%viscosity = viscosity
    p%alpha = alpha
    p%diffusion = diffusion
    p%delta = delta
    p%skin = skin
    p%tensile = tensile
    p%tensile_eps = tensile_eps
    p%tensile_n = tensile_n
    p%pressure_gradient = pressure_gradient
    p%divergence = divergence
    p%shifting = shifting
    p%renormalise = renormalise
  end subroutine read_numerics

  subroutine read_output(text, p, ios, iomsg)
    character(len=*), intent(in) :: text
    type(output_params_t), intent(inout) :: p
    integer, intent(out) :: ios
    character(len=*), intent(inout) :: iomsg
    ! Wider than p%dir so that gfortran does not warn of truncation; the
    ! extra character p%dir keeps is enough for validate to see the excess.
    character(len=4 * DIR_LEN_MAX) :: dir
    real(wp) :: dt, probes(3, MAX_PROBES)
    integer :: probe_every, n_probes
    logical :: snapshots
    namelist /output/ dir, dt, probe_every, snapshots, n_probes, probes
    dir = p%dir
    dt = p%dt
    probe_every = p%probe_every
    snapshots = p%snapshots
    n_probes = p%n_probes
    probes = p%probes
    read(text, nml=output, iostat=ios, iomsg=iomsg)
    if (ios /= 0) return
    p%dir = dir(1:len(p%dir))
    p%dt = dt
    p%probe_every = probe_every
    p%snapshots = snapshots
    p%n_probes = n_probes
    p%probes = probes
  end subroutine read_output

  subroutine read_circle2d(text, p, ios, iomsg)
    character(len=*), intent(in) :: text
    type(circle2d_params_t), intent(inout) :: p
    integer, intent(out) :: ios
    character(len=*), intent(inout) :: iomsg
    real(wp) :: radius, a0
    namelist /circle2d/ radius, a0
    radius = p%radius
    a0 = p%a0
    read(text, nml=circle2d, iostat=ios, iomsg=iomsg)
    if (ios /= 0) return
    p%radius = radius
    p%a0 = a0
  end subroutine read_circle2d

  subroutine read_ellipsoid3d(text, p, ios, iomsg)
    character(len=*), intent(in) :: text
    type(ellipsoid3d_params_t), intent(inout) :: p
    integer, intent(out) :: ios
    character(len=*), intent(inout) :: iomsg
    real(wp) :: radius, a0, rates(3)
    logical :: prepared
    namelist /ellipsoid3d/ radius, a0, rates, prepared
    radius = p%radius
    a0 = p%a0
    rates = p%rates
    prepared = p%prepared
    read(text, nml=ellipsoid3d, iostat=ios, iomsg=iomsg)
    if (ios /= 0) return
    p%radius = radius
    p%a0 = a0
    p%rates = rates
    p%prepared = prepared
  end subroutine read_ellipsoid3d

  subroutine read_square_rotation(text, p, ios, iomsg)
    character(len=*), intent(in) :: text
    type(square_rotation_params_t), intent(inout) :: p
    integer, intent(out) :: ios
    character(len=*), intent(inout) :: iomsg
    real(wp) :: side, omega
    namelist /square_rotation/ side, omega
    side = p%side
    omega = p%omega
    read(text, nml=square_rotation, iostat=ios, iomsg=iomsg)
    if (ios /= 0) return
    p%side = side
    p%omega = omega
  end subroutine read_square_rotation

  subroutine read_parallel(text, p, ios, iomsg)
    character(len=*), intent(in) :: text
    type(parallel_params_t), intent(inout) :: p
    integer, intent(out) :: ios
    character(len=*), intent(inout) :: iomsg
    character(len=NAME_LEN) :: decomposition, balance
    real(wp) :: imbalance_threshold
    namelist /parallel/ decomposition, balance, imbalance_threshold
    decomposition = p%decomposition
    balance = p%balance
    imbalance_threshold = p%imbalance_threshold
    read(text, nml=parallel, iostat=ios, iomsg=iomsg)
    if (ios /= 0) return
    p%decomposition = lower(decomposition)
    p%balance = lower(balance)
    p%imbalance_threshold = imbalance_threshold
  end subroutine read_parallel

  subroutine read_square_vortical(text, p, ios, iomsg)
    character(len=*), intent(in) :: text
    type(square_vortical_params_t), intent(inout) :: p
    integer, intent(out) :: ios
    character(len=*), intent(inout) :: iomsg
    real(wp) :: side, v0
    namelist /square_vortical/ side, v0
    side = p%side
    v0 = p%v0
    read(text, nml=square_vortical, iostat=ios, iomsg=iomsg)
    if (ios /= 0) return
    p%side = side
    p%v0 = v0
  end subroutine read_square_vortical

  ! ------------------------------------------------------------------------
  ! Checks
  ! ------------------------------------------------------------------------

  !> Word-valued variables are compared in lower case without leading
  !> blanks, as Fortran compares names ('Gaussian' is 'gaussian').
  subroutine normalise_words(c)
    type(config_t), intent(inout) :: c
    c%run%case_name = lower(adjustl(c%run%case_name))
    c%particles%placement = lower(adjustl(c%particles%placement))
    c%physics%eos = lower(adjustl(c%physics%eos))
    c%numerics%kernel = lower(adjustl(c%numerics%kernel))
    c%numerics%integrator = lower(adjustl(c%numerics%integrator))
    c%numerics%viscosity = lower(adjustl(c%numerics%viscosity))
    c%numerics%diffusion = lower(adjustl(c%numerics%diffusion))
    c%numerics%pressure_gradient = lower(adjustl(c%numerics%pressure_gradient))
    c%numerics%divergence = lower(adjustl(c%numerics%divergence))
    c%numerics%renormalise = lower(adjustl(c%numerics%renormalise))
  end subroutine normalise_words

  !> Every value on its own (ranges and lists from VARS), then the rules
  !> that involve several values.  Messages name where the value was set.
  subroutine validate(c, path, origins, err)
    type(config_t), intent(in) :: c
    character(len=*), intent(in) :: path
    type(origin_t), intent(in) :: origins(:)
    character(len=:), allocatable, intent(inout) :: err
    character(len=:), allocatable :: text, origin, head, formula, dir
    character(len=NAME_LEN), allocatable :: list(:)
    real(wp) :: x, speed, s
    integer :: k, line
    type(var_t) :: v

    do k = 1, size(VARS)
      v = VARS(k)
      call get_value(c, v, text, x)
      call origin_of(origins, path, key(v), origin, line)
      head = '&' // trim(GROUPS(v%group)%name) // ' ' // trim(v%name) // ' = ' // text
      if (v%lo_rule /= LO_NONE .or. v%hi_rule /= HI_NONE) then
        if (.not. in_range(v, x)) then
          call fail(err, origin, head // ' is out of range', line, &
                    ': allowed ' // allowed_text(v))
          return
        end if
      else if (v%choices /= CH_NONE) then
        list = choice_list(v%choices)
        if (.not. any(quoted_list(list) == text)) then
          call fail(err, origin, head // ' is not allowed', line, &
                    ': choose one of ' // allowed_words(list))
          return
        end if
      end if
    end do

    call origin_of(origins, path, 'output.dir', origin, line)
    dir = trim(c%output%dir)
    if (len(dir) == 0) then
      call fail(err, origin, '&output dir = '''' is empty', line, &
                ': give the run directory, at most ' // int_str(DIR_LEN_MAX) // ' characters')
      return
    else if (len(dir) > DIR_LEN_MAX) then
      call fail(err, origin, '&output dir = ' // quoted(dir(1:40)) // '... is too long', line, &
                ': allowed at most ' // int_str(DIR_LEN_MAX) // ' characters')
      return
    end if

    call require_file(err, origins, path, 'run.restart', trim(c%run%restart), &
                      ': give an existing snapshot file (snap_NNNNN.h5 in a run directory), ' // &
                      'or leave it empty')
    if (allocated(err)) return
    call require_file(err, origins, path, 'particles.from', trim(c%particles%from), &
                      ': give an existing snapshot file of a run with placement = ''packed'', ' // &
                      'or leave it empty')
    if (allocated(err)) return
    if (len_trim(c%particles%from) > 0) then
      call origin_of(origins, path, 'particles.from', origin, line)
      if (c%particles%placement /= 'packed') then
        call fail(err, origin, '&particles from = ' // quoted(trim(c%particles%from)) // &
                  ' needs placement = ''packed''', line, ': the file holds a packed ' // &
                  'distribution (set particles.placement = ''packed'', or leave from empty)')
        return
      end if
    end if
    if (c%particles%placement == 'packed' .and. c%run%case_name /= 'circle2d' .and. &
        c%run%case_name /= 'ellipsoid3d') then
      call origin_of(origins, path, 'particles.placement', origin, line)
      call fail(err, origin, '&particles placement = ''packed'' is not available for ' // &
                trim(c%run%case_name), line, ': packing serves circle2d and ellipsoid3d; ' // &
                'the square patches are always on a lattice')
      return
    end if

    call origin_of(origins, path, 'output.probes', origin, line)
    do k = 1, MAX_PROBES
      if (.not. all(ieee_is_finite(c%output%probes(:, k)))) then
        call fail(err, origin, '&output probes(1:3,' // int_str(k) // ') = ' // &
                  real_list(c%output%probes(:, k)) // ' is not a finite position', line, '')
        return
      end if
    end do

    ! The rates of a divergence-free linear field sum to zero (doc/theory.md X1).
    associate (rates => c%ellipsoid3d%rates)
      call origin_of(origins, path, 'ellipsoid3d.rates', origin, line)
      head = '&ellipsoid3d rates = ' // real_list(rates)
      s = sum(rates)
      if (.not. all(ieee_is_finite(rates))) then
        call fail(err, origin, head // ' are not all finite', line, '')
        return
      else if (.not. abs(s) <= RATES_SUM_TOL) then
        call fail(err, origin, head // ' sum to ' // real_str(s), line, &
                  ': they must sum to zero (incompressible flow), within ' // &
                  real_str(RATES_SUM_TOL) // ', e.g. -1.0, -1.0, 2.0')
        return
      else if (.not. maxval(abs(rates)) > 0) then
        call fail(err, origin, head // ' are all zero', line, &
                  ': give a non-zero flow, e.g. -1.0, -1.0, 2.0')
        return
      end if
    end associate

    ! Stability of the time integrators in the acoustic CFL (measured on
    ! circle2d, doc/numerics.md): rk4 is unaffected up to 2.4 and degrades
    ! at 2.8; pc2 is fine at 1.0 and unstable from 1.1.
    call origin_of(origins, path, 'numerics.cfl', origin, line)
    if (c%numerics%integrator == 'pc2' .and. c%numerics%cfl > PC2_CFL_MAX) then
      call fail(err, origin, '&numerics cfl = ' // real_str(c%numerics%cfl) // &
                ' is too large for integrator = ''pc2''', line, &
                ': allowed 0 < cfl <= ' // real_str(PC2_CFL_MAX) // &
                ' (the predictor-corrector is unstable above it; rk4 allows up to ' // &
                real_str(RK4_CFL_MAX) // ')')
      return
    else if (c%numerics%integrator == 'rk4' .and. c%numerics%cfl > RK4_CFL_MAX) then
      call fail(err, origin, '&numerics cfl = ' // real_str(c%numerics%cfl) // &
                ' is too large for integrator = ''rk4''', line, &
                ': allowed 0 < cfl <= ' // real_str(RK4_CFL_MAX))
      return
    end if

    ! Weak compressibility: the Mach number must stay small.
    call case_speed(c, speed, formula)
    call origin_of(origins, path, 'physics.c0', origin, line)
    if (.not. c%physics%c0 >= MACH_FACTOR * speed) then
      call fail(err, origin, '&physics c0 = ' // real_str(c%physics%c0) // &
                ' is too small for case ''' // trim(c%run%case_name) // '''', line, &
                ': allowed c0 >= 3 max|u0| = ' // real_str(MACH_FACTOR * speed) // &
                ', where max|u0| = ' // formula // ' = ' // real_str(speed) // &
                ' is the largest initial speed')
      return
    end if
  end subroutine validate

  !> The largest initial speed of the selected case and how it is computed.
  subroutine case_speed(c, speed, formula)
    type(config_t), intent(in) :: c
    real(wp), intent(out) :: speed
    character(len=:), allocatable, intent(out) :: formula
    select case (c%run%case_name)
    case ('circle2d')   ! u = -A0 x, v = A0 y: A0 R on the circle
      speed = c%circle2d%a0 * c%circle2d%radius
      formula = '&circle2d a0 radius'
    case ('ellipsoid3d')   ! u_k = rates(k) A0 x_k: max|rates| A0 R on the sphere
      speed = maxval(abs(c%ellipsoid3d%rates)) * c%ellipsoid3d%a0 * c%ellipsoid3d%radius
      formula = '&ellipsoid3d max|rates| a0 radius'
    case ('square_rotation')   ! u = omega (y, -x): omega L/sqrt(2) at the corners
      speed = c%square_rotation%omega * c%square_rotation%side / sqrt(2.0_wp)
      formula = '&square_rotation omega side/sqrt(2)'
    case ('square_vortical')   ! |u| = sqrt(2) V0 (1 - e^-4) at the centre
      speed = sqrt(2.0_wp) * c%square_vortical%v0 * (1 - exp(-4.0_wp))
      formula = '&square_vortical sqrt(2) (1 - e^-4) v0'
    case default
      speed = 0
      formula = '0'
    end select
  end subroutine case_speed

  logical function in_range(v, x)
    type(var_t), intent(in) :: v
    real(wp), intent(in) :: x
    ! No comparison with a NaN: it would raise IEEE invalid (trapped in debug builds).
    in_range = ieee_is_finite(x)
    if (.not. in_range) return
    if (v%lo_rule == LO_GT) in_range = in_range .and. x > v%lo
    if (v%lo_rule == LO_GE) in_range = in_range .and. x >= v%lo
    if (v%hi_rule == HI_LT) in_range = in_range .and. x < v%hi
    if (v%hi_rule == HI_LE) in_range = in_range .and. x <= v%hi
  end function in_range

  ! ------------------------------------------------------------------------
  ! Writing
  ! ------------------------------------------------------------------------

  !> Writes c as a commented namelist file that reads back to c exactly.
  subroutine write_config(c, unit, title)
    type(config_t), intent(in) :: c
    integer, intent(in) :: unit
    character(len=*), intent(in) :: title(:)
    character(len=:), allocatable :: text
    real(wp) :: x
    integer :: g, k, p
    logical :: first

    do k = 1, size(title)
      write(unit, '(a)') trim('! ' // title(k))
    end do
    do g = 1, size(GROUPS)
      write(unit, '(a)') '', '! ' // trim(GROUPS(g)%help), '&' // trim(GROUPS(g)%name)
      do k = 1, size(VARS)
        if (VARS(k)%group /= g) cycle
        if (VARS(k)%dims(2) > 0) then
          ! probes: one line per probe in use or set (the rest stay zero).
          first = .true.
          do p = 1, MAX_PROBES
            if (p > max(1, c%output%n_probes) .and. &
                all(transfer(c%output%probes(:, p), 0_i8, 3) == 0_i8)) cycle
            call write_item(unit, trim(VARS(k)%name) // '(1:3,' // int_str(p) // ')', &
                            real_list(c%output%probes(:, p)), VARS(k), first)
            first = .false.
          end do
        else
          call get_value(c, VARS(k), text, x)
          call write_item(unit, trim(VARS(k)%name), text, VARS(k), .true.)
        end if
      end do
      write(unit, '(a)') '/'
    end do
  end subroutine write_config

  !> One line `  name = value   ! what it is (allowed: ...)`.
  subroutine write_item(unit, name, text, v, with_comment)
    integer, intent(in) :: unit
    character(len=*), intent(in) :: name, text
    type(var_t), intent(in) :: v
    logical, intent(in) :: with_comment
    character(len=:), allocatable :: line
    line = '  ' // name // ' = ' // text
    if (with_comment) line = pad(line, 36) // '  ! ' // trim(v%help) // ' (allowed: ' // &
                             allowed_text(v) // ')'
    write(unit, '(a)') line
  end subroutine write_item

  !> The value of variable v in c as namelist text and, for a number, as x
  !> (output.probes has no single text: see write_config).
  subroutine get_value(c, v, text, x)
    type(config_t), intent(in) :: c
    type(var_t), intent(in) :: v
    character(len=:), allocatable, intent(out) :: text
    real(wp), intent(out) :: x
    x = 0
    text = ''
    select case (key(v))
    case ('run.case')
      text = quoted(c%run%case_name)
    case ('run.t_end')
      x = c%run%t_end
    case ('run.max_steps')
      x = real(c%run%max_steps, wp)
    case ('run.progress_interval')
      x = c%run%progress_interval
    case ('particles.n')
      x = real(c%particles%n, wp)
    case ('particles.placement')
      text = quoted(c%particles%placement)
    case ('particles.h_over_dx')
      x = c%particles%h_over_dx
    case ('particles.pack_iterations')
      x = real(c%particles%pack_iterations, wp)
    case ('particles.from')
      text = quoted(c%particles%from)
    case ('physics.rho0')
      x = c%physics%rho0
    case ('physics.c0')
      x = c%physics%c0
    case ('physics.eos')
      text = quoted(c%physics%eos)
    case ('physics.gamma')
      x = c%physics%gamma
    case ('numerics.kernel')
      text = quoted(c%numerics%kernel)
    case ('numerics.integrator')
      text = quoted(c%numerics%integrator)
    case ('numerics.cfl')
      x = c%numerics%cfl
    case ('numerics.cfl_force')
      x = c%numerics%cfl_force
    case ('numerics.cfl_visc')
      x = c%numerics%cfl_visc
    case ('numerics.viscosity')
      text = quoted(c%numerics%viscosity)
    case ('numerics.alpha')
      x = c%numerics%alpha
    case ('numerics.diffusion')
      text = quoted(c%numerics%diffusion)
    case ('numerics.delta')
      x = c%numerics%delta
    case ('numerics.skin')
      x = c%numerics%skin
    case ('numerics.tensile')
      text = merge('.true. ', '.false.', c%numerics%tensile)
      text = trim(text)
    case ('numerics.tensile_eps')
      x = c%numerics%tensile_eps
    case ('numerics.tensile_n')
      x = real(c%numerics%tensile_n, wp)
    case ('numerics.pressure_gradient')
      text = quoted(c%numerics%pressure_gradient)
    case ('numerics.renormalise')
      text = quoted(c%numerics%renormalise)
    case ('numerics.divergence')
      text = quoted(c%numerics%divergence)
    case ('numerics.shifting')
      text = merge('.true. ', '.false.', c%numerics%shifting)
      text = trim(text)
    case ('output.dir')
      text = quoted(c%output%dir)
    case ('output.dt')
      x = c%output%dt
    case ('output.probe_every')
      x = real(c%output%probe_every, wp)
    case ('output.snapshots')
      text = merge('.true. ', '.false.', c%output%snapshots)
      text = trim(text)
    case ('output.n_probes')
      x = real(c%output%n_probes, wp)
    case ('circle2d.radius')
      x = c%circle2d%radius
    case ('circle2d.a0')
      x = c%circle2d%a0
    case ('ellipsoid3d.radius')
      x = c%ellipsoid3d%radius
    case ('ellipsoid3d.a0')
      x = c%ellipsoid3d%a0
    case ('ellipsoid3d.rates')
      text = real_list(c%ellipsoid3d%rates)
    case ('ellipsoid3d.prepared')
      text = trim(merge('.true. ', '.false.', c%ellipsoid3d%prepared))
    case ('square_rotation.side')
      x = c%square_rotation%side
    case ('square_rotation.omega')
      x = c%square_rotation%omega
    case ('square_vortical.side')
      x = c%square_vortical%side
    case ('square_vortical.v0')
      x = c%square_vortical%v0
    case ('run.restart')
      text = quoted(c%run%restart)
    case ('parallel.decomposition')
      text = quoted(c%parallel%decomposition)
    case ('parallel.balance')
      text = quoted(c%parallel%balance)
    case ('parallel.imbalance_threshold')
      x = c%parallel%imbalance_threshold
    end select
    if (v%dims(1) == 0) then
      if (v%type == T_INT) text = int_str(nint(x))
      if (v%type == T_REAL) text = real_str(x)
    end if
  end subroutine get_value

  ! ------------------------------------------------------------------------
  ! Messages
  ! ------------------------------------------------------------------------

  !> A non-empty file name given for variable `key` (group.name) must name
  !> an existing file; err says so otherwise.
  subroutine require_file(err, origins, path, key, file, hint)
    character(len=:), allocatable, intent(inout) :: err
    type(origin_t), intent(in) :: origins(:)
    character(len=*), intent(in) :: path, key, file, hint
    character(len=:), allocatable :: origin
    integer :: line, dot
    logical :: exists
    if (len(file) == 0) return
    inquire(file=file, exist=exists)
    if (exists) return
    call origin_of(origins, path, key, origin, line)
    dot = index(key, '.')
    call fail(err, origin, '&' // key(1:dot - 1) // ' ' // key(dot + 1:) // ' = ' // quoted(file) &
              // ' does not exist', line, hint)
  end subroutine require_file

  !> What is allowed for v, e.g. "0 < cfl <= 3" or "one of 'rk4', 'pc2'".
  function allowed_text(v) result(s)
    type(var_t), intent(in) :: v
    character(len=:), allocatable :: s
    character(len=:), allocatable :: name
    name = trim(v%name)
    if (v%choices /= CH_NONE) then
      s = 'one of ' // allowed_words(choice_list(v%choices))
    else if (v%lo_rule /= LO_NONE .and. v%hi_rule /= HI_NONE) then
      s = num_str(v%lo) // lo_op(v%lo_rule) // name // hi_op(v%hi_rule) // num_str(v%hi)
    else if (v%lo_rule /= LO_NONE) then
      ! "x > lo" reads better than "lo < x"
      s = name // ' >= ' // num_str(v%lo)
      if (v%lo_rule == LO_GT) s = name // ' > ' // num_str(v%lo)
    else if (v%hi_rule /= HI_NONE) then
      s = name // hi_op(v%hi_rule) // num_str(v%hi)
    else if (v%type == T_LOGICAL) then
      s = '.true. or .false.'
    else
      s = trim(v%rule)
    end if
  end function allowed_text

  function lo_op(rule) result(s)
    integer, intent(in) :: rule
    character(len=:), allocatable :: s
    s = ' <= '
    if (rule == LO_GT) s = ' < '
  end function lo_op

  function hi_op(rule) result(s)
    integer, intent(in) :: rule
    character(len=:), allocatable :: s
    s = ' <= '
    if (rule == HI_LT) s = ' < '
  end function hi_op

  !> The default of v as text (for hints).
  function default_text(v) result(s)
    type(var_t), intent(in) :: v
    character(len=:), allocatable :: s
    real(wp) :: x
    if (v%dims(2) > 0) then
      s = 'all 0.0'
    else
      call get_value(config_t(), v, s, x)
    end if
  end function default_text

  !> "; did you mean &numerics? The groups are &run, &particles, ...".
  function unknown_group_hint(name) result(s)
    character(len=*), intent(in) :: name
    character(len=:), allocatable :: s
    character(len=:), allocatable :: best
    character(len=len(GROUPS%name)) :: names(size(GROUPS))
    integer :: k
    names = GROUPS%name
    best = closest(name, names)
    s = '; the groups are'
    if (len(best) > 0) s = '; did you mean &' // best // '? The groups are'
    do k = 1, size(GROUPS)
      s = s // ' &' // trim(GROUPS(k)%name)
      if (k < size(GROUPS)) s = s // ','
    end do
  end function unknown_group_hint

  !> "; did you mean 'cfl'? The variables of &numerics are kernel, ...".
  function unknown_var_hint(g, name) result(s)
    integer, intent(in) :: g
    character(len=*), intent(in) :: name
    character(len=:), allocatable :: s
    character(len=:), allocatable :: best
    integer :: k
    logical :: first
    best = closest(name, pack(VARS%name, VARS%group == g))
    s = '; the variables of &' // trim(GROUPS(g)%name) // ' are'
    if (len(best) > 0) s = '; did you mean ''' // best // '''? The variables of &' // &
                           trim(GROUPS(g)%name) // ' are'
    first = .true.
    do k = 1, size(VARS)
      if (VARS(k)%group /= g) cycle
      if (.not. first) s = s // ','
      s = s // ' ' // trim(VARS(k)%name)
      first = .false.
    end do
  end function unknown_var_hint

  !> "a real number", "an integer", ... for "cannot be read as ...".
  function type_text(v) result(s)
    type(var_t), intent(in) :: v
    character(len=:), allocatable :: s
    select case (v%type)
    case (T_INT)
      s = 'an integer'
    case (T_REAL)
      s = 'a real number'
      if (v%dims(1) > 0) s = 'real numbers for ' // trim(v%name) // shape_text(v)
    case (T_STRING)
      s = 'a string'
    case default
      s = 'a logical'
    end select
  end function type_text

  !> The index ranges of an array variable, e.g. "(1:3, 1:16)".
  function shape_text(v) result(s)
    type(var_t), intent(in) :: v
    character(len=:), allocatable :: s
    s = '(1:' // int_str(v%dims(1))
    if (v%dims(2) > 0) s = s // ', 1:' // int_str(v%dims(2))
    s = s // ')'
  end function shape_text

  !> Where the value of variable `k` ('group.name') was last set, for a
  !> message: the command line, or the file and its line (0 if a default).
  subroutine origin_of(origins, path, k, origin, line)
    type(origin_t), intent(in) :: origins(:)
    character(len=*), intent(in) :: path, k
    character(len=:), allocatable, intent(out) :: origin
    integer, intent(out) :: line
    integer :: i
    origin = path
    line = 0
    do i = size(origins), 1, -1
      if (origins(i)%key /= k) cycle
      line = origins(i)%line
      if (line == 0) origin = 'command line'
      return
    end do
  end subroutine origin_of

  subroutine set_origin(origins, k, line)
    type(origin_t), allocatable, intent(inout) :: origins(:)
    character(len=*), intent(in) :: k
    integer, intent(in) :: line
    origins = [origins, origin_t(k, line)]
  end subroutine set_origin

  ! ------------------------------------------------------------------------
  ! Small text helpers
  ! ------------------------------------------------------------------------

  !> 'group.name' of a variable.
  function key(v) result(s)
    type(var_t), intent(in) :: v
    character(len=:), allocatable :: s
    s = trim(GROUPS(v%group)%name) // '.' // trim(v%name)
  end function key

  integer function group_index(name)
    character(len=*), intent(in) :: name
    integer :: k
    group_index = 0
    do k = 1, size(GROUPS)
      if (GROUPS(k)%name == name) group_index = k
    end do
  end function group_index

  integer function var_index(g, name)
    integer, intent(in) :: g
    character(len=*), intent(in) :: name
    integer :: k
    var_index = 0
    do k = 1, size(VARS)
      if (VARS(k)%group == g .and. VARS(k)%name == name) var_index = k
    end do
  end function var_index

  function choice_list(id) result(list)
    integer, intent(in) :: id
    character(len=NAME_LEN), allocatable :: list(:)
    select case (id)
    case (CH_CASE)
      list = CASES%name
    case (CH_PLACEMENT)
      list = PLACEMENTS
    case (CH_EOS)
      list = EOS_NAMES
    case (CH_KERNEL)
      list = KERNEL_NAMES
    case (CH_INTEGRATOR)
      list = INTEGRATORS
    case (CH_VISCOSITY)
      list = VISCOSITIES
    case (CH_DIFFUSION)
      list = DIFFUSIONS
    case (CH_DECOMPOSITION)
      list = DECOMPOSITIONS
    case (CH_BALANCE)
      list = BALANCES
    case (CH_PRESSURE_GRADIENT)
      list = PRESSURE_GRADIENTS
    case (CH_DIVERGENCE)
      list = DIVERGENCES
    case (CH_RENORMALISE)
      list = RENORMALISE_WHEN
    case default
      allocate(list(0))
    end select
  end function choice_list

end module config
