!> Diagnostics of the free-surface patches beyond the global sums of
!> `diagnostics` (doc/theory/ D1, D3): angular momentum, the positions of
!> all particles by global id (for symmetry checks), the topology of the
!> fluid region (components and holes).  The vorticity and the
!> free-surface indicator of the snapshots come from the solver's own list
!> (solver_flow_fields).
module flow_diagnostics
  use kinds, only: wp, i8
  use particles, only: particles_t
  use parallel_env, only: parallel_env_t, par_sum, par_sum_array
  implicit none
  private
  public :: angular_momentum, gather_by_id, symmetry_error, topology_t, fluid_topology
  public :: RASTER_CELL, FLUID_RADIUS, MIN_HOLE_AREA

  !> Rasterisation of the fluid region (fluid_topology), in units of the
  !> particle spacing dx: cell size, radius of the disc each particle
  !> covers, smallest hole counted (in dx^2).  A radius of 1.5 dx: with
  !> 1.0 dx, the strongly strained lattice of the vortical patch (rows
  !> 0.5 dx apart, 2 dx between them) showed holes of 4 dx^2 at t V0/L =
  !> 0.4 in an intact fluid; with 1.5 dx none until the free surface
  !> reconnects, and the rotating square with tensile control shows none.
  real(wp), parameter :: RASTER_CELL = 0.5_wp
  real(wp), parameter :: FLUID_RADIUS = 1.5_wp
  real(wp), parameter :: MIN_HOLE_AREA = 3.0_wp
  !> The raster never has more cells than this many per particle (a
  !> particle thrown far away would otherwise make the box huge): the cells
  !> grow instead.
  integer, parameter :: MAX_CELLS_PER_PARTICLE = 400

  !> The topology of the union of discs of radius FLUID_RADIUS dx around the
  !> particles, rasterised on cells of RASTER_CELL dx.
  type :: topology_t
    integer :: components = 0       !< connected fluid regions (8-neighbour connectivity)
    integer :: holes = 0            !< enclosed voids of at least MIN_HOLE_AREA dx^2 (4-connectivity)
    integer :: cavities = 0         !< holes of at least big_area
    real(wp) :: largest_hole = 0    !< area of the largest hole
    integer :: largest_share = 0    !< particles in the largest component, per mille
    real(wp) :: cell = 0            !< the raster cell size used
  end type topology_t

