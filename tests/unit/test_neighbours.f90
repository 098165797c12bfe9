!> Neighbour lists against a brute-force O(N^2) search on random clouds, and
!> the property the canonical order exists for: a right-hand side computed
!> on a piece of the cloud (owned particles plus halo copies) equals, bit
!> for bit, the one computed on the whole cloud.
module test_neighbours
  use kinds, only: wp, i8
  use neighbours, only: neighbour_list_t, neighbour_build, cell_sort_permutation, &
                        max_displacement
  use kernels, only: kernel_init, KERNEL_WENDLAND_C2
  use fluid_rhs, only: rhs_params_t, rhs_evaluate, rhs_density_gradient, DIFF_ANTUONO, &
                       VISC_DELTA
  use testing, only: run_test, assert_equal, assert_true
  implicit none
  private
  public :: suite_neighbours

contains

  subroutine suite_neighbours()
    call run_test('neighbours', 'half_list_equals_brute_force_2d', brute_force_2d)
    call run_test('neighbours', 'half_list_equals_brute_force_3d', brute_force_3d)
    call run_test('neighbours', 'scattered_cloud_3d', scattered_3d)
    call run_test('neighbours', 'rows_in_canonical_order', canonical_rows)
    call run_test('neighbours', 'piece_of_cloud_gives_bitwise_same_rhs', bitwise_pieces)
    call run_test('neighbours', 'cell_sort_is_a_permutation', sort_permutation)
    call run_test('neighbours', 'displacement_since_build', displacement)
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
  subroutine check_against_brute_force(dim, n, ntot, x, r, label)
    integer, intent(in) :: dim, n, ntot
    real(wp), intent(in) :: x(3, ntot), r
    character(len=*), intent(in) :: label
    type(neighbour_list_t) :: nl
    integer, allocatable :: seen(:, :), rows(:)
    integer :: i, j, nbrute, nmissing, nextra, kk
    integer(i8) :: k
    call neighbour_build(nl, dim, n, ntot, x, scrambled_ids(ntot), r, minval(x, dim=2))
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

  !> A dense cluster plus a few particles several cluster sizes away (the
  !> grid is dense: spreads beyond 64 cells per particle stop the run).
  subroutine scattered_3d()
    real(wp), allocatable :: x(:, :)
    call random_cloud(3, 2000, 1.0_wp, 13, x)
    x(:, 1995:2000) = x(:, 1995:2000) * 4
    call check_against_brute_force(3, 2000, 2000, x, 0.12_wp, 'scattered')
  end subroutine scattered_3d

  !> Rows come in (cell, id) order and each row's partners come after the
  !> row's particle in that order.
  subroutine canonical_rows()
    real(wp), allocatable :: x(:, :)
    integer(i8), allocatable :: id(:)
    type(neighbour_list_t) :: nl
    real(wp) :: r, lo(3)
    integer :: kk, i, j, bad_rows, bad_partners
    integer(i8) :: k, key_i, key_prev
    call random_cloud(3, 2000, 1.0_wp, 16, x)
    allocate(id(2000))
    id = scrambled_ids(2000)
    r = 0.13_wp
    lo = minval(x, dim=2)
    call neighbour_build(nl, 3, 1500, 2000, x, id, r, lo)
    bad_rows = 0; bad_partners = 0
    key_prev = -1
    do kk = 1, nl%n_rows
      i = nl%row(kk)
      key_i = key(x(:, i), id(i))
      if (key_i <= key_prev) bad_rows = bad_rows + 1
      key_prev = key_i
      do k = nl%start(kk), nl%start(kk + 1) - 1
        j = nl%nbr(k)
        if (key(x(:, j), id(j)) <= key_i) bad_partners = bad_partners + 1
      end do
    end do
    call assert_equal(0, bad_rows, 'rows in ascending (cell, id) order')
    call assert_equal(0, bad_partners, 'partners after their row''s particle')
  contains
    !> (cz, cy, cx, id) packed into one integer (cells < 100 per axis here)
    integer(i8) function key(p, pid)
      real(wp), intent(in) :: p(3)
      integer(i8), intent(in) :: pid
      integer(i8) :: c(3)
      c = int((p - lo) / r, i8)
      key = ((c(3) * 100 + c(2)) * 100 + c(1)) * 100000_i8 + pid
    end function key
  end subroutine canonical_rows

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

  !> Bit-for-bit equality of two real arrays.
  pure logical function same_bits(a, b)
    real(wp), intent(in) :: a(:), b(:)
    same_bits = all(transfer(a, 1_i8, size(a)) == transfer(b, 1_i8, size(b)))
  end function same_bits

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

  subroutine displacement()
    real(wp), allocatable :: x(:, :)
    type(neighbour_list_t) :: nl
    integer :: k
    call random_cloud(3, 500, 1.0_wp, 15, x)
    call neighbour_build(nl, 3, 500, 500, x, [(int(k, i8), k = 1, 500)], 0.2_wp, &
                         minval(x, dim=2))
    x(2, 17) = x(2, 17) + 0.03_wp
    x(1, 400) = x(1, 400) - 0.01_wp
    call assert_equal(0.03_wp, max_displacement(nl, x), 1e-14_wp, 'largest displacement')
  end subroutine displacement

end module test_neighbours
