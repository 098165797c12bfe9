!> Neighbour search: a cell-linked list with cells no smaller than the list
!> radius, used to sort particles by cell (memory locality) and to build a
!> half (symmetric) Verlet list with a skin, reused until particles have
!> moved far enough to invalidate it.
module neighbours
  use kinds, only: wp, i8
  implicit none
  private
  public :: neighbour_list_t, cell_sort_permutation, neighbour_build, max_displacement

  !> Half list in compressed rows, in canonical order (neighbour_build):
  !> row k belongs to particle row(k) (owned, or a halo copy when > n) and
  !> holds its partners nbr(start(k):start(k+1)-1).  Each pair within
  !> `radius` at build time with at least one owned particle appears once.
  type :: neighbour_list_t
    real(wp) :: radius = 0
    integer :: n = 0                      !< owned particles
    integer :: n_rows = 0                 !< rows: owned and halo particles
    integer(i8) :: n_pairs = 0
    integer, allocatable :: row(:)        !< (n_rows) the particle of each row
    integer(i8), allocatable :: start(:)  !< (n_rows+1)
    integer, allocatable :: nbr(:)
    real(wp), allocatable :: x_ref(:, :)  !< owned positions at build, for the skin test
  end type neighbour_list_t

  !> A grid of cubic cells with one empty layer of padding on each side, so
  !> that a stencil around any occupied cell stays inside the grid.  Cell
  !> (0-based) coordinate along an axis: 1 + int((x - lo)/size), lo the
  !> cloud's minimum (the padding is added in integers, free of round-off).
  type :: cell_grid_t
    real(wp) :: lo(3) = 0, size = 1
    integer(i8) :: shift(3) = 0          !< global coordinate of local cell 1 (global grids)
    integer :: nc(3) = 1
    integer :: n_stencil = 0
    integer, allocatable :: stencil(:)   !< linear offsets of the 3^dim cells around a cell
  end type cell_grid_t

