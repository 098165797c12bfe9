!> make bench-pairloop: what the standard operators' pair loop costs in three
!> structures and two precisions, on one core (doc/studies/speed.md, "What three
!> times faster would take").  The particles: a jittered cubic lattice
!> of spacing dx = 1 in a ball (212,472 particles by default; the argument
!> sets the lattice's side, 74), h/dx 1.6, Wendland C2, list radius 1.1 times
!> the support (the bench's skin of 0.2 h), then moved by up to 0.05 dx, as
!> between list rebuilds.  Variants (pairloop_kernels.inc):
!>   half list   the solver's structure (compaction, gathers, scatter);
!>   terms only  the kernel and the pair terms on compacted contiguous
!>               data, rows that fit in the L2 cache: the least any
!>               structure pays per pair;
!>   clusters    4 x 8 cluster pairs, list radius the support (a list rebuilt
!>               every step) and the support plus the skin.
!> Each in double and single precision, alternated, best of five; the sums
!> are checked against the double half list (the reference): the program
!> stops with status 1 if any structure disagrees beyond its precision.
program pairloop_bench
  use pairloop_layout, only: dp, sp, i8, LANES, REC_LEN, R_RHO, R_P, R_VOL, R_IRHO, P_DX, &
                             P_DZ, P_R2, P_U, P_W, P_RHO, P_P, P_VOL, P_IRHO, P_COLS, Q_X, Q_Z, &
                             Q_U, Q_W, Q_RHO, Q_P, Q_VOL, Q_IRHO, Q_COLS
  use pairloop_double, only: half_rows_d => half_rows, body_only_d => body_only, &
                             clusters_d => clusters
  use pairloop_single, only: half_rows_s => half_rows, body_only_s => body_only, &
                             clusters_s => clusters
  implicit none
  integer, parameter :: REPS = 5, N_VARIANTS = 8
  real(dp), parameter :: H = 1.6_dp, SUPPORT = 2 * H, RLIST = SUPPORT + 0.2_dp * H
  real(dp), parameter :: PI = 3.141592653589793_dp
  ! columns of the clusters: 2 dx square, 8 particles in a cluster
  real(dp), parameter :: COLUMN = 2.0_dp
  ! the pair terms' coefficients: delta h c0 and alpha h c0 (c0 = 10)
  real(dp), parameter :: DIFF = 0.1_dp * H * 10, VISC = 0.01_dp * H * 10
  ! the terms only: compacted rows of NROW interior particles (full rows),
  ! which fit in the L2 cache, passed over until as many pairs as a pass
  integer, parameter :: NROW = 100
  real(dp), allocatable :: x(:, :), rec(:, :), acc_ref(:, :), work_d(:, :)
  real(sp), allocatable :: xf(:, :), recf(:, :), accf(:, :), work_s(:, :)
  integer, allocatable :: start(:), lst(:), jl(:)
  real(dp), allocatable :: pd(:, :), own(:, :), t(:, :), acc_rows(:, :)
  real(sp), allocatable :: pdf(:, :), ownf(:, :), tf(:, :), acc_rowsf(:, :)
  integer, allocatable :: rs(:)
  real(dp), allocatable :: cd(:, :), acc_c(:, :)
  real(sp), allocatable :: cdf(:, :), acc_cf(:, :)
  integer, allocatable :: slot_of(:), ps_support(:), pl_support(:), ps_list(:), pl_list(:)
  real(dp) :: times(N_VARIANTS, REPS), err(N_VARIANTS), s2, cker
  character(len=40) :: names(N_VARIANTS)
  integer(i8) :: pairs_in, floor_pairs, lanes_done(N_VARIANTS)
  integer :: n, nside, longest, rep, v, passes, padded, nc8
  character(len=32) :: arg

  nside = 74
  if (command_argument_count() >= 1) then
    call get_command_argument(1, arg)
    read (arg, *) nside
  end if
  s2 = SUPPORT**2
  cker = -5 * 21 / (16 * PI * H**3) / H**2
  call make_particles(nside, x, rec, n)
  call make_half_list(n, x, rec, start, lst, longest)
  call move_particles(n, x)
  pairs_in = count_in_support(n, x, start, lst)
  write (*, '(a, i0, a, f6.1, a, f6.1, a)') 'particles ', n, ', listed partners ', &
    2.0_dp * (start(n + 1) - 1) / n, ' a particle, ', 2.0_dp * pairs_in / n, ' within the support'
  allocate(acc_ref(4, n), accf(4, n), jl(longest + 2 * LANES))
  allocate(work_d(longest + 2 * LANES, 9), work_s(longest + 2 * LANES, 9))
  xf = real(x, sp)
  recf = real(rec, sp)
  call compact_rows(NROW, pd, own, rs, floor_pairs, padded)
  passes = max(1, int(pairs_in / floor_pairs))
  pdf = real(pd, sp)
  ownf = real(own, sp)
  allocate(t(padded, 4), tf(padded, 4), acc_rows(4, NROW), acc_rowsf(4, NROW))
  call make_clusters(n, x, rec, cd, slot_of, nc8)
  call cluster_pairs(nc8, cd, slot_of, SUPPORT, ps_support, pl_support)
  call cluster_pairs(nc8, cd, slot_of, RLIST, ps_list, pl_list)
  cdf = real(cd, sp)
  allocate(acc_c(size(cd, 1), 4), acc_cf(size(cd, 1), 4))
  names = [character(len=40) :: 'half list, double', 'half list, single', &
           'terms only, double', 'terms only, single', &
           'clusters 4x8 (support), double', 'clusters 4x8 (support), single', &
           'clusters 4x8 (list radius), double', 'clusters 4x8 (list radius), single']
  lanes_done = 0
  err = 0
  do rep = 1, REPS
    do v = 1, N_VARIANTS
      times(v, rep) = run_variant(v)
    end do
  end do
  call report()
  ! the structures must compute the same sums: double precision to
  ! round-off (1.4e-15 measured at 212,472 particles), single to its own
  ! (5.5e-6 measured)
  if (maxval(err([5, 7])) > 1e-12_dp .or. maxval(err([2, 6, 8])) > 1e-4_dp) then
    write (*, '(a, 5es9.1)') 'pairloop_bench: the loops disagree with the reference: ', &
      err([2, 5, 6, 7, 8])
    error stop 1
  end if

contains

  !> One timed run of variant v; the sums checked against the reference.
  real(dp) function run_variant(v) result(seconds)
    integer, intent(in) :: v
    integer(i8) :: t0, t1, rate
    integer :: pass
    pass = 0
    call system_clock(t0, rate)
    select case (v)
    case (1)
      acc_ref = 0
      call half_rows_d(n, x, rec, start, lst, s2, 1 / H, cker, DIFF, VISC, acc_ref, size(jl), jl, &
                       work_d(:, 1), work_d(:, 2), work_d(:, 3), work_d(:, 4), work_d(:, 5), &
                       work_d(:, 6), work_d(:, 7), work_d(:, 8), work_d(:, 9))
    case (2)
      accf = 0
      call half_rows_s(n, xf, recf, start, lst, real(s2, sp), real(1 / H, sp), real(cker, sp), &
                       real(DIFF, sp), real(VISC, sp), accf, size(jl), jl, work_s(:, 1), &
                       work_s(:, 2), work_s(:, 3), work_s(:, 4), work_s(:, 5), work_s(:, 6), &
                       work_s(:, 7), work_s(:, 8), work_s(:, 9))
    case (3)
      acc_rows = 0
      do pass = 1, passes
        call body_only_d(NROW, rs, pd, own, 1 / H, cker, DIFF, VISC, t, acc_rows)
      end do
    case (4)
      acc_rowsf = 0
      do pass = 1, passes
        call body_only_s(NROW, rs, pdf, ownf, real(1 / H, sp), real(cker, sp), real(DIFF, sp), &
                         real(VISC, sp), tf, acc_rowsf)
      end do
    case (5, 7)
      acc_c = 0
      lanes_done(v) = 0
      if (v == 5) then
        call clusters_d(nc8, cd, ps_support, pl_support, 1 / H, cker, DIFF, VISC, 1e-6_dp, &
                        acc_c, lanes_done(v))
      else
        call clusters_d(nc8, cd, ps_list, pl_list, 1 / H, cker, DIFF, VISC, 1e-6_dp, acc_c, &
                        lanes_done(v))
      end if
    case (6, 8)
      acc_cf = 0
      lanes_done(v) = 0
      if (v == 6) then
        call clusters_s(nc8, cdf, ps_support, pl_support, real(1 / H, sp), real(cker, sp), &
                        real(DIFF, sp), real(VISC, sp), 1e-6_sp, acc_cf, lanes_done(v))
      else
        call clusters_s(nc8, cdf, ps_list, pl_list, real(1 / H, sp), real(cker, sp), &
                        real(DIFF, sp), real(VISC, sp), 1e-6_sp, acc_cf, lanes_done(v))
      end if
    end select
    call system_clock(t1)
    seconds = real(t1 - t0, dp) / rate
    select case (v)
    case (2)
      err(v) = max_difference(acc_ref, real(accf, dp))
    case (5, 7)
      err(v) = max_difference(acc_ref, cluster_sums(real(acc_c, dp), slot_of))
    case (6, 8)
      err(v) = max_difference(acc_ref, cluster_sums(real(acc_cf, dp), slot_of))
    end select
  end function run_variant

  !> The table: seconds per pass over all pairs (the terms only: scaled to
  !> the same number of pairs), ns per pair within the support, the speed
  !> against the double half list, the lanes a pair within the support costs
  !> (clusters), and the largest difference of the sums from the reference
  !> over the largest sum, per quantity.
  subroutine report()
    real(dp) :: best(N_VARIANTS), ns
    character(len=16) :: lanes, check
    integer :: w
    best = minval(times, dim=2)
    best(3:4) = best(3:4) * real(pairs_in, dp) / (passes * floor_pairs)
    write (*, '(a)') '', '| loop | s per pass | ns per pair | speed | lanes per pair | ' // &
      'sums against the reference |', '|---|---|---|---|---|---|'
    do w = 1, N_VARIANTS
      ns = 1e9_dp * best(w) / pairs_in
      lanes = '1'
      if (lanes_done(w) > 0) write (lanes, '(f5.2)') real(lanes_done(w), dp) / pairs_in
      ! (the terms only run on rows of their own: not compared)
      check = '-'
      if (w == 1) check = '(reference)'
      if (w /= 1 .and. w /= 3 .and. w /= 4) write (check, '(es8.1)') err(w)
      write (*, '(3a, f7.4, a, f6.2, a, f5.2, 5a)') '| ', trim(names(w)), ' | ', best(w), ' | ', &
        ns, ' | ', best(1) / best(w), ' | ', trim(adjustl(lanes)), ' | ', trim(check), ' |'
    end do
  end subroutine report

  !> A jittered cubic lattice (spacing 1, jitter 0.05) in the ball inscribed
  !> in nside^3 cells; the records: small random velocities, densities within
  !> 1 % of 1, p = 100 (rho - 1), V = 1/rho.
  subroutine make_particles(nside, x, rec, n)
    integer, intent(in) :: nside
    real(dp), allocatable, intent(out) :: x(:, :), rec(:, :)
    integer, intent(out) :: n
    real(dp), allocatable :: tmp(:, :)
    real(dp) :: r(3), radius, jit(3)
    integer :: i, j, k
    integer, allocatable :: seed(:)
    call random_seed(size=k)
    allocate(seed(k))
    seed = [(12345 + 7 * i, i = 1, k)]
    call random_seed(put=seed)
    radius = nside / 2.0_dp
    allocate(tmp(3, nside**3))
    n = 0
    do k = 1, nside
      do j = 1, nside
        do i = 1, nside
          r = [i, j, k] - 0.5_dp - radius
          if (norm2(r) < radius) then
            n = n + 1
            call random_number(jit)
            tmp(:, n) = r + 0.05_dp * (jit - 0.5_dp)
          end if
        end do
      end do
    end do
    x = tmp(:, 1:n)
    allocate(rec(REC_LEN, n))
    do i = 1, n
      call random_number(rec(1:R_RHO, i))
      rec(1:3, i) = 0.1_dp * rec(1:3, i)
      rec(R_RHO, i) = 1 + 0.01_dp * rec(R_RHO, i)
      rec(R_P, i) = 100 * (rec(R_RHO, i) - 1)
      rec(R_VOL, i) = 1 / rec(R_RHO, i)
      rec(R_IRHO, i) = 1 / rec(R_RHO, i)
      rec(REC_LEN, i) = 0
    end do
  end subroutine make_particles

  !> Sorts the particles (x, rec) by cell of side RLIST (z, y, x order) and
  !> lists, for each, the later ones within RLIST, ascending: the canonical
  !> half list.
  subroutine make_half_list(n, x, rec, start, lst, longest)
    integer, intent(in) :: n
    real(dp), intent(inout) :: x(:, :), rec(:, :)
    integer, allocatable, intent(out) :: start(:), lst(:)
    integer, intent(out) :: longest
    integer, allocatable :: cell(:), cstart(:), perm(:)
    integer :: nc, i, j, a, b, m, ix(3), cn
    real(dp) :: lo
    ! a layer of empty cells around: every cell has its 26 neighbours
    lo = minval(x) - RLIST
    nc = ceiling((maxval(x) - lo) / RLIST) + 2
    allocate(cell(n))
    do i = 1, n
      ix = floor((x(:, i) - lo) / RLIST)
      cell(i) = 1 + ix(1) + nc * (ix(2) + nc * ix(3))
    end do
    call bucket_order(cell, nc**3, cstart, perm)
    x = x(:, perm)
    rec = rec(:, perm)
    cell = cell(perm)
    allocate(start(n + 1), lst(n * 120))
    m = 0
    longest = 0
    do i = 1, n
      start(i) = m + 1
      do a = 0, 26
        cn = around(cell(i), nc, a)
        do j = max(cstart(cn), i + 1), cstart(cn + 1) - 1
          if (sum((x(:, i) - x(:, j))**2) < RLIST**2) then
            m = m + 1
            if (m > size(lst)) error stop 'pairloop_bench: list too long'
            lst(m) = j
          end if
        end do
      end do
      b = m - start(i) + 1
      call sort_ascending(lst(start(i):m))
      longest = max(longest, b)
    end do
    start(n + 1) = m + 1
  end subroutine make_half_list

  !> Moves each particle by up to 0.05 dx per axis: within the skin.
  subroutine move_particles(n, x)
    integer, intent(in) :: n
    real(dp), intent(inout) :: x(:, :)
    real(dp) :: r(3)
    integer :: i
    do i = 1, n
      call random_number(r)
      x(:, i) = x(:, i) + 0.1_dp * (r - 0.5_dp)
    end do
  end subroutine move_particles

  integer(i8) function count_in_support(n, x, start, lst) result(c)
    integer, intent(in) :: n, start(:), lst(:)
    real(dp), intent(in) :: x(:, :)
    integer :: i, q
    c = 0
    do i = 1, n
      do q = start(i), start(i + 1) - 1
        if (sum((x(:, i) - x(:, lst(q)))**2) < s2) c = c + 1
      end do
    end do
  end function count_in_support

  !> The rows of nrow interior particles, their partners within the support
  !> compacted with all the data the terms read, each row padded with zero
  !> terms to whole vectors; pairs: the real ones.
  subroutine compact_rows(nrow, pd, own, rs, pairs, padded)
    integer, intent(in) :: nrow
    real(dp), allocatable, intent(out) :: pd(:, :), own(:, :)
    integer, allocatable, intent(out) :: rs(:)
    integer(i8), intent(out) :: pairs
    integer, intent(out) :: padded
    integer :: r, i, q, j, l, first
    real(dp) :: d(3), r2
    allocate(pd((longest + LANES) * nrow, P_COLS), own(REC_LEN, nrow), rs(nrow + 1))
    pd = 0
    pd(:, P_R2) = s2
    pd(:, P_RHO) = 1
    pd(:, P_IRHO) = 1
    ! interior rows: from the middle of the particle order
    first = n / 2
    l = 0
    pairs = 0
    do r = 1, nrow
      i = first + r
      rs(r) = l + 1
      own(:, r) = rec(:, i)
      do q = start(i), start(i + 1) - 1
        j = lst(q)
        d = x(:, i) - x(:, j)
        r2 = sum(d**2)
        if (r2 >= s2) cycle
        l = l + 1
        pairs = pairs + 1
        pd(l, P_DX:P_DZ) = d
        pd(l, P_R2) = r2
        pd(l, P_U:P_W) = rec(1:3, j)
        pd(l, P_RHO) = rec(R_RHO, j)
        pd(l, P_P) = rec(R_P, j)
        pd(l, P_VOL) = rec(R_VOL, j)
        pd(l, P_IRHO) = rec(R_IRHO, j)
      end do
      l = rs(r) - 1 + ((l - rs(r) + 1 + LANES - 1) / LANES) * LANES
    end do
    rs(nrow + 1) = l + 1
    padded = l
  end subroutine compact_rows

  !> The cluster order: columns of COLUMN x COLUMN in (x, y), each column's
  !> particles by z, in clusters of 8 (the last of a column padded with
  !> particles far away, which no pair reaches).  cd(slot, Q_*); slot_of:
  !> the particle in each slot, 0 for padding.
  subroutine make_clusters(n, x, rec, cd, slot_of, nc8)
    integer, intent(in) :: n
    real(dp), intent(in) :: x(:, :), rec(:, :)
    real(dp), allocatable, intent(out) :: cd(:, :)
    integer, allocatable, intent(out) :: slot_of(:)
    integer, intent(out) :: nc8
    integer, allocatable :: col(:), cstart(:), perm(:), order(:)
    real(dp), allocatable :: z(:)
    real(dp) :: lo
    integer :: ncol, i, c, m, k, slot, nslot
    lo = minval(x) - 1
    ncol = ceiling((maxval(x) - lo) / COLUMN) + 1
    allocate(col(n))
    do i = 1, n
      col(i) = 1 + floor((x(1, i) - lo) / COLUMN) + ncol * floor((x(2, i) - lo) / COLUMN)
    end do
    call bucket_order(col, ncol**2, cstart, perm)
    nslot = 0
    do c = 1, ncol**2
      nslot = nslot + 8 * ((cstart(c + 1) - cstart(c) + 7) / 8)
    end do
    nc8 = nslot / 8
    allocate(cd(nslot, Q_COLS), slot_of(nslot))
    slot = 0
    do c = 1, ncol**2
      m = cstart(c + 1) - cstart(c)
      if (m == 0) cycle
      z = x(3, perm(cstart(c):cstart(c + 1) - 1))
      order = [(k, k = 1, m)]
      call sort_by_key(z, order)
      do k = 1, 8 * ((m + 7) / 8)
        slot = slot + 1
        if (k <= m) then
          i = perm(cstart(c) - 1 + order(k))
          slot_of(slot) = i
          cd(slot, Q_X:Q_Z) = x(:, i)
          cd(slot, Q_U:Q_W) = rec(1:3, i)
          cd(slot, Q_RHO) = rec(R_RHO, i)
          cd(slot, Q_P) = rec(R_P, i)
          cd(slot, Q_VOL) = rec(R_VOL, i)
          cd(slot, Q_IRHO) = rec(R_IRHO, i)
        else
          slot_of(slot) = 0
          cd(slot, Q_X:Q_Z) = 1.0e4_dp + 100.0_dp * slot
          cd(slot, Q_U:Q_W) = 0
          cd(slot, Q_RHO) = 1
          cd(slot, Q_P) = 0
          cd(slot, Q_VOL) = 0
          cd(slot, Q_IRHO) = 1
        end if
      end do
    end do
  end subroutine make_clusters

  !> The half list of 8-clusters: for cluster a, itself and every later one
  !> whose bounding box (of its real particles) lies within radius of a's.
  subroutine cluster_pairs(nc8, cd, slot_of, radius, pstart, plist)
    integer, intent(in) :: nc8, slot_of(:)
    real(dp), intent(in) :: cd(:, :), radius
    integer, allocatable, intent(out) :: pstart(:), plist(:)
    real(dp), allocatable :: box(:, :, :)
    integer, allocatable :: cell(:), cstart(:), order(:)
    integer :: a, b, k, m, nc, ix(3), cn, q
    real(dp) :: lo, side
    allocate(box(3, 2, nc8))
    do a = 1, nc8
      box(:, 1, a) = huge(1.0_dp)
      box(:, 2, a) = -huge(1.0_dp)
      do k = 8 * (a - 1) + 1, 8 * a
        if (slot_of(k) == 0) cycle
        box(:, 1, a) = min(box(:, 1, a), cd(k, Q_X:Q_Z))
        box(:, 2, a) = max(box(:, 2, a), cd(k, Q_X:Q_Z))
      end do
    end do
    ! clusters binned by the cell of their lower corner (side: radius plus
    ! the largest box), searched in the 27 cells around
    side = radius + maxval(box(:, 2, :) - box(:, 1, :))
    lo = minval(box(:, 1, :)) - side
    nc = ceiling((maxval(box(:, 1, :)) - lo) / side) + 2
    allocate(cell(nc8))
    do a = 1, nc8
      ix = floor((box(:, 1, a) - lo) / side)
      cell(a) = 1 + ix(1) + nc * (ix(2) + nc * ix(3))
    end do
    call bucket_order(cell, nc**3, cstart, order)
    allocate(pstart(nc8 + 1), plist(nc8 * 200))
    m = 0
    do a = 1, nc8
      pstart(a) = m + 1
      do q = 0, 26
        cn = around(cell(a), nc, q)
        do k = cstart(cn), cstart(cn + 1) - 1
          b = order(k)
          if (b < a) cycle
          if (sum(max(0.0_dp, box(:, 1, b) - box(:, 2, a), box(:, 1, a) - box(:, 2, b))**2) &
              < radius**2) then
            m = m + 1
            if (m > size(plist)) error stop 'pairloop_bench: cluster list too long'
            plist(m) = b
          end if
        end do
      end do
      call sort_ascending(plist(pstart(a):m))
    end do
    pstart(nc8 + 1) = m + 1
  end subroutine cluster_pairs

  !> Neighbour q (0..26) of cell c of an nc^3 grid numbered 1 + ix + nc (iy
  !> + nc iz): the cell at offset (mod(q, 3), mod(q/3, 3), q/9) - 1.
  pure integer function around(c, nc, q) result(cn)
    integer, intent(in) :: c, nc, q
    integer :: ix(3), dd(3)
    ix = [mod(c - 1, nc), mod((c - 1) / nc, nc), (c - 1) / nc**2]
    dd = [mod(q, 3) - 1, mod(q / 3, 3) - 1, q / 9 - 1]
    cn = 1 + (ix(1) + dd(1)) + nc * ((ix(2) + dd(2)) + nc * (ix(3) + dd(3)))
  end function around

  !> Items 1..size(key) by key (1..nkeys), in index order within a key:
  !> those of key k are order(kstart(k):kstart(k+1)-1).
  subroutine bucket_order(key, nkeys, kstart, order)
    integer, intent(in) :: key(:), nkeys
    integer, allocatable, intent(out) :: kstart(:), order(:)
    integer, allocatable :: pos(:)
    integer :: i, k
    allocate(kstart(nkeys + 1), order(size(key)))
    kstart = 0
    do i = 1, size(key)
      kstart(key(i) + 1) = kstart(key(i) + 1) + 1
    end do
    kstart(1) = 1
    do k = 2, nkeys + 1
      kstart(k) = kstart(k) + kstart(k - 1)
    end do
    pos = kstart
    do i = 1, size(key)
      order(pos(key(i))) = i
      pos(key(i)) = pos(key(i)) + 1
    end do
  end subroutine bucket_order

  !> The cluster sums back in particle order.
  function cluster_sums(acc_c, slot_of) result(s)
    real(dp), intent(in) :: acc_c(:, :)
    integer, intent(in) :: slot_of(:)
    real(dp) :: s(4, n)
    integer :: k
    s = 0
    do k = 1, size(slot_of)
      if (slot_of(k) > 0) s(:, slot_of(k)) = acc_c(k, :)
    end do
  end function cluster_sums

  !> max |a - b| / max |a| over the particles, the largest over the four sums.
  real(dp) function max_difference(a, b) result(e)
    real(dp), intent(in) :: a(:, :), b(:, :)
    integer :: q
    e = 0
    do q = 1, 4
      e = max(e, maxval(abs(a(q, :) - b(q, :))) / maxval(abs(a(q, :))))
    end do
  end function max_difference

  subroutine sort_ascending(a)
    integer, intent(inout) :: a(:)
    integer :: p, q, v
    do p = 2, size(a)
      v = a(p)
      q = p - 1
      do while (q >= 1)
        if (a(q) <= v) exit
        a(q + 1) = a(q)
        q = q - 1
      end do
      a(q + 1) = v
    end do
  end subroutine sort_ascending

  !> Insertion sort of key, carrying idx along (a column: a few dozen).
  subroutine sort_by_key(key, idx)
    real(dp), intent(inout) :: key(:)
    integer, intent(inout) :: idx(:)
    integer :: p, q, v
    real(dp) :: w
    do p = 2, size(key)
      w = key(p)
      v = idx(p)
      q = p - 1
      do while (q >= 1)
        if (key(q) <= w) exit
        key(q + 1) = key(q)
        idx(q + 1) = idx(q)
        q = q - 1
      end do
      key(q + 1) = w
      idx(q + 1) = v
    end do
  end subroutine sort_by_key

end program pairloop_bench
