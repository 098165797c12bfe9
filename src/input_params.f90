!> The parameters of the generic namelist groups (doc/input.md): one
!> derived type per group, every component at its default.  config reads
!> them; the cases see the groups they need (case_base).  A case's own group
!> lives in the case's module.
module input_params
  use kinds, only: wp
  implicit none
  private
  public :: run_params_t, particles_params_t, physics_params_t, numerics_params_t, &
            output_params_t, parallel_params_t, NAME_LEN, DIR_LEN_MAX, MAX_PROBES

  integer, parameter :: NAME_LEN = 32      !< length of the word-valued variables
  integer, parameter :: DIR_LEN_MAX = 255  !< longest output.dir allowed
  integer, parameter :: MAX_PROBES = 16    !< size of output.probes(3, :)

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

  !> &parallel: the domain decomposition across MPI ranks.
  type :: parallel_params_t
    character(len=NAME_LEN) :: decomposition = 'slab'
    character(len=NAME_LEN) :: balance = 'particles'
    real(wp) :: imbalance_threshold = 0.1_wp
  end type parallel_params_t

end module input_params
