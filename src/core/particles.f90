!> Particle state as a structure of arrays.  Owned particles come first
!> (1..n), halo copies from other ranks after them (n+1..n+n_halo).
!> Vectors always have three components; in 2D the third stays zero, so one
!> code serves both dimensions.  Each array is a field of the registry
!> (particle_fields), through which the code that moves particles between
!> ranks and files reaches them without naming them.
module particles
  use kinds, only: wp, i8
  use particle_fields, only: FIELD_TABLE, N_FIELDS, FIELD_X, FIELD_U, FIELD_RHO, FIELD_P, &
                             FIELD_M, FIELD_ID, FIELD_X0, FIELD_XREF
  implicit none
  private
  public :: particles_t, particles_allocate, particles_permute, particles_reserve
  public :: particles_field, particles_field_i8, particles_pack, particles_unpack

  type :: particles_t
    integer :: dim = 2
    integer :: n = 0                  !< owned particles
    integer :: n_halo = 0             !< halo copies stored after the owned ones
    real(wp), allocatable :: x(:, :)  !< position (3, capacity)
    real(wp), allocatable :: u(:, :)  !< velocity (3, capacity)
    real(wp), allocatable :: rho(:)   !< density
    real(wp), allocatable :: p(:)     !< pressure, from rho by the equation of state
    real(wp), allocatable :: m(:)     !< mass
    real(wp), allocatable :: x0(:, :) !< initial position (Lagrangian label)
    !> position at the last neighbour-list build (list_check's reference)
    real(wp), allocatable :: xref(:, :)
    integer(i8), allocatable :: id(:) !< global id, 1..N
  end type particles_t

contains

  !> Empty particles with room for `capacity`, every field zero.
  subroutine particles_allocate(parts, dim, capacity)
    type(particles_t), intent(out) :: parts
    integer, intent(in) :: dim, capacity
    parts%dim = dim
    allocate(parts%x(3, capacity), parts%u(3, capacity), parts%rho(capacity), &
             parts%p(capacity), parts%m(capacity), parts%x0(3, capacity), &
             parts%xref(3, capacity), parts%id(capacity))
    parts%x = 0; parts%u = 0; parts%x0 = 0; parts%xref = 0
    parts%rho = 0; parts%p = 0; parts%m = 0; parts%id = 0
  end subroutine particles_allocate

  !> The storage of real field f (FIELD_TABLE) as (ncomp, capacity).
  !> parts must be a target in the caller, which may write through it.
  function particles_field(parts, f) result(a)
    type(particles_t), intent(in), target :: parts
    integer, intent(in) :: f
    real(wp), pointer, contiguous :: a(:, :)
    select case (f)
    case (FIELD_X)
      a => parts%x
    case (FIELD_U)
      a => parts%u
    case (FIELD_RHO)
      a(1:1, 1:size(parts%rho)) => parts%rho
    case (FIELD_P)
      a(1:1, 1:size(parts%p)) => parts%p
    case (FIELD_M)
      a(1:1, 1:size(parts%m)) => parts%m
    case (FIELD_X0)
      a => parts%x0
    case (FIELD_XREF)
      a => parts%xref
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
    case (FIELD_ID)
      a => parts%id
    case default
      error stop 'particles_field_i8: not an int64 field'
    end select
  end function particles_field_i8

  !> Makes room for at least `capacity` particles, keeping the contents
  !> (grows by half again at least, so repeated growth stays cheap).
  subroutine particles_reserve(parts, capacity)
    type(particles_t), intent(inout), target :: parts
    integer, intent(in) :: capacity
    type(particles_t), target :: grown
    real(wp), pointer, contiguous :: a(:, :), b(:, :)
    integer(i8), pointer, contiguous :: ia(:), ib(:)
    integer :: old, f
    old = size(parts%rho)
    if (capacity <= old) return
    call particles_allocate(grown, parts%dim, max(capacity, old + old / 2))
    grown%n = parts%n
    grown%n_halo = parts%n_halo
    do f = 1, N_FIELDS
      if (FIELD_TABLE(f)%integer8) then
        ia => particles_field_i8(grown, f)
        ib => particles_field_i8(parts, f)
        ia(1:old) = ib
      else
        a => particles_field(grown, f)
        b => particles_field(parts, f)
        a(:, 1:old) = b
      end if
    end do
    ! one copy more than moving each array, but growth is rare and no
    ! field needs naming here
    parts = grown
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
