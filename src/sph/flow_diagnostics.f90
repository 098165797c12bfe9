!> Diagnostics of the free-surface patches beyond the global sums of
!> `diagnostics` (doc/theory.md D1, D3): angular momentum, the positions of
!> all particles by global id (for symmetry checks), the topology of the
!> fluid region (components and holes), the SPH vorticity and the
!> free-surface indicator.
module flow_diagnostics
  use kinds, only: wp, i8
  use particles, only: particles_t
  use kernels, only: kernel_t, kernel_f
  use sym3, only: sym_min_eigenvalue
  use fluid_rhs, only: LAMBDA_MIN
  use parallel_env, only: parallel_env_t, par_sum, par_sum_array
  implicit none
  private
  public :: angular_momentum, gather_by_id, symmetry_error, topology_t, fluid_topology, &
            vorticity_2d, free_surface_lambda
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
          call fill(i, j, ncomp, 1_1, 8, area)
        else
          nvoid = nvoid + 1
          call fill(i, j, -nvoid, 0_1, 4, area)
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

    !> Flood fill from (i1, j1) of the cells with fluid == value, giving them
    !> label `lab`; `conn` 4 or 8 neighbours; area = cells filled.
    subroutine fill(i1, j1, lab, value, conn, area)
      integer, intent(in) :: i1, j1, lab, conn
      integer(kind=1), intent(in) :: value
      integer, intent(out) :: area
      integer, parameter :: di(8) = [1, -1, 0, 0, 1, 1, -1, -1]
      integer, parameter :: dj(8) = [0, 0, 1, -1, 1, -1, 1, -1]
      integer :: top, ii, jj, a, b, d
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

    subroutine mark_outside(lab)
      integer, intent(in) :: lab
      if (lab < 0) counts(-lab) = 0
    end subroutine mark_outside

  end function fluid_topology

  !> The SPH vorticity of 2D particles, omega_i = dv/dx - du/dy from the
  !> renormalised velocity gradient (E3)
  !>   grad u_i = [Sum_j V_j (u_j - u_i) (x) grad_i W_ij] L_i^T,
  !>   L_i = M_i^-1, M_i = Sum_j V_j grad_i W_ij (x_j - x_i)^T,
  !> exact for any linear velocity field (a rigid rotation gives -2 omega on
  !> every particle, free surface included).  Where M_i is nearly singular
  !> (smallest eigenvalue below LAMBDA_MIN, isolated particles) L_i = I.
  !> Particles 1..n get a value; all of 1..ntot (owned and halo copies) serve
  !> as neighbours.  A cell list of the kernel support finds them.
  subroutine vorticity_2d(kernel, n, ntot, x, u, m, rho, omega)
    type(kernel_t), intent(in) :: kernel
    integer, intent(in) :: n, ntot
    real(wp), intent(in) :: x(:, :), u(:, :), m(:), rho(:)
    real(wp), intent(out) :: omega(n)
    integer, allocatable :: head(:), next(:)
    real(wp) :: lo(2), s, s2, xij(2), r2, f, v, g(2), du(2), gu(2, 2), mm(2, 2), det, lam, &
                inv(2, 2), a(2, 2)
    integer :: nc(2), i, j, ci, a1, b1, c_own(2)
    s = kernel%support
    s2 = s**2
    if (ntot < 1) return
    lo = minval(x(1:2, 1:ntot), dim=2)
    nc = int((maxval(x(1:2, 1:ntot), dim=2) - lo) / s) + 1
    allocate(head(nc(1) * nc(2)), next(ntot))
    head = 0
    do j = ntot, 1, -1
      ci = cell_index(x(1:2, j))
      next(j) = head(ci)
      head(ci) = j
    end do
    do i = 1, n
      gu = 0
      mm = 0
      c_own = 1 + int((x(1:2, i) - lo) / s)
      do b1 = max(1, c_own(2) - 1), min(nc(2), c_own(2) + 1)
        do a1 = max(1, c_own(1) - 1), min(nc(1), c_own(1) + 1)
          j = head(a1 + nc(1) * (b1 - 1))
          do while (j > 0)
            xij = x(1:2, i) - x(1:2, j)
            r2 = xij(1)**2 + xij(2)**2
            if (j /= i .and. r2 < s2) then
              f = kernel_f(kernel, sqrt(r2))
              v = m(j) / rho(j)
              g = f * xij                       ! grad_i W_ij
              du = u(1:2, j) - u(1:2, i)
              gu(:, 1) = gu(:, 1) + v * du * g(1)   ! gu(a, b) = Sum V du_a g_b
              gu(:, 2) = gu(:, 2) + v * du * g(2)
              mm(:, 1) = mm(:, 1) - v * g * xij(1)  ! Sum V g (x_j - x_i)^T
              mm(:, 2) = mm(:, 2) - v * g * xij(2)
            end if
            j = next(j)
          end do
        end do
      end do
      ! M is symmetric up to rounding: its (1, 2) element serves the eigenvalue
      lam = sym_min_eigenvalue(2, [mm(1, 1), mm(2, 2), 0.0_wp, mm(1, 2), 0.0_wp, 0.0_wp])
      det = mm(1, 1) * mm(2, 2) - mm(1, 2) * mm(2, 1)
      if (lam >= LAMBDA_MIN .and. det > 0) then
        inv = reshape([mm(2, 2), -mm(2, 1), -mm(1, 2), mm(1, 1)], [2, 2]) / det
        ! grad u = G L^T with G(a, b) = Sum V du_a g_b; L symmetric
        a = matmul(gu, transpose(inv))
      else
        a = gu
      end if
      omega(i) = a(2, 1) - a(1, 2)
    end do

  contains

    integer function cell_index(p)
      real(wp), intent(in) :: p(2)
      integer :: c(2)
      c = 1 + int((p - lo) / s)
      cell_index = c(1) + nc(1) * (c(2) - 1)
    end function cell_index

  end subroutine vorticity_2d

  !> (E9) The free-surface indicator of Marrone et al. (2010) for the n owned
  !> particles: lambda_i, the smallest eigenvalue of
  !>   M_i = Sum_j V_j grad_i W_ij (x_j - x_i)^T
  !> (the matrix whose inverse renormalises gradients, E3), about 1 inside
  !> the fluid, 0.5 on a flat free surface, 0 for an isolated particle;
  !> the solver treats lambda < 0.55 as free surface and 0.55 <= lambda <
  !> 0.9 as near it (fluid_rhs: LAMBDA_SURFACE, LAMBDA_NEAR).  The halo
  !> copies n+1..ntot, when present, serve as neighbours.  Its own cell
  !> search, in memory order: equal to the solver's lambda to round-off.
  subroutine free_surface_lambda(kernel, dim, n, ntot, x, m, rho, lambda)
    type(kernel_t), intent(in) :: kernel
    integer, intent(in) :: dim, n, ntot
    real(wp), intent(in) :: x(:, :), m(:), rho(:)
    real(wp), intent(out) :: lambda(n)
    integer, allocatable :: head(:), next(:)
    real(wp) :: lo(3), s, s2, xij(3), r2, f, mm(6)
    integer :: nc(3), c(3), i, j, a1, b1, c1
    s2 = kernel%support**2
    if (ntot < 1) return
    lo = 0
    lo(1:dim) = minval(x(1:dim, 1:ntot), dim=2)
    ! cells of at least the support, larger when a scattered cloud would
    ! need many more cells than particles
    s = kernel%support
    do
      nc = 1
      nc(1:dim) = int((maxval(x(1:dim, 1:ntot), dim=2) - lo(1:dim)) / s) + 1
      if (product(real(nc, wp)) <= 8.0_wp * ntot + 4096) exit
      s = 1.25_wp * s
    end do
    allocate(head(product(nc)), next(ntot))
    head = 0
    do j = ntot, 1, -1
      c = cell_of(x(:, j))
      next(j) = head(c(1) + nc(1) * (c(2) - 1 + nc(2) * (c(3) - 1)))
      head(c(1) + nc(1) * (c(2) - 1 + nc(2) * (c(3) - 1))) = j
    end do
    do i = 1, n
      mm = 0
      c = cell_of(x(:, i))
      do c1 = max(1, c(3) - 1), min(nc(3), c(3) + 1)
        do b1 = max(1, c(2) - 1), min(nc(2), c(2) + 1)
          do a1 = max(1, c(1) - 1), min(nc(1), c(1) + 1)
            j = head(a1 + nc(1) * (b1 - 1 + nc(2) * (c1 - 1)))
            do while (j > 0)
              xij = 0
              xij(1:dim) = x(1:dim, i) - x(1:dim, j)
              r2 = sum(xij**2)
              if (j /= i .and. r2 < s2) then
                f = kernel_f(kernel, sqrt(r2))
                ! V_j g (x_j - x_i)^T = -V_j F x_ij x_ij^T, as (xx, yy, zz, xy, xz, yz)
                mm = mm - m(j) / rho(j) * f * [xij(1)**2, xij(2)**2, xij(3)**2, &
                                               xij(1) * xij(2), xij(1) * xij(3), xij(2) * xij(3)]
              end if
              j = next(j)
            end do
          end do
        end do
      end do
      lambda(i) = sym_min_eigenvalue(dim, mm)
    end do

  contains

    function cell_of(p) result(cc)
      real(wp), intent(in) :: p(3)
      integer :: cc(3)
      cc = 1
      cc(1:dim) = 1 + int((p(1:dim) - lo(1:dim)) / s)
    end function cell_of

  end subroutine free_surface_lambda

end module flow_diagnostics
