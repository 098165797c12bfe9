!> The right-hand side against references that do not use it: conservation
!> laws on random clouds, exact algebra (renormalised gradient of a linear
!> field), and the continuum values of div u and grad p on a lattice.
module test_fluid_rhs
  use kinds, only: wp, i8
  use kernels, only: kernel_init, kernel_f, kernel_w, KERNEL_WENDLAND_C2
  use neighbours, only: neighbour_list_t, neighbour_build
  use fluid_rhs, only: rhs_params_t, rhs_density_gradient, rhs_evaluate, &
                       VISC_NONE, VISC_DELTA, VISC_MONAGHAN, DIFF_NONE, DIFF_MOLTENI, &
                       DIFF_ANTUONO, sym_min_eigenvalue, LAMBDA_MIN
  use testing, only: run_test, assert_equal, assert_true
  implicit none
  private
  public :: suite_fluid_rhs

  !> A cloud with everything the right-hand side needs.
  type :: cloud_t
    integer :: dim, n
    real(wp) :: dx
    real(wp), allocatable :: x(:, :), u(:, :), rho(:), m(:), p(:), g(:, :)
    real(wp), allocatable :: drho(:), du(:, :)
    type(neighbour_list_t) :: nl
    type(rhs_params_t) :: prm
  end type cloud_t

