!> config against real files: the defaults and the echo read back exactly,
!> overrides of every type win over the file, the namelist features a user
!> may write are understood, the shipped inputs load, and a table of bad
!> inputs each fail with their own message naming group, variable and value.
!>
!> Files go to a scratch directory made by mkdtemp (unique per rank and per
!> run, so concurrent runs do not collide) and are deleted after each use;
!> the last test checks the directory is empty by removing it.
module test_config
  use, intrinsic :: iso_c_binding, only: c_char, c_int, c_ptr, c_null_char, c_associated
  use kinds, only: wp
  use config, only: config_t, config_load, config_write_defaults, config_echo, config_dim, &
                    MAX_PROBES
  use testing, only: run_test, assert_true, assert_equal, test_comm
  use mpi_f08, only: MPI_Comm_rank
  implicit none
  private
  public :: suite_config

  interface
    function c_mkdtemp(template) bind(c, name='mkdtemp') result(p)
      import :: c_char, c_ptr
      character(kind=c_char), intent(inout) :: template(*)
      type(c_ptr) :: p
    end function c_mkdtemp
    function c_rmdir(path) bind(c, name='rmdir') result(r)
      import :: c_char, c_int
      character(kind=c_char), intent(in) :: path(*)
      integer(c_int) :: r
    end function c_rmdir
  end interface

  character(len=:), allocatable, save :: scratch   !< this rank's scratch directory
  character(len=*), parameter :: NO_FILE = '<no file>'

