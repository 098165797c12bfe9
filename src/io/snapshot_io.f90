!> Particle snapshots in parallel HDF5, and the XDMF index that makes the run
!> a time series in ParaView (doc/reference/output.md describes the files).
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
module snapshot_io
  use, intrinsic :: iso_c_binding, only: c_ptr, c_loc, c_char
  use, intrinsic :: iso_fortran_env, only: int32
  use kinds, only: wp, i8
  use shares, only: share_range
  use mpi_f08, only: MPI_Comm, MPI_Comm_rank, MPI_Comm_size, MPI_Exscan, MPI_Allreduce, &
                     MPI_INTEGER8, MPI_INTEGER, MPI_SUM, MPI_MAX, MPI_INFO_NULL, MPI_IN_PLACE
  use hdf5, only: hid_t, hsize_t, size_t, h5open_f, h5close_f, &
                  h5fcreate_f, h5fopen_f, h5fclose_f, H5F_ACC_TRUNC_F, H5F_ACC_RDONLY_F, &
                  h5fis_hdf5_f, h5eset_auto_f, &
                  h5pcreate_f, h5pclose_f, h5pset_fapl_mpio_f, h5pset_dxpl_mpio_f, &
                  H5P_FILE_ACCESS_F, H5P_DATASET_XFER_F, H5FD_MPIO_COLLECTIVE_F, &
                  h5screate_simple_f, h5screate_f, h5sclose_f, h5sselect_hyperslab_f, &
                  h5sselect_none_f, h5sget_simple_extent_ndims_f, h5sget_simple_extent_dims_f, &
                  H5S_SCALAR_F, H5S_SELECT_SET_F, &
                  h5dcreate_f, h5dopen_f, h5dclose_f, h5dwrite_f, h5dread_f, h5dget_space_f, &
                  h5dget_type_f, &
                  h5acreate_f, h5aopen_f, h5aclose_f, h5awrite_f, h5aread_f, h5aexists_f, &
                  h5aget_type_f, h5aget_space_f, h5aget_num_attrs_f, h5aget_name_by_idx_f, &
                  h5tcopy_f, h5tset_size_f, h5tget_size_f, h5tget_class_f, h5tclose_f, &
                  H5T_NATIVE_DOUBLE, H5T_NATIVE_INTEGER, H5T_IEEE_F64LE, H5T_STD_I32LE, &
                  H5T_STD_I64LE, H5T_FORTRAN_S1, H5T_FLOAT_F, H5T_STRING_F, &
                  h5kind_to_type, H5_INTEGER_KIND, &
                  h5gget_info_f, h5lget_name_by_idx_f, H5_INDEX_NAME_F, H5_ITER_INC_F
  use fileutil, only: temp_path, rename_file, remove_file, agree_ok, base_name, dir_name, &
                      file_exists, is_directory, text_buffer_t, text_append, write_file_atomic, &
                      free_bytes
  implicit none
  private
  public :: snapshot_field_t, snapshot_source_t, snapshot_t, xdmf_index_t
  public :: snapshot_write, snapshot_read, snapshot_filename
  public :: snapshot_find_field, snapshot_find_attribute, snapshot_get_field
  public :: xdmf_init, xdmf_add, xdmf_write
  public :: SNAPSHOT_NAME_LEN, SNAPSHOT_FORMAT_VERSION

  integer, parameter :: SNAPSHOT_NAME_LEN = 64      !< longest field or attribute name
  integer, parameter :: SNAPSHOT_FORMAT_VERSION = 1 !< root attribute `format_version`

  !> A named field: real scalar s(n), real vector v(dim, n) or int64 i(n);
  !> exactly one is allocated, or instead exactly one of the views s_view,
  !> v_view, i_view points to data the caller keeps alive while it writes
  !> (the particles' own arrays, written without a copy), or instead
  !> `computed` is 's' or 'v' and the writer has the values made by a
  !> snapshot_source_t just before it writes them, and frees them after:
  !> however many such fields, one is held at a time.  Arrays may be
  !> longer than the local count (capacity, halo): only the first n_local
  !> entries are written.
  type :: snapshot_field_t
    character(len=:), allocatable :: name
    real(wp), allocatable :: s(:)
    real(wp), allocatable :: v(:,:)
    integer(i8), allocatable :: i(:)
    real(wp), pointer, contiguous :: s_view(:) => null()
    real(wp), pointer, contiguous :: v_view(:, :) => null()
    integer(i8), pointer, contiguous :: i_view(:) => null()
    character(len=1) :: computed = ' '
  end type snapshot_field_t

  !> What makes the computed fields of a snapshot (snapshot_write's
  !> `source`), e.g. a case's exact solution at the particles.
  type, abstract :: snapshot_source_t
  contains
    procedure(source_fill_i), deferred :: fill
  end type snapshot_source_t

  abstract interface
    !> Allocates field%s (field%computed = 's') or field%v ('v', dim or
    !> more rows) with at least n_local entries: the values of the field
    !> named field%name.
    subroutine source_fill_i(self, field)
      import :: snapshot_source_t, snapshot_field_t
      class(snapshot_source_t), intent(inout) :: self
      type(snapshot_field_t), intent(inout) :: field
    end subroutine source_fill_i
  end interface

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

  !> One snapshot in the XDMF index.
  type :: xdmf_entry_t
    real(wp) :: time = 0.0_wp
    character(len=:), allocatable :: file   !< relative to the index's directory
    integer(i8) :: n = 0
    integer :: dim = 0
    character(len=SNAPSHOT_NAME_LEN), allocatable :: names(:)   !< extra fields
    integer, allocatable :: ncomp(:)                            !< 1 or dim
    logical, allocatable :: int8(:)                             !< int64, else float64
  end type xdmf_entry_t

  !> The XDMF index of a run: the entries so far, rewritten whole (and
  !> atomically) by rank 0 at each xdmf_write.  Keep it identical on all
  !> ranks (call xdmf_add everywhere); only rank 0 writes.
  type :: xdmf_index_t
    character(len=:), allocatable :: path
    integer :: count = 0
    type(xdmf_entry_t), allocatable :: entries(:)
  end type xdmf_index_t

  !> The datasets of every snapshot: the first six are the fields the
  !> writer must be given, of the kinds in STANDARD_KINDS (v vector, s
  !> scalar, i int64); connectivity it makes itself.
  character(len=*), parameter :: STANDARD_DATASETS(7) = &
    [character(len=12) :: 'position', 'velocity', 'density', 'pressure', 'mass', 'id', &
                          'connectivity']
  character(len=*), parameter :: STANDARD_KINDS = 'vvsssi'
  character(len=*), parameter :: RESERVED_ATTRIBUTES(5) = &
    [character(len=14) :: 'time', 'step', 'dim', 'case', 'format_version']

contains

  !> The snapshot file name for output number k (from 0): snap_00000.h5.
  function snapshot_filename(k) result(name)
    integer, intent(in) :: k
    character(len=:), allocatable :: name
    character(len=32) :: s
    write(s, '(a,i5.5,a)') 'snap_', k, '.h5'
    name = trim(s)
  end function snapshot_filename

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

    integer(i8) :: n8, offset, n_global, need
    integer(hid_t) :: file_id, dxpl
    integer :: err, k, rank, nfields, counts(2)
    character(len=:), allocatable :: tmp, rel
    logical :: closed
    real(wp), target :: rdummy(1)
    integer(i8), target :: idummy(1)

    call MPI_Comm_rank(comm, rank)
    nfields = size(fields)

    ! ---- arguments (local), then agreement before any collective call ----
    call check_arguments(ok, errmsg)
    counts = [nfields, -nfields]
    call MPI_Allreduce(MPI_IN_PLACE, counts, 2, MPI_INTEGER, MPI_MAX, comm)
    if (ok .and. counts(1) /= -counts(2)) then
      ok = .false.
      errmsg = 'snapshot_write: ranks pass different numbers of fields'
    end if
    call agree_ok(comm, ok, errmsg)
    if (.not. ok) return

    n8 = int(n_local, i8)
    offset = 0
    call MPI_Exscan(n8, offset, 1, MPI_INTEGER8, MPI_SUM, comm)
    if (rank == 0) offset = 0
    call MPI_Allreduce(n8, n_global, 1, MPI_INTEGER8, MPI_SUM, comm)

    ! ---- room for it: a full disk is said in one line, before HDF5 fails ----
    need = needed_bytes()
    if (rank == 0) call check_room(ok, errmsg)
    call agree_ok(comm, ok, errmsg)
    if (.not. ok) return

    ! ---- the file, under its temporary name ----
    call h5open_f(err)
    ! what fails is said in errmsg: HDF5's own error stack is not printed
    call h5eset_auto_f(0, err)
    tmp = temp_path(filename)
    file_id = -1
    dxpl = -1
    closed = .false.
    ok = .false.
    io: block
      if (.not. open_parallel(tmp, .true., comm, file_id, dxpl, errmsg)) exit io

      do k = 1, nfields
        if (fields(k)%computed /= ' ') then
          if (.not. write_computed(fields(k))) exit io
          cycle
        end if
        associate (f => fields(k))
          select case (kind_of(f))
          case ('i')
            if (.not. write_block(file_id, dxpl, f%name, H5T_STD_I64LE, &
                                  h5kind_to_type(i8, H5_INTEGER_KIND), &
                                  loc_i1(field_i(f), idummy), 1, 1, n_local, offset, &
                                  n_global, errmsg)) exit io
          case ('s')
            if (.not. write_real(file_id, dxpl, f%name, field_s(f), 1, 1)) exit io
          case default
            if (.not. write_real(file_id, dxpl, f%name, field_v(f), size(field_v(f), 1), &
                                 dim)) exit io
          end select
        end associate
      end do
      if (.not. write_connectivity()) exit io

      if (.not. write_attr_real(file_id, 'time', time, errmsg)) exit io
      if (.not. write_attr_int(file_id, 'step', step, errmsg)) exit io
      if (.not. write_attr_int(file_id, 'dim', dim, errmsg)) exit io
      if (.not. write_attr_string(file_id, 'case', case_name, errmsg)) exit io
      if (.not. write_attr_int(file_id, 'format_version', SNAPSHOT_FORMAT_VERSION, &
                               errmsg)) exit io
      if (present(attr_names)) then
        do k = 1, size(attr_names)
          if (.not. write_attr_real(file_id, trim(attr_names(k)), attr_values(k), &
                                    errmsg)) exit io
        end do
      end if

      call h5pclose_f(dxpl, err)
      dxpl = -1
      call h5fclose_f(file_id, err)   ! collective: every rank's data is in
      closed = .true.
      if (err < 0) then
        errmsg = 'HDF5: cannot close "' // tmp // '"'
        exit io
      end if
      ok = .true.
    end block io
    if (.not. closed) then
      if (dxpl >= 0) call h5pclose_f(dxpl, err)
      if (file_id >= 0) call h5fclose_f(file_id, err)
    end if
    if (.not. ok) then
      ! the disk filled while writing (another process, a larger estimate)
      if (room_left() < need) &
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
        call rename_file(tmp, filename, ok, errmsg)
      end if
      if (.not. ok) call remove_file(tmp)
    end if
    call agree_ok(comm, ok, errmsg)
    if (.not. ok) return

    if (present(index)) then
      if (dir_name(filename) == dir_name(index%path)) then
        rel = base_name(filename)
      else
        rel = filename
      end if
      call xdmf_add(index, time, rel, n_global, dim, fields)
      call xdmf_write(comm, index, ok, errmsg)
    end if

  contains

    !> The file's size, from below: the datasets' bytes, without HDF5's own.
    integer(i8) function needed_bytes() result(b)
      integer :: j
      b = 4 * n_global                                    ! connectivity
      do j = 1, nfields
        if (kind_of(fields(j)) == 'v') then
          b = b + 8 * dim * n_global
        else
          b = b + 8 * n_global
        end if
      end do
    end function needed_bytes

    !> The free bytes where the file goes (huge if that cannot be told).
    integer(i8) function room_left() result(b)
      b = free_bytes(dir_name(filename))
      if (b < 0) b = huge(b)
    end function room_left

    subroutine check_room(good, msg)
      logical, intent(out) :: good
      character(len=:), allocatable, intent(out) :: msg
      integer(i8) :: free
      character(len=64) :: s
      free = room_left()
      good = free >= need
      msg = ''
      if (.not. good) then
        write(s, '(f12.3)') real(free, wp) / 1e6_wp
        msg = 'no space left on device for "' // filename // '": ' // trim(adjustl(s))
        write(s, '(f12.3)') real(need, wp) / 1e6_wp
        msg = msg // ' MB free, the snapshot needs at least ' // trim(adjustl(s)) // ' MB'
      end if
    end subroutine check_room

    !> A computed field: made by `source`, its shape agreed on by the ranks
    !> (it is only known now), written, and freed on return.
    logical function write_computed(declared) result(good)
      type(snapshot_field_t), intent(in) :: declared
      type(snapshot_field_t), target :: made
      made%name = declared%name
      made%computed = declared%computed
      call source%fill(made)
      if (made%computed == 's') then
        good = allocated(made%s) .and. .not. allocated(made%v)
        if (good) good = size(made%s) >= n_local
      else
        good = allocated(made%v) .and. .not. allocated(made%s)
        if (good) good = size(made%v, 1) >= dim .and. size(made%v, 2) >= n_local
      end if
      if (.not. good) errmsg = 'snapshot_write: the source made field "' // made%name // &
                               '" of another kind or shape than declared'
      call agree_ok(comm, good, errmsg)
      if (.not. good) return
      if (made%computed == 's') then
        good = write_real(file_id, dxpl, made%name, made%s, 1, 1)
      else
        good = write_real(file_id, dxpl, made%name, made%v, size(made%v, 1), dim)
      end if
    end function write_computed

    !> `connectivity`: the row numbers 0 .. N-1, the vertex list of the
    !> XDMF Polyvertex topology (int32 unless N needs int64).
    logical function write_connectivity()
      integer(int32), allocatable, target :: c32(:)
      integer(i8), allocatable, target :: c64(:)
      integer :: j
      if (connectivity_precision(n_global) == 4) then
        allocate(c32(max(n_local, 1)))
        c32(1:n_local) = [(int(offset + j - 1, int32), j = 1, n_local)]
        write_connectivity = write_block(file_id, dxpl, 'connectivity', H5T_STD_I32LE, &
                                         h5kind_to_type(int32, H5_INTEGER_KIND), c_loc(c32), &
                                         1, 1, n_local, offset, n_global, errmsg)
      else
        allocate(c64(max(n_local, 1)))
        c64(1:n_local) = [(offset + j - 1, j = 1, n_local)]
        write_connectivity = write_block(file_id, dxpl, 'connectivity', H5T_STD_I64LE, &
                                         h5kind_to_type(i8, H5_INTEGER_KIND), c_loc(c64), &
                                         1, 1, n_local, offset, n_global, errmsg)
      end if
    end function write_connectivity

    subroutine check_arguments(good, msg)
      logical, intent(out) :: good
      character(len=:), allocatable, intent(out) :: msg
      integer :: j, l, k
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
        do j = 1, size(attr_names)
          if (.not. valid_name(attr_names(j))) then
            good = .false.
            msg = 'snapshot_write: invalid attribute name "' // trim(attr_names(j)) // '"'
            return
          end if
          if (any(RESERVED_ATTRIBUTES == attr_names(j)) .or. &
              any(attr_names(:j-1) == attr_names(j))) then
            good = .false.
            msg = 'snapshot_write: attribute name "' // trim(attr_names(j)) // &
                  '" is reserved or repeated'
            return
          end if
        end do
      end if
      do j = 1, nfields
        msg = ''
        if (.not. allocated(fields(j)%name)) then
          msg = 'snapshot_write: a field has no name'
        else if (.not. valid_name(fields(j)%name)) then
          msg = 'snapshot_write: invalid field name "' // fields(j)%name // '"'
        else if (fields(j)%name == 'connectivity') then
          msg = 'snapshot_write: field "connectivity" is made by the writer'
        else if (count([allocated(fields(j)%s), allocated(fields(j)%v), &
                        allocated(fields(j)%i), associated(fields(j)%s_view), &
                        associated(fields(j)%v_view), associated(fields(j)%i_view), &
                        fields(j)%computed /= ' ']) /= 1) then
          msg = 'snapshot_write: field "' // fields(j)%name // &
                '" needs exactly one of s (scalar), v (vector) and i (int64), or of their ' // &
                'views, or to be computed'
        else if (fields(j)%computed /= ' ') then
          if (fields(j)%computed /= 's' .and. fields(j)%computed /= 'v') then
            msg = 'snapshot_write: field "' // fields(j)%name // &
                  '" can only be computed as s (scalar) or v (vector)'
          else if (.not. present(source)) then
            msg = 'snapshot_write: field "' // fields(j)%name // &
                  '" is computed but there is no source'
          end if
        else if (kind_of(fields(j)) == 's') then
          if (size(field_s(fields(j))) < n_local) &
            msg = 'snapshot_write: field "' // fields(j)%name // '" is shorter than n_local'
        else if (kind_of(fields(j)) == 'i') then
          if (size(field_i(fields(j))) < n_local) &
            msg = 'snapshot_write: field "' // fields(j)%name // '" is shorter than n_local'
        else if (size(field_v(fields(j)), 2) < n_local) then
          msg = 'snapshot_write: field "' // fields(j)%name // '" is shorter than n_local'
        else if (size(field_v(fields(j)), 1) < dim) then
          msg = 'snapshot_write: field "' // fields(j)%name // '" has fewer than dim rows'
        end if
        if (len(msg) == 0) then
          do l = 1, j - 1
            if (fields(l)%name == fields(j)%name) &
              msg = 'snapshot_write: field "' // fields(j)%name // '" is repeated'
          end do
        end if
        if (len(msg) > 0) then
          good = .false.
          return
        end if
      end do
      ! the standard datasets, of their kinds (snapshot_read needs them)
      msg = ''
      do l = 1, len(STANDARD_KINDS)
        j = findloc([(fields(k)%name == trim(STANDARD_DATASETS(l)), k = 1, nfields)], &
                    .true., dim=1)
        if (j == 0) then
          msg = 'snapshot_write: no field "' // trim(STANDARD_DATASETS(l)) // '"'
        else if (kind_of(fields(j)) /= STANDARD_KINDS(l:l)) then
          msg = 'snapshot_write: field "' // trim(STANDARD_DATASETS(l)) // &
                '" is not of its standard kind'
        end if
        if (len(msg) > 0) then
          good = .false.
          return
        end if
      end do
      msg = ''
    end subroutine check_arguments

    !> A real dataset: ncomp = 1 gives (N), else (ncomp, N) from the
    !> leading `lead` x n_local block of `a`.
    logical function write_real(fid, xfer, name, a, lead, ncomp)
      integer(hid_t), intent(in) :: fid, xfer
      character(len=*), intent(in) :: name
      real(wp), intent(in), target :: a(..)
      integer, intent(in) :: lead, ncomp
      type(c_ptr) :: buf
      buf = c_loc(rdummy)
      select rank (a)
      rank (1)
        if (size(a) > 0) buf = c_loc(a)
      rank (2)
        if (size(a) > 0) buf = c_loc(a)
      end select
      write_real = write_block(fid, xfer, name, H5T_IEEE_F64LE, H5T_NATIVE_DOUBLE, buf, &
                               lead, ncomp, n_local, offset, n_global, errmsg)
    end function write_real

  end subroutine snapshot_write

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

    integer(hid_t) :: file_id, dxpl, dset, space
    integer(hsize_t) :: dims(2), maxdims(2), nlinks_h, j
    integer(size_t) :: name_size
    integer :: err, rank, nranks, k, ndims, nattr, storage, max_corder, tclass, version
    integer(i8) :: first, last
    character(len=256) :: name
    character(len=:), allocatable :: tmp_s
    logical :: headers, exists
    real(wp) :: value
    real(wp), target :: rdummy(1)
    integer(i8), target :: idummy(1)
    character(len=SNAPSHOT_NAME_LEN), allocatable :: fnames(:)
    integer, allocatable :: fncomp(:)
    integer :: nfound
    character(len=SNAPSHOT_NAME_LEN), allocatable :: anames(:)
    real(wp), allocatable :: avalues(:)

    headers = .false.
    if (present(header_only)) headers = header_only
    call MPI_Comm_rank(comm, rank)
    call MPI_Comm_size(comm, nranks)
    call h5open_f(err)
    ! what fails is said in errmsg: HDF5's own error stack is not printed
    call h5eset_auto_f(0, err)
    file_id = -1
    dxpl = -1
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
      if (.not. open_parallel(filename, .false., comm, file_id, dxpl, errmsg)) exit io

      ! root attributes
      if (.not. read_attr_real(file_id, 'time', snap%time, errmsg)) exit io
      if (.not. read_attr_int(file_id, 'step', snap%step, errmsg)) exit io
      if (.not. read_attr_int(file_id, 'dim', snap%dim, errmsg)) exit io
      if (.not. read_attr_string(file_id, 'case', snap%case_name, errmsg)) exit io
      call h5aexists_f(file_id, 'format_version', exists, err)
      if (exists) then
        if (.not. read_attr_int(file_id, 'format_version', version, errmsg)) exit io
        if (version > SNAPSHOT_FORMAT_VERSION) then
          errmsg = 'snapshot "' // filename // '" has a newer format than this program reads'
          exit io
        end if
      end if
      if (snap%dim /= 2 .and. snap%dim /= 3) then
        errmsg = 'snapshot "' // filename // '": attribute dim is neither 2 nor 3'
        exit io
      end if

      ! N from `position`, then this rank's block of rows
      if (.not. dataset_shape(file_id, 'position', ndims, dims)) exit io
      if (ndims /= 2 .or. dims(1) /= int(snap%dim, hsize_t)) then
        errmsg = 'snapshot "' // filename // '": position is not (dim, N)'
        exit io
      end if
      snap%n_global = int(dims(2), i8)
      call share_range(snap%n_global, rank, nranks, first, last)
      snap%offset = first - 1
      snap%n_local = int(last - first + 1)
      if (headers) snap%n_local = 0
      associate (n => snap%n_local, d => snap%dim)
        allocate(snap%id(n), snap%x(d, n), snap%u(d, n), snap%rho(n), snap%p(n), snap%m(n))
      end associate

      if (.not. read_real(snap%x, 'position', snap%dim)) exit io
      if (.not. read_real(snap%u, 'velocity', snap%dim)) exit io
      if (.not. read_real(snap%rho, 'density', 1)) exit io
      if (.not. read_real(snap%p, 'pressure', 1)) exit io
      if (.not. read_real(snap%m, 'mass', 1)) exit io
      if (.not. check_shape('id', 1)) exit io
      if (.not. headers) then
        if (.not. read_block(file_id, dxpl, 'id', h5kind_to_type(i8, H5_INTEGER_KIND), &
                             loc_i1(snap%id, idummy), 1, snap%n_local, snap%offset, &
                             errmsg)) exit io
      end if

      ! extra fields: every other real dataset of shape (N) or (dim, N)
      call h5gget_info_f(file_id, storage, k, max_corder, err)
      nlinks_h = int(k, hsize_t)
      allocate(fnames(nlinks_h), fncomp(nlinks_h))
      nfound = 0
      do j = 0, nlinks_h - 1
        name = ''
        call h5lget_name_by_idx_f(file_id, '.', H5_INDEX_NAME_F, H5_ITER_INC_F, j, name, &
                                  err, name_size)
        if (err < 0 .or. int(name_size) > SNAPSHOT_NAME_LEN) cycle
        if (any(STANDARD_DATASETS == name)) cycle
        call h5dopen_f(file_id, trim(name), dset, err)
        if (err < 0) cycle
        call h5dget_type_f(dset, space, err)
        call h5tget_class_f(space, tclass, err)
        call h5tclose_f(space, err)
        call h5dget_space_f(dset, space, err)
        call h5sget_simple_extent_ndims_f(space, ndims, err)
        dims = 0
        if (ndims >= 1 .and. ndims <= 2) &
          call h5sget_simple_extent_dims_f(space, dims(1:ndims), maxdims(1:ndims), err)
        call h5sclose_f(space, err)
        call h5dclose_f(dset, err)
        if (tclass /= H5T_FLOAT_F .or. dims(ndims) /= int(snap%n_global, hsize_t)) cycle
        if (ndims == 1 .or. (ndims == 2 .and. dims(1) == int(snap%dim, hsize_t))) then
          nfound = nfound + 1
          fnames(nfound) = name(1:SNAPSHOT_NAME_LEN)
          fncomp(nfound) = merge(1, snap%dim, ndims == 1)
        end if
      end do
      allocate(snap%extra(nfound))
      do k = 1, nfound
        snap%extra(k)%name = trim(fnames(k))
        if (fncomp(k) == 1) then
          allocate(snap%extra(k)%s(snap%n_local))
        else
          allocate(snap%extra(k)%v(snap%dim, snap%n_local))
        end if
      end do
      do k = 1, size(snap%extra)
        if (allocated(snap%extra(k)%s)) then
          if (.not. read_real(snap%extra(k)%s, snap%extra(k)%name, 1)) exit io
        else
          if (.not. read_real(snap%extra(k)%v, snap%extra(k)%name, snap%dim)) exit io
        end if
      end do

      ! extra attributes: every other scalar real attribute of the root
      call h5aget_num_attrs_f(file_id, nattr, err)
      allocate(anames(max(nattr, 0)), avalues(max(nattr, 0)))
      nfound = 0
      do k = 0, nattr - 1
        name = ''
        call h5aget_name_by_idx_f(file_id, '.', H5_INDEX_NAME_F, H5_ITER_INC_F, &
                                  int(k, hsize_t), name, err, name_size)
        if (err < 0 .or. int(name_size) > SNAPSHOT_NAME_LEN) cycle
        if (any(RESERVED_ATTRIBUTES == name)) cycle
        if (.not. attr_is_real_scalar(file_id, trim(name))) cycle
        if (.not. read_attr_real(file_id, trim(name), value, errmsg)) exit io
        nfound = nfound + 1
        anames(nfound) = name(1:SNAPSHOT_NAME_LEN)
        avalues(nfound) = value
      end do
      snap%attr_names = anames(1:nfound)
      snap%attr_values = avalues(1:nfound)
      ok = .true.
    end block io
    call h5eset_auto_f(1, err)
    if (dxpl >= 0) call h5pclose_f(dxpl, err)
    if (file_id >= 0) then
      call h5fclose_f(file_id, err)
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

  contains

    !> Reads this rank's rows of a real dataset of ncomp components (ncomp
    !> = 1: shape (N)) into `a` after checking its shape.
    logical function read_real(a, dname, ncomp)
      real(wp), intent(inout), target :: a(..)
      character(len=*), intent(in) :: dname
      integer, intent(in) :: ncomp
      type(c_ptr) :: buf
      read_real = check_shape(dname, ncomp)
      if (.not. read_real .or. headers) return
      buf = c_loc(rdummy)
      select rank (a)
      rank (1)
        if (size(a) > 0) buf = c_loc(a)
      rank (2)
        if (size(a) > 0) buf = c_loc(a)
      end select
      read_real = read_block(file_id, dxpl, dname, H5T_NATIVE_DOUBLE, buf, ncomp, &
                             snap%n_local, snap%offset, errmsg)
    end function read_real

    logical function check_shape(dname, ncomp)
      character(len=*), intent(in) :: dname
      integer, intent(in) :: ncomp
      integer :: nd
      integer(hsize_t) :: d(2)
      check_shape = dataset_shape(file_id, dname, nd, d)
      if (.not. check_shape) return
      if (ncomp == 1) then
        check_shape = nd == 1 .and. d(1) == int(snap%n_global, hsize_t)
      else
        check_shape = nd == 2 .and. d(1) == int(ncomp, hsize_t) .and. &
                      d(2) == int(snap%n_global, hsize_t)
      end if
      if (.not. check_shape) errmsg = '"' // filename // '": dataset ' // dname // &
                                      ' does not have the shape of position'
    end function check_shape

    logical function dataset_shape(fid, dname, nd, d)
      integer(hid_t), intent(in) :: fid
      character(len=*), intent(in) :: dname
      integer, intent(out) :: nd
      integer(hsize_t), intent(out) :: d(2)
      integer(hid_t) :: ds, sp
      integer(hsize_t) :: md(2)
      integer :: e
      dataset_shape = .false.
      nd = 0
      d = 0
      call h5dopen_f(fid, dname, ds, e)
      if (e < 0) then
        errmsg = '"' // filename // '" has no dataset ' // dname
        return
      end if
      call h5dget_space_f(ds, sp, e)
      call h5sget_simple_extent_ndims_f(sp, nd, e)
      if (nd >= 1 .and. nd <= 2) call h5sget_simple_extent_dims_f(sp, d(1:nd), md(1:nd), e)
      call h5sclose_f(sp, e)
      call h5dclose_f(ds, e)
      dataset_shape = .true.
    end function dataset_shape

  end subroutine snapshot_read

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

  ! ==================== XDMF index ====================

  !> Starts an empty index that will be written to `path` (snapshots.xdmf).
  subroutine xdmf_init(index, path)
    type(xdmf_index_t), intent(out) :: index
    character(len=*), intent(in) :: path
    index%path = path
    index%count = 0
    allocate(index%entries(16))
  end subroutine xdmf_init

  !> Adds a snapshot: its time, its file name as the index should refer to
  !> it (relative to the index's directory), N, dim, and its fields (only
  !> their names and kinds are used; the standard ones have fixed places in
  !> every grid, the others follow them in the order given).
  subroutine xdmf_add(index, time, file, n_global, dim, fields)
    type(xdmf_index_t), intent(inout) :: index
    real(wp), intent(in) :: time
    character(len=*), intent(in) :: file
    integer(i8), intent(in) :: n_global
    integer, intent(in) :: dim
    type(snapshot_field_t), intent(in) :: fields(:)
    type(xdmf_entry_t), allocatable :: grown(:)
    integer :: k, nextra
    if (.not. allocated(index%entries)) allocate(index%entries(16))
    if (index%count == size(index%entries)) then
      allocate(grown(2 * size(index%entries)))
      grown(1:index%count) = index%entries(1:index%count)
      call move_alloc(grown, index%entries)
    end if
    index%count = index%count + 1
    associate (e => index%entries(index%count))
      e%time = time
      e%file = file
      e%n = n_global
      e%dim = dim
      allocate(e%names(size(fields)), e%ncomp(size(fields)), e%int8(size(fields)))
      nextra = 0
      do k = 1, size(fields)
        if (any(STANDARD_DATASETS == fields(k)%name)) cycle
        nextra = nextra + 1
        e%names(nextra) = fields(k)%name
        e%ncomp(nextra) = merge(dim, 1, kind_of(fields(k)) == 'v')
        e%int8(nextra) = kind_of(fields(k)) == 'i'
      end do
      e%names = e%names(1:nextra)
      e%ncomp = e%ncomp(1:nextra)
      e%int8 = e%int8(1:nextra)
    end associate
  end subroutine xdmf_add

  !> Rewrites the whole index file (XDMF 3: a temporal collection of
  !> uniform grids, one per snapshot, Polyvertex topology, data in the HDF5
  !> files).  Rank 0 writes, atomically; collective over `comm`.
  subroutine xdmf_write(comm, index, ok, errmsg)
    type(MPI_Comm), intent(in) :: comm
    type(xdmf_index_t), intent(in) :: index
    logical, intent(out) :: ok
    character(len=:), allocatable, intent(out) :: errmsg
    type(text_buffer_t) :: t
    integer :: rank, k, j
    character(len=:), allocatable :: n, nd
    character(len=32) :: s
    call MPI_Comm_rank(comm, rank)
    ok = .true.
    errmsg = ''
    if (rank == 0) then
      call text_append(t, '<?xml version="1.0" ?>' // new_line('a'))
      call text_append(t, '<!DOCTYPE Xdmf SYSTEM "Xdmf.dtd" []>' // new_line('a'))
      call text_append(t, '<Xdmf Version="3.0">' // new_line('a'))
      call text_append(t, '  <Domain>' // new_line('a'))
      call text_append(t, '    <Grid Name="particles" GridType="Collection" ' // &
                          'CollectionType="Temporal">' // new_line('a'))
      do k = 1, index%count
        associate (e => index%entries(k))
          write(s, '(i0)') e%n
          n = trim(s)
          write(s, '(i0)') e%dim
          nd = n // ' ' // trim(s)
          write(s, '(es24.16e3)') e%time
          call text_append(t, '      <Grid Name="' // xml_escape(grid_name(e%file)) // &
                              '" GridType="Uniform">' // new_line('a'))
          call text_append(t, '        <Time Value="' // trim(adjustl(s)) // '"/>' // &
                              new_line('a'))
          ! explicit vertices: without them the Xdmf3 readers make no cells
          write(s, '(i0)') connectivity_precision(e%n)
          call text_append(t, '        <Topology TopologyType="Polyvertex" NumberOfElements="' &
                              // n // '" NodesPerElement="1">' // new_line('a'))
          call text_append(t, '          <DataItem Dimensions="' // n // '" NumberType="Int" ' &
                              // 'Precision="' // trim(s) // '" Format="HDF">' // &
                              xml_escape(e%file) // ':/connectivity</DataItem>' // new_line('a'))
          call text_append(t, '        </Topology>' // new_line('a'))
          call text_append(t, '        <Geometry GeometryType="' // &
                              trim(merge('XY ', 'XYZ', e%dim == 2)) // '">' // new_line('a'))
          call data_item(e%file, 'position', nd, 'Float')
          call text_append(t, '        </Geometry>' // new_line('a'))
          call attribute(e%file, 'velocity', nd, 'Vector', 'Float')
          call attribute(e%file, 'density', n, 'Scalar', 'Float')
          call attribute(e%file, 'pressure', n, 'Scalar', 'Float')
          call attribute(e%file, 'mass', n, 'Scalar', 'Float')
          call attribute(e%file, 'id', n, 'Scalar', 'Int')
          do j = 1, size(e%names)
            if (e%int8(j)) then
              call attribute(e%file, trim(e%names(j)), n, 'Scalar', 'Int')
            else if (e%ncomp(j) == 1) then
              call attribute(e%file, trim(e%names(j)), n, 'Scalar', 'Float')
            else
              call attribute(e%file, trim(e%names(j)), nd, 'Vector', 'Float')
            end if
          end do
          call text_append(t, '      </Grid>' // new_line('a'))
        end associate
      end do
      call text_append(t, '    </Grid>' // new_line('a'))
      call text_append(t, '  </Domain>' // new_line('a'))
      call text_append(t, '</Xdmf>' // new_line('a'))
      call write_file_atomic(index%path, t%s(1:t%n), ok, errmsg)
    end if
    call agree_ok(comm, ok, errmsg)

  contains

    subroutine attribute(file, name, dims, kind, number_type)
      character(len=*), intent(in) :: file, name, dims, kind, number_type
      call text_append(t, '        <Attribute Name="' // name // '" AttributeType="' // &
                          kind // '" Center="Node">' // new_line('a'))
      call data_item(file, name, dims, number_type)
      call text_append(t, '        </Attribute>' // new_line('a'))
    end subroutine attribute

    subroutine data_item(file, name, dims, number_type)
      character(len=*), intent(in) :: file, name, dims, number_type
      call text_append(t, '          <DataItem Dimensions="' // dims // '" NumberType="' // &
                          number_type // '" Precision="8" Format="HDF">' // &
                          xml_escape(file) // ':/' // name // '</DataItem>' // new_line('a'))
    end subroutine data_item

  end subroutine xdmf_write

  ! ==================== internals ====================

  !> Bytes per entry of the connectivity dataset: 4 while N < 2^31.
  !> A field's kind as STANDARD_KINDS spells it.
  pure character function kind_of(field)
    type(snapshot_field_t), intent(in) :: field
    kind_of = 'v'
    if (allocated(field%s) .or. associated(field%s_view)) kind_of = 's'
    if (allocated(field%i) .or. associated(field%i_view)) kind_of = 'i'
    if (field%computed /= ' ') kind_of = field%computed
  end function kind_of

  !> A field's data, its own array or its view.
  function field_s(field) result(a)
    type(snapshot_field_t), intent(in), target :: field
    real(wp), pointer, contiguous :: a(:)
    if (allocated(field%s)) then
      a => field%s
    else
      a => field%s_view
    end if
  end function field_s

  function field_v(field) result(a)
    type(snapshot_field_t), intent(in), target :: field
    real(wp), pointer, contiguous :: a(:, :)
    if (allocated(field%v)) then
      a => field%v
    else
      a => field%v_view
    end if
  end function field_v

  function field_i(field) result(a)
    type(snapshot_field_t), intent(in), target :: field
    integer(i8), pointer, contiguous :: a(:)
    if (allocated(field%i)) then
      a => field%i
    else
      a => field%i_view
    end if
  end function field_i

  integer function connectivity_precision(n_global)
    integer(i8), intent(in) :: n_global
    connectivity_precision = merge(4, 8, n_global < 2_i8**31)
  end function connectivity_precision

  !> A grid's name in the index: the file's name without directory and .h5.
  function grid_name(file) result(name)
    character(len=*), intent(in) :: file
    character(len=:), allocatable :: name
    name = base_name(file)
    if (len(name) > 3) then
      if (name(len(name)-2:) == '.h5') name = name(1:len(name)-3)
    end if
  end function grid_name

  !> Creates dataset `name` ((N) if ncomp = 1, else (ncomp, N)) and writes
  !> this rank's rows offset+1 .. offset+n_local collectively from `buf`, a
  !> (lead, n_local) block of which the first ncomp rows are used.
  logical function write_block(fid, xfer, name, file_type, mem_type, buf, lead, ncomp, &
                               n_local, offset, n_global, errmsg) result(good)
    integer(hid_t), intent(in) :: fid, xfer, file_type, mem_type
    character(len=*), intent(in) :: name
    type(c_ptr), intent(in) :: buf
    integer, intent(in) :: lead, ncomp, n_local
    integer(i8), intent(in) :: offset, n_global
    character(len=:), allocatable, intent(inout) :: errmsg
    integer(hid_t) :: fspace, mspace, dset
    integer(hsize_t) :: fdims(2), mdims(2)
    integer :: err, e, r
    good = .false.
    r = merge(1, 2, ncomp == 1)
    if (r == 1) then
      fdims(1) = int(n_global, hsize_t)
    else
      fdims = [int(ncomp, hsize_t), int(n_global, hsize_t)]
    end if
    call h5screate_simple_f(r, fdims(1:r), fspace, err)
    if (err < 0) then
      errmsg = 'HDF5: cannot create the dataspace of ' // name
      return
    end if
    call h5dcreate_f(fid, name, file_type, fspace, dset, err)
    if (err < 0) then
      call h5sclose_f(fspace, e)
      errmsg = 'HDF5: cannot create dataset ' // name
      return
    end if
    mdims = [int(lead, hsize_t), int(max(n_local, 1), hsize_t)]
    call h5screate_simple_f(2, mdims, mspace, err)
    call select_rows(fspace, mspace, ncomp, n_local, offset)
    ! an empty dataset (no particle anywhere) has no storage to write to
    if (n_global > 0) call h5dwrite_f(dset, mem_type, buf, err, mem_space_id=mspace, &
                                      file_space_id=fspace, xfer_prp=xfer)
    if (err < 0) errmsg = 'HDF5: cannot write dataset ' // name
    call h5sclose_f(mspace, e)
    call h5sclose_f(fspace, e)
    call h5dclose_f(dset, e)
    good = err >= 0
  end function write_block

  !> Reads this rank's rows offset+1 .. offset+n_local of dataset `name`
  !> ((N) if ncomp = 1, else (ncomp, N)) collectively into `buf`.
  logical function read_block(fid, xfer, name, mem_type, buf, ncomp, n_local, offset, &
                              errmsg) result(good)
    integer(hid_t), intent(in) :: fid, xfer, mem_type
    character(len=*), intent(in) :: name
    type(c_ptr), intent(in) :: buf
    integer, intent(in) :: ncomp, n_local
    integer(i8), intent(in) :: offset
    character(len=:), allocatable, intent(inout) :: errmsg
    integer(hid_t) :: fspace, mspace, dset
    integer(hsize_t) :: mdims(2)
    integer(hsize_t) :: fdims(2), maxdims(2)
    integer :: err, e, nd
    type(c_ptr) :: ptr
    good = .false.
    call h5dopen_f(fid, name, dset, err)
    if (err < 0) then
      errmsg = 'cannot open dataset ' // name
      return
    end if
    call h5dget_space_f(dset, fspace, err)
    mdims = [int(ncomp, hsize_t), int(max(n_local, 1), hsize_t)]
    call h5screate_simple_f(2, mdims, mspace, err)
    call select_rows(fspace, mspace, ncomp, n_local, offset)
    ptr = buf
    ! an empty dataset has no storage to read from (h5sget_simple_extent_
    ! npoints_f would call an empty dataspace an error: use the extent)
    fdims = 1
    call h5sget_simple_extent_ndims_f(fspace, nd, err)
    if (nd >= 1 .and. nd <= 2) call h5sget_simple_extent_dims_f(fspace, fdims(1:nd), &
                                                                 maxdims(1:nd), e)
    if (product(fdims) > 0) call h5dread_f(dset, mem_type, ptr, err, mem_space_id=mspace, &
                                    file_space_id=fspace, xfer_prp=xfer)
    if (err < 0) errmsg = 'cannot read dataset ' // name
    call h5sclose_f(mspace, e)
    call h5sclose_f(fspace, e)
    call h5dclose_f(dset, e)
    good = err >= 0
  end function read_block

  !> Selects this rank's rows offset+1 .. offset+n_local of a dataset of
  !> ncomp components ((N) if ncomp = 1, else (ncomp, N)) in its file space
  !> and the first ncomp rows of the n_local columns of the memory space;
  !> nothing in either when n_local = 0 (the rank still takes part).
  subroutine select_rows(fspace, mspace, ncomp, n_local, offset)
    integer(hid_t), intent(in) :: fspace, mspace
    integer, intent(in) :: ncomp, n_local
    integer(i8), intent(in) :: offset
    integer(hsize_t) :: count(2)
    integer :: e
    if (n_local > 0) then
      count = [int(ncomp, hsize_t), int(n_local, hsize_t)]
      call h5sselect_hyperslab_f(mspace, H5S_SELECT_SET_F, [0_hsize_t, 0_hsize_t], count, e)
      if (ncomp == 1) then
        call h5sselect_hyperslab_f(fspace, H5S_SELECT_SET_F, [int(offset, hsize_t)], &
                                   count(2:2), e)
      else
        call h5sselect_hyperslab_f(fspace, H5S_SELECT_SET_F, &
                                   [0_hsize_t, int(offset, hsize_t)], count, e)
      end if
    else
      call h5sselect_none_f(mspace, e)
      call h5sselect_none_f(fspace, e)
    end if
  end subroutine select_rows

  logical function write_attr_real(loc, name, value, errmsg) result(good)
    integer(hid_t), intent(in) :: loc
    character(len=*), intent(in) :: name
    real(wp), intent(in) :: value
    character(len=:), allocatable, intent(inout) :: errmsg
    real(wp), target :: v
    v = value
    good = write_attr(loc, name, H5T_IEEE_F64LE, H5T_NATIVE_DOUBLE, c_loc(v), errmsg)
  end function write_attr_real

  logical function write_attr_int(loc, name, value, errmsg) result(good)
    integer(hid_t), intent(in) :: loc
    character(len=*), intent(in) :: name
    integer, intent(in) :: value
    character(len=:), allocatable, intent(inout) :: errmsg
    integer, target :: v
    v = value
    good = write_attr(loc, name, H5T_STD_I32LE, H5T_NATIVE_INTEGER, c_loc(v), errmsg)
  end function write_attr_int

  !> A fixed-length ASCII string attribute (h5py reads it as bytes).
  logical function write_attr_string(loc, name, value, errmsg) result(good)
    integer(hid_t), intent(in) :: loc
    character(len=*), intent(in) :: name, value
    character(len=:), allocatable, intent(inout) :: errmsg
    character(kind=c_char), allocatable, target :: chars(:)
    integer(hid_t) :: stype
    integer :: err, e, k, n
    n = max(len(value), 1)
    allocate(chars(n))
    chars = ' '
    do k = 1, len(value)
      chars(k) = value(k:k)
    end do
    good = .false.
    call h5tcopy_f(H5T_FORTRAN_S1, stype, err)
    if (err >= 0) call h5tset_size_f(stype, int(n, size_t), err)
    if (err < 0) then
      errmsg = 'HDF5: cannot make a string type for attribute ' // name
      return
    end if
    good = write_attr(loc, name, stype, stype, c_loc(chars), errmsg)
    call h5tclose_f(stype, e)
  end function write_attr_string

  logical function write_attr(loc, name, file_type, mem_type, buf, errmsg) result(good)
    integer(hid_t), intent(in) :: loc, file_type, mem_type
    character(len=*), intent(in) :: name
    type(c_ptr), intent(in) :: buf
    character(len=:), allocatable, intent(inout) :: errmsg
    integer(hid_t) :: space, attr
    integer :: err, e
    good = .false.
    call h5screate_f(H5S_SCALAR_F, space, err)
    call h5acreate_f(loc, name, file_type, space, attr, err)
    if (err < 0) then
      call h5sclose_f(space, e)
      errmsg = 'HDF5: cannot create attribute ' // name
      return
    end if
    call h5awrite_f(attr, mem_type, buf, err)
    if (err < 0) errmsg = 'HDF5: cannot write attribute ' // name
    call h5aclose_f(attr, e)
    call h5sclose_f(space, e)
    good = err >= 0
  end function write_attr

  logical function read_attr_real(loc, name, value, errmsg) result(good)
    integer(hid_t), intent(in) :: loc
    character(len=*), intent(in) :: name
    real(wp), intent(out) :: value
    character(len=:), allocatable, intent(inout) :: errmsg
    real(wp), target :: v
    v = 0
    good = read_attr(loc, name, H5T_NATIVE_DOUBLE, c_loc(v), errmsg)
    value = v
  end function read_attr_real

  logical function read_attr_int(loc, name, value, errmsg) result(good)
    integer(hid_t), intent(in) :: loc
    character(len=*), intent(in) :: name
    integer, intent(out) :: value
    character(len=:), allocatable, intent(inout) :: errmsg
    integer, target :: v
    v = 0
    good = read_attr(loc, name, H5T_NATIVE_INTEGER, c_loc(v), errmsg)
    value = v
  end function read_attr_int

  logical function read_attr_string(loc, name, value, errmsg) result(good)
    integer(hid_t), intent(in) :: loc
    character(len=*), intent(in) :: name
    character(len=:), allocatable, intent(out) :: value
    character(len=:), allocatable, intent(inout) :: errmsg
    character(kind=c_char), allocatable, target :: chars(:)
    type(c_ptr) :: ptr
    integer(hid_t) :: attr, stype
    integer(size_t) :: n
    integer :: err, e, k, tclass
    good = .false.
    value = ''
    call h5aopen_f(loc, name, attr, err)
    if (err < 0) then
      errmsg = 'missing attribute ' // name
      return
    end if
    call h5aget_type_f(attr, stype, err)
    call h5tget_class_f(stype, tclass, err)
    call h5tget_size_f(stype, n, err)
    if (tclass /= H5T_STRING_F) then
      errmsg = 'attribute ' // name // ' is not a string'
    else
      allocate(chars(max(n, 1_size_t)))
      ptr = c_loc(chars)
      call h5aread_f(attr, stype, ptr, err)
      if (err < 0) then
        errmsg = 'cannot read attribute ' // name
      else
        deallocate(value)
        allocate(character(len=int(n)) :: value)
        do k = 1, int(n)
          value(k:k) = chars(k)
          if (chars(k) == achar(0)) value(k:k) = ' '
        end do
        value = trim(value)
        good = .true.
      end if
    end if
    call h5tclose_f(stype, e)
    call h5aclose_f(attr, e)
  end function read_attr_string

  logical function read_attr(loc, name, mem_type, buf, errmsg) result(good)
    integer(hid_t), intent(in) :: loc, mem_type
    character(len=*), intent(in) :: name
    type(c_ptr), intent(in) :: buf
    type(c_ptr) :: ptr
    character(len=:), allocatable, intent(inout) :: errmsg
    integer(hid_t) :: attr
    integer :: err, e
    good = .false.
    call h5aopen_f(loc, name, attr, err)
    if (err < 0) then
      errmsg = 'missing attribute ' // name
      return
    end if
    ptr = buf
    call h5aread_f(attr, mem_type, ptr, err)
    if (err < 0) errmsg = 'cannot read attribute ' // name
    call h5aclose_f(attr, e)
    good = err >= 0
  end function read_attr

  logical function attr_is_real_scalar(loc, name) result(yes)
    integer(hid_t), intent(in) :: loc
    character(len=*), intent(in) :: name
    integer(hid_t) :: attr, t, space
    integer :: err, tclass, nd
    yes = .false.
    call h5aopen_f(loc, name, attr, err)
    if (err < 0) return
    call h5aget_type_f(attr, t, err)
    call h5tget_class_f(t, tclass, err)
    call h5tclose_f(t, err)
    call h5aget_space_f(attr, space, err)
    call h5sget_simple_extent_ndims_f(space, nd, err)
    call h5sclose_f(space, err)
    call h5aclose_f(attr, err)
    yes = tclass == H5T_FLOAT_F .and. nd == 0
  end function attr_is_real_scalar

  !> Names of fields and attributes: letters, digits, '_', '-', '.', at most
  !> SNAPSHOT_NAME_LEN characters (safe as HDF5 names and inside XML).
  logical function valid_name(name)
    character(len=*), intent(in) :: name
    integer :: k
    character :: c
    valid_name = len_trim(name) > 0 .and. len_trim(name) <= SNAPSHOT_NAME_LEN
    do k = 1, len_trim(name)
      c = name(k:k)
      if (.not. (('a' <= c .and. c <= 'z') .or. ('A' <= c .and. c <= 'Z') .or. &
                 ('0' <= c .and. c <= '9') .or. c == '_' .or. c == '-' .or. c == '.')) &
        valid_name = .false.
    end do
  end function valid_name

  function xml_escape(s) result(r)
    character(len=*), intent(in) :: s
    character(len=:), allocatable :: r
    integer :: k
    r = ''
    do k = 1, len(s)
      select case (s(k:k))
      case ('&')
        r = r // '&amp;'
      case ('<')
        r = r // '&lt;'
      case ('>')
        r = r // '&gt;'
      case ('"')
        r = r // '&quot;'
      case default
        r = r // s(k:k)
      end select
    end do
  end function xml_escape

  function loc_i1(a, dummy) result(p)
    integer(i8), intent(in), target :: a(:), dummy(:)
    type(c_ptr) :: p
    if (size(a) > 0) then
      p = c_loc(a)
    else
      p = c_loc(dummy)
    end if
  end function loc_i1

  !> Opens `path` for parallel I/O on `comm` (every rank calls it): created
  !> (truncated) when `create`, else read-only; dxpl gets collective
  !> transfers.  False with errmsg set on failure; file_id and dxpl are -1
  !> unless opened (the caller closes what is open).
  logical function open_parallel(path, create, comm, file_id, dxpl, errmsg) result(ok)
    character(len=*), intent(in) :: path
    logical, intent(in) :: create
    type(MPI_Comm), intent(in) :: comm
    integer(hid_t), intent(out) :: file_id, dxpl
    character(len=:), allocatable, intent(inout) :: errmsg
    integer(hid_t) :: fapl
    integer :: err, err_close
    logical :: is_hdf5
    ok = .false.
    file_id = -1
    dxpl = -1
    call h5pcreate_f(H5P_FILE_ACCESS_F, fapl, err)
    if (err < 0) then
      errmsg = 'HDF5: cannot create a file access property list'
      return
    end if
    call h5pset_fapl_mpio_f(fapl, comm%MPI_VAL, MPI_INFO_NULL%MPI_VAL, err)
    if (err >= 0) then
      if (create) then
        call h5fcreate_f(path, H5F_ACC_TRUNC_F, file_id, err, access_prp=fapl)
      else
        ! a file that is not one: said in one line (snapshot_read has
        ! silenced HDF5's own error stack; a damaged file fails the open)
        call h5fis_hdf5_f(path, is_hdf5, err)
        if (err >= 0 .and. .not. is_hdf5) then
          call h5pclose_f(fapl, err_close)
          errmsg = '"' // path // '" is not an HDF5 file (give a snap_NNNNN.h5 or ' // &
                   'checkpoint.h5 that sph wrote)'
          return
        end if
        call h5fopen_f(path, H5F_ACC_RDONLY_F, file_id, err, access_prp=fapl)
      end if
    end if
    call h5pclose_f(fapl, err_close)
    if (err < 0) then
      file_id = -1
      if (create) then
        errmsg = 'HDF5: cannot create "' // path // '"'
      else
        errmsg = 'cannot open snapshot "' // path // '" (a damaged or unreadable HDF5 file)'
      end if
      return
    end if
    call h5pcreate_f(H5P_DATASET_XFER_F, dxpl, err)
    if (err >= 0) call h5pset_dxpl_mpio_f(dxpl, H5FD_MPIO_COLLECTIVE_F, err)
    if (err < 0) then
      errmsg = 'HDF5: cannot set collective transfers'
      return
    end if
    ok = .true.
  end function open_parallel

end module snapshot_io