contains

  subroutine suite_fluid_rhs()
    call run_test('fluid_rhs', 'conserves_momentum_and_angular_momentum', conservation)
    call run_test('fluid_rhs', 'diffusion_conserves_mass', diffusion_conservative)
    call run_test('fluid_rhs', 'renormalised_gradient_exact_for_linear', gradient_linear)
    call run_test('fluid_rhs', 'rigid_rotation_no_divergence_no_viscous_force', rigid_rotation)
    call run_test('fluid_rhs', 'viscosity_dissipates', viscosity_dissipates)
    call run_test('fluid_rhs', 'lattice_divergence_and_pressure_gradient', lattice_fields)
    call run_test('fluid_rhs', 'tensile_control_conserves_momentum', tensile_conservation)
    call run_test('fluid_rhs', 'tensile_control_repulsive_under_tension_only', tensile_pair)
  end subroutine suite_fluid_rhs

  !> Lattice of spacing dx in the box [-L, L]^dim, optionally jittered, with
  !> h = 2 dx, rho = 1 + small random variation, masses rho dx^dim.
  subroutine make_cloud(c, dim, m_side, jitter, seed)
    type(cloud_t), intent(out) :: c
    integer, intent(in) :: dim, m_side, seed
    real(wp), intent(in) :: jitter
    real(wp), allocatable :: r(:, :)
    integer, allocatable :: s(:)
    integer :: i, j, k, kz, ns, np
    c%dim = dim
    c%dx = 1.0_wp / m_side
    kz = merge(m_side, 1, dim == 3)
    c%n = (2 * m_side)**2 * merge(2 * m_side, 1, dim == 3)
    allocate(c%x(3, c%n), c%u(3, c%n), c%rho(c%n), c%m(c%n), c%p(c%n), c%g(3, c%n), &
             c%drho(c%n), c%du(3, c%n), r(4, c%n))
    call random_seed(size=ns)
    allocate(s(ns))
    s = seed + 101 * [(i, i = 1, ns)]
    call random_seed(put=s)
    call random_number(r)
    np = 0
    c%x = 0
    do k = 1, merge(2 * m_side, 1, dim == 3)
      do j = 1, 2 * m_side
        do i = 1, 2 * m_side
          np = np + 1
          c%x(1, np) = (i - m_side - 0.5_wp) * c%dx
          c%x(2, np) = (j - m_side - 0.5_wp) * c%dx
          if (dim == 3) c%x(3, np) = (k - kz - 0.5_wp) * c%dx
        end do
      end do
    end do
    c%x(1:dim, :) = c%x(1:dim, :) + jitter * c%dx * (r(1:dim, :) - 0.5_wp)
    c%rho = 1 + 0.01_wp * (r(4, :) - 0.5_wp)
    c%m = c%rho * c%dx**dim
    c%u = 0
    c%p = 0
    c%g = 0
    c%prm%dim = dim
    c%prm%kernel = kernel_init(KERNEL_WENDLAND_C2, dim, 2 * c%dx)
    c%prm%c0 = 10
    c%prm%rho0 = 1
    c%prm%alpha = 0.05_wp
    c%prm%delta = 0.1_wp
    call neighbour_build(c%nl, dim, c%n, c%n, c%x, [(int(i, i8), i = 1, c%n)], &
                         c%prm%kernel%support, minval(c%x, dim=2))
  end subroutine make_cloud

  subroutine evaluate(c)
    type(cloud_t), intent(inout) :: c
    if (c%prm%diffusion == DIFF_ANTUONO) &
      call rhs_density_gradient(c%prm, c%n, c%n, c%x, c%rho, c%m, c%nl, c%g)
    call rhs_evaluate(c%prm, c%n, c%n, c%x, c%u, c%rho, c%m, c%p, c%g, c%nl, c%drho, c%du)
  end subroutine evaluate

  !> Pressure and viscous forces are pairwise equal and opposite and central,
  !> so Sum m du = 0 and Sum m x x du = 0, for any state.
  subroutine conservation()
    type(cloud_t) :: c
    integer :: dim, visc, i
    real(wp) :: mom(3), ang(3), scale
    do dim = 2, 3
      do visc = VISC_NONE, VISC_MONAGHAN
        call make_cloud(c, dim, merge(12, 5, dim == 2), 0.6_wp, 7 + dim)
        call random_number(c%u)
        c%u = c%u - 0.5_wp
        if (dim == 2) c%u(3, :) = 0
        c%p = 100 * (c%rho - 1) + 0.3_wp
        c%prm%viscosity = visc
        c%prm%diffusion = DIFF_ANTUONO
        call evaluate(c)
        mom = 0; ang = 0
        do i = 1, c%n
          mom = mom + c%m(i) * c%du(:, i)
          ang = ang + c%m(i) * cross(c%x(:, i), c%du(:, i))
        end do
        scale = sum(c%m * sqrt(sum(c%du**2, dim=1)))
        call assert_true(scale > 0, 'forces are not all zero')
        call assert_equal([0.0_wp, 0.0_wp, 0.0_wp], mom / scale, 1e-13_wp, 'linear momentum')
        call assert_equal([0.0_wp, 0.0_wp, 0.0_wp], ang / scale, 1e-13_wp, 'angular momentum')
      end do
    end do
  end subroutine conservation

  pure function cross(a, b) result(c)
    real(wp), intent(in) :: a(3), b(3)
    real(wp) :: c(3)
    c = [a(2) * b(3) - a(3) * b(2), a(3) * b(1) - a(1) * b(3), a(1) * b(2) - a(2) * b(1)]
  end function cross

  !> With u = 0 only the diffusion term changes the density, and it moves
  !> mass between pairs: Sum_i V_i D_i = 0.  It also smooths: Sum V rho D < 0.
  subroutine diffusion_conservative()
    type(cloud_t) :: c
    integer :: dim, diff
    real(wp) :: total, smoothing, scale
    do dim = 2, 3
      do diff = DIFF_MOLTENI, DIFF_ANTUONO
        call make_cloud(c, dim, merge(12, 5, dim == 2), 0.6_wp, 20 + dim)
        c%prm%diffusion = diff
        call evaluate(c)
        total = sum(c%m / c%rho * c%drho)
        smoothing = sum(c%m * c%drho)        ! V rho D = m D
        scale = sum(abs(c%m / c%rho * c%drho))
        call assert_true(scale > 0, 'diffusion acts')
        call assert_equal(0.0_wp, total / scale, 1e-13_wp, 'Sum V D = 0')
        call assert_true(smoothing < 0 .or. diff == DIFF_ANTUONO, 'diffusion smooths')
      end do
    end do
  end subroutine diffusion_conservative

  !> (E3): L_i Sum_j (rho_j - rho_i) grad W V_j recovers the gradient of a
  !> linear density exactly, for any particle arrangement, even at the edge.
  subroutine gradient_linear()
    type(cloud_t) :: c
    integer :: dim, i, checked
    real(wp) :: a(3)
    do dim = 2, 3
      call make_cloud(c, dim, merge(10, 5, dim == 2), 0.8_wp, 30 + dim)
      a = [0.3_wp, -0.2_wp, merge(0.1_wp, 0.0_wp, dim == 3)]
      do i = 1, c%n
        c%rho(i) = 1 + sum(a * c%x(:, i))
      end do
      call rhs_density_gradient(c%prm, c%n, c%n, c%x, c%rho, c%m, c%nl, c%g)
      checked = 0
      do i = 1, c%n
        if (min_eig(c, i) < LAMBDA_MIN) cycle   ! not renormalised there, by design
        call assert_equal(a, c%g(:, i), 1e-11_wp, 'gradient of a linear field')
        checked = checked + 1
      end do
      ! the guard must only skip a few corner particles of the jittered box
      call assert_true(checked >= c%n - c%n / 50, 'renormalised almost everywhere')
    end do
  end subroutine gradient_linear

  !> Smallest eigenvalue of M_i computed here by brute force over all pairs.
  function min_eig(c, i) result(lam)
    type(cloud_t), intent(in) :: c
    integer, intent(in) :: i
    real(wp) :: lam, mm(6), xij(3), f
    integer :: j
    mm = 0
    do j = 1, c%n
      if (j == i) cycle
      xij = c%x(:, i) - c%x(:, j)
      f = kernel_f(c%prm%kernel, norm2(xij))
      mm = mm - c%m(j) / c%rho(j) * f * [xij(1)**2, xij(2)**2, xij(3)**2, &
                                          xij(1) * xij(2), xij(1) * xij(3), xij(2) * xij(3)]
    end do
    lam = sym_min_eigenvalue(c%dim, mm)
  end function min_eig

  !> u = w x x: pair velocities are normal to the pair, so div = 0 and the
  !> delta-SPH viscosity vanishes exactly.
  subroutine rigid_rotation()
    type(cloud_t) :: c
    integer :: dim, i
    real(wp) :: w(3)
    do dim = 2, 3
      call make_cloud(c, dim, merge(10, 5, dim == 2), 0.6_wp, 40 + dim)
      c%rho = 1
      c%m = c%dx**dim
      w = [merge(0.4_wp, 0.0_wp, dim == 3), merge(-0.7_wp, 0.0_wp, dim == 3), 1.3_wp]
      do i = 1, c%n
        c%u(:, i) = cross(w, c%x(:, i))
      end do
      c%prm%viscosity = VISC_DELTA
      c%prm%diffusion = DIFF_MOLTENI
      call evaluate(c)
      call assert_equal(0.0_wp, maxval(abs(c%drho)), 1e-12_wp, 'no compression')
      call assert_equal(0.0_wp, maxval(abs(c%du)), 1e-12_wp, 'no viscous force')
    end do
  end subroutine rigid_rotation

  !> The viscous force alone never creates kinetic energy: Sum m u.du <= 0.
  subroutine viscosity_dissipates()
    type(cloud_t) :: c
    integer :: dim, visc
    real(wp) :: power
    do dim = 2, 3
      do visc = VISC_DELTA, VISC_MONAGHAN
        call make_cloud(c, dim, merge(10, 5, dim == 2), 0.6_wp, 50 + dim)
        call random_number(c%u)
        c%u = c%u - 0.5_wp
        if (dim == 2) c%u(3, :) = 0
        c%p = 0
        c%prm%viscosity = visc
        c%prm%diffusion = DIFF_NONE
        call evaluate(c)
        power = sum(c%m * sum(c%u * c%du, dim=1))
        call assert_true(power < 0, 'viscous power is negative')
      end do
    end do
  end subroutine viscosity_dissipates

  !> On a regular lattice, away from the edges, u = (a x, b y) gives
  !> D rho/Dt = -rho (a + b) m2 and p = c . x gives du = -c m2 (rho = 1), where
  !> m2 = -Sum_j F x_ij,1^2 V_j is the lattice's second kernel moment (0.9992
  !> at h = 2 dx, 1 in the continuum): exact algebra on the lattice.
  subroutine lattice_fields()
    type(cloud_t) :: c
    integer :: i, j, inner
    real(wp) :: cvec(3), m2, r
    call make_cloud(c, 2, 16, 0.0_wp, 60)
    c%rho = 1
    c%m = c%dx**2
    cvec = [2.0_wp, -3.0_wp, 0.0_wp]
    do i = 1, c%n
      c%u(:, i) = [-0.7_wp * c%x(1, i), 1.1_wp * c%x(2, i), 0.0_wp]
      c%p(i) = 5 + sum(cvec * c%x(:, i))
    end do
    c%prm%viscosity = VISC_NONE
    c%prm%diffusion = DIFF_NONE
    call evaluate(c)
    m2 = 0
    do j = -5, 5
      do i = -5, 5
        r = c%dx * sqrt(real(i**2 + j**2, wp))
        if (i /= 0 .or. j /= 0) m2 = m2 - kernel_f(c%prm%kernel, r) * (i * c%dx)**2 * c%dx**2
      end do
    end do
    call assert_equal(1.0_wp, m2, 1e-3_wp, 'lattice moment near its continuum value')
    inner = 0
    do i = 1, c%n
      if (maxval(abs(c%x(1:2, i))) > 1 - 1.01_wp * c%prm%kernel%support) cycle
      inner = inner + 1
      call assert_equal(-(-0.7_wp + 1.1_wp) * m2, c%drho(i), 1e-12_wp, 'continuity: -rho div u')
      call assert_equal(-cvec * m2, c%du(:, i), 1e-11_wp, 'momentum: -grad p / rho')
    end do
    call assert_true(inner > 100, 'enough interior particles')
  end subroutine lattice_fields

  !> (E7) The tensile control is pairwise antisymmetric and central like the
  !> pressure term: momentum and angular momentum stay conserved with it on,
  !> in a cloud whose pressures are mostly negative; and it changes the
  !> forces (it is not silently off).
  subroutine tensile_conservation()
    type(cloud_t) :: c
    integer :: dim, i
    real(wp) :: mom(3), ang(3), scale
    real(wp), allocatable :: du_off(:, :)
    do dim = 2, 3
      call make_cloud(c, dim, merge(12, 5, dim == 2), 0.6_wp, 70 + dim)
      call random_number(c%u)
      c%u = c%u - 0.5_wp
      if (dim == 2) c%u(3, :) = 0
      c%p = 100 * (c%rho - 1) - 0.3_wp
      c%prm%diffusion = DIFF_MOLTENI
      call evaluate(c)
      du_off = c%du
      c%prm%tensile_eps = 0.4_wp
      c%prm%tensile_dx = c%dx
      call evaluate(c)
      mom = 0; ang = 0
      do i = 1, c%n
        mom = mom + c%m(i) * c%du(:, i)
        ang = ang + c%m(i) * cross(c%x(:, i), c%du(:, i))
      end do
      scale = sum(c%m * sqrt(sum(c%du**2, dim=1)))
      call assert_true(maxval(abs(c%du - du_off)) > 1e-3_wp * maxval(abs(du_off)), &
                       'the tensile control acts')
      call assert_equal([0.0_wp, 0.0_wp, 0.0_wp], mom / scale, 1e-13_wp, 'linear momentum')
      call assert_equal([0.0_wp, 0.0_wp, 0.0_wp], ang / scale, 1e-13_wp, 'angular momentum')
    end do
  end subroutine tensile_conservation

  !> Two particles at distance r, alone: the control adds
  !>   tens_i = -m_j (R_i + R_j) (W(r)/W(dx))^n F(r) x_ij,  R = eps |p|/rho^2 (p < 0),
  !> which points from j to i (repulsion, F < 0) when either pressure is
  !> negative, and nothing when both are positive.
  subroutine tensile_pair()
    type(cloud_t) :: c
    real(wp) :: r, pressures(2, 3), ri(2), expected(3), du_off(3, 2)
    integer :: k, i
    pressures = reshape([-0.5_wp, -0.2_wp, -0.5_wp, 0.3_wp, 0.5_wp, 0.2_wp], [2, 3])
    c%dim = 2
    c%n = 2
    c%dx = 0.1_wp
    r = 1.3_wp * c%dx
    c%x = reshape([0.0_wp, 0.0_wp, 0.0_wp, r * 0.6_wp, r * 0.8_wp, 0.0_wp], [3, 2])
    allocate(c%u(3, 2), c%p(2), c%g(3, 2), c%drho(2), c%du(3, 2))
    c%u = 0
    c%rho = [1.01_wp, 0.98_wp]
    c%m = [1.0_wp, 1.2_wp] * c%dx**2
    c%g = 0
    c%prm%dim = 2
    c%prm%kernel = kernel_init(KERNEL_WENDLAND_C2, 2, 2 * c%dx)
    c%prm%viscosity = VISC_NONE
    c%prm%diffusion = DIFF_NONE
    call neighbour_build(c%nl, 2, 2, 2, c%x, [1_i8, 2_i8], c%prm%kernel%support, &
                         minval(c%x, dim=2))
    do k = 1, 3
      c%p = pressures(:, k)
      c%prm%tensile_eps = 0
      call evaluate(c)
      du_off = c%du(:, 1:2)
      c%prm%tensile_eps = 0.2_wp
      c%prm%tensile_n = 4
      c%prm%tensile_dx = c%dx
      call evaluate(c)
      do i = 1, 2
        ri(i) = 0.2_wp * max(0.0_wp, -c%p(i)) / c%rho(i)**2
      end do
      ! on particle 1 (x_12 = x_1 - x_2), from particle 2
      expected = -c%m(2) * sum(ri) * (kernel_w(c%prm%kernel, r) / kernel_w(c%prm%kernel, c%dx))**4 &
                 * kernel_f(c%prm%kernel, r) * (c%x(:, 1) - c%x(:, 2))
      call assert_equal(expected, c%du(:, 1) - du_off(:, 1), 1e-12_wp * maxval(abs(du_off)), &
                        'E7 on particle 1')
      call assert_equal(-expected * c%m(1) / c%m(2), c%du(:, 2) - du_off(:, 2), &
                        1e-12_wp * maxval(abs(du_off)), 'E7 on particle 2: opposite momentum')
      if (k < 3) then
        call assert_true(sum((c%du(:, 1) - du_off(:, 1)) * (c%x(:, 1) - c%x(:, 2))) > 0, &
                         'repulsive when a pressure is negative')
      else
        call assert_equal(0.0_wp, maxval(abs(c%du(:, 1:2) - du_off)), 0.0_wp, &
                          'no control when both pressures are positive')
      end if
    end do
  end subroutine tensile_pair

end module test_fluid_rhs
