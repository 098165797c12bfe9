!> Neighbour search: a cell-linked list with cells no smaller than the list
!> radius, used to sort particles by cell (memory locality) and to build a
!> half (symmetric) Verlet list with a skin, reused until particles have
!> moved far enough to invalidate it.
module neighbours
  use kinds, only: wp, i8
  implicit none
  private
  public :: neighbour_list_t, cell_sort_permutation, neighbour_build, max_displacement

  !> Half list in compressed rows: owned particle i has the partners
  !> nbr(start(i):start(i+1)-1); each pair within `radius` at build time
  !> appears exactly once, in the row of an owned particle (a partner j > n
  !> is a halo copy).
  type :: neighbour_list_t
    real(wp) :: radius = 0
    integer :: n = 0                      !< owned particles the rows cover
    integer(i8) :: n_pairs = 0
    integer(i8), allocatable :: start(:)  !< (n+1)
    integer, allocatable :: nbr(:)
    real(wp), allocatable :: x_ref(:, :)  !< owned positions at build, for the skin test
  end type neighbour_list_t

  !> A grid of cubic cells with one empty layer of padding on each side, so
  !> that a stencil around any occupied cell stays inside the grid.  Cell
  !> (0-based) coordinate along an axis: 1 + int((x - lo)/size), lo the
  !> cloud's minimum (the padding is added in integers, free of round-off).
  type :: cell_grid_t
    real(wp) :: lo(3) = 0, size = 1
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
    i = 1 + int((x - g%lo) / g%size)
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

  !> Builds the half list of all pairs (i <= n, j) closer than `radius`
  !> among the n owned and ntot - n halo particles, each pair once: from i's
  !> own cell the partners j > i, from the cells after it in the stencil
  !> (lexicographically positive offsets) every partner, and from the cells
  !> before it only halo copies (they have no row of their own).
  subroutine neighbour_build(nl, dim, n, ntot, x, radius)
    type(neighbour_list_t), intent(inout) :: nl
    integer, intent(in) :: dim, n, ntot
    real(wp), intent(in) :: x(3, ntot), radius
    type(cell_grid_t) :: g
    integer, allocatable :: cell(:), cstart(:), order(:), tmp(:)
    integer(i8) :: np, cap, row_max
    integer :: i, j, s, c, k, mid
    real(wp) :: r2max, d(3), xi(3)
    nl%radius = radius
    nl%n = n
    r2max = radius**2
    g = make_grid(dim, ntot, x, radius)
    call bin_particles(g, ntot, x, cell, cstart, order)
    mid = (g%n_stencil + 1) / 2      ! the cell itself
    if (allocated(nl%start)) deallocate(nl%start)
    allocate(nl%start(n + 1))
    cap = max(nl%n_pairs + nl%n_pairs / 4, 16_i8 * n, 64_i8)
    if (allocated(nl%nbr)) then
      if (size(nl%nbr, kind=i8) < cap) deallocate(nl%nbr)
    end if
    if (.not. allocated(nl%nbr)) allocate(nl%nbr(cap))
    np = 0
    do i = 1, n
      nl%start(i) = np + 1
      xi = x(:, i)
      ! room for every candidate of this row (the compaction below writes
      ! one slot past the last pair)
      row_max = 1
      do s = mid, g%n_stencil
        c = cell(i) + g%stencil(s)
        row_max = row_max + cstart(c + 1) - cstart(c)
      end do
      if (ntot > n) row_max = row_max + ntot - n
      if (np + row_max > size(nl%nbr, kind=i8)) then
        allocate(tmp(max(size(nl%nbr, kind=i8) * 3 / 2, np + row_max)))
        tmp(1:np) = nl%nbr(1:np)
        call move_alloc(tmp, nl%nbr)
      end if
      ! own cell: partners after i (branchless compaction, as in the
      ! right-hand side: the in-range test is too random to predict)
      c = cell(i)
      do k = cstart(c), cstart(c + 1) - 1
        j = order(k)
        d = xi - x(:, j)
        nl%nbr(np + 1) = j
        np = np + merge(1, 0, j > i .and. d(1)**2 + d(2)**2 + d(3)**2 < r2max)
      end do
      do s = mid + 1, g%n_stencil
        c = cell(i) + g%stencil(s)
        do k = cstart(c), cstart(c + 1) - 1
          j = order(k)
          d = xi - x(:, j)
          nl%nbr(np + 1) = j
          np = np + merge(1, 0, d(1)**2 + d(2)**2 + d(3)**2 < r2max)
        end do
      end do
      if (ntot > n) then
        do s = 1, mid - 1
          c = cell(i) + g%stencil(s)
          do k = cstart(c), cstart(c + 1) - 1
            j = order(k)
            if (j <= n) cycle
            d = xi - x(:, j)
            nl%nbr(np + 1) = j
            np = np + merge(1, 0, d(1)**2 + d(2)**2 + d(3)**2 < r2max)
          end do
        end do
      end if
    end do
    nl%start(n + 1) = np + 1
    nl%n_pairs = np
    if (allocated(nl%x_ref)) then
      if (size(nl%x_ref, 2) < n) deallocate(nl%x_ref)
    end if
    if (.not. allocated(nl%x_ref)) allocate(nl%x_ref(3, max(n, 1)))
    nl%x_ref(:, 1:n) = x(:, 1:n)
  end subroutine neighbour_build

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
