!> Domain decomposition: which rank owns which part of space.
!>
!> Three kinds share one interface, so the halo and migration code serves all:
!>  - slabs along one axis (the axis of largest extent of the particle
!>    cloud), cut where the cumulative work reaches k/P of the total;
!>  - an owner-of-cell map on a grid of cells, from a METIS partition of the
!>    graph of occupied cells (weights: the work in each cell);
!>  - a space-filling curve: the cells of that grid ordered along a Hilbert
!>    curve and cut into P contiguous pieces of equal work (rank r owns the
!>    keys splitters(r) <= key < splitters(r+1)); nothing per cell is stored.
!> owner(x) names the rank owning point x; ranks_near(x, R) lists the other
!> ranks owning some point within R of x: a particle is copied to those as
!> a halo, which is correct however thin a region is.
module domain
  use kinds, only: wp, i8
  use sorting, only: sort_index
  use parallel_env, only: parallel_env_t, par_sum, par_max, par_min, par_sum_array, &
                          par_bcast_int
  use metis_partition, only: partition_graph
  implicit none
  private
  public :: domain_t, domain_owner, domain_ranks_near, domain_balance, domain_imbalance
  public :: DECOMP_SLAB, DECOMP_METIS, DECOMP_SFC, hilbert_key

  integer, parameter :: DECOMP_SLAB = 1, DECOMP_METIS = 2, DECOMP_SFC = 3

  type :: domain_t
    integer :: kind = DECOMP_SLAB
    integer :: rank = 0, nranks = 1, dim = 2
    ! slabs: rank r owns cuts(r) <= x(axis) < cuts(r + 1)
    integer :: axis = 1
    real(wp), allocatable :: cuts(:)            !< (0:nranks), cuts(0) = -huge, cuts(P) = huge
    ! cell map: cell (i, j, k) >= 0 of size `cell` from `origin`; points
    ! outside the grid belong to the nearest cell (coordinates clamped)
    real(wp) :: origin(3) = 0, cell = 1
    integer :: nc(3) = 1
    integer, allocatable :: cell_owner(:)       !< (product(nc)), 0-based ranks
    ! space-filling curve on the same grid: keys of `bits` bits per axis
    integer :: bits = 1
    integer(i8), allocatable :: splitters(:)    !< (0:nranks), 0 and 2^(dim bits)
    integer :: n_balances = 0
  end type domain_t

