!> Neighbour lists against a brute-force O(N^2) search on random clouds.
module test_neighbours
  use kinds, only: wp, i8
  use neighbours, only: neighbour_list_t, neighbour_build, cell_sort_permutation, &
                        max_displacement
  use testing, only: run_test, assert_equal, assert_true
  implicit none
  private
  public :: suite_neighbours

contains

  subroutine suite_neighbours()
    call run_test('neighbours', 'half_list_equals_brute_force_2d', brute_force_2d)
    call run_test('neighbours', 'half_list_equals_brute_force_3d', brute_force_3d)
    call run_test('neighbours', 'scattered_cloud_3d', scattered_3d)
    call run_test('neighbours', 'cell_sort_is_a_permutation', sort_permutation)
    call run_test('neighbours', 'displacement_since_build', displacement)
  end subroutine suite_neighbours

  !> Random cloud: n owned and nh halo particles in a box of side `side`.
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

  !> Every pair with at least one owned particle (index <= n) within r
  !> appears exactly once in the list, in the row of an owned particle, and
  !> nothing else does.
  subroutine check_against_brute_force(dim, n, ntot, x, r, label)
    integer, intent(in) :: dim, n, ntot
    real(wp), intent(in) :: x(3, ntot), r
    character(len=*), intent(in) :: label
    type(neighbour_list_t) :: nl
    integer, allocatable :: seen(:, :)
    integer :: i, j, nbrute, nmissing, nextra
    integer(i8) :: k
    call neighbour_build(nl, dim, n, ntot, x, r)
    ! count[i, j] over the list, symmetric, against brute force
    allocate(seen(ntot, ntot))
    seen = 0
    nextra = 0
    do i = 1, n
      do k = nl%start(i), nl%start(i + 1) - 1
        j = nl%nbr(k)
        if (j < 1 .or. j > ntot .or. j == i) then
          nextra = nextra + 1
        else
          seen(min(i, j), max(i, j)) = seen(min(i, j), max(i, j)) + 1
        end if
      end do
    end do
    nbrute = 0; nmissing = 0
    do i = 1, n
      do j = i + 1, ntot
        if (sum((x(:, i) - x(:, j))**2) < r**2) then
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

  !> A dense cluster plus a few far-away particles: the grid must coarsen
  !> instead of allocating a huge number of empty cells, and stay correct.
  subroutine scattered_3d()
    real(wp), allocatable :: x(:, :)
    call random_cloud(3, 2000, 1.0_wp, 13, x)
    x(:, 1995:2000) = x(:, 1995:2000) * 1e4_wp
    call check_against_brute_force(3, 2000, 2000, x, 0.12_wp, 'scattered')
  end subroutine scattered_3d

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
    call random_cloud(3, 500, 1.0_wp, 15, x)
    call neighbour_build(nl, 3, 500, 500, x, 0.2_wp)
    x(2, 17) = x(2, 17) + 0.03_wp
    x(1, 400) = x(1, 400) - 0.01_wp
    call assert_equal(0.03_wp, max_displacement(nl, x), 1e-14_wp, 'largest displacement')
  end subroutine displacement

end module test_neighbours
