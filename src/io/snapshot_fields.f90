!> What a snapshot holds, apart from the file: the named fields a run hands
!> to the writer (snapshot_field_t, and snapshot_source_t for the fields
!> made only when written), the standard datasets every snapshot has, their
!> kinds, the names allowed, and the checks of the fields and attribute
!> names given to snapshot_write.  snapshot_io writes and reads the files,
!> xdmf_index lists them for ParaView.
module snapshot_fields
  use kinds, only: wp, i8
  implicit none
  private
  public :: snapshot_field_t, snapshot_source_t
  public :: SNAPSHOT_NAME_LEN, STANDARD_DATASETS, STANDARD_KINDS, RESERVED_ATTRIBUTES
  public :: kind_of, field_s, field_v, field_i, valid_name
  public :: check_fields, check_attribute_names

  integer, parameter :: SNAPSHOT_NAME_LEN = 64      !< longest field or attribute name

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

  !> The datasets of every snapshot: the first six are the fields the
  !> writer must be given, of the kinds in STANDARD_KINDS (v vector, s
  !> scalar, i int64); connectivity it makes itself.
  character(len=*), parameter :: STANDARD_DATASETS(7) = &
    [character(len=12) :: 'position', 'velocity', 'density', 'pressure', 'mass', 'id', &
                          'connectivity']
  character(len=*), parameter :: STANDARD_KINDS = 'vvsssi'
  !> the root attributes every snapshot has
  character(len=*), parameter :: RESERVED_ATTRIBUTES(5) = &
    [character(len=14) :: 'time', 'step', 'dim', 'case', 'format_version']

contains

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

  !> The extra root attributes' names given to snapshot_write: valid, not
  !> reserved, not repeated.
  subroutine check_attribute_names(attr_names, good, msg)
    character(len=*), intent(in) :: attr_names(:)
    logical, intent(out) :: good
    character(len=:), allocatable, intent(out) :: msg
    integer :: j
    good = .false.
    do j = 1, size(attr_names)
      if (.not. valid_name(attr_names(j))) then
        msg = 'snapshot_write: invalid attribute name "' // trim(attr_names(j)) // '"'
        return
      end if
      if (any(RESERVED_ATTRIBUTES == attr_names(j)) .or. &
          any(attr_names(:j-1) == attr_names(j))) then
        msg = 'snapshot_write: attribute name "' // trim(attr_names(j)) // &
              '" is reserved or repeated'
        return
      end if
    end do
    good = .true.
    msg = ''
  end subroutine check_attribute_names

  !> The fields given to snapshot_write: each named validly and once, of
  !> one kind, with n_local entries (and dim rows) at least, computed only
  !> when there is a source (has_source); the standard ones there, of their
  !> kinds (snapshot_read needs them).
  subroutine check_fields(fields, dim, n_local, has_source, good, msg)
    type(snapshot_field_t), intent(in) :: fields(:)
    integer, intent(in) :: dim, n_local
    logical, intent(in) :: has_source
    logical, intent(out) :: good
    character(len=:), allocatable, intent(out) :: msg
    integer :: j, l, k
    good = .false.
    do j = 1, size(fields)
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
        else if (.not. has_source) then
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
      if (len(msg) > 0) return
    end do
    msg = ''
    do l = 1, len(STANDARD_KINDS)
      j = findloc([(fields(k)%name == trim(STANDARD_DATASETS(l)), k = 1, size(fields))], &
                  .true., dim=1)
      if (j == 0) then
        msg = 'snapshot_write: no field "' // trim(STANDARD_DATASETS(l)) // '"'
      else if (kind_of(fields(j)) /= STANDARD_KINDS(l:l)) then
        msg = 'snapshot_write: field "' // trim(STANDARD_DATASETS(l)) // &
              '" is not of its standard kind'
      end if
      if (len(msg) > 0) return
    end do
    good = .true.
    msg = ''
  end subroutine check_fields

end module snapshot_fields
