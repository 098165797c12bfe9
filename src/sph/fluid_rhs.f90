!> The weakly-compressible SPH right-hand side (doc/theory.md E1-E9, H1).
!>
!> Notation: x_ij = x_i - x_j, r = |x_ij|, g = grad_i W_ij = F(r) x_ij with
!> F = W'/r < 0 (kernels module), V_j = m_j/rho_j, u_ji = u_j - u_i.  Pairs
!> come from a half list in canonical order (neighbours module): each pair
!> is computed once and added to i and, with grad_j W_ji = -g, to j, row by
!> row, so that every owned particle receives its terms in an order that
!> does not depend on the decomposition: results are bitwise the same for
!> any number of ranks.  Terms for halo copies land in slots that are
!> ignored (their owners compute them).
module fluid_rhs
  use kinds, only: wp, i8
  use kernels, only: kernel_t, kernel_f_list, kernel_w, kernel_w_list
  use neighbours, only: neighbour_list_t
  use sym3, only: sym_min_eigenvalue, invert_sym
  implicit none
  private
  public :: rhs_params_t, rhs_density_gradient, rhs_renormalisation, rhs_evaluate, rhs_shift, &
            LAMBDA_MIN, LAMBDA_SURFACE, LAMBDA_NEAR, pair_buffers, &
            in_range_pairs
  public :: VISC_NONE, VISC_DELTA, VISC_MONAGHAN, DIFF_NONE, DIFF_MOLTENI, DIFF_ANTUONO
  public :: PGRAD_STANDARD, PGRAD_HIGHER_ORDER, DIV_STANDARD, DIV_RENORMALISED

  integer, parameter :: VISC_NONE = 0, VISC_DELTA = 1, VISC_MONAGHAN = 2
  integer, parameter :: DIFF_NONE = 0, DIFF_MOLTENI = 1, DIFF_ANTUONO = 2
  !> (E4) -(1/rho_i) Sum_j (p_i + p_j) g V_j, or (H1) the corrected
  !> -(1/rho_i) L_i Sum_j (p_j - p_i) g V_j with p = 0 on the free surface
  integer, parameter :: PGRAD_STANDARD = 1, PGRAD_HIGHER_ORDER = 2
  !> (E1) the velocity divergence Sum_j u_ji . g V_j, or its renormalised
  !> form Sum_j u_ji . (L_i g) V_j, exact for linear velocity fields
  integer, parameter :: DIV_STANDARD = 1, DIV_RENORMALISED = 2
  real(wp), parameter :: LAMBDA_MIN = 0.1_wp   !< below it, M_i is not inverted
  !> (E9) Marrone et al. (2010): lambda_i, the smallest eigenvalue of M_i
  !> (= L_i^-1), is about 1 inside the fluid, 0.5 on a flat free surface;
  !> below LAMBDA_SURFACE a particle is on the free surface, below
  !> LAMBDA_NEAR near it.
  real(wp), parameter :: LAMBDA_SURFACE = 0.55_wp, LAMBDA_NEAR = 0.9_wp
  !> (H1) the higher-order gradient's weight rises linearly from 0 at
  !> LAMBDA_BLEND to 1 at LAMBDA_NEAR (doc/numerics.md, "the blend")
  real(wp), parameter :: LAMBDA_BLEND = 0.7_wp
  !> (H1) the corrected form's largest weight: a tenth of the
  !> conservative (E4) stays everywhere, whose term 2 p_i Sum_j g V_j pushes
  !> particles apart where they crowd; the corrected form alone has no such
  !> restoring force, and a stretched Lagrangian arrangement then grows
  !> particle-scale velocity noise (doc/numerics.md, "the blend")
  real(wp), parameter :: HO_WEIGHT_MAX = 0.9_wp
  !> (E8) the weight of the anti-clustering term R (W_ij/W(dx))^n of the
  !> shifting (Sun et al. 2017: R = 0.2, n = 4)
  real(wp), parameter :: SHIFT_R = 0.2_wp
  integer, parameter :: SHIFT_N = 4

  !> The physical and numerical constants of the right-hand side.
  type :: rhs_params_t
    type(kernel_t) :: kernel
    integer :: dim = 2
    real(wp) :: c0 = 10, rho0 = 1
    integer :: viscosity = VISC_DELTA
    real(wp) :: alpha = 0.01_wp
    integer :: diffusion = DIFF_MOLTENI
    real(wp) :: delta = 0.1_wp
    !> (E7) tensile instability control, on when tensile_eps > 0; tensile_dx
    !> is the particle spacing of W(dx) and must then be set.
    real(wp) :: tensile_eps = 0
    integer :: tensile_n = 4
    real(wp) :: tensile_dx = 0
    !> pressure gradient of the momentum equation: PGRAD_STANDARD (E4) or
    !> PGRAD_HIGHER_ORDER (H1, needs rhs_renormalisation first)
    integer :: pressure_gradient = PGRAD_STANDARD
    !> velocity divergence of the continuity equation: DIV_STANDARD (E1) or
    !> DIV_RENORMALISED (needs rhs_renormalisation first)
    integer :: divergence = DIV_STANDARD
    !> the corrected gradient's weight inside the fluid (H1, the
    !> blend); 1 gives the corrected form alone (the unit tests of its
    !> exactness use that)
    real(wp) :: ho_weight = HO_WEIGHT_MAX
  end type rhs_params_t

