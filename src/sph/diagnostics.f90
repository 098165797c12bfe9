!> Global diagnostics of the particle state (doc/theory/ D1, D2, D4),
!> reduced over all ranks.  With mirror planes (the optional mask, mirrors)
!> they are the whole body's: the part's sums times the copies, the
!> centre of mass on the planes, and the probes summing over the owned
!> particles and their reflections (never over the halo slots, whose real
!> copies would count twice).
module diagnostics
  use kinds, only: wp
  use particles, only: particles_t
  use mirrors, only: mirror_copies, mirror_codes, reflect
  use kernels, only: kernel_t, kernel_w
  use sym3, only: solve_spd
  use parallel_env, only: parallel_env_t, par_sum, par_sum_array, par_sum_exact
  use, intrinsic :: ieee_arithmetic, only: ieee_value, ieee_quiet_nan, ieee_is_finite
  implicit none
  private
  public :: kinetic_energy, total_mass, total_momentum, probe_pressure, fitted_semi_axes, &
            find_bad_particle, nan_value, probe_pressure_quadratic

contains

  !> (D1) 1/2 Sum m |u|^2
  function kinetic_energy(env, parts, mirror) result(ke)
    type(parallel_env_t), intent(in) :: env
    type(particles_t), intent(in) :: parts
    integer, intent(in), optional :: mirror
    real(wp) :: ke
    integer :: n
    n = parts%n
    ke = par_sum(env, 0.5_wp * sum(parts%m(1:n) * sum(parts%u(:, 1:n)**2, dim=1)))
    ke = ke * copies(mirror)
  end function kinetic_energy

  function total_mass(env, parts, mirror) result(mass)
    type(parallel_env_t), intent(in) :: env
    type(particles_t), intent(in) :: parts
    integer, intent(in), optional :: mirror
    real(wp) :: mass
    mass = par_sum(env, sum(parts%m(1:parts%n))) * copies(mirror)
  end function total_mass

  !> The whole body's momentum: 0 along a plane's normal.
  function total_momentum(env, parts, mirror) result(mom)
    type(parallel_env_t), intent(in) :: env
    type(particles_t), intent(in) :: parts
    integer, intent(in), optional :: mirror
    real(wp) :: mom(3)
    integer :: k
    do k = 1, 3
      mom(k) = sum(parts%m(1:parts%n) * parts%u(k, 1:parts%n))
    end do
    call par_sum_array(env, mom)
    mom = mom * copies(mirror)
    do k = 1, 3
      if (btest(mask(mirror), k - 1)) mom(k) = 0
    end do
  end function total_momentum

  !> The copies of the part in the whole body (1 without planes).
  pure integer function copies(mirror)
    integer, intent(in), optional :: mirror
    copies = mirror_copies(mask(mirror))
  end function copies

  pure integer function mask(mirror)
    integer, intent(in), optional :: mirror
    mask = 0
    if (present(mirror)) mask = mirror
  end function mask

  !> The reflections a point sums over: 0 (the particle), then the codes.
  pure function all_codes(mirror) result(codes)
    integer, intent(in), optional :: mirror
    integer, allocatable :: codes(:)
    codes = [0, mirror_codes(mask(mirror))]
  end function all_codes

  !> (D4) Shepard-normalised kernel interpolation of the pressure at a point:
  !> p(x) = Sum_j p_j W(x - x_j) V_j / Sum_j W(x - x_j) V_j.  NaN when no
  !> particle lies within the kernel support of the point.
  function probe_pressure(env, parts, kernel, point, mirror) result(p)
    type(parallel_env_t), intent(in) :: env
    type(particles_t), intent(in) :: parts
    type(kernel_t), intent(in) :: kernel
    real(wp), intent(in) :: point(3)
    integer, intent(in), optional :: mirror
    real(wp) :: p, sums(2), w, r2, s2
    integer, allocatable :: codes(:)
    integer :: j, c
    sums = 0
    s2 = kernel%support**2
    allocate(codes, source=all_codes(mirror))
    do j = 1, parts%n
      do c = 1, size(codes)
        r2 = sum((reflect(parts%x(:, j), codes(c)) - point)**2)
        if (r2 >= s2) cycle
        w = kernel_w(kernel, sqrt(r2)) * parts%m(j) / parts%rho(j)
        sums = sums + [w * parts%p(j), w]
      end do
    end do
    call par_sum_array(env, sums)
    if (sums(2) > 0) then
      p = sums(1) / sums(2)
    else
      p = nan_value()
    end if
  end function probe_pressure

  !> (D5) The pressure at a point from the quadratic polynomial fitted to the
  !> particle pressures within the kernel support by weighted least squares,
  !>   min Sum_j W(|x - x_j|) V_j (p_j - q(x_j - x))^2,  q in span{1, xi_a, xi_a xi_b},
  !> its value q(0): exact for any quadratic pressure field, where the Shepard
  !> probe (D4) is off by about (h^2/2) <r^2>_W laplacian(p) (0.56 h^2 P/R^2 at
  !> the centre of the circular patch).  The sums are exact (par_sum_exact):
  !> the value is bitwise the same on any number of ranks.  Falls back to D4
  !> where the fit is ill-posed (fewer than 3 (dim + 1) particles, or a
  !> pivot of the normal matrix below 1e-10 of its largest diagonal entry).
  function probe_pressure_quadratic(env, parts, kernel, point, mirror) result(p)
    type(parallel_env_t), intent(in) :: env
    type(particles_t), intent(in) :: parts
    type(kernel_t), intent(in) :: kernel
    real(wp), intent(in) :: point(3)
    integer, intent(in), optional :: mirror
    real(wp) :: p
    real(wp), allocatable :: terms(:, :), sums(:), a(:, :), b(:, :)
    real(wp) :: phi(10), xi(3), w, r2, y(3)
    integer, allocatable :: near(:), near_code(:), codes(:)
    integer :: nb, nt, j, k, l, c, m, dim, nn
    dim = parts%dim
    nb = merge(6, 10, dim == 2)              ! 1, xi_a, xi_a xi_b
    nt = nb * (nb + 1) / 2 + nb + 1          ! the normal matrix, the right-hand side, the count
    allocate(codes, source=all_codes(mirror))
    allocate(near(parts%n * size(codes)), near_code(parts%n * size(codes)))
    nn = 0
    do j = 1, parts%n
      do c = 1, size(codes)
        if (sum((reflect(parts%x(:, j), codes(c)) - point)**2) >= kernel%support**2) cycle
        nn = nn + 1
        near(nn) = j
        near_code(nn) = codes(c)
      end do
    end do
    allocate(terms(nt, nn))
    do m = 1, nn
      j = near(m)
      y = reflect(parts%x(:, j), near_code(m))
      r2 = sum((y - point)**2)
      w = kernel_w(kernel, sqrt(r2)) * parts%m(j) / parts%rho(j)
      xi = (y - point) / kernel%h
      phi(1:nb) = quadratic_basis(dim, xi)
      c = 0
      do k = 1, nb
        do l = k, nb
          c = c + 1
          terms(c, m) = w * phi(k) * phi(l)
        end do
      end do
      terms(c + 1:c + nb, m) = w * parts%p(j) * phi(1:nb)
      terms(nt, m) = 1
    end do
    sums = par_sum_exact(env, terms)
    ! the fallback, on every rank (a collective call)
    p = probe_pressure(env, parts, kernel, point, mirror)
    if (nint(sums(nt)) < 3 * (dim + 1)) return
    allocate(a(nb, nb), b(nb, 1))
    c = 0
    do k = 1, nb
      do l = k, nb
        c = c + 1
        a(k, l) = sums(c)
        a(l, k) = sums(c)
      end do
    end do
    b(:, 1) = sums(c + 1:c + nb)
    if (solve_spd(a, b, 1e-10_wp)) p = b(1, 1)
  end function probe_pressure_quadratic

  !> The quadratic monomials of xi: 1, xi_a, xi_a xi_b (a <= b) in dim dimensions.
  pure function quadratic_basis(dim, xi) result(phi)
    integer, intent(in) :: dim
    real(wp), intent(in) :: xi(3)
    real(wp) :: phi(merge(6, 10, dim == 2))
    if (dim == 2) then
      phi = [1.0_wp, xi(1), xi(2), xi(1)**2, xi(1) * xi(2), xi(2)**2]
    else
      phi = [1.0_wp, xi(1), xi(2), xi(3), xi(1)**2, xi(1) * xi(2), xi(1) * xi(3), xi(2)**2, &
             xi(2) * xi(3), xi(3)**2]
    end if
  end function quadratic_basis

  !> (D2) Semi-axes of the ellipse (ellipsoid) with the particles' second moments
  !> about their centre of mass: a_k = 2 sqrt(<x_k^2>) in 2D, sqrt(5 <x_k^2>)
  !> in 3D (uniform ellipse / ellipsoid).  x is either the particle positions
  !> or any other per-particle points (e.g. the exact Lagrangian map).  With
  !> planes the moments of the part are the body's, whose centre lies on the
  !> planes.
  function fitted_semi_axes(env, dim, n, m, x, mirror) result(axes)
    type(parallel_env_t), intent(in) :: env
    integer, intent(in) :: dim, n
    real(wp), intent(in) :: m(:), x(:, :)
    integer, intent(in), optional :: mirror
    real(wp) :: axes(3), s(7), c(3)
    integer :: k
    s = 0
    s(1) = sum(m(1:n))
    do k = 1, 3
      s(1 + k) = sum(m(1:n) * x(k, 1:n))
      s(4 + k) = sum(m(1:n) * x(k, 1:n)**2)
    end do
    call par_sum_array(env, s)
    c = s(2:4) / s(1)
    do k = 1, 3
      if (btest(mask(mirror), k - 1)) c(k) = 0
    end do
    axes = 0
    do k = 1, dim
      axes(k) = sqrt(max(0.0_wp, s(4 + k) / s(1) - c(k)**2) * merge(4.0_wp, 5.0_wp, dim == 2))
    end do
  end function fitted_semi_axes

  !> The first particle whose state is not finite or whose density is not
  !> positive, or that is across a mirror plane (0 when all are sound; M4
  !> trades one that crossed in a step for its image, M5 lets one lie on
  !> a plane).
  function find_bad_particle(parts, mirror) result(i_bad)
    type(particles_t), intent(in) :: parts
    integer, intent(in), optional :: mirror
    integer :: i_bad, i, k
    i_bad = 0
    do i = 1, parts%n
      if (.not. (all(ieee_is_finite(parts%x(:, i))) .and. all(ieee_is_finite(parts%u(:, i))) &
                 .and. ieee_is_finite(parts%rho(i)) .and. parts%rho(i) > 0)) then
        i_bad = i
        return
      end if
      do k = 1, 3
        if (btest(mask(mirror), k - 1) .and. .not. parts%x(k, i) >= 0) then
          i_bad = i
          return
        end if
      end do
    end do
  end function find_bad_particle

  function nan_value() result(v)
    real(wp) :: v
    v = ieee_value(1.0_wp, ieee_quiet_nan)
  end function nan_value

end module diagnostics
