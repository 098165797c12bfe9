!> The parameters of the generic namelist groups (doc/input.md): one
!> derived type per group, every component at its default, with its reader
!> and its values as text (the same two procedures a case gives for its own
!> group, case_base).  The cases see the groups they need.
module input_params
  use kinds, only: wp
  use input_text, only: quoted, real_str, int_str, lower
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
  contains
    procedure, pass(p) :: read_group => read_run
    procedure :: value_text => run_value_text
  end type run_params_t

  !> &particles: the initial layout.
  type :: particles_params_t
    integer :: n = 20000                                 !< approximate count
    character(len=NAME_LEN) :: placement = 'rings'
    real(wp) :: h_over_dx = 2.0_wp
    integer :: pack_iterations = 300                     !< doc/packing.md
    character(len=DIR_LEN_MAX + 1) :: from = ''          !< snapshot of a packed distribution
  contains
    procedure, pass(p) :: read_group => read_particles
    procedure :: value_text => particles_value_text
  end type particles_params_t

  !> &physics: the fluid.
  type :: physics_params_t
    real(wp) :: rho0 = 1.0_wp
    real(wp) :: c0 = 10.0_wp
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
    logical :: snapshots = .true.
    integer :: n_probes = 1
    real(wp) :: probes(3, MAX_PROBES) = 0.0_wp           !< probe k at probes(:, k)
  contains
    procedure, pass(p) :: read_group => read_output
    procedure :: value_text => output_value_text
  end type output_params_t

  !> &parallel: the domain decomposition across MPI ranks.
  type :: parallel_params_t
    character(len=NAME_LEN) :: decomposition = 'slab'
    character(len=NAME_LEN) :: balance = 'particles'
    real(wp) :: imbalance_threshold = 0.1_wp
  contains
    procedure, pass(p) :: read_group => read_parallel
    procedure :: value_text => parallel_value_text
  end type parallel_params_t

contains

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
    class(particles_params_t), intent(inout) :: p
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
    class(physics_params_t), intent(inout) :: p
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
    class(numerics_params_t), intent(inout) :: p
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
    class(output_params_t), intent(inout) :: p
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
    case ('pack_iterations')
      text = int_str(p%pack_iterations)
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
    case ('diffusion')
      text = quoted(p%diffusion)
    case ('delta')
      text = real_str(p%delta)
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
    case ('snapshots')
      text = logical_text(p%snapshots)
    case ('n_probes')
      text = int_str(p%n_probes)
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
