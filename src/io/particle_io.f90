!> Particles to and from snapshots through the field registry
!> (particle_fields): the snapshot fields of the owned particles, and the
!> particles of a snapshot read back.
module particle_io
  use kinds, only: wp, i8
  use particle_fields, only: FIELD_TABLE, SNAPSHOT_FIELDS, RESTART_FIELDS, CHECKPOINT_FIELDS
  use particles, only: particles_t, particles_allocate, particles_field, particles_field_i8
  use snapshot_io, only: snapshot_field_t, snapshot_t, snapshot_get_field
  use mirrors, only: mirror_codes, image_id, image_code, reflect_column, planes_on, &
                     plane_weights, set_weight, REFLECT_VECTOR
  implicit none
  private
  public :: particles_snapshot_fields, particles_from_snapshot, particles_from_checkpoint, &
            particles_whole_body, particles_drop_images

contains

  !> The registered snapshot fields of the owned particles, in table order
  !> (vectors with their 3 rows: the snapshot keeps the first dim), as
  !> views of the particles' arrays (parts must be a target in the caller
  !> and stay unchanged until the write), then `extra`, whose arrays are
  !> moved, not copied (or which are computed as they are written).  A
  !> checkpoint holds the registered checkpoint fields too.
  subroutine particles_snapshot_fields(parts, extra, fields, checkpoint)
    type(particles_t), intent(in), target :: parts
    type(snapshot_field_t), intent(inout) :: extra(:)
    type(snapshot_field_t), allocatable, intent(out) :: fields(:)
    logical, intent(in), optional :: checkpoint
    real(wp), pointer, contiguous :: a(:, :)
    integer(i8), pointer, contiguous :: ia(:)
    integer, allocatable :: keys(:)
    integer :: j, f, n, m
    logical :: with_checkpoint
    n = parts%n
    with_checkpoint = .false.
    if (present(checkpoint)) with_checkpoint = checkpoint
    if (with_checkpoint) then
      keys = [SNAPSHOT_FIELDS, CHECKPOINT_FIELDS]
    else
      keys = SNAPSHOT_FIELDS
    end if
    m = size(keys)
    allocate(fields(m + size(extra)))
    do j = 1, m
      f = keys(j)
      fields(j)%name = trim(FIELD_TABLE(f)%name)
      ! views of the particles' arrays, not copies (their first n entries
      ! are contiguous)
      if (FIELD_TABLE(f)%integer8) then
        ia => particles_field_i8(parts, f)
        fields(j)%i_view => ia(1:n)
      else if (FIELD_TABLE(f)%ncomp == 1) then
        a => particles_field(parts, f)
        fields(j)%s_view(1:n) => a(:, 1:n)
      else
        a => particles_field(parts, f)
        fields(j)%v_view => a(:, 1:n)
      end if
    end do
    do j = 1, size(extra)
      call move_alloc(extra(j)%name, fields(m + j)%name)
      if (allocated(extra(j)%s)) call move_alloc(extra(j)%s, fields(m + j)%s)
      if (allocated(extra(j)%v)) call move_alloc(extra(j)%v, fields(m + j)%v)
      if (allocated(extra(j)%i)) call move_alloc(extra(j)%i, fields(m + j)%i)
      fields(m + j)%computed = extra(j)%computed
    end do
  end subroutine particles_snapshot_fields

  !> This rank's rows of snapshot `snap` as owned particles of dimension
  !> dim, every registered restart field from its dataset; fails naming the
  !> first dataset the snapshot lacks.
  subroutine particles_from_snapshot(snap, dim, parts, ok, missing)
    type(snapshot_t), intent(in) :: snap
    integer, intent(in) :: dim
    type(particles_t), intent(inout), target :: parts
    logical, intent(out) :: ok
    character(len=:), allocatable, intent(out) :: missing
    call particles_allocate(parts, dim, max(snap%n_local, 1))
    parts%n = snap%n_local
    call read_fields(snap, dim, RESTART_FIELDS, parts, ok, missing)
  end subroutine particles_from_snapshot

  !> The registered checkpoint fields of checkpoint `snap` into the
  !> particles particles_from_snapshot read from it.
  subroutine particles_from_checkpoint(snap, dim, parts, ok, missing)
    type(snapshot_t), intent(in) :: snap
    integer, intent(in) :: dim
    type(particles_t), intent(inout), target :: parts
    logical, intent(out) :: ok
    character(len=:), allocatable, intent(out) :: missing
    call read_fields(snap, dim, CHECKPOINT_FIELDS, parts, ok, missing)
  end subroutine particles_from_checkpoint

  subroutine read_fields(snap, dim, keys, parts, ok, missing)
    type(snapshot_t), intent(in) :: snap
    integer, intent(in) :: dim, keys(:)
    type(particles_t), intent(inout), target :: parts
    logical, intent(out) :: ok
    character(len=:), allocatable, intent(out) :: missing
    type(snapshot_field_t) :: sf
    real(wp), pointer, contiguous :: a(:, :)
    integer(i8), pointer, contiguous :: ia(:)
    integer :: j, f, n
    n = snap%n_local
    ok = .true.
    missing = ''
    do j = 1, size(keys)
      f = keys(j)
      call snapshot_get_field(snap, trim(FIELD_TABLE(f)%name), sf, ok)
      if (ok) ok = allocated(sf%i) .eqv. FIELD_TABLE(f)%integer8
      if (ok) ok = allocated(sf%s) .eqv. (FIELD_TABLE(f)%ncomp == 1 .and. &
                                          .not. FIELD_TABLE(f)%integer8)
      if (.not. ok) then
        missing = trim(FIELD_TABLE(f)%name)
        return
      end if
      if (allocated(sf%i)) then
        ia => particles_field_i8(parts, f)
        ia(1:n) = sf%i(1:n)
      else if (allocated(sf%s)) then
        a => particles_field(parts, f)
        a(1, 1:n) = sf%s(1:n)
      else
        a => particles_field(parts, f)
        a(1:dim, 1:n) = sf%v(1:dim, 1:n)
      end if
    end do
  end subroutine read_fields

  !> (M3) The whole body of a run with mirror planes (mask): the owned
  !> particles, then their reflections by each code in ascending order,
  !> every registered field reflected by its kind (vectors flip the code's
  !> components, the id becomes the image's, scalars are copied).  (M5) A
  !> particle on planes P is one particle with its images across them: it
  !> appears once per code that flips none of P, with the mass 2^|P| m.
  subroutine particles_whole_body(parts, mask, whole)
    type(particles_t), intent(in), target :: parts
    integer, intent(in) :: mask
    type(particles_t), intent(out), target :: whole
    integer, allocatable :: codes(:), on(:), rows(:)
    real(wp), allocatable :: w(:)
    real(wp), pointer, contiguous :: a(:, :), b(:, :)
    integer(i8), pointer, contiguous :: ia(:), ib(:)
    integer :: n, c, f, i, nw, first
    n = parts%n
    allocate(codes, source=[0, mirror_codes(mask)])
    allocate(on, source=[(planes_on(parts%x(:, i), mask), i = 1, n)])
    w = set_weight(on)
    nw = 0
    do c = 1, size(codes)
      nw = nw + count(iand(on, codes(c)) == 0)
    end do
    call particles_allocate(whole, parts%dim, max(nw, 1))
    whole%n = nw
    first = 0
    do c = 1, size(codes)
      rows = pack([(i, i = 1, n)], iand(on, codes(c)) == 0)
      do f = 1, size(FIELD_TABLE)
        if (FIELD_TABLE(f)%integer8) then
          ia => particles_field_i8(parts, f)
          ib => particles_field_i8(whole, f)
          ib(first + 1:first + size(rows)) = image_id(ia(rows), codes(c))
        else
          a => particles_field(parts, f)
          b => particles_field(whole, f)
          b(:, first + 1:first + size(rows)) = a(:, rows)
          if (FIELD_TABLE(f)%ncomp == 3) then
            do i = first + 1, first + size(rows)
              call reflect_column(REFLECT_VECTOR, codes(c), b(:, i))
            end do
          end if
        end if
      end do
      whole%m(first + 1:first + size(rows)) = whole%m(first + 1:first + size(rows)) / w(rows)
      first = first + size(rows)
    end do
  end subroutine particles_whole_body

  !> Keeps the owned particles that are no image (a snapshot written with
  !> output.mirror holds the part's reflections too), in their order; (M5)
  !> one on planes gets back its share of the mass, 2^-|P| (mask: the
  !> planes).
  subroutine particles_drop_images(parts, mask)
    type(particles_t), intent(inout), target :: parts
    integer, intent(in) :: mask
    real(wp), pointer, contiguous :: a(:, :)
    integer(i8), pointer, contiguous :: ia(:)
    logical, allocatable :: keep(:)
    integer :: f, n, nk
    n = parts%n
    allocate(keep, source=image_code(parts%id(1:n)) == 0)
    nk = count(keep)
    if (nk == n) return
    do f = 1, size(FIELD_TABLE)
      if (FIELD_TABLE(f)%integer8) then
        ia => particles_field_i8(parts, f)
        ia(1:nk) = pack(ia(1:n), keep)
      else
        a => particles_field(parts, f)
        a(:, 1:nk) = reshape(pack(a(:, 1:n), spread(keep, 1, size(a, 1))), [size(a, 1), nk])
      end if
    end do
    parts%n = nk
    parts%m(1:nk) = parts%m(1:nk) * plane_weights(parts%x(:, 1:nk), mask)
  end subroutine particles_drop_images

end module particle_io