contains

  !> First pass of delta-SPH with the Antuono correction: the renormalised
  !> density gradient (E2, E3) G_i = L_i Sum_j (rho_j - rho_i) g V_j
  !> (rhs_renormalisation).  Halo values are zero: they come from their
  !> owners by an exchange.
  subroutine rhs_density_gradient(prm, n, ntot, x, rho, m, nl, grad_rho)
    type(rhs_params_t), intent(in) :: prm
    integer, intent(in) :: n, ntot
    real(wp), intent(in) :: x(3, ntot), rho(ntot), m(ntot)
    type(neighbour_list_t), intent(in) :: nl
    real(wp), intent(out) :: grad_rho(3, ntot)
    real(wp), allocatable :: lambda(:)
    allocate(lambda(ntot))
    call rhs_renormalisation(prm, n, ntot, x, rho, m, nl, lambda, grad_rho=grad_rho)
  end subroutine rhs_density_gradient

  !> The free-surface indicator (E9) of the n owned particles, and
  !> optionally the renormalisation matrix (E3) and the renormalised density
  !> gradient:
  !>   M_i = Sum_j V_j g (x_j - x_i)^T = - Sum_j V_j F x_ij x_ij^T,
  !>   lambda_i = smallest eigenvalue of M_i, L_i = M_i^-1,
  !>   G_i = L_i Sum_j (rho_j - rho_i) g V_j   (E2),
  !> so that L_i Sum_j (f_j - f_i) g V_j is exact for every linear f.  Where
  !> M_i is nearly singular (isolated particles, thin filaments: lambda_i
  !> below LAMBDA_MIN, against 1 in the bulk and about 0.5 on a flat free
  !> surface) L_i = I is used instead.  lmat holds the symmetric L_i as
  !> (xx, yy, zz, xy, xz, yz).  Halo slots of lambda, lmat and grad_rho
  !> are zero: their owners compute them (exchange lambda and G if needed).
  subroutine rhs_renormalisation(prm, n, ntot, x, rho, m, nl, lambda, lmat, grad_rho)
    type(rhs_params_t), intent(in) :: prm
    integer, intent(in) :: n, ntot
    real(wp), intent(in) :: x(3, ntot), rho(ntot), m(ntot)
    type(neighbour_list_t), intent(in) :: nl
    real(wp), intent(out) :: lambda(ntot)
    real(wp), intent(out), optional :: lmat(6, ntot), grad_rho(3, ntot)
    real(wp), allocatable :: mm(:, :)   ! symmetric M: xx, yy, zz, xy, xz, yz
    real(wp), allocatable :: vol(:)
    real(wp), allocatable :: xl(:, :), r2l(:), fl(:)
    integer, allocatable :: jl(:)
    real(wp) :: xij(3), f, g(3), vi, vj, drho, s2, inv(3, 3), det, xx(6)
    real(wp) :: gi(3), mi(6)
    integer :: i, j, l, nn, kk
    logical :: with_g
    with_g = present(grad_rho)
    allocate(mm(6, ntot), vol(ntot))
    mm = 0
    vol = m(1:ntot) / rho(1:ntot)
    if (with_g) grad_rho = 0
    s2 = prm%kernel%support**2
    call pair_buffers(nl, jl, xl, r2l, fl)
    do kk = 1, nl%n_rows
      i = nl%row(kk)
      call in_range_pairs(kk, i, x, s2, nl, nn, jl, xl, r2l)
      call kernel_f_list(prm%kernel, nn, r2l, fl)
      vi = vol(i)
      gi = 0
      mi = 0
      do l = 1, nn
        j = jl(l)
        xij = xl(:, l)
        f = fl(l)
        vj = vol(j)
        if (with_g) then
          g = f * xij
          drho = rho(j) - rho(i)
          ! (rho_j - rho_i) g V_j for i; (rho_i - rho_j)(-g) V_i for j
          gi = gi + drho * vj * g
          grad_rho(:, j) = grad_rho(:, j) + drho * vi * g
        end if
        xx = moment_term(f, xij)
        mi = mi + vj * xx
        mm(:, j) = mm(:, j) + vi * xx
      end do
      if (with_g) grad_rho(:, i) = grad_rho(:, i) + gi
      mm(:, i) = mm(:, i) + mi
    end do
    lambda = 0
    if (present(lmat)) lmat = 0
    do i = 1, n
      lambda(i) = sym_min_eigenvalue(prm%dim, mm(:, i))
      if (present(lmat)) lmat(1:prm%dim, i) = 1      ! L = I unless M_i is well conditioned
      if (lambda(i) < LAMBDA_MIN) cycle
      call invert_sym(prm%dim, mm(:, i), inv, det)
      if (present(lmat)) lmat(:, i) = [inv(1, 1), inv(2, 2), inv(3, 3), inv(1, 2), inv(1, 3), &
                                       inv(2, 3)]
      if (with_g) grad_rho(:, i) = matmul(inv, grad_rho(:, i))
    end do
    if (with_g) grad_rho(:, n + 1:ntot) = 0   ! halo values come from their owners
  end subroutine rhs_renormalisation

  !> (E3) The term of one pair in M_i, the same in M_j: -F x_ij x_ij^T,
  !> packed as (xx, yy, zz, xy, xz, yz) (sym3).  The one definition of M:
  !> the renormalisation and the shifting both accumulate it.
  pure function moment_term(f, xij) result(xx)
    real(wp), intent(in) :: f, xij(3)
    real(wp) :: xx(6)
    xx = -f * [xij(1)**2, xij(2)**2, xij(3)**2, &
               xij(1) * xij(2), xij(1) * xij(3), xij(2) * xij(3)]
  end function moment_term

  !> Work arrays for the in-range partners of one particle, sized by the
  !> longest row of the list.
  subroutine pair_buffers(nl, jl, xl, r2l, fl)
    type(neighbour_list_t), intent(in) :: nl
    integer, allocatable, intent(out) :: jl(:)
    real(wp), allocatable, intent(out) :: xl(:, :), r2l(:), fl(:)
    integer :: longest
    longest = 1
    if (nl%n_rows > 0) &
      longest = max(1, int(maxval(nl%start(2:nl%n_rows + 1) - nl%start(1:nl%n_rows))))
    allocate(jl(longest + 1), xl(3, longest + 1), r2l(longest + 1), fl(longest + 1))
  end subroutine pair_buffers

  !> The partners j in row kk (of particle i) that lie within the kernel
  !> support (r^2 < s2), with x_ij and r^2: the list's skin makes most of
  !> the rest fall outside, so filtering first saves the kernel work.
  pure subroutine in_range_pairs(kk, i, x, s2, nl, nn, jl, xl, r2l)
    integer, intent(in) :: kk, i
    real(wp), intent(in) :: x(:, :), s2
    type(neighbour_list_t), intent(in) :: nl
    integer, intent(out) :: nn
    integer, intent(inout) :: jl(:)
    real(wp), intent(inout) :: xl(:, :), r2l(:)
    real(wp) :: xij(3), r2
    integer :: j
    integer(i8) :: k
    ! branchless compaction: always store in the next free slot, advance
    ! only when in range (the test is too random for branch prediction)
    nn = 0
    do k = nl%start(kk), nl%start(kk + 1) - 1
      j = nl%nbr(k)
      xij = x(:, i) - x(:, j)
      r2 = xij(1)**2 + xij(2)**2 + xij(3)**2
      jl(nn + 1) = j
      xl(:, nn + 1) = xij
      r2l(nn + 1) = r2
      nn = nn + merge(1, 0, r2 < s2)
    end do
  end subroutine in_range_pairs

  !> Time derivatives of density and velocity of the n owned particles.
  !>  (E1) D rho_i/Dt = -rho_i Sum_j u_ji . g V_j + D_i
  !>  (E2) D_i = delta h c0 Sum_j psi_ij . g V_j,
  !>       psi_ij = 2 (rho_j - rho_i) (x_j - x_i)/r^2 - (G_i + G_j)
  !>  (E4) D u_i/Dt = -(1/rho_i) Sum_j (p_i + p_j) g V_j + visc_i
  !>  (E5) visc_i = alpha h c0 (rho0/rho_i) Sum_j pi_ij g V_j,
  !>       pi_ij = u_ji . (x_j - x_i)/r^2;  or Monaghan's Pi_ij.
  !>  (E7) tens_i = -Sum_j m_j (R_i + R_j) (W_ij/W(dx))^n g, R_i = eps |p_i|/rho_i^2
  !>       where p_i < 0, else 0 (Monaghan 2000): a repulsion between
  !>       particles under tension, antisymmetric like the pressure term.
  !> (H1) prm%pressure_gradient = PGRAD_HIGHER_ORDER: inside the fluid
  !> (lambda_i >= LAMBDA_NEAR, E9) the pressure part of (E4) becomes the
  !> consistent, corrected form
  !>       -(1/rho_i) L_i Sum_j (p_j - p_i) g V_j,
  !>   exact for a linear pressure, with p = 0 imposed on the free-surface
  !>   particles (lambda < LAMBDA_SURFACE).  On and near the free surface
  !>   (lambda_i <= LAMBDA_BLEND) the particle keeps the conservative (E4):
  !>   there the corrected form, with its truncated kernel and L_i far from
  !>   I, was measured unstable (doc/numerics.md: the rotating square and
  !>   the circle blow up by t = 0.5/omega, 0.8/A0, whether L_i is used or
  !>   not on the surface).  Between, the two forms are blended with the
  !>   weight w_i = (lambda_i - LAMBDA_BLEND)/(LAMBDA_NEAR - LAMBDA_BLEND)
  !>   of the corrected one: a stretched arrangement lowers lambda inside
  !>   the fluid too, and a hard switch there turned bulk particles to (E4)
  !>   one by one.  Inside, the weight is prm%ho_weight (0.9), not 1 (measured in
  !>   doc/numerics.md).  Not conservative.
  !> prm%divergence = DIV_RENORMALISED: the velocity divergence of (E1) is
  !>   Sum_j u_ji . (L_i g) V_j, exact for linear velocity fields (the
  !>   standard sum is not near the free surface, where it makes the density
  !>   drift).
  !> L_i = M_i^-1 (E3; I where lambda_i < LAMBDA_MIN) comes from the first
  !> pass (rhs_renormalisation: lmat), which the renormalised operators
  !> need; each pair then uses L_i g for i and L_j g for j, so the
  !> corrected terms go into the same canonical-order sums as the others.
  !> For the pressure gradient, lambda must hold the free-surface indicator
  !> of the owned particles and halo copies (rhs_renormalisation, then the
  !> halo exchange).  grad_rho (G) is used only with the Antuono diffusion
  !> and must then hold valid values for halo copies too.
  subroutine rhs_evaluate(prm, n, ntot, x, u, rho, m, p, grad_rho, nl, drho, du, lambda, &
                          lmat)
    type(rhs_params_t), intent(in) :: prm
    integer, intent(in) :: n, ntot
    real(wp), intent(in) :: x(3, ntot), u(3, ntot), rho(ntot), m(ntot), p(ntot)
    real(wp), intent(in) :: grad_rho(3, ntot)
    type(neighbour_list_t), intent(in) :: nl
    real(wp), intent(out) :: drho(ntot), du(3, ntot)
    real(wp), intent(in), optional :: lambda(ntot), lmat(:, :)
    real(wp) :: xij(3), uji(3), g(3), r2, f, s2, h, eta2
    real(wp) :: div_i, div_j, dterm, a, coef_visc, diff_coef, xu, vi, vj, iri, irj
    real(wp) :: drho_i, du_i(3), rhoi, pi_, pp, dp, li(6), lgi(3), lgj(3), wi, wj
    real(wp), allocatable :: vol(:), inv_rho(:), xl(:, :), r2l(:), fl(:), rt(:), wl(:)
    real(wp), allocatable :: pf(:), wc(:)
    real(wp) :: inv_wdx
    integer, allocatable :: jl(:)
    integer :: i, j, l, nn, kk
    logical :: antuono, tensile, corrected, renorm_div, renorm
    h = prm%kernel%h
    s2 = prm%kernel%support**2
    eta2 = 0.01_wp * h**2
    coef_visc = 0
    if (prm%viscosity == VISC_DELTA) coef_visc = prm%alpha * h * prm%c0 * prm%rho0
    diff_coef = 0
    if (prm%diffusion /= DIFF_NONE) diff_coef = prm%delta * h * prm%c0
    antuono = prm%diffusion == DIFF_ANTUONO
    ! per-particle V = m/rho and 1/rho: no division inside the pair loop
    allocate(vol(ntot), inv_rho(ntot))
    inv_rho = 1 / rho(1:ntot)
    vol = m(1:ntot) * inv_rho
    call pair_buffers(nl, jl, xl, r2l, fl)
    ! (E7): R_i per particle, 1/W(dx), and W for each row
    tensile = prm%tensile_eps > 0
    inv_wdx = 0
    if (tensile) then
      if (.not. prm%tensile_dx > 0) error stop 'rhs_evaluate: tensile control needs tensile_dx'
      allocate(rt(ntot), wl(size(r2l)))
      rt = prm%tensile_eps * max(0.0_wp, -p(1:ntot)) * inv_rho**2
      inv_wdx = 1 / kernel_w(prm%kernel, prm%tensile_dx)
    end if
    ! The corrected operators use L_i g in place of g, L_i from the first
    ! pass (lmat).  Halo slots of L are zero: the terms they give to halo
    ! copies are discarded below anyway.
    corrected = prm%pressure_gradient == PGRAD_HIGHER_ORDER
    renorm_div = prm%divergence == DIV_RENORMALISED
    renorm = corrected .or. renorm_div
    if (renorm .and. .not. present(lmat)) &
      error stop 'rhs_evaluate: the renormalised operators need lmat (rhs_renormalisation)'
    ! (H1): the pressure with p = 0 on the free surface (pf), and the
    ! weight wc of the consistent form: prm%ho_weight inside the fluid
    ! (lambda >= LAMBDA_NEAR), 0 (the conservative E4) on the surface and
    ! near it (lambda <= LAMBDA_BLEND), linear in lambda between
    if (corrected) then
      if (.not. present(lambda)) error stop 'rhs_evaluate: the higher-order gradient needs lambda'
      allocate(pf(ntot), wc(ntot))
      pf = merge(0.0_wp, p(1:ntot), lambda(1:ntot) < LAMBDA_SURFACE)
      wc = prm%ho_weight * max(0.0_wp, min(1.0_wp, (lambda(1:ntot) - LAMBDA_BLEND) &
                                               / (LAMBDA_NEAR - LAMBDA_BLEND)))
    end if
    li = 0
    lgi = 0
    lgj = 0
    wi = 0
    drho = 0
    du = 0
    do kk = 1, nl%n_rows
      i = nl%row(kk)
      call in_range_pairs(kk, i, x, s2, nl, nn, jl, xl, r2l)
      call kernel_f_list(prm%kernel, nn, r2l, fl)
      if (tensile) call kernel_w_list(prm%kernel, nn, r2l, wl)
      rhoi = rho(i)
      iri = inv_rho(i)
      vi = vol(i)
      pi_ = p(i)
      if (renorm) li = lmat(:, i)
      if (corrected) wi = wc(i)
      drho_i = 0
      du_i = 0
      do l = 1, nn
        j = jl(l)
        xij = xl(:, l)
        r2 = r2l(l)
        f = fl(l)
        g = f * xij
        vj = vol(j)
        irj = inv_rho(j)
        uji = u(:, j) - u(:, i)
        if (renorm) then
          ! L_i g and L_j g (L symmetric: xx, yy, zz, xy, xz, yz)
          lgi = sym_times(li, g)
          lgj = sym_times(lmat(:, j), g)
        end if
        ! (E1): the pair's velocity divergence u_ji . g, for i and for j
        ! (grad_j W_ji = -g, u_ij = -u_ji); renormalised u_ji . L_i g and
        ! u_ji . L_j g, exact for linear velocity fields
        if (renorm_div) then
          div_i = uji(1) * lgi(1) + uji(2) * lgi(2) + uji(3) * lgi(3)
          div_j = uji(1) * lgj(1) + uji(2) * lgj(2) + uji(3) * lgj(3)
        else
          div_i = uji(1) * g(1) + uji(2) * g(2) + uji(3) * g(3)
          div_j = div_i
        end if
        ! (E2): (x_j - x_i) . g / r^2 = -F, so the first part of psi . g is
        ! -2 (rho_j - rho_i) F; psi_ji = psi_ij and grad_j W_ji = -g.
        dterm = -2 * (rho(j) - rhoi) * f
        if (antuono) dterm = dterm - sum((grad_rho(:, i) + grad_rho(:, j)) * g)
        dterm = diff_coef * dterm
        drho_i = drho_i + (-rhoi * div_i + dterm) * vj
        drho(j) = drho(j) + (-rho(j) * div_j - dterm) * vi
        ! (E4) + (E5): du_i = A V_j/rho_i g, du_j = -A V_i/rho_j g, with
        ! A = -(p_i + p_j) + the viscous term
        xu = -(uji(1) * xij(1) + uji(2) * xij(2) + uji(3) * xij(3))   ! u_ji . (x_j - x_i)
        pp = pi_ + p(j)
        a = 0
        if (.not. corrected) a = -pp
        select case (prm%viscosity)
        case (VISC_DELTA)
          a = a + coef_visc * xu / r2
        case (VISC_MONAGHAN)
          ! Pi_ij = -alpha c0 mu_ij / rhobar for approaching pairs, with
          ! u_ij . x_ij = u_ji . (x_j - x_i) = xu; du_i = -m_j Pi_ij g.
          if (xu < 0) a = a + prm%alpha * prm%c0 * h * xu / (r2 + eta2) &
                          / (0.5_wp * (rhoi + rho(j))) * rhoi * rho(j)
        end select
        ! (E7): -m_j (R_i + R_j) f^n g = A V_j/rho_i g with A = -rho_i rho_j (R_i + R_j) f^n
        if (tensile) a = a - rhoi * rho(j) * (rt(i) + rt(j)) * (wl(l) * inv_wdx)**prm%tensile_n
        du_i = du_i + (a * vj * iri) * g
        du(:, j) = du(:, j) - (a * vi * irj) * g
        if (corrected) then
          ! (H1): -(1/rho_i) (p_j - p_i) L_i g V_j inside the fluid,
          ! -(1/rho_i) (p_i + p_j) g V_j (E4) near the surface; for j,
          ! -(1/rho_j) (p_i - p_j) L_j (-g) V_i or +(1/rho_j) (p_i + p_j) g V_i
          dp = pf(j) - pf(i)
          wj = wc(j)
          du_i = du_i - (vj * iri) * ((wi * dp) * lgi + ((1 - wi) * pp) * g)
          du(:, j) = du(:, j) + (vi * irj) * (((1 - wj) * pp) * g - (wj * dp) * lgj)
        end if
      end do
      ! the terms from partners earlier in canonical order are already in
      ! drho(i), du(:, i): the row's own sum comes after them
      drho(i) = drho(i) + drho_i
      du(:, i) = du(:, i) + du_i
    end do
    ! halo slots hold partial sums: their owners compute the real values
    drho(n + 1:ntot) = 0
    du(:, n + 1:ntot) = 0

  contains

    !> L v for a symmetric L stored as (xx, yy, zz, xy, xz, yz)
    pure function sym_times(ls, v) result(w)
      real(wp), intent(in) :: ls(6), v(3)
      real(wp) :: w(3)
      w = [ls(1) * v(1) + ls(4) * v(2) + ls(5) * v(3), &
           ls(4) * v(1) + ls(2) * v(2) + ls(6) * v(3), &
           ls(5) * v(1) + ls(6) * v(2) + ls(3) * v(3)]
    end function sym_times

  end subroutine rhs_evaluate

  !> (E8) Particle shifting of the delta-plus-SPH (Sun et al. 2017): the
  !> displacement of each owned particle
  !>   dr_i = -coef Sum_j [1 + R (W_ij/W(dx))^n] g V_j,  R = 0.2, n = 4,
  !> with coef = CFL Ma (2h)^2 given by the caller, pushing particles from
  !> crowded to sparse regions (-grad of the kernel sum), plus a repulsion
  !> of close pairs.  On the free surface (lambda_i < LAMBDA_SURFACE, E9)
  !> there is no shift; near it (lambda_i < LAMBDA_NEAR) the component along
  !> the normal n_i = -nu_i/|nu_i|, nu_i = L_i Sum_j g V_j (the renormalised
  !> gradient of the kernel sum, Marrone et al. 2010) is removed, so that the
  !> surface does not diffuse outwards.  dr and lambda of halo slots are
  !> zero.  Positions only: the caller adds dr to x.
  subroutine rhs_shift(prm, n, ntot, x, rho, m, nl, coef, dx, dr, lambda)
    type(rhs_params_t), intent(in) :: prm
    integer, intent(in) :: n, ntot
    real(wp), intent(in) :: x(3, ntot), rho(ntot), m(ntot), coef, dx
    type(neighbour_list_t), intent(in) :: nl
    real(wp), intent(out) :: dr(3, ntot), lambda(ntot)
    real(wp), allocatable :: mm(:, :), s0(:, :), s1(:, :), vol(:)
    real(wp), allocatable :: xl(:, :), r2l(:), fl(:), wl(:)
    integer, allocatable :: jl(:)
    real(wp) :: xij(3), g(3), xx(6), mi(6), s0i(3), s1i(3), w, inv_wdx, s2, vi, vj
    real(wp) :: inv(3, 3), det, nu(3), nn_(3), a
    integer :: i, j, l, nn, kk
    allocate(mm(6, ntot), s0(3, ntot), s1(3, ntot), vol(ntot))
    mm = 0
    s0 = 0
    s1 = 0
    vol = m(1:ntot) / rho(1:ntot)
    s2 = prm%kernel%support**2
    inv_wdx = 1 / kernel_w(prm%kernel, dx)
    call pair_buffers(nl, jl, xl, r2l, fl)
    allocate(wl(size(r2l)))
    do kk = 1, nl%n_rows
      i = nl%row(kk)
      call in_range_pairs(kk, i, x, s2, nl, nn, jl, xl, r2l)
      call kernel_f_list(prm%kernel, nn, r2l, fl)
      call kernel_w_list(prm%kernel, nn, r2l, wl)
      vi = vol(i)
      mi = 0
      s0i = 0
      s1i = 0
      do l = 1, nn
        j = jl(l)
        xij = xl(:, l)
        g = fl(l) * xij
        vj = vol(j)
        w = 1 + SHIFT_R * (wl(l) * inv_wdx)**SHIFT_N
        ! g V_j for i, -g V_i for j (grad_j W_ji = -g)
        s0i = s0i + vj * g
        s0(:, j) = s0(:, j) - vi * g
        s1i = s1i + (w * vj) * g
        s1(:, j) = s1(:, j) - (w * vi) * g
        xx = moment_term(fl(l), xij)
        mi = mi + vj * xx
        mm(:, j) = mm(:, j) + vi * xx
      end do
      mm(:, i) = mm(:, i) + mi
      s0(:, i) = s0(:, i) + s0i
      s1(:, i) = s1(:, i) + s1i
    end do
    dr = 0
    lambda = 0
    do i = 1, n
      lambda(i) = sym_min_eigenvalue(prm%dim, mm(:, i))
      if (lambda(i) < LAMBDA_SURFACE) cycle          ! on the free surface: none
      dr(:, i) = -coef * s1(:, i)
      if (lambda(i) >= LAMBDA_NEAR) cycle
      ! near the free surface: no motion along the normal (lambda_i >=
      ! LAMBDA_SURFACE > LAMBDA_MIN, so M_i is invertible)
      call invert_sym(prm%dim, mm(:, i), inv, det)
      nu = matmul(inv, s0(:, i))
      a = norm2(nu)
      if (.not. a > 0) cycle
      nn_ = -nu / a
      dr(:, i) = dr(:, i) - sum(dr(:, i) * nn_) * nn_
    end do
  end subroutine rhs_shift

end module fluid_rhs
