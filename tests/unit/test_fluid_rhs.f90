!> The right-hand side against references that do not use it: conservation
!> laws on random clouds, exact algebra (renormalised gradient of a linear
!> field), and the continuum values of div u and grad p on a lattice.
module test_fluid_rhs
  use kinds, only: wp, i8
  use kernels, only: kernel_init, kernel_f, kernel_w, KERNEL_WENDLAND_C2
  use neighbours, only: neighbour_list_t, neighbour_build
  use fluid_rhs, only: rhs_params_t, rhs_density_gradient, rhs_evaluate, &
                       rhs_renormalisation, rhs_shift, &
                       VISC_NONE, VISC_DELTA, VISC_MONAGHAN, DIFF_NONE, DIFF_MOLTENI, &
                       DIFF_ANTUONO, PGRAD_STANDARD, PGRAD_HIGHER_ORDER, sym_min_eigenvalue, &
                       LAMBDA_MIN, LAMBDA_SURFACE, LAMBDA_NEAR, DIV_STANDARD, DIV_RENORMALISED
  use flow_diagnostics, only: free_surface_lambda
  use testing, only: run_test, assert_equal, assert_true, same_bits
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
    call run_test('fluid_rhs', 'higher_order_gradient_exact_for_linear_pressure', ho_linear)
    call run_test('fluid_rhs', 'higher_order_gradient_on_lattice', ho_lattice)
    call run_test('fluid_rhs', 'higher_order_ignores_free_surface_pressure', ho_surface_pressure)
    call run_test('fluid_rhs', 'higher_order_blend_of_the_two_forms', ho_blend)
    call run_test('fluid_rhs', 'renormalised_divergence_exact_for_linear_velocity', div_linear)
    call run_test('fluid_rhs', 'free_surface_indicator_on_lattice_disc', free_surface_disc)
    call run_test('fluid_rhs', 'shifting_zero_on_lattice_interior_and_surface', shift_lattice)
    call run_test('fluid_rhs', 'shifting_relaxes_perturbed_lattice', shift_relaxes)
    call run_test('fluid_rhs', 'shifting_none_on_surface_tangential_near_it', shift_surface)
    call run_test('fluid_rhs', 'corrected_operators_and_shift_bitwise_on_pieces', bitwise_pieces)
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

  !> (Section 5) -(1/rho_i) L_i Sum_j (p_j - p_i) g V_j is -grad p/rho_i
  !> exactly for a linear pressure on a jittered cloud, on every particle
  !> that uses it (lambda_i >= LAMBDA_NEAR), when no partner is treated as
  !> free surface (lambda passed as 1).
  subroutine ho_linear()
    type(cloud_t) :: c
    integer :: dim, i, checked
    real(wp) :: a(3)
    real(wp), allocatable :: lmat(:, :), lambda(:), ones(:)
    do dim = 2, 3
      call make_cloud(c, dim, merge(10, 5, dim == 2), 0.8_wp, 80 + dim)
      a = [0.3_wp, -0.2_wp, merge(0.1_wp, 0.0_wp, dim == 3)]
      do i = 1, c%n
        c%p(i) = 2 + sum(a * c%x(:, i))
      end do
      c%prm%viscosity = VISC_NONE
      c%prm%diffusion = DIFF_NONE
      c%prm%pressure_gradient = PGRAD_HIGHER_ORDER
      c%prm%ho_weight = 1      ! the corrected form alone
      allocate(lmat(6, c%n), lambda(c%n), ones(c%n))
      call rhs_renormalisation(c%prm, c%n, c%n, c%x, c%rho, c%m, c%nl, lambda, lmat)
      ones = 1
      call rhs_evaluate(c%prm, c%n, c%n, c%x, c%u, c%rho, c%m, c%p, c%g, c%nl, c%drho, c%du, &
                        ones, lmat)
      checked = 0
      do i = 1, c%n
        if (lambda(i) < LAMBDA_NEAR) cycle
        call assert_equal(-a / c%rho(i), c%du(:, i), 1e-11_wp, 'du = -grad p / rho')
        checked = checked + 1
      end do
      call assert_true(checked >= merge(c%n / 4, c%n / 20, dim == 2), 'enough particles inside')
      deallocate(lmat, lambda, ones)
    end do
  end subroutine ho_linear

  !> On a regular lattice with p = 5 + c . x: -c/rho everywhere away from the
  !> free surface (the standard form gives -c m2 there, m2 the lattice's
  !> second moment); the outer layer is detected as free surface and its
  !> pressure replaced by 0, which changes the gradient of its neighbours
  !> only.
  subroutine ho_lattice()
    type(cloud_t) :: c
    integer :: i, inner, surface
    real(wp) :: cvec(3)
    real(wp), allocatable :: lmat(:, :), lambda(:)
    call make_cloud(c, 2, 16, 0.0_wp, 90)
    c%rho = 1
    c%m = c%dx**2
    cvec = [2.0_wp, -3.0_wp, 0.0_wp]
    do i = 1, c%n
      c%p(i) = 5 + sum(cvec * c%x(:, i))
    end do
    c%prm%viscosity = VISC_NONE
    c%prm%diffusion = DIFF_NONE
    c%prm%pressure_gradient = PGRAD_HIGHER_ORDER
    c%prm%ho_weight = 1      ! the corrected form alone
    allocate(lmat(6, c%n), lambda(c%n))
    call rhs_renormalisation(c%prm, c%n, c%n, c%x, c%rho, c%m, c%nl, lambda, lmat)
    call rhs_evaluate(c%prm, c%n, c%n, c%x, c%u, c%rho, c%m, c%p, c%g, c%nl, c%drho, c%du, &
                      lambda, lmat)
    inner = 0
    surface = 0
    do i = 1, c%n
      ! the outer layer of the box is free surface, the rest is not
      if (maxval(abs(c%x(1:2, i))) > 1 - c%dx) then
        surface = surface + 1
        call assert_true(lambda(i) < LAMBDA_SURFACE, 'outer layer is free surface')
        cycle
      end if
      call assert_true(lambda(i) >= LAMBDA_SURFACE, 'inner layers are not free surface')
      if (maxval(abs(c%x(1:2, i))) > 1 - 1.01_wp * c%prm%kernel%support) cycle
      inner = inner + 1
      call assert_equal(-cvec, c%du(:, i), 1e-11_wp, 'momentum: -grad p / rho')
    end do
    call assert_equal(4 * 32 - 4, surface, 'outer layer count')
    call assert_true(inner > 100, 'enough interior particles')
  end subroutine ho_lattice

  !> (Section 5) The pressure of free-surface particles (lambda < 0.55) is
  !> replaced by 0 in the corrected form: changing it changes nothing for
  !> particles inside the fluid (lambda >= 0.9), which use that form, and
  !> does change the surface particles, which keep (E4).
  subroutine ho_surface_pressure()
    type(cloud_t) :: c
    integer :: i, inner
    real(wp), allocatable :: lmat(:, :), lambda(:), du0(:, :), r(:)
    call make_cloud(c, 2, 12, 0.3_wp, 95)
    allocate(lmat(6, c%n), lambda(c%n), r(c%n), du0(3, c%n))
    call random_number(r)
    do i = 1, c%n
      c%p(i) = 1 - sum(c%x(:, i)**2)
    end do
    c%prm%viscosity = VISC_NONE
    c%prm%diffusion = DIFF_NONE
    c%prm%pressure_gradient = PGRAD_HIGHER_ORDER
    c%prm%ho_weight = 1      ! the corrected form alone inside
    call rhs_renormalisation(c%prm, c%n, c%n, c%x, c%rho, c%m, c%nl, lambda, lmat)
    call rhs_evaluate(c%prm, c%n, c%n, c%x, c%u, c%rho, c%m, c%p, c%g, c%nl, c%drho, c%du, &
                      lambda, lmat)
    du0(:, :) = c%du
    where (lambda < LAMBDA_SURFACE) c%p = c%p + 10 * (r - 0.5_wp)
    call rhs_evaluate(c%prm, c%n, c%n, c%x, c%u, c%rho, c%m, c%p, c%g, c%nl, c%drho, c%du, &
                      lambda, lmat)
    inner = count(lambda >= LAMBDA_NEAR)
    call assert_true(inner > c%n / 3 .and. count(lambda < LAMBDA_SURFACE) > 4 * 20, &
                     'the box has an inside and a surface')
    call assert_equal(0.0_wp, maxval(abs(c%du(:, 1:c%n) - du0), &
                                     mask=spread(lambda >= LAMBDA_NEAR, 1, 3)), 0.0_wp, &
                      'inside: surface pressures replaced by 0')
    call assert_true(maxval(abs(c%du - du0), mask=spread(lambda < LAMBDA_SURFACE, 1, 3)) > 1, &
                     'on the surface: (E4) with the particles'' own pressures')
  end subroutine ho_surface_pressure

  !> (Section 5, the blend) Each pair adds w_i times the corrected form and
  !> 1 - w_i times (E4) to particle i, w_i = W clamp((lambda_i - 0.7)/0.2,
  !> 0, 1), W = ho_weight: so the gradient with W = 0.9 is 0.9 times the one
  !> with W = 1 plus 0.1 times (E4), particle by particle, to round-off.
  subroutine ho_blend()
    type(cloud_t) :: c
    integer :: i, dim, nblend
    real(wp) :: w
    real(wp), allocatable :: lmat(:, :), lambda(:), du_std(:, :), du_ho(:, :)
    do dim = 2, 3
      call make_cloud(c, dim, merge(12, 6, dim == 2), 0.5_wp, 97 + dim)
      allocate(lmat(6, c%n), lambda(c%n), du_std(3, c%n), du_ho(3, c%n))
      do i = 1, c%n
        c%p(i) = 1 - sum(c%x(:, i)**2) + 0.3_wp * c%x(1, i)
      end do
      c%prm%viscosity = VISC_NONE
      c%prm%diffusion = DIFF_NONE
      call rhs_renormalisation(c%prm, c%n, c%n, c%x, c%rho, c%m, c%nl, lambda, lmat)
      c%prm%pressure_gradient = PGRAD_STANDARD
      call rhs_evaluate(c%prm, c%n, c%n, c%x, c%u, c%rho, c%m, c%p, c%g, c%nl, c%drho, c%du)
      du_std = c%du(:, 1:c%n)
      c%prm%pressure_gradient = PGRAD_HIGHER_ORDER
      c%prm%ho_weight = 1
      call rhs_evaluate(c%prm, c%n, c%n, c%x, c%u, c%rho, c%m, c%p, c%g, c%nl, c%drho, c%du, &
                        lambda, lmat)
      du_ho = c%du(:, 1:c%n)
      c%prm%ho_weight = 0.9_wp
      call rhs_evaluate(c%prm, c%n, c%n, c%x, c%u, c%rho, c%m, c%p, c%g, c%nl, c%drho, c%du, &
                        lambda, lmat)
      nblend = 0
      do i = 1, c%n
        w = max(0.0_wp, min(1.0_wp, (lambda(i) - 0.7_wp) / 0.2_wp))
        if (w > 0 .and. w < 1) nblend = nblend + 1
        call assert_equal(0.9_wp * du_ho(:, i) + 0.1_wp * du_std(:, i), c%du(:, i), &
                          1e-12_wp * maxval(abs(du_std)), 'du = 0.9 du(W = 1) + 0.1 du_E4')
      end do
      call assert_true(nblend > 0, 'particles in the blend zone')
      deallocate(lmat, lambda, du_std, du_ho)
    end do
  end subroutine ho_blend

  !> (E1) renormalised: Sum_j u_ji . (L_i g) V_j is div u exactly for a
  !> linear velocity on a jittered cloud wherever L_i is renormalised; with
  !> no diffusion D rho_i/Dt = -rho_i tr(A).  The standard sum is not exact
  !> at the edges.
  subroutine div_linear()
    type(cloud_t) :: c
    integer :: dim, i, checked
    real(wp) :: a(3, 3), tr
    real(wp), allocatable :: lmat(:, :), lambda(:)
    do dim = 2, 3
      call make_cloud(c, dim, merge(10, 5, dim == 2), 0.8_wp, 100 + dim)
      a = reshape([0.3_wp, -0.5_wp, 0.2_wp, 0.7_wp, 0.4_wp, -0.1_wp, 0.6_wp, 0.1_wp, -0.2_wp], &
                  [3, 3])
      if (dim == 2) a(3, :) = 0
      if (dim == 2) a(:, 3) = 0
      tr = a(1, 1) + a(2, 2) + a(3, 3)
      do i = 1, c%n
        c%u(:, i) = matmul(a, c%x(:, i))
      end do
      c%prm%viscosity = VISC_NONE
      c%prm%diffusion = DIFF_NONE
      c%prm%divergence = DIV_RENORMALISED
      allocate(lmat(6, c%n), lambda(c%n))
      call rhs_renormalisation(c%prm, c%n, c%n, c%x, c%rho, c%m, c%nl, lambda, lmat)
      call rhs_evaluate(c%prm, c%n, c%n, c%x, c%u, c%rho, c%m, c%p, c%g, c%nl, c%drho, c%du, &
                        lambda, lmat)
      checked = 0
      do i = 1, c%n
        if (lambda(i) < LAMBDA_MIN) cycle
        call assert_equal(-c%rho(i) * tr, c%drho(i), 1e-11_wp, 'D rho/Dt = -rho div u')
        checked = checked + 1
      end do
      call assert_true(checked >= c%n - c%n / 50, 'exact almost everywhere')
      c%prm%divergence = DIV_STANDARD
      call evaluate(c)
      call assert_true(maxval(abs(c%drho(1:c%n) + c%rho * tr)) > 0.1_wp * abs(tr), &
                       'the standard divergence is not exact at the edges')
      deallocate(lmat, lambda)
    end do
  end subroutine div_linear

  !> (E9) On a square lattice clipped to a disc (2D) or a ball (3D), h = 2 dx:
  !> lambda ~ 1 more than a kernel support inside; below 0.55 on the outer
  !> layer, the particles whose lattice neighbour along an axis is missing on
  !> the outward side; at or above 0.55 on every particle whose 3^dim - 1
  !> lattice neighbours are all there.  (Particles with only a diagonal
  !> neighbour missing, at the steps of the clipped lattice, fall on either
  !> side: 0.53 to 0.55 in 3D.)  The snapshot diagnostic (flow_diagnostics)
  !> agrees to round-off.
  subroutine free_surface_disc()
    type(cloud_t) :: c
    real(wp), allocatable :: x(:, :), lmat(:, :), lambda(:), lam_diag(:)
    logical, allocatable :: outer(:), complete(:), keep(:)
    integer :: dim, i, a, b, k, n, m_side, zr
    real(wp) :: rr, dx, e(3)
    do dim = 2, 3
      m_side = merge(20, 8, dim == 2)
      call make_cloud(c, dim, m_side, 0.0_wp, 110)
      rr = 1.0_wp - 0.25_wp * c%dx
      if (allocated(keep)) deallocate(keep)
      allocate(keep(c%n))
      keep = sum(c%x**2, dim=1) < rr**2
      n = count(keep)
      allocate(x(3, n))
      x = c%x(:, pack([(i, i = 1, c%n)], keep))
      dx = c%dx
      deallocate(c%rho, c%m)
      allocate(c%rho(n), c%m(n), lmat(6, n), lambda(n), lam_diag(n), outer(n), complete(n))
      c%rho = 1
      c%m = dx**dim
      call neighbour_build(c%nl, dim, n, n, x, [(int(i, i8), i = 1, n)], c%prm%kernel%support, &
                           minval(x, dim=2))
      call rhs_renormalisation(c%prm, n, n, x, c%rho, c%m, c%nl, lambda, lmat)
      zr = merge(1, 0, dim == 3)
      do i = 1, n
        outer(i) = .false.
        complete(i) = .true.
        do k = -zr, zr
          do b = -1, 1
            do a = -1, 1
              e = [a, b, k] * dx
              if (sum((x(:, i) + e)**2) < rr**2) cycle
              complete(i) = .false.
              ! an axis neighbour missing on the outward side
              if (abs(a) + abs(b) + abs(k) == 1 .and. sum(e * x(:, i)) > 0) outer(i) = .true.
            end do
          end do
        end do
      end do
      do i = 1, n
        if (norm2(x(:, i)) < rr - 1.01_wp * c%prm%kernel%support) then
          call assert_equal(1.0_wp, lambda(i), 2e-3_wp, 'lambda ~ 1 inside')
        else if (outer(i)) then
          call assert_true(lambda(i) < LAMBDA_SURFACE, 'outer layer below 0.55')
        else if (complete(i)) then
          call assert_true(lambda(i) >= LAMBDA_SURFACE, 'all neighbours there: not surface')
        end if
      end do
      call assert_true(count(outer) > merge(100, 150, dim == 2), 'an outer layer')
      call assert_true(count(complete .and. norm2(x, dim=1) > rr - c%prm%kernel%support) > &
                       merge(100, 150, dim == 2), 'complete particles near the surface')
      call free_surface_lambda(c%prm%kernel, dim, n, n, x, c%m, c%rho, lam_diag)
      call assert_equal(lambda, lam_diag, 1e-12_wp, 'snapshot diagnostic = solver''s lambda')
      deallocate(x, lmat, lambda, lam_diag, outer, complete)
    end do
  end subroutine free_surface_disc

  !> (E8) On a regular lattice box: no shift inside (the kernel sum is
  !> uniform), none on the free surface, none near it either (0.55 <=
  !> lambda < 0.9: there the kernel-sum gradient is normal to the flat edge
  !> and is removed), except near the corners, where the normal is not
  !> along the lattice.  Without the free-surface treatment the edges would
  !> be pushed outwards.  (The next row in, lambda >= 0.9 but within a
  !> kernel support of the edge, is pushed outwards a little.)
  subroutine shift_lattice()
    type(cloud_t) :: c
    real(wp), allocatable :: dr(:, :), lambda(:)
    real(wp) :: coef, d
    integer :: i, moved_edges
    real(wp) :: dd(2)
    call make_cloud(c, 2, 16, 0.0_wp, 120)
    c%rho = 1
    c%m = c%dx**2
    allocate(dr(3, c%n), lambda(c%n))
    coef = 0.01_wp * c%prm%kernel%h**2
    call rhs_shift(c%prm, c%n, c%n, c%x, c%rho, c%m, c%nl, coef, c%dx, dr, lambda)
    moved_edges = 0
    do i = 1, c%n
      dd = 1 - abs(c%x(1:2, i))                ! distances to the edges
      d = minval(dd)
      if (lambda(i) < LAMBDA_SURFACE) then
        call assert_equal(0.0_wp, norm2(dr(:, i)), 0.0_wp, 'no shift on the free surface')
      else if (d > c%prm%kernel%support) then
        call assert_equal(0.0_wp, norm2(dr(:, i)), 1e-15_wp, 'no shift inside')
      else if (lambda(i) < LAMBDA_NEAR .and. maxval(dd) > 2 * c%prm%kernel%support) then
        ! near one edge only, away from the corners
        call assert_equal(0.0_wp, norm2(dr(:, i)), 1e-15_wp, 'no normal shift near the surface')
        moved_edges = moved_edges + 1
      end if
    end do
    call assert_true(moved_edges > 50, 'near-surface particles checked')
  end subroutine shift_lattice

  !> (E8) Repeated shifts regularise a jittered lattice: the disorder,
  !> measured as the RMS over the particles inside of h |Sum_j g V_j| (zero
  !> on a regular lattice), falls by more than half in 10 shifts of
  !> 0.02 h^2 Sum (...) (about 0.03 dx per shift at the start).
  subroutine shift_relaxes()
    type(cloud_t) :: c
    real(wp), allocatable :: dr(:, :), lambda(:)
    real(wp) :: coef, dis0, dis
    integer :: it
    call make_cloud(c, 2, 12, 0.4_wp, 130)
    c%rho = 1
    c%m = c%dx**2
    allocate(dr(3, c%n), lambda(c%n))
    coef = 0.2_wp * c%prm%kernel%h**2
    dis0 = disorder()
    do it = 1, 10
      call neighbour_build(c%nl, 2, c%n, c%n, c%x, [(int(it, i8), it = 1, c%n)], &
                           c%prm%kernel%support, minval(c%x, dim=2))
      call rhs_shift(c%prm, c%n, c%n, c%x, c%rho, c%m, c%nl, coef, c%dx, dr, lambda)
      c%x = c%x + dr
    end do
    dis = disorder()
    call assert_true(dis0 > 0.05_wp, 'the jittered lattice is disordered')
    call assert_true(dis < 0.5_wp * dis0, 'shifting halves the disorder')
  contains
    real(wp) function disorder()
      real(wp) :: s0(3), xij(3)
      integer :: i, j, cnt
      disorder = 0
      cnt = 0
      do i = 1, c%n
        if (maxval(abs(c%x(1:2, i))) > 1 - 1.5_wp * c%prm%kernel%support) cycle
        s0 = 0
        do j = 1, c%n
          xij = c%x(:, i) - c%x(:, j)
          if (j == i .or. norm2(xij) >= c%prm%kernel%support) cycle
          s0 = s0 + kernel_f(c%prm%kernel, norm2(xij)) * xij * c%m(j) / c%rho(j)
        end do
        disorder = disorder + (c%prm%kernel%h * norm2(s0))**2
        cnt = cnt + 1
      end do
      disorder = sqrt(disorder / cnt)
    end function disorder
  end subroutine shift_relaxes

  !> (E8) On a jittered box: free-surface particles do not move; near the
  !> surface (0.55 <= lambda < 0.9) the shift is orthogonal to the normal
  !> -M_i^-1 Sum_j g V_j (computed here by brute force); inside it is the
  !> full formula -coef Sum_j [1 + 0.2 (W_ij/W(dx))^4] g V_j.
  subroutine shift_surface()
    type(cloud_t) :: c
    real(wp), allocatable :: dr(:, :), lambda(:)
    real(wp) :: coef, s0(3), s1(3), mm(3, 3), xij(3), nu(3), w, wdx, full(3)
    integer :: i, j, near, inside
    call make_cloud(c, 2, 12, 0.5_wp, 140)
    allocate(dr(3, c%n), lambda(c%n))
    coef = 0.05_wp * c%prm%kernel%h**2
    call rhs_shift(c%prm, c%n, c%n, c%x, c%rho, c%m, c%nl, coef, c%dx, dr, lambda)
    wdx = kernel_w(c%prm%kernel, c%dx)
    near = 0
    inside = 0
    do i = 1, c%n
      s0 = 0; s1 = 0; mm = 0
      do j = 1, c%n
        xij = c%x(:, i) - c%x(:, j)
        if (j == i .or. norm2(xij) >= c%prm%kernel%support) cycle
        w = 1 + 0.2_wp * (kernel_w(c%prm%kernel, norm2(xij)) / wdx)**4
        s0 = s0 + kernel_f(c%prm%kernel, norm2(xij)) * xij * c%m(j) / c%rho(j)
        s1 = s1 + w * kernel_f(c%prm%kernel, norm2(xij)) * xij * c%m(j) / c%rho(j)
        mm(1:2, 1:2) = mm(1:2, 1:2) - c%m(j) / c%rho(j) * kernel_f(c%prm%kernel, norm2(xij)) &
                       * spread(xij(1:2), 2, 2) * spread(xij(1:2), 1, 2)
      end do
      full = -coef * s1
      if (lambda(i) < LAMBDA_SURFACE) then
        call assert_equal(0.0_wp, norm2(dr(:, i)), 0.0_wp, 'no shift on the free surface')
      else if (lambda(i) < LAMBDA_NEAR) then
        ! M^-1 s0 in 2D
        nu(1:2) = [mm(2, 2) * s0(1) - mm(1, 2) * s0(2), mm(1, 1) * s0(2) - mm(2, 1) * s0(1)]
        nu(3) = 0
        call assert_equal(0.0_wp, sum(dr(:, i) * nu) / norm2(nu), 1e-12_wp * norm2(full), &
                          'near the surface: no normal component')
        call assert_true(norm2(dr(:, i)) <= norm2(full) * (1 + 1e-12_wp), 'a projection')
        near = near + 1
      else
        call assert_equal(full, dr(:, i), 1e-12_wp * norm2(full), 'inside: the full shift')
        inside = inside + 1
      end if
    end do
    call assert_true(near > 50 .and. inside > 100, 'both kinds present')
  end subroutine shift_surface

  !> The corrected operators (higher-order gradient, renormalised
  !> divergence) and the shift on two pieces of a random cloud, each with
  !> halo copies of the other piece in another memory order, give the owned
  !> particles bit for bit the whole cloud's values (the canonical order of
  !> the pair sums; lambda of halo copies from the whole cloud, as the halo
  !> exchange brings it).
  subroutine bitwise_pieces()
    real(wp), allocatable :: x(:, :), u(:, :), rho(:), m(:), p(:), g(:, :), drho(:), du(:, :)
    real(wp), allocatable :: lmat(:, :), lambda(:), dr(:, :), lam_s(:), r(:)
    integer(i8), allocatable :: id(:)
    type(neighbour_list_t) :: nl
    type(rhs_params_t) :: prm
    integer :: dim, ntot, piece, k, nmis, i
    real(wp) :: radius, lo(3), coef
    do dim = 2, 3
      ntot = merge(1500, 2500, dim == 2)
      allocate(x(3, ntot), u(3, ntot), rho(ntot), m(ntot), p(ntot), g(3, ntot), drho(ntot), &
               du(3, ntot), id(ntot), lmat(6, ntot), lambda(ntot), dr(3, ntot), lam_s(ntot), &
               r(ntot))
      call random_number(x)
      if (dim == 2) x(3, :) = 0
      call random_number(u)
      u = u - 0.5_wp
      if (dim == 2) u(3, :) = 0
      call random_number(rho)
      rho = 1 + 0.01_wp * rho
      m = rho * (1.0_wp / ntot)
      p = 100 * (rho - 1)
      g = 0
      call random_number(r)
      id = [(int(mod(7919_i8 * i, 4_i8 * ntot + 1) + 1, i8), i = 1, ntot)]
      prm%dim = dim
      prm%kernel = kernel_init(KERNEL_WENDLAND_C2, dim, merge(0.03_wp, 0.07_wp, dim == 2))
      prm%viscosity = VISC_DELTA
      prm%diffusion = DIFF_MOLTENI
      prm%pressure_gradient = PGRAD_HIGHER_ORDER
      prm%divergence = DIV_RENORMALISED
      prm%tensile_eps = 0.4_wp
      prm%tensile_dx = prm%kernel%h / 2
      coef = 0.1_wp * prm%kernel%h**2
      radius = 1.15_wp * prm%kernel%support
      lo = minval(x, dim=2)
      call neighbour_build(nl, dim, ntot, ntot, x, id, radius, lo)
      call rhs_renormalisation(prm, ntot, ntot, x, rho, m, nl, lambda, lmat)
      call rhs_evaluate(prm, ntot, ntot, x, u, rho, m, p, g, nl, drho, du, lambda, lmat)
      call rhs_shift(prm, ntot, ntot, x, rho, m, nl, coef, prm%tensile_dx, dr, lam_s)
      call assert_true(count(lambda >= LAMBDA_NEAR) > ntot / 20 .and. &
                       count(lambda < LAMBDA_SURFACE) > ntot / 100, 'all zones present')
      nmis = 0
      do piece = 1, 2
        call compare_piece(piece, nmis)
      end do
      call assert_equal(0, nmis, 'owned particles whose values differ in any bit')
      deallocate(x, u, rho, m, p, g, drho, du, id, lmat, lambda, dr, lam_s, r)
    end do
  contains
    subroutine compare_piece(piece, nmis)
      integer, intent(in) :: piece
      integer, intent(inout) :: nmis
      integer, allocatable :: sel(:)
      logical, allocatable :: own(:), halo(:)
      real(wp), allocatable :: lp(:, :), lap(:), drp(:), dup(:, :), drs(:, :), las(:)
      integer :: n_own, nt
      allocate(own(ntot), halo(ntot))
      own = (x(1, :) < 0.5_wp) .eqv. (piece == 1)
      halo = .not. own .and. abs(x(1, :) - 0.5_wp) < radius
      allocate(sel(count(own) + count(halo)))
      sel = [pack([(i, i = ntot, 1, -1)], own(ntot:1:-1)), pack([(i, i = 1, ntot)], halo)]
      n_own = count(own)
      nt = size(sel)
      call neighbour_build(nl, dim, n_own, nt, x(:, sel), id(sel), radius, lo)
      allocate(lp(6, nt), lap(nt), drp(nt), dup(3, nt), drs(3, nt), las(nt))
      call rhs_renormalisation(prm, n_own, nt, x(:, sel), rho(sel), m(sel), nl, lap, lp)
      lap(n_own + 1:nt) = lambda(sel(n_own + 1:nt))      ! the halo exchange of lambda
      call rhs_evaluate(prm, n_own, nt, x(:, sel), u(:, sel), rho(sel), m(sel), p(sel), &
                        g(:, sel), nl, drp, dup, lap, lp)
      call rhs_shift(prm, n_own, nt, x(:, sel), rho(sel), m(sel), nl, coef, prm%tensile_dx, &
                     drs, las)
      do k = 1, n_own
        i = sel(k)
        if (.not. (same_bits([drp(k)], [drho(i)]) .and. same_bits(dup(:, k), du(:, i)) &
                   .and. same_bits(drs(:, k), dr(:, i)) .and. same_bits([lap(k)], [lambda(i)]))) &
          nmis = nmis + 1
      end do
    end subroutine compare_piece
  end subroutine bitwise_pieces

end module test_fluid_rhs
