!> Initial particle placement in a disc (2D) or ball (3D) of radius R.
!>
!> 'rings': concentric rings (shells in 3D) of spacing dx at radii
!> (k - 1/2) dx, k = 1..K with K dx = R, each evenly filled; every particle
!> gets the area (volume) of its ring divided by the ring's count, so the
!> volumes add up to the body's exactly.  It survives strong stretching
!> where a clipped lattice fails (doc/theory.md, "Measurements the defaults rest on").
!> 'lattice': a square (cubic) lattice of spacing dx clipped to the body,
!> each particle with volume dx^dim.
!> 'packed': the first guess of the packing (doc/packing.md): the clipped
!> lattice with every point moved by a pseudo-random offset of up to
!> PACK_NOISE dx per axis (a hash of the particle's number, so the guess is
!> the same on every rank and every run) and kept inside R - dx/4; every
!> particle gets the volume |Omega|/N.
module placement
  use kinds, only: wp, pi, i8
  implicit none
  private
  public :: place_ball, ball_spacing, PLACE_RINGS, PLACE_LATTICE, PLACE_PACKED, hash_uniform, &
            packed_volume

  integer, parameter :: PLACE_RINGS = 1, PLACE_LATTICE = 2, PLACE_PACKED = 3
  real(wp), parameter :: PACK_NOISE = 1.0_wp

