!> The generic namelist groups (doc/reference/input.md): the rows describing their
!> variables (GENERIC_VARS), and one derived type per group, every component
!> at its default, with its reader and its values as text (what a case
!> gives for its own group, case_base).  The cases see the groups they need.
module input_params
  use kinds, only: wp
  use input_text, only: quoted, real_str, real_list, int_str, lower
  use input_var, only: var_t, T_INT, T_REAL, T_STRING, T_LOGICAL, LO_NONE, LO_GT, LO_GE, &
                       HI_NONE, HI_LE, CH_NONE, SCALAR
  implicit none
  private
  public :: run_params_t, particles_params_t, physics_params_t, numerics_params_t, &
            output_params_t, parallel_params_t, NAME_LEN, DIR_LEN_MAX, MAX_PROBES
  public :: group_t, GENERIC_GROUPS, GENERIC_VARS, G_RUN, G_PARTICLES, G_PHYSICS, &
            G_NUMERICS, G_OUTPUT, G_PARALLEL, CH_CASE, word_list
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

  !> A namelist group: its name and a line saying what it is for.
  type :: group_t
    character(len=16) :: name
    character(len=100) :: help
  end type group_t

  !> The generic groups (config puts the cases' own groups before &parallel).
  integer, parameter :: G_RUN = 1, G_PARTICLES = 2, G_PHYSICS = 3, G_NUMERICS = 4, &
                        G_OUTPUT = 5, G_PARALLEL = 6
  type(group_t), parameter :: GENERIC_GROUPS(*) = [ &
    group_t('run', 'what to run and for how long'), &
    group_t('particles', 'the initial particle layout'), &
    group_t('physics', 'the fluid'), &
    group_t('numerics', 'SPH discretisation and time stepping'), &
    group_t('output', 'run directory, snapshots, time series and pressure probes'), &
    group_t('parallel', 'the domain decomposition across MPI ranks (doc/developer/parallel.md)')]

  ! The lists of allowed words of var_t%choices.
  integer, parameter :: CH_CASE = 1, CH_PLACEMENT = 2, CH_EOS = 3, &
                        CH_KERNEL = 4, CH_INTEGRATOR = 5, CH_VISCOSITY = 6, CH_DIFFUSION = 7, &
                        CH_DECOMPOSITION = 8, CH_BALANCE = 9, CH_PRESSURE_GRADIENT = 10, &
                        CH_DIVERGENCE = 11, CH_RENORMALISE = 12, CH_SYMMETRY = 13

  !> The variables of the generic groups (group: index into GENERIC_GROUPS).
  type(var_t), parameter :: GENERIC_VARS(*) = [ &
    var_t(G_RUN, 'case', T_STRING, SCALAR, LO_NONE, HI_NONE, 0.0_wp, 0.0_wp, CH_CASE, '', &
          'the test case; its own group sets its geometry', &
          doc='the test case. Its own group, of the same name (`&circle2d` for ' // &
              '`circle2d`), sets its geometry and initial flow'), &
    var_t(G_RUN, 't_end', T_REAL, SCALAR, LO_GT, HI_NONE, 0.0_wp, 0.0_wp, CH_NONE, '', &
          'end time (read as t A0 with the non-dimensional defaults)'), &
    var_t(G_RUN, 'max_steps', T_INT, SCALAR, LO_GE, HI_NONE, 0.0_wp, 0.0_wp, CH_NONE, '', &
          'stop after this many steps, 0 for no limit (a final snapshot is written then)'), &
    var_t(G_RUN, 'progress_interval', T_REAL, SCALAR, LO_GT, HI_NONE, 0.0_wp, 0.0_wp, &
          CH_NONE, '', 'wall-clock seconds between progress lines'), &
    var_t(G_RUN, 'wall_limit', T_REAL, SCALAR, LO_GE, HI_NONE, 0.0_wp, 0.0_wp, CH_NONE, '', &
          'wall-clock seconds the run may take; it stops in time with a checkpoint ' // &
          '(0: no limit)', &
          doc='wall-clock seconds the run may take (the job''s time limit less a margin ' // &
              'for the start of mpirun): it stops early enough to write `checkpoint.h5` ' // &
              'and exits with code 75; 0: no limit (doc/guide/restarts.md, "Stopping and ' // &
              'continuing")'), &
    var_t(G_RUN, 'restart', T_STRING, SCALAR, LO_NONE, HI_NONE, 0.0_wp, 0.0_wp, CH_NONE, &
          'empty, or an existing snapshot file of the same case', &
          'snapshot or checkpoint to continue the run from, e.g. ' // &
          'runs/circle2d/snap_00010.h5 (empty: none)', &
          doc='continue the run from this snapshot (`runs/circle2d/snap_00010.h5`) or ' // &
              'checkpoint (`runs/circle2d/checkpoint.h5`), with any number of ranks; ' // &
              'the snapshot numbering, XDMF index and time series in `output.dir` ' // &
              'continue (doc/guide/restarts.md)'), &
    var_t(G_PARTICLES, 'n', T_INT, SCALAR, LO_GE, HI_LE, 50.0_wp, 2000000000.0_wp, CH_NONE, &
          '', 'approximate number of particles; the spacing dx follows from it'), &
    var_t(G_PARTICLES, 'placement', T_STRING, SCALAR, LO_NONE, HI_NONE, 0.0_wp, 0.0_wp, &
          CH_PLACEMENT, '', 'rings: concentric (shells); lattice: a clipped square ' // &
          '(cubic); packed: relaxed (doc/theory/packing.md)', &
          doc='`rings`: concentric rings (3D: shells) of spacing dx; `lattice`: square ' // &
              '(cubic) lattice clipped to the body; `packed`: relaxed into a uniform, ' // &
              'isotropic arrangement with a sharp surface (circle2d and ellipsoid3d ' // &
              'only, [packing](../theory/packing.md); both input files use it). The square ' // &
              'patches are always on a lattice of nint(sqrt(n)) x nint(sqrt(n)) ' // &
              'particles and refuse `packed`'), &
    var_t(G_PARTICLES, 'h_over_dx', T_REAL, SCALAR, LO_GE, HI_LE, 1.0_wp, 8.0_wp, CH_NONE, &
          '', 'smoothing length h over particle spacing dx', &
          doc='smoothing length h over particle spacing dx (at `n_ref` particles when ' // &
              '`n_ref > 0`)'), &
    var_t(G_PARTICLES, 'n_ref', T_REAL, SCALAR, LO_GE, HI_NONE, 0.0_wp, 0.0_wp, CH_NONE, '', &
          'resolution scaling: h_over_dx, c0, alpha, delta hold at this count; 0: none ' // &
          '(doc/studies/convergence.md)', &
          doc='resolution scaling (doc/theory/scaling.md, S1): `h_over_dx`, `c0`, `alpha` ' // &
              'and `delta` hold as given at `n_ref` particles and scale with s = ' // &
              '(n/n_ref)^(1/dim) = dx_ref/dx by their exponents; 0: no scaling. The run ' // &
              'prints the values it uses; the echoed `input.nml` keeps the given ones'), &
    var_t(G_PARTICLES, 'h_exponent', T_REAL, SCALAR, LO_GE, HI_LE, 0.0_wp, 1.0_wp, CH_NONE, &
          '', 'with n_ref > 0: h/dx = h_over_dx (n/n_ref)^(h_exponent/dim)'), &
    var_t(G_PARTICLES, 'pack_iterations', T_INT, SCALAR, LO_GE, HI_LE, 1.0_wp, 100000.0_wp, &
          CH_NONE, '', 'most iterations of the packing (placement = ''packed'')', &
          doc='most iterations of the packing (`placement = ''packed''`); it stops ' // &
              'earlier when every move is below 1e-4 dx'), &
    var_t(G_PARTICLES, 'from', T_STRING, SCALAR, LO_NONE, HI_NONE, 0.0_wp, 0.0_wp, CH_NONE, &
          'empty, or a snapshot of a packed run of the same case', &
          'snapshot whose initial positions are the packed particles (empty: pack anew)', &
          doc='reuse a packed distribution: the initial positions (`position_initial`) ' // &
              'of any snapshot of a packed run of the same case, e.g. ' // &
              '`runs/e1M/snap_00000.h5`, instead of packing again; dx follows from its ' // &
              'particle count and `n` is not used, except with `n_ref > 0`, whose scaling ' // &
              'takes h/dx, c0, alpha and delta from `n`: then `n` must be the file''s ' // &
              'count (within 2 %)'), &
    var_t(G_PARTICLES, 'symmetry', T_STRING, SCALAR, LO_NONE, HI_NONE, 0.0_wp, 0.0_wp, &
          CH_SYMMETRY, '', 'mirror planes x = 0, y = 0, z = 0 by their normals: ' // &
          'the run holds the part x_k >= 0 (doc/theory/mirrors.md)', &
          doc='mirror planes through the centre, named by their normal axes (`''xyz''`: ' // &
              'the three coordinate planes): the run holds the part of the body with ' // &
              'x_k >= 0 on each, and the particles near a plane see their mirror images ' // &
              'as neighbours, so that the part moves as the whole body would; a ' // &
              'particle may lie on a plane, with its share of the mass (M5, ' // &
              '[mirrors](../theory/mirrors.md)). `n` stays the whole body''s count; the run ' // &
              'holds about n / 2^(planes). circle2d and ellipsoid3d only, with `lattice` or ' // &
              '`packed` and without shifting'), &
    var_t(G_PHYSICS, 'rho0', T_REAL, SCALAR, LO_GT, HI_NONE, 0.0_wp, 0.0_wp, CH_NONE, '', &
          'reference density'), &
    var_t(G_PHYSICS, 'c0', T_REAL, SCALAR, LO_GT, HI_NONE, 0.0_wp, 0.0_wp, CH_NONE, '', &
          'speed of sound (at n_ref particles when scaled); at least 3 times the largest ' // &
          'initial speed of the case'), &
    var_t(G_PHYSICS, 'c0_exponent', T_REAL, SCALAR, LO_GE, HI_LE, 0.0_wp, 2.0_wp, CH_NONE, &
          '', 'with particles.n_ref > 0: c0 = c0 (n/n_ref)^(c0_exponent/dim)'), &
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
    var_t(G_NUMERICS, 'visc_reconstruction', T_LOGICAL, SCALAR, LO_NONE, HI_NONE, &
          0.0_wp, 0.0_wp, CH_NONE, '', 'viscosity on u_ji less its linear part ' // &
          'from the strain rates of i and j: none on a linear velocity field', &
          doc='the viscosity acts on u_ji less its linear part, reconstructed from the ' // &
              'renormalised strain rates of i and j ([theory](../theory/equations.md) R1): ' // &
              'zero on any linear velocity field, also at the free surface. Its sums ' // &
              'join the first pass where L_i is computed, else one more pass'), &
    var_t(G_NUMERICS, 'alpha_exponent', T_REAL, SCALAR, LO_GE, HI_LE, -2.0_wp, 2.0_wp, &
          CH_NONE, '', 'with particles.n_ref > 0: alpha = alpha (n/n_ref)^(alpha_exponent/dim)', &
          doc='with `particles.n_ref > 0`: alpha = `alpha` s^`alpha_exponent` (-1: alpha ' // &
              'proportional to dx)'), &
    var_t(G_NUMERICS, 'diffusion', T_STRING, SCALAR, LO_NONE, HI_NONE, 0.0_wp, 0.0_wp, &
          CH_DIFFUSION, '', 'density diffusion: molteni (delta-SPH without gradient ' // &
          'correction), antuono (with it), or none', &
          doc='density diffusion: delta-SPH without gradient correction (`molteni`), ' // &
              'with the renormalised density gradient (`antuono`), or none'), &
    var_t(G_NUMERICS, 'delta', T_REAL, SCALAR, LO_GE, HI_LE, 0.0_wp, 1.0_wp, CH_NONE, '', &
          'density diffusion coefficient'), &
    var_t(G_NUMERICS, 'delta_exponent', T_REAL, SCALAR, LO_GE, HI_LE, -2.0_wp, 2.0_wp, &
          CH_NONE, '', 'with particles.n_ref > 0: delta = delta (n/n_ref)^(delta_exponent/dim)'), &
    var_t(G_NUMERICS, 'skin', T_REAL, SCALAR, LO_GE, HI_LE, 0.0_wp, 2.0_wp, CH_NONE, '', &
          'smallest neighbour-list skin in units of h (widened when a step needs more)', &
          doc='smallest neighbour-list skin, in units of h; the list is rebuilt when an ' // &
              'unlisted pair could come within the support during the next step ' // &
              '(affine-motion test), and a rebuild widens the skin when one step''s ' // &
              'motion needs more (see doc/studies/numerics.md)'), &
    var_t(G_NUMERICS, 'tensile', T_LOGICAL, SCALAR, LO_NONE, HI_NONE, 0.0_wp, 0.0_wp, &
          CH_NONE, '', 'tensile instability control (Monaghan 2000): a repulsion ' // &
          'between particles under negative pressure', &
          doc='tensile instability control (Monaghan 2000, [theory](../theory/equations.md) ' // &
              'E7): a repulsion -Sum_j m_j (R_i + R_j) (W_ij/W(dx))^n grad_i W_ij ' // &
              'between particles under negative pressure. Needed by the square patches ' // &
              'unless `shifting` keeps the particles regular (both square inputs use ' // &
              'shifting, which measured better: doc/studies/numerics.md)'), &
    var_t(G_NUMERICS, 'tensile_eps', T_REAL, SCALAR, LO_GT, HI_LE, 0.0_wp, 1.0_wp, CH_NONE, &
          '', 'tensile control strength: R_i = tensile_eps |p_i|/rho_i^2 where p_i < 0', &
          doc='R_i = tensile_eps |p_i|/rho_i^2 where p_i < 0, else 0. 0.4 is the best ' // &
              'measured with `wendland_c2` at h = 2 dx: 0.2 (Monaghan''s value) lets the ' // &
              'rotating square open voids, 0.5 and more compress its core ' // &
              '(doc/studies/numerics.md)'), &
    var_t(G_NUMERICS, 'tensile_n', T_INT, SCALAR, LO_GE, HI_LE, 1.0_wp, 8.0_wp, CH_NONE, &
          '', 'tensile control exponent n of (W_ij/W(dx))^n'), &
    var_t(G_NUMERICS, 'pressure_gradient', T_STRING, SCALAR, LO_NONE, HI_NONE, 0.0_wp, &
          0.0_wp, CH_PRESSURE_GRADIENT, '', 'standard: (p_i + p_j); higher_order: L_i ' // &
          '(p_j - p_i) inside; renormalised: (p_i L_i + p_j L_j), keeps energy', &
          doc='`standard`: -(1/rho_i) Sum_j (p_i + p_j) grad_i W_ij V_j (E4), ' // &
              'conservative; `higher_order` (H1): inside the fluid (lambda >= 0.9) 0.9 ' // &
              'times -(1/rho_i) L_i Sum_j (p_j - p_i) grad_i W_ij V_j with p = 0 on ' // &
              'free-surface particles (lambda < 0.55) plus 0.1 times E4; E4 for lambda ' // &
              '<= 0.7, blended between. Not conservative; use it with `divergence = ' // &
              '''renormalised''` (alone it lost 17 % of the rotating square''s kinetic ' // &
              'energy); `renormalised` (H2): -(1/rho_i) Sum_j (p_i B_i + p_j B_j) grad_i ' // &
              'W_ij V_j, B = L ramped to I for lambda from 0.55 to 0.4, the adjoint of ' // &
              'the renormalised divergence (required; it uses B too): kinetic plus ' // &
              'internal energy kept (doc/theory/)'), &
    var_t(G_NUMERICS, 'divergence', T_STRING, SCALAR, LO_NONE, HI_NONE, 0.0_wp, 0.0_wp, &
          CH_DIVERGENCE, '', 'velocity divergence of the continuity equation: standard, ' // &
          'or renormalised (exact for linear u)', &
          doc='velocity divergence of the continuity equation (E1): `standard` Sum_j V_j ' // &
              '(u_j - u_i) . grad_i W_ij; `renormalised` Sum_j V_j (u_j - u_i) . (L_i ' // &
              'grad_i W_ij), exact for linear velocity fields also at the free surface ' // &
              '(L_i the renormalisation matrix, E3), 55 % more time a step. Momentum and ' // &
              'angular momentum stay exactly conserved either way. The renormalised form ' // &
              'cut the velocity error of circle2d and ellipsoid3d 1.2 to 3.7 times ' // &
              '(doc/studies/numerics.md)'), &
    var_t(G_NUMERICS, 'renormalise', T_STRING, SCALAR, LO_NONE, HI_NONE, 0.0_wp, 0.0_wp, &
          CH_RENORMALISE, '', 'L_i and lambda_i of the renormalised operators at every ' // &
          'stage, or once a step (doc/studies/numerics.md)', &
          doc='when the renormalised operators compute L_i and lambda_i: at every RK4 ' // &
              'stage, or once a step for all its stages (27 % less time a step on ' // &
              'ellipsoid3d, errors unchanged: [numerics](../studies/numerics.md))'), &
    var_t(G_NUMERICS, 'shifting', T_LOGICAL, SCALAR, LO_NONE, HI_NONE, 0.0_wp, 0.0_wp, &
          CH_NONE, '', 'particle shifting after each step (delta-plus-SPH, Sun et al. ' // &
          '2017), none on the free surface', &
          doc='particle shifting after each step (delta-plus-SPH, Sun et al. 2017, ' // &
              '[theory](../theory/equations.md) E8): dr_i = -CFL Ma (2h)^2 Sum_j [1 + 0.2 ' // &
              '(W_ij/W(dx))^4] grad_i W_ij V_j, none on the free surface (lambda < ' // &
              '0.55), only tangential near it (lambda < 0.9). Positions only. Keeps the ' // &
              'square patches in one piece without the tensile control (on in ' // &
              'both square inputs); breaks the Lagrangian map (circle2d''s ' // &
              'position error doubles): off by default'), &
    var_t(G_NUMERICS, 'binned_sums', T_LOGICAL, SCALAR, LO_NONE, HI_NONE, 0.0_wp, 0.0_wp, &
          CH_NONE, '', 'pair sums independent of the partners'' order: symmetric ' // &
          'cases stay exactly symmetric', &
          doc='each pair term is rounded onto two fixed grids and summed exactly ' // &
              '([theory](../theory/operators.md) B1), so that a particle''s sums do not depend ' // &
              'on the order of its partners: the square patches, symmetric under a ' // &
              'rotation or a mirror, then stay symmetric to the last bit. The ' // &
              'standard operators only (with shifting, the tensile control and either ' // &
              'viscosity); the general, scalar pair loop: 2.1 times the time of a step'), &
    var_t(G_OUTPUT, 'dir', T_STRING, SCALAR, LO_NONE, HI_NONE, 0.0_wp, 0.0_wp, CH_NONE, &
          'a non-empty path of at most 255 characters', 'run directory'), &
    var_t(G_OUTPUT, 'dt', T_REAL, SCALAR, LO_GT, HI_NONE, 0.0_wp, 0.0_wp, CH_NONE, '', &
          'snapshot interval (a snapshot is always written at t = 0 and at the end)'), &
    var_t(G_OUTPUT, 'probe_every', T_INT, SCALAR, LO_GE, HI_NONE, 1.0_wp, 0.0_wp, CH_NONE, &
          '', 'a time-series row every this many steps'), &
    var_t(G_OUTPUT, 'snapshots', T_LOGICAL, SCALAR, LO_NONE, HI_NONE, 0.0_wp, 0.0_wp, &
          CH_NONE, '', 'write HDF5 snapshots at all'), &
    var_t(G_OUTPUT, 'probe_quadratic', T_LOGICAL, SCALAR, LO_NONE, HI_NONE, 0.0_wp, 0.0_wp, &
          CH_NONE, '', 'probes fit a quadratic to the pressures in the support (exact for ' // &
          'quadratic p) instead of the Shepard mean', &
          doc='the probes fit a quadratic polynomial to the particle pressures within the ' // &
              'kernel support by weighted least squares ([theory](../theory/diagnostics.md) D5): ' // &
              'exact for a quadratic pressure field, where the Shepard mean (D4) is off ' // &
              'by O(h^2) (0.56 (h/R)^2 P at the centre of the circular patch)'), &
    var_t(G_OUTPUT, 'mirror', T_LOGICAL, SCALAR, LO_NONE, HI_NONE, 0.0_wp, 0.0_wp, &
          CH_NONE, '', 'with particles.symmetry: snapshots hold the whole body (the part ' // &
          'and its reflections) instead of the part', &
          doc='with `particles.symmetry`: every snapshot holds the whole body, the part ' // &
              'followed by its reflections (for ParaView), instead of the part alone; ' // &
              'a restart from it reads the part ([mirrors](../theory/mirrors.md)). ' // &
              'Checkpoints always hold the part'), &
    var_t(G_OUTPUT, 'n_probes', T_INT, SCALAR, LO_GE, HI_LE, 0.0_wp, real(MAX_PROBES, wp), &
          CH_NONE, '', 'number of pressure probes'), &
    var_t(G_OUTPUT, 'probes', T_REAL, [3, MAX_PROBES], LO_NONE, HI_NONE, 0.0_wp, 0.0_wp, &
          CH_NONE, 'finite numbers', &
          'probe k at probes(1:3,k); the third component is ignored in 2D', &
          doc='probe k is at `probes(1:3,k)`, k = 1..n_probes. The third component is ' // &
              'ignored in 2D'), &
    var_t(G_PARALLEL, 'decomposition', T_STRING, SCALAR, LO_NONE, HI_NONE, 0.0_wp, 0.0_wp, &
          CH_DECOMPOSITION, '', 'auto (slab up to 4 ranks, else sfc), slab, METIS ' // &
          'partition of cells, or sfc (pieces of a Hilbert curve)', &
          doc='`auto`: `slab` on up to 4 ranks, `sfc` on more (the measured choice, ' // &
              'doc/developer/parallel.md); `slab`: slabs along the longest axis of the particle ' // &
              'cloud; `metis`: a METIS partition of the graph of occupied cells; `sfc`: ' // &
              'the cells in the order of a Hilbert space-filling curve, cut into pieces ' // &
              'of equal work'), &
    var_t(G_PARALLEL, 'balance', T_STRING, SCALAR, LO_NONE, HI_NONE, 0.0_wp, 0.0_wp, &
          CH_BALANCE, '', 'work measure for the balance: particle count or listed pairs', &
          doc='the work to balance: particle counts, or each particle''s number of ' // &
              'listed pairs'), &
    var_t(G_PARALLEL, 'imbalance_threshold', T_REAL, SCALAR, LO_GT, HI_LE, 0.0_wp, 10.0_wp, &
          CH_NONE, '', 're-balance when max/mean work exceeds 1 + this', &
          doc='re-balance (at a neighbour-list rebuild) when max/mean work exceeds 1 + ' // &
              'this')]

  !> &run: what to run and for how long.
  type :: run_params_t
    character(len=NAME_LEN) :: case_name = 'circle2d'   !< namelist name: case
    real(wp) :: t_end = 2.0_wp
    integer :: max_steps = 0                             !< 0: no limit
    real(wp) :: progress_interval = 5.0_wp               !< wall-clock seconds
    real(wp) :: wall_limit = 0                           !< wall-clock seconds, 0: none
    character(len=DIR_LEN_MAX + 1) :: restart = ''       !< snapshot to continue from
  contains
    procedure, pass(p) :: read_group => read_run
    procedure :: value_text => run_value_text
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
    procedure, pass(p) :: read_group => read_particles
    procedure :: value_text => particles_value_text
  end type particles_params_t

  !> &physics: the fluid.
  type :: physics_params_t
    real(wp) :: rho0 = 1.0_wp
    real(wp) :: c0 = 10.0_wp
    real(wp) :: c0_exponent = 0                          !< resolution scaling of c0
    character(len=NAME_LEN) :: eos = 'linear'
    real(wp) :: gamma = 7.0_wp
  contains
    procedure, pass(p) :: read_group => read_physics
    procedure :: value_text => physics_value_text
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
    procedure, pass(p) :: read_group => read_numerics
    procedure :: value_text => numerics_value_text
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
    procedure, pass(p) :: read_group => read_output
    procedure :: value_text => output_value_text
  end type output_params_t

  !> &parallel: the domain decomposition across MPI ranks.
  type :: parallel_params_t
    character(len=NAME_LEN) :: decomposition = 'auto'
    character(len=NAME_LEN) :: balance = 'particles'
    real(wp) :: imbalance_threshold = 0.1_wp
  contains
    procedure, pass(p) :: read_group => read_parallel
    procedure :: value_text => parallel_value_text
  end type parallel_params_t

contains

  !> The allowed words of list `id` (CH_*; CH_CASE is config's, the cases').
  function word_list(id) result(list)
    integer, intent(in) :: id
    character(len=NAME_LEN), allocatable :: list(:)
    select case (id)
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
    case (CH_SYMMETRY)
      list = SYMMETRIES
    case default
      allocate(list(0))
    end select
  end function word_list

  ! One reader per group: the namelist needs local variables with the names
  ! the user writes.  Each starts from the current values, so an item
  ! changes only its own variable, and stores nothing if the read fails.

  subroutine read_run(text, p, ios, iomsg)
    character(len=*), intent(in) :: text
    class(run_params_t), intent(inout) :: p
    integer, intent(out) :: ios
    character(len=*), intent(inout) :: iomsg
    character(len=NAME_LEN) :: case
    character(len=4 * DIR_LEN_MAX) :: restart   ! wider than p%restart, as for output.dir
    real(wp) :: t_end, progress_interval, wall_limit
    integer :: max_steps
    namelist /run/ case, t_end, max_steps, progress_interval, wall_limit, restart
    case = p%case_name
    t_end = p%t_end
    max_steps = p%max_steps
    progress_interval = p%progress_interval
    wall_limit = p%wall_limit
    restart = p%restart
    read(text, nml=run, iostat=ios, iomsg=iomsg)
    if (ios /= 0) return
    p%case_name = case
    p%t_end = t_end
    p%max_steps = max_steps
    p%progress_interval = progress_interval
    p%wall_limit = wall_limit
    p%restart = restart(1:len(p%restart))
  end subroutine read_run

  subroutine read_particles(text, p, ios, iomsg)
    character(len=*), intent(in) :: text
    class(particles_params_t), intent(inout) :: p
    integer, intent(out) :: ios
    character(len=*), intent(inout) :: iomsg
    integer :: n
    character(len=NAME_LEN) :: placement
    character(len=4 * DIR_LEN_MAX) :: from   ! wider than p%from, as for output.dir
    real(wp) :: h_over_dx, n_ref, h_exponent
    integer :: pack_iterations
    character(len=NAME_LEN) :: symmetry
    namelist /particles/ n, placement, h_over_dx, n_ref, h_exponent, pack_iterations, from, &
                         symmetry
    symmetry = p%symmetry
    n = p%n
    placement = p%placement
    h_over_dx = p%h_over_dx
    n_ref = p%n_ref
    h_exponent = p%h_exponent
    pack_iterations = p%pack_iterations
    from = p%from
    read(text, nml=particles, iostat=ios, iomsg=iomsg)
    if (ios /= 0) return
    p%n = n
    p%placement = placement
    p%h_over_dx = h_over_dx
    p%n_ref = n_ref
    p%h_exponent = h_exponent
    p%pack_iterations = pack_iterations
    p%from = from(1:len(p%from))
    p%symmetry = lower(symmetry)
  end subroutine read_particles

  subroutine read_physics(text, p, ios, iomsg)
    character(len=*), intent(in) :: text
    class(physics_params_t), intent(inout) :: p
    integer, intent(out) :: ios
    character(len=*), intent(inout) :: iomsg
    real(wp) :: rho0, c0, c0_exponent, gamma
    character(len=NAME_LEN) :: eos
    namelist /physics/ rho0, c0, c0_exponent, eos, gamma
    rho0 = p%rho0
    c0 = p%c0
    c0_exponent = p%c0_exponent
    eos = p%eos
    gamma = p%gamma
    read(text, nml=physics, iostat=ios, iomsg=iomsg)
    if (ios /= 0) return
    p%rho0 = rho0
    p%c0 = c0
    p%c0_exponent = c0_exponent
    p%eos = eos
    p%gamma = gamma
  end subroutine read_physics

  subroutine read_numerics(text, p, ios, iomsg)
    character(len=*), intent(in) :: text
    class(numerics_params_t), intent(inout) :: p
    integer, intent(out) :: ios
    character(len=*), intent(inout) :: iomsg
    character(len=NAME_LEN) :: kernel, integrator, viscosity, diffusion
    character(len=NAME_LEN) :: pressure_gradient, divergence, renormalise
    real(wp) :: cfl, cfl_force, cfl_visc, alpha, alpha_exponent, delta, delta_exponent, skin
    real(wp) :: tensile_eps
    logical :: tensile, shifting, visc_reconstruction, binned_sums
    integer :: tensile_n
    namelist /numerics/ kernel, integrator, cfl, cfl_force, cfl_visc, viscosity, alpha, &
                        alpha_exponent, diffusion, delta, delta_exponent, skin, tensile, &
                        tensile_eps, tensile_n, pressure_gradient, divergence, shifting, &
                        renormalise, visc_reconstruction, binned_sums
    kernel = p%kernel
    integrator = p%integrator
    cfl = p%cfl
    cfl_force = p%cfl_force
    cfl_visc = p%cfl_visc
    viscosity = p%viscosity
    alpha = p%alpha
    alpha_exponent = p%alpha_exponent
    visc_reconstruction = p%visc_reconstruction
    diffusion = p%diffusion
    delta = p%delta
    delta_exponent = p%delta_exponent
    skin = p%skin
    tensile = p%tensile
    tensile_eps = p%tensile_eps
    tensile_n = p%tensile_n
    pressure_gradient = p%pressure_gradient
    divergence = p%divergence
    shifting = p%shifting
    renormalise = p%renormalise
    binned_sums = p%binned_sums
    read(text, nml=numerics, iostat=ios, iomsg=iomsg)
    if (ios /= 0) return
    p%kernel = kernel
    p%integrator = integrator
    p%cfl = cfl
    p%cfl_force = cfl_force
    p%cfl_visc = cfl_visc
    p%viscosity = viscosity
    p%alpha = alpha
    p%alpha_exponent = alpha_exponent
    p%visc_reconstruction = visc_reconstruction
    p%diffusion = diffusion
    p%delta = delta
    p%delta_exponent = delta_exponent
    p%skin = skin
    p%tensile = tensile
    p%tensile_eps = tensile_eps
    p%tensile_n = tensile_n
    p%pressure_gradient = pressure_gradient
    p%divergence = divergence
    p%shifting = shifting
    p%renormalise = renormalise
    p%binned_sums = binned_sums
  end subroutine read_numerics

  subroutine read_output(text, p, ios, iomsg)
    character(len=*), intent(in) :: text
    class(output_params_t), intent(inout) :: p
    integer, intent(out) :: ios
    character(len=*), intent(inout) :: iomsg
    ! Wider than p%dir so that gfortran does not warn of truncation; the
    ! extra character p%dir keeps is enough for validate to see the excess.
    character(len=4 * DIR_LEN_MAX) :: dir
    real(wp) :: dt, probes(3, MAX_PROBES)
    integer :: probe_every, n_probes
    logical :: snapshots, probe_quadratic, mirror
    namelist /output/ dir, dt, probe_every, snapshots, n_probes, probes, probe_quadratic, mirror
    mirror = p%mirror
    dir = p%dir
    dt = p%dt
    probe_every = p%probe_every
    probe_quadratic = p%probe_quadratic
    snapshots = p%snapshots
    n_probes = p%n_probes
    probes = p%probes
    read(text, nml=output, iostat=ios, iomsg=iomsg)
    if (ios /= 0) return
    p%dir = dir(1:len(p%dir))
    p%dt = dt
    p%probe_every = probe_every
    p%probe_quadratic = probe_quadratic
    p%snapshots = snapshots
    p%n_probes = n_probes
    p%probes = probes
    p%mirror = mirror
  end subroutine read_output

  subroutine read_parallel(text, p, ios, iomsg)
    character(len=*), intent(in) :: text
    class(parallel_params_t), intent(inout) :: p
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

  ! The value of each variable as namelist text that reads back exactly
  ! (output.probes has no single text: config writes it probe by probe).

  function run_value_text(p, name) result(text)
    class(run_params_t), intent(in) :: p
    character(len=*), intent(in) :: name
    character(len=:), allocatable :: text
    select case (name)
    case ('case')
      text = quoted(p%case_name)
    case ('t_end')
      text = real_str(p%t_end)
    case ('max_steps')
      text = int_str(p%max_steps)
    case ('progress_interval')
      text = real_str(p%progress_interval)
    case ('wall_limit')
      text = real_str(p%wall_limit)
    case default
      text = quoted(p%restart)
    end select
  end function run_value_text

  function particles_value_text(p, name) result(text)
    class(particles_params_t), intent(in) :: p
    character(len=*), intent(in) :: name
    character(len=:), allocatable :: text
    select case (name)
    case ('n')
      text = int_str(p%n)
    case ('placement')
      text = quoted(p%placement)
    case ('h_over_dx')
      text = real_str(p%h_over_dx)
    case ('n_ref')
      text = real_str(p%n_ref)
    case ('h_exponent')
      text = real_str(p%h_exponent)
    case ('pack_iterations')
      text = int_str(p%pack_iterations)
    case ('symmetry')
      text = quoted(p%symmetry)
    case default
      text = quoted(p%from)
    end select
  end function particles_value_text

  function physics_value_text(p, name) result(text)
    class(physics_params_t), intent(in) :: p
    character(len=*), intent(in) :: name
    character(len=:), allocatable :: text
    select case (name)
    case ('rho0')
      text = real_str(p%rho0)
    case ('c0')
      text = real_str(p%c0)
    case ('c0_exponent')
      text = real_str(p%c0_exponent)
    case ('eos')
      text = quoted(p%eos)
    case default
      text = real_str(p%gamma)
    end select
  end function physics_value_text

  function numerics_value_text(p, name) result(text)
    class(numerics_params_t), intent(in) :: p
    character(len=*), intent(in) :: name
    character(len=:), allocatable :: text
    select case (name)
    case ('kernel')
      text = quoted(p%kernel)
    case ('integrator')
      text = quoted(p%integrator)
    case ('cfl')
      text = real_str(p%cfl)
    case ('cfl_force')
      text = real_str(p%cfl_force)
    case ('cfl_visc')
      text = real_str(p%cfl_visc)
    case ('viscosity')
      text = quoted(p%viscosity)
    case ('alpha')
      text = real_str(p%alpha)
    case ('alpha_exponent')
      text = real_str(p%alpha_exponent)
    case ('visc_reconstruction')
      text = logical_text(p%visc_reconstruction)
    case ('binned_sums')
      text = logical_text(p%binned_sums)
    case ('diffusion')
      text = quoted(p%diffusion)
    case ('delta')
      text = real_str(p%delta)
    case ('delta_exponent')
      text = real_str(p%delta_exponent)
    case ('skin')
      text = real_str(p%skin)
    case ('tensile')
      text = logical_text(p%tensile)
    case ('tensile_eps')
      text = real_str(p%tensile_eps)
    case ('tensile_n')
      text = int_str(p%tensile_n)
    case ('pressure_gradient')
      text = quoted(p%pressure_gradient)
    case ('renormalise')
      text = quoted(p%renormalise)
    case ('divergence')
      text = quoted(p%divergence)
    case default
      text = logical_text(p%shifting)
    end select
  end function numerics_value_text

  function output_value_text(p, name) result(text)
    class(output_params_t), intent(in) :: p
    character(len=*), intent(in) :: name
    character(len=:), allocatable :: text
    select case (name)
    case ('dir')
      text = quoted(p%dir)
    case ('dt')
      text = real_str(p%dt)
    case ('probe_every')
      text = int_str(p%probe_every)
    case ('probe_quadratic')
      text = logical_text(p%probe_quadratic)
    case ('snapshots')
      text = logical_text(p%snapshots)
    case ('mirror')
      text = logical_text(p%mirror)
    case ('n_probes')
      text = int_str(p%n_probes)
    case ('probes')
      ! all of them, in array element order
      text = real_list(reshape(p%probes, [size(p%probes)]))
    case default
      text = ''
    end select
  end function output_value_text

  function parallel_value_text(p, name) result(text)
    class(parallel_params_t), intent(in) :: p
    character(len=*), intent(in) :: name
    character(len=:), allocatable :: text
    select case (name)
    case ('decomposition')
      text = quoted(p%decomposition)
    case ('balance')
      text = quoted(p%balance)
    case default
      text = real_str(p%imbalance_threshold)
    end select
  end function parallel_value_text

  function logical_text(l) result(text)
    logical, intent(in) :: l
    character(len=:), allocatable :: text
    text = trim(merge('.true. ', '.false.', l))
  end function logical_text

end module input_params
