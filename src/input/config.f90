!> The input of a run (doc/reference/input.md): the namelist groups, one
!> derived type per group, each case holding its own; their visit in the
!> order of the written files; loading (a file, then command-line
!> overrides `group.variable=value`, input_read) and the validation: each
!> value against its row, then the rules between variables, here in one
!> place.  Every error is one message naming the group, the variable, the
!> offending value and what is allowed.  No output here: config_load
!> returns ok and one message; every rank reads the same file the same way.
module config
  use, intrinsic :: ieee_arithmetic, only: ieee_is_finite
  use kinds, only: wp
  use mirrors, only: mirror_mask
  use input_text, only: fail, quoted, int_str, real_list, real_str
  use input_visit, only: input_t, visit_t
  use input_read, only: origin_t, read_input, check_values, origin_of
  use input_write, only: write_input, write_help, write_tables
  use input_params, only: run_params_t, particles_params_t, physics_params_t, &
                          numerics_params_t, output_params_t, parallel_params_t, NAME_LEN, &
                          DIR_LEN_MAX, MAX_PROBES
  use case_base, only: case_t, case_slot_t
  use case_factory, only: register_cases
  implicit none
  private
  public :: config_t, run_params_t, particles_params_t, physics_params_t, &
            numerics_params_t, output_params_t, parallel_params_t
  public :: config_load, config_defaults, config_write_defaults, config_echo, &
            config_write_help, config_write_input_tables, config_dim, config_case, &
            config_scaled, config_resolution_scale
  public :: NAME_LEN, DIR_LEN_MAX, MAX_PROBES

  !> The whole configuration.  The generic groups have their defaults; the
  !> cases, each holding its own group, come from config_defaults or
  !> config_load.
  type, extends(input_t) :: config_t
    type(run_params_t) :: run
    type(particles_params_t) :: particles
    type(physics_params_t) :: physics
    type(numerics_params_t) :: numerics
    type(output_params_t) :: output
    type(parallel_params_t) :: parallel
    type(case_slot_t), allocatable :: cases(:)   !< every case of case_factory
  contains
    procedure :: visit => config_visit
  end type config_t

  real(wp), parameter :: MACH_FACTOR = 3.0_wp          !< c0 >= MACH_FACTOR * max initial speed
  real(wp), parameter :: RK4_CFL_MAX = 2.5_wp          !< stability limit of rk4 in cfl
  real(wp), parameter :: PC2_CFL_MAX = 1.0_wp          !< stability limit of pc2 in cfl

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

    ok = .false.
    cfg = config_defaults()
    call read_input(path, overrides, cfg, origins, errmsg)
    if (allocated(errmsg)) return
    call validate(cfg, path, origins, errmsg)
    if (allocated(errmsg)) return
    ! the values the run will use must be valid too
    if (cfg%particles%n_ref > 0) then
      call validate(config_scaled(cfg), path, origins, errmsg)
      if (allocated(errmsg)) then
        errmsg = errmsg // ' (the value after the resolution scaling of &particles n_ref = ' &
                 // real_str(cfg%particles%n_ref) // ', doc/studies/convergence.md)'
        return
      end if
    end if
    ok = .true.
    errmsg = ''
  end subroutine config_load

  !> The configuration with the resolution scaling applied (doc/studies/convergence.md,
  !> S1): with particles%n_ref > 0 and s = (n/n_ref)^(1/dim) (= dx_ref/dx),
  !>   h/dx = h_over_dx s^h_exponent,  c0 = c0 s^c0_exponent,
  !>   alpha = alpha s^alpha_exponent,  delta = delta s^delta_exponent;
  !> unchanged with n_ref = 0.  The run uses these values; the echoed input
  !> keeps the given ones (with the rule), so that it reads back the same.
  function config_scaled(cfg) result(eff)
    type(config_t), intent(in) :: cfg
    type(config_t) :: eff
    real(wp) :: s
    eff = cfg
    if (.not. cfg%particles%n_ref > 0) return
    s = config_resolution_scale(cfg)
    eff%particles%h_over_dx = cfg%particles%h_over_dx * s**cfg%particles%h_exponent
    eff%physics%c0 = cfg%physics%c0 * s**cfg%physics%c0_exponent
    eff%numerics%alpha = cfg%numerics%alpha * s**cfg%numerics%alpha_exponent
    eff%numerics%delta = cfg%numerics%delta * s**cfg%numerics%delta_exponent
  end function config_scaled

  !> s = (n/n_ref)^(1/dim) = dx_ref/dx of the resolution scaling (S1);
  !> 1 without it (n_ref = 0).
  real(wp) function config_resolution_scale(cfg) result(s)
    type(config_t), intent(in) :: cfg
    s = 1
    if (cfg%particles%n_ref > 0) &
      s = (real(cfg%particles%n, wp) / cfg%particles%n_ref)**(1.0_wp / config_dim(cfg))
  end function config_resolution_scale

  !> Writes a complete namelist file with every group and variable at its
  !> default, each with a comment saying what it is and what is allowed.
  subroutine config_write_defaults(unit)
    integer, intent(in) :: unit
    call write_input(config_defaults(), unit, [character(len=80) :: &
      'sph input file: every group and variable at its default (sph --defaults).', &
      'Fortran namelist syntax: strings in quotes, ''!'' starts a comment; any', &
      'group or variable may be left out, and any variable can be set on the', &
      'command line after the file as group.variable=value (doc/reference/input.md).'])
  end subroutine config_write_defaults

  !> Writes the effective configuration as a namelist file (it reads back to
  !> the same configuration), for the run directory.
  subroutine config_echo(cfg, unit)
    type(config_t), intent(in) :: cfg
    integer, intent(in) :: unit
    call write_input(cfg, unit, [character(len=80) :: &
      'sph: the effective configuration of this run (input file and command-line', &
      'overrides); run it again with: sph <this file>'])
  end subroutine config_echo

  !> Writes a short reference of the input for `sph --help`: the syntax of
  !> the file and of the overrides, then every variable as group.variable =
  !> default with what is allowed.
  subroutine config_write_help(unit)
    integer, intent(in) :: unit
    write(unit, '(a)') 'Input: a Fortran namelist file (doc/reference/input.md) with the groups below;', &
      'any group or variable may be left out (defaults).  After the file, any number', &
      'of overrides group.variable=value, applied in order, e.g. numerics.cfl=0.5', &
      'output.dir=runs/x output.probes(1,2)=0.25 ellipsoid3d.rates=1,1,-2.', &
      'sph --defaults writes a complete input file with every default.', '', &
      'group.variable = default    allowed values'
    call write_help(config_defaults(), unit)
  end subroutine config_write_help

  !> Writes the tables of doc/reference/input.md (markdown), for each group a line
  !> `&group` and the table of its variables (input_tables: table_row).
  subroutine config_write_input_tables(unit)
    integer, intent(in) :: unit
    call write_tables(config_defaults(), unit)
  end subroutine config_write_input_tables

  !> The dimension of the selected case (2 or 3), 0 if the case is unknown.
  integer function config_dim(cfg)
    type(config_t), intent(in) :: cfg
    integer :: k
    config_dim = 0
    k = selected_case(cfg)
    if (k > 0) config_dim = cfg%cases(k)%c%dim
  end function config_dim

  !> The configuration with every default: the generic groups' and those of
  !> every registered case.
  function config_defaults() result(cfg)
    type(config_t) :: cfg
    call register_cases(cfg%cases)
  end function config_defaults

  !> The selected case (run.case) with its group's values, to set up the run.
  subroutine config_case(cfg, c)
    type(config_t), intent(in) :: cfg
    class(case_t), allocatable, intent(out) :: c
    integer :: k
    k = selected_case(cfg)
    if (k == 0) error stop 'config_case: unknown case (config_load rejects it)'
    allocate(c, source=cfg%cases(k)%c)
    c%mirror = mirror_mask(trim(cfg%particles%symmetry))
  end subroutine config_case

  ! ------------------------------------------------------------------------
  ! The groups
  ! ------------------------------------------------------------------------

  !> Every group in the order of the written files: the generic ones, with
  !> each case's own group before &parallel, where input files have always
  !> had them.
  subroutine config_visit(self, v)
    class(config_t), intent(inout) :: self
    type(visit_t), intent(inout) :: v
    integer :: k
    call self%run%visit(v, case_names(self))
    call self%particles%visit(v)
    call self%physics%visit(v)
    call self%numerics%visit(v)
    call self%output%visit(v)
    do k = 1, size(self%cases)
      associate(c => self%cases(k)%c)
      call v%group(trim(c%name), trim(c%help) // ', used when run.case = ''' // trim(c%name) &
                   // '''')
      call c%visit(v)
      end associate
    end do
    call self%parallel%visit(v)
  end subroutine config_visit

  ! ------------------------------------------------------------------------
  ! Validation
  ! ------------------------------------------------------------------------

  !> Every value on its own (ranges and lists of the rows), then the rules
  !> that involve several values.  Messages name where the value was set.
  subroutine validate(c, path, origins, err)
    type(config_t), intent(in) :: c
    character(len=*), intent(in) :: path
    type(origin_t), intent(in) :: origins(:)
    character(len=:), allocatable, intent(inout) :: err
    call check_values(c, path, origins, err)
    if (.not. allocated(err)) call check_files(c, path, origins, err)
    if (.not. allocated(err)) call check_layout(c, path, origins, err)
    if (.not. allocated(err)) call check_cases(c, path, origins, err)
    if (.not. allocated(err)) call check_numerics(c, path, origins, err)
  end subroutine validate

  !> The run directory, and the files named by run.restart and particles.from.
  subroutine check_files(c, path, origins, err)
    type(config_t), intent(in) :: c
    character(len=*), intent(in) :: path
    type(origin_t), intent(in) :: origins(:)
    character(len=:), allocatable, intent(inout) :: err
    character(len=:), allocatable :: origin, dir
    integer :: line

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
  end subroutine check_files

  !> The placement and the mirror planes against the case, and the probes.
  subroutine check_layout(c, path, origins, err)
    type(config_t), intent(in) :: c
    character(len=*), intent(in) :: path
    type(origin_t), intent(in) :: origins(:)
    character(len=:), allocatable, intent(inout) :: err
    character(len=:), allocatable :: origin, sym
    integer :: k, line, sel

    sel = selected_case(c)
    if (c%particles%placement == 'packed' .and. sel > 0) then
      if (len_trim(c%cases(sel)%c%no_packing) > 0) then
        call origin_of(origins, path, 'particles.placement', origin, line)
        call fail(err, origin, '&particles placement = ''packed'' is not available for ' // &
                  trim(c%run%case_name), line, ': packing serves ' // packing_cases(c) // &
                  '; ' // trim(c%cases(sel)%c%no_packing))
        return
      end if
    end if

    if (c%particles%symmetry /= 'none') then
      call origin_of(origins, path, 'particles.symmetry', origin, line)
      sym = '&particles symmetry = ' // quoted(trim(c%particles%symmetry))
      if (sel > 0) then
        if (len_trim(c%cases(sel)%c%no_symmetry) > 0) then
          call fail(err, origin, sym // ' is not available for ' // trim(c%run%case_name), &
                    line, ': ' // trim(c%cases(sel)%c%no_symmetry) // ' (mirror planes ' // &
                    'serve circle2d and ellipsoid3d)')
          return
        end if
      end if
      if (index(c%particles%symmetry, 'z') > 0 .and. config_dim(c) == 2) then
        call fail(err, origin, sym // ' names the plane z = 0 in a 2D case', line, &
                  ': use x, y or xy')
        return
      end if
      if (c%particles%placement == 'rings') then
        call fail(err, origin, sym // ' with placement = ''rings''', line, ': rings put ' // &
                  'particles on the planes; use placement = ''lattice'' or ''packed''')
        return
      end if
      if (c%numerics%shifting) then
        call fail(err, origin, sym // ' with numerics.shifting = .true.', line, ': the ' // &
                  'shifting does not know the planes; set shifting = .false.')
        return
      end if
    else if (c%output%mirror) then
      call origin_of(origins, path, 'output.mirror', origin, line)
      call fail(err, origin, '&output mirror = .true. without mirror planes', line, &
                ': it writes the reflections of the part; set particles.symmetry, or ' // &
                'leave mirror = .false.')
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
  end subroutine check_layout

  !> The rules of each case's own group, whichever case runs.
  subroutine check_cases(c, path, origins, err)
    type(config_t), intent(in) :: c
    character(len=*), intent(in) :: path
    type(origin_t), intent(in) :: origins(:)
    character(len=:), allocatable, intent(inout) :: err
    character(len=:), allocatable :: origin, var, what, hint
    integer :: k, line
    do k = 1, size(c%cases)
      call c%cases(k)%c%check(var, what, hint)
      if (len(var) == 0) cycle
      call origin_of(origins, path, trim(c%cases(k)%c%name) // '.' // var, origin, line)
      call fail(err, origin, '&' // trim(c%cases(k)%c%name) // ' ' // what, line, hint)
      return
    end do
  end subroutine check_cases

  !> The time step against the integrator, the operators that only work
  !> together, and the speed of sound against the case's largest speed.
  subroutine check_numerics(c, path, origins, err)
    type(config_t), intent(in) :: c
    character(len=*), intent(in) :: path
    type(origin_t), intent(in) :: origins(:)
    character(len=:), allocatable, intent(inout) :: err
    character(len=:), allocatable :: origin, formula
    real(wp) :: speed
    integer :: line, sel

    ! Stability of the time integrators in the acoustic CFL (measured on
    ! circle2d, doc/studies/numerics.md): rk4 is unaffected up to 2.4 and degrades
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

    ! (H2) is the adjoint of the renormalised divergence: the pair keeps
    ! the energy only together (doc/theory/)
    if (c%numerics%pressure_gradient == 'renormalised' .and. &
        c%numerics%divergence /= 'renormalised') then
      call origin_of(origins, path, 'numerics.pressure_gradient', origin, line)
      call fail(err, origin, '&numerics pressure_gradient = ''renormalised'' needs ' // &
                'divergence = ''renormalised'' (here ''' // trim(c%numerics%divergence) // &
                ''')', line, ': the two form one energy-conserving pair; allowed ' // &
                'pressure_gradient = ''standard'' or ''higher_order'' with divergence = ''' // &
                trim(c%numerics%divergence) // '''')
      return
    end if

    ! (B1) binned sums exist in the main pair loop and the shifting pass,
    ! not in the first pass of the renormalised operators
    if (c%numerics%binned_sums .and. (c%numerics%pressure_gradient /= 'standard' .or. &
        c%numerics%divergence /= 'standard' .or. c%numerics%diffusion == 'antuono' .or. &
        c%numerics%visc_reconstruction)) then
      call origin_of(origins, path, 'numerics.binned_sums', origin, line)
      call fail(err, origin, '&numerics binned_sums = .true. needs the standard operators ' // &
                '(here pressure_gradient = ''' // trim(c%numerics%pressure_gradient) // &
                ''', divergence = ''' // trim(c%numerics%divergence) // ''', diffusion = ''' // &
                trim(c%numerics%diffusion) // ''', visc_reconstruction = ' // &
                merge('.true. ', '.false.', c%numerics%visc_reconstruction) // ')', line, &
                ': allowed with pressure_gradient = ''standard'', divergence = ''standard'', ' // &
                'a diffusion other than ''antuono'' and visc_reconstruction = .false.')
      return
    end if

    ! Weak compressibility: the Mach number must stay small.
    speed = 0
    formula = '0'
    sel = selected_case(c)
    if (sel > 0) call c%cases(sel)%c%max_speed(speed, formula)
    call origin_of(origins, path, 'physics.c0', origin, line)
    if (.not. c%physics%c0 >= MACH_FACTOR * speed) then
      call fail(err, origin, '&physics c0 = ' // real_str(c%physics%c0) // &
                ' is too small for case ''' // trim(c%run%case_name) // '''', line, &
                ': allowed c0 >= 3 max|u0| = ' // real_str(MACH_FACTOR * speed) // &
                ', where max|u0| = ' // formula // ' = ' // real_str(speed) // &
                ' is the largest initial speed')
      return
    end if
  end subroutine check_numerics

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

  ! ------------------------------------------------------------------------
  ! The cases
  ! ------------------------------------------------------------------------

  !> The index into c%cases of run.case, 0 if no case has that name.
  integer function selected_case(c)
    type(config_t), intent(in) :: c
    integer :: k
    selected_case = 0
    do k = 1, size(c%cases)
      if (c%cases(k)%c%name == c%run%case_name) selected_case = k
    end do
  end function selected_case

  !> The names of the cases: the allowed values of run.case.
  function case_names(c) result(names)
    type(config_t), intent(in) :: c
    character(len=NAME_LEN), allocatable :: names(:)
    integer :: k
    allocate(names(size(c%cases)))
    do k = 1, size(c%cases)
      names(k) = c%cases(k)%c%name
    end do
  end function case_names

  !> "a, b and c": the cases that can start from packed particles.
  function packing_cases(c) result(s)
    type(config_t), intent(in) :: c
    character(len=:), allocatable :: s
    integer :: k, n, left
    s = ''
    n = count([(len_trim(c%cases(k)%c%no_packing) == 0, k = 1, size(c%cases))])
    left = n
    do k = 1, size(c%cases)
      if (len_trim(c%cases(k)%c%no_packing) > 0) cycle
      if (left == 1 .and. n > 1) then
        s = s // ' and '
      else if (left < n) then
        s = s // ', '
      end if
      s = s // trim(c%cases(k)%c%name)
      left = left - 1
    end do
  end function packing_cases

end module config
