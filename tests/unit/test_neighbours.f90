!> Neighbour lists against a brute-force O(N^2) search on random clouds, and
!> the property the canonical order exists for: a right-hand side computed
!> on a piece of the cloud (owned particles plus halo copies) equals, bit
!> for bit, the one computed on the whole cloud.
module test_neighbours
  use kinds, only: wp, i8
  use neighbours, only: neighbour_list_t, neighbour_build, cell_sort_permutation
  use kernels, only: kernel_init, KERNEL_WENDLAND_C2
  use fluid_rhs, only: rhs_params_t, rhs_evaluate, rhs_density_gradient, DIFF_ANTUONO, &
                       VISC_DELTA
  use testing, only: run_test, assert_equal, assert_true, test_comm, same_bits
  use mpi_f08, only: MPI_Comm_rank
  use, intrinsic :: iso_fortran_env, only: output_unit
  implicit none
  private
  public :: suite_neighbours

contains

  subroutine suite_neighbours()
    call run_test('neighbours', 'half_list_equals_brute_force_2d', brute_force_2d)
    call run_test('neighbours', 'half_list_equals_brute_force_3d', brute_force_3d)
    call run_test('neighbours', 'scattered_cloud_3d', scattered_3d)
    call run_test('neighbours', 'far_particles_2d', far_particles_2d)
    call run_test('neighbours', 'far_particles_3d', far_particles_3d)
    call run_test('neighbours', 'origin_inside_the_cloud', origin_inside)
    call run_test('neighbours', 'rows_in_canonical_order', canonical_rows)
    call run_test('neighbours', 'rows_in_canonical_order_far_particles', canonical_rows_far)
    call run_test('neighbours', 'piece_of_cloud_gives_bitwise_same_rhs', bitwise_pieces)
    call run_test('neighbours', 'cell_sort_is_a_permutation', sort_permutation)
    call run_test('neighbours', 'cell_sort_with_far_particles', sort_permutation_far)
    call run_test('neighbours', 'far_particles_build_time', far_build_time)
  end subroutine suite_neighbours

  !> Random cloud of ntot particles in a box of side `side`.
  subroutine random_cloud(dim, ntot, side, seed, x)
    integer, intent(in) :: dim, ntot, seed
    real(wp), intent(in) :: side
    real(wp), allocatable, intent(out) :: x(:, :)
    integer, allocatable :: s(:)
    integer :: ns
    call random_seed(size=ns)
    allocate(s(ns))
    s = seed + 37 * [(ns, ns = 1, size(s))]
    call random_seed(put=s)
    allocate(x(3, ntot))
    call random_number(x)
    x = x * side
    if (dim == 2) x(3, :) = 0
  end subroutine random_cloud

  !> Ids that are a scrambled permutation of 1..ntot (memory order must
  !> not matter).
  function scrambled_ids(ntot) result(id)
    integer, intent(in) :: ntot
    integer(i8) :: id(ntot)
    integer :: k
    do k = 1, ntot
      id(k) = int(mod(7919_i8 * k, int(ntot, i8) * 4 + 1), i8) + 1
    end do
  end function scrambled_ids

  !> Every pair with at least one owned particle (index <= n) within r
  !> appears exactly once, in either particle's row, and nothing else does;
  !> every particle has exactly one row.
  !> The grid's origin is the cloud's lower corner unless given.
  subroutine check_against_brute_force(dim, n, ntot, x, r, label, origin)
    integer, intent(in) :: dim, n, ntot
    real(wp), intent(in) :: x(3, ntot), r
    character(len=*), intent(in) :: label
    real(wp), intent(in), optional :: origin(3)
    type(neighbour_list_t) :: nl
    integer, allocatable :: seen(:, :), rows(:)
    integer :: i, j, nbrute, nmissing, nextra, kk
    integer(i8) :: k
    real(wp) :: lo(3)
    lo = minval(x, dim=2)
    if (present(origin)) lo = origin
    call neighbour_build(nl, dim, n, ntot, x, scrambled_ids(ntot), r, lo)
    allocate(seen(ntot, ntot), rows(ntot))
    seen = 0
    rows = 0
    nextra = 0
    do kk = 1, nl%n_rows
      i = nl%row(kk)
      rows(i) = rows(i) + 1
      do k = nl%start(kk), nl%start(kk + 1) - 1
        j = nl%nbr(k)
        if (j < 1 .or. j > ntot .or. j == i) then
          nextra = nextra + 1
        else
          seen(min(i, j), max(i, j)) = seen(min(i, j), max(i, j)) + 1
        end if
      end do
    end do
    call assert_true(all(rows == 1), label // ': one row per particle')
    nbrute = 0; nmissing = 0
    do i = 1, ntot
      do j = i + 1, ntot
        if (sum((x(:, i) - x(:, j))**2) < r**2 .and. min(i, j) <= n) then
          nbrute = nbrute + 1
          if (seen(i, j) == 0) nmissing = nmissing + 1
          if (seen(i, j) > 1) nextra = nextra + seen(i, j) - 1
        else if (seen(i, j) > 0) then
          nextra = nextra + 1
        end if
      end do
    end do
    call assert_true(nbrute > 10 * n / 2, label // ': the cloud has pairs to find')
    call assert_equal(nbrute, int(nl%n_pairs), label // ': pair count')
    call assert_equal(0, nmissing, label // ': pairs missing from the list')
    call assert_equal(0, nextra, label // ': pairs listed wrongly or twice')
  end subroutine check_against_brute_force

  subroutine brute_force_2d()
    real(wp), allocatable :: x(:, :)
    call random_cloud(2, 2300, 1.0_wp, 11, x)
    call check_against_brute_force(2, 2000, 2300, x, 0.06_wp, '2d')
  end subroutine brute_force_2d

  subroutine brute_force_3d()
    real(wp), allocatable :: x(:, :)
    call random_cloud(3, 3000, 1.0_wp, 12, x)
    call check_against_brute_force(3, 2500, 3000, x, 0.12_wp, '3d')
  end subroutine brute_force_3d

  !> A dense cluster plus a few particles several cluster sizes away.
  subroutine scattered_3d()
    real(wp), allocatable :: x(:, :)
    call random_cloud(3, 2000, 1.0_wp, 13, x)
    x(:, 1995:2000) = x(:, 1995:2000) * 4
    call check_against_brute_force(3, 2000, 2000, x, 0.12_wp, 'scattered')
  end subroutine scattered_3d

  !> A random cluster whose last 8 particles are flung about 10^6 cells away
  !> (cells of side r), as spray from a fragmenting free surface: a group of
  !> three within r of each other across cell boundaries far up, a pair far
  !> below the cluster along x (so that the cluster itself lies 10^6 cells
  !> from the origin), and three lone particles.
  subroutine far_cloud(dim, ntot, r, seed, x)
    integer, intent(in) :: dim, ntot, seed
    real(wp), intent(in) :: r
    real(wp), allocatable, intent(out) :: x(:, :)
    real(wp), parameter :: FAR = 1e6_wp
    real(wp) :: up(3), down(3)
    call random_cloud(dim, ntot, 1.0_wp, seed, x)
    up = (FAR + 0.9_wp) * r * [1.0_wp, 1.0_wp, 1.0_wp]
    down = FAR * r * [-1.0_wp, 0.5_wp, 0.25_wp]
    x(:, ntot - 7) = up
    x(:, ntot - 6) = up + r * [0.6_wp, 0.0_wp, 0.0_wp]
    x(:, ntot - 5) = up + r * [0.3_wp, 0.7_wp, 0.4_wp]
    x(:, ntot - 4) = down
    x(:, ntot - 3) = down + r * [0.2_wp, -0.5_wp, 0.3_wp]
    x(:, ntot - 2) = FAR * r * [0.0_wp, -1.0_wp, 1.0_wp]
    x(:, ntot - 1) = FAR * r * [0.0_wp, 2.0_wp, 0.0_wp]
    x(:, ntot) = 3 * FAR * r * [1.0_wp, 0.0_wp, 0.0_wp]
    if (dim == 2) x(3, :) = 0
  end subroutine far_cloud

  !> Pairs within r among the far particles of far_cloud: the list must find
  !> them as well (the brute-force check counts them with the others).
  integer function far_pairs(ntot, x, r) result(np)
    integer, intent(in) :: ntot
    real(wp), intent(in) :: x(3, ntot), r
    integer :: i, j
    np = 0
    do i = ntot - 7, ntot
      do j = i + 1, ntot
        if (sum((x(:, i) - x(:, j))**2) < r**2) np = np + 1
      end do
    end do
  end function far_pairs

  subroutine far_particles_2d()
    real(wp), allocatable :: x(:, :)
    call far_cloud(2, 2300, 0.06_wp, 21, x)
    call assert_equal(4, far_pairs(2300, x, 0.06_wp), 'pairs among the far particles')
    call check_against_brute_force(2, 2000, 2300, x, 0.06_wp, 'far 2d')
  end subroutine far_particles_2d

  subroutine far_particles_3d()
    real(wp), allocatable :: x(:, :)
    call far_cloud(3, 3000, 0.12_wp, 22, x)
    call assert_equal(4, far_pairs(3000, x, 0.12_wp), 'pairs among the far particles')
    call check_against_brute_force(3, 2500, 3000, x, 0.12_wp, 'far 3d')
  end subroutine far_particles_3d

  !> Cells are floor((x - origin)/size): an origin inside the cloud (cells
  !> of negative coordinates) gives the same pairs.
  subroutine origin_inside()
    real(wp), allocatable :: x(:, :)
    call random_cloud(2, 2300, 1.0_wp, 23, x)
    call check_against_brute_force(2, 2000, 2300, x, 0.06_wp, 'origin inside 2d', &
                                   [0.51_wp, 0.47_wp, 0.0_wp])
    call random_cloud(3, 3000, 1.0_wp, 24, x)
    call check_against_brute_force(3, 2500, 3000, x, 0.12_wp, 'origin inside 3d', &
                                   [0.51_wp, 0.47_wp, 0.53_wp])
  end subroutine origin_inside

  !> Rows come in (cell, id) order and each row's partners come after the
  !> row's particle in that order.
  subroutine canonical_rows()
    real(wp), allocatable :: x(:, :)
    call random_cloud(3, 2000, 1.0_wp, 16, x)
    call check_canonical(3, 1500, 2000, x, 0.13_wp, 'random 3d')
  end subroutine canonical_rows

  !> The same with particles 10^6 cells away from the cluster (and the
  !> cluster 10^6 cells from the origin).
  subroutine canonical_rows_far()
    real(wp), allocatable :: x(:, :)
    call far_cloud(3, 2000, 0.13_wp, 25, x)
    call check_canonical(3, 1500, 2000, x, 0.13_wp, 'far 3d')
    call far_cloud(2, 2000, 0.06_wp, 26, x)
    call check_canonical(2, 1500, 2000, x, 0.06_wp, 'far 2d')
  end subroutine canonical_rows_far

  !> The canonical order as the tuple (cz, cy, cx, id), cells
  !> floor((x - lo)/r) on the cloud's lower corner lo, compared
  !> lexicographically.
  subroutine check_canonical(dim, n, ntot, x, r, label)
    integer, intent(in) :: dim, n, ntot
    real(wp), intent(in) :: x(3, ntot), r
    character(len=*), intent(in) :: label
    integer(i8), allocatable :: id(:)
    type(neighbour_list_t) :: nl
    real(wp) :: lo(3)
    integer :: kk, i, j, bad_rows, bad_partners
    integer(i8) :: k, key_i(4), key_prev(4)
    allocate(id(ntot))
    id = scrambled_ids(ntot)
    lo = minval(x, dim=2)
    call neighbour_build(nl, dim, n, ntot, x, id, r, lo)
    bad_rows = 0; bad_partners = 0
    do kk = 1, nl%n_rows
      i = nl%row(kk)
      key_i = key(x(:, i), id(i))
      if (kk > 1) then
        if (.not. before(key_prev, key_i)) bad_rows = bad_rows + 1
      end if
      key_prev = key_i
      do k = nl%start(kk), nl%start(kk + 1) - 1
        j = nl%nbr(k)
        if (.not. before(key_i, key(x(:, j), id(j)))) bad_partners = bad_partners + 1
      end do
    end do
    call assert_equal(ntot, nl%n_rows, label // ': one row per particle')
    call assert_equal(0, bad_rows, label // ': rows in ascending (cell, id) order')
    call assert_equal(0, bad_partners, label // ': partners after their row''s particle')
  contains
    function key(p, pid) result(t)
      real(wp), intent(in) :: p(3)
      integer(i8), intent(in) :: pid
      integer(i8) :: t(4)
      t = [floor((p(3:1:-1) - lo(3:1:-1)) / r, i8), pid]
    end function key
    logical function before(a, b)
      integer(i8), intent(in) :: a(4), b(4)
      integer :: l
      before = .false.
      do l = 1, 4
        if (a(l) /= b(l)) then
          before = a(l) < b(l)
          return
        end if
      end do
    end function before
  end subroutine check_canonical

  !> Cut a cloud into two pieces at x = 0.5; each piece is its owned
  !> particles plus halo copies of the other piece's particles within the
  !> list radius, in a different memory order.  The density and velocity
  !> derivatives of every owned particle (delta-SPH with the renormalised
  !> gradient, whose halo values come from the whole-cloud pass as an
  !> exchange would bring them) must equal the whole cloud's bit for bit.
  subroutine bitwise_pieces()
    real(wp), allocatable :: x(:, :), u(:, :), rho(:), m(:), p(:), g(:, :), drho(:), du(:, :)
    integer(i8), allocatable :: id(:)
    type(neighbour_list_t) :: nl
    type(rhs_params_t) :: prm
    integer :: dim, ntot, piece, k, nmis
    real(wp) :: radius, lo(3)
    do dim = 2, 3
      ntot = merge(1500, 2500, dim == 2)
      call random_cloud(dim, ntot, 1.0_wp, 17 + dim, x)
      allocate(u(3, ntot), rho(ntot), m(ntot), p(ntot), g(3, ntot), drho(ntot), du(3, ntot))
      allocate(id(ntot))
      call random_number(u)
      u = u - 0.5_wp
      if (dim == 2) u(3, :) = 0
      call random_number(rho)
      rho = 1 + 0.01_wp * rho
      m = rho * (1.0_wp / ntot)
      p = 100 * (rho - 1)
      id = scrambled_ids(ntot)
      prm%dim = dim
      prm%kernel = kernel_init(KERNEL_WENDLAND_C2, dim, merge(0.03_wp, 0.07_wp, dim == 2))
      prm%viscosity = VISC_DELTA
      prm%diffusion = DIFF_ANTUONO
      radius = 1.15_wp * prm%kernel%support
      lo = minval(x, dim=2)
      ! the whole cloud
      call neighbour_build(nl, dim, ntot, ntot, x, id, radius, lo)
      call rhs_density_gradient(prm, ntot, ntot, x, rho, m, nl, g)
      call rhs_evaluate(prm, ntot, ntot, x, u, rho, m, p, g, nl, drho, du)
      nmis = 0
      do piece = 1, 2
        call compare_piece(piece, nmis)
      end do
      call assert_equal(0, nmis, 'owned particles whose derivatives differ in any bit')
      deallocate(u, rho, m, p, g, drho, du, id)
    end do
  contains
    subroutine compare_piece(piece, nmis)
      integer, intent(in) :: piece
      integer, intent(inout) :: nmis
      integer, allocatable :: sel(:)
      logical, allocatable :: own(:), halo(:)
      real(wp), allocatable :: gp(:, :), drp(:), dup(:, :)
      integer :: n_own, nt, i
      allocate(own(ntot))
      own = (x(1, :) < 0.5_wp) .eqv. (piece == 1)
      halo = .not. own .and. abs(x(1, :) - 0.5_wp) < radius
      ! owned particles first, in reverse memory order, then the halo
      sel = [pack([(i, i = ntot, 1, -1)], own(ntot:1:-1)), pack([(i, i = 1, ntot)], halo)]
      n_own = count(own)
      nt = size(sel)
      call neighbour_build(nl, dim, n_own, nt, x(:, sel), id(sel), radius, lo)
      allocate(gp(3, nt), drp(nt), dup(3, nt))
      call rhs_density_gradient(prm, n_own, nt, x(:, sel), rho(sel), m(sel), nl, gp)
      gp(:, n_own + 1:nt) = g(:, sel(n_own + 1:nt))      ! the halo exchange of G
      call rhs_evaluate(prm, n_own, nt, x(:, sel), u(:, sel), rho(sel), m(sel), p(sel), gp, &
                        nl, drp, dup)
      do k = 1, n_own
        i = sel(k)
        if (.not. (same_bits([drp(k)], [drho(i)]) .and. same_bits(dup(:, k), du(:, i)) &
                   .and. same_bits(gp(:, k), g(:, i)))) nmis = nmis + 1
      end do
    end subroutine compare_piece
  end subroutine bitwise_pieces

  subroutine sort_permutation()
    real(wp), allocatable :: x(:, :)
    integer :: perm(5000), k
    logical :: seen(5000)
    real(wp) :: jump
    call random_cloud(2, 5000, 1.0_wp, 14, x)
    call cell_sort_permutation(2, 5000, x, 0.05_wp, perm)
    seen = .false.
    do k = 1, 5000
      seen(perm(k)) = .true.
    end do
    call assert_true(all(seen), 'every particle appears once')
    ! Sorted by cell, consecutive particles are mostly in the same cell: the
    ! mean distance between successive particles drops from ~0.5 to ~0.05.
    jump = 0
    do k = 2, 5000
      jump = jump + norm2(x(:, perm(k)) - x(:, perm(k - 1)))
    end do
    call assert_true(jump / 4999 < 0.1_wp, 'sorted particles are close in memory')
  end subroutine sort_permutation

  !> Far particles neither break the sort nor spoil its locality: successive
  !> particles of the cluster stay as close as without them.
  subroutine sort_permutation_far()
    real(wp), allocatable :: x(:, :)
    integer :: perm(5000), k, near
    logical :: seen(5000)
    call far_cloud(3, 5000, 0.1_wp, 27, x)
    call cell_sort_permutation(3, 5000, x, 0.1_wp, perm)
    seen = .false.
    do k = 1, 5000
      seen(perm(k)) = .true.
    end do
    call assert_true(all(seen), 'every particle appears once')
    near = 0
    do k = 2, 5000
      if (norm2(x(:, perm(k)) - x(:, perm(k - 1))) < 0.3_wp) near = near + 1
    end do
    call assert_true(near > 4500, 'successive particles mostly within 3 cells')
  end subroutine sort_permutation_far

  !> Not asserted (timings depend on the machine's load): the build time on
  !> a cluster of 20,000 particles, alone and with 8 of them flung 10^6
  !> cells away, best of 3 each, interleaved; printed by rank 0.
  subroutine far_build_time()
    real(wp), allocatable :: x(:, :), xf(:, :)
    integer, allocatable :: perm(:)
    integer(i8), allocatable :: id(:)
    type(neighbour_list_t) :: nl
    real(wp) :: t0, t1, t_near, t_far, r
    integer :: rep, rank
    r = 0.1_wp
    call random_cloud(3, 20000, 1.0_wp, 28, x)
    call far_cloud(3, 20000, r, 28, xf)
    allocate(perm(20000))
    call cell_sort_permutation(3, 20000, x, r, perm)
    x = x(:, perm)
    call cell_sort_permutation(3, 20000, xf, r, perm)
    xf = xf(:, perm)
    allocate(id(20000))
    id = scrambled_ids(20000)
    t_near = huge(1.0_wp); t_far = huge(1.0_wp)
    do rep = 1, 3
      call cpu_time(t0)
      call neighbour_build(nl, 3, 20000, 20000, x, id, r, minval(x, dim=2))
      call cpu_time(t1)
      t_near = min(t_near, t1 - t0)
      call cpu_time(t0)
      call neighbour_build(nl, 3, 20000, 20000, xf, id, r, minval(xf, dim=2))
      call cpu_time(t1)
      t_far = min(t_far, t1 - t0)
    end do
    call MPI_Comm_rank(test_comm(), rank)
    if (rank == 0) write(output_unit, '(a, f8.4, a, f8.4, a)') &
      '  list build, 20,000 particles in 3D: ', t_near, ' s compact, ', t_far, &
      ' s with 8 at 1e6 cells'
    call assert_true(nl%n_pairs > 0, 'the list has pairs')
  end subroutine far_build_time

end module test_neighbours
