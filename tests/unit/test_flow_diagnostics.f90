!> The patch diagnostics against cases with known answers: the SPH vorticity
!> of linear fields (exact by renormalisation) and of the vortical patch's
!> field; the topology of particle sets built with known components and
!> holes; the symmetry error of exact and perturbed images; gathering by id
!> across ranks; angular momentum of a rigid rotation.
module test_flow_diagnostics
  use kinds, only: wp, i8
  use kernels, only: kernel_t, kernel_init, KERNEL_WENDLAND_C2
  use particles, only: particles_t, particles_allocate
  use parallel_env, only: parallel_env_t, par_from_comm
  use flow_diagnostics, only: angular_momentum, gather_by_id, symmetry_error, topology_t, &
                              fluid_topology, vorticity_2d
  use case_square, only: vortical_velocity, vortical_vorticity
  use testing, only: run_test, assert_true, assert_equal, test_comm
  implicit none
  private
  public :: suite_flow_diagnostics

contains

  subroutine suite_flow_diagnostics()
    call run_test('flow_diagnostics', 'vorticity_exact_for_linear_fields', vorticity_linear)
    call run_test('flow_diagnostics', 'vorticity_of_the_vortical_patch', vorticity_vortical)
    call run_test('flow_diagnostics', 'topology_of_known_shapes', topology_shapes)
    call run_test('flow_diagnostics', 'symmetry_error_of_images', symmetry_images)
    call run_test('flow_diagnostics', 'gather_by_id_and_angular_momentum_on_ranks', gather_ranks)
  end subroutine suite_flow_diagnostics

  !> The n x n lattice of spacing 1/n filling [-1/2, 1/2]^2, ids by row.
  subroutine lattice(n, x)
    integer, intent(in) :: n
    real(wp), allocatable, intent(out) :: x(:, :)
    integer :: i, j
    allocate(x(3, n * n))
    do j = 1, n
      do i = 1, n
        x(:, i + (j - 1) * n) = [(i - 0.5_wp) / n - 0.5_wp, (j - 0.5_wp) / n - 0.5_wp, 0.0_wp]
      end do
    end do
  end subroutine lattice

  ! u = (a x + b y, c x - a y) has vorticity c - b; the renormalised curl
  ! gives it on every particle of a square patch, corners and edges
  ! included, and on a jittered one.
  subroutine vorticity_linear()
    real(wp), allocatable :: x(:, :), u(:, :), m(:), rho(:), w(:), r(:, :)
    type(kernel_t) :: k
    integer :: n, np, jit
    n = 30
    call lattice(n, x)
    np = n * n
    allocate(u(3, np), m(np), rho(np), w(np), r(2, np))
    call random_number(r)
    k = kernel_init(KERNEL_WENDLAND_C2, 2, 2.0_wp / n)
    rho = 1 + 0.01_wp * r(1, :)
    m = rho / n**2
    do jit = 0, 1
      x(1:2, :) = x(1:2, :) + jit * 0.3_wp / n * (r - 0.5_wp)
      u(1, :) = 0.3_wp * x(1, :) + 1.7_wp * x(2, :)
      u(2, :) = -0.4_wp * x(1, :) - 0.3_wp * x(2, :)
      u(3, :) = 0
      call vorticity_2d(k, np, np, x, u, m, rho, w)
      call assert_equal(spread(-0.4_wp - 1.7_wp, 1, np), w, 1e-11_wp, 'curl of a linear field')
    end do
  end subroutine vorticity_linear

  ! The vortical patch's initial field: the SPH curl against the exact
  ! vorticity -V0 (f'(x) + f'(y)) (peak 2 x 32 e^-1/2 / (4 sqrt 2) = 6.86 V0/L,
  ! at x = y = L/(4 sqrt 2)).
  ! Measured RMS errors over the particles: 1.20 % of the peak at 40 x 40,
  ! 0.32 % at 80 x 80 (second order: the renormalised gradient is exact for
  ! linear fields); thresholds 1.5 % and 0.4 %.
  subroutine vorticity_vortical()
    real(wp), allocatable :: x(:, :), u(:, :), m(:), rho(:), w(:), we(:)
    type(kernel_t) :: k
    real(wp) :: err(2), peak
    integer :: n, np, i, level
    peak = 64 * exp(-0.5_wp) / (4 * sqrt(2.0_wp))
    do level = 1, 2
      n = 40 * level
      call lattice(n, x)
      np = n * n
      allocate(u(3, np), m(np), rho(np), w(np), we(np))
      do i = 1, np
        u(:, i) = vortical_velocity(x(1, i), x(2, i), 1.0_wp, 1.0_wp)
      end do
      we = vortical_vorticity(x(1, :), x(2, :), 1.0_wp, 1.0_wp)
      rho = 1
      m = 1.0_wp / n**2
      k = kernel_init(KERNEL_WENDLAND_C2, 2, 2.0_wp / n)
      call vorticity_2d(k, np, np, x, u, m, rho, w)
      err(level) = sqrt(sum((w - we)**2) / np) / peak
      deallocate(u, m, rho, w, we)
    end do
    call assert_true(err(1) < 0.015_wp, 'vortical patch: curl at 40 x 40')
    call assert_true(err(2) < 0.004_wp, 'vortical patch: curl at 80 x 80')
  end subroutine vorticity_vortical

  ! A filled square: one component, no hole; a square ring (a 10 dx hole):
  ! one hole, a cavity when big_area is below its area; two squares 4 dx
  ! apart: two components; a missing particle or a lattice strained to rows
  ! 0.5 dx apart with 2 dx between particles (the vortical patch near its
  ! stagnation points): no hole.
  subroutine topology_shapes()
    real(wp), allocatable :: x(:, :), y(:, :)
    type(topology_t) :: t
    real(wp) :: dx
    integer :: n, i, j, k
    n = 40
    dx = 1.0_wp / n
    call lattice(n, x)
    t = fluid_topology(x(1:2, :), dx, 0.01_wp)
    call assert_equal(1, t%components, 'square: components')
    call assert_equal(0, t%holes, 'square: holes')
    call assert_equal(1000, t%largest_share, 'square: share of the largest component')
    ! remove the central 10 x 10 block: a hole of (10 dx)^2 less the discs' reach
    y = pack_keep(x, maxval(abs(x(1:2, :)), dim=1) > 5 * dx)
    t = fluid_topology(y(1:2, :), dx, 0.01_wp)
    call assert_equal(1, t%components, 'ring: components')
    call assert_equal(1, t%holes, 'ring: holes')
    call assert_equal(1, t%cavities, 'ring: a cavity (hole > 1 % of L^2)')
    call assert_true(t%largest_hole > 30 * dx**2 .and. t%largest_hole < 100 * dx**2, &
                     'ring: hole area')
    t = fluid_topology(y(1:2, :), dx, 0.1_wp)
    call assert_equal(0, t%cavities, 'ring: no cavity above 10 % of L^2')
    ! one particle missing
    y = pack_keep(x, [(k /= n * n / 2 + n / 2, k = 1, n * n)])
    t = fluid_topology(y(1:2, :), dx, 0.01_wp)
    call assert_equal(0, t%holes, 'a missing particle is not a hole')
    ! two halves 4 dx apart
    y = x
    where (y(1, :) > 0) y(1, :) = y(1, :) + 3 * dx
    t = fluid_topology(y(1:2, :), dx, 0.01_wp)
    call assert_equal(2, t%components, 'two pieces')
    call assert_equal(500, t%largest_share, 'two halves: share')
    ! strained lattice: spacing 2 dx along x, 0.5 dx along y
    deallocate(y)
    allocate(y(2, n * n))
    do j = 1, 2 * n
      do i = 1, n / 2
        y(:, i + (j - 1) * (n / 2)) = [2 * dx * i, 0.5_wp * dx * j]
      end do
    end do
    t = fluid_topology(y, dx, 0.01_wp)
    call assert_equal(1, t%components, 'strained lattice: components')
    call assert_equal(0, t%holes, 'strained lattice: holes')
  end subroutine topology_shapes

  function pack_keep(x, keep) result(y)
    real(wp), intent(in) :: x(:, :)
    logical, intent(in) :: keep(:)
    real(wp), allocatable :: y(:, :)
    integer :: k, m
    allocate(y(size(x, 1), count(keep)))
    m = 0
    do k = 1, size(keep)
      if (.not. keep(k)) cycle
      m = m + 1
      y(:, m) = x(:, k)
    end do
  end function pack_keep

  ! A lattice and its exact image under the rotation by 90 degrees give
  ! zero; moving one particle of N by e gives RMS e/sqrt(N/2) (it and its
  ! partner's image are both off) and largest e, in units of the scale.
  subroutine symmetry_images()
    real(wp), allocatable :: x(:, :)
    integer, allocatable :: partner(:)
    real(wp) :: s(2, 2), rms, largest, e
    integer :: n, i, j, id
    n = 20
    call lattice(n, x)
    allocate(partner(n * n))
    do j = 1, n
      do i = 1, n
        id = i + (j - 1) * n
        partner(id) = (n + 1 - j) + (i - 1) * n     ! S x0 = (-y0, x0)
      end do
    end do
    s = reshape([0.0_wp, 1.0_wp, -1.0_wp, 0.0_wp], [2, 2])
    call symmetry_error(x(1:2, :), partner, s, 0.05_wp, rms, largest)
    call assert_equal(0.0_wp, largest, 1e-13_wp, 'exact image (round-off)')
    e = 1e-3_wp
    x(1, 7) = x(1, 7) + e
    call symmetry_error(x(1:2, :), partner, s, 0.05_wp, rms, largest)
    call assert_equal(e / 0.05_wp, largest, 1e-12_wp, 'largest error')
    call assert_equal(e * sqrt(2.0_wp / (n * n)) / 0.05_wp, rms, 1e-12_wp, 'RMS error')
  end subroutine symmetry_images

  ! Each rank owns the ids congruent to its rank: gather_by_id rebuilds the
  ! whole set on every rank; angular momentum of u = w (y, -x) is
  ! -w Sum m r^2 (reduced over the ranks).
  subroutine gather_ranks()
    type(parallel_env_t) :: env
    type(particles_t) :: parts
    real(wp), allocatable :: x(:, :), xg(:, :)
    real(wp) :: lz, expected
    integer :: n, k, np
    env = par_from_comm(test_comm())
    n = 15
    call lattice(n, x)
    call particles_allocate(parts, 2, n * n)
    np = 0
    expected = 0
    do k = 1, n * n
      expected = expected - 0.7_wp * 2.0_wp * sum(x(1:2, k)**2)
      if (mod(k, env%nranks) /= env%rank) cycle
      np = np + 1
      parts%x(:, np) = x(:, k)
      parts%u(:, np) = 0.7_wp * [x(2, k), -x(1, k), 0.0_wp]
      parts%m(np) = 2
      parts%id(np) = int(k, i8)
    end do
    parts%n = np
    call gather_by_id(env, parts, parts%x, 2, n * n, xg)
    call assert_equal(reshape(x(1:2, :), [2 * n * n]), reshape(xg, [2 * n * n]), 0.0_wp, &
                      'positions by id')
    lz = angular_momentum(env, parts)
    call assert_equal(expected, lz, 1e-12_wp * abs(expected), 'angular momentum')
  end subroutine gather_ranks

end module test_flow_diagnostics
