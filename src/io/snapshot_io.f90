!> Particle snapshots in parallel HDF5 (doc/reference/output.md describes
!> the files): written by every rank, read back by any number of ranks.
!>
!> One file per output time for the whole run, written collectively by every
!> rank of the communicator: rank r contributes its n_r local particles as
!> the rows offset_r + 1 .. offset_r + n_r, offset_r = n_0 + ... + n_{r-1}
!> (MPI_Exscan), so the layout is the same for any rank count except the
!> order of the rows; the int64 dataset `id` lets a reader sort them.
!> Fortran arrays x(dim, N) are datasets that h5py sees with shape (N, dim).
!>
!> Every file is written to a hidden temporary name in its directory and
!> renamed when complete (fileutil), so a reader never sees a partial file.
!> All procedures here are collective over the communicator they are given
!> and return the same ok and errmsg on every rank.  Argument errors are
!> agreed on before the first HDF5 call (a computed field's shape, known
!> only once it is made, before it is written); an HDF5 failure is assumed
!> to hit every rank alike (as file creation, space and permission errors do).
!>
!> Besides the fields, each snapshot holds `connectivity` (0 .. N-1), the
!> vertex list of the XDMF Polyvertex topology: without it ParaView's Xdmf3
!> readers load the points but make no cells, and most filters need cells.
!>
!> The fields and their kinds are snapshot_fields', the HDF5 calls
!> hdf5_helpers', the index xdmf_index's; this module re-exports the names
!> its callers need with snapshot_write and snapshot_read.
module snapshot_io
  use, intrinsic :: iso_c_binding, only: c_ptr, c_loc
  use, intrinsic :: iso_fortran_env, only: int32
  use kinds, only: wp, i8
  use shares, only: share_range
  use mpi_f08, only: MPI_Comm, MPI_Comm_rank, MPI_Comm_size, MPI_Exscan, MPI_Allreduce, &
                     MPI_INTEGER8, MPI_INTEGER, MPI_SUM, MPI_MAX, MPI_IN_PLACE
  use hdf5, only: hid_t, hsize_t, h5open_f, h5close_f, h5fclose_f, h5pclose_f, h5eset_auto_f, &
                  h5aexists_f, H5T_NATIVE_DOUBLE, H5T_IEEE_F64LE, H5T_STD_I32LE, &
                  H5T_STD_I64LE, h5kind_to_type, H5_INTEGER_KIND
  use fileutil, only: temp_path, rename_file, remove_file, agree_ok, base_name, dir_name, &
                      file_exists, is_directory, free_bytes
  use hdf5_helpers, only: open_parallel, write_block, read_block, write_attr_real, &
                          write_attr_int, write_attr_string, read_attr_real, read_attr_int, &
                          read_attr_string, attr_is_real_scalar, dataset_shape, &
                          root_link_names, root_attribute_names
  use snapshot_fields, only: snapshot_field_t, snapshot_source_t, SNAPSHOT_NAME_LEN, &
                             STANDARD_DATASETS, RESERVED_ATTRIBUTES, kind_of, field_s, &
                             field_v, field_i, check_fields, check_attribute_names
  use xdmf_index, only: xdmf_index_t, xdmf_init, xdmf_add, xdmf_write, connectivity_precision
  implicit none
  private
  public :: snapshot_t, snapshot_write, snapshot_read, snapshot_filename
  public :: snapshot_find_field, snapshot_find_attribute, snapshot_get_field
  public :: SNAPSHOT_FORMAT_VERSION
  ! the names that come with snapshot_write's and snapshot_read's arguments
  public :: snapshot_field_t, snapshot_source_t, SNAPSHOT_NAME_LEN
  public :: xdmf_index_t, xdmf_init, xdmf_add, xdmf_write

  integer, parameter :: SNAPSHOT_FORMAT_VERSION = 1 !< root attribute `format_version`

  !> A snapshot as read back: this rank's contiguous block of rows
  !> offset+1 .. offset+n_local of the file's N = n_global rows.
  type :: snapshot_t
    real(wp) :: time = 0.0_wp
    integer :: step = 0
    integer :: dim = 0
    character(len=:), allocatable :: case_name
    integer(i8) :: n_global = 0
    integer(i8) :: offset = 0
    integer :: n_local = 0
    integer(i8), allocatable :: id(:)
    real(wp), allocatable :: x(:,:), u(:,:), rho(:), p(:), m(:)
    type(snapshot_field_t), allocatable :: extra(:)    !< by name, alphabetical
    character(len=SNAPSHOT_NAME_LEN), allocatable :: attr_names(:)   !< alphabetical
    real(wp), allocatable :: attr_values(:)
  end type snapshot_t
  !> A snapshot file open for collective I/O and this rank's rows in it,
  !> offset+1 .. offset+n_local of n_global.
  type :: snapshot_file_t
    character(len=:), allocatable :: path
    integer(hid_t) :: id = -1              !< the file, -1 unless open
    integer(hid_t) :: dxpl = -1            !< its collective transfers, -1 unless made
    integer :: n_local = 0
    integer(i8) :: offset = 0
    integer(i8) :: n_global = 0
    logical :: header_only = .false.       !< reading: shapes checked, no rows read
  end type snapshot_file_t

