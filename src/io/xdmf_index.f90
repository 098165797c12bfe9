!> The XDMF index of a run (snapshots.xdmf): the snapshots as one time
!> series for ParaView, each a uniform grid of Polyvertex topology whose
!> data stay in the snapshot's HDF5 file (doc/reference/output.md).  The
!> index is kept identical on every rank and rewritten whole, atomically,
!> by rank 0.
module xdmf_index
  use kinds, only: wp, i8
  use mpi_f08, only: MPI_Comm, MPI_Comm_rank
  use fileutil, only: agree_ok, base_name, text_buffer_t, text_append, write_file_atomic
  use snapshot_fields, only: snapshot_field_t, SNAPSHOT_NAME_LEN, STANDARD_DATASETS, kind_of
  implicit none
  private
  public :: xdmf_index_t, xdmf_init, xdmf_add, xdmf_write, connectivity_precision

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

contains

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

  !> Bytes per entry of a snapshot's `connectivity` dataset, the vertex
  !> list of the Polyvertex topology: 4 while N < 2^31.
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

  !> Text for an XML attribute value or element.
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

end module xdmf_index
