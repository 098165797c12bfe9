!> Particle state as a structure of arrays.  Owned particles come first
!> (1..n), halo copies from other ranks after them (n+1..n+n_halo).
!> Vectors always have three components; in 2D the third stays zero, so one
!> code serves both dimensions.  Each array is a field of the registry
!> (particle_fields.inc, expanded here by the C preprocessor), through which
!> the code that moves particles between ranks and files reaches them
!> without naming them.
module particles
  use kinds, only: wp, i8
  use particle_fields, only: FIELD_TABLE, N_FIELDS
#define FIELD(key, mem, kind, dset, mi, ha, re, sn, rs, ck) use particle_fields, only: key
#include "particle_fields.inc"
#undef FIELD
  implicit none
  private
  public :: particles_t, particles_allocate, particles_permute, particles_reserve
  public :: particles_field, particles_field_i8, particles_pack, particles_unpack

  type :: particles_t
    integer :: dim = 2
    integer :: n = 0                  !< owned particles
    integer :: n_halo = 0             !< halo copies stored after the owned ones
    !> the fields of particle_fields.inc: a VECTOR as (3, capacity), a
    !> SCALAR or an INT8 as (capacity)
#define FIELD(key, mem, kind, dset, mi, ha, re, sn, rs, ck) kind(mem)
#define VECTOR(mem) real(wp), allocatable :: mem(:, :)
#define SCALAR(mem) real(wp), allocatable :: mem(:)
#define INT8(mem) integer(i8), allocatable :: mem(:)
#include "particle_fields.inc"
#undef VECTOR
#undef SCALAR
#undef INT8
#undef FIELD
  end type particles_t

contains

  !> Empty particles with room for `capacity`, every field zero.
  subroutine particles_allocate(parts, dim, capacity)
    type(particles_t), intent(out) :: parts
    integer, intent(in) :: dim, capacity
    parts%dim = dim
#define FIELD(key, mem, kind, dset, mi, ha, re, sn, rs, ck) kind(mem)
#define VECTOR(mem) allocate(parts%mem(3, capacity), source=0.0_wp)
#define SCALAR(mem) allocate(parts%mem(capacity), source=0.0_wp)
#define INT8(mem) allocate(parts%mem(capacity), source=0_i8)
#include "particle_fields.inc"
#undef VECTOR
#undef SCALAR
#undef INT8
#undef FIELD
  end subroutine particles_allocate

  !> The storage of real field f (FIELD_TABLE) as (ncomp, capacity).
  !> parts must be a target in the caller, which may write through it.
  function particles_field(parts, f) result(a)
    type(particles_t), intent(in), target :: parts
    integer, intent(in) :: f
    real(wp), pointer, contiguous :: a(:, :)
    select case (f)
#define FIELD(key, mem, kind, dset, mi, ha, re, sn, rs, ck) kind(key, mem)
#define VECTOR(key, mem) case (key); a => parts%mem
#define SCALAR(key, mem) case (key); a(1:1, 1:size(parts%mem)) => parts%mem
#define INT8(key, mem)
#include "particle_fields.inc"
#undef VECTOR
#undef SCALAR
#undef INT8
#undef FIELD
    case default
      error stop 'particles_field: not a real field'
    end select
  end function particles_field

  !> The storage of int64 field f, as particles_field.
  function particles_field_i8(parts, f) result(a)
    type(particles_t), intent(in), target :: parts
    integer, intent(in) :: f
    integer(i8), pointer, contiguous :: a(:)
    select case (f)
#define FIELD(key, mem, kind, dset, mi, ha, re, sn, rs, ck) kind(key, mem)
#define VECTOR(key, mem)
#define SCALAR(key, mem)
#define INT8(key, mem) case (key); a => parts%mem
#include "particle_fields.inc"
#undef VECTOR
#undef SCALAR
#undef INT8
#undef FIELD
    case default
      error stop 'particles_field_i8: not an int64 field'
    end select
  end function particles_field_i8

  !> Makes room for at least `capacity` particles, keeping the contents.
  !> Grows to capacity + capacity/16: the halo and the owned count change a
  !> little at each rebuild, and every per-particle array of the solver is
  !> sized by this capacity, so headroom costs memory in all of them.  Field
  !> by field (move_alloc), so that the transient is one field, not all.
  subroutine particles_reserve(parts, capacity)
    type(particles_t), intent(inout), target :: parts
    integer, intent(in) :: capacity
    integer :: old, cap
    old = size(parts%rho)
    if (capacity <= old) return
    cap = capacity + capacity / 16
