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
  use, intrinsic :: iso_fortran_env, only: int8
  use kinds, only: wp, i8
  use sorting, only: sort_index
  implicit none
  private
  public :: neighbour_list_t, cell_sort_permutation, neighbour_build, neighbour_counts, &
            neighbour_row, ROW_PAD, STREAM_PAD

  !> Half list in canonical order (neighbour_build): row k belongs to
  !> particle row(k) (owned, or a halo copy when > n) and holds its partners
  !> in the list's order (neighbour_row).  Each pair within `radius` at build
  !> time with at least one owned particle appears once.
  !>
  !> The rows are stored compressed.  A row's candidates are a few ranges of
  !> canonical positions (the rest of its own cell and the stencil cells
  !> after it, merged where they are consecutive): the same ranges for
  !> every row of a cell (ranges, n_ranges), except that the first starts
  !> after the row itself.  Row k's bytes, from start(k), hold for each range
  !> the number of its partners, then their offsets from the range's first
  !> position, ascending, each in `width` bytes (1 while every range is
  !> shorter than 256 positions, else 2, else 4): about a byte a pair
  !> against four for a list of indices.  The partner at canonical position
  !> q is particle row(q), which is q + shift over a range whose particles
  !> sit in consecutive slots (the solver sorts its owned particles in the
  !> canonical order: cell_sort_permutation).
  integer, parameter :: NOT_CONSECUTIVE = -huge(1)
  !> neighbour_row decodes whole chunks of ROW_CHUNK offsets: its jl must
  !> hold nl%longest + ROW_PAD entries, the stream has STREAM_PAD spare bytes
  integer, parameter :: ROW_CHUNK = 8, ROW_PAD = 2 * ROW_CHUNK, STREAM_PAD = 4 * ROW_CHUNK

  type :: neighbour_list_t
    real(wp) :: radius = 0
    integer :: n = 0                      !< owned particles
    integer :: n_rows = 0                 !< rows: owned and halo particles
    integer(i8) :: n_pairs = 0
    integer :: longest = 0                !< the most partners in a row
    integer :: width = 1                  !< bytes per count and offset
    integer, allocatable :: row(:)        !< (n_rows) the particle of each row
    integer, allocatable :: cell(:)       !< (n_rows) the cell of each row
    integer, allocatable :: n_ranges(:)   !< (n_cells) ranges of a cell's rows
    !> (3, max ranges, n_cells) first and last canonical positions, and
    !> the shift from canonical position to slot where the range's
    !> particles sit in consecutive slots (NOT_CONSECUTIVE otherwise)
    integer, allocatable :: ranges(:, :, :)
    integer(i8), allocatable :: start(:)  !< (n_rows+1) first byte of each row
    integer(int8), allocatable :: bytes(:)
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
  !> With the list's origin and the global ids, it is the list's canonical
  !> order (neighbour_build): the owned particles of a cell then sit in
  !> consecutive slots in list order, so that most candidate ranges of the
  !> list map to consecutive slots (neighbour_row); without them the grid is
  !> aligned on the particles' lower corner, by index within a cell.
  subroutine cell_sort_permutation(dim, n, x, cell_size, perm, origin, id)
    integer, intent(in) :: dim, n
    real(wp), intent(in) :: x(3, n), cell_size
    integer, intent(out) :: perm(n)
    real(wp), intent(in), optional :: origin(3)
    integer(i8), intent(in), optional :: id(n)
    type(cell_set_t) :: cs
    real(wp) :: lo(3)
    lo = 0
    if (n > 0) lo = minval(x, dim=2)
    if (present(origin)) lo = origin
    call bin_cells(dim, n, x, cell_size, lo, cs, id)
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
  subroutine neighbour_build(nl, dim, n, ntot, x, id, radius, origin, min_width)
    type(neighbour_list_t), intent(inout) :: nl
    integer, intent(in) :: dim, n, ntot
    real(wp), intent(in) :: x(3, ntot), radius, origin(3)
    integer(i8), intent(in) :: id(ntot)
    !> at least this many bytes per count and offset (1, 2 or 4: the unit
    !> tests' way to reach the wide encodings with few particles)
    integer, intent(in), optional :: min_width
    type(cell_set_t) :: cs
    integer, allocatable :: keep(:)
    real(wp), allocatable :: xc(:), yc(:), zc(:)
    logical, allocatable :: owned(:)
    integer(i8) :: nbytes, pos
    integer :: a, ca, k, kk, nr, r, pass, lo, hi, cnt, longest
    logical :: a_owned
    real(wp) :: r2max, xa, ya, za
    nl%radius = radius
    nl%n = n
    nl%n_rows = ntot
    r2max = radius**2
    call bin_cells(dim, ntot, x, radius, origin, cs, id)
    call cell_ranges(cs, nl)
    if (present(min_width)) then
      ! the encodings are 1, 2 and 4 bytes wide
      if (min_width > nl%width) nl%width = merge(2, 4, min_width <= 2)
    end if
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
    if (allocated(nl%start)) deallocate(nl%start, nl%row, nl%cell)
    allocate(nl%start(ntot + 1), nl%row(ntot), nl%cell(ntot))
    nl%row = cs%order
    nl%cell = cs%cell(cs%order)
    call mark_consecutive(nl, cs%n_cells)
    ! two passes over the same candidates: count each row's bytes, then
    ! fill a stream of exactly that size
    nl%n_pairs = 0
    longest = 0
    do pass = 1, 2
      nbytes = 0
      do kk = 1, ntot
        a_owned = owned(kk)
        xa = xc(kk)
        ya = yc(kk)
        za = zc(kk)
        ca = nl%cell(kk)
        nl%start(kk) = nbytes + 1
        nr = nl%n_ranges(ca)
        nbytes = nbytes + nr * nl%width
        do r = 1, nr
          lo = nl%ranges(1, r, ca)
          if (r == 1) lo = kk + 1
          hi = nl%ranges(2, r, ca)
          ! in range, and not a pair of two halo copies: a vector loop
          do k = lo, hi
            keep(k) = merge(1, 0, (xa - xc(k))**2 + (ya - yc(k))**2 + (za - zc(k))**2 &
                                  < r2max .and. (a_owned .or. owned(k)))
          end do
          cnt = sum(keep(lo:hi))
          if (pass == 2) then
            pos = nl%start(kk) + (r - 1) * nl%width
            call put(pos, cnt)
            ! branchless: every candidate is written at the next free slot,
            ! which advances only when it is kept (the extra write lands on
            ! a byte the stream writes later, or on the spare bytes at the
            ! end)
            pos = nbytes + 1
            if (nl%width == 1) then
              do k = lo, hi
                nl%bytes(pos) = byte(k - lo)
                pos = pos + keep(k)
              end do
            else
              do k = lo, hi
                call put(pos, k - lo)
                pos = pos + keep(k) * nl%width
              end do
            end if
          else
            nl%n_pairs = nl%n_pairs + cnt
          end if
          nbytes = nbytes + cnt * nl%width
        end do
        if (pass == 1) longest = max(longest, int((nbytes - nl%start(kk) + 1) / nl%width) - nr)
      end do
      if (pass == 1) then
        if (allocated(nl%bytes)) then
          if (size(nl%bytes, kind=i8) < nbytes + STREAM_PAD .or. &
              size(nl%bytes, kind=i8) > nbytes + nbytes / 8 + 64) deallocate(nl%bytes)
        end if
        if (.not. allocated(nl%bytes)) allocate(nl%bytes(nbytes + STREAM_PAD))
      end if
    end do
    nl%start(ntot + 1) = nbytes + 1
    nl%longest = longest

  contains

    !> v (0 <= v < 256^width) as `width` bytes from pos, the lowest first
    subroutine put(pos, v)
      integer(i8), intent(in) :: pos
      integer, intent(in) :: v
      integer :: b
      do b = 0, nl%width - 1
        nl%bytes(pos + b) = byte(ishft(v, -8 * b))
      end do
    end subroutine put

  end subroutine neighbour_build

  !> The ranges of nl's cells whose particles sit in consecutive slots of
  !> the canonical order: their shift (ranges(3, :, :)), NOT_CONSECUTIVE
  !> for the others.
  subroutine mark_consecutive(nl, n_cells)
    type(neighbour_list_t), intent(inout) :: nl
    integer, intent(in) :: n_cells
    integer :: c, r, lo, hi
    do c = 1, n_cells
      do r = 1, nl%n_ranges(c)
        lo = nl%ranges(1, r, c)
        hi = nl%ranges(2, r, c)
        nl%ranges(3, r, c) = NOT_CONSECUTIVE
        if (all(nl%row(lo + 1:hi) == nl%row(lo:hi - 1) + 1)) nl%ranges(3, r, c) = nl%row(lo) - lo
      end do
    end do
  end subroutine mark_consecutive

  !> The lowest 8 bits of v as a (two's complement) int8.
  elemental integer(int8) function byte(v)
    integer, intent(in) :: v
    byte = int(iand(v, 255) - merge(256, 0, iand(v, 255) > 127), int8)
  end function byte

  !> The candidate ranges of the rows of each cell (neighbour_list_t): the
  !> cell itself, then the stencil cells after it, as ranges of canonical
  !> positions; cells consecutive in canonical order (neighbours along x)
  !> merge into one range.  The width of the counts and offsets: 1 byte
  !> while every range is shorter than 256 positions, else 2, else 4.
  subroutine cell_ranges(cs, nl)
    type(cell_set_t), intent(in) :: cs
    type(neighbour_list_t), intent(inout) :: nl
    integer :: ca, s, c, nr, longest
    if (allocated(nl%ranges)) deallocate(nl%ranges, nl%n_ranges)
    allocate(nl%ranges(3, 1 + cs%n_after, max(cs%n_cells, 1)), nl%n_ranges(max(cs%n_cells, 1)))
    nl%n_ranges = 0
    longest = 0
    do ca = 1, cs%n_cells
      nr = 1
      nl%ranges(1:2, 1, ca) = [cs%cstart(ca), cs%cstart(ca + 1) - 1]
      do s = 1, cs%n_after
        c = cs%after(s, ca)
        if (c > cs%n_cells) cycle
        if (cs%cstart(c) == nl%ranges(2, nr, ca) + 1) then
          nl%ranges(2, nr, ca) = cs%cstart(c + 1) - 1
        else
          nr = nr + 1
          nl%ranges(1:2, nr, ca) = [cs%cstart(c), cs%cstart(c + 1) - 1]
        end if
      end do
      nl%n_ranges(ca) = nr
      longest = max(longest, maxval(nl%ranges(2, 1:nr, ca) - nl%ranges(1, 1:nr, ca) + 1))
    end do
    nl%width = 4
    if (longest < 2**16) nl%width = 2
    if (longest < 2**8) nl%width = 1
  end subroutine cell_ranges

  !> The partners of row kk (particle nl%row(kk)) in jl(1:nn), in the
  !> list's order: ascending canonical position within each range, the
  !> ranges in stencil order.  jl must hold nl%longest + ROW_PAD entries.
  pure subroutine neighbour_row(nl, kk, jl, nn)
    type(neighbour_list_t), intent(in) :: nl
    integer, intent(in) :: kk
    integer, intent(inout) :: jl(:)
    integer, intent(out) :: nn
    integer :: ca
    ca = nl%cell(kk)
    select case (nl%width)
    case (1)
      call decode_1(nl%n_ranges(ca), nl%ranges(:, :, ca), nl%bytes(nl%start(kk):), nl%row, &
                    kk + 1, jl, nn)
    case (2)
      call decode_2(nl%n_ranges(ca), nl%ranges(:, :, ca), nl%bytes(nl%start(kk):), nl%row, &
                    kk + 1, jl, nn)
    case default
      call decode_4(nl%n_ranges(ca), nl%ranges(:, :, ca), nl%bytes(nl%start(kk):), nl%row, &
                    kk + 1, jl, nn)
    end select
  end subroutine neighbour_row

  !> neighbour_row for counts and offsets of W bytes (row_decode.inc), on
  !> plain arrays: no descriptor loads in the loops.
  pure subroutine decode_1(nr, rg, b, row, first, jl, nn)
    integer, parameter :: W = 1
    include 'row_decode.inc'
  end subroutine decode_1

  pure subroutine decode_2(nr, rg, b, row, first, jl, nn)
    integer, parameter :: W = 2
    include 'row_decode.inc'
  end subroutine decode_2

  pure subroutine decode_4(nr, rg, b, row, first, jl, nn)
    integer, parameter :: W = 4
    include 'row_decode.inc'
  end subroutine decode_4

  !> Bins particles 1..ntot on the occupied cells of side `size` aligned on
  !> `origin` (cell_set_t), in O(ntot) expected time plus the sort of the
  !> cells, which are far fewer than the particles:
  !> 1. the distinct cells in order of first appearance, found through an
  !>    open-addressing hash table (linear probing, at most half full) from
  !>    coordinates to cell; consecutive particles, sorted by cell in memory,
  !>    mostly share a cell and skip the table;
  !> 2. the cells sorted lexicographically (z, y, x);
  !> 3. the particles counting-sorted by cell (by index within a cell, or
  !>    by ascending global id when `id` is given: the canonical order);
  !> 4. for each cell, the stencil cells after it, looked up in the table.
  subroutine bin_cells(dim, ntot, x, size, origin, cs, id)
    integer, intent(in) :: dim, ntot
    real(wp), intent(in) :: x(3, ntot), size, origin(3)
    type(cell_set_t), intent(out) :: cs
    integer(i8), intent(in), optional :: id(ntot)
    integer, allocatable :: table(:), first(:), perm(:), rank(:)
    integer(i8), allocatable :: cc(:, :)
    integer(i8) :: ci(3), c_last(3), off(3, 13)
    integer :: i, k, m, u, s, bits
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
    if (present(id)) then
      do k = 1, m
        call sort_index(id, cs%order(cs%cstart(k):cs%cstart(k + 1) - 1))
      end do
    end if
    ! 4. each cell's neighbours after it in the stencil
    cs%n_after = (3**dim - 1) / 2
    off = stencil_after(dim)
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

  !> The stencil's cell offsets after (0, 0, 0) in lexicographic (z, y, x)
  !> order: the first (3^dim - 1)/2 columns.
  pure function stencil_after(dim) result(off)
    integer, intent(in) :: dim
    integer(i8) :: off(3, 13)
    integer :: s, dx, dy, dz
    off = 0
    s = 0
    do dz = 0, merge(1, 0, dim == 3)
      do dy = -1, 1
        do dx = -1, 1
          if (dz == 0 .and. (dy < 0 .or. (dy == 0 .and. dx <= 0))) cycle
          s = s + 1
          off(:, s) = [dx, dy, dz]
        end do
      end do
    end do
  end function stencil_after

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
    integer :: kk, i, j, w, l, nn
    integer, allocatable :: jl(:)
    listed = 0
    in_range = 0
    allocate(jl(nl%longest + ROW_PAD))
    do kk = 1, nl%n_rows
      i = nl%row(kk)
      call neighbour_row(nl, kk, jl, nn)
      do l = 1, nn
        j = jl(l)
        w = merge(1, 0, i <= n) + merge(1, 0, j <= n)
        listed = listed + w
        if (sum((x(:, i) - x(:, j))**2) < s2) in_range = in_range + w
      end do
    end do
  end subroutine neighbour_counts

end module neighbours