contains

  !> A grid covering x(:, 1:ntot) with cells of at least `cell_size`; the
  !> cells grow when a scattered cloud would need too many of them.
  function make_grid(dim, ntot, x, cell_size) result(g)
    integer, intent(in) :: dim, ntot
    real(wp), intent(in) :: x(3, ntot), cell_size
    type(cell_grid_t) :: g
    real(wp) :: lo(3), hi(3)
    integer(i8) :: ncell
    integer :: a, dx, dy, dz, k, zr
    lo = 0; hi = 0
    if (ntot > 0) then
      lo = minval(x(:, 1:ntot), dim=2)
      hi = maxval(x(:, 1:ntot), dim=2)
    end if
    g%size = cell_size
    do
      g%nc = 1
      do a = 1, dim
        g%nc(a) = int((hi(a) - lo(a)) / g%size) + 3
      end do
      ncell = product(int(g%nc, i8))
      if (ncell <= max(8_i8 * ntot, 4096_i8)) exit
      g%size = g%size * 1.25_wp
    end do
    g%lo = lo
    zr = merge(1, 0, dim == 3)
    g%n_stencil = 3**dim
    allocate(g%stencil(g%n_stencil))
    k = 0
    do dz = -zr, zr
      do dy = -1, 1
        do dx = -1, 1
          k = k + 1
          g%stencil(k) = dx + g%nc(1) * (dy + g%nc(2) * dz)
        end do
      end do
    end do
  end function make_grid

  pure integer function cell_of(g, x) result(c)
    type(cell_grid_t), intent(in) :: g
    real(wp), intent(in) :: x(3)
    integer :: i(3)
    i = 1 + int(int((x - g%lo) / g%size, i8) - g%shift)
    if (g%nc(3) == 1) i(3) = 0   ! 2D: a single layer
    c = 1 + i(1) + g%nc(1) * (i(2) + g%nc(2) * i(3))
  end function cell_of

  !> Counting sort of particles 1..ntot by cell: order(cstart(c):cstart(c+1)-1)
  !> are the particles in cell c, in increasing index.
  subroutine bin_particles(g, ntot, x, cell, cstart, order)
    type(cell_grid_t), intent(in) :: g
    integer, intent(in) :: ntot
    real(wp), intent(in) :: x(3, ntot)
    integer, allocatable, intent(out) :: cell(:), cstart(:), order(:)
    integer :: i, c, ncell
    ncell = product(g%nc)
    allocate(cell(ntot), cstart(ncell + 1), order(ntot))
    cstart = 0
    do i = 1, ntot
      c = cell_of(g, x(:, i))
      cell(i) = c
      cstart(c + 1) = cstart(c + 1) + 1
    end do
    cstart(1) = 1
    do c = 1, ncell
      cstart(c + 1) = cstart(c + 1) + cstart(c)
    end do
    do i = 1, ntot      ! cstart(c) runs ahead while filling, then is restored
      c = cell(i)
      order(cstart(c)) = i
      cstart(c) = cstart(c) + 1
    end do
    do c = ncell, 1, -1
      cstart(c + 1) = cstart(c)
    end do
    cstart(1) = 1
  end subroutine bin_particles

  !> The permutation that sorts particles 1..n by cell of size cell_size
  !> (new slot k holds old particle perm(k)).
  subroutine cell_sort_permutation(dim, n, x, cell_size, perm)
    integer, intent(in) :: dim, n
    real(wp), intent(in) :: x(3, n), cell_size
    integer, intent(out) :: perm(n)
    type(cell_grid_t) :: g
    integer, allocatable :: cell(:), cstart(:), order(:)
    g = make_grid(dim, n, x, cell_size)
    call bin_particles(g, n, x, cell, cstart, order)
    perm = order
  end subroutine cell_sort_permutation

  !> Builds the half list in canonical order.  The canonical order of the
  !> particles is by cell of a grid with the given origin and cell size
  !> `radius` (the same on every rank), cells in lexicographic (z, y, x)
  !> order, then by ascending global id.  Every particle, owned or halo copy,
  !> gets a row, and the rows come in canonical order; a row holds the
  !> partners within `radius` that come later in that order (the rest of its
  !> own cell, and the cells after it in the stencil), except that a pair of
  !> two halo copies is left out.  Summing pair terms row by row, each into
  !> the row's particle and scattered to the partner, every owned particle
  !> then receives its contributions in the same order whatever the number of
  !> ranks: first from the partners before it, in canonical order, then its
  !> own row.  So the sums are bitwise independent of the decomposition.
  subroutine neighbour_build(nl, dim, n, ntot, x, id, radius, origin)
    type(neighbour_list_t), intent(inout) :: nl
    integer, intent(in) :: dim, n, ntot
    real(wp), intent(in) :: x(3, ntot), radius, origin(3)
    integer(i8), intent(in) :: id(ntot)
    type(cell_grid_t) :: g
    integer, allocatable :: cell(:), cstart(:), order(:), tmp(:)
    integer(i8) :: np, cap, row_max
    integer :: a, b, s, c, k, kk, mid
    logical :: a_owned
    real(wp) :: r2max, d(3), xa(3)
    nl%radius = radius
    nl%n = n
    nl%n_rows = ntot
    r2max = radius**2
    g = make_global_grid(dim, ntot, x, radius, origin)
    call bin_particles(g, ntot, x, cell, cstart, order)
    call sort_cells_by_id(cstart, order, id)
    mid = (g%n_stencil + 1) / 2      ! the cell itself
    if (allocated(nl%start)) deallocate(nl%start, nl%row)
    allocate(nl%start(ntot + 1), nl%row(ntot))
    cap = max(nl%n_pairs + nl%n_pairs / 4, 16_i8 * ntot, 64_i8)
    if (allocated(nl%nbr)) then
      if (size(nl%nbr, kind=i8) < cap) deallocate(nl%nbr)
    end if
    if (.not. allocated(nl%nbr)) allocate(nl%nbr(cap))
    np = 0
    do kk = 1, ntot
      a = order(kk)
      nl%row(kk) = a
      nl%start(kk) = np + 1
      a_owned = a <= n
      xa = x(:, a)
      ! room for every candidate of this row (the branchless compaction
      ! writes one slot past the last pair)
      row_max = 1
      do s = mid, g%n_stencil
        c = cell(a) + g%stencil(s)
        row_max = row_max + cstart(c + 1) - cstart(c)
      end do
      if (np + row_max > size(nl%nbr, kind=i8)) then
        allocate(tmp(max(size(nl%nbr, kind=i8) * 3 / 2, np + row_max)))
        tmp(1:np) = nl%nbr(1:np)
        call move_alloc(tmp, nl%nbr)
      end if
      ! the rest of its own cell (after it in id order), then the cells
      ! after it; branchless, as the in-range test is too random to predict
      c = cell(a)
      do k = kk + 1, cstart(c + 1) - 1
        b = order(k)
        d = xa - x(:, b)
        nl%nbr(np + 1) = b
        np = np + merge(1, 0, d(1)**2 + d(2)**2 + d(3)**2 < r2max .and. (a_owned .or. b <= n))
      end do
      do s = mid + 1, g%n_stencil
        c = cell(a) + g%stencil(s)
        do k = cstart(c), cstart(c + 1) - 1
          b = order(k)
          d = xa - x(:, b)
          nl%nbr(np + 1) = b
          np = np + merge(1, 0, d(1)**2 + d(2)**2 + d(3)**2 < r2max .and. (a_owned .or. b <= n))
        end do
      end do
    end do
    nl%start(ntot + 1) = np + 1
    nl%n_pairs = np
    if (allocated(nl%x_ref)) then
      if (size(nl%x_ref, 2) < n) deallocate(nl%x_ref)
    end if
    if (.not. allocated(nl%x_ref)) allocate(nl%x_ref(3, max(n, 1)))
    nl%x_ref(:, 1:n) = x(:, 1:n)
  end subroutine neighbour_build

  !> A grid of cells of size `size` aligned on `origin` (shared by all ranks:
  !> a particle's cell coordinates floor((x - origin)/size) are then the
  !> same wherever it is held), covering this rank's particles with a layer
  !> of padding.  origin must lie below every particle of every rank.
  function make_global_grid(dim, ntot, x, size, origin) result(g)
    integer, intent(in) :: dim, ntot
    real(wp), intent(in) :: x(3, ntot), size, origin(3)
    type(cell_grid_t) :: g
    integer :: a, dx, dy, dz, k, zr, i
    integer(i8) :: cmin(3), cmax(3), ci
    cmin = 0; cmax = 0
    do a = 1, dim
      if (ntot > 0) then
        cmin(a) = huge(1_i8); cmax(a) = -huge(1_i8)
        do i = 1, ntot
          ci = int((x(a, i) - origin(a)) / size, i8)
          cmin(a) = min(cmin(a), ci)
          cmax(a) = max(cmax(a), ci)
        end do
      end if
    end do
    g%size = size
    g%nc = 1
    do a = 1, dim
      g%nc(a) = int(cmax(a) - cmin(a)) + 3
    end do
    ! cell_of computes 1 + int((x - lo)/size): with lo one cell below the
    ! lowest occupied cell, that is the global cell coordinate shifted by a
    ! whole number of cells, so the padding stays exact
    g%lo = origin
    g%shift = 0
    do a = 1, dim
      g%shift(a) = cmin(a)
    end do
    if (product(int(g%nc, i8)) > max(64_i8 * ntot, 4096_i8)) &
      error stop 'make_global_grid: the particles are spread over too many cells'
    zr = merge(1, 0, dim == 3)
    g%n_stencil = 3**dim
    allocate(g%stencil(g%n_stencil))
    k = 0
    do dz = -zr, zr
      do dy = -1, 1
        do dx = -1, 1
          k = k + 1
          g%stencil(k) = dx + g%nc(1) * (dy + g%nc(2) * dz)
        end do
      end do
    end do
  end function make_global_grid

  !> Within each cell, orders the particles by ascending global id
  !> (insertion sort: cells hold tens of particles, mostly in order already).
  subroutine sort_cells_by_id(cstart, order, id)
    integer, intent(in) :: cstart(:)
    integer, intent(inout) :: order(:)
    integer(i8), intent(in) :: id(:)
    integer :: c, k, l, v
    do c = 1, size(cstart) - 1
      do k = cstart(c) + 1, cstart(c + 1) - 1
        v = order(k)
        l = k - 1
        do while (l >= cstart(c))
          if (id(order(l)) <= id(v)) exit
          order(l + 1) = order(l)
          l = l - 1
        end do
        order(l + 1) = v
      end do
    end do
  end subroutine sort_cells_by_id

  !> Largest distance an owned particle has moved since the list was built.
  function max_displacement(nl, x) result(dmax)
    type(neighbour_list_t), intent(in) :: nl
    real(wp), intent(in) :: x(:, :)
    real(wp) :: dmax
    integer :: i
    dmax = 0
    do i = 1, nl%n
      dmax = max(dmax, sum((x(:, i) - nl%x_ref(:, i))**2))
    end do
    dmax = sqrt(dmax)
  end function max_displacement

end module neighbours