#define FIELD(key, mem, kind, dset, mi, ha, re, sn, rs, ck) kind(mem)
#define VECTOR(mem) call grow_vector(parts%mem)
#define SCALAR(mem) call grow_scalar(parts%mem)
#define INT8(mem) call grow_int8(parts%mem)
#include "particle_fields.inc"
#undef VECTOR
#undef SCALAR
#undef INT8
#undef FIELD

  contains

    subroutine grow_vector(a)
      real(wp), allocatable, intent(inout) :: a(:, :)
      real(wp), allocatable :: b(:, :)
      allocate(b(3, cap), source=0.0_wp)
      b(:, 1:old) = a
      call move_alloc(b, a)
    end subroutine grow_vector

    subroutine grow_scalar(a)
      real(wp), allocatable, intent(inout) :: a(:)
      real(wp), allocatable :: b(:)
      allocate(b(cap), source=0.0_wp)
      b(1:old) = a
      call move_alloc(b, a)
    end subroutine grow_scalar

    subroutine grow_int8(a)
      integer(i8), allocatable, intent(inout) :: a(:)
      integer(i8), allocatable :: b(:)
      allocate(b(cap), source=0_i8)
      b(1:old) = a
      call move_alloc(b, a)
    end subroutine grow_int8

  end subroutine particles_reserve

  !> Reorders the owned particles: new slot k receives old particle perm(k);
  !> with fewer entries than particles it also selects (the first size(perm)
  !> slots are filled, n is the caller's to set).
  subroutine particles_permute(parts, perm)
    type(particles_t), intent(inout), target :: parts
    integer, intent(in) :: perm(:)
    real(wp), pointer, contiguous :: a(:, :)
    integer(i8), pointer, contiguous :: ia(:)
    integer :: n, f
    n = size(perm)
    do f = 1, N_FIELDS
      if (FIELD_TABLE(f)%integer8) then
        ia => particles_field_i8(parts, f)
        ia(1:n) = ia(perm)
      else
        a => particles_field(parts, f)
        a(:, 1:n) = a(:, perm)
      end if
    end do
  end subroutine particles_permute

  !> Copies the fields `list` of particles idx(:) into the columns of buf,
  !> one field after the other (int64 fields bit for bit).  The loop over
  !> the fields is outside, so the copies run over particles.
  subroutine particles_pack(parts, list, idx, buf)
    type(particles_t), intent(in), target :: parts
    integer, intent(in) :: list(:), idx(:)
    real(wp), intent(inout) :: buf(:, :)
    real(wp), pointer, contiguous :: a(:, :)
    integer(i8), pointer, contiguous :: ia(:)
    integer :: j, f, r, nc, k
    r = 0
    do j = 1, size(list)
      f = list(j)
      nc = FIELD_TABLE(f)%ncomp
      if (FIELD_TABLE(f)%integer8) then
        ia => particles_field_i8(parts, f)
        do k = 1, size(idx)
          buf(r + 1, k) = transfer(ia(idx(k)), 1.0_wp)
        end do
      else
        a => particles_field(parts, f)
        if (nc == 3) then   ! fixed extents: copies the compiler can unroll
          do k = 1, size(idx)
            buf(r + 1:r + 3, k) = a(1:3, idx(k))
          end do
        else
          do k = 1, size(idx)
            buf(r + 1, k) = a(1, idx(k))
          end do
        end if
      end if
      r = r + nc
    end do
  end subroutine particles_pack

  !> The inverse of particles_pack: column k <= count of buf goes to slot
  !> first + k.
  subroutine particles_unpack(parts, list, first, count, buf)
    type(particles_t), intent(inout), target :: parts
    integer, intent(in) :: list(:), first, count
    real(wp), intent(in) :: buf(:, :)
    real(wp), pointer, contiguous :: a(:, :)
    integer(i8), pointer, contiguous :: ia(:)
    integer :: j, f, r, nc, k
    r = 0
    do j = 1, size(list)
      f = list(j)
      nc = FIELD_TABLE(f)%ncomp
      if (FIELD_TABLE(f)%integer8) then
        ia => particles_field_i8(parts, f)
        do k = 1, count
          ia(first + k) = transfer(buf(r + 1, k), 1_i8)
        end do
      else
        a => particles_field(parts, f)
        if (nc == 3) then
          do k = 1, count
            a(1:3, first + k) = buf(r + 1:r + 3, k)
          end do
        else
          do k = 1, count
            a(1, first + k) = buf(r + 1, k)
          end do
        end if
      end if
      r = r + nc
    end do
  end subroutine particles_unpack

end module particles
