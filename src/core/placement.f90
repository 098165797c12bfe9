!> Initial particle placement in a disc (2D) or ball (3D) of radius R, and
!> on a square (place_square).
!>
!> 'rings': concentric rings (shells in 3D) of spacing dx at radii
!> (k - 1/2) dx, k = 1..K with K dx = R, each evenly filled; every particle
!> gets the area (volume) of its ring divided by the ring's count, so the
!> volumes add up to the body's exactly.  It survives strong stretching
!> where a clipped lattice fails (doc/studies/numerics.md, "The plain scheme on circle2d").
!> 'lattice': a square (cubic) lattice of spacing dx clipped to the body,
!> each particle with volume dx^dim.
!> 'packed': the first guess of the packing (doc/theory/packing.md): the clipped
!> lattice with every point moved by a pseudo-random offset of up to
!> PACK_NOISE dx per axis (a hash of the particle's number, so the guess is
!> the same on every rank and every run) and kept inside R - dx/4; every
!> particle gets the volume |Omega|/N.
!>
!> Every placement numbers its particles 1..N in a fixed order, so a rank
!> can generate its own share (a contiguous range of numbers) without the
!> others: the set-up is distributed, no rank holds all particles.
!>
!> With mirror planes (mirrors) 'lattice' and 'packed' place the part
!> x_k >= 0 of the body on each mirrored axis k: the lattice points with
!> i >= 0 there (every coordinate at least dx/2, none on a plane), whose
!> reflections are exactly the full lattice.  The packing's guess there
!> (guess_with_planes) conserves the weight (M5): each plane carries a
!> lattice of its own (one plane per point at most), whose points of
!> weight 1/2 stand for the slab within slab(k) dx of the plane (dx/4, half
!> a lattice layer; dx/2 where the flow approaches the plane, M6), and the
!> other points form the lattice shifted slab(k) dx off the planes, which
!> fills the rest; jittered, they are reflected to the part's side and kept
!> slab(k) dx off the planes.  The guess is then
!> uniform in weight up to the plane, and the packing has no deficit to
!> spread (doc/studies/symmetry.md, "The start-up dip").
module placement
  use kinds, only: wp, pi, i8
  use shares, only: share_range
  use mirrors, only: mirror_copies, on_plane, PLANE_SLAB
  implicit none
  private
  public :: place_ball, ball_spacing, PLACE_RINGS, PLACE_LATTICE, PLACE_PACKED, hash_uniform, &
            packed_volume, place_square

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

  !> Positions x(3, :) and volumes vol(:) of the particles of the ball:
  !> all of them, or with share = [r, P] the r-th of P contiguous shares of
  !> their numbers (r = 0..P-1: numbers floor(r N/P) + 1 .. floor((r+1) N/P)).
  !> first: the number of x(:, 1); n_total: N (of the part with mirror, the
  !> planes' mask; rings have no planes).
  subroutine place_ball(dim, radius, dx, kind, x, vol, share, first, n_total, mirror, n_whole, &
                        slab)
    integer, intent(in) :: dim, kind
    real(wp), intent(in) :: radius, dx
    real(wp), allocatable, intent(out) :: x(:, :), vol(:)
    integer, intent(in), optional :: share(2)
    integer, intent(out), optional :: first, n_total
    integer, intent(in), optional :: mirror
    integer(i8), intent(out), optional :: n_whole
    !> each axis's plane's slab in dx (M5, M6; PLANE_SLAB by default)
    real(wp), intent(in), optional :: slab(3)
    integer :: total, lo, hi, mask, n_on
    integer(i8) :: first8, last8, whole
    real(wp) :: sl(3)
    mask = 0
    if (present(mirror)) mask = mirror
    sl = PLANE_SLAB
    if (present(slab)) sl = slab
    n_on = 0
    if (mask /= 0 .and. kind == PLACE_RINGS) error stop 'place_ball: rings have no mirror planes'
    if (kind == PLACE_RINGS .and. dim == 2) then
      total = rings_2d_count(radius, dx)
    else if (kind == PLACE_RINGS) then
      total = shells_3d_count(radius, dx)
    else if (kind == PLACE_PACKED .and. mask /= 0) then
      call guess_with_planes_count(dim, radius, dx, mask, sl, total, n_on)
    else
      total = clipped_lattice_count(dim, radius, dx, mask)
    end if
    ! the whole body's count: each point once per copy, one on a plane
    ! (M5, weight 1/2) half as often
    whole = int(total - n_on, i8) * mirror_copies(mask) + int(n_on, i8) * mirror_copies(mask) / 2
    lo = 1
    hi = total
    if (present(share)) then
      call share_range(int(total, i8), share(1), share(2), first8, last8)
      lo = int(first8)
      hi = int(last8)
    end if
    allocate(x(3, hi - lo + 1), vol(hi - lo + 1))
    x = 0
    if (kind == PLACE_RINGS .and. dim == 2) then
      call rings_2d(radius, dx, lo, hi, x, vol)
    else if (kind == PLACE_RINGS) then
      call shells_3d(radius, dx, lo, hi, x, vol)
    else if (kind == PLACE_PACKED .and. mask /= 0) then
      call guess_with_planes(dim, radius, dx, lo, hi, x, vol, mask, sl)
      call perturb(dim, radius, dx, lo, whole, x, vol, mask, sl)
    else
      call clipped_lattice(dim, radius, dx, lo, hi, x, vol, mask)
      if (kind == PLACE_PACKED) call perturb(dim, radius, dx, lo, whole, x, vol, mask, sl)
    end if
    if (present(first)) first = lo
    if (present(n_total)) n_total = total
    if (present(n_whole)) n_whole = whole
  end subroutine place_ball

  !> The packing's first guess from the clipped lattice (see the header),
  !> for the particles numbered lo.., each of the volume of the whole body's
  !> count n_whole.  With planes (mask) a point
  !> of a plane's own lattice moves along that plane only; every point is
  !> reflected to the part's side, and one on no plane is kept its slab
  !> slab(k) dx off each plane k (reflected about that distance: the count is
  !> kept).
  subroutine perturb(dim, radius, dx, lo, n_whole, x, vol, mask, slab)
    integer, intent(in) :: dim, lo, mask
    integer(i8), intent(in) :: n_whole
    real(wp), intent(in) :: radius, dx, slab(3)
    real(wp), intent(inout) :: x(:, :), vol(:)
    real(wp) :: r, r_max, keep
    integer :: i, k, own
    r_max = radius - 0.25_wp * dx
    do i = 1, size(vol)
      own = 0
      do k = 1, dim
        if (btest(mask, k - 1) .and. on_plane(x(k, i))) own = k
      end do
      do k = 1, dim
        if (k == own) cycle
        x(k, i) = x(k, i) + PACK_NOISE * dx * (2 * hash_uniform(lo + i - 1, k) - 1)
      end do
      r = norm2(x(:, i))
      if (r > r_max) x(:, i) = x(:, i) * (r_max / r)
      do k = 1, dim
        if (.not. btest(mask, k - 1) .or. k == own) cycle
        x(k, i) = abs(x(k, i))
        keep = slab(k) * dx
        if (own == 0 .and. x(k, i) < keep) x(k, i) = 2 * keep - x(k, i)
      end do
    end do
    vol = packed_volume(dim, radius, n_whole)
  end subroutine perturb

  !> (M5) The packing's guess with planes (mask), numbers lo..hi (the count
  !> with lo > hi): first the lattice shifted slab(k) dx off each plane k
  !> (coordinate (i + 1/2 + slab(k)) dx, i >= 0, on a mirrored axis k),
  !> then for each mirrored axis k in turn the points of plane k, a lattice
  !> of spacing a_k in the other axes with a_k^(dim-1) = dx^(dim-1) /
  !> (2 slab(k)), so that at weight 1/2 they stand for slab(k) dx of depth
  !> (off the other planes: (j + 1/2) a_k, j >= 0, on a mirrored axis).
  !> Inside the ball.
  !> total: the count; n_on: of them on a plane.
  subroutine guess_with_planes(dim, radius, dx, lo, hi, x, vol, mask, slab, total, n_on)
    integer, intent(in) :: dim, lo, hi, mask
    real(wp), intent(in) :: radius, dx, slab(3)
    real(wp), intent(inout) :: x(:, :), vol(:)
    integer, intent(out), optional :: total, n_on
    integer :: np, seg, n_off
    real(wp) :: a
    np = 0
    call lattice_points(dim, radius, dx, dx, mask, 0, slab, lo, hi, x, vol, np)
    n_off = np
    do seg = 1, dim
      if (.not. btest(mask, seg - 1)) cycle
      a = dx * (0.5_wp / slab(seg))**(1 / real(dim - 1, wp))
      call lattice_points(dim, radius, a, dx, mask, seg, [0.0_wp, 0.0_wp, 0.0_wp], lo, hi, x, &
                          vol, np)
    end do
    if (present(total)) total = np
    if (present(n_on)) n_on = np - n_off
  end subroutine guess_with_planes

  subroutine guess_with_planes_count(dim, radius, dx, mask, slab, total, n_on)
    integer, intent(in) :: dim, mask
    real(wp), intent(in) :: radius, dx, slab(3)
    integer, intent(out) :: total, n_on
    real(wp) :: x(3, 0), vol(0)
    call guess_with_planes(dim, radius, dx, 1, 0, x, vol, mask, slab, total, n_on)
  end subroutine guess_with_planes_count

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

  !> Rings: particles numbered lo..hi into x(:, 1:), vol(1:).
  subroutine rings_2d(radius, dx, lo, hi, x, vol)
    real(wp), intent(in) :: radius, dx
    integer, intent(in) :: lo, hi
    real(wp), intent(inout) :: x(:, :), vol(:)
    integer :: k, j, nk, np
    real(wp) :: rk, theta, shift
    np = 0
    do k = 1, nint(radius / dx)
      nk = ring_count(k)
      if (np + nk < lo) then                  ! the whole ring comes before the share
        np = np + nk
        cycle
      end if
      rk = (k - 0.5_wp) * dx
      ! alternate rings are rotated by half a spacing, like a hexagonal packing
      shift = 0.5_wp * mod(k, 2)
      do j = 1, nk
        np = np + 1
        if (np < lo .or. np > hi) cycle
        theta = 2 * pi * (j - 1 + shift) / nk
        x(1:2, np - lo + 1) = rk * [cos(theta), sin(theta)]
        ! annulus between (k-1) dx and k dx shared by its nk particles
        vol(np - lo + 1) = pi * dx**2 * (2 * k - 1) / nk
      end do
      if (np >= hi) exit
    end do
  end subroutine rings_2d

  integer function rings_2d_count(radius, dx) result(total)
    real(wp), intent(in) :: radius, dx
    integer :: k
    total = 0
    do k = 1, nint(radius / dx)
      total = total + ring_count(k)
    end do
  end function rings_2d_count

  pure integer function ring_count(k)
    integer, intent(in) :: k
    ring_count = max(1, nint(2 * pi * (k - 0.5_wp)))
  end function ring_count

  !> Shells of radius (k - 1/2) dx, each with about 4 pi r^2/dx^2 points on a
  !> Fibonacci spiral (near-uniform on the sphere); successive shells are
  !> turned by the golden angle so their seams do not line up.
  subroutine shells_3d(radius, dx, lo, hi, x, vol)
    real(wp), intent(in) :: radius, dx
    integer, intent(in) :: lo, hi
    real(wp), intent(inout) :: x(:, :), vol(:)
    real(wp), parameter :: golden = pi * (3 - sqrt(5.0_wp))
    integer :: k, j, nk, np
    real(wp) :: rk, z, rho, phi, shell_vol
    np = 0
    do k = 1, nint(radius / dx)
      nk = shell_count(k)
      if (np + nk < lo) then
        np = np + nk
        cycle
      end if
      rk = (k - 0.5_wp) * dx
      shell_vol = 4 * pi / 3 * dx**3 * (real(k, wp)**3 - real(k - 1, wp)**3)
      do j = 0, nk - 1
        np = np + 1
        if (np < lo .or. np > hi) cycle
        z = 1 - (2 * j + 1) / real(nk, wp)
        rho = sqrt(max(0.0_wp, 1 - z**2))
        phi = golden * j + golden * k
        x(:, np - lo + 1) = rk * [rho * cos(phi), rho * sin(phi), z]
        vol(np - lo + 1) = shell_vol / nk
      end do
      if (np >= hi) exit
    end do
  end subroutine shells_3d

  integer function shells_3d_count(radius, dx) result(total)
    real(wp), intent(in) :: radius, dx
    integer :: k
    total = 0
    do k = 1, nint(radius / dx)
      total = total + shell_count(k)
    end do
  end function shells_3d_count

  pure integer function shell_count(k)
    integer, intent(in) :: k
    shell_count = max(1, nint(4 * pi * (k - 0.5_wp)**2))
  end function shell_count

  !> Lattice points ((i + 1/2) dx, ...) inside the ball, symmetric about the
  !> centre in every axis; on the mirrored axes of mask only i >= 0.
  !> (numbers lo..hi; the count with lo > hi, x and vol then untouched)
  subroutine clipped_lattice(dim, radius, dx, lo, hi, x, vol, mask, total)
    integer, intent(in) :: dim, lo, hi, mask
    real(wp), intent(in) :: radius, dx
    real(wp), intent(inout) :: x(:, :), vol(:)
    integer, intent(out), optional :: total
    integer :: np
    np = 0
    call lattice_points(dim, radius, dx, dx, mask, 0, [0.0_wp, 0.0_wp, 0.0_wp], lo, hi, x, &
                        vol, np)
    if (present(total)) total = np
  end subroutine clipped_lattice

  !> The lattice points ((i + 1/2) d, ...) inside the ball, i >= 0 on the
  !> mirrored axes of mask and there shifted by shift(k) d, coordinate 0 on
  !> axis `fixed` (none when 0), numbered on from np (updated); those
  !> numbered lo..hi go into x and vol (dx^dim each).
  subroutine lattice_points(dim, radius, d, dx, mask, fixed, shift, lo, hi, x, vol, np)
    integer, intent(in) :: dim, mask, fixed, lo, hi
    real(wp), intent(in) :: radius, d, dx, shift(3)
    real(wp), intent(inout) :: x(:, :), vol(:)
    integer, intent(inout) :: np
    integer :: m, lo3(3), hi3(3), i, j, l, k
    real(wp) :: p(3)
    m = ceiling(radius / d)
    lo3 = 0
    hi3 = 0
    do k = 1, dim
      lo3(k) = merge(0, -m, btest(mask, k - 1))
      hi3(k) = m - 1
    end do
    if (fixed > 0) then
      lo3(fixed) = 0
      hi3(fixed) = 0
    end if
    do l = lo3(3), hi3(3)
      do j = lo3(2), hi3(2)
        do i = lo3(1), hi3(1)
          p = [(i + 0.5_wp) * d, (j + 0.5_wp) * d, (l + 0.5_wp) * d]
          p(dim + 1:) = 0
          do k = 1, dim
            if (k == fixed) then
              p(k) = 0
            else if (btest(mask, k - 1)) then
              p(k) = p(k) + shift(k) * d
            end if
          end do
          if (sum(p**2) >= radius**2) cycle
          np = np + 1
          if (np >= lo .and. np <= hi) then
            x(:, np - lo + 1) = p
            vol(np - lo + 1) = dx**dim
          end if
        end do
      end do
    end do
  end subroutine lattice_points

  integer function clipped_lattice_count(dim, radius, dx, mask) result(total)
    integer, intent(in) :: dim, mask
    real(wp), intent(in) :: radius, dx
    real(wp) :: x(3, 0), vol(0)
    call clipped_lattice(dim, radius, dx, 1, 0, x, vol, mask, total)
  end function clipped_lattice_count

  !> The n_side^2 points x(3, :) (n_side = max(4, nint(sqrt(n)))) of the
  !> square lattice of spacing dx = side/n_side filling the square of that
  !> side centred at the origin (2D): point i + (j - 1) n_side at
  !> ((i - (n_side + 1)/2) dx, (j - (n_side + 1)/2) dx), so that -x and -y
  !> are lattice points exactly.
  subroutine place_square(side, n, x, dx, n_side)
    real(wp), intent(in) :: side
    integer, intent(in) :: n
    real(wp), allocatable, intent(out) :: x(:, :)
    real(wp), intent(out) :: dx
    integer, intent(out) :: n_side
    integer :: i, j
    n_side = max(4, nint(sqrt(real(n, wp))))
    dx = side / n_side
    allocate(x(3, n_side**2))
    do j = 1, n_side
      do i = 1, n_side
        x(:, i + (j - 1) * n_side) = [(i - 0.5_wp * (n_side + 1)) * dx, &
                                      (j - 0.5_wp * (n_side + 1)) * dx, 0.0_wp]
      end do
    end do
  end subroutine place_square

end module placement
