!> The neighbour-list validity test: decomposition-independent sums, the
!> affine fit, the smallest singular value, and the property the solver
!> relies on: after an affine motion plus a bounded residual, every pair
!> closer than sigma_min(F) r_list - 2 e_max is in the list (brute force).
module test_affine_motion
  use kinds, only: wp, i8
  use affine_motion, only: affine_fit, sigma_min
  use parallel_env, only: parallel_env_t, par_from_comm, par_sum_exact
  use neighbours, only: neighbour_list_t, neighbour_build
  use testing, only: run_test, assert_equal, assert_true, test_comm
  implicit none
  private
  public :: suite_affine_motion

contains

  subroutine suite_affine_motion()
    call run_test('affine_motion', 'exact_sum_independent_of_ranks', exact_sum)
    call run_test('affine_motion', 'sigma_min_of_known_matrices', smallest_singular_value)
    call run_test('affine_motion', 'fit_recovers_affine_map_2d', fit_2d)
    call run_test('affine_motion', 'list_holds_every_close_pair_after_affine_motion', &
                  list_validity)
  end subroutine suite_affine_motion

  subroutine seed(base)
    integer, intent(in) :: base
    integer, allocatable :: s(:)
    integer :: ns, k
    call random_seed(size=ns)
    allocate(s(ns))
    s = [(base + 37 * k, k = 1, ns)]
    call random_seed(put=s)
  end subroutine seed

  !> Rotation by angle t about the unit axis k (Rodrigues).
  function rotation(k, t) result(r)
    real(wp), intent(in) :: k(3), t
    real(wp) :: r(3, 3), kx(3, 3)
    integer :: i
    kx = reshape([0.0_wp, k(3), -k(2), -k(3), 0.0_wp, k(1), k(2), -k(1), 0.0_wp], [3, 3])
    r = sin(t) * kx + (1 - cos(t)) * matmul(kx, kx)
    do i = 1, 3
      r(i, i) = r(i, i) + 1
    end do
  end function rotation

  !> The columns of a global array this rank takes (round robin), packed.
  subroutine my_columns(env, x, mine)
    type(parallel_env_t), intent(in) :: env
    real(wp), intent(in) :: x(:, :)
    real(wp), allocatable, intent(out) :: mine(:, :)
    integer :: i, k
    allocate(mine(size(x, 1), (size(x, 2) - env%rank + env%nranks - 1) / env%nranks))
    k = 0
    do i = env%rank + 1, size(x, 2), env%nranks
      k = k + 1
      mine(:, k) = x(:, i)
    end do
  end subroutine my_columns

  !> Values spread over six decades summed from round-robin slices, and
  !> again with every value on rank 0 in reverse order: the two results are
  !> bitwise equal, and within N quanta of the true sum.
  subroutine exact_sum()
    integer, parameter :: N = 1001
    type(parallel_env_t) :: env
    real(wp) :: x(2, N), q(2), got(2), again(2), accurate(2)
    real(wp), allocatable :: mine(:, :)
    integer :: i
    env = par_from_comm(test_comm())
    do i = 1, N
      x(1, i) = sin(real(i, wp)) * 10.0_wp**(mod(i, 7) - 3)
      x(2, i) = 1 + 1e-9_wp * i
    end do
    call my_columns(env, x, mine)
    got = par_sum_exact(env, mine)
    deallocate(mine)
    allocate(mine(2, 0))
    if (env%rank == 0) mine = x(:, N:1:-1)
    again = par_sum_exact(env, mine)
    call assert_equal(got, again, 0.0_wp, 'bitwise equal whatever the distribution and order')
    q = maxval(abs(x), dim=2) * N * 2.0_wp**(-61)
    do i = 1, 2
      accurate(i) = real(sum(real(x(i, :), kind=16)), wp)
    end do
    call assert_true(all(abs(got - accurate) <= N * q), 'within N quanta of the true sum')
  end subroutine exact_sum

  subroutine smallest_singular_value()
    real(wp) :: f(3, 3), d(3, 3), q1(3, 3), q2(3, 3)
    d = 0
    d(1, 1) = 3
    d(2, 2) = 0.5_wp
    d(3, 3) = 2
    q1 = rotation([0.6_wp, 0.0_wp, 0.8_wp], 0.7_wp)
    q2 = rotation([0.0_wp, 1.0_wp, 0.0_wp], -1.2_wp)
    f = matmul(q1, matmul(d, transpose(q2)))
    call assert_equal(0.5_wp, sigma_min(3, f), 1e-14_wp, '3d: Q1 diag(3, 0.5, 2) Q2^T')
    ! 2D: [[2, 1], [1, 2]] has singular values 1 and 3; the third row and
    ! column do not belong to the 2D map
    f = reshape([2.0_wp, 1.0_wp, 9.0_wp, 1.0_wp, 2.0_wp, 9.0_wp, 9.0_wp, 9.0_wp, 0.0_wp], [3, 3])
    call assert_equal(1.0_wp, sigma_min(2, f), 1e-14_wp, '2d block')
    call assert_equal(0.0_wp, sigma_min(3, reshape([1.0_wp, 2.0_wp, 0.0_wp, 2.0_wp, 4.0_wp, &
                      0.0_wp, 0.0_wp, 0.0_wp, 1.0_wp], [3, 3])), 1e-7_wp, 'singular')
  end subroutine smallest_singular_value

  !> A 2D cloud moved by an exact affine map, fitted from the ranks' slices.
  subroutine fit_2d()
    integer, parameter :: N = 400
    type(parallel_env_t) :: env
    real(wp) :: x0(3, N), y(3, N), a(3, 3), b(3), afit(3, 3), bfit(3), e_max
    real(wp), allocatable :: x0m(:, :), ym(:, :)
    env = par_from_comm(test_comm())
    call seed(56)
    call random_number(x0)
    x0(1:2, :) = 1e3_wp + x0(1:2, :)     ! far from the origin: centring matters
    x0(3, :) = 0
    a = 0
    a(1:2, 1:2) = reshape([1.1_wp, 0.3_wp, -0.2_wp, 0.8_wp], [2, 2])
    b = [4.0_wp, -2.0_wp, 0.0_wp]
    y = matmul(a, x0)
    y(1, :) = y(1, :) + b(1)
    y(2, :) = y(2, :) + b(2)
    call my_columns(env, x0, x0m)
    call my_columns(env, y, ym)
    call affine_fit(env, 2, size(x0m, 2), x0m, ym, afit, bfit, e_max)
    call assert_equal(reshape(a, [9]), reshape(afit, [9]), 1e-9_wp, 'map')
    call assert_equal(b, bfit, 1e-5_wp, 'offset')
    call assert_true(e_max < 1e-9_wp, 'no residual')
  end subroutine fit_2d

  !> 1,500 random points, a list of radius r_list = 0.15 built on them, then
  !> a rotation, an anisotropic strain, a translation far beyond the skin
  !> and a random residual below 0.002: the fit gives s0 = sigma_min(F)
  !> r_list - 2 e_max above the support 0.12, and every pair now closer than
  !> s0 must be in the list.  The usual test (displacement below half the
  !> skin) would have forced a rebuild.
  subroutine list_validity()
    integer, parameter :: N = 1500
    real(wp), parameter :: R_LIST = 0.15_wp, SUPPORT = 0.12_wp, NOISE = 0.002_wp
    type(parallel_env_t) :: env
    type(neighbour_list_t) :: nl
    real(wp) :: x0(3, N), x(3, N), e(3, N), f(3, 3), strain(3, 3), b(3), e_max, s0, d
    real(wp), allocatable :: x0m(:, :), xm(:, :)
    logical, allocatable :: listed(:, :)
    integer :: i, j, kk, missing, close_new
    integer(i8) :: k
    env = par_from_comm(test_comm())
    call seed(206)
    call random_number(x0)
    call random_number(e)
    call neighbour_build(nl, 3, N, N, x0, [(int(i, i8), i = 1, N)], R_LIST, minval(x0, dim=2))
    allocate(listed(N, N))
    listed = .false.
    do kk = 1, nl%n_rows
      i = nl%row(kk)
      do k = nl%start(kk), nl%start(kk + 1) - 1
        j = nl%nbr(k)
        listed(i, j) = .true.
        listed(j, i) = .true.
      end do
    end do
    strain = 0
    strain(1, 1) = 0.97_wp
    strain(2, 2) = 0.99_wp
    strain(3, 3) = 1.04_wp
    f = matmul(rotation([0.0_wp, 0.6_wp, 0.8_wp], 0.5_wp), strain)
    x = matmul(f, x0) + NOISE / sqrt(3.0_wp) * (2 * e - 1)
    do i = 1, N
      x(:, i) = x(:, i) + [5.0_wp, -3.0_wp, 2.0_wp]
    end do
    call assert_true(maxval(sqrt(sum((x - x0)**2, dim=1))) > (R_LIST - SUPPORT) / 2, &
                     'the displacement test would rebuild')
    call my_columns(env, x0, x0m)
    call my_columns(env, x, xm)
    call affine_fit(env, 3, size(x0m, 2), x0m, xm, f, b, e_max)
    call assert_true(e_max < 2 * NOISE, 'residual of the order of the noise')
    s0 = sigma_min(3, f) * R_LIST - 2 * e_max
    call assert_true(s0 > SUPPORT, 'the fitted bound keeps the list')
    missing = 0
    close_new = 0
    do j = 1, N
      do i = j + 1, N
        d = sqrt(sum((x(:, i) - x(:, j))**2))
        if (d < s0 .and. .not. listed(i, j)) missing = missing + 1
        if (d < s0 .and. sqrt(sum((x0(:, i) - x0(:, j))**2)) > SUPPORT) close_new = close_new + 1
      end do
    end do
    call assert_equal(0, missing, 'pairs closer than s0 missing from the list')
    call assert_true(close_new > 100, 'pairs that came from beyond the support')
  end subroutine list_validity

end module test_affine_motion