contains

  !> The snapshot file name for output number k (from 0): snap_00000.h5.
  function snapshot_filename(k) result(name)
    integer, intent(in) :: k
    character(len=:), allocatable :: name
    character(len=32) :: s
    write(s, '(a,i5.5,a)') 'snap_', k, '.h5'
    name = trim(s)
  end function snapshot_filename

  ! ==================== writing ====================

  !> Writes one snapshot collectively.  Every rank passes its n_local
  !> particles as `fields`, one dataset each in the order given: the
  !> standard ones (position, velocity, density, pressure, mass, id) and
  !> any others, the extra fields (arrays may be longer: the first n_local
  !> entries are written; vectors may have more rows than dim: the first
  !> dim rows are written).  time, step, dim, case_name, the names and kinds
  !> of the fields and the attributes must be the same on every rank.
  !> attr_names/attr_values add real root attributes.  If `index` is given,
  !> the snapshot is added to it and the index file is rewritten (the
  !> snapshot's name in the index is relative to the index's directory).
  !> `source` makes the computed fields, in the order of `fields`.
  subroutine snapshot_write(comm, filename, time, step, dim, case_name, n_local, fields, &
                            ok, errmsg, attr_names, attr_values, index, source)
    type(MPI_Comm), intent(in) :: comm
    character(len=*), intent(in) :: filename, case_name
    real(wp), intent(in) :: time
    integer, intent(in) :: step, dim, n_local
    type(snapshot_field_t), intent(in), target :: fields(:)
    logical, intent(out) :: ok
    character(len=:), allocatable, intent(out) :: errmsg
    character(len=*), intent(in), optional :: attr_names(:)
    real(wp), intent(in), optional :: attr_values(:)
    type(xdmf_index_t), intent(inout), optional :: index
    class(snapshot_source_t), intent(inout), optional :: source

    type(snapshot_file_t) :: f
    integer(i8) :: n8, need
    integer :: err, rank, counts(2)
    character(len=:), allocatable :: rel
    logical :: closed

    call MPI_Comm_rank(comm, rank)

    ! ---- arguments (local), then agreement before any collective call ----
    call check_write_arguments(fields, dim, n_local, present(source), ok, errmsg, &
                               attr_names, attr_values)
    counts = [size(fields), -size(fields)]
    call MPI_Allreduce(MPI_IN_PLACE, counts, 2, MPI_INTEGER, MPI_MAX, comm)
    if (ok .and. counts(1) /= -counts(2)) then
      ok = .false.
      errmsg = 'snapshot_write: ranks pass different numbers of fields'
    end if
    call agree_ok(comm, ok, errmsg)
    if (.not. ok) return

    ! ---- this rank's rows ----
    f%n_local = n_local
    n8 = int(n_local, i8)
    call MPI_Exscan(n8, f%offset, 1, MPI_INTEGER8, MPI_SUM, comm)
    if (rank == 0) f%offset = 0
    call MPI_Allreduce(n8, f%n_global, 1, MPI_INTEGER8, MPI_SUM, comm)

    ! ---- room for it: a full disk is said in one line, before HDF5 fails ----
    need = needed_bytes(fields, dim, f%n_global)
    if (rank == 0) call check_room(filename, need, ok, errmsg)
    call agree_ok(comm, ok, errmsg)
    if (.not. ok) return

    ! ---- the file, under its temporary name ----
    call h5open_f(err)
    ! what fails is said in errmsg: HDF5's own error stack is not printed
    call h5eset_auto_f(0, err)
    f%path = temp_path(filename)
    closed = .false.
    ok = .false.
    io: block
      if (.not. open_parallel(f%path, .true., comm, f%id, f%dxpl, errmsg)) exit io
      if (.not. write_fields(f, comm, fields, dim, errmsg, source)) exit io
      if (.not. write_connectivity(f, errmsg)) exit io
      if (.not. write_root_attributes(f%id, time, step, dim, case_name, errmsg, &
                                      attr_names, attr_values)) exit io
      call h5pclose_f(f%dxpl, err)
      f%dxpl = -1
      call h5fclose_f(f%id, err)   ! collective: every rank's data is in
      closed = .true.
      if (err < 0) then
        errmsg = 'HDF5: cannot close "' // f%path // '"'
        exit io
      end if
      ok = .true.
    end block io
    if (.not. closed) then
      if (f%dxpl >= 0) call h5pclose_f(f%dxpl, err)
      if (f%id >= 0) call h5fclose_f(f%id, err)
    end if
    if (.not. ok) then
      ! the disk filled while writing (another process, a larger estimate)
      if (room_left(filename) < need) &
        errmsg = 'no space left on device writing "' // filename // '" (' // errmsg // ')'
      ! a file whose flush failed stays open in HDF5, which would close it
      ! again at exit, after MPI_Finalize, and crash: end the library now
      ! (its next start prints HDF5's errors again, as does this)
      call h5close_f(err)
    else
      call h5eset_auto_f(1, err)
    end if
    call agree_ok(comm, ok, errmsg)

    ! ---- publish: rename on rank 0 (after every rank has closed the file) ----
    if (rank == 0) then
      if (ok) then
        call rename_file(f%path, filename, ok, errmsg)
      end if
      if (.not. ok) call remove_file(f%path)
    end if
    call agree_ok(comm, ok, errmsg)
    if (.not. ok) return

    if (present(index)) then
      if (dir_name(filename) == dir_name(index%path)) then
        rel = base_name(filename)
      else
        rel = filename
      end if
      call xdmf_add(index, time, rel, f%n_global, dim, fields)
      call xdmf_write(comm, index, ok, errmsg)
    end if
  end subroutine snapshot_write

  !> snapshot_write's arguments on this rank: dim, n_local, the attributes'
  !> names (snapshot_fields), then the fields.
  subroutine check_write_arguments(fields, dim, n_local, has_source, good, msg, &
                                   attr_names, attr_values)
    type(snapshot_field_t), intent(in) :: fields(:)
    integer, intent(in) :: dim, n_local
    logical, intent(in) :: has_source
    logical, intent(out) :: good
    character(len=:), allocatable, intent(out) :: msg
    character(len=*), intent(in), optional :: attr_names(:)
    real(wp), intent(in), optional :: attr_values(:)
    good = .false.
    if (dim /= 2 .and. dim /= 3) then
      msg = 'snapshot_write: dim must be 2 or 3'
    else if (n_local < 0) then
      msg = 'snapshot_write: negative n_local'
    else if (present(attr_names) .neqv. present(attr_values)) then
      msg = 'snapshot_write: give attr_names and attr_values together'
    else
      good = .true.
    end if
    if (.not. good) return
    if (present(attr_names)) then
      if (size(attr_names) /= size(attr_values)) then
        good = .false.
        msg = 'snapshot_write: attr_names and attr_values differ in size'
        return
      end if
      call check_attribute_names(attr_names, good, msg)
      if (.not. good) return
    end if
    call check_fields(fields, dim, n_local, has_source, good, msg)
  end subroutine check_write_arguments

  !> The file's size, from below: the datasets' bytes, without HDF5's own.
  integer(i8) function needed_bytes(fields, dim, n_global) result(b)
    type(snapshot_field_t), intent(in) :: fields(:)
    integer, intent(in) :: dim
    integer(i8), intent(in) :: n_global
    integer :: j
    b = 4 * n_global                                    ! connectivity
    do j = 1, size(fields)
      if (kind_of(fields(j)) == 'v') then
        b = b + 8 * dim * n_global
      else
        b = b + 8 * n_global
      end if
    end do
  end function needed_bytes

  !> The free bytes where `filename` goes (huge if that cannot be told).
  integer(i8) function room_left(filename) result(b)
    character(len=*), intent(in) :: filename
    b = free_bytes(dir_name(filename))
    if (b < 0) b = huge(b)
  end function room_left

  !> Whether `need` bytes are free for `filename`, else the message.
  subroutine check_room(filename, need, good, msg)
    character(len=*), intent(in) :: filename
    integer(i8), intent(in) :: need
    logical, intent(out) :: good
    character(len=:), allocatable, intent(out) :: msg
    integer(i8) :: free
    character(len=64) :: s
    free = room_left(filename)
    good = free >= need
    msg = ''
    if (.not. good) then
      write(s, '(f12.3)') real(free, wp) / 1e6_wp
      msg = 'no space left on device for "' // filename // '": ' // trim(adjustl(s))
      write(s, '(f12.3)') real(need, wp) / 1e6_wp
      msg = msg // ' MB free, the snapshot needs at least ' // trim(adjustl(s)) // ' MB'
    end if
  end subroutine check_room

  !> The fields' datasets, in the order given; `source` makes the computed ones.
  logical function write_fields(f, comm, fields, dim, errmsg, source) result(good)
    type(snapshot_file_t), intent(in) :: f
    type(MPI_Comm), intent(in) :: comm
    type(snapshot_field_t), intent(in), target :: fields(:)
    integer, intent(in) :: dim
    character(len=:), allocatable, intent(inout) :: errmsg
    class(snapshot_source_t), intent(inout), optional :: source
    integer(i8), target :: idummy(1)
    integer :: k
    good = .false.
    do k = 1, size(fields)
      if (fields(k)%computed /= ' ') then
        if (.not. write_computed(f, comm, fields(k), dim, source, errmsg)) return
        cycle
      end if
      associate (fk => fields(k))
        select case (kind_of(fk))
        case ('i')
          if (.not. write_block(f%id, f%dxpl, fk%name, H5T_STD_I64LE, &
                                h5kind_to_type(i8, H5_INTEGER_KIND), &
                                loc_i1(field_i(fk), idummy), 1, 1, f%n_local, f%offset, &
                                f%n_global, errmsg)) return
        case ('s')
          if (.not. write_real(f, fk%name, field_s(fk), 1, 1, errmsg)) return
        case default
          if (.not. write_real(f, fk%name, field_v(fk), size(field_v(fk), 1), dim, &
                               errmsg)) return
        end select
      end associate
    end do
    good = .true.
  end function write_fields

  !> A computed field: made by `source`, its shape agreed on by the ranks
  !> (it is only known now), written, and freed on return.
  logical function write_computed(f, comm, declared, dim, source, errmsg) result(good)
    type(snapshot_file_t), intent(in) :: f
    type(MPI_Comm), intent(in) :: comm
    type(snapshot_field_t), intent(in) :: declared
    integer, intent(in) :: dim
    class(snapshot_source_t), intent(inout) :: source
    character(len=:), allocatable, intent(inout) :: errmsg
    type(snapshot_field_t), target :: made
    made%name = declared%name
    made%computed = declared%computed
    call source%fill(made)
    if (made%computed == 's') then
      good = allocated(made%s) .and. .not. allocated(made%v)
      if (good) good = size(made%s) >= f%n_local
    else
      good = allocated(made%v) .and. .not. allocated(made%s)
      if (good) good = size(made%v, 1) >= dim .and. size(made%v, 2) >= f%n_local
    end if
    if (.not. good) errmsg = 'snapshot_write: the source made field "' // made%name // &
                             '" of another kind or shape than declared'
    call agree_ok(comm, good, errmsg)
    if (.not. good) return
    if (made%computed == 's') then
      good = write_real(f, made%name, made%s, 1, 1, errmsg)
    else
      good = write_real(f, made%name, made%v, size(made%v, 1), dim, errmsg)
    end if
  end function write_computed

  !> `connectivity`: the row numbers 0 .. N-1, the vertex list of the
  !> XDMF Polyvertex topology (int32 unless N needs int64).
  logical function write_connectivity(f, errmsg) result(good)
    type(snapshot_file_t), intent(in) :: f
    character(len=:), allocatable, intent(inout) :: errmsg
    integer(int32), allocatable, target :: c32(:)
    integer(i8), allocatable, target :: c64(:)
    integer :: j
    if (connectivity_precision(f%n_global) == 4) then
      allocate(c32(max(f%n_local, 1)))
      c32(1:f%n_local) = [(int(f%offset + j - 1, int32), j = 1, f%n_local)]
      good = write_block(f%id, f%dxpl, 'connectivity', H5T_STD_I32LE, &
                         h5kind_to_type(int32, H5_INTEGER_KIND), c_loc(c32), &
                         1, 1, f%n_local, f%offset, f%n_global, errmsg)
    else
      allocate(c64(max(f%n_local, 1)))
      c64(1:f%n_local) = [(f%offset + j - 1, j = 1, f%n_local)]
      good = write_block(f%id, f%dxpl, 'connectivity', H5T_STD_I64LE, &
                         h5kind_to_type(i8, H5_INTEGER_KIND), c_loc(c64), &
                         1, 1, f%n_local, f%offset, f%n_global, errmsg)
    end if
  end function write_connectivity

  !> The root attributes: the reserved ones, then attr_names/attr_values.
  logical function write_root_attributes(fid, time, step, dim, case_name, errmsg, &
                                         attr_names, attr_values) result(good)
    integer(hid_t), intent(in) :: fid
    real(wp), intent(in) :: time
    integer, intent(in) :: step, dim
    character(len=*), intent(in) :: case_name
    character(len=:), allocatable, intent(inout) :: errmsg
    character(len=*), intent(in), optional :: attr_names(:)
    real(wp), intent(in), optional :: attr_values(:)
    integer :: k
    good = .false.
    if (.not. write_attr_real(fid, 'time', time, errmsg)) return
    if (.not. write_attr_int(fid, 'step', step, errmsg)) return
    if (.not. write_attr_int(fid, 'dim', dim, errmsg)) return
    if (.not. write_attr_string(fid, 'case', case_name, errmsg)) return
    if (.not. write_attr_int(fid, 'format_version', SNAPSHOT_FORMAT_VERSION, errmsg)) return
    if (present(attr_names)) then
      do k = 1, size(attr_names)
        if (.not. write_attr_real(fid, trim(attr_names(k)), attr_values(k), errmsg)) return
      end do
    end if
    good = .true.
  end function write_root_attributes

  !> A real dataset: ncomp = 1 gives (N), else (ncomp, N) from the
  !> leading `lead` x n_local block of `a`.
  logical function write_real(f, name, a, lead, ncomp, errmsg)
    type(snapshot_file_t), intent(in) :: f
    character(len=*), intent(in) :: name
    real(wp), intent(in), target :: a(..)
    integer, intent(in) :: lead, ncomp
    character(len=:), allocatable, intent(inout) :: errmsg
    real(wp), target :: rdummy(1)
    type(c_ptr) :: buf
    buf = c_loc(rdummy)
    select rank (a)
    rank (1)
      if (size(a) > 0) buf = c_loc(a)
    rank (2)
      if (size(a) > 0) buf = c_loc(a)
    end select
    write_real = write_block(f%id, f%dxpl, name, H5T_IEEE_F64LE, H5T_NATIVE_DOUBLE, buf, &
                             lead, ncomp, f%n_local, f%offset, f%n_global, errmsg)
  end function write_real

  ! ==================== reading ====================

  !> Reads a snapshot collectively: each rank gets a contiguous block of
  !> rows (rank r of P: rows floor(r N/P) + 1 .. floor((r+1) N/P)), with
  !> every standard dataset, the extra fields (any other real dataset of
  !> shape (N) or (dim, N)) and the real root attributes besides the
  !> standard ones.  With header_only, only the attributes, N and the names
  !> and kinds of the extra fields are read (arrays allocated with 0 rows).
  subroutine snapshot_read(comm, filename, snap, ok, errmsg, header_only)
    type(MPI_Comm), intent(in) :: comm
    character(len=*), intent(in) :: filename
    type(snapshot_t), intent(out), target :: snap
    logical, intent(out) :: ok
    character(len=:), allocatable, intent(out) :: errmsg
    logical, intent(in), optional :: header_only

    type(snapshot_file_t) :: f
    integer :: err, rank, nranks
    character(len=:), allocatable :: tmp_s

    f%path = filename
    if (present(header_only)) f%header_only = header_only
    call MPI_Comm_rank(comm, rank)
    call MPI_Comm_size(comm, nranks)
    call h5open_f(err)
    ! what fails is said in errmsg: HDF5's own error stack is not printed
    call h5eset_auto_f(0, err)
    ok = .false.
    io: block
      if (.not. file_exists(filename)) then
        errmsg = 'no file "' // filename // '"'
        exit io
      end if
      if (is_directory(filename)) then        ! MPI-IO would fail at length
        errmsg = '"' // filename // '" is a directory, not a snapshot file'
        exit io
      end if
      if (.not. open_parallel(filename, .false., comm, f%id, f%dxpl, errmsg)) exit io
      if (.not. read_header(f, snap, errmsg)) exit io
      if (.not. read_standard_fields(f, rank, nranks, snap, errmsg)) exit io
      if (.not. read_extra_fields(f, snap, errmsg)) exit io
      if (.not. read_extra_attributes(f, snap, errmsg)) exit io
      ok = .true.
    end block io
    call h5eset_auto_f(1, err)
    if (f%dxpl >= 0) call h5pclose_f(f%dxpl, err)
    if (f%id >= 0) then
      call h5fclose_f(f%id, err)
      if (ok .and. err < 0) then
        ok = .false.
        errmsg = 'HDF5: cannot close "' // filename // '"'
      end if
    end if
    if (ok) errmsg = ''
    if (.not. ok) then
      tmp_s = errmsg
      errmsg = 'snapshot_read: ' // tmp_s
    end if
    call agree_ok(comm, ok, errmsg)
    if (.not. allocated(snap%case_name)) snap%case_name = ''
  end subroutine snapshot_read

  !> The reserved root attributes: time, step, dim, case, and a format this
  !> program reads.
  logical function read_header(f, snap, errmsg) result(good)
    type(snapshot_file_t), intent(in) :: f
    type(snapshot_t), intent(inout) :: snap
    character(len=:), allocatable, intent(inout) :: errmsg
    integer :: version, err
    logical :: exists
    good = .false.
    if (.not. read_attr_real(f%id, 'time', snap%time, errmsg)) return
    if (.not. read_attr_int(f%id, 'step', snap%step, errmsg)) return
    if (.not. read_attr_int(f%id, 'dim', snap%dim, errmsg)) return
    if (.not. read_attr_string(f%id, 'case', snap%case_name, errmsg)) return
    call h5aexists_f(f%id, 'format_version', exists, err)
    if (exists) then
      if (.not. read_attr_int(f%id, 'format_version', version, errmsg)) return
      if (version > SNAPSHOT_FORMAT_VERSION) then
        errmsg = 'snapshot "' // f%path // '" has a newer format than this program reads'
        return
      end if
    end if
    if (snap%dim /= 2 .and. snap%dim /= 3) then
      errmsg = 'snapshot "' // f%path // '": attribute dim is neither 2 nor 3'
      return
    end if
    good = .true.
  end function read_header

  !> N from `position`, this rank's block of rows of it (in f and snap),
  !> and the standard datasets' rows.
  logical function read_standard_fields(f, rank, nranks, snap, errmsg) result(good)
    type(snapshot_file_t), intent(inout) :: f
    integer, intent(in) :: rank, nranks
    type(snapshot_t), intent(inout), target :: snap
    character(len=:), allocatable, intent(inout) :: errmsg
    integer(hsize_t) :: dims(2)
    integer :: ndims
    integer(i8) :: first, last
    integer(i8), target :: idummy(1)
    good = .false.
    if (.not. dataset_shape(f%id, 'position', ndims, dims)) then
      errmsg = '"' // f%path // '" has no dataset position'
      return
    end if
    if (ndims /= 2 .or. dims(1) /= int(snap%dim, hsize_t)) then
      errmsg = 'snapshot "' // f%path // '": position is not (dim, N)'
      return
    end if
    snap%n_global = int(dims(2), i8)
    call share_range(snap%n_global, rank, nranks, first, last)
    snap%offset = first - 1
    snap%n_local = int(last - first + 1)
    if (f%header_only) snap%n_local = 0
    f%n_global = snap%n_global
    f%offset = snap%offset
    f%n_local = snap%n_local
    associate (n => snap%n_local, d => snap%dim)
      allocate(snap%id(n), snap%x(d, n), snap%u(d, n), snap%rho(n), snap%p(n), snap%m(n))
    end associate

    if (.not. read_real(f, snap%x, 'position', snap%dim, errmsg)) return
    if (.not. read_real(f, snap%u, 'velocity', snap%dim, errmsg)) return
    if (.not. read_real(f, snap%rho, 'density', 1, errmsg)) return
    if (.not. read_real(f, snap%p, 'pressure', 1, errmsg)) return
    if (.not. read_real(f, snap%m, 'mass', 1, errmsg)) return
    if (.not. check_shape(f, 'id', 1, errmsg)) return
    if (.not. f%header_only) then
      if (.not. read_block(f%id, f%dxpl, 'id', h5kind_to_type(i8, H5_INTEGER_KIND), &
                           loc_i1(snap%id, idummy), 1, f%n_local, f%offset, errmsg)) return
    end if
    good = .true.
  end function read_standard_fields

  !> The extra fields: every other real dataset of shape (N) or (dim, N),
  !> by name.
  logical function read_extra_fields(f, snap, errmsg) result(good)
    type(snapshot_file_t), intent(in) :: f
    type(snapshot_t), intent(inout), target :: snap
    character(len=:), allocatable, intent(inout) :: errmsg
    character(len=SNAPSHOT_NAME_LEN), allocatable :: names(:)
    integer, allocatable :: which(:), ncomp(:)
    integer(hsize_t) :: dims(2)
    integer :: j, k, nd, nfound
    logical :: is_float
    good = .false.
    call root_link_names(f%id, names)
    allocate(which(size(names)), ncomp(size(names)))
    nfound = 0
    do j = 1, size(names)
      if (any(STANDARD_DATASETS == names(j))) cycle
      if (.not. dataset_shape(f%id, trim(names(j)), nd, dims, is_float)) cycle
      if (.not. is_float .or. nd < 1 .or. nd > 2) cycle
      if (dims(nd) /= int(snap%n_global, hsize_t)) cycle
      if (nd == 1 .or. dims(1) == int(snap%dim, hsize_t)) then
        nfound = nfound + 1
        which(nfound) = j
        ncomp(nfound) = merge(1, snap%dim, nd == 1)
      end if
    end do
    allocate(snap%extra(nfound))
    do k = 1, nfound
      associate (e => snap%extra(k))
        e%name = trim(names(which(k)))
        if (ncomp(k) == 1) then
          allocate(e%s(snap%n_local))
          if (.not. read_real(f, e%s, e%name, 1, errmsg)) return
        else
          allocate(e%v(snap%dim, snap%n_local))
          if (.not. read_real(f, e%v, e%name, snap%dim, errmsg)) return
        end if
      end associate
    end do
    good = .true.
  end function read_extra_fields

  !> The extra attributes: every other scalar real attribute of the root,
  !> by name.
  logical function read_extra_attributes(f, snap, errmsg) result(good)
    type(snapshot_file_t), intent(in) :: f
    type(snapshot_t), intent(inout) :: snap
    character(len=:), allocatable, intent(inout) :: errmsg
    character(len=SNAPSHOT_NAME_LEN), allocatable :: names(:)
    real(wp), allocatable :: values(:)
    logical, allocatable :: extra(:)
    integer :: k
    good = .false.
    call root_attribute_names(f%id, names)
    allocate(values(size(names)), extra(size(names)))
    do k = 1, size(names)
      extra(k) = .not. any(RESERVED_ATTRIBUTES == names(k))
      if (extra(k)) extra(k) = attr_is_real_scalar(f%id, trim(names(k)))
      values(k) = 0
      if (.not. extra(k)) cycle
      if (.not. read_attr_real(f%id, trim(names(k)), values(k), errmsg)) return
    end do
    snap%attr_names = pack(names, extra)
    snap%attr_values = pack(values, extra)
    good = .true.
  end function read_extra_attributes

  !> Reads this rank's rows of a real dataset of ncomp components (ncomp
  !> = 1: shape (N)) into `a` after checking its shape; only the shape with
  !> f%header_only.
  logical function read_real(f, a, dname, ncomp, errmsg)
    type(snapshot_file_t), intent(in) :: f
    real(wp), intent(inout), target :: a(..)
    character(len=*), intent(in) :: dname
    integer, intent(in) :: ncomp
    character(len=:), allocatable, intent(inout) :: errmsg
    real(wp), target :: rdummy(1)
    type(c_ptr) :: buf
    read_real = check_shape(f, dname, ncomp, errmsg)
    if (.not. read_real .or. f%header_only) return
    buf = c_loc(rdummy)
    select rank (a)
    rank (1)
      if (size(a) > 0) buf = c_loc(a)
    rank (2)
      if (size(a) > 0) buf = c_loc(a)
    end select
    read_real = read_block(f%id, f%dxpl, dname, H5T_NATIVE_DOUBLE, buf, ncomp, f%n_local, &
                           f%offset, errmsg)
  end function read_real

  !> Whether dataset `dname` has the shape of position: (N), or (ncomp, N).
  logical function check_shape(f, dname, ncomp, errmsg)
    type(snapshot_file_t), intent(in) :: f
    character(len=*), intent(in) :: dname
    integer, intent(in) :: ncomp
    character(len=:), allocatable, intent(inout) :: errmsg
    integer :: nd
    integer(hsize_t) :: d(2)
    check_shape = dataset_shape(f%id, dname, nd, d)
    if (.not. check_shape) then
      errmsg = '"' // f%path // '" has no dataset ' // dname
      return
    end if
    if (ncomp == 1) then
      check_shape = nd == 1 .and. d(1) == int(f%n_global, hsize_t)
    else
      check_shape = nd == 2 .and. d(1) == int(ncomp, hsize_t) .and. &
                    d(2) == int(f%n_global, hsize_t)
    end if
    if (.not. check_shape) errmsg = '"' // f%path // '": dataset ' // dname // &
                                    ' does not have the shape of position'
  end function check_shape

  !> The address of `a`, or of `dummy` when `a` is empty (HDF5 wants one).
  function loc_i1(a, dummy) result(p)
    integer(i8), intent(in), target :: a(:), dummy(:)
    type(c_ptr) :: p
    if (size(a) > 0) then
      p = c_loc(a)
    else
      p = c_loc(dummy)
    end if
  end function loc_i1

  ! ==================== snapshots read back ====================

  !> Index of the extra field `name` in snap%extra, 0 if absent.
  integer function snapshot_find_field(snap, name) result(k)
    type(snapshot_t), intent(in) :: snap
    character(len=*), intent(in) :: name
    if (allocated(snap%extra)) then
      do k = 1, size(snap%extra)
        if (snap%extra(k)%name == name) return
      end do
    end if
    k = 0
  end function snapshot_find_field

  !> Index of the extra attribute `name` in snap%attr_names, 0 if absent.
  integer function snapshot_find_attribute(snap, name) result(k)
    type(snapshot_t), intent(in) :: snap
    character(len=*), intent(in) :: name
    if (allocated(snap%attr_names)) then
      do k = 1, size(snap%attr_names)
        if (snap%attr_names(k) == name) return
      end do
    end if
    k = 0
  end function snapshot_find_attribute

  !> Field `name` of a snapshot read back, standard or extra, as a copy of
  !> this rank's rows; found is false if the snapshot has no such field.
  subroutine snapshot_get_field(snap, name, field, found)
    type(snapshot_t), intent(in) :: snap
    character(len=*), intent(in) :: name
    type(snapshot_field_t), intent(out) :: field
    logical, intent(out) :: found
    integer :: k
    found = .true.
    field%name = name
    select case (name)
    case ('position')
      field%v = snap%x
    case ('velocity')
      field%v = snap%u
    case ('density')
      field%s = snap%rho
    case ('pressure')
      field%s = snap%p
    case ('mass')
      field%s = snap%m
    case ('id')
      field%i = snap%id
    case default
      k = snapshot_find_field(snap, name)
      found = k > 0
      if (found) field = snap%extra(k)
    end select
  end subroutine snapshot_get_field
end module snapshot_io
