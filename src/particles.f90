!> Particle state as a structure of arrays.  Owned particles come first
!> (1..n), halo copies from other ranks after them (n+1..n+n_halo).
!> Vectors always have three components; in 2D the third stays zero, so one
!> code serves both dimensions.
module particles
  use kinds, only: wp, i8
  implicit none
  private
  public :: particles_t, particles_allocate, particles_permute, particles_reserve

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
    integer(i8), allocatable :: id(:) !< global id, 1..N
  end type particles_t

contains

  subroutine particles_allocate(parts, dim, capacity)
    type(particles_t), intent(inout) :: parts
    integer, intent(in) :: dim, capacity
    parts%dim = dim
    parts%n = 0
    parts%n_halo = 0
    if (allocated(parts%x)) deallocate(parts%x, parts%u, parts%rho, parts%p, parts%m, &
                                       parts%x0, parts%id)
    allocate(parts%x(3, capacity), parts%u(3, capacity), parts%rho(capacity), &
             parts%p(capacity), parts%m(capacity), parts%x0(3, capacity), parts%id(capacity))
    parts%x = 0; parts%u = 0; parts%x0 = 0
    parts%rho = 0; parts%p = 0; parts%m = 0; parts%id = 0
  end subroutine particles_allocate

  !> Makes room for at least `capacity` particles, keeping the contents
  !> (grows by half again at least, so repeated growth stays cheap).
  subroutine particles_reserve(parts, capacity)
    type(particles_t), intent(inout) :: parts
    integer, intent(in) :: capacity
    real(wp), allocatable :: r1(:), r3(:, :)
    integer(i8), allocatable :: i1(:)
    integer :: old, cap
    old = size(parts%rho)
    if (capacity <= old) return
    cap = max(capacity, old + old / 2)
    allocate(r3(3, cap)); r3 = 0; r3(:, 1:old) = parts%x; call move_alloc(r3, parts%x)
    allocate(r3(3, cap)); r3 = 0; r3(:, 1:old) = parts%u; call move_alloc(r3, parts%u)
    allocate(r3(3, cap)); r3 = 0; r3(:, 1:old) = parts%x0; call move_alloc(r3, parts%x0)
    allocate(r1(cap)); r1 = 0; r1(1:old) = parts%rho; call move_alloc(r1, parts%rho)
    allocate(r1(cap)); r1 = 0; r1(1:old) = parts%p; call move_alloc(r1, parts%p)
    allocate(r1(cap)); r1 = 0; r1(1:old) = parts%m; call move_alloc(r1, parts%m)
    allocate(i1(cap)); i1 = 0; i1(1:old) = parts%id; call move_alloc(i1, parts%id)
  end subroutine particles_reserve

  !> Reorders the owned particles: new slot k receives old particle perm(k);
  !> with fewer entries than particles it also selects (the first size(perm)
  !> slots are filled, n is the caller's to set).
  subroutine particles_permute(parts, perm)
    type(particles_t), intent(inout) :: parts
    integer, intent(in) :: perm(:)
    integer :: n
    n = size(perm)
    parts%x(:, 1:n) = parts%x(:, perm)
    parts%u(:, 1:n) = parts%u(:, perm)
    parts%x0(:, 1:n) = parts%x0(:, perm)
    parts%rho(1:n) = parts%rho(perm)
    parts%p(1:n) = parts%p(perm)
    parts%m(1:n) = parts%m(perm)
    parts%id(1:n) = parts%id(perm)
  end subroutine particles_permute

end module particles
