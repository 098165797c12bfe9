!> Snapshots and their XDMF index written by every rank and read back
!> (snapshot_io), and the file-system helpers they rest on (fileutil).
!>
!> Each rank contributes a different number of particles (rank 1 none when
!> there are 3 or more ranks) whose values are functions of the global id,
!> so every value read back can be checked against its id, and the rows'
!> order against the ranks' offsets.  h5dump, when installed, gives an
!> independent view of the shapes (N first, as h5py sees them).
module test_snapshot_io
  use kinds, only: wp, i8
  use mpi_f08, only: MPI_Comm, MPI_Comm_rank, MPI_Comm_size, MPI_Bcast, MPI_Allreduce, &
                     MPI_Barrier, MPI_INTEGER, MPI_INTEGER8, MPI_CHARACTER, MPI_SUM, &
                     MPI_IN_PLACE
  use testing, only: run_test, assert_true, assert_equal, test_comm
  use fileutil, only: make_directory, rename_file, file_exists, remove_file, is_directory, &
                      make_temp_directory, temp_path, base_name, dir_name, join_path, &
                      write_file_atomic, agree_ok
  use snapshot_io, only: snapshot_field_t, snapshot_t, xdmf_index_t, snapshot_write, &
                         snapshot_read, snapshot_filename, snapshot_find_field, &
                         snapshot_find_attribute, xdmf_init
  implicit none
  private
  public :: suite_snapshot_io