contains

  !> The spacing for about n_target particles in the ball: for rings it is
  !> adjusted so that R/dx is a whole number of rings.
  function ball_spacing(dim, radius, n_target, kind) result(dx)
    integer, intent(in) :: dim, n_target, kind
    real(wp), intent(in) :: radius
    real(wp) :: dx
    integer :: nrings
    if (dim == 2) then
      dx = sqrt(pi * radius**2 / n_target)
    else
      dx = (4 * pi * radius**3 / (3 * real(n_target, wp)))**(1 / 3.0_wp)
    end if
    if (kind == PLACE_RINGS) then
      nrings = max(1, nint(radius / dx))
      dx = radius / nrings
    end if
  end function ball_spacing

  !> Positions x(3, np) and volumes vol(np) of the particles of the ball.
  subroutine place_ball(dim, radius, dx, kind, x, vol)
    integer, intent(in) :: dim, kind
    real(wp), intent(in) :: radius, dx
    real(wp), allocatable, intent(out) :: x(:, :), vol(:)
    if (kind == PLACE_RINGS) then
      if (dim == 2) then
        call rings_2d(radius, dx, x, vol)
      else
        call shells_3d(radius, dx, x, vol)
      end if
    else
      call clipped_lattice(dim, radius, dx, x, vol)
      if (kind == PLACE_PACKED) call perturb(dim, radius, dx, x, vol)
    end if
  end subroutine place_ball

  !> The packing's first guess from the clipped lattice (see the header).
  subroutine perturb(dim, radius, dx, x, vol)
    integer, intent(in) :: dim
    real(wp), intent(in) :: radius, dx
    real(wp), intent(inout) :: x(:, :), vol(:)
    real(wp) :: r, r_max
    integer :: i, k
    r_max = radius - 0.25_wp * dx
    do i = 1, size(vol)
      do k = 1, dim
        x(k, i) = x(k, i) + PACK_NOISE * dx * (2 * hash_uniform(i, k) - 1)
      end do
      r = norm2(x(:, i))
      if (r > r_max) x(:, i) = x(:, i) * (r_max / r)
    end do
    vol = packed_volume(dim, radius, size(vol, kind=i8))
  end subroutine perturb

  !> The volume of each of n packed particles, |Omega|/n (one expression for
  !> the packing and for particles.from, so that both round alike).
  pure real(wp) function packed_volume(dim, radius, n) result(v)
    integer, intent(in) :: dim
    real(wp), intent(in) :: radius
    integer(i8), intent(in) :: n
    if (dim == 2) then
      v = pi * radius**2 / real(n, wp)
    else
      v = 4 * pi * radius**3 / (3 * real(n, wp))
    end if
  end function packed_volume

  !> A number in [0, 1) from (i, k) by a few rounds of the Park-Miller
  !> generator, each followed by an xor-shift that breaks its linearity (so
  !> that neighbouring seeds give unrelated numbers); products stay below
  !> 2^47: no overflow in 64-bit integers.
  pure real(wp) function hash_uniform(i, k) result(u)
    integer, intent(in) :: i, k
    integer(i8), parameter :: a = 48271_i8, m = 2147483647_i8
    integer(i8) :: z
    integer :: l
    z = mod(int(i, i8) * 3_i8 + int(k, i8), m - 1) + 1
    do l = 1, 4
      z = mod(a * z, m)
      z = ieor(z, ishft(z, -11))
      if (z == 0) z = 1
    end do
    u = real(z - 1, wp) / real(m - 1, wp)
  end function hash_uniform

  subroutine rings_2d(radius, dx, x, vol)
    real(wp), intent(in) :: radius, dx
    real(wp), allocatable, intent(out) :: x(:, :), vol(:)
    integer :: nrings, k, j, nk, np, total
    real(wp) :: rk, theta, shift
    nrings = nint(radius / dx)
    total = 0
    do k = 1, nrings
      total = total + ring_count(k)
    end do
    allocate(x(3, total), vol(total))
    x = 0
    np = 0
    do k = 1, nrings
      rk = (k - 0.5_wp) * dx
      nk = ring_count(k)
      ! alternate rings are rotated by half a spacing, like a hexagonal packing
      shift = 0.5_wp * mod(k, 2)
      do j = 1, nk
        theta = 2 * pi * (j - 1 + shift) / nk
        np = np + 1
        x(1:2, np) = rk * [cos(theta), sin(theta)]
        ! annulus between (k-1) dx and k dx shared by its nk particles
        vol(np) = pi * dx**2 * (2 * k - 1) / nk
      end do
    end do
  contains
    integer function ring_count(kk)
      integer, intent(in) :: kk
      ring_count = max(1, nint(2 * pi * (kk - 0.5_wp)))
    end function ring_count
  end subroutine rings_2d

  !> Shells of radius (k - 1/2) dx, each with about 4 pi r^2/dx^2 points on a
  !> Fibonacci spiral (near-uniform on the sphere); successive shells are
  !> turned by the golden angle so their seams do not line up.
  subroutine shells_3d(radius, dx, x, vol)
    real(wp), intent(in) :: radius, dx
    real(wp), intent(out), allocatable :: x(:, :), vol(:)
    real(wp), parameter :: golden = pi * (3 - sqrt(5.0_wp))
    integer :: nshells, k, j, nk, np, total
    real(wp) :: rk, z, rho, phi, shell_vol
    nshells = nint(radius / dx)
    total = 0
    do k = 1, nshells
      total = total + shell_count(k)
    end do
    allocate(x(3, total), vol(total))
    np = 0
    do k = 1, nshells
      rk = (k - 0.5_wp) * dx
      nk = shell_count(k)
      shell_vol = 4 * pi / 3 * dx**3 * (real(k, wp)**3 - real(k - 1, wp)**3)
      do j = 0, nk - 1
        z = 1 - (2 * j + 1) / real(nk, wp)
        rho = sqrt(max(0.0_wp, 1 - z**2))
        phi = golden * j + golden * k
        np = np + 1
        x(:, np) = rk * [rho * cos(phi), rho * sin(phi), z]
        vol(np) = shell_vol / nk
      end do
    end do
  contains
    integer function shell_count(kk)
      integer, intent(in) :: kk
      shell_count = max(1, nint(4 * pi * (kk - 0.5_wp)**2))
    end function shell_count
  end subroutine shells_3d

  !> Lattice points ((i + 1/2) dx, ...) inside the ball, symmetric about the
  !> centre in every axis.
  subroutine clipped_lattice(dim, radius, dx, x, vol)
    integer, intent(in) :: dim
    real(wp), intent(in) :: radius, dx
    real(wp), allocatable, intent(out) :: x(:, :), vol(:)
    integer :: m, i, j, k, kz, np, pass
    real(wp) :: p(3)
    m = ceiling(radius / dx)
    kz = merge(m, 0, dim == 3)
    np = 0
    do pass = 1, 2
      np = 0
      do k = -kz, max(kz - 1, 0)
        do j = -m, m - 1
          do i = -m, m - 1
            p = [(i + 0.5_wp) * dx, (j + 0.5_wp) * dx, 0.0_wp]
            if (dim == 3) p(3) = (k + 0.5_wp) * dx
            if (sum(p**2) >= radius**2) cycle
            np = np + 1
            if (pass == 2) x(:, np) = p
          end do
        end do
      end do
      if (pass == 1) allocate(x(3, np), vol(np))
    end do
    vol = dx**dim
  end subroutine clipped_lattice

end module placement