contains

  !> (D1) z-component of Sum m x x u (about the origin): conserved by the
  !> pairwise central forces of the SPH scheme.
  function angular_momentum(env, parts) result(lz)
    type(parallel_env_t), intent(in) :: env
    type(particles_t), intent(in) :: parts
    real(wp) :: lz
    integer :: n
    n = parts%n
    lz = par_sum(env, sum(parts%m(1:n) * (parts%x(1, 1:n) * parts%u(2, 1:n) &
                                          - parts%x(2, 1:n) * parts%u(1, 1:n))))
  end function angular_momentum

  !> The first `dim` components of `field` (3, n) of all particles of all
  !> ranks, by global id: out(:, id), ids 1..n_global (collective).
  subroutine gather_by_id(env, parts, field, dim, n_global, out)
    type(parallel_env_t), intent(in) :: env
    type(particles_t), intent(in) :: parts
    real(wp), intent(in) :: field(:, :)
    integer, intent(in) :: dim, n_global
    real(wp), allocatable, intent(out) :: out(:, :)
    real(wp), allocatable :: flat(:)
    integer :: i, k
    allocate(flat(dim * n_global))
    flat = 0
    do i = 1, parts%n
      k = int(parts%id(i) - 1_i8) * dim
      flat(k + 1:k + dim) = field(1:dim, i)
    end do
    call par_sum_array(env, flat)
    out = reshape(flat, [dim, n_global])
  end subroutine gather_by_id

  !> (D3) Symmetry error of a 2D particle set under the linear map S (a rotation
  !> or reflection that maps the initial lattice onto itself):
  !> particle k's partner partner(k) started at S x_k(0), so a symmetric flow
  !> keeps x_partner(k)(t) = S x_k(t).  Returns the RMS and the largest
  !> |x_partner(k) - S x_k| over the particles, divided by `scale`.
  subroutine symmetry_error(x, partner, s, scale, rms, largest)
    real(wp), intent(in) :: x(:, :)          !< (2, N) positions by id
    integer, intent(in) :: partner(:)        !< (N)
    real(wp), intent(in) :: s(2, 2), scale
    real(wp), intent(out) :: rms, largest
    real(wp) :: e2, sum2
    integer :: k
    sum2 = 0
    largest = 0
    do k = 1, size(partner)
      e2 = sum((x(:, partner(k)) - matmul(s, x(:, k)))**2)
      sum2 = sum2 + e2
      largest = max(largest, e2)
    end do
    rms = sqrt(sum2 / max(1, size(partner))) / scale
    largest = sqrt(largest) / scale
  end subroutine symmetry_error

  !> Components and holes of the fluid region of a 2D particle set x(2, N),
  !> N > 0: the union of discs of radius FLUID_RADIUS dx around the
  !> particles, rasterised on square cells of RASTER_CELL dx (a cell is
  !> fluid when its centre lies in a disc, or it holds a particle).
  !> Components use 8-neighbour connectivity, the void 4-neighbour (the
  !> dual pair that makes the counts consistent); a hole is a void region
  !> not connected to the border of the raster, counted only when its area
  !> is at least MIN_HOLE_AREA dx^2 (smaller voids are gaps between
  !> particles, below the resolution).  Discs of radius dx cover a lattice of
  !> spacing up to 1.4 dx, so a stretched but intact region shows no holes;
  !> a gap between two fluid regions closes in the raster when it is
  !> narrower than about 3 dx.  Holes of at least big_area are also counted
  !> as cavities (large enclosed voids, such as those of a reconnected free
  !> surface, rather than gaps opened between particles).
  function fluid_topology(x, dx, big_area) result(topo)
    real(wp), intent(in) :: x(:, :)
    real(wp), intent(in) :: dx, big_area
    type(topology_t) :: topo
    integer(kind=1), allocatable :: fluid(:, :)
    integer, allocatable :: label(:, :), stack(:, :), counts(:)
    real(wp) :: lo(2), hi(2), c, r, r2, pad, cx, cy
    integer :: nc(2), np, k, i, j, i0, j0, w, ncomp, nvoid, area, lab
    integer(i8) :: ncells
    np = size(x, 2)
    r = FLUID_RADIUS * dx
    c = RASTER_CELL * dx
    lo = minval(x, dim=2)
    hi = maxval(x, dim=2)
    ncells = int((hi(1) - lo(1) + 2 * r) / c + 6, i8) * int((hi(2) - lo(2) + 2 * r) / c + 6, i8)
    if (ncells > int(MAX_CELLS_PER_PARTICLE, i8) * np) then
      c = c * sqrt(real(ncells, wp) / (real(MAX_CELLS_PER_PARTICLE, wp) * np))
    end if
    topo%cell = c
    pad = r + 2 * c
    lo = lo - pad
    nc = int((hi + pad - lo) / c) + 1
    allocate(fluid(nc(1), nc(2)), label(nc(1), nc(2)))
    fluid = 0
    r2 = r**2
    w = ceiling(r / c)
    do k = 1, np
      i0 = 1 + int((x(1, k) - lo(1)) / c)
      j0 = 1 + int((x(2, k) - lo(2)) / c)
      fluid(i0, j0) = 1
      do j = max(1, j0 - w), min(nc(2), j0 + w)
        cy = lo(2) + (j - 0.5_wp) * c - x(2, k)
        do i = max(1, i0 - w), min(nc(1), i0 + w)
          cx = lo(1) + (i - 0.5_wp) * c - x(1, k)
          if (cx**2 + cy**2 <= r2) fluid(i, j) = 1
        end do
      end do
    end do

    ! label the fluid components (8-connectivity) and the void regions
    ! (4-connectivity) by flood fill with an explicit stack
    allocate(stack(2, nc(1) * nc(2)))
    label = 0
    ncomp = 0
    nvoid = 0
    do j = 1, nc(2)
      do i = 1, nc(1)
        if (label(i, j) /= 0) cycle
        if (fluid(i, j) == 1) then
          ncomp = ncomp + 1
          call fill(fluid, label, stack, i, j, ncomp, 1_1, 8, area)
        else
          nvoid = nvoid + 1
          call fill(fluid, label, stack, i, j, -nvoid, 0_1, 4, area)
        end if
      end do
    end do
    ! voids touching the border are the outside; the rest are holes
    allocate(counts(nvoid))
    counts = 0
    do j = 1, nc(2)
      do i = 1, nc(1)
        if (label(i, j) < 0) counts(-label(i, j)) = counts(-label(i, j)) + 1
      end do
    end do
    do i = 1, nc(1)
      call mark_outside(label(i, 1))
      call mark_outside(label(i, nc(2)))
    end do
    do j = 1, nc(2)
      call mark_outside(label(1, j))
      call mark_outside(label(nc(1), j))
    end do
    topo%holes = count(real(counts, wp) * c**2 >= MIN_HOLE_AREA * dx**2)
    topo%cavities = count(real(counts, wp) * c**2 >= big_area)
    topo%largest_hole = maxval(real(counts, wp), mask=counts > 0) * c**2
    if (.not. any(counts > 0)) topo%largest_hole = 0
    topo%components = ncomp
    ! the share of the particles in the largest component
    deallocate(counts)
    allocate(counts(max(ncomp, 1)))
    counts = 0
    do k = 1, np
      i0 = 1 + int((x(1, k) - lo(1)) / c)
      j0 = 1 + int((x(2, k) - lo(2)) / c)
      lab = label(i0, j0)
      counts(lab) = counts(lab) + 1
    end do
    topo%largest_share = (1000 * maxval(counts)) / np

  contains

    subroutine mark_outside(lab)
      integer, intent(in) :: lab
      if (lab < 0) counts(-lab) = 0
    end subroutine mark_outside

  end function fluid_topology

  !> Flood fill from (i1, j1) of the cells with fluid == value, giving them
  !> label `lab`; `conn` 4 or 8 neighbours; area = cells filled; stack:
  !> room for every cell.
  pure subroutine fill(fluid, label, stack, i1, j1, lab, value, conn, area)
    integer(kind=1), intent(in) :: fluid(:, :)
    integer, intent(inout) :: label(:, :), stack(:, :)
    integer, intent(in) :: i1, j1, lab, conn
    integer(kind=1), intent(in) :: value
    integer, intent(out) :: area
    integer, parameter :: di(8) = [1, -1, 0, 0, 1, 1, -1, -1]
    integer, parameter :: dj(8) = [0, 0, 1, -1, 1, -1, 1, -1]
    integer :: top, ii, jj, a, b, d, nc(2)
    nc = shape(label)
    top = 1
    stack(:, 1) = [i1, j1]
    label(i1, j1) = lab
    area = 0
    do while (top > 0)
      ii = stack(1, top)
      jj = stack(2, top)
      top = top - 1
      area = area + 1
      do d = 1, conn
        a = ii + di(d)
        b = jj + dj(d)
        if (a < 1 .or. a > nc(1) .or. b < 1 .or. b > nc(2)) cycle
        if (label(a, b) /= 0 .or. fluid(a, b) /= value) cycle
        label(a, b) = lab
        top = top + 1
        stack(:, top) = [a, b]
      end do
    end do
  end subroutine fill

end module flow_diagnostics
