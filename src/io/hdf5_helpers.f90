!> The HDF5 calls of the snapshots, apart from what a snapshot holds: a file
!> opened for collective I/O, this rank's block of rows of a dataset written
!> or read collectively, scalar attributes, and the shapes and names of
!> what a file holds.
!>
!> A dataset of ncomp components is (N) when ncomp = 1, else (ncomp, N) in
!> Fortran order (h5py sees (N, ncomp)); rank r writes or reads its rows
!> offset+1 .. offset+n_local.  A function with an errmsg returns false
!> with errmsg set on failure; each closes what it opened.  HDF5's own
!> error stack is the caller's to silence.
module hdf5_helpers
  use, intrinsic :: iso_c_binding, only: c_ptr, c_loc, c_char
  use kinds, only: wp, i8
  use mpi_f08, only: MPI_Comm, MPI_INFO_NULL
  use hdf5, only: hid_t, hsize_t, size_t, &
                  h5fcreate_f, h5fopen_f, H5F_ACC_TRUNC_F, H5F_ACC_RDONLY_F, h5fis_hdf5_f, &
                  h5pcreate_f, h5pclose_f, h5pset_fapl_mpio_f, h5pset_dxpl_mpio_f, &
                  H5P_FILE_ACCESS_F, H5P_DATASET_XFER_F, H5FD_MPIO_COLLECTIVE_F, &
                  h5screate_simple_f, h5screate_f, h5sclose_f, h5sselect_hyperslab_f, &
                  h5sselect_none_f, h5sget_simple_extent_ndims_f, h5sget_simple_extent_dims_f, &
                  H5S_SCALAR_F, H5S_SELECT_SET_F, &
                  h5dcreate_f, h5dopen_f, h5dclose_f, h5dwrite_f, h5dread_f, h5dget_space_f, &
                  h5dget_type_f, &
                  h5acreate_f, h5aopen_f, h5aclose_f, h5awrite_f, h5aread_f, &
                  h5aget_type_f, h5aget_space_f, h5aget_num_attrs_f, h5aget_name_by_idx_f, &
                  h5tcopy_f, h5tset_size_f, h5tget_size_f, h5tget_class_f, h5tclose_f, &
                  H5T_NATIVE_DOUBLE, H5T_NATIVE_INTEGER, H5T_IEEE_F64LE, H5T_STD_I32LE, &
                  H5T_FORTRAN_S1, H5T_FLOAT_F, H5T_STRING_F, &
                  h5gget_info_f, h5lget_name_by_idx_f, H5_INDEX_NAME_F, H5_ITER_INC_F
  implicit none
  private
  public :: open_parallel, write_block, read_block
  public :: write_attr_real, write_attr_int, write_attr_string
  public :: read_attr_real, read_attr_int, read_attr_string, attr_is_real_scalar
  public :: dataset_shape, root_link_names, root_attribute_names

contains

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
        ! a file that is not one: said in one line (the reader has
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

  !> Creates and writes a scalar float64 attribute of `loc` (a file or an
  !> object); the int32 and string ones likewise.
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

  !> Reads a scalar attribute of `loc` in the native kind (the int and string
  !> ones likewise); a missing attribute is an error.
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

  !> Whether `loc` has a scalar floating-point attribute `name`.
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
  !> The shape of dataset `name`: nd dimensions, the first min(nd, 2) in
  !> d (0 beyond); is_float tells whether it holds floating-point numbers.
  !> False if there is no such dataset.
  logical function dataset_shape(fid, name, nd, d, is_float) result(found)
    integer(hid_t), intent(in) :: fid
    character(len=*), intent(in) :: name
    integer, intent(out) :: nd
    integer(hsize_t), intent(out) :: d(2)
    logical, intent(out), optional :: is_float
    integer(hid_t) :: dset, space, dtype
    integer(hsize_t) :: md(2)
    integer :: e, tclass
    nd = 0
    d = 0
    if (present(is_float)) is_float = .false.
    call h5dopen_f(fid, name, dset, e)
    found = e >= 0
    if (.not. found) return
    if (present(is_float)) then
      call h5dget_type_f(dset, dtype, e)
      call h5tget_class_f(dtype, tclass, e)
      call h5tclose_f(dtype, e)
      is_float = tclass == H5T_FLOAT_F
    end if
    call h5dget_space_f(dset, space, e)
    call h5sget_simple_extent_ndims_f(space, nd, e)
    if (nd >= 1 .and. nd <= 2) call h5sget_simple_extent_dims_f(space, d(1:nd), md(1:nd), e)
    call h5sclose_f(space, e)
    call h5dclose_f(dset, e)
  end function dataset_shape

  !> The names of the root group's members, in name order, leaving out
  !> those longer than the names' length.
  subroutine root_link_names(fid, names)
    integer(hid_t), intent(in) :: fid
    character(len=*), allocatable, intent(out) :: names(:)
    character(len=256) :: name
    integer(size_t) :: name_size
    integer(hsize_t) :: j
    integer :: n, nlinks, storage, max_corder, err
    call h5gget_info_f(fid, storage, nlinks, max_corder, err)
    allocate(names(max(nlinks, 0)))
    n = 0
    do j = 0, int(nlinks, hsize_t) - 1
      name = ''
      call h5lget_name_by_idx_f(fid, '.', H5_INDEX_NAME_F, H5_ITER_INC_F, j, name, err, &
                                name_size)
      if (err < 0 .or. int(name_size) > len(names)) cycle
      n = n + 1
      names(n) = name
    end do
    names = names(1:n)
  end subroutine root_link_names

  !> The names of the root's attributes, in name order, leaving out those
  !> longer than the names' length.
  subroutine root_attribute_names(fid, names)
    integer(hid_t), intent(in) :: fid
    character(len=*), allocatable, intent(out) :: names(:)
    character(len=256) :: name
    integer(size_t) :: name_size
    integer :: k, n, nattr, err
    call h5aget_num_attrs_f(fid, nattr, err)
    allocate(names(max(nattr, 0)))
    n = 0
    do k = 0, nattr - 1
      name = ''
      call h5aget_name_by_idx_f(fid, '.', H5_INDEX_NAME_F, H5_ITER_INC_F, int(k, hsize_t), &
                                name, err, name_size)
      if (err < 0 .or. int(name_size) > len(names)) cycle
      n = n + 1
      names(n) = name
    end do
    names = names(1:n)
  end subroutine root_attribute_names

end module hdf5_helpers
