!> The input of a run (doc/reference/input.md): Fortran namelist groups, one derived
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
  use mirrors, only: mirror_mask
  use input_text, only: fail, closest, allowed_words, quoted_list, quoted, shown_value, &
                        unquoted, value_is_bare, base_name, word_at, name_end_at, lower, pad, &
                        int_str, num_str, real_list, real_str
  use namelist_scan, only: load_text, find_group_end, split_items
  use input_tables, only: TABLE_HEADER, table_row, range_text
  use input_var, only: var_t, T_INT, T_REAL, T_STRING, T_LOGICAL, LO_NONE, LO_GT, LO_GE, &
                       HI_NONE, HI_LT, HI_LE, CH_NONE
  use input_params, only: run_params_t, particles_params_t, physics_params_t, &
                          numerics_params_t, output_params_t, parallel_params_t, NAME_LEN, &
                          DIR_LEN_MAX, MAX_PROBES, group_t, GENERIC_GROUPS, GENERIC_VARS, &
                          G_RUN, G_PARTICLES, G_PHYSICS, G_NUMERICS, G_OUTPUT, CH_CASE, word_list
  use case_base, only: case_t, case_slot_t
  use case_factory, only: register_cases
  implicit none
  private
  public :: config_t, run_params_t, particles_params_t, physics_params_t, &
            numerics_params_t, output_params_t, parallel_params_t
  public :: config_load, config_defaults, config_write_defaults, config_echo, &
            config_write_help, config_write_input_tables, config_dim, config_case, config_scaled, config_resolution_scale
  public :: NAME_LEN, DIR_LEN_MAX, MAX_PROBES

  !> The whole configuration.  The generic groups have their defaults; the
  !> cases, each holding its own group, come from config_defaults or
  !> config_load.
  type :: config_t
    type(run_params_t) :: run
    type(particles_params_t) :: particles
    type(physics_params_t) :: physics
    type(numerics_params_t) :: numerics
    type(output_params_t) :: output
    type(parallel_params_t) :: parallel
    type(case_slot_t), allocatable :: cases(:)   !< every case of case_factory
  end type config_t

  !> The cases' own groups go between &output and &parallel, where input
  !> files have always had them (list_groups).
  integer, parameter :: N_BEFORE_CASES = G_OUTPUT

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
    cfg = config_defaults()
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
    call write_config(config_defaults(), unit, [character(len=80) :: &
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
    call write_config(cfg, unit, [character(len=80) :: &
      'sph: the effective configuration of this run (input file and command-line', &
      'overrides); run it again with: sph <this file>'])
  end subroutine config_echo

  !> Writes a short reference of the input for `sph --help`: the syntax of
  !> the file and of the overrides, then every variable as group.variable =
  !> default with what is allowed.
  subroutine config_write_help(unit)
    integer, intent(in) :: unit
    type(group_t), allocatable :: groups(:)
    type(var_t), allocatable :: vars(:)
    type(config_t) :: defaults
    character(len=:), allocatable :: text, lhs
    real(wp) :: x
    integer :: k
    call list_groups(groups)
    call list_vars(vars)
    defaults = config_defaults()
    write(unit, '(a)') 'Input: a Fortran namelist file (doc/reference/input.md) with the groups below;', &
      'any group or variable may be left out (defaults).  After the file, any number', &
      'of overrides group.variable=value, applied in order, e.g. numerics.cfl=0.5', &
      'output.dir=runs/x output.probes(1,2)=0.25 ellipsoid3d.rates=1,1,-2.', &
      'sph --defaults writes a complete input file with every default.', '', &
      'group.variable = default    allowed values'
    do k = 1, size(vars)
      lhs = trim(groups(vars(k)%group)%name) // '.' // trim(vars(k)%name)
      if (vars(k)%dims(2) > 0) lhs = lhs // '(1:3,k)'
      call get_value(defaults, vars(k), text, x)
      if (vars(k)%dims(2) > 0) text = real_list(defaults%output%probes(:, 1))
      write(unit, '(a)') '  ' // pad(lhs // ' = ' // text, 40) // ' ' // allowed_text(vars(k))
    end do
  end subroutine config_write_help

  !> Writes the tables of doc/reference/input.md (markdown), for each group a line
  !> `&group` and the table of its variables (input_tables: table_row).
  subroutine config_write_input_tables(unit)
    integer, intent(in) :: unit
    type(group_t), allocatable :: groups(:)
    type(var_t), allocatable :: vars(:)
    type(config_t) :: defaults
    character(len=:), allocatable :: text
    character(len=NAME_LEN), allocatable :: words(:)
    real(wp) :: x
    integer :: g, k
    call list_groups(groups)
    call list_vars(vars)
    defaults = config_defaults()
    do g = 1, size(groups)
      write(unit, '(a)') '&' // trim(groups(g)%name), (trim(TABLE_HEADER(k)), k = 1, 2)
      do k = 1, size(vars)
        if (vars(k)%group /= g) cycle
        text = ''
        if (vars(k)%dims(2) == 0) call get_value(defaults, vars(k), text, x)
        allocate(words(0))
        if (vars(k)%choices /= CH_NONE) words = choice_list(vars(k)%choices)
        write(unit, '(a)') table_row(vars(k), text, words)
        deallocate(words)
      end do
      write(unit, '(a)') ''
    end do
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
  ! Reading the file
  ! ------------------------------------------------------------------------

  !> Reads the groups of the file into cfg, recording where each variable
  !> was set.  err is allocated (with the message) on the first error.
  subroutine read_file(path, cfg, origins, err)
    character(len=*), intent(in) :: path
    type(config_t), intent(inout) :: cfg
    type(origin_t), allocatable, intent(inout) :: origins(:)
    character(len=:), allocatable, intent(inout) :: err
    type(group_t), allocatable :: groups(:)
    character(len=:), allocatable :: buf
    integer, allocatable :: line_of(:)
    integer :: pos, name_end, term, term_len, g
    integer, allocatable :: first_line(:)
    character(len=:), allocatable :: name

    call list_groups(groups)
    call load_text(path, buf, line_of, err)
    if (allocated(err)) return
    allocate(first_line(size(groups)), source=0)
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
    ! an empty file would silently run every default: surely not meant
    if (all(first_line == 0)) call fail(err, path, 'holds no namelist group', 0, &
      ': the file is empty or only comments; give at least &run case = ''circle2d'' / ' // &
      '(./sph --defaults writes a complete file)')
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
    type(group_t), allocatable :: groups(:)
    integer, allocatable :: starts(:), eqs(:)
    character(len=40), allocatable :: plain(:)
    integer, allocatable :: plain_line(:)
    character(len=:), allocatable :: name, value, reason, hint, head
    integer :: i, last, status, line, k, v, e
    type(var_t), allocatable :: vars(:)
    ! per array variable of the group, the line that set each element (0:
    ! none yet), in array element order, from elem_first(v)
    integer, allocatable :: elem_line(:), elem_first(:)
    logical, allocatable :: now(:)

    call list_groups(groups)
    call list_vars(vars)
    allocate(elem_first(size(vars)), elem_line(0), now(0))
    do v = 1, size(vars)
      elem_first(v) = size(elem_line) + 1
      if (vars(v)%group == g .and. vars(v)%dims(1) > 0) &
        elem_line = [elem_line, spread(0, 1, element_count(vars(v)))]
    end do
    call split_items(body, starts, eqs)
    last = len(body)
    if (size(starts) > 0) last = starts(1) - 1
    if (len_trim(body(1:last)) > 0) then
      call fail(err, path, '&' // trim(groups(g)%name) // ': ''' // trim(adjustl(body(1:last))) &
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
          call fail(err, path, '&' // trim(groups(g)%name) // ' ' // name // ' is set twice', &
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
        head = '&' // trim(groups(g)%name) // ' ' // name
        if (len(shown_value(value)) > 0) head = head // ' = ' // shown_value(value)
        call fail(err, path, head // ' ' // reason, line, hint)
        return
      end if
      ! An element of an array set twice is the same slip as a scalar
      v = var_index(g, base_name(name))
      if (v > 0) then
        if (vars(v)%dims(1) > 0) then
          now = elements_set(trim(groups(g)%name), vars(v), name, value, cfg)
          associate(seen => elem_line(elem_first(v):elem_first(v) + size(now) - 1))
          do e = 1, size(now)
            if (now(e) .and. seen(e) > 0) then
              call fail(err, path, '&' // trim(groups(g)%name) // ' ' // &
                        element_name(vars(v), e) // ' is set twice', line, &
                        ': it was already set on line ' // int_str(seen(e)) // '; keep one')
              return
            end if
          end do
          where (now) seen = line
          end associate
        end if
      end if
      call set_origin(origins, trim(groups(g)%name) // '.' // base_name(name), line)
    end do
  end subroutine read_group_body

  !> The elements of array variable v (of group `group`) that the item
  !> `name = value`, read already without error, sets, in array element
  !> order: read once over zeros and once over ones, an element is set where
  !> both reads give the same value (value_text is exact).  Numeric arrays
  !> only: the inputs have no others.
  function elements_set(group, v, name, value, c) result(set)
    character(len=*), intent(in) :: group, name, value
    type(var_t), intent(in) :: v
    type(config_t), intent(in) :: c
    logical, allocatable :: set(:)
    type(config_t) :: c0, c1
    character(len=:), allocatable :: t0, t1
    character(len=256) :: iomsg
    real(wp) :: x
    integer :: ios, n
    n = element_count(v)
    c0 = c
    c1 = c
    iomsg = ''
    call read_group(v%group, '&' // group // ' ' // trim(v%name) // ' = ' // int_str(n) // &
                    '*0 /', c0, ios, iomsg)
    call read_group(v%group, '&' // group // ' ' // trim(v%name) // ' = ' // int_str(n) // &
                    '*1 /', c1, ios, iomsg)
    call read_group(v%group, '&' // group // ' ' // name // ' = ' // value // ' /', c0, ios, iomsg)
    call read_group(v%group, '&' // group // ' ' // name // ' = ' // value // ' /', c1, ios, iomsg)
    call get_value(c0, v, t0, x)
    call get_value(c1, v, t1, x)
    set = list_items(t0, n) == list_items(t1, n)
  end function elements_set

  !> The number of elements of array variable v.
  pure integer function element_count(v)
    type(var_t), intent(in) :: v
    element_count = v%dims(1) * max(1, v%dims(2))
  end function element_count

  !> name(i) or name(i,k) of element e (in array element order) of v.
  function element_name(v, e) result(s)
    type(var_t), intent(in) :: v
    integer, intent(in) :: e
    character(len=:), allocatable :: s
    s = trim(v%name) // '(' // int_str(mod(e - 1, v%dims(1)) + 1)
    if (v%dims(2) > 0) s = s // ',' // int_str((e - 1) / v%dims(1) + 1)
    s = s // ')'
  end function element_name

  !> The n comma-separated items of text (value_text of an array), trimmed.
  function list_items(text, n) result(items)
    character(len=*), intent(in) :: text
    integer, intent(in) :: n
    character(len=40) :: items(n)
    integer :: k, start, comma
    items = ''
    start = 1
    do k = 1, n
      comma = index(text(start:), ',')
      if (comma == 0) comma = len(text) - start + 2
      items(k) = adjustl(text(start:start + comma - 2))
      start = start + comma
      if (start > len(text)) exit
    end do
  end function list_items

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
    type(var_t), allocatable :: vars(:)
    character(len=*), parameter :: ORIGIN = 'command line'
    character(len=:), allocatable :: ov, lhs, gname, name, value, reason, hint
    integer, allocatable :: starts(:), eqs(:)
    integer :: eq, dot, g, v, status

    call list_vars(vars)
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
      if (vars(v)%type == T_STRING .and. len(value) > 0) then
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
    type(group_t), allocatable :: groups(:)
    type(var_t), allocatable :: vars(:)
    character(len=:), allocatable :: s
    integer :: k, found
    call list_groups(groups)
    call list_vars(vars)
    s = ''
    found = 0
    do k = 1, size(vars)
      if (vars(k)%name /= name) cycle
      if (found > 0) return   ! in several groups: no single guess
      found = k
    end do
    if (found > 0) s = ', e.g. ' // trim(groups(vars(found)%group)%name) // '.' // name // rest
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
    type(group_t), allocatable :: groups(:)
    type(var_t), allocatable :: vars(:)
    character(len=*), parameter :: NEUTRAL(4) = ['0  ', '0  ', "'' ", 'F  ']
    character(len=:), allocatable :: base, group
    type(config_t) :: trial
    character(len=512) :: iomsg
    real(wp) :: x
    integer :: v, ios

    call list_groups(groups)
    call list_vars(vars)
    group = trim(groups(g)%name)
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
             default_text(vars(v)) // ')'
      return
    end if
    ! '/' ends namelist input: numerics.cfl=1/2 would silently read 1.
    if (scan(unquoted(value), '/') > 0) then
      reason = 'cannot be read as ' // type_text(vars(v))
      hint = ': a ''/'' outside quotes ends the namelist input'
      return
    end if
    ! gfortran reads any .word. by its first letter (.tomato. as true)
    if (vars(v)%type == T_LOGICAL) then
      select case (lower(trim(adjustl(shown_value(value)))))
      case ('.true.', '.false.', '.t.', '.f.', 't', 'f')
      case default
        reason = 'cannot be read as ' // type_text(vars(v))
        hint = ': write .true. or .false.'
        return
      end select
    end if
    call read_group(g, '&' // group // ' ' // name // ' = ' // value // ' /', c, ios, iomsg)
    if (ios == 0) then
      status = ITEM_OK
      return
    end if
    if (index(name, '(') > 0) then
      ! A subscript that is not one (unbalanced, a stray ':'): said as such
      if (.not. subscript_ok(name(index(name, '(') + 1:))) then
        reason = 'has a malformed subscript'
        hint = ': write e.g. ' // base // '(1:3,2) = ...'
        return
      end if
      ! Is the index at fault rather than the value?  Try a value that fits.
      trial = c
      call read_group(g, '&' // group // ' ' // name // ' = ' // trim(NEUTRAL(vars(v)%type)) &
                      // ' /', trial, ios, iomsg)
      if (ios /= 0) then
        if (vars(v)%dims(1) == 0) then
          reason = 'has an index, but ' // base // ' is not an array'
        else
          reason = 'has an index outside ' // base // shape_text(vars(v))
        end if
        return
      end if
    end if
    reason = 'cannot be read as ' // type_text(vars(v))
    select case (vars(v)%type)
    case (T_INT)
      read(value, *, iostat=ios) x
      if (verify(shown_value(value), '+-0123456789') == 0) then
        hint = ': it is too large'
        if (vars(v)%hi_rule /= HI_NONE) hint = hint // '; allowed ' // allowed_text(vars(v))
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

  !> text is 'sub)' for a subscript: comma-separated whole numbers or
  !> ranges lo:hi, and the closing parenthesis.
  pure logical function subscript_ok(text) result(ok)
    character(len=*), intent(in) :: text
    character(len=:), allocatable :: inner, part
    integer :: k, start, n
    ok = .false.
    n = len_trim(text)
    if (n < 2) return
    if (text(n:n) /= ')') return
    inner = text(1:n - 1)
    if (verify(inner, '0123456789:, ') /= 0) return
    start = 1
    do k = 1, len(inner) + 1
      if (k <= len(inner)) then
        if (inner(k:k) /= ',') cycle
      end if
      ! one part: a number, or lo:hi with both
      part = trim(adjustl(inner(start:k - 1)))
      if (len(part) == 0) return
      if (part(1:1) == ':' .or. part(len(part):len(part)) == ':') return
      if (index(part, ':') /= index(part, ':', back=.true.)) return
      start = k + 1
    end do
    ok = .true.
  end function subscript_ok

  !> Reads namelist text '&group ... /' into the component of c for group g.
  subroutine read_group(g, text, c, ios, iomsg)
    integer, intent(in) :: g
    character(len=*), intent(in) :: text
    type(config_t), intent(inout) :: c
    integer, intent(out) :: ios
    character(len=*), intent(inout) :: iomsg
    integer :: k
    k = case_of_group(c, g)
    if (k > 0) then
      call c%cases(k)%c%read_group(text, ios, iomsg)
      return
    end if
    select case (generic_group(c, g))
    case (G_RUN)
      call c%run%read_group(text, ios, iomsg)
    case (G_PARTICLES)
      call c%particles%read_group(text, ios, iomsg)
    case (G_PHYSICS)
      call c%physics%read_group(text, ios, iomsg)
    case (G_NUMERICS)
      call c%numerics%read_group(text, ios, iomsg)
    case (G_OUTPUT)
      call c%output%read_group(text, ios, iomsg)
    case default
      call c%parallel%read_group(text, ios, iomsg)
    end select
  end subroutine read_group

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

  !> Every value on its own (ranges and lists from vars), then the rules
  !> that involve several values.  Messages name where the value was set.
  subroutine validate(c, path, origins, err)
    type(config_t), intent(in) :: c
    character(len=*), intent(in) :: path
    type(origin_t), intent(in) :: origins(:)
    character(len=:), allocatable, intent(inout) :: err
    type(group_t), allocatable :: groups(:)
    type(var_t), allocatable :: vars(:)
    character(len=:), allocatable :: text, origin, head, formula, dir, var, what, hint, sym
    character(len=NAME_LEN), allocatable :: list(:)
    real(wp) :: x, speed
    integer :: k, line, sel
    type(var_t) :: v

    call list_groups(groups)
    call list_vars(vars)
    do k = 1, size(vars)
      v = vars(k)
      call get_value(c, v, text, x)
      call origin_of(origins, path, key(v), origin, line)
      head = '&' // trim(groups(v%group)%name) // ' ' // trim(v%name) // ' = ' // text
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

    ! The rules of each case's own group, whichever case runs.
    do k = 1, size(c%cases)
      call c%cases(k)%c%check(var, what, hint)
      if (len(var) == 0) cycle
      call origin_of(origins, path, trim(c%cases(k)%c%name) // '.' // var, origin, line)
      call fail(err, origin, '&' // trim(c%cases(k)%c%name) // ' ' // what, line, hint)
      return
    end do

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
  end subroutine validate

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
    type(group_t), allocatable :: groups(:)
    type(var_t), allocatable :: vars(:)
    character(len=:), allocatable :: text
    real(wp) :: x
    integer :: g, k, p
    logical :: first

    call list_groups(groups)
    call list_vars(vars)
    do k = 1, size(title)
      write(unit, '(a)') trim('! ' // title(k))
    end do
    do g = 1, size(groups)
      write(unit, '(a)') '', '! ' // trim(groups(g)%help), '&' // trim(groups(g)%name)
      do k = 1, size(vars)
        if (vars(k)%group /= g) cycle
        if (vars(k)%dims(2) > 0) then
          ! probes: one line per probe in use or set (the rest stay zero).
          first = .true.
          do p = 1, MAX_PROBES
            if (p > max(1, c%output%n_probes) .and. &
                all(transfer(c%output%probes(:, p), 0_i8, 3) == 0_i8)) cycle
            call write_item(unit, trim(vars(k)%name) // '(1:3,' // int_str(p) // ')', &
                            real_list(c%output%probes(:, p)), vars(k), first)
            first = .false.
          end do
        else
          call get_value(c, vars(k), text, x)
          call write_item(unit, trim(vars(k)%name), text, vars(k), .true.)
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
    integer :: k
    x = 0
    k = case_of_group(c, v%group)
    if (k > 0) then
      text = c%cases(k)%c%value_text(trim(v%name))
    else
      select case (generic_group(c, v%group))
      case (G_RUN)
        text = c%run%value_text(trim(v%name))
      case (G_PARTICLES)
        text = c%particles%value_text(trim(v%name))
      case (G_PHYSICS)
        text = c%physics%value_text(trim(v%name))
      case (G_NUMERICS)
        text = c%numerics%value_text(trim(v%name))
      case (G_OUTPUT)
        text = c%output%value_text(trim(v%name))
      case default
        text = c%parallel%value_text(trim(v%name))
      end select
    end if
    if (v%dims(1) == 0 .and. (v%type == T_INT .or. v%type == T_REAL)) read(text, *) x
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
    if (v%choices /= CH_NONE) then
      s = 'one of ' // allowed_words(choice_list(v%choices))
    else if (v%lo_rule /= LO_NONE .or. v%hi_rule /= HI_NONE) then
      s = range_text(v)
    else if (v%type == T_LOGICAL) then
      s = '.true. or .false.'
    else
      s = trim(v%rule)
    end if
  end function allowed_text

  !> The default of v as text (for hints).
  function default_text(v) result(s)
    type(var_t), intent(in) :: v
    character(len=:), allocatable :: s
    real(wp) :: x
    if (v%dims(2) > 0) then
      s = 'all 0.0'
    else
      call get_value(config_defaults(), v, s, x)
    end if
  end function default_text

  !> "; did you mean &numerics? The groups are &run, &particles, ...".
  function unknown_group_hint(name) result(s)
    character(len=*), intent(in) :: name
    character(len=:), allocatable :: s
    character(len=:), allocatable :: best
    type(group_t), allocatable :: groups(:)
    integer :: k
    call list_groups(groups)
    best = closest(name, groups%name)
    s = '; the groups are'
    if (len(best) > 0) s = '; did you mean &' // best // '? The groups are'
    do k = 1, size(groups)
      s = s // ' &' // trim(groups(k)%name)
      if (k < size(groups)) s = s // ','
    end do
  end function unknown_group_hint

  !> "; did you mean 'cfl'? The variables of &numerics are kernel, ...".
  function unknown_var_hint(g, name) result(s)
    integer, intent(in) :: g
    character(len=*), intent(in) :: name
    type(group_t), allocatable :: groups(:)
    type(var_t), allocatable :: vars(:)
    character(len=:), allocatable :: s
    character(len=:), allocatable :: best
    integer :: k
    logical :: first
    call list_groups(groups)
    call list_vars(vars)
    best = closest(name, pack(vars%name, vars%group == g))
    s = '; the variables of &' // trim(groups(g)%name) // ' are'
    if (len(best) > 0) s = '; did you mean ''' // best // '''? The variables of &' // &
                           trim(groups(g)%name) // ' are'
    first = .true.
    do k = 1, size(vars)
      if (vars(k)%group /= g) cycle
      if (.not. first) s = s // ','
      s = s // ' ' // trim(vars(k)%name)
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
    type(group_t), allocatable :: groups(:)
    character(len=:), allocatable :: s
    call list_groups(groups)
    s = trim(groups(v%group)%name) // '.' // trim(v%name)
  end function key

  integer function group_index(name)
    character(len=*), intent(in) :: name
    type(group_t), allocatable :: groups(:)
    integer :: k
    call list_groups(groups)
    group_index = 0
    do k = 1, size(groups)
      if (groups(k)%name == name) group_index = k
    end do
  end function group_index

  integer function var_index(g, name)
    integer, intent(in) :: g
    character(len=*), intent(in) :: name
    type(var_t), allocatable :: vars(:)
    integer :: k
    call list_vars(vars)
    var_index = 0
    do k = 1, size(vars)
      if (vars(k)%group == g .and. vars(k)%name == name) var_index = k
    end do
  end function var_index

  !> Every group: the generic ones with each case's own group before &parallel.
  subroutine list_groups(groups)
    type(group_t), allocatable, intent(out) :: groups(:)
    type(config_t) :: defaults   ! not a local array of cases: gfortran -Wall warns falsely
    character(len=:), allocatable :: name
    integer :: k
    call register_cases(defaults%cases)
    groups = GENERIC_GROUPS(1:N_BEFORE_CASES)
    do k = 1, size(defaults%cases)
      name = trim(defaults%cases(k)%c%name)
      groups = [groups, group_t(name, trim(defaults%cases(k)%c%help) // &
                                ', used when run.case = ''' // name // '''')]
    end do
    groups = [groups, GENERIC_GROUPS(N_BEFORE_CASES + 1:)]
  end subroutine list_groups

  !> Every variable in the order of list_groups, var_t%group indexing it.
  subroutine list_vars(vars)
    type(var_t), allocatable, intent(out) :: vars(:)
    type(var_t), allocatable :: more(:)
    type(config_t) :: defaults   ! not a local array of cases: gfortran -Wall warns falsely
    integer :: k
    call register_cases(defaults%cases)
    vars = pack(GENERIC_VARS, GENERIC_VARS%group <= N_BEFORE_CASES)
    do k = 1, size(defaults%cases)
      more = defaults%cases(k)%c%vars()
      more%group = N_BEFORE_CASES + k
      vars = [vars, more]
    end do
    more = pack(GENERIC_VARS, GENERIC_VARS%group > N_BEFORE_CASES)
    more%group = more%group + size(defaults%cases)
    vars = [vars, more]
  end subroutine list_vars

  !> The index into c%cases of the case whose group is group g, 0 if none.
  integer function case_of_group(c, g)
    type(config_t), intent(in) :: c
    integer, intent(in) :: g
    case_of_group = g - N_BEFORE_CASES
    if (case_of_group < 1 .or. case_of_group > size(c%cases)) case_of_group = 0
  end function case_of_group

  !> The index into GENERIC_GROUPS of group g (not a case's group).
  integer function generic_group(c, g)
    type(config_t), intent(in) :: c
    integer, intent(in) :: g
    generic_group = g
    if (g > N_BEFORE_CASES) generic_group = g - size(c%cases)
  end function generic_group

  !> The index into c%cases of run.case, 0 if no case has that name.
  integer function selected_case(c)
    type(config_t), intent(in) :: c
    integer :: k
    selected_case = 0
    do k = 1, size(c%cases)
      if (c%cases(k)%c%name == c%run%case_name) selected_case = k
    end do
  end function selected_case

  function case_names() result(names)
    character(len=NAME_LEN), allocatable :: names(:)
    type(config_t) :: defaults   ! not a local array of cases: gfortran -Wall warns falsely
    integer :: k
    call register_cases(defaults%cases)
    allocate(names(size(defaults%cases)))
    do k = 1, size(defaults%cases)
      names(k) = defaults%cases(k)%c%name
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

  function choice_list(id) result(list)
    integer, intent(in) :: id
    character(len=NAME_LEN), allocatable :: list(:)
    if (id == CH_CASE) then
      list = case_names()
    else
      list = word_list(id)
    end if
  end function choice_list

end module config