contains

  subroutine suite_config()
    call make_scratch()
    call run_test('config', 'defaults_round_trip', defaults_round_trip)
    call run_test('config', 'echo_round_trip', echo_round_trip)
    call run_test('config', 'overrides_win_over_file', overrides_win_over_file)
    call run_test('config', 'namelist_features', namelist_features)
    call run_test('config', 'shipped_inputs_load', shipped_inputs_load)
    call run_test('config', 'bad_inputs', bad_inputs)
    call run_test('config', 'scratch_left_empty', scratch_left_empty)
  end subroutine suite_config

  ! ------------------------------------------------------------------------

  !> config_write_defaults -> config_load gives config_t(); every variable
  !> line carries a comment saying what is allowed.
  subroutine defaults_round_trip()
    type(config_t) :: cfg
    logical :: ok
    character(len=:), allocatable :: msg, path
    character(len=1000) :: line
    integer :: u, ios, nvars, ncommented

    path = scratch // '/defaults.nml'
    open(newunit=u, file=path, status='replace', action='write')
    call config_write_defaults(u)
    close(u)
    call config_load(path, [character(len=1) ::], cfg, ok, msg)
    call assert_true(ok, 'defaults file loads: ' // msg)
    call assert_equal('', msg, 'no message when ok')
    call check_same(config_t(), cfg, 'defaults')
    call assert_equal(2, config_dim(cfg), 'the default case is 2D')

    nvars = 0
    ncommented = 0
    open(newunit=u, file=path, status='old', action='read')
    do
      read(u, '(a)', iostat=ios) line
      if (ios /= 0) exit
      line = adjustl(line)
      if (line(1:1) == '!' .or. line(1:1) == '&' .or. line(1:1) == '/') cycle
      if (index(line, ' = ') == 0) cycle
      nvars = nvars + 1
      if (index(line, '! ') > 0 .and. index(line, '(allowed: ') > 0) ncommented = ncommented + 1
    end do
    close(u, status='delete')
    ! 43 variables, probes written once (probe 1, as n_probes = 1)
    call assert_equal(50, nvars, 'variable lines in the defaults file')
    call assert_equal(nvars, ncommented, 'variable lines with a comment saying what is allowed')
  end subroutine defaults_round_trip

  !> A configuration with every value changed (awkward reals, a quote and a
  !> '!' in a string, probes beyond n_probes) echoes and reads back bit for
  !> bit; so does a second echo of what was read.
  subroutine echo_round_trip()
    type(config_t) :: c, back, again
    logical :: ok
    character(len=:), allocatable :: msg, path

    c%run%case_name = 'ellipsoid3d'
    c%run%t_end = 1.0_wp / 3
    c%run%max_steps = 123
    c%run%progress_interval = 0.7_wp
    c%particles%n = 123457
    c%particles%placement = 'packed'
    c%particles%h_over_dx = 1.3_wp
    c%particles%pack_iterations = 77
    c%physics%rho0 = 1000.0_wp
    c%physics%c0 = 20.0_wp / 3    ! >= 3 * max|rates| a0 radius = 5.46
    c%physics%eos = 'tait'
    c%physics%gamma = 7.5_wp
    c%numerics%kernel = 'gaussian'
    c%numerics%integrator = 'pc2'
    c%numerics%cfl = 0.1_wp + 0.2_wp  ! 0.30000000000000004
    c%numerics%cfl_force = 1.0e-3_wp
    c%numerics%cfl_visc = 0.2_wp
    c%numerics%viscosity = 'monaghan'
    c%numerics%alpha = 0.0_wp
    c%numerics%diffusion = 'antuono'
    c%numerics%delta = 1.0_wp
    c%numerics%skin = 2.0_wp
    c%numerics%tensile = .true.
    c%numerics%tensile_eps = 0.15_wp
    c%numerics%tensile_n = 3
    c%numerics%pressure_gradient = 'higher_order'
    c%numerics%divergence = 'renormalised'
    c%numerics%renormalise = 'step'
    c%numerics%shifting = .true.
    c%output%dir = 'runs/it''s!a test'
    c%output%dt = 1.0e-5_wp
    c%output%probe_every = 3
    c%output%snapshots = .false.
    c%output%n_probes = 2
    c%output%probes(:, 1) = [0.1_wp, -0.2_wp, 0.3_wp]
    c%output%probes(:, 2) = [1.0_wp / 3, 0.0_wp, 0.0_wp]
    c%output%probes(:, 5) = [1.0e-300_wp, 1.0e20_wp, -1.0_wp / 7]
    c%circle2d%radius = 2.5_wp
    c%circle2d%a0 = 0.5_wp
    c%ellipsoid3d%radius = 0.7_wp
    c%ellipsoid3d%a0 = 1.3_wp
    c%ellipsoid3d%rates = [0.5_wp, 1.5_wp, -2.0_wp]
    c%ellipsoid3d%prepared = .true.
    c%square_rotation%side = 2.0_wp / 3
    c%square_rotation%omega = 0.25_wp
    c%square_vortical%side = 1.0e-3_wp
    c%square_vortical%v0 = 0.1_wp
    c%parallel%decomposition = 'metis'
    c%parallel%balance = 'pairs'
    c%parallel%imbalance_threshold = 1.0_wp / 3

    path = scratch // '/echo.nml'
    c%run%restart = path          ! any existing file passes the validation
    c%particles%from = path
    call echo_to(c, path)
    call config_load(path, [character(len=1) ::], back, ok, msg)
    call assert_true(ok, 'echo loads: ' // msg)
    call check_same(c, back, 'echo')
    call assert_equal(3, config_dim(back), 'ellipsoid3d is 3D')
    call echo_to(back, path)
    call config_load(path, [character(len=1) ::], again, ok, msg)
    call assert_true(ok, 'second echo loads: ' // msg)
    call check_same(c, again, 'second echo')
    call delete_file(path)
  end subroutine echo_round_trip

  !> Overrides of each type take effect, win over the file, apply in order,
  !> and work for groups the file does not have.
  subroutine overrides_win_over_file()
    type(config_t) :: c
    logical :: ok
    character(len=:), allocatable :: msg
    call load('&numerics cfl = 0.5, kernel = ''gaussian'', skin = 0.5 /|' // &
              '&particles n = 1000 /|' // &
              '&output dir = ''runs/file'', snapshots = .true., probes(1,2) = 0.25 /', &
              [character(len=40) :: &
               'numerics.cfl=0.75', &                  ! real
               'particles.n=5000', &                   ! integer
               'numerics.kernel=''cubic_spline''', &   ! string with quotes
               'numerics.integrator=pc2', &            ! string without quotes
               'output.dir=runs/x/y', &                ! string with '/', no quotes
               'output.snapshots=.false.', &           ! logical
               'output.probes(1,2)=0.5', &             ! array element
               'output.probes(2,2)=-0.125', &
               'ellipsoid3d.rates=2,-1,-1', &          ! whole array, group not in file
               'circle2d.a0=2', &                      ! group not in file
               'NUMERICS.Alpha=0.02', &                ! names in any case
               'numerics.delta=0.2', &
               'numerics.delta=0.3', &                 ! the last one wins
               'run.max_steps=7'], c, ok, msg)
    call assert_true(ok, 'loads: ' // msg)
    call assert_equal(0.75_wp, c%numerics%cfl, 0.0_wp, 'real override')
    call assert_equal(5000, c%particles%n, 'integer override')
    call assert_equal('cubic_spline', trim(c%numerics%kernel), 'quoted string override')
    call assert_equal('pc2', trim(c%numerics%integrator), 'unquoted string override')
    call assert_equal('runs/x/y', trim(c%output%dir), 'unquoted path override')
    call assert_true(.not. c%output%snapshots, 'logical override')
    call assert_equal([0.5_wp, -0.125_wp, 0.0_wp], c%output%probes(:, 2), 0.0_wp, &
                      'array element overrides')
    call assert_equal([2.0_wp, -1.0_wp, -1.0_wp], c%ellipsoid3d%rates, 0.0_wp, &
                      'whole array override')
    call assert_equal(2.0_wp, c%circle2d%a0, 0.0_wp, 'override of a group not in the file')
    call assert_equal(0.02_wp, c%numerics%alpha, 0.0_wp, 'override in upper case')
    call assert_equal(0.3_wp, c%numerics%delta, 0.0_wp, 'the last override wins')
    call assert_equal(7, c%run%max_steps, 'integer override of a group not in the file')
    call assert_equal(0.5_wp, c%numerics%skin, 0.0_wp, 'file value not overridden')
  end subroutine overrides_win_over_file

  !> Comments (also after values and inside a group), '!' inside quotes,
  !> names in any case, words normalised to lower case, values over several
  !> lines, repeat counts, array sections, ';' separators, tabs, a last
  !> line without a newline, &end as terminator, and missing groups.
  subroutine namelist_features()
    type(config_t) :: c
    logical :: ok
    character(len=:), allocatable :: msg
    call load('! a header|   ! an indented comment||' // &
              '&NUMERICS          ! upper-case group|' // &
              '  CFL = 0.5,  Kernel = ''Gaussian''   ! mixed case|' // &
              '  alpha = 0.02;' // achar(9) // 'delta = 0.2|' // &
              '/|' // &
              '&output|' // &
              '  dir = "runs/a!b"   ! "!" in quotes is no comment|' // &
              '  probes(1:3,1) = 0.1,|' // &
              '                  0.2,   ! a value list over lines|' // &
              '                  0.3|' // &
              '  probes(:,2) = 3*0.5, n_probes = 2|' // &
              '&end|' // &
              '&run case = ''ellipsoid3d'' /', &
              [character(len=1) ::], c, ok, msg)
    call assert_true(ok, 'loads: ' // msg)
    call assert_equal(0.5_wp, c%numerics%cfl, 0.0_wp, 'upper-case name')
    call assert_equal('gaussian', trim(c%numerics%kernel), 'word in lower case')
    call assert_equal(0.02_wp, c%numerics%alpha, 0.0_wp, 'before ;')
    call assert_equal(0.2_wp, c%numerics%delta, 0.0_wp, 'after ; and a tab')
    call assert_equal('runs/a!b', trim(c%output%dir), '! inside quotes')
    call assert_equal([0.1_wp, 0.2_wp, 0.3_wp], c%output%probes(:, 1), 0.0_wp, &
                      'values over lines')
    call assert_equal([0.5_wp, 0.5_wp, 0.5_wp], c%output%probes(:, 2), 0.0_wp, 'repeat count')
    call assert_equal(2, c%output%n_probes, 'after an array section')
    call assert_equal('ellipsoid3d', trim(c%run%case_name), 'after &end, last line')
    call assert_equal(20000, c%particles%n, 'missing group: default')
    call assert_equal(3, config_dim(c), 'dimension of the case')
  end subroutine namelist_features

  !> input/circle2d.nml and input/ellipsoid3d.nml (relative to the
  !> repository root, where the tests run) load with the intended values.
  subroutine shipped_inputs_load()
    type(config_t) :: c
    logical :: ok
    character(len=:), allocatable :: msg
    call config_load('input/circle2d.nml', [character(len=1) ::], c, ok, msg)
    call assert_true(ok, 'input/circle2d.nml: ' // msg)
    call assert_equal('circle2d', trim(c%run%case_name), 'circle2d case')
    call assert_equal(2, config_dim(c), 'circle2d is 2D')
    call assert_equal(20000, c%particles%n, 'circle2d n')
    call assert_equal(2.0_wp, c%run%t_end, 0.0_wp, 'circle2d t_end')
    call assert_equal('runs/circle2d', trim(c%output%dir), 'circle2d dir')
    call assert_equal(0.1_wp, c%output%dt, 0.0_wp, 'circle2d output.dt')

    call config_load('input/ellipsoid3d.nml', [character(len=1) ::], c, ok, msg)
    call assert_true(ok, 'input/ellipsoid3d.nml: ' // msg)
    call assert_equal('ellipsoid3d', trim(c%run%case_name), 'ellipsoid3d case')
    call assert_equal(3, config_dim(c), 'ellipsoid3d is 3D')
    call assert_equal(1000000, c%particles%n, 'ellipsoid3d n')
    call assert_equal(1.0_wp, c%run%t_end, 0.0_wp, 'ellipsoid3d t_end')
    call assert_equal('runs/ellipsoid3d', trim(c%output%dir), 'ellipsoid3d dir')
    call assert_equal(0.1_wp, c%output%dt, 0.0_wp, 'ellipsoid3d output.dt')
    call assert_equal([-1.0_wp, -1.0_wp, 2.0_wp], c%ellipsoid3d%rates, 0.0_wp, &
                      'ellipsoid3d rates')

    ! the paper's c0 = 7 omega L (f0 = c0/(sqrt(2) L) = 4.95 omega), t omega = 4
    call config_load('input/square_rotation.nml', [character(len=1) ::], c, ok, msg)
    call assert_true(ok, 'input/square_rotation.nml: ' // msg)
    call assert_equal('square_rotation', trim(c%run%case_name), 'square_rotation case')
    call assert_equal(2, config_dim(c), 'square_rotation is 2D')
    call assert_equal(7.0_wp, c%physics%c0 / (c%square_rotation%omega * c%square_rotation%side), &
                      1e-12_wp, 'square_rotation c0 = 7 omega L')
    call assert_true(c%run%t_end * c%square_rotation%omega >= 4, 'square_rotation t omega >= 4')
    call assert_true(c%numerics%shifting .and. .not. c%numerics%tensile, &
                     'square_rotation keeps its particles regular by shifting')
    call assert_true(c%output%n_probes >= 1 .and. all(abs(c%output%probes(:, 1)) <= 0), &
                     'square_rotation probe 1 at the centre A')

    ! t V0/L = 1.5, snapshots at 0.4 and 1.5 (the paper's Figure 5)
    call config_load('input/square_vortical.nml', [character(len=1) ::], c, ok, msg)
    call assert_true(ok, 'input/square_vortical.nml: ' // msg)
    call assert_equal('square_vortical', trim(c%run%case_name), 'square_vortical case')
    call assert_true(c%run%t_end * c%square_vortical%v0 / c%square_vortical%side >= 1.5_wp, &
                     'square_vortical t V0/L >= 1.5')
    call assert_equal(0.0_wp, modulo(0.4_wp / c%output%dt + 0.5_wp, 1.0_wp) - 0.5_wp, 1e-9_wp, &
                      'square_vortical: a snapshot at t V0/L = 0.4')
  end subroutine shipped_inputs_load

  !> Each bad input fails with one line naming where (file or command line),
  !> the group, the variable, the value and what is allowed.
  subroutine bad_inputs()
    character(len=*), parameter :: F = 'file', CL = 'command line'
    character(len=1), parameter :: NONE(0) = [character(len=1) ::]
    character(len=:), allocatable :: long
    ! unknown names
    call expect_error(F, '&numerics|  cfll = 1.0|/', NONE, [character(len=80) :: &
      "&numerics has no variable 'cfll' (line 2)", "did you mean 'cfl'?", 'cfl_force'])
    call expect_error(F, '&numerix cfl = 1.0 /', NONE, [character(len=80) :: &
      'unknown namelist group &numerix (line 1)', 'did you mean &numerics?', '&ellipsoid3d'])
    call expect_error(F, '&run tend = 1.0 /', NONE, [character(len=80) :: &
      "&run has no variable 'tend'", "did you mean 't_end'?"])
    ! wrong types
    call expect_error(F, '&particles n = 1.5e4 /', NONE, [character(len=80) :: &
      '&particles n = 1.5e4 cannot be read as an integer', 'e.g. 15000'])
    call expect_error(F, '&particles n = ''abc'' /', NONE, [character(len=80) :: &
      '&particles n = ''abc'' cannot be read as an integer'])
    call expect_error(F, '&numerics cfl = abc /', NONE, [character(len=80) :: &
      '&numerics cfl = abc cannot be read as a real number'])
    call expect_error(F, '&particles n = 3000000000 /', NONE, [character(len=80) :: &
      '&particles n = 3000000000 cannot be read as an integer', 'too large', &
      '50 <= n <= 2000000000'])
    call expect_error(F, '&output snapshots = yes /', NONE, [character(len=80) :: &
      '&output snapshots = yes cannot be read as a logical', '.true. or .false.'])
    call expect_error(F, '&numerics kernel = gaussian /', NONE, [character(len=80) :: &
      '&numerics kernel = gaussian cannot be read as a string', 'kernel = ''gaussian'''])
    call expect_error(F, '&output dir = runs/x /', NONE, [character(len=80) :: &
      '&output dir = runs cannot be read as a string', 'quotes'])
    ! out of range, one per kind of bound
    call expect_error(F, '&numerics cfl = -1.0 /', NONE, [character(len=80) :: &
      '&numerics cfl = -1.0 is out of range (line 1): allowed 0 < cfl <= 3'])
    call expect_error(F, '&particles n = 10 /', NONE, [character(len=80) :: &
      '&particles n = 10 is out of range', 'allowed 50 <= n <= 2000000000'])
    call expect_error(F, '&particles h_over_dx = 5.0 /', NONE, [character(len=80) :: &
      '&particles h_over_dx = 5.0 is out of range', 'allowed 1 <= h_over_dx <= 4'])
    call expect_error(CL, '', [character(len=40) :: 'numerics.alpha=1.5'], &
      [character(len=80) :: '&numerics alpha = 1.5 is out of range', 'allowed 0 <= alpha <= 1'])
    call expect_error(F, '&output n_probes = 17 /', NONE, [character(len=80) :: &
      '&output n_probes = 17 is out of range', 'allowed 0 <= n_probes <= 16'])
    call expect_error(F, '&run t_end = 0 /', NONE, [character(len=80) :: &
      '&run t_end = 0.0 is out of range', 'allowed t_end > 0'])
    call expect_error(CL, '&output dt = 1.0 /', [character(len=40) :: 'output.dt=-0.1'], &
      [character(len=80) :: '&output dt = -0.1 is out of range', 'allowed dt > 0'])
    call expect_error(F, '&physics gamma = 0.5 /', NONE, [character(len=80) :: &
      '&physics gamma = 0.5 is out of range', 'allowed gamma >= 1'])
    call expect_error(F, '&run max_steps = -5 /', NONE, [character(len=80) :: &
      '&run max_steps = -5 is out of range', 'allowed max_steps >= 0'])
    call expect_error(F, '&numerics cfl = nan /', NONE, [character(len=80) :: &
      '&numerics cfl = NaN is out of range'])
    call expect_error(F, '&output probes(1,2) = inf /', NONE, [character(len=80) :: &
      '&output probes(1:3,2) = Infinity, 0.0, 0.0 is not a finite position'])
    ! words not in the list
    call expect_error(F, '&numerics kernel = ''wendlnd'' /', NONE, [character(len=80) :: &
      "&numerics kernel = 'wendlnd' is not allowed", &
      "choose one of 'wendland_c2', 'cubic_spline', 'gaussian'"])
    call expect_error(F, '&physics eos = ''tate'' /', NONE, [character(len=80) :: &
      "&physics eos = 'tate' is not allowed", "choose one of 'linear', 'tait'"])
    call expect_error(CL, '', [character(len=40) :: 'run.case=square'], [character(len=80) :: &
      "&run case = 'square' is not allowed", "choose one of 'circle2d', 'ellipsoid3d', " // &
      "'square_rotation', 'square_vortical'"])
    call expect_error(F, '&numerics tensile_eps = 0 /', NONE, [character(len=80) :: &
      '&numerics tensile_eps = 0.0 is out of range', 'allowed 0 < tensile_eps <= 1'])
    call expect_error(CL, '', [character(len=40) :: 'numerics.tensile_n=0'], &
      [character(len=80) :: '&numerics tensile_n = 0 is out of range', &
      'allowed 1 <= tensile_n <= 8'])
    call expect_error(F, '&numerics tensile = 1 /', NONE, [character(len=80) :: &
      '&numerics tensile = 1 cannot be read as a logical', '.true. or .false.'])
    call expect_error(CL, '', [character(len=40) :: 'numerics.pressure_gradient=high'], &
      [character(len=80) :: "&numerics pressure_gradient = 'high' is not allowed", &
      "choose one of 'standard', 'higher_order'"])
    call expect_error(F, '&numerics shifting = yes /', NONE, [character(len=80) :: &
      '&numerics shifting = yes cannot be read as a logical', '.true. or .false.'])
    call expect_error(F, '&square_rotation side = -1 /', NONE, [character(len=80) :: &
      '&square_rotation side = -1.0 is out of range', 'allowed side > 0'])
    call expect_error(F, '&square_vortical v0 = 0 /', NONE, [character(len=80) :: &
      '&square_vortical v0 = 0.0 is out of range', 'allowed v0 > 0'])
    call expect_error(F, '&square_rotaton omega = 2 /', NONE, [character(len=80) :: &
      'unknown namelist group &square_rotaton', 'did you mean &square_rotation?'])
    ! consistency between values
    call expect_error(F, '&run case = ''ellipsoid3d'' /|&ellipsoid3d rates = -1.0, -1.0, 1.0 /', &
      NONE, [character(len=80) :: &
      '&ellipsoid3d rates = -1.0, -1.0, 1.0 sum to -1.0 (line 2)', 'must sum to zero'])
    call expect_error(F, '&particles from = ''echo.nml'' /', NONE, [character(len=80) :: &
      '&particles from = ''echo.nml'' does not exist', 'placement = ''packed'''])
    call expect_error(F, '&particles from = ''Makefile'' /', NONE, [character(len=80) :: &
      '&particles from = ''Makefile'' needs placement = ''packed'''])
    call expect_error(F, '&particles placement = ''packed'', pack_iterations = 0 /', NONE, &
      [character(len=80) :: '&particles pack_iterations = 0 is out of range', &
      'allowed 1 <= pack_iterations <= 100000'])
    call expect_error(F, '&run case = ''square_rotation'' /|&particles placement = ''packed'' /', &
      NONE, [character(len=80) :: '&particles placement = ''packed'' is not available for ' // &
      'square_rotation', 'the square patches are always on a lattice'])
    call expect_error(F, '&ellipsoid3d rates = 0, 0, 0 /', NONE, [character(len=80) :: &
      '&ellipsoid3d rates = 0.0, 0.0, 0.0 are all zero'])
    call expect_error(F, '&physics c0 = 2.0 /', NONE, [character(len=80) :: &
      "&physics c0 = 2.0 is too small for case 'circle2d'", 'allowed c0 >= 3 max|u0| = 3.0'])
    call expect_error(F, '&physics c0 = 5.0 /', [character(len=40) :: 'run.case=ellipsoid3d'], &
      [character(len=80) :: "&physics c0 = 5.0 is too small for case 'ellipsoid3d'", &
      'allowed c0 >= 3 max|u0| = 6.0'])
    ! omega L/sqrt(2) = 2 sqrt(2) at the corners: c0 >= 6 sqrt(2) = 8.485...
    call expect_error(CL, '&run case = ''square_rotation'' /|&square_rotation omega = 4 /', &
      [character(len=40) :: 'physics.c0=8'], [character(len=80) :: &
      "&physics c0 = 8.0 is too small for case 'square_rotation'", &
      'allowed c0 >= 3 max|u0| = 8.48528137423857', '&square_rotation omega side/sqrt(2)'])
    call expect_error(F, '&run case = ''square_vortical'' /|&physics c0 = 4 /', NONE, &
      [character(len=80) :: "&physics c0 = 4.0 is too small for case 'square_vortical' (line 2)", &
      'allowed c0 >= 3 max|u0| = 4.16', 'sqrt(2) (1 - e^-4) v0'])
    call expect_error(CL, '', [character(len=40) :: 'output.dir='''''], [character(len=80) :: &
      "&output dir = '' is empty"])
    long = 'output.dir=' // repeat('a', 300)
    call expect_error(CL, '', [long], [character(len=80) :: &
      "&output dir = 'aaaa", 'is too long', 'at most 255 characters'])
    ! the file itself
    call expect_error(F, NO_FILE, NONE, [character(len=80) :: &
      'missing.nml: cannot open the file: No such file or directory'])
    call expect_error(F, '&numerics cfl = 1.0 /|&physics /|&numerics delta = 0.2 /', NONE, &
      [character(len=80) :: '&numerics appears twice (line 3)', 'already appeared on line 1'])
    call expect_error(F, '&numerics cfl = 1.0|&physics c0 = 20 /', NONE, [character(len=80) :: &
      '&numerics is not closed (line 1)', 'before &physics on line 2'])
    call expect_error(F, 'numerics cfl = 1.0 /', NONE, [character(len=80) :: &
      "text 'numerics' outside any namelist group (line 1)"])
    call expect_error(F, '&output dir = ''runs/x /', NONE, [character(len=80) :: &
      'a quoted string is not closed (line 1)'])
    call expect_error(F, '&numerics|cfl = 1.0,|cfl = 2.0 /', NONE, [character(len=80) :: &
      '&numerics cfl is set twice (line 3)', 'already set on line 2'])
    call expect_error(F, '&numerics cfl 5 /', NONE, [character(len=80) :: &
      "&numerics: 'cfl 5' is not of the form name = value"])
    call expect_error(F, '&numerics cfl = /', NONE, [character(len=80) :: &
      '&numerics cfl has no value', 'default (1.5)'])
    ! malformed overrides
    call expect_error(CL, '', [character(len=40) :: 'numerics.cfl'], [character(len=80) :: &
      "override 'numerics.cfl' has no '=value'"])
    call expect_error(CL, '&numerics cfl = 1.0 /', [character(len=40) :: 'numerics.cfl=abc'], &
      [character(len=80) :: 'numerics.cfl=abc cannot be read as a real number'])
    call expect_error(CL, '', [character(len=40) :: 'cfl=0.5'], [character(len=80) :: &
      "override 'cfl=0.5' does not name a group", 'e.g. numerics.cfl=0.5'])
    call expect_error(CL, '', [character(len=40) :: 'numerix.cfl=0.5'], [character(len=80) :: &
      "override 'numerix.cfl=0.5': unknown namelist group &numerix", 'did you mean &numerics?'])
    call expect_error(CL, '', [character(len=40) :: 'numerics.cfll=0.5'], [character(len=80) :: &
      "override 'numerics.cfll=0.5': &numerics has no variable 'cfll'"])
    call expect_error(CL, '', [character(len=40) :: 'numerics.cfl='], [character(len=80) :: &
      'numerics.cfl= has no value'])
    call expect_error(CL, '', [character(len=40) :: 'numerics.cfl=0.5 kernel=''x'''], &
      [character(len=80) :: "override 'numerics.cfl=0.5 kernel='x'' sets more than one variable"])
    call expect_error(CL, '', [character(len=40) :: 'numerics.cfl=1/2'], [character(len=80) :: &
      'numerics.cfl=1/2 cannot be read as a real number', '''/'' outside quotes'])
    call expect_error(CL, '', [character(len=40) :: 'output.probes(1,17)=1'], &
      [character(len=80) :: 'output.probes(1,17)=1 has an index outside probes(1:3, 1:16)'])
    call expect_error(CL, '', [character(len=40) :: 'particles.n(1)=100'], &
      [character(len=80) :: 'particles.n(1)=100 has an index, but n is not an array'])
    call expect_error(CL, '', [character(len=40) :: 'ellipsoid3d.rates=1,2,-3,4'], &
      [character(len=80) :: 'ellipsoid3d.rates=1,2,-3,4 cannot be read as real numbers', &
      'rates(1:3)'])
  end subroutine bad_inputs

  !> Every file the tests wrote has been deleted: the directory can go.
  subroutine scratch_left_empty()
    call assert_equal(0, int(c_rmdir(scratch // c_null_char)), &
                      'rmdir ' // scratch // ' (files left behind?)')
  end subroutine scratch_left_empty

  ! ------------------------------------------------------------------------
  ! Helpers
  ! ------------------------------------------------------------------------

  !> Writes `text` (lines separated by '|'; NO_FILE for none) as in.nml,
  !> loads it with the overrides, deletes it.
  subroutine load(text, overrides, cfg, ok, msg, path)
    character(len=*), intent(in) :: text
    character(len=*), intent(in) :: overrides(:)
    type(config_t), intent(out) :: cfg
    logical, intent(out) :: ok
    character(len=:), allocatable, intent(out) :: msg
    character(len=:), allocatable, intent(out), optional :: path
    character(len=:), allocatable :: p
    integer :: u, start, bar
    if (text == NO_FILE) then
      p = scratch // '/missing.nml'
      call config_load(p, overrides, cfg, ok, msg)
    else
      p = scratch // '/in.nml'
      open(newunit=u, file=p, status='replace', action='write')
      start = 1
      do
        bar = index(text(start:), '|')
        if (bar == 0) exit
        write(u, '(a)') text(start:start + bar - 2)
        start = start + bar
      end do
      write(u, '(a)', advance='no') text(start:)   ! the last line without a newline
      close(u)
      call config_load(p, overrides, cfg, ok, msg)
      call delete_file(p)
    end if
    if (present(path)) path = p
  end subroutine load

  !> Loading `text` with the overrides must fail with one line that starts
  !> with its origin (the file's path, or 'command line') and contains each
  !> of the expected pieces.
  subroutine expect_error(origin, text, overrides, expected)
    character(len=*), intent(in) :: origin, text
    character(len=*), intent(in) :: overrides(:), expected(:)
    type(config_t) :: cfg
    logical :: ok
    character(len=:), allocatable :: msg, path, prefix
    integer :: k
    call load(text, overrides, cfg, ok, msg, path)
    call assert_true(.not. ok, trim(expected(1)) // ': should have failed')
    if (ok) return
    prefix = 'command line: '
    if (origin == 'file') prefix = path // ': '
    call assert_true(index(msg, prefix) == 1, 'message starts with "' // prefix // '": ' // msg)
    call assert_true(index(msg, new_line('a')) == 0, 'message is one line: ' // msg)
    do k = 1, size(expected)
      call assert_true(index(msg, trim(expected(k))) > 0, &
                       'message contains "' // trim(expected(k)) // '": ' // msg)
    end do
  end subroutine expect_error

  !> Every component of a equals that of e exactly.
  subroutine check_same(e, a, label)
    type(config_t), intent(in) :: e, a
    character(len=*), intent(in) :: label
    character(len=:), allocatable :: l
    l = label // ': '
    call assert_equal(trim(e%run%case_name), trim(a%run%case_name), l // 'run.case')
    call assert_equal(e%run%t_end, a%run%t_end, 0.0_wp, l // 'run.t_end')
    call assert_equal(e%run%max_steps, a%run%max_steps, l // 'run.max_steps')
    call assert_equal(e%run%progress_interval, a%run%progress_interval, 0.0_wp, &
                      l // 'run.progress_interval')
    call assert_equal(e%particles%n, a%particles%n, l // 'particles.n')
    call assert_equal(trim(e%particles%placement), trim(a%particles%placement), &
                      l // 'particles.placement')
    call assert_equal(e%particles%h_over_dx, a%particles%h_over_dx, 0.0_wp, &
                      l // 'particles.h_over_dx')
    call assert_equal(e%physics%rho0, a%physics%rho0, 0.0_wp, l // 'physics.rho0')
    call assert_equal(e%physics%c0, a%physics%c0, 0.0_wp, l // 'physics.c0')
    call assert_equal(trim(e%physics%eos), trim(a%physics%eos), l // 'physics.eos')
    call assert_equal(e%physics%gamma, a%physics%gamma, 0.0_wp, l // 'physics.gamma')
    call assert_equal(trim(e%numerics%kernel), trim(a%numerics%kernel), l // 'numerics.kernel')
    call assert_equal(trim(e%numerics%integrator), trim(a%numerics%integrator), &
                      l // 'numerics.integrator')
    call assert_equal(e%numerics%cfl, a%numerics%cfl, 0.0_wp, l // 'numerics.cfl')
    call assert_equal(e%numerics%cfl_force, a%numerics%cfl_force, 0.0_wp, &
                      l // 'numerics.cfl_force')
    call assert_equal(e%numerics%cfl_visc, a%numerics%cfl_visc, 0.0_wp, l // 'numerics.cfl_visc')
    call assert_equal(trim(e%numerics%viscosity), trim(a%numerics%viscosity), &
                      l // 'numerics.viscosity')
    call assert_equal(e%numerics%alpha, a%numerics%alpha, 0.0_wp, l // 'numerics.alpha')
    call assert_equal(trim(e%numerics%diffusion), trim(a%numerics%diffusion), &
                      l // 'numerics.diffusion')
    call assert_equal(e%numerics%delta, a%numerics%delta, 0.0_wp, l // 'numerics.delta')
    call assert_equal(e%numerics%skin, a%numerics%skin, 0.0_wp, l // 'numerics.skin')
    call assert_equal(trim(e%output%dir), trim(a%output%dir), l // 'output.dir')
    call assert_equal(e%output%dt, a%output%dt, 0.0_wp, l // 'output.dt')
    call assert_equal(e%output%probe_every, a%output%probe_every, l // 'output.probe_every')
    call assert_true(e%output%snapshots .eqv. a%output%snapshots, l // 'output.snapshots')
    call assert_equal(e%output%n_probes, a%output%n_probes, l // 'output.n_probes')
    call assert_equal(reshape(e%output%probes, [3 * MAX_PROBES]), &
                      reshape(a%output%probes, [3 * MAX_PROBES]), 0.0_wp, l // 'output.probes')
    call assert_equal(e%circle2d%radius, a%circle2d%radius, 0.0_wp, l // 'circle2d.radius')
    call assert_equal(e%circle2d%a0, a%circle2d%a0, 0.0_wp, l // 'circle2d.a0')
    call assert_equal(e%ellipsoid3d%radius, a%ellipsoid3d%radius, 0.0_wp, &
                      l // 'ellipsoid3d.radius')
    call assert_equal(e%ellipsoid3d%a0, a%ellipsoid3d%a0, 0.0_wp, l // 'ellipsoid3d.a0')
    call assert_equal(e%ellipsoid3d%rates, a%ellipsoid3d%rates, 0.0_wp, l // 'ellipsoid3d.rates')
    call assert_true(e%numerics%tensile .eqv. a%numerics%tensile, l // 'numerics.tensile')
    call assert_equal(e%numerics%tensile_eps, a%numerics%tensile_eps, 0.0_wp, &
                      l // 'numerics.tensile_eps')
    call assert_equal(e%numerics%tensile_n, a%numerics%tensile_n, l // 'numerics.tensile_n')
    call assert_equal(trim(e%numerics%pressure_gradient), trim(a%numerics%pressure_gradient), &
                      l // 'numerics.pressure_gradient')
    call assert_equal(trim(e%numerics%divergence), trim(a%numerics%divergence), &
                      l // 'numerics.divergence')
    call assert_true(e%numerics%shifting .eqv. a%numerics%shifting, l // 'numerics.shifting')
    call assert_equal(e%square_rotation%side, a%square_rotation%side, 0.0_wp, &
                      l // 'square_rotation.side')
    call assert_equal(e%square_rotation%omega, a%square_rotation%omega, 0.0_wp, &
                      l // 'square_rotation.omega')
    call assert_equal(e%square_vortical%side, a%square_vortical%side, 0.0_wp, &
                      l // 'square_vortical.side')
    call assert_equal(e%square_vortical%v0, a%square_vortical%v0, 0.0_wp, &
                      l // 'square_vortical.v0')
    call assert_equal(trim(e%run%restart), trim(a%run%restart), l // 'run.restart')
    call assert_equal(e%particles%pack_iterations, a%particles%pack_iterations, &
                      l // 'particles.pack_iterations')
    call assert_equal(trim(e%particles%from), trim(a%particles%from), l // 'particles.from')
    call assert_equal(trim(e%numerics%renormalise), trim(a%numerics%renormalise), &
                      l // 'numerics.renormalise')
    call assert_true(e%ellipsoid3d%prepared .eqv. a%ellipsoid3d%prepared, &
                     l // 'ellipsoid3d.prepared')
    call assert_equal(trim(e%parallel%decomposition), trim(a%parallel%decomposition), &
                      l // 'parallel.decomposition')
    call assert_equal(trim(e%parallel%balance), trim(a%parallel%balance), l // 'parallel.balance')
    call assert_equal(e%parallel%imbalance_threshold, a%parallel%imbalance_threshold, 0.0_wp, &
                      l // 'parallel.imbalance_threshold')
  end subroutine check_same

  subroutine echo_to(c, path)
    type(config_t), intent(in) :: c
    character(len=*), intent(in) :: path
    integer :: u
    open(newunit=u, file=path, status='replace', action='write')
    call config_echo(c, u)
    close(u)
  end subroutine echo_to

  subroutine delete_file(path)
    character(len=*), intent(in) :: path
    integer :: u, ios
    open(newunit=u, file=path, status='old', iostat=ios)
    if (ios == 0) close(u, status='delete')
  end subroutine delete_file

  !> A fresh directory /tmp/sph_test_config_r<rank>_XXXXXX.
  subroutine make_scratch()
    character(len=64) :: template
    integer :: rank
    call MPI_Comm_rank(test_comm(), rank)
    write(template, '(a,i0,a)') '/tmp/sph_test_config_r', rank, '_XXXXXX'
    template = trim(template) // c_null_char
    if (.not. c_associated(c_mkdtemp(template))) error stop 'test_config: mkdtemp failed'
    scratch = template(1:index(template, c_null_char) - 1)
  end subroutine make_scratch

end module test_config
