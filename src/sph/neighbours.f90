!> Neighbour search: a cell-linked list with cells the size of the list
!> radius, used to sort particles by cell (memory locality) and to build a
!> half (symmetric) Verlet list with a skin, reused until particles have
!> moved far enough to invalidate it.
!>
!> The cells are sparse (cell_set_t): only the occupied ones are stored,
!> found through a hash table from integer cell coordinates and sorted in
!> lexicographic (z, y, x) order, with no bounding box.  Memory and time
!> grow with the number of particles whatever their spread: particles flung
!> far from the rest (spray, fragmenting free surfaces) cost no more than
!> the same particles close by, and no spread stops the run.
module neighbours
  use kinds, only: wp, i8
  use sorting, only: sort_index
  implicit none
  private
  public :: neighbour_list_t, cell_sort_permutation, neighbour_build, neighbour_counts

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
  end type neighbour_list_t

  !> The occupied cells of a grid of cubic cells of side `size` aligned on
  !> `origin`: the particle at x lies in the cell of integer coordinates
  !> floor((x - origin)/size) (0 along the unused axis in 2D), whatever rank
  !> holds it.  Cells are numbered 1..n_cells in lexicographic (z, y, x)
  !> order of their coordinates; cell n_cells + 1 is an empty cell that
  !> stands for every unoccupied one.
  type :: cell_set_t
    integer :: n_cells = 0
    integer(i8), allocatable :: c(:, :)   !< (3, n_cells) cell coordinates
    integer, allocatable :: cell(:)       !< (ntot) the cell of each particle
    !> (n_cells + 2) the particles of cell k are order(cstart(k):cstart(k+1)-1)
    integer, allocatable :: cstart(:)
    integer, allocatable :: order(:)      !< (ntot) by cell, by index within a cell
    !> the 3^dim cells around a cell that come after it in lexicographic
    !> order ((3^dim - 1)/2 of them), in that order; n_cells + 1 if empty
    integer :: n_after = 0
    integer, allocatable :: after(:, :)   !< (n_after, n_cells)
  end type cell_set_t