contains

  !> The rank that owns point x.
  pure integer function domain_owner(d, x) result(r)
    type(domain_t), intent(in) :: d
    real(wp), intent(in) :: x(3)
    if (d%nranks == 1) then
      r = 0
    else if (d%kind == DECOMP_SLAB) then
      r = last_cut(d, x(d%axis), .false.)
    else
      r = cell_rank(d, cell_coords(d, x))
    end if
  end function domain_owner

  !> The last r in 0..P-1 with cuts(r) <= v (strict: cuts(r) < v): the
  !> number of inner cuts below v, as cuts(0) = -huge and the cuts ascend.
  pure integer function last_cut(d, v, strict) result(r)
    type(domain_t), intent(in) :: d
    real(wp), intent(in) :: v
    logical, intent(in) :: strict
    r = count_below(d%cuts(1:d%nranks - 1), v, inclusive=.not. strict)
  end function last_cut

  !> The rank that owns cell c (cell map or curve).
  pure integer function cell_rank(d, c) result(r)
    type(domain_t), intent(in) :: d
    integer, intent(in) :: c(3)
    if (d%kind == DECOMP_METIS) then
      r = d%cell_owner(cell_index(d, c))
    else
      ! the last r with splitters(r) <= key: the inner splitters below key + 1
      r = count_keys_below(d%splitters(1:d%nranks - 1), hilbert_key(c, d%bits, d%dim) + 1)
    end if
  end function cell_rank

  !> The ranks other than owner(x) that own some point within `radius` of
  !> x, in ascending order (nr of them in ranks(1:nr)).
  pure subroutine domain_ranks_near(d, x, radius, ranks, nr)
    type(domain_t), intent(in) :: d
    real(wp), intent(in) :: x(3), radius
    integer, intent(inout) :: ranks(:)
    integer, intent(out) :: nr
    integer :: me, q, c(3), c0(3), layers, i, j, k, zr, o, idx(size(ranks))
    nr = 0
    if (d%nranks == 1) return
    me = domain_owner(d, x)
    if (d%kind == DECOMP_SLAB) then
      ! the slabs q with cuts(q) < x + R and cuts(q+1) > x - R: a run of
      ! consecutive ranks, found by two binary searches (not a loop over P)
      do q = last_cut(d, x(d%axis) - radius, .false.), last_cut(d, x(d%axis) + radius, .true.)
        if (q == me) cycle
        nr = nr + 1
        ranks(nr) = q
      end do
    else
      ! a point within `radius` lies at most `layers` cells away, and
      ! clamping into the grid does not increase the distance in cells
      layers = ceiling(radius / d%cell)
      c0 = cell_coords(d, x)
      zr = merge(layers, 0, d%dim == 3)
      do k = -zr, zr
        do j = -layers, layers
          do i = -layers, layers
            c = clamp_coords(d, c0 + [i, j, k])
            o = cell_rank(d, c)
            if (o == me .or. any(ranks(1:nr) == o)) cycle
            nr = nr + 1
            ranks(nr) = o
          end do
        end do
      end do
      ! ascending rank order: the same order of messages on every run
      idx(1:nr) = [(i, i = 1, nr)]
      call sort_index(int(ranks(1:nr), i8), idx(1:nr))
      ranks(1:nr) = ranks(idx(1:nr))
    end if
  end subroutine domain_ranks_near


  pure function cell_coords(d, x) result(c)
    type(domain_t), intent(in) :: d
    real(wp), intent(in) :: x(3)
    integer :: c(3)
    real(wp) :: s(3)
    s = (x - d%origin) / d%cell
    ! clamp in real arithmetic first: far points must not overflow integers
    s = max(0.0_wp, min(s, real(d%nc - 1, wp)))
    c = int(s)
    if (d%dim == 2) c(3) = 0
  end function cell_coords

  pure function clamp_coords(d, c) result(cc)
    type(domain_t), intent(in) :: d
    integer, intent(in) :: c(3)
    integer :: cc(3)
    cc = max(0, min(c, d%nc - 1))
  end function clamp_coords

  pure integer function cell_index(d, c)
    type(domain_t), intent(in) :: d
    integer, intent(in) :: c(3)
    cell_index = 1 + c(1) + d%nc(1) * (c(2) + d%nc(2) * c(3))
  end function cell_index

  !> max over ranks of the local work divided by the mean work (1 = perfect).
  function domain_imbalance(env, work) result(imb)
    type(parallel_env_t), intent(in) :: env
    real(wp), intent(in) :: work
    real(wp) :: imb, total
    total = par_sum(env, work)
    imb = 1
    if (total > 0) imb = par_max(env, work) / (total / env%nranks)
  end function domain_imbalance

  !> Recomputes the decomposition for the owned particles x(:, 1:n) with
  !> work weights w(1:n) (1 per particle, or its number of pairs).  For
  !> cell maps, `cell` is the cell size (at least the halo radius is best).
  subroutine domain_balance(d, env, kind, dim, n, x, w, cell)
    type(domain_t), intent(inout) :: d
    type(parallel_env_t), intent(in) :: env
    integer, intent(in) :: kind, dim, n
    real(wp), intent(in) :: x(:, :), w(:), cell
    d%kind = kind
    d%dim = dim
    d%rank = env%rank
    d%nranks = env%nranks
    d%n_balances = d%n_balances + 1
    select case (kind)
    case (DECOMP_SLAB)
      call balance_slabs(d, env, dim, n, x, w)
    case (DECOMP_SFC)
      call balance_curve(d, env, dim, n, x, w, cell)
    case default
      call balance_cells(d, env, dim, n, x, w, cell)
    end select
  end subroutine domain_balance

  !> Slabs along the axis of largest global extent, each cut placed by
  !> bisection where the global work below it reaches k/P of the total.
  !> Weights are whole numbers, so the sums are exact and every rank finds
  !> the same cuts.
  subroutine balance_slabs(d, env, dim, n, x, w)
    type(domain_t), intent(inout) :: d
    type(parallel_env_t), intent(in) :: env
    integer, intent(in) :: dim, n
    real(wp), intent(in) :: x(:, :), w(:)
    real(wp) :: lo(3), hi(3), total, target
    real(wp), allocatable :: xs(:), cw(:), below(:), a(:), b(:)
    integer, allocatable :: idx(:)
    integer :: k, it, p, i
    p = env%nranks
    call global_bounds(env, n, x, lo, hi)
    d%axis = maxloc(hi(1:dim) - lo(1:dim), dim=1)
    if (allocated(d%cuts)) deallocate(d%cuts)
    allocate(d%cuts(0:p))
    d%cuts(0) = -huge(1.0_wp)
    d%cuts(p) = huge(1.0_wp)
    if (p == 1) return
    ! local coordinates sorted, with cumulative weights: work below a cut
    ! is then a binary search
    allocate(xs(n), cw(0:n), idx(n))
    xs = x(d%axis, 1:n)
    idx = [(i, i = 1, n)]
    call sort_index(xs, idx)
    xs = xs(idx)
    cw(0) = 0
    do i = 1, n
      cw(i) = cw(i - 1) + w(idx(i))
    end do
    total = par_sum(env, cw(n))
    allocate(below(p - 1), a(p - 1), b(p - 1))
    a = lo(d%axis)
    b = hi(d%axis) + 1e-12_wp * max(1.0_wp, abs(hi(d%axis)))
    ! 60 halvings take the bracket to round-off
    do it = 1, 60
      do k = 1, p - 1
        below(k) = cw(count_below(xs, 0.5_wp * (a(k) + b(k))))
      end do
      call par_sum_array(env, below)
      do k = 1, p - 1
        target = total * k / p
        if (below(k) < target) then
          a(k) = 0.5_wp * (a(k) + b(k))
        else
          b(k) = 0.5_wp * (a(k) + b(k))
        end if
      end do
    end do
    d%cuts(1:p - 1) = b
  end subroutine balance_slabs

  !> Hilbert-curve pieces: the grid of cells of size `cell` from the global
  !> lower corner, each particle's key that of its cell along the curve,
  !> and the splitters placed by bisection on the keys where the global
  !> work below reaches k/P of the total (whole-number weights: exact sums,
  !> the same splitters on every rank).  A cell is never cut.
  subroutine balance_curve(d, env, dim, n, x, w, cell)
    type(domain_t), intent(inout) :: d
    type(parallel_env_t), intent(in) :: env
    integer, intent(in) :: dim, n
    real(wp), intent(in) :: x(:, :), w(:), cell
    real(wp) :: lo(3), hi(3), total
    real(wp), allocatable :: cw(:), below(:)
    integer(i8), allocatable :: keys(:), a(:), b(:), mid(:)
    integer, allocatable :: idx(:)
    integer :: k, i, p
    p = env%nranks
    call global_bounds(env, n, x, lo, hi)
    d%cell = cell
    d%origin = lo
    d%nc = 1
    do k = 1, dim
      d%nc(k) = int((hi(k) - lo(k)) / cell) + 1
    end do
    d%bits = 1
    do while (2**d%bits < maxval(d%nc))
      d%bits = d%bits + 1
    end do
    if (dim * d%bits > 62) error stop 'balance_curve: more than 2^31 cells along an axis'
    if (allocated(d%splitters)) deallocate(d%splitters)
    allocate(d%splitters(0:p))
    d%splitters(0) = 0
    d%splitters(p) = 2_i8**(dim * d%bits)
    if (p == 1) return
    ! local keys sorted, with cumulative weights
    allocate(keys(n), idx(n), cw(0:n))
    do i = 1, n
      keys(i) = hilbert_key(cell_coords(d, x(:, i)), d%bits, dim)
    end do
    idx = [(i, i = 1, n)]
    call sort_index(keys, idx)
    keys = keys(idx)
    cw(0) = 0
    do i = 1, n
      cw(i) = cw(i - 1) + w(idx(i))
    end do
    total = par_sum(env, cw(n))
    ! invariant: work below a(k) < k total/P <= work below b(k)
    allocate(a(p - 1), b(p - 1), mid(p - 1), below(p - 1))
    a = 0
    b = d%splitters(p)
    do while (any(b - a > 1))
      mid = a + (b - a) / 2
      do k = 1, p - 1
        below(k) = cw(count_keys_below(keys, mid(k)))
      end do
      call par_sum_array(env, below)
      do k = 1, p - 1
        if (b(k) - a(k) <= 1) cycle
        if (below(k) < total * k / p) then
          a(k) = mid(k)
        else
          b(k) = mid(k)
        end if
      end do
    end do
    d%splitters(1:p - 1) = b
  end subroutine balance_curve

  !> Number of sorted keys strictly below v.
  pure integer function count_keys_below(keys, v) result(c)
    integer(i8), intent(in) :: keys(:), v
    integer :: lo, hi, mid
    lo = 0
    hi = size(keys)
    do while (lo < hi)
      mid = (lo + hi + 1) / 2
      if (keys(mid) < v) then
        lo = mid
      else
        hi = mid - 1
      end if
    end do
    c = lo
  end function count_keys_below

  !> The position of cell c (coordinates 0 .. 2^bits - 1 along each of dim
  !> axes) along the Hilbert curve of the 2^bits grid: consecutive keys are
  !> cells that share a face.  Skilling's construction (AIP Conf. Proc. 707,
  !> 381, 2004): the coordinates are turned into the "transposed" index by
  !> undoing the curve's rotations and reflections level by level and a Gray
  !> code, whose bits are then interleaved, most significant first.
  pure integer(i8) function hilbert_key(c, bits, dim) result(key)
    integer, intent(in) :: c(3), bits, dim
    integer :: xs(3), m, q, pm, i, t
    xs = c
    m = 2**(bits - 1)
    q = m
    do while (q > 1)
      pm = q - 1
      do i = 1, dim
        if (iand(xs(i), q) /= 0) then
          xs(1) = ieor(xs(1), pm)                       ! reflect
        else
          t = iand(ieor(xs(1), xs(i)), pm)              ! swap the low bits
          xs(1) = ieor(xs(1), t)
          xs(i) = ieor(xs(i), t)
        end if
      end do
      q = q / 2
    end do
    do i = 2, dim
      xs(i) = ieor(xs(i), xs(i - 1))
    end do
    t = 0
    q = m
    do while (q > 1)
      if (iand(xs(dim), q) /= 0) t = ieor(t, q - 1)
      q = q / 2
    end do
    do i = 1, dim
      xs(i) = ieor(xs(i), t)
    end do
    key = 0
    do q = bits - 1, 0, -1
      do i = 1, dim
        key = ior(ishft(key, 1), int(ibits(xs(i), q, 1), i8))
      end do
    end do
  end function hilbert_key

  !> The bounding box of the particles of all ranks.
  subroutine global_bounds(env, n, x, lo, hi)
    type(parallel_env_t), intent(in) :: env
    integer, intent(in) :: n
    real(wp), intent(in) :: x(:, :)
    real(wp), intent(out) :: lo(3), hi(3)
    integer :: k
    do k = 1, 3
      lo(k) = huge(1.0_wp); hi(k) = -huge(1.0_wp)
      if (n > 0) then
        lo(k) = minval(x(k, 1:n)); hi(k) = maxval(x(k, 1:n))
      end if
      lo(k) = par_min(env, lo(k))
      hi(k) = par_max(env, hi(k))
    end do
  end subroutine global_bounds

  !> Number of sorted values strictly below v (inclusive: at most v).
  pure integer function count_below(xs, v, inclusive) result(c)
    real(wp), intent(in) :: xs(:), v
    logical, intent(in), optional :: inclusive
    integer :: lo, hi, mid
    logical :: incl, below
    incl = .false.
    if (present(inclusive)) incl = inclusive
    lo = 0
    hi = size(xs)
    do while (lo < hi)
      mid = (lo + hi + 1) / 2
      if (incl) then
        below = xs(mid) <= v
      else
        below = xs(mid) < v
      end if
      if (below) then
        lo = mid
      else
        hi = mid - 1
      end if
    end do
    c = lo
  end function count_below


  !> Owner-of-cell map from a METIS partition of the occupied cells: the
  !> grid covers the global bounding box; every rank builds the same global
  !> work-per-cell array, rank 0 partitions its graph (vertex weight =
  !> work, an edge between cells that touch), the result is broadcast, and
  !> empty cells take the owner of the nearest occupied cell (breadth-first
  !> fill), so the map is total.
  subroutine balance_cells(d, env, dim, n, x, w, cell)
    type(domain_t), intent(inout) :: d
    type(parallel_env_t), intent(in) :: env
    integer, intent(in) :: dim, n
    real(wp), intent(in) :: x(:, :), w(:), cell
    real(wp) :: lo(3), hi(3)
    real(wp), allocatable :: work(:)
    integer, allocatable :: vid(:), part(:), xadj(:), adjncy(:), vwgt(:)
    integer :: k, i, ncell, nv, c(3), nb(3), di, dj, dk, zr, ne, ci
    call global_bounds(env, n, x, lo, hi)
    d%cell = cell
    d%origin = lo
    d%nc = 1
    do k = 1, dim
      d%nc(k) = int((hi(k) - lo(k)) / cell) + 1
    end do
    ncell = product(d%nc)
    allocate(work(ncell))
    work = 0
    do i = 1, n
      ci = cell_index(d, cell_coords(d, x(:, i)))
      work(ci) = work(ci) + w(i)
    end do
    call par_sum_array(env, work)
    if (allocated(d%cell_owner)) deallocate(d%cell_owner)
    allocate(d%cell_owner(ncell))
    d%cell_owner = -1
    ! graph of occupied cells (0-based vertex numbers, CSR)
    allocate(vid(ncell))
    vid = -1
    nv = 0
    do ci = 1, ncell
      if (work(ci) > 0) then
        vid(ci) = nv
        nv = nv + 1
      end if
    end do
    allocate(xadj(nv + 1), vwgt(nv), adjncy(nv * 3**dim), part(nv))
    zr = merge(1, 0, dim == 3)
    ne = 0
    xadj(1) = 0
    do ci = 1, ncell
      if (vid(ci) < 0) cycle
      vwgt(vid(ci) + 1) = max(1, nint(work(ci)))
      c = coords_of(d, ci)
      do dk = -zr, zr
        do dj = -1, 1
          do di = -1, 1
            if (di == 0 .and. dj == 0 .and. dk == 0) cycle
            nb = c + [di, dj, dk]
            if (any(nb < 0) .or. any(nb >= d%nc)) cycle
            if (vid(cell_index(d, nb)) < 0) cycle
            ne = ne + 1
            adjncy(ne) = vid(cell_index(d, nb))
          end do
        end do
      end do
      xadj(vid(ci) + 2) = ne
    end do
    if (env%rank == 0) call partition_graph(nv, xadj, adjncy(1:ne), vwgt, env%nranks, part)
    call par_bcast_int(env, part)
    do ci = 1, ncell
      if (vid(ci) >= 0) d%cell_owner(ci) = part(vid(ci) + 1)
    end do
    call fill_empty_cells(d)
  end subroutine balance_cells

  pure function coords_of(d, ci) result(c)
    type(domain_t), intent(in) :: d
    integer, intent(in) :: ci
    integer :: c(3), r
    r = ci - 1
    c(1) = mod(r, d%nc(1))
    r = r / d%nc(1)
    c(2) = mod(r, d%nc(2))
    c(3) = r / d%nc(2)
  end function coords_of

  !> Breadth-first fill: each empty cell takes the owner of the nearest
  !> assigned cell (face neighbours, deterministic visiting order).
  subroutine fill_empty_cells(d)
    type(domain_t), intent(inout) :: d
    integer, allocatable :: queue(:)
    integer :: head, tail, ci, c(3), nb(3), k, s, nbi
    integer, parameter :: faces(3, 6) = reshape([1, 0, 0, -1, 0, 0, 0, 1, 0, 0, -1, 0, &
                                                 0, 0, 1, 0, 0, -1], [3, 6])
    allocate(queue(size(d%cell_owner)))
    tail = 0
    do ci = 1, size(d%cell_owner)
      if (d%cell_owner(ci) >= 0) then
        tail = tail + 1
        queue(tail) = ci
      end if
    end do
    if (tail == 0) then
      d%cell_owner = 0
      return
    end if
    head = 0
    do while (head < tail)
      head = head + 1
      ci = queue(head)
      c = coords_of(d, ci)
      do s = 1, 6
        nb = c + faces(:, s)
        if (any(nb < 0) .or. any(nb >= d%nc)) cycle
        nbi = cell_index(d, nb)
        if (d%cell_owner(nbi) >= 0) cycle
        d%cell_owner(nbi) = d%cell_owner(ci)
        tail = tail + 1
        queue(tail) = nbi
      end do
    end do
    k = count(d%cell_owner < 0)
    if (k > 0) error stop 'fill_empty_cells: cells left without an owner'
  end subroutine fill_empty_cells

end module domain