contains

  subroutine suite_snapshot_io()
    call run_test('snapshot_io', 'fileutil_mkdir_rename_exists', fileutil_basics)
    call run_test('snapshot_io', 'roundtrip_2d', roundtrip_2d)
    call run_test('snapshot_io', 'roundtrip_3d', roundtrip_3d)
    call run_test('snapshot_io', 'xdmf_index_two_snapshots', xdmf_two_snapshots)
    call run_test('snapshot_io', 'no_particles_anywhere', empty_snapshot)
    call run_test('snapshot_io', 'bad_arguments_fail_on_every_rank', bad_arguments)
  end subroutine suite_snapshot_io

  ! ---------------------------------------------------------------- helpers

  !> A fresh directory made by rank 0 and known to every rank.
  function shared_scratch(tag) result(dir)
    character(len=*), intent(in) :: tag
    character(len=:), allocatable :: dir
    type(MPI_Comm) :: comm
    integer :: rank, n
    comm = test_comm()
    call MPI_Comm_rank(comm, rank)
    if (rank == 0) dir = make_temp_directory('/tmp/sph_test_' // tag // '_')
    n = 0
    if (rank == 0) n = len(dir)
    call MPI_Bcast(n, 1, MPI_INTEGER, 0, comm)
    if (rank /= 0) allocate(character(len=n) :: dir)
    if (n > 0) call MPI_Bcast(dir, n, MPI_CHARACTER, 0, comm)
  end function shared_scratch

  !> Rank 0 removes the given files of `dir`, then `dir` (after a barrier).
  subroutine cleanup(dir, names)
    character(len=*), intent(in) :: dir, names(:)
    integer :: rank, k
    call MPI_Barrier(test_comm())
    call MPI_Comm_rank(test_comm(), rank)
    if (rank /= 0) return
    do k = 1, size(names)
      call remove_file(join_path(dir, trim(names(k))))
    end do
    call remove_file(dir)
  end subroutine cleanup

  !> Particles of rank r: 0 on rank 1 when there are >= 3 ranks, else 3+2r+dim.
  integer function count_of(r, nranks, dim)
    integer, intent(in) :: r, nranks, dim
    count_of = 3 + 2 * r + dim
    if (nranks >= 3 .and. r == 1) count_of = 0
  end function count_of

  !> Global id of local particle k of rank r (unique, not in row order).
  integer(i8) function id_of(r, k)
    integer, intent(in) :: r, k
    id_of = 100000_i8 * (r + 1) + 3_i8 * k
  end function id_of

  ! The fields as functions of the id: exactly representable (no rounding,
  ! so FMA contraction or vector maths cannot change them), except 1/id,
  ! which IEEE division rounds the same way everywhere.
  pure real(wp) function fx(a, id)
    integer, intent(in) :: a
    integer(i8), intent(in) :: id
    fx = a + real(id, wp) / 1024
  end function fx
  pure real(wp) function fu(a, id)
    integer, intent(in) :: a
    integer(i8), intent(in) :: id
    fu = -0.125_wp * a * real(id, wp)
  end function fu
  pure real(wp) function frho(id)
    integer(i8), intent(in) :: id
    frho = 1000.0_wp + real(id, wp) / 4096
  end function frho
  pure real(wp) function fp(id)
    integer(i8), intent(in) :: id
    fp = 0.25_wp * real(id, wp) - 3
  end function fp
  pure real(wp) function fm(id)
    integer(i8), intent(in) :: id
    fm = 1.0_wp / real(id, wp)
  end function fm
  pure real(wp) function fs(id)
    integer(i8), intent(in) :: id
    fs = 0.5_wp * real(id, wp) + 0.125_wp
  end function fs
  pure real(wp) function fv(a, id)
    integer, intent(in) :: a
    integer(i8), intent(in) :: id
    fv = 0.5_wp * a * real(id, wp) + 7.0_wp
  end function fv

  !> Writes this rank's particles of the test pattern to `file`.  Arrays
  !> are longer than the count (2 spare entries holding junk), and in 2D x
  !> has a third row of junk: only (1:dim, 1:n_local) may be written.
  subroutine write_pattern(file, dim, time, step, ok, errmsg, index)
    character(len=*), intent(in) :: file
    integer, intent(in) :: dim, step
    real(wp), intent(in) :: time
    logical, intent(out) :: ok
    character(len=:), allocatable, intent(out) :: errmsg
    type(xdmf_index_t), intent(inout), optional :: index
    integer :: rank, nranks, n, k, a
    integer(i8), allocatable :: id(:)
    real(wp), allocatable :: x(:,:), u(:,:), rho(:), p(:), m(:)
    type(snapshot_field_t) :: extra(2)
    call MPI_Comm_rank(test_comm(), rank)
    call MPI_Comm_size(test_comm(), nranks)
    n = count_of(rank, nranks, dim)
    allocate(id(n + 2), x(3, n + 2), u(dim, n + 2), rho(n + 2), p(n + 2), m(n + 2))
    id = -1
    x = -999
    u = -999
    rho = -999
    p = -999
    m = -999
    extra(1)%name = 'velocity_exact'
    allocate(extra(1)%v(dim, n + 2))
    extra(1)%v = -999
    extra(2)%name = 'pressure_exact'
    allocate(extra(2)%s(n + 2))
    extra(2)%s = -999
    do k = 1, n
      id(k) = id_of(rank, k)
      do a = 1, dim
        x(a, k) = fx(a, id(k))
        u(a, k) = fu(a, id(k))
        extra(1)%v(a, k) = fv(a, id(k))
      end do
      rho(k) = frho(id(k))
      p(k) = fp(id(k))
      m(k) = fm(id(k))
      extra(2)%s(k) = fs(id(k))
    end do
    call snapshot_write(test_comm(), file, time, step, dim, 'test_case', n, id, x, u, &
                        rho, p, m, ok, errmsg, extra=extra, &
                        attr_names=[character(len=12) :: 'semi_axis_a', 'semi_axis_b'], &
                        attr_values=[1.25_wp, 0.8_wp], index=index)
  end subroutine write_pattern

  !> Checks a snapshot read back against the pattern of write_pattern.
  subroutine check_pattern(snap, dim, time, step, label)
    type(snapshot_t), intent(in) :: snap
    integer, intent(in) :: dim, step
    real(wp), intent(in) :: time
    character(len=*), intent(in) :: label
    integer :: rank, nranks, k, a, r, kv, ks, row_rank, row_k
    integer(i8) :: n_expected, id_sum, id_sum_expected, rows, g, acc
    logical :: values_ok, order_ok
    call MPI_Comm_rank(test_comm(), rank)
    call MPI_Comm_size(test_comm(), nranks)
    n_expected = 0
    id_sum_expected = 0
    do r = 0, nranks - 1
      n_expected = n_expected + count_of(r, nranks, dim)
      do k = 1, count_of(r, nranks, dim)
        id_sum_expected = id_sum_expected + id_of(r, k)
      end do
    end do
    call assert_equal(dim, snap%dim, label // ': dim')
    call assert_equal(step, snap%step, label // ': step')
    call assert_equal(time, snap%time, 0.0_wp, label // ': time')
    call assert_equal('test_case', snap%case_name, label // ': case')
    call assert_true(snap%n_global == n_expected, label // ': N')
    ! extra fields by name, vector and scalar
    kv = snapshot_find_field(snap, 'velocity_exact')
    ks = snapshot_find_field(snap, 'pressure_exact')
    call assert_equal(2, size(snap%extra), label // ': number of extra fields')
    call assert_true(kv > 0 .and. ks > 0, label // ': extra fields found by name')
    if (kv == 0 .or. ks == 0) return
    call assert_true(allocated(snap%extra(kv)%v) .and. .not. allocated(snap%extra(kv)%s), &
                     label // ': velocity_exact is a vector')
    call assert_true(allocated(snap%extra(ks)%s) .and. .not. allocated(snap%extra(ks)%v), &
                     label // ': pressure_exact is a scalar')
    k = snapshot_find_attribute(snap, 'semi_axis_a')
    call assert_true(k > 0, label // ': attribute semi_axis_a')
    if (k > 0) call assert_equal(1.25_wp, snap%attr_values(k), 0.0_wp, label // ': semi_axis_a')
    k = snapshot_find_attribute(snap, 'semi_axis_b')
    call assert_true(k > 0, label // ': attribute semi_axis_b')
    if (k > 0) call assert_equal(0.8_wp, snap%attr_values(k), 0.0_wp, label // ': semi_axis_b')
    call assert_equal(2, size(snap%attr_names), label // ': number of extra attributes')
    ! every row: values from its id (bitwise), id in rank order of the writer
    values_ok = .true.
    order_ok = .true.
    id_sum = 0
    do k = 1, snap%n_local
      associate (id => snap%id(k))
        id_sum = id_sum + id
        do a = 1, dim
          values_ok = values_ok .and. same(snap%x(a, k), fx(a, id)) .and. &
                      same(snap%u(a, k), fu(a, id)) .and. &
                      same(snap%extra(kv)%v(a, k), fv(a, id))
        end do
        values_ok = values_ok .and. same(snap%rho(k), frho(id)) .and. same(snap%p(k), fp(id)) &
                    .and. same(snap%m(k), fm(id)) .and. same(snap%extra(ks)%s(k), fs(id))
      end associate
      ! which writer rank and local index row offset+k came from
      g = snap%offset + k
      acc = 0
      row_rank = -1
      row_k = 0
      do r = 0, nranks - 1
        if (g <= acc + count_of(r, nranks, dim)) then
          row_rank = r
          row_k = int(g - acc)
          exit
        end if
        acc = acc + count_of(r, nranks, dim)
      end do
      order_ok = order_ok .and. row_rank >= 0
      if (row_rank >= 0) order_ok = order_ok .and. snap%id(k) == id_of(row_rank, row_k)
    end do
    call assert_true(values_ok, label // ': values match their ids')
    call assert_true(order_ok, label // ': rows in rank order (offset = exclusive prefix sum)')
    rows = snap%n_local
    call MPI_Allreduce(MPI_IN_PLACE, rows, 1, MPI_INTEGER8, MPI_SUM, test_comm())
    call MPI_Allreduce(MPI_IN_PLACE, id_sum, 1, MPI_INTEGER8, MPI_SUM, test_comm())
    call assert_true(rows == n_expected, label // ': the ranks read every row once')
    call assert_true(id_sum == id_sum_expected, label // ': every id read back')
  end subroutine check_pattern

  !> Bitwise-equal reals (what goes into the file must come back unchanged).
  pure logical function same(a, b)
    real(wp), intent(in) :: a, b
    same = abs(a - b) <= 0.0_wp
  end function same

  !> h5dump's shape of a dataset, e.g. "( 17, 2 )", or '' if h5dump failed.
  function h5dump_shape(file, dataset, out) result(shape)
    character(len=*), intent(in) :: file, dataset, out
    character(len=:), allocatable :: shape
    character(len=512) :: line
    integer :: stat, cstat, u, ios, i, j
    shape = ''
    call execute_command_line('h5dump -H -d /' // dataset // ' ' // file // ' > ' // out // &
                              ' 2>/dev/null', exitstat=stat, cmdstat=cstat)
    if (cstat /= 0 .or. stat /= 0) return
    open(newunit=u, file=out, status='old', action='read', iostat=ios)
    if (ios /= 0) return
    do
      read(u, '(a)', iostat=ios) line
      if (ios /= 0) exit
      i = index(line, 'SIMPLE {')
      if (i > 0) then
        j = index(line, ' / ')
        shape = trim(adjustl(line(i + 8:j - 1)))
      end if
    end do
    close(u, status='delete')
  end function h5dump_shape

  !> h5dump's values of a 1-D dataset on one line ("0, 1, 2"), or ''.
  function h5dump_values(file, dataset, out) result(values)
    character(len=*), intent(in) :: file, dataset, out
    character(len=:), allocatable :: values
    character(len=4096) :: line
    integer :: stat, cstat, u, ios
    logical :: in_data
    values = ''
    call execute_command_line('h5dump -y -w 0 -d /' // dataset // ' ' // file // ' > ' // &
                              out // ' 2>/dev/null', exitstat=stat, cmdstat=cstat)
    if (cstat /= 0 .or. stat /= 0) return
    open(newunit=u, file=out, status='old', action='read', iostat=ios)
    if (ios /= 0) return
    in_data = .false.
    do
      read(u, '(a)', iostat=ios) line
      if (ios /= 0) exit
      if (in_data) then
        values = trim(adjustl(line))
        exit
      end if
      in_data = index(line, 'DATA {') > 0
    end do
    close(u, status='delete')
  end function h5dump_values

  logical function have_command(cmd)
    character(len=*), intent(in) :: cmd
    integer :: stat, cstat
    call execute_command_line('command -v ' // cmd // ' > /dev/null 2>&1', exitstat=stat, &
                              cmdstat=cstat)
    have_command = cstat == 0 .and. stat == 0
  end function have_command

  function itoa(i) result(s)
    integer(i8), intent(in) :: i
    character(len=:), allocatable :: s
    character(len=24) :: b
    write(b, '(i0)') i
    s = trim(b)
  end function itoa

  !> The whole text of a file ('' if it cannot be read).
  function read_text(path) result(text)
    character(len=*), intent(in) :: path
    character(len=:), allocatable :: text
    integer :: u, ios, n
    text = ''
    open(newunit=u, file=path, access='stream', form='unformatted', status='old', &
         action='read', iostat=ios)
    if (ios /= 0) return
    inquire(unit=u, size=n)
    deallocate(text)
    allocate(character(len=n) :: text)
    read(u, iostat=ios) text
    close(u)
  end function read_text

  integer function count_substring(text, sub) result(c)
    character(len=*), intent(in) :: text, sub
    integer :: i, k
    c = 0
    i = 1
    do
      k = index(text(i:), sub)
      if (k == 0) exit
      c = c + 1
      i = i + k + len(sub) - 1
      if (i > len(text)) exit
    end do
  end function count_substring

  ! ------------------------------------------------------------------ tests

  !> mkdir -p of a nested path (twice), a file in the way, atomic write,
  !> rename, exists, remove, and the path helpers.  Each rank in its own
  !> directory.
  subroutine fileutil_basics()
    character(len=:), allocatable :: dir, nested, f1, f2, errmsg
    logical :: ok
    integer :: rank
    character(len=8) :: r
    call MPI_Comm_rank(test_comm(), rank)
    write(r, '(i0)') rank
    dir = make_temp_directory('/tmp/sph_test_fileutil_' // trim(r) // '_')
    ok = len(dir) > 0
    if (ok) ok = is_directory(dir)
    call assert_true(ok, 'make_temp_directory')
    nested = join_path(dir, 'a/b/c')
    call make_directory(nested, ok, errmsg)
    if (ok) ok = is_directory(nested)
    call assert_true(ok, 'nested mkdir: ' // errmsg)
    call make_directory(nested // '/', ok, errmsg)
    call assert_true(ok, 'mkdir of an existing directory is fine: ' // errmsg)
    f1 = join_path(nested, 'one.txt')
    call write_file_atomic(f1, 'hello' // new_line('a'), ok, errmsg)
    if (ok) ok = file_exists(f1)
    call assert_true(ok, 'write_file_atomic: ' // errmsg)
    call assert_true(.not. file_exists(temp_path(f1)), 'no temporary file left')
    call assert_equal(join_path(nested, '.one.txt.tmp'), temp_path(f1), 'temp_path')
    call make_directory(join_path(f1, 'x'), ok, errmsg)
    call assert_true(.not. ok .and. len(errmsg) > 0, 'mkdir under a file fails')
    call make_directory(f1, ok, errmsg)
    call assert_true(.not. ok .and. index(errmsg, 'not a directory') > 0, &
                     'mkdir of an existing file fails: ' // errmsg)
    f2 = join_path(dir, 'two.txt')
    call rename_file(f1, f2, ok, errmsg)
    if (ok) ok = file_exists(f2)
    if (ok) ok = .not. file_exists(f1)
    call assert_true(ok, 'rename: ' // errmsg)
    call rename_file(f1, f2, ok, errmsg)
    call assert_true(.not. ok .and. index(errmsg, 'No such file') > 0, &
                     'rename of a missing file fails with the reason: ' // errmsg)
    call assert_equal('two.txt', base_name(f2), 'base_name')
    call assert_equal(dir, dir_name(f2), 'dir_name')
    call assert_equal('.', dir_name('x.h5'), 'dir_name of a bare name')
    call assert_equal('x.h5', join_path('.', 'x.h5'), 'join_path with "."')
    call assert_equal('d/x.h5', join_path('d/', 'x.h5'), 'join_path with a trailing /')
    call remove_file(f2, ok)
    if (ok) ok = .not. file_exists(f2)
    call assert_true(ok, 'remove_file')
    call remove_file(nested)
    call remove_file(join_path(dir, 'a/b'))
    call remove_file(join_path(dir, 'a'))
    call remove_file(dir, ok)
    if (ok) ok = .not. file_exists(dir)
    call assert_true(ok, 'directories removed')
  end subroutine fileutil_basics

  subroutine roundtrip_2d()
    call roundtrip(2)
  end subroutine roundtrip_2d

  subroutine roundtrip_3d()
    call roundtrip(3)
  end subroutine roundtrip_3d

  !> Write, read back (full and header only), compare with the pattern and
  !> with h5dump's shapes; no temporary file remains.
  subroutine roundtrip(dim)
    integer, intent(in) :: dim
    character(len=:), allocatable :: dir, file, errmsg, shape, n, expected
    character(len=1) :: d
    integer(i8) :: k
    type(snapshot_t) :: snap
    logical :: ok, have
    integer :: rank
    call MPI_Comm_rank(test_comm(), rank)
    have = .false.
    write(d, '(i1)') dim
    dir = shared_scratch('snap' // d // 'd')
    file = join_path(dir, snapshot_filename(3))
    call assert_equal('snap_00003.h5', snapshot_filename(3), 'snapshot_filename')
    call write_pattern(file, dim, 0.625_wp, 42, ok, errmsg)
    call assert_true(ok, 'snapshot_write: ' // errmsg)
    call assert_true(file_exists(file), 'the snapshot exists')
    call assert_true(.not. file_exists(temp_path(file)), 'no temporary file left')
    call snapshot_read(test_comm(), file, snap, ok, errmsg)
    call assert_true(ok, 'snapshot_read: ' // errmsg)
    if (ok) call check_pattern(snap, dim, 0.625_wp, 42, d // 'D read')
    call snapshot_read(test_comm(), file, snap, ok, errmsg, header_only=.true.)
    call assert_true(ok, 'snapshot_read header_only: ' // errmsg)
    if (ok) then
      call assert_equal(0, snap%n_local, 'header only: no rows')
      call assert_equal(2, size(snap%extra), 'header only: extra fields listed')
      call assert_equal(dim, snap%dim, 'header only: dim')
    end if
    ! an independent view: h5dump shows (N, dim) and (N)
    n = itoa(snap%n_global)
    if (rank == 0) have = have_command('h5dump')
    if (have) then
      shape = h5dump_shape(file, 'position', join_path(dir, 'h5dump.txt'))
      call assert_equal('( ' // n // ', ' // d // ' )', shape, 'h5dump shape of position')
      shape = h5dump_shape(file, 'velocity_exact', join_path(dir, 'h5dump.txt'))
      call assert_equal('( ' // n // ', ' // d // ' )', shape, 'h5dump shape of velocity_exact')
      shape = h5dump_shape(file, 'id', join_path(dir, 'h5dump.txt'))
      call assert_equal('( ' // n // ' )', shape, 'h5dump shape of id')
      shape = h5dump_shape(file, 'pressure_exact', join_path(dir, 'h5dump.txt'))
      call assert_equal('( ' // n // ' )', shape, 'h5dump shape of pressure_exact')
      ! the XDMF vertex list: row numbers 0 .. N-1 whatever the rank count
      expected = '0'
      do k = 1, snap%n_global - 1
        expected = expected // ', ' // itoa(k)
      end do
      call assert_equal(expected, h5dump_values(file, 'connectivity', &
                        join_path(dir, 'h5dump.txt')), 'connectivity is 0 .. N-1')
    end if
    call cleanup(dir, [character(len=16) :: 'snap_00003.h5', 'h5dump.txt'])
  end subroutine roundtrip

  !> Two snapshots through an index: the XDMF names both files and times,
  !> has the right shapes (those h5dump shows) and balanced tags, and parses
  !> as XML when /usr/bin/python3 is there.
  subroutine xdmf_two_snapshots()
    character(len=:), allocatable :: dir, errmsg, text, n, shape
    type(xdmf_index_t) :: xdmf
    type(snapshot_t) :: snap
    logical :: ok, have
    integer :: rank, stat, cstat
    call MPI_Comm_rank(test_comm(), rank)
    have = .false.
    dir = shared_scratch('xdmf')
    call xdmf_init(xdmf, join_path(dir, 'snapshots.xdmf'))
    call write_pattern(join_path(dir, snapshot_filename(0)), 2, 0.0_wp, 0, ok, errmsg, xdmf)
    call assert_true(ok, 'first snapshot: ' // errmsg)
    call write_pattern(join_path(dir, snapshot_filename(1)), 2, 0.375_wp, 12, ok, errmsg, xdmf)
    call assert_true(ok, 'second snapshot: ' // errmsg)
    call assert_equal(2, xdmf%count, 'two entries')
    call assert_true(.not. file_exists(temp_path(xdmf%path)), 'no temporary index left')
    call snapshot_read(test_comm(), join_path(dir, snapshot_filename(1)), snap, ok, errmsg, &
                       header_only=.true.)
    n = itoa(snap%n_global)
    text = read_text(xdmf%path)
    call assert_true(index(text, '<Xdmf Version="3.0">') > 0, 'XDMF 3 header')
    call assert_true(index(text, 'CollectionType="Temporal"') > 0, 'temporal collection')
    call assert_true(index(text, '<Time Value="0.0000000000000000E+000"/>') > 0, 'first time')
    call assert_true(index(text, '<Time Value="3.7500000000000000E-001"/>') > 0, 'second time')
    call assert_equal(2, count_substring(text, '<Time '), 'two times')
    call assert_true(index(text, '>snap_00000.h5:/position</DataItem>') > 0, 'first file')
    call assert_true(index(text, '>snap_00001.h5:/position</DataItem>') > 0, 'second file')
    call assert_true(index(text, '<Grid Name="snap_00001" GridType="Uniform">') > 0, 'grid name')
    call assert_true(index(text, 'NumberType="Int" Precision="4" Format="HDF">' // &
                           'snap_00001.h5:/connectivity</DataItem>') > 0, 'Polyvertex vertices')
    call assert_true(index(text, '>snap_00001.h5:/velocity_exact</DataItem>') > 0, &
                     'extra vector field')
    call assert_true(index(text, '>snap_00001.h5:/pressure_exact</DataItem>') > 0, &
                     'extra scalar field')
    call assert_equal(2, count_substring(text, 'GeometryType="XY"'), 'XY geometry')
    call assert_equal(2, count_substring(text, 'NumberOfElements="' // n // '"'), 'Polyvertex N')
    ! per snapshot: position, velocity, velocity_exact are (N 2); density,
    ! pressure, mass, id, pressure_exact are (N)
    call assert_equal(6, count_substring(text, 'Dimensions="' // n // ' 2"'), 'vector shapes')
    call assert_equal(12, count_substring(text, 'Dimensions="' // n // '"'), &
                      'scalar shapes (with the connectivity)')
    call assert_equal(2, count_substring(text, 'NumberType="Int" Precision="8"'), 'int64 id')
    call assert_equal(14, count_substring(text, 'Center="Node"'), 'attributes at nodes')
    call assert_equal(3, count_substring(text, '<Grid '), 'opening Grid tags')
    call assert_equal(3, count_substring(text, '</Grid>'), 'closing Grid tags')
    call assert_equal(18, count_substring(text, '<DataItem '), 'opening DataItem tags')
    call assert_equal(18, count_substring(text, '</DataItem>'), 'closing DataItem tags')
    call assert_equal(2, count_substring(text, '</Topology>'), 'closing Topology tags')
    call assert_equal(count_substring(text, '<Attribute '), count_substring(text, '</Attribute>'), &
                      'balanced Attribute tags')
    if (rank == 0) have = have_command('h5dump')
    if (have) then
      shape = h5dump_shape(join_path(dir, snapshot_filename(1)), 'position', &
                           join_path(dir, 'h5dump.txt'))
      call assert_equal('( ' // n // ', 2 )', shape, 'XDMF dims are those h5dump shows')
    end if
    if (rank == 0) have = file_exists('/usr/bin/python3')
    if (have) then
      call execute_command_line('/usr/bin/python3 -c "import sys, xml.etree.ElementTree as E; ' &
                                // 'E.parse(sys.argv[1])" ' // xdmf%path // ' 2>/dev/null', &
                                exitstat=stat, cmdstat=cstat)
      call assert_true(cstat == 0 .and. stat == 0, 'the index parses as XML')
    end if
    ! literal names: gfortran 12 ignores the type-spec length of an array
    ! constructor whose first item is a deferred-length function result
    call cleanup(dir, [character(len=16) :: 'snap_00000.h5', 'snap_00001.h5', &
                       'snapshots.xdmf', 'h5dump.txt'])
  end subroutine xdmf_two_snapshots

  !> N = 0 (every rank empty): the file is written and read back empty.
  subroutine empty_snapshot()
    character(len=:), allocatable :: dir, file, errmsg
    type(snapshot_t) :: snap
    type(snapshot_field_t) :: extra(1)
    integer(i8) :: id(0)
    real(wp) :: x(3, 0), rho(0)
    logical :: ok
    dir = shared_scratch('snapempty')
    file = join_path(dir, 'empty.h5')
    extra(1)%name = 'pressure_exact'
    allocate(extra(1)%s(0))
    call snapshot_write(test_comm(), file, 2.0_wp, 7, 3, 'empty', 0, id, x, x, rho, rho, rho, &
                        ok, errmsg, extra=extra)
    call assert_true(ok, 'writing an empty snapshot: ' // errmsg)
    call snapshot_read(test_comm(), file, snap, ok, errmsg)
    call assert_true(ok, 'reading it back: ' // errmsg)
    if (.not. ok) return
    call assert_true(snap%n_global == 0 .and. snap%n_local == 0, 'no rows')
    call assert_equal(3, snap%dim, 'dim')
    call assert_equal(7, snap%step, 'step')
    call assert_equal(1, size(snap%extra), 'the extra field is listed')
    call cleanup(dir, [character(len=8) :: 'empty.h5'])
  end subroutine empty_snapshot

  !> A bad argument on one rank only fails the write on every rank, with the
  !> same message, and leaves no file; a missing file fails the read.
  subroutine bad_arguments()
    character(len=:), allocatable :: dir, file, errmsg, first
    type(snapshot_t) :: snap
    integer(i8) :: id(4)
    real(wp) :: x(2, 4), rho(4)
    logical :: ok, same
    integer :: rank, nranks, n, len_first
    call MPI_Comm_rank(test_comm(), rank)
    call MPI_Comm_size(test_comm(), nranks)
    dir = shared_scratch('snapbad')
    file = join_path(dir, 'bad.h5')
    id = [1, 2, 3, 4] + 4_i8 * rank
    x = 0
    rho = 1
    n = 4
    if (rank == nranks - 1) n = 5   ! more particles than the arrays hold
    call snapshot_write(test_comm(), file, 0.0_wp, 0, 2, 'bad', n, id, x, x, rho, rho, rho, &
                        ok, errmsg)
    call assert_true(.not. ok, 'a short array on the last rank fails everywhere')
    call assert_true(index(errmsg, 'shorter than n_local') > 0, 'the reason: ' // errmsg)
    ! the same message on every rank
    first = errmsg
    len_first = len(first)
    call MPI_Bcast(len_first, 1, MPI_INTEGER, 0, test_comm())
    if (rank /= 0) then
      deallocate(first)
      allocate(character(len=len_first) :: first)
    end if
    call MPI_Bcast(first, len_first, MPI_CHARACTER, 0, test_comm())
    same = first == errmsg
    call assert_true(same, 'every rank has the same message')
    ok = file_exists(file)
    if (.not. ok) ok = file_exists(temp_path(file))
    call assert_true(.not. ok, 'no file left behind')
    call snapshot_write(test_comm(), file, 0.0_wp, 0, 4, 'bad', 4, id, x, x, rho, rho, rho, &
                        ok, errmsg)
    call assert_true(.not. ok .and. index(errmsg, 'dim') > 0, 'dim 4 is refused: ' // errmsg)
    call snapshot_read(test_comm(), join_path(dir, 'missing.h5'), snap, ok, errmsg)
    call assert_true(.not. ok .and. index(errmsg, 'missing.h5') > 0, &
                     'reading a missing file fails: ' // errmsg)
    ok = rank /= 0
    errmsg = 'only rank 0 failed'
    call agree_ok(test_comm(), ok, errmsg)
    call assert_true(.not. ok .and. errmsg == 'only rank 0 failed', 'agree_ok spreads a failure')
    call cleanup(dir, [character(len=8) :: 'bad.h5'])
  end subroutine bad_arguments

end module test_snapshot_io