contains

  !> The permutation that sorts particles 1..n by cell of size cell_size
  !> (new slot k holds old particle perm(k)), cells in lexicographic order.
  subroutine cell_sort_permutation(dim, n, x, cell_size, perm)
    integer, intent(in) :: dim, n
    real(wp), intent(in) :: x(3, n), cell_size
    integer, intent(out) :: perm(n)
    type(cell_set_t) :: cs
    real(wp) :: lo(3)
    lo = 0
    if (n > 0) lo = minval(x, dim=2)
    call bin_cells(dim, n, x, cell_size, lo, cs)
    perm = cs%order
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
  !> The origin must be the same on every rank; nothing else is required of
  !> it (cells are only stored where particles are).
  subroutine neighbour_build(nl, dim, n, ntot, x, id, radius, origin)
    type(neighbour_list_t), intent(inout) :: nl
    integer, intent(in) :: dim, n, ntot
    real(wp), intent(in) :: x(3, ntot), radius, origin(3)
    integer(i8), intent(in) :: id(ntot)
    type(cell_set_t) :: cs
    integer, allocatable :: keep(:)
    real(wp), allocatable :: xc(:), yc(:), zc(:)
    logical, allocatable :: owned(:)
    integer(i8) :: np
    integer :: a, s, c, ca, k, kk, nr, r, lo(14), hi(14), pass
    logical :: a_owned
    real(wp) :: r2max, xa, ya, za
    nl%radius = radius
    nl%n = n
    nl%n_rows = ntot
    r2max = radius**2
    call bin_cells(dim, ntot, x, radius, origin, cs)
    ! within each cell, by ascending global id
    do c = 1, cs%n_cells
      call sort_index(id, cs%order(cs%cstart(c):cs%cstart(c + 1) - 1))
    end do
    ! positions and ownership in canonical order: a cell's candidates are
    ! then contiguous and their distances a vector loop
    allocate(xc(ntot), yc(ntot), zc(ntot), owned(ntot), keep(ntot + 1))
    do k = 1, ntot
      a = cs%order(k)
      xc(k) = x(1, a)
      yc(k) = x(2, a)
      zc(k) = x(3, a)
      owned(k) = a <= n
    end do
    if (allocated(nl%start)) deallocate(nl%start, nl%row)
    allocate(nl%start(ntot + 1), nl%row(ntot))
    ! two passes over the same candidates: count each row's pairs, then
    ! fill a list of exactly that size (one slot more: the branchless
    ! compaction writes one past the last pair).  Growing the list instead
    ! held the old and the new array at once, 2.5 times the list at a peak.
    do pass = 1, 2
      np = 0
      do kk = 1, ntot
        a = cs%order(kk)
        a_owned = owned(kk)
        xa = xc(kk)
        ya = yc(kk)
        za = zc(kk)
        ca = cs%cell(a)
        ! the candidates: the rest of its own cell (after it in id order),
        ! then the cells after it, as canonical ranges; cells numbered in a
        ! row (neighbours along x) merge into one range
        nr = 1
        lo(1) = kk + 1
        hi(1) = cs%cstart(ca + 1) - 1
        do s = 1, cs%n_after
          c = cs%after(s, ca)
          if (c > cs%n_cells) cycle
          if (cs%cstart(c) == hi(nr) + 1) then
            hi(nr) = cs%cstart(c + 1) - 1
          else
            nr = nr + 1
            lo(nr) = cs%cstart(c)
            hi(nr) = cs%cstart(c + 1) - 1
          end if
        end do
        if (pass == 2) then
          nl%row(kk) = a
          nl%start(kk) = np + 1
        end if
        do r = 1, nr
          ! in range, and not a pair of two halo copies: a vector loop
          do k = lo(r), hi(r)
            keep(k) = merge(1, 0, (xa - xc(k))**2 + (ya - yc(k))**2 + (za - zc(k))**2 &
                                  < r2max .and. (a_owned .or. owned(k)))
          end do
          if (pass == 1) then
            np = np + sum(keep(lo(r):hi(r)))
          else
            ! branchless compaction, as the test is too random to predict
            do k = lo(r), hi(r)
              nl%nbr(np + 1) = cs%order(k)
              np = np + keep(k)
            end do
          end if
        end do
      end do
      if (pass == 1) then
        if (allocated(nl%nbr)) then
          if (size(nl%nbr, kind=i8) < np + 1 .or. size(nl%nbr, kind=i8) > np + np / 8 + 64) &
            deallocate(nl%nbr)
        end if
        if (.not. allocated(nl%nbr)) allocate(nl%nbr(np + 1))
      end if
    end do
    nl%start(ntot + 1) = np + 1
    nl%n_pairs = np
  end subroutine neighbour_build

  !> Bins particles 1..ntot on the occupied cells of side `size` aligned on
  !> `origin` (cell_set_t), in O(ntot) expected time plus the sort of the
  !> cells, which are far fewer than the particles:
  !> 1. the distinct cells in order of first appearance, found through an
  !>    open-addressing hash table (linear probing, at most half full) from
  !>    coordinates to cell; consecutive particles, sorted by cell in memory,
  !>    mostly share a cell and skip the table;
  !> 2. the cells sorted lexicographically (z, y, x);
  !> 3. the particles counting-sorted by cell (by index within a cell);
  !> 4. for each cell, the stencil cells after it, looked up in the table.
  subroutine bin_cells(dim, ntot, x, size, origin, cs)
    integer, intent(in) :: dim, ntot
    real(wp), intent(in) :: x(3, ntot), size, origin(3)
    type(cell_set_t), intent(out) :: cs
    integer, allocatable :: table(:), first(:), perm(:), rank(:)
    integer(i8), allocatable :: cc(:, :)
    integer(i8) :: ci(3), c_last(3), off(3, 13)
    integer :: i, k, m, u, s, dx, dy, dz, zr, bits
    ! 1. distinct cells (cc(:, 1:m)); first(i) is particle i's among them
    bits = 10
    allocate(table(0:2**bits - 1), cc(3, 2**(bits - 1)), first(ntot))
    table = 0
    m = 0
    u = 0
    c_last = 0
    do i = 1, ntot
      ci = cell_coords(dim, x(:, i), size, origin)
      if (u == 0 .or. any(ci /= c_last)) then
        call locate(ci, .true., u)
        c_last = ci
      end if
      first(i) = u
    end do
    ! 2. cell perm(k) of first appearance is cell k in lexicographic order
    allocate(perm(m), rank(m))
    ! (the coordinates are all distinct: stable sorts by x, then y, then z)
    perm = [(k, k = 1, m)]
    do s = 1, 3
      call sort_index(cc(s, 1:m), perm)
    end do
    rank(perm) = [(k, k = 1, m)]
    cs%n_cells = m
    cs%c = cc(:, perm)
    ! 3. counting sort; cstart(k) runs ahead while filling, then is restored
    allocate(cs%cell(ntot), cs%cstart(m + 2), cs%order(ntot))
    cs%cstart = 0
    do i = 1, ntot
      k = rank(first(i))
      cs%cell(i) = k
      cs%cstart(k + 1) = cs%cstart(k + 1) + 1
    end do
    cs%cstart(1) = 1
    do k = 1, m + 1
      cs%cstart(k + 1) = cs%cstart(k + 1) + cs%cstart(k)
    end do
    do i = 1, ntot
      k = cs%cell(i)
      cs%order(cs%cstart(k)) = i
      cs%cstart(k) = cs%cstart(k) + 1
    end do
    do k = m, 1, -1
      cs%cstart(k + 1) = cs%cstart(k)
    end do
    cs%cstart(1) = 1
    ! 4. the stencil offsets after (0, 0, 0) in lexicographic (z, y, x) order
    zr = merge(1, 0, dim == 3)
    cs%n_after = (3**dim - 1) / 2
    s = 0
    do dz = 0, zr
      do dy = -1, 1
        do dx = -1, 1
          if (dz == 0 .and. (dy < 0 .or. (dy == 0 .and. dx <= 0))) cycle
          s = s + 1
          off(:, s) = [dx, dy, dz]
        end do
      end do
    end do
    allocate(cs%after(cs%n_after, m))
    do k = 1, m
      do s = 1, cs%n_after
        call locate(cs%c(:, k) + off(:, s), .false., u)
        cs%after(s, k) = m + 1
        if (u > 0) cs%after(s, k) = rank(u)
      end do
    end do

  contains

    !> u: the cell of coordinates c in cc(:, 1:m), 0 if absent; added when
    !> `insert`, and the table doubled when more than half full.
    subroutine locate(c, insert, u)
      integer(i8), intent(in) :: c(3)
      logical, intent(in) :: insert
      integer, intent(out) :: u
      integer, allocatable :: grown(:)
      integer(i8), allocatable :: cc_grown(:, :)
      integer :: h, j
      h = hash_slot(c, bits)
      do
        u = table(h)
        if (u == 0) exit
        if (all(cc(:, u) == c)) return
        h = iand(h + 1, 2**bits - 1)
      end do
      if (.not. insert) return
      m = m + 1
      if (m > ubound(cc, 2)) then
        allocate(cc_grown(3, 2 * m))
        cc_grown(:, 1:m - 1) = cc(:, 1:m - 1)
        call move_alloc(cc_grown, cc)
      end if
      cc(:, m) = c
      table(h) = m
      u = m
      if (2 * m <= 2**bits) return
      bits = bits + 1
      allocate(grown(0:2**bits - 1))
      grown = 0
      do j = 1, m
        h = hash_slot(cc(:, j), bits)
        do while (grown(h) /= 0)
          h = iand(h + 1, 2**bits - 1)
        end do
        grown(h) = j
      end do
      call move_alloc(grown, table)
    end subroutine locate

  end subroutine bin_cells

  !> Integer coordinates of the cell of side `size` aligned on `origin`
  !> holding x: floor((x - origin)/size) along the first dim axes, 0 along
  !> the others.  Bounded by 2^60 in magnitude, so that neighbouring cells
  !> (+-1) and the hash stay free of integer overflow even for absurd
  !> positions.
  pure function cell_coords(dim, x, size, origin) result(c)
    integer, intent(in) :: dim
    real(wp), intent(in) :: x(3), size, origin(3)
    integer(i8) :: c(3)
    real(wp), parameter :: BOUND = 2.0_wp**60
    integer :: a
    c = 0
    do a = 1, dim
      c(a) = floor(max(-BOUND, min(BOUND, (x(a) - origin(a)) / size)), i8)
    end do
  end function cell_coords

  !> Slot in a table of 2^bits (bits <= 31) for cell coordinates c:
  !> Fibonacci hashing modulo 2^31, h = (K . c) mod 2^31 with multipliers
  !> 2^31 times the fractional parts of the golden ratio, sqrt 2 and sqrt 3,
  !> keeping the top `bits` bits.  Coordinates are taken modulo 2^30, so
  !> every product stays below 2^61 and the sum below 2^63.
  pure integer function hash_slot(c, bits) result(h)
    integer(i8), intent(in) :: c(3)
    integer, intent(in) :: bits
    integer(i8), parameter :: K(3) = [1327217885_i8, 889516853_i8, 1572067139_i8]
    integer(i8), parameter :: MASK30 = 2_i8**30 - 1, MASK31 = 2_i8**31 - 1
    h = int(ishft(iand(sum(iand(c, MASK30) * K), MASK31), -(31 - bits)))
  end function hash_slot

  !> Neighbours of the owned particles 1..n: `listed` counts each listed
  !> pair once for each owned particle in it, `in_range` the same for the
  !> pairs closer than sqrt(s2) at positions x.  Summed over the ranks and
  !> divided by the number of particles, they are the neighbours per
  !> particle in the list and within the kernel support (a pair across two
  !> ranks is listed on both, once as owned on each).
  subroutine neighbour_counts(nl, n, x, s2, listed, in_range)
    type(neighbour_list_t), intent(in) :: nl
    integer, intent(in) :: n
    real(wp), intent(in) :: x(:, :), s2
    integer(i8), intent(out) :: listed, in_range
    integer :: kk, i, j, w
    integer(i8) :: k
    listed = 0
    in_range = 0
    do kk = 1, nl%n_rows
      i = nl%row(kk)
      do k = nl%start(kk), nl%start(kk + 1) - 1
        j = nl%nbr(k)
        w = merge(1, 0, i <= n) + merge(1, 0, j <= n)
        listed = listed + w
        if (sum((x(:, i) - x(:, j))**2) < s2) in_range = in_range + w
      end do
    end do
  end subroutine neighbour_counts

end module neighbours
