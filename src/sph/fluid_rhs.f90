!> The weakly-compressible SPH right-hand side (doc/theory/ E1-E9, H1).
!>
!> Notation: x_ij = x_i - x_j, r = |x_ij|, g = grad_i W_ij = F(r) x_ij with
!> F = W'/r < 0 (kernels module), V_j = m_j/rho_j, u_ji = u_j - u_i.  Pairs
!> come from a half list in canonical order (neighbours module): each pair
!> is computed once and added to i and, with grad_j W_ji = -g, to j, row by
!> row, so that every owned particle receives its terms in an order that
!> does not depend on the decomposition: results are bitwise the same for
!> any number of ranks.  Terms for halo copies land in slots that are
!> ignored (their owners compute them).  The pair loop of rhs_evaluate is
!> pair_rows.inc, written for the vectoriser (doc/studies/ellipsoid3d.md, "Speed"):
!> a row's terms for i are summed in LANES partial sums, an order fixed by
!> the row alone, which keeps that property.
module fluid_rhs
  use kinds, only: wp, i8
  use kernels, only: kernel_t, kernel_f_list, kernel_w, kernel_w_list
  use neighbours, only: neighbour_list_t, neighbour_row, ROW_PAD
  use sym3, only: sym_min_eigenvalue, invert_sym
  implicit none
  private
  public :: rhs_params_t, rhs_density_gradient, rhs_renormalisation, rhs_evaluate, rhs_shift, &
            rhs_strain_rate, rhs_reconstructs, &
            LAMBDA_MIN, LAMBDA_SURFACE, LAMBDA_NEAR, LAMBDA_OUTER, rhs_work_t, rhs_work_reserve, &
            in_range_soa, lane_total, &
            row_capacity, LANES
  public :: VISC_NONE, VISC_DELTA, VISC_MONAGHAN, DIFF_NONE, DIFF_MOLTENI, DIFF_ANTUONO
  public :: PGRAD_STANDARD, PGRAD_HIGHER_ORDER, PGRAD_RENORMALISED, DIV_STANDARD, DIV_RENORMALISED

  integer, parameter :: VISC_NONE = 0, VISC_DELTA = 1, VISC_MONAGHAN = 2
  integer, parameter :: DIFF_NONE = 0, DIFF_MOLTENI = 1, DIFF_ANTUONO = 2
  !> (E4) -(1/rho_i) Sum_j (p_i + p_j) g V_j, or (H1) the corrected
  !> -(1/rho_i) L_i Sum_j (p_j - p_i) g V_j with p = 0 on the free surface,
  !> or (H2) -(1/rho_i) Sum_j (p_i L_i + p_j L_j) g V_j, the adjoint of the
  !> renormalised divergence
  integer, parameter :: PGRAD_STANDARD = 1, PGRAD_HIGHER_ORDER = 2, PGRAD_RENORMALISED = 3
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
  !> LAMBDA_BLEND to 1 at LAMBDA_NEAR (doc/studies/numerics.md, "the blend")
  real(wp), parameter :: LAMBDA_BLEND = 0.7_wp
  !> (H2) the pair's matrix B_i goes from L_i at LAMBDA_SURFACE to I at
  !> LAMBDA_OUTER, across the outer layer of the free surface: L_i alone
  !> there (B = L) was measured unstable (doc/studies/convergence.md)
  real(wp), parameter :: LAMBDA_OUTER = 0.4_wp
  !> (H1) the corrected form's largest weight: a tenth of the
  !> conservative (E4) stays everywhere, whose term 2 p_i Sum_j g V_j pushes
  !> particles apart where they crowd; the corrected form alone has no such
  !> restoring force, and a stretched Lagrangian arrangement then grows
  !> particle-scale velocity noise (doc/studies/numerics.md, "the blend")
  real(wp), parameter :: HO_WEIGHT_MAX = 0.9_wp
  !> (E8) the weight of the anti-clustering term R (W_ij/W(dx))^n of the
  !> shifting (Sun et al. 2017: R = 0.2, n = 4)
  real(wp), parameter :: SHIFT_R = 0.2_wp
  integer, parameter :: SHIFT_N = 4
  !> the partial sums of a row (lane_sums): a vector of doubles on AVX-512
  integer, parameter :: LANES = 8
  !> the row buffers of pair_rows.inc (rhs_work_t%rb)
  integer, parameter :: N_ROWBUF = 14
  !> the vectorised copies of the pair loop (rows_vectorised)
  integer, parameter :: LOOP_STANDARD = 1, LOOP_RENORMALISED = 2, LOOP_ADJOINT = 3
  !> rhs_work_t%rec(:, j): what the pair loop reads of a partner j, in one
  !> place (two cache lines): u (1:3), rho, p, V, 1/rho, the pressure and
  !> weight of (H1), L (R_L + 1:R_L + 6) and R of (E7); the standard
  !> operators read only the first REC_SHORT (one cache line)
  !> (R1) the reconstructed viscosity adds the strain rate S (R_S + 1:R_S + 6)
  integer, parameter :: REC_SHORT = 8, REC_LONG = 16, REC_RECON = 24
  integer, parameter :: R_RHO = 4, R_P = 5, R_VOL = 6, R_IRHO = 7, R_PF = 8, R_WC = 9, R_L = 9, &
                        R_RT = 16, R_S = 16

  !> The physical and numerical constants of the right-hand side.
  type :: rhs_params_t
    type(kernel_t) :: kernel
    integer :: dim = 2
    real(wp) :: c0 = 10, rho0 = 1
    integer :: viscosity = VISC_DELTA
    real(wp) :: alpha = 0.01_wp
    !> (R1) the viscosity acts on u_ji less its linear part, reconstructed
    !> from the strain rates of i and j (rhs_strain_rate): zero for any
    !> linear velocity field, also at the free surface
    logical :: reconstruct = .false.
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
    !> run the pair loop with its branches (rows_general) even where a
    !> vectorised copy exists: the reference the tests compare them with
    logical :: generic_loop = .false.
    !> (B1) binned sums: every pair term rounded onto fixed grids and summed
    !> exactly, so that a particle's sums do not depend on the order of its
    !> partners (symmetric cases stay symmetric); the general loop only,
    !> with the standard operators (no first pass)
    logical :: binned = .false.
  end type rhs_params_t

  !> The constants of the pair loop (pair_rows.inc), from rhs_params_t.
  type :: pair_coefs_t
    real(wp) :: s2 = 0          !< support^2
    real(wp) :: eta2 = 0        !< (E5) Monaghan's 0.01 h^2
    real(wp) :: visc = 0        !< (E5) alpha h c0 rho0
    real(wp) :: monaghan = 0    !< (E5) alpha c0 h
    real(wp) :: diff = 0        !< (E2) delta h c0
    real(wp) :: inv_wdx = 0     !< (E7) 1/W(dx)
    integer :: tensile_n = 4    !< (E7) n
    !> (B1) the anchors of the two bins of drho, du_x, du_y, du_z
    real(wp) :: bin1(4) = 0, bin2(4) = 0
  end type pair_coefs_t

  !> Work arrays of the passes, kept between calls (the solver holds one)
  !> and grown only when the particles or the longest row outgrow them, so
  !> that the time loop allocates nothing.  Per particle: V = m/rho, 1/rho,
  !> the pressure and weight of (H1), R of (E7).  Per row: the in-range
  !> partners (in_range_soa), F and W, and the pair terms for i and j.
  type :: rhs_work_t
    real(wp), allocatable :: rec(:, :)
    integer, allocatable :: jl(:)
    real(wp), allocatable :: rb(:, :)     !< (nr, N_ROWBUF) the row buffers of pair_rows.inc
    !> the per-particle sums of a pass, viewed as (rows, ntot) through a
    !> pointer (sums_view): 4 rows in rhs_evaluate (drho, du), 9 in the
    !> first pass (M, G), 12 in rhs_shift; one buffer, sized for the most
    !> rows asked for, since the passes never need theirs at once
    real(wp), allocatable :: sums(:)
    real(wp), allocatable :: vg(:, :)     !< (9, :) (R1) the velocity gradient's sums
  end type rhs_work_t

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
  !> (xx, yy, zz, xy, xz, yz).  Halo slots of lambda, lmat, grad_rho and
  !> strain are zero: their owners compute them (exchange them if needed).
  !> With phi, grad_rho is the same gradient of phi instead of rho (e.g. a
  !> velocity component: flow_fields).
  subroutine rhs_renormalisation(prm, n, ntot, x, rho, m, nl, lambda, lmat, grad_rho, work, phi, &
                                 u, strain)
    type(rhs_params_t), intent(in) :: prm
    integer, intent(in) :: n, ntot
    real(wp), intent(in) :: x(3, ntot), rho(ntot), m(ntot)
    type(neighbour_list_t), intent(in) :: nl
    real(wp), intent(out) :: lambda(ntot)
    real(wp), intent(out), optional :: lmat(6, ntot), grad_rho(3, ntot)
    real(wp), intent(in), optional :: phi(ntot)
    type(rhs_work_t), intent(inout), optional, target :: work
    !> (R1) with u and strain (both or neither), also the strain rate S of
    !> rhs_strain_rate, in the same pass (L_i applies after the sum)
    real(wp), intent(in), optional :: u(3, ntot)
    real(wp), intent(out), optional :: strain(6, ntot)
    type(rhs_work_t), target :: own
    type(rhs_work_t), pointer :: w
    real(wp), pointer, contiguous :: acc(:, :)
    real(wp) :: inv(3, 3), det, l6(6)
    integer :: i
    logical :: with_g, with_u
    with_g = present(grad_rho)
    with_u = present(u) .and. present(strain)
    if (present(u) .neqv. present(strain)) &
      error stop 'rhs_renormalisation: the strain rate needs both u and strain'
    w => own
    if (present(work)) w => work
    call rhs_work_reserve(w, ntot, nl, REC_SHORT, with_u, sum_rows=9)
    acc => sums_view(w, 9, ntot)
    associate(rec => w%rec, r => w%rb, nr => size(w%jl))
    ! rec: V, rho (and u) per particle; acc: M (1:6) and the sum of G (7:9)
    rec(R_VOL, 1:ntot) = m(1:ntot) / rho(1:ntot)
    if (present(phi)) then
      rec(R_RHO, 1:ntot) = phi(1:ntot)
    else
      rec(R_RHO, 1:ntot) = rho(1:ntot)
    end if
    acc(:, 1:ntot) = 0
    if (with_u) then
      rec(1:3, 1:ntot) = u(:, 1:ntot)
      w%vg(:, 1:ntot) = 0
    end if
    call moment_rows(.true., with_g, with_u, prm%dim == 2, prm%kernel, ntot, x, nl, size(rec, 1), &
                     rec, nr, w%jl, r(:, 1), r(:, 2), r(:, 3), r(:, 4), r(:, 5), r(:, 6), &
                     r(:, 7), r(:, 8), r(:, 9), r(:, 10), r(:, 11), r(:, 12), r(:, 13), r(:, 14), &
                     acc, w%vg)
    lambda = 0
    if (present(lmat)) lmat = 0
    if (with_g) grad_rho = 0
    if (with_u) strain = 0
    do i = 1, n
      lambda(i) = sym_min_eigenvalue(prm%dim, acc(1:6, i))
      if (with_g) grad_rho(:, i) = acc(7:9, i)
      ! L_i (as l6): I unless M_i is well conditioned
      l6 = 0
      l6(1:prm%dim) = 1
      if (lambda(i) >= LAMBDA_MIN) then
        call invert_sym(prm%dim, acc(1:6, i), inv, det)
        l6 = [inv(1, 1), inv(2, 2), inv(3, 3), inv(1, 2), inv(1, 3), inv(2, 3)]
        if (with_g) grad_rho(:, i) = matmul(inv, acc(7:9, i))
      end if
      if (present(lmat)) lmat(:, i) = l6
      if (with_u) strain(:, i) = strain_of(l6, w%vg(:, i))
    end do
    end associate
  end subroutine rhs_renormalisation

  !> (R1) S = (G + G^T)/2 of the renormalised velocity gradient G, row a of
  !> which is L (symmetric, as xx, yy, zz, xy, xz, yz) times the sum
  !> raw(3a - 2:3a) of component a (moment_rows), as (xx, yy, zz, xy, xz, yz).
  pure function strain_of(lm, raw) result(st)
    real(wp), intent(in) :: lm(6), raw(9)
    real(wp) :: st(6), l(3, 3), g(3, 3)
    integer :: a
    l(:, 1) = [lm(1), lm(4), lm(5)]
    l(:, 2) = [lm(4), lm(2), lm(6)]
    l(:, 3) = [lm(5), lm(6), lm(3)]
    do a = 1, 3
      g(a, :) = matmul(l, raw(3 * a - 2:3 * a))
    end do
    st = [g(1, 1), g(2, 2), g(3, 3), 0.5_wp * (g(1, 2) + g(2, 1)), &
          0.5_wp * (g(1, 3) + g(3, 1)), 0.5_wp * (g(2, 3) + g(3, 2))]
  end function strain_of

  !> The rows of the list for rhs_renormalisation and rhs_strain_rate: per
  !> pair, with_m, the term of M (moment_term, the same for i and j), with_g
  !> (which needs with_m) the density gradient's
  !> ((rho_j - rho_i) g V_j for i, (rho_i - rho_j)(-g) V_i for j) and with_u
  !> the velocity gradient's ((u_j - u_i) (x) g V_j for i, (u_i - u_j) (x)
  !> (-g) V_i for j, component a of u in accu(3a - 2:3a)), each summed for i
  !> in lanes (as pair_rows.inc) and added to j in row order.  M and G share
  !> a loop over the row, the velocity gradient has its own, with the
  !> options outside the loops, so that every loop vectorises; planar (2D):
  !> only the x, y components, the others staying zero.
  subroutine moment_rows(with_m, with_g, with_u, planar, kernel, ntot, x, nl, nrec, rec, nr, jl, &
                         dx, dy, dz, r2l, fl, t1, t2, t3, t4, t5, t6, t7, t8, t9, acc, accu)
    logical, intent(in) :: with_m, with_g, with_u, planar
    type(kernel_t), intent(in) :: kernel
    integer, intent(in) :: ntot, nrec, nr
    real(wp), intent(in) :: x(3, ntot), rec(nrec, ntot)
    type(neighbour_list_t), intent(in) :: nl
    integer, intent(inout) :: jl(nr)
    real(wp), intent(inout), dimension(nr) :: dx, dy, dz, r2l, fl, t1, t2, t3, t4, t5, t6, t7, &
                                              t8, t9
    real(wp), intent(inout) :: acc(9, ntot), accu(:, :)
    real(wp), dimension(LANES, 9) :: si, su
    real(wp) :: s2, vi, vj, rhoi, f, q, gs, xx(6), ui(3), qx, qy, qz, gx, gy, gz
    integer :: kk, i, j, l, nn, nb, b, k, c
    if (with_g .and. .not. with_m) error stop 'moment_rows: G is summed with M'
    s2 = kernel%support**2
    ui = 0
    do kk = 1, nl%n_rows
      i = nl%row(kk)
      if (planar) then
        call in_range_2d(kk, i, x, s2, nl, nn, nb, jl, dx, dy, r2l)
      else
        call in_range_soa(kk, i, x, s2, nl, nn, nb, jl, dx, dy, dz, r2l, .false.)
      end if
      call kernel_f_list(kernel, nb, r2l, fl)
      vi = rec(R_VOL, i)
      rhoi = rec(R_RHO, i)
      if (with_u) ui = rec(1:3, i)
      si = 0
      ! (E3) M: for i vj xx, for j vi xx; with_g (E2) G, in the same loop
      ! (one loop per combination, without branches: each vectorises)
      if (with_m .and. with_g .and. planar) then
        do b = 0, nb - LANES, LANES
          do k = 1, LANES
            l = b + k
            j = jl(l)
            f = fl(l)
            vj = rec(R_VOL, j)
            ! z = 0: the z moments are neither summed nor kept
            xx = moment_term(f, [dx(l), dy(l), 0.0_wp])
            si(k, 1) = si(k, 1) + vj * xx(1)
            si(k, 2) = si(k, 2) + vj * xx(2)
            si(k, 4) = si(k, 4) + vj * xx(4)
            t1(l) = vi * xx(1)
            t2(l) = vi * xx(2)
            t4(l) = vi * xx(4)
            ! (E2) (rho_j - rho_i) g V_j for i, (rho_i - rho_j)(-g) V_i for j
            q = rec(R_RHO, j) - rhoi
            gs = q * vj * f
            si(k, 7) = si(k, 7) + gs * dx(l)
            si(k, 8) = si(k, 8) + gs * dy(l)
            gs = q * vi * f
            t7(l) = gs * dx(l)
            t8(l) = gs * dy(l)
          end do
        end do
      else if (with_m .and. with_g) then
        do b = 0, nb - LANES, LANES
          do k = 1, LANES
            l = b + k
            j = jl(l)
            f = fl(l)
            vj = rec(R_VOL, j)
            xx = moment_term(f, [dx(l), dy(l), dz(l)])
            si(k, 1) = si(k, 1) + vj * xx(1)
            si(k, 2) = si(k, 2) + vj * xx(2)
            si(k, 3) = si(k, 3) + vj * xx(3)
            si(k, 4) = si(k, 4) + vj * xx(4)
            si(k, 5) = si(k, 5) + vj * xx(5)
            si(k, 6) = si(k, 6) + vj * xx(6)
            t1(l) = vi * xx(1)
            t2(l) = vi * xx(2)
            t3(l) = vi * xx(3)
            t4(l) = vi * xx(4)
            t5(l) = vi * xx(5)
            t6(l) = vi * xx(6)
            ! (E2) (rho_j - rho_i) g V_j for i, (rho_i - rho_j)(-g) V_i for j
            q = rec(R_RHO, j) - rhoi
            gs = q * vj * f
            si(k, 7) = si(k, 7) + gs * dx(l)
            si(k, 8) = si(k, 8) + gs * dy(l)
            si(k, 9) = si(k, 9) + gs * dz(l)
            gs = q * vi * f
            t7(l) = gs * dx(l)
            t8(l) = gs * dy(l)
            t9(l) = gs * dz(l)
          end do
        end do
      else if (with_m .and. planar) then
        do b = 0, nb - LANES, LANES
          do k = 1, LANES
            l = b + k
            j = jl(l)
            f = fl(l)
            vj = rec(R_VOL, j)
            ! z = 0: the z moments are neither summed nor kept
            xx = moment_term(f, [dx(l), dy(l), 0.0_wp])
            si(k, 1) = si(k, 1) + vj * xx(1)
            si(k, 2) = si(k, 2) + vj * xx(2)
            si(k, 4) = si(k, 4) + vj * xx(4)
            t1(l) = vi * xx(1)
            t2(l) = vi * xx(2)
            t4(l) = vi * xx(4)
          end do
        end do
      else if (with_m) then
        do b = 0, nb - LANES, LANES
          do k = 1, LANES
            l = b + k
            j = jl(l)
            f = fl(l)
            vj = rec(R_VOL, j)
            xx = moment_term(f, [dx(l), dy(l), dz(l)])
            si(k, 1) = si(k, 1) + vj * xx(1)
            si(k, 2) = si(k, 2) + vj * xx(2)
            si(k, 3) = si(k, 3) + vj * xx(3)
            si(k, 4) = si(k, 4) + vj * xx(4)
            si(k, 5) = si(k, 5) + vj * xx(5)
            si(k, 6) = si(k, 6) + vj * xx(6)
            t1(l) = vi * xx(1)
            t2(l) = vi * xx(2)
            t3(l) = vi * xx(3)
            t4(l) = vi * xx(4)
            t5(l) = vi * xx(5)
            t6(l) = vi * xx(6)
          end do
        end do
      end if
      if (with_m .and. planar) then
        do l = 1, nn
          j = jl(l)
          acc(1, j) = acc(1, j) + t1(l)
          acc(2, j) = acc(2, j) + t2(l)
          acc(4, j) = acc(4, j) + t4(l)
          if (with_g) acc(7:8, j) = acc(7:8, j) + [t7(l), t8(l)]
        end do
      else if (with_m) then
        do l = 1, nn
          j = jl(l)
          acc(1:6, j) = acc(1:6, j) + [t1(l), t2(l), t3(l), t4(l), t5(l), t6(l)]
          if (with_g) acc(7:9, j) = acc(7:9, j) + [t7(l), t8(l), t9(l)]
        end do
      end if
      do c = 1, 9
        if (planar .and. (c == 3 .or. c == 5 .or. c == 6 .or. c == 9)) cycle
        if ((c <= 6 .and. with_m) .or. (c > 6 .and. with_g)) &
          acc(c, i) = acc(c, i) + lane_total(si(:, c))
      end do
      if (.not. with_u) cycle
      ! (R1) the velocity gradient: (u_j - u_i) (x) g V_j for i, the same
      ! with V_i for j (u_ij (x) (-g) = u_ji (x) g)
      su = 0
      if (planar) then
        do b = 0, nb - LANES, LANES
          do k = 1, LANES
            l = b + k
            j = jl(l)
            f = fl(l)
            vj = rec(R_VOL, j)
            qx = rec(1, j) - ui(1)
            qy = rec(2, j) - ui(2)
            gx = f * dx(l)
            gy = f * dy(l)
            su(k, 1) = su(k, 1) + vj * qx * gx
            su(k, 2) = su(k, 2) + vj * qx * gy
            su(k, 4) = su(k, 4) + vj * qy * gx
            su(k, 5) = su(k, 5) + vj * qy * gy
            t1(l) = vi * qx * gx
            t2(l) = vi * qx * gy
            t4(l) = vi * qy * gx
            t5(l) = vi * qy * gy
          end do
        end do
        do l = 1, nn
          j = jl(l)
          accu(1:2, j) = accu(1:2, j) + [t1(l), t2(l)]
          accu(4:5, j) = accu(4:5, j) + [t4(l), t5(l)]
        end do
      else
        do b = 0, nb - LANES, LANES
          do k = 1, LANES
            l = b + k
            j = jl(l)
            f = fl(l)
            vj = rec(R_VOL, j)
            qx = rec(1, j) - ui(1)
            qy = rec(2, j) - ui(2)
            qz = rec(3, j) - ui(3)
            gx = f * dx(l)
            gy = f * dy(l)
            gz = f * dz(l)
            su(k, 1) = su(k, 1) + vj * qx * gx
            su(k, 2) = su(k, 2) + vj * qx * gy
            su(k, 3) = su(k, 3) + vj * qx * gz
            su(k, 4) = su(k, 4) + vj * qy * gx
            su(k, 5) = su(k, 5) + vj * qy * gy
            su(k, 6) = su(k, 6) + vj * qy * gz
            su(k, 7) = su(k, 7) + vj * qz * gx
            su(k, 8) = su(k, 8) + vj * qz * gy
            su(k, 9) = su(k, 9) + vj * qz * gz
            t1(l) = vi * qx * gx
            t2(l) = vi * qx * gy
            t3(l) = vi * qx * gz
            t4(l) = vi * qy * gx
            t5(l) = vi * qy * gy
            t6(l) = vi * qy * gz
            t7(l) = vi * qz * gx
            t8(l) = vi * qz * gy
            t9(l) = vi * qz * gz
          end do
        end do
        do l = 1, nn
          j = jl(l)
          accu(:, j) = accu(:, j) + [t1(l), t2(l), t3(l), t4(l), t5(l), t6(l), t7(l), t8(l), t9(l)]
        end do
      end if
      do c = 1, 9
        if (planar .and. .not. (c == 1 .or. c == 2 .or. c == 4 .or. c == 5)) cycle
        accu(c, i) = accu(c, i) + lane_total(su(:, c))
      end do
    end do
  end subroutine moment_rows

  !> (E3) The term of one pair in M_i, the same in M_j: -F x_ij x_ij^T,
  !> packed as (xx, yy, zz, xy, xz, yz) (sym3).  The one definition of M:
  !> the renormalisation and the shifting both accumulate it.
  pure function moment_term(f, xij) result(xx)
    real(wp), intent(in) :: f, xij(3)
    real(wp) :: xx(6)
    xx = -f * [xij(1)**2, xij(2)**2, xij(3)**2, &
               xij(1) * xij(2), xij(1) * xij(3), xij(2) * xij(3)]
  end function moment_term

  !> (R1) Whether the viscosity is reconstructed: asked for, and a viscosity
  !> on (then the pair loop needs the strain rate: rhs_renormalisation with
  !> u, or rhs_strain_rate).
  pure logical function rhs_reconstructs(prm)
    type(rhs_params_t), intent(in) :: prm
    rhs_reconstructs = prm%reconstruct .and. prm%viscosity /= VISC_NONE
  end function rhs_reconstructs

  !> (R1) The strain rate of the owned particles from the renormalised
  !> velocity gradient (E3):
  !>   G_i = (L_i Sum_j (u_a,j - u_a,i) g V_j)_a,   S_i = (G_i + G_i^T)/2,
  !> exact for linear velocity fields wherever L_i is M_i^-1; strain holds
  !> S as (xx, yy, zz, xy, xz, yz).  lmat is L of rhs_renormalisation.
  !> Halo slots are zero: their owners compute them (exchange S).
  subroutine rhs_strain_rate(prm, n, ntot, x, u, rho, m, nl, lmat, strain, work)
    type(rhs_params_t), intent(in) :: prm
    integer, intent(in) :: n, ntot
    real(wp), intent(in) :: x(3, ntot), u(3, ntot), rho(ntot), m(ntot), lmat(6, ntot)
    type(neighbour_list_t), intent(in) :: nl
    real(wp), intent(out) :: strain(6, ntot)
    type(rhs_work_t), intent(inout), optional, target :: work
    type(rhs_work_t), target :: own
    type(rhs_work_t), pointer :: w
    integer :: i
    w => own
    if (present(work)) w => work
    call rhs_work_reserve(w, ntot, nl, REC_SHORT, .true., sum_rows=9)
    associate(rec => w%rec, r => w%rb, nr => size(w%jl))
    rec(1:3, 1:ntot) = u(:, 1:ntot)
    rec(R_VOL, 1:ntot) = m(1:ntot) / rho(1:ntot)
    w%vg(:, 1:ntot) = 0
    call moment_rows(.false., .false., .true., prm%dim == 2, prm%kernel, ntot, x, nl, &
                     size(rec, 1), rec, nr, w%jl, r(:, 1), r(:, 2), r(:, 3), r(:, 4), r(:, 5), &
                     r(:, 6), r(:, 7), r(:, 8), r(:, 9), r(:, 10), r(:, 11), r(:, 12), r(:, 13), &
                     r(:, 14), sums_view(w, 9, ntot), w%vg)
    strain = 0
    do i = 1, n
      strain(:, i) = strain_of(lmat(:, i), w%vg(:, i))
    end do
    end associate
  end subroutine rhs_strain_rate

  !> Sizes w for ntot particles, records of nrec values and the rows of nl (a row's buffers hold
  !> its longest row plus a vector of padding, lane_sums), keeping what
  !> is large enough.
  subroutine rhs_work_reserve(w, ntot, nl, nrec, with_vg, sum_rows)
    type(rhs_work_t), intent(inout) :: w
    integer, intent(in) :: ntot
    type(neighbour_list_t), intent(in) :: nl
    integer, intent(in) :: nrec      !< rows of the particle record: REC_SHORT or REC_LONG
    logical, intent(in), optional :: with_vg   !< (R1) the velocity gradient's sums too
    integer, intent(in) :: sum_rows  !< rows of the pass's sums (rhs_work_t%sums)
    integer :: np, nr
    logical :: yes
    np = max(ntot, 1)
    if (allocated(w%rec)) then
      if (size(w%rec, 2) < np .or. size(w%rec, 1) < nrec) deallocate(w%rec)
    end if
    ! room for the particle count to grow a little between rebuilds
    if (.not. allocated(w%rec)) allocate(w%rec(nrec, np + np / 16))
    if (allocated(w%sums)) then
      if (size(w%sums, kind=i8) < int(sum_rows, i8) * np) deallocate(w%sums)
    end if
    if (.not. allocated(w%sums)) allocate(w%sums(int(sum_rows, i8) * (np + np / 16)))
    ! vg: at least one column, unused where not asked for (the loops take
    ! it as an argument); once grown it stays
    yes = .false.
    if (present(with_vg)) yes = with_vg
    np = merge(size(w%rec, 2), 1, yes)
    if (allocated(w%vg)) then
      if (size(w%vg, 2) < np) deallocate(w%vg)
    end if
    if (.not. allocated(w%vg)) allocate(w%vg(9, np))
    nr = row_capacity(nl)
    if (allocated(w%jl)) then
      if (size(w%jl) < nr) deallocate(w%jl, w%rb)
    end if
    if (.not. allocated(w%jl)) allocate(w%jl(nr), w%rb(nr, N_ROWBUF))
  end subroutine rhs_work_reserve

  !> The first rows * ntot of w%sums as a (rows, ntot) array.
  function sums_view(w, rows, ntot) result(v)
    type(rhs_work_t), intent(in), target :: w
    integer, intent(in) :: rows, ntot
    real(wp), pointer, contiguous :: v(:, :)
    v(1:rows, 1:ntot) => w%sums(1:int(rows, i8) * ntot)
  end function sums_view

  !> Slots of a row buffer: the longest row of nl and the padding of
  !> neighbour_row (ROW_PAD), rounded to whole vectors, plus a vector.
  pure integer function row_capacity(nl) result(nr)
    type(neighbour_list_t), intent(in) :: nl
    integer :: longest
    longest = 1
    if (nl%n_rows > 0) longest = max(1, nl%longest)
    nr = ((longest + max(LANES, ROW_PAD)) / LANES + 1) * LANES
  end function row_capacity

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
  !>   I, was measured unstable (doc/studies/numerics.md: the rotating square and
  !>   the circle blow up by t = 0.5/omega, 0.8/A0, whether L_i is used or
  !>   not on the surface).  Between, the two forms are blended with the
  !>   weight w_i = (lambda_i - LAMBDA_BLEND)/(LAMBDA_NEAR - LAMBDA_BLEND)
  !>   of the corrected one: a stretched arrangement lowers lambda inside
  !>   the fluid too, and a hard switch there turned bulk particles to (E4)
  !>   one by one.  Inside, the weight is prm%ho_weight (0.9), not 1 (measured in
  !>   doc/studies/numerics.md).  Not conservative.
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
                          lmat, work, strain)
    type(rhs_params_t), intent(in) :: prm
    integer, intent(in) :: n, ntot
    real(wp), intent(in) :: x(3, ntot), u(3, ntot), rho(ntot), m(ntot), p(ntot)
    !> (3, ntot) with the Antuono diffusion; unread otherwise (any size)
    real(wp), intent(in) :: grad_rho(3, *)
    type(neighbour_list_t), intent(in) :: nl
    real(wp), intent(out) :: drho(ntot), du(3, ntot)
    real(wp), intent(in), optional :: lambda(ntot)
    real(wp), intent(in), optional :: lmat(:, :)
    type(rhs_work_t), intent(inout), optional, target :: work
    !> (R1) S of rhs_strain_rate, owned and halo: with prm%reconstruct
    real(wp), intent(in), optional :: strain(:, :)
    type(rhs_work_t), target :: own
    type(rhs_work_t), pointer :: w
    real(wp), pointer, contiguous :: acc(:, :)
    real(wp) :: s2, h, eta2, coef_visc, coef_mon, diff_coef, inv_wdx
    type(pair_coefs_t) :: c
    logical :: antuono, tensile, corrected, renorm_div, renorm, delta_visc, monaghan_visc, recon
    logical :: adjoint, planar
    integer :: nrec_need, i, vec
    real(wp) :: b
    !> I as the six entries xx, yy, zz, xy, xz, yz of a symmetric matrix
    real(wp), parameter :: IDENTITY6(6) = [1, 1, 1, 0, 0, 0]
    h = prm%kernel%h
    s2 = prm%kernel%support**2
    eta2 = 0.01_wp * h**2
    delta_visc = prm%viscosity == VISC_DELTA
    monaghan_visc = prm%viscosity == VISC_MONAGHAN
    coef_visc = prm%alpha * h * prm%c0 * prm%rho0
    coef_mon = prm%alpha * prm%c0 * h
    diff_coef = 0
    if (prm%diffusion /= DIFF_NONE) diff_coef = prm%delta * h * prm%c0
    antuono = prm%diffusion == DIFF_ANTUONO
    tensile = prm%tensile_eps > 0
    corrected = prm%pressure_gradient == PGRAD_HIGHER_ORDER
    renorm_div = prm%divergence == DIV_RENORMALISED
    adjoint = prm%pressure_gradient == PGRAD_RENORMALISED
    renorm = corrected .or. renorm_div .or. adjoint
    if (renorm .and. .not. present(lmat)) &
      error stop 'rhs_evaluate: the renormalised operators need lmat (rhs_renormalisation)'
    if ((corrected .or. adjoint) .and. .not. present(lambda)) &
      error stop 'rhs_evaluate: the corrected pressure gradients need lambda'
    if (tensile .and. .not. prm%tensile_dx > 0) &
      error stop 'rhs_evaluate: tensile control needs tensile_dx'
    recon = rhs_reconstructs(prm)
    if (recon .and. .not. present(strain)) &
      error stop 'rhs_evaluate: the reconstructed viscosity needs the strain rate'
    w => own
    if (present(work)) w => work
    nrec_need = merge(REC_LONG, REC_SHORT, renorm .or. tensile)
    if (recon) nrec_need = REC_RECON
    if (prm%binned .and. (renorm .or. antuono .or. recon)) &
      error stop 'rhs_evaluate: binned sums only with the standard operators'
    ! (B1) binned: the high bins in acc(:, 1:ntot), the low in acc(:, ntot + 1:)
    call rhs_work_reserve(w, ntot, nl, nrec_need, sum_rows=merge(8, 4, prm%binned))
    acc => sums_view(w, 4, merge(2 * ntot, ntot, prm%binned))
    ! per particle: u, rho, p, V = m/rho and 1/rho (no division in the
    ! pair loop), and what the options need
    associate(rec => w%rec)
    rec(1:3, 1:ntot) = u(:, 1:ntot)
    rec(R_RHO, 1:ntot) = rho(1:ntot)
    rec(R_P, 1:ntot) = p(1:ntot)
    rec(R_IRHO, 1:ntot) = 1 / rho(1:ntot)
    rec(R_VOL, 1:ntot) = m(1:ntot) * rec(R_IRHO, 1:ntot)
    rec(R_PF:, 1:ntot) = 0     ! (the padding of the short record too)
    ! (E7): R_i per particle and 1/W(dx)
    inv_wdx = 0
    if (tensile) then
      rec(R_RT, 1:ntot) = prm%tensile_eps * max(0.0_wp, -p(1:ntot)) * rec(R_IRHO, 1:ntot)**2
      inv_wdx = 1 / kernel_w(prm%kernel, prm%tensile_dx)
    end if
    if (adjoint) then
      ! (H2): B_i = b_i L_i + (1 - b_i) I for both operators of the pair
      do i = 1, ntot
        b = max(0.0_wp, min(1.0_wp, (lambda(i) - LAMBDA_OUTER) / (LAMBDA_SURFACE - LAMBDA_OUTER)))
        rec(R_L + 1:R_L + 6, i) = b * lmat(:, i) + (1 - b) * IDENTITY6
      end do
    else if (renorm) then
      rec(R_L + 1:R_L + 6, 1:ntot) = lmat(:, 1:ntot)
    end if
    if (recon) rec(R_S + 1:R_S + 6, 1:ntot) = strain(:, 1:ntot)
    ! (H1): the pressure with p = 0 on the free surface (pf), and the
    ! weight wc of the consistent form: prm%ho_weight inside the fluid
    ! (lambda >= LAMBDA_NEAR), 0 (the conservative E4) on the surface and
    ! near it (lambda <= LAMBDA_BLEND), linear in lambda between
    if (corrected) then
      rec(R_PF, 1:ntot) = merge(0.0_wp, p(1:ntot), lambda(1:ntot) < LAMBDA_SURFACE)
      rec(R_WC, 1:ntot) = prm%ho_weight * max(0.0_wp, min(1.0_wp, (lambda(1:ntot) &
                                          - LAMBDA_BLEND) / (LAMBDA_NEAR - LAMBDA_BLEND)))
    end if
    end associate
    acc = 0
    c = pair_coefs_t(s2, eta2, coef_visc, coef_mon, diff_coef, inv_wdx, prm%tensile_n)
    ! (B1) the scales of drho and du: rho0 c0/h and c0^2/h
    call bin_anchors(prm%rho0 * prm%c0 / h, c%bin1(1), c%bin2(1))
    call bin_anchors(prm%c0**2 / h, c%bin1(2:4), c%bin2(2:4))
    ! the common configurations have their own vectorised copies of the loop
    ! (the planar twins in 2D, where the z components are zero)
    planar = prm%dim == 2
    vec = 0
    if (.not. (renorm .or. antuono .or. tensile .or. recon) .and. delta_visc) vec = LOOP_STANDARD
    if (renorm_div .and. corrected .and. .not. (antuono .or. tensile .or. recon) &
        .and. delta_visc) vec = LOOP_RENORMALISED
    if (renorm_div .and. adjoint .and. antuono .and. recon .and. .not. tensile &
        .and. delta_visc) vec = LOOP_ADJOINT
    if (prm%generic_loop .or. prm%binned) vec = 0
    associate(r => w%rb, nr => size(w%jl), nrec => size(w%rec, 1))
    if (vec /= 0) then
      call rows_vectorised(vec, planar, prm%kernel, c, ntot, x, grad_rho, nl, nrec, w%rec, nr, &
                           w%jl, r, acc)
    else
      call rows_general(renorm_div, corrected, antuono, tensile, delta_visc, monaghan_visc, &
                        recon, adjoint, prm%binned, prm%kernel, c, ntot, x, grad_rho, nl, &
                        nrec, w%rec, nr, &
                        w%jl, r(:, 1), r(:, 2), r(:, 3), r(:, 4), r(:, 5), r(:, 6), r(:, 7), &
                        r(:, 8), r(:, 9), r(:, 10), acc)
    end if
    end associate
    if (prm%binned) then
      drho(1:n) = acc(1, 1:n) + acc(1, ntot + 1:ntot + n)
      du(:, 1:n) = acc(2:4, 1:n) + acc(2:4, ntot + 1:ntot + n)
    else
      drho(1:n) = acc(1, 1:n)
      du(:, 1:n) = acc(2:4, 1:n)
    end if
    ! halo slots hold partial sums: their owners compute the real values
    drho(n + 1:ntot) = 0
    du(:, n + 1:ntot) = 0
  end subroutine rhs_evaluate

  !> The rows of the list for rhs_evaluate (the loop: pair_rows.inc), with
  !> the options as arguments: any combination, branches in the loop.
  subroutine rows_general(renorm_div, corrected, antuono, tensile, delta_visc, monaghan_visc, &
                          recon, adjoint, binned, kernel, c, ntot, x, grad_rho, nl, nrec, rec, &
                          nr, jl, dx, dy, dz, r2l, fl, wl, tj_r, tj_x, tj_y, tj_z, acc)
    logical, intent(in) :: renorm_div, corrected, antuono, tensile, delta_visc, monaghan_visc, &
                           recon, adjoint, binned
    logical, parameter :: planar = .false.
    include 'pair_rows.inc'
  end subroutine rows_general

  !> The standard operators (E1, E4) with the delta-SPH viscosity and the
  !> Molteni diffusion: the options constant, the loop vectorised.
  subroutine rows_standard(kernel, c, ntot, x, grad_rho, nl, nrec, rec, nr, jl, &
                           dx, dy, dz, r2l, fl, wl, tj_r, tj_x, tj_y, tj_z, acc)
    logical, parameter :: renorm_div = .false., corrected = .false., antuono = .false., &
                          tensile = .false., delta_visc = .true., monaghan_visc = .false., &
                          recon = .false., adjoint = .false., planar = .false.
    logical, parameter :: binned = .false.
    include 'pair_rows.inc'
  end subroutine rows_standard

  !> rows_standard in 2D (planar): no z components.
  subroutine rows_standard_2d(kernel, c, ntot, x, grad_rho, nl, nrec, rec, nr, jl, &
                              dx, dy, dz, r2l, fl, wl, tj_r, tj_x, tj_y, tj_z, acc)
    logical, parameter :: renorm_div = .false., corrected = .false., antuono = .false., &
                          tensile = .false., delta_visc = .true., monaghan_visc = .false., &
                          recon = .false., adjoint = .false., planar = .true.
    logical, parameter :: binned = .false.
    include 'pair_rows.inc'
  end subroutine rows_standard_2d

  !> The renormalised divergence and higher-order gradient (H1) with the
  !> delta-SPH viscosity and the Molteni diffusion, vectorised.
  subroutine rows_renormalised(kernel, c, ntot, x, grad_rho, nl, nrec, rec, nr, jl, &
                               dx, dy, dz, r2l, fl, wl, tj_r, tj_x, tj_y, tj_z, acc)
    logical, parameter :: renorm_div = .true., corrected = .true., antuono = .false., &
                          tensile = .false., delta_visc = .true., monaghan_visc = .false., &
                          recon = .false., adjoint = .false., planar = .false.
    logical, parameter :: binned = .false.
    include 'pair_rows.inc'
  end subroutine rows_renormalised

  !> rows_renormalised in 2D (planar): no z components.
  subroutine rows_renormalised_2d(kernel, c, ntot, x, grad_rho, nl, nrec, rec, nr, jl, &
                                  dx, dy, dz, r2l, fl, wl, tj_r, tj_x, tj_y, tj_z, acc)
    logical, parameter :: renorm_div = .true., corrected = .true., antuono = .false., &
                          tensile = .false., delta_visc = .true., monaghan_visc = .false., &
                          recon = .false., adjoint = .false., planar = .true.
    logical, parameter :: binned = .false.
    include 'pair_rows.inc'
  end subroutine rows_renormalised_2d

  !> The renormalised divergence with its adjoint gradient (H2), the
  !> reconstructed delta-SPH viscosity (R1) and Antuono's diffusion: the
  !> convergence recipe (input/circle2d_convergence.nml), vectorised.
  subroutine rows_adjoint(kernel, c, ntot, x, grad_rho, nl, nrec, rec, nr, jl, &
                          dx, dy, dz, r2l, fl, wl, tj_r, tj_x, tj_y, tj_z, acc)
    logical, parameter :: renorm_div = .true., corrected = .false., antuono = .true., &
                          tensile = .false., delta_visc = .true., monaghan_visc = .false., &
                          recon = .true., adjoint = .true., planar = .false.
    logical, parameter :: binned = .false.
    include 'pair_rows.inc'
  end subroutine rows_adjoint

  !> rows_adjoint in 2D (planar): no z components.
  subroutine rows_adjoint_2d(kernel, c, ntot, x, grad_rho, nl, nrec, rec, nr, jl, &
                             dx, dy, dz, r2l, fl, wl, tj_r, tj_x, tj_y, tj_z, acc)
    logical, parameter :: renorm_div = .true., corrected = .false., antuono = .true., &
                          tensile = .false., delta_visc = .true., monaghan_visc = .false., &
                          recon = .true., adjoint = .true., planar = .true.
    logical, parameter :: binned = .false.
    include 'pair_rows.inc'
  end subroutine rows_adjoint_2d

  !> Calls the vectorised copy `vec` (LOOP_*) of the pair loop, its planar
  !> twin in 2D, with the row buffers r (rhs_work_t%rb).
  subroutine rows_vectorised(vec, planar, kernel, c, ntot, x, grad_rho, nl, nrec, rec, nr, jl, r, &
                             acc)
    integer, intent(in) :: vec
    logical, intent(in) :: planar
    type(kernel_t), intent(in) :: kernel
    type(pair_coefs_t), intent(in) :: c
    integer, intent(in) :: ntot, nrec, nr
    real(wp), intent(in) :: x(3, ntot), grad_rho(3, *), rec(nrec, ntot)
    type(neighbour_list_t), intent(in) :: nl
    integer, intent(inout) :: jl(nr)
    real(wp), intent(inout) :: r(nr, N_ROWBUF), acc(4, ntot)
    select case (vec + merge(10, 0, planar))
    case (LOOP_STANDARD)
      call rows_standard(kernel, c, ntot, x, grad_rho, nl, nrec, rec, nr, jl, r(:, 1), &
                         r(:, 2), r(:, 3), r(:, 4), r(:, 5), r(:, 6), r(:, 7), r(:, 8), &
                         r(:, 9), r(:, 10), acc)
    case (LOOP_STANDARD + 10)
      call rows_standard_2d(kernel, c, ntot, x, grad_rho, nl, nrec, rec, nr, jl, r(:, 1), &
                            r(:, 2), r(:, 3), r(:, 4), r(:, 5), r(:, 6), r(:, 7), r(:, 8), &
                            r(:, 9), r(:, 10), acc)
    case (LOOP_RENORMALISED)
      call rows_renormalised(kernel, c, ntot, x, grad_rho, nl, nrec, rec, nr, jl, r(:, 1), &
                             r(:, 2), r(:, 3), r(:, 4), r(:, 5), r(:, 6), r(:, 7), r(:, 8), &
                             r(:, 9), r(:, 10), acc)
    case (LOOP_RENORMALISED + 10)
      call rows_renormalised_2d(kernel, c, ntot, x, grad_rho, nl, nrec, rec, nr, jl, r(:, 1), &
                                r(:, 2), r(:, 3), r(:, 4), r(:, 5), r(:, 6), r(:, 7), r(:, 8), &
                                r(:, 9), r(:, 10), acc)
    case (LOOP_ADJOINT)
      call rows_adjoint(kernel, c, ntot, x, grad_rho, nl, nrec, rec, nr, jl, r(:, 1), &
                        r(:, 2), r(:, 3), r(:, 4), r(:, 5), r(:, 6), r(:, 7), r(:, 8), &
                        r(:, 9), r(:, 10), acc)
    case (LOOP_ADJOINT + 10)
      call rows_adjoint_2d(kernel, c, ntot, x, grad_rho, nl, nrec, rec, nr, jl, r(:, 1), &
                           r(:, 2), r(:, 3), r(:, 4), r(:, 5), r(:, 6), r(:, 7), r(:, 8), &
                           r(:, 9), r(:, 10), acc)
    case default
      error stop 'rows_vectorised: no such copy of the pair loop'
    end select
  end subroutine rows_vectorised

  !> (B1) The anchors m1, m2 of the two bins of a sum whose terms and
  !> total stay well below 2^30 q: m1 = 1.5 2^e with 2^e the power of two
  !> just above 2^30 q, m2 = m1 2^-40.  The first bin's grid is then
  !> about 2^-22 q, the second's 2^-62 q.
  elemental subroutine bin_anchors(q, m1, m2)
    real(wp), intent(in) :: q
    real(wp), intent(out) :: m1, m2
    m1 = scale(1.5_wp, exponent(q) + 30)
    m2 = scale(m1, -40)
  end subroutine bin_anchors

  !> (B1) Adds t to the binned sum (hi, lo) of anchors m1, m2: t rounded
  !> to the grid of m1 (whose spacing is ulp(m1)) goes to hi, the rest
  !> rounded to the grid of m2 to lo.  Both bins add multiples of their
  !> grid far below 2^53 of them, so they add exactly, in any order.  The
  !> rounding is an odd function (a tie goes to the even neighbour, even
  !> on both sides of the anchor): -t adds exactly the opposite of t.
  elemental subroutine bin_add(hi, lo, t, m1, m2)
    real(wp), intent(inout) :: hi, lo
    real(wp), intent(in) :: t, m1, m2
    real(wp) :: a, r
    a = (t + m1) - m1
    r = t - a
    hi = hi + a
    lo = lo + ((r + m2) - m2)
  end subroutine bin_add

  !> The total of LANES partial sums, added pairwise in a fixed order.
  pure real(wp) function lane_total(acc) result(total)
    real(wp), intent(in) :: acc(LANES)
    total = ((acc(1) + acc(2)) + (acc(3) + acc(4))) + ((acc(5) + acc(6)) + (acc(7) + acc(8)))
  end function lane_total

  !> The partners j in row kk (of particle i) that lie within the kernel
  !> support (r^2 < s2), the first nn of jl, with x_ij in dx, dy, dz and r^2:
  !> the list's skin makes most of the rest fall outside, so filtering first
  !> saves the pair work.  The row is padded up to nb, a multiple of LANES,
  !> with partners that give exact zeros (j = i at r^2 = s2, where F = W =
  !> 0), so that the vectorised loops run on whole vectors.
  pure subroutine in_range_soa(kk, i, x, s2, nl, nn, nb, jl, dx, dy, dz, r2l, symmetric)
    integer, intent(in) :: kk, i
    real(wp), intent(in) :: x(:, :), s2
    !> r^2 as (dx^2 + dy^2) + dz^2, each square rounded: the same bits for
    !> a pair and its image under a rotation or mirror (B1)
    logical, intent(in) :: symmetric
    type(neighbour_list_t), intent(in) :: nl
    integer, intent(out) :: nn, nb
    integer, intent(inout) :: jl(:)
    real(wp), intent(inout) :: dx(:), dy(:), dz(:), r2l(:)
    real(wp) :: xi(3), d(3), r2
    integer :: j, l, nt
    ! branchless compaction in place: always store in the next free slot,
    ! advance only when in range (the test is too random for branch
    ! prediction)
    xi = x(:, i)
    call neighbour_row(nl, kk, jl, nt)
    nn = 0
    do l = 1, nt
      j = jl(l)
      d = xi - x(:, j)
      if (symmetric) then
        r2 = (d(1)**2) + (d(2)**2) + (d(3)**2)
      else
        r2 = d(1)**2 + d(2)**2 + d(3)**2
      end if
      jl(nn + 1) = j
      dx(nn + 1) = d(1)
      dy(nn + 1) = d(2)
      dz(nn + 1) = d(3)
      r2l(nn + 1) = r2
      nn = nn + merge(1, 0, r2 < s2)
    end do
    nb = ((nn + LANES - 1) / LANES) * LANES
    jl(nn + 1:nb) = i
    dx(nn + 1:nb) = 0
    dy(nn + 1:nb) = 0
    dz(nn + 1:nb) = 0
    r2l(nn + 1:nb) = s2
  end subroutine in_range_soa

  !> in_range_soa in 2D: the same partners, without the z components
  !> (zero in a planar run).
  pure subroutine in_range_2d(kk, i, x, s2, nl, nn, nb, jl, dx, dy, r2l)
    integer, intent(in) :: kk, i
    real(wp), intent(in) :: x(:, :), s2
    type(neighbour_list_t), intent(in) :: nl
    integer, intent(out) :: nn, nb
    integer, intent(inout) :: jl(:)
    real(wp), intent(inout) :: dx(:), dy(:), r2l(:)
    real(wp) :: xi(2), d(2), r2
    integer :: j, l, nt
    xi = x(1:2, i)
    call neighbour_row(nl, kk, jl, nt)
    nn = 0
    do l = 1, nt
      j = jl(l)
      d = xi - x(1:2, j)
      r2 = d(1)**2 + d(2)**2
      jl(nn + 1) = j
      dx(nn + 1) = d(1)
      dy(nn + 1) = d(2)
      r2l(nn + 1) = r2
      nn = nn + merge(1, 0, r2 < s2)
    end do
    nb = ((nn + LANES - 1) / LANES) * LANES
    jl(nn + 1:nb) = i
    dx(nn + 1:nb) = 0
    dy(nn + 1:nb) = 0
    r2l(nn + 1:nb) = s2
  end subroutine in_range_2d


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
  !> zero.  Positions only: the caller adds dr to x.  The sums use the
  !> work arrays (no allocation per call).
  subroutine rhs_shift(prm, n, ntot, x, rho, m, nl, coef, dx, dr, lambda, work)
    type(rhs_params_t), intent(in) :: prm
    integer, intent(in) :: n, ntot
    real(wp), intent(in) :: x(3, ntot), rho(ntot), m(ntot), coef, dx
    type(neighbour_list_t), intent(in) :: nl
    real(wp), intent(out) :: dr(3, ntot), lambda(ntot)
    type(rhs_work_t), intent(inout), optional, target :: work
    type(rhs_work_t), target :: own
    type(rhs_work_t), pointer :: w
    real(wp), pointer, contiguous :: acc(:, :)
    real(wp) :: xij(3), g(3), xx(6), mi(6), s0i(3), s1i(3), wgt, inv_wdx, s2, vi, vj
    real(wp) :: inv(3, 3), det, nu(3), nn_(3), a
    integer :: i, j, l, nn, nb, kk
    real(wp) :: m1(12), m2(12)
    w => own
    if (present(work)) w => work
    call rhs_work_reserve(w, ntot, nl, REC_SHORT, sum_rows=merge(24, 12, prm%binned))
    acc => sums_view(w, 12, merge(2 * ntot, ntot, prm%binned))
    ! the work arrays: M in sums(1:6), the sum of g V in sums(7:9), the
    ! weighted sum in sums(10:12), V in rec(R_VOL); the row in jl and rb;
    ! binned (B1), the low bins in columns ntot + 1:2 ntot, the scales 1
    ! (M) and 1/h (the sums of g V)
    call bin_anchors(1.0_wp, m1(1:6), m2(1:6))
    call bin_anchors(1 / prm%kernel%h, m1(7:12), m2(7:12))
    associate(mm => acc(1:6, :), s0 => acc(7:9, :), s1 => acc(10:12, :), &
              vol => w%rec(R_VOL, :), jl => w%jl, xd => w%rb(:, 1), yd => w%rb(:, 2), &
              zd => w%rb(:, 3), r2l => w%rb(:, 4), fl => w%rb(:, 5), wl => w%rb(:, 6))
    acc = 0
    vol(1:ntot) = m(1:ntot) / rho(1:ntot)
    s2 = prm%kernel%support**2
    inv_wdx = 1 / kernel_w(prm%kernel, dx)
    do kk = 1, nl%n_rows
      i = nl%row(kk)
      call in_range_soa(kk, i, x, s2, nl, nn, nb, jl, xd, yd, zd, r2l, prm%binned)
      call kernel_f_list(prm%kernel, nn, r2l, fl)
      call kernel_w_list(prm%kernel, nn, r2l, wl)
      vi = vol(i)
      mi = 0
      s0i = 0
      s1i = 0
      do l = 1, nn
        j = jl(l)
        xij = [xd(l), yd(l), zd(l)]
        g = fl(l) * xij
        vj = vol(j)
        wgt = 1 + SHIFT_R * (wl(l) * inv_wdx)**SHIFT_N
        xx = moment_term(fl(l), xij)
        if (prm%binned) then
          call bin_add(acc(:, i), acc(:, ntot + i), [vj * xx, vj * g, (wgt * vj) * g], m1, m2)
          call bin_add(acc(:, j), acc(:, ntot + j), [vi * xx, -vi * g, -(wgt * vi) * g], m1, m2)
          cycle
        end if
        ! g V_j for i, -g V_i for j (grad_j W_ji = -g)
        s0i = s0i + vj * g
        s0(:, j) = s0(:, j) - vi * g
        s1i = s1i + (wgt * vj) * g
        s1(:, j) = s1(:, j) - (wgt * vi) * g
        mi = mi + vj * xx
        mm(:, j) = mm(:, j) + vi * xx
      end do
      mm(:, i) = mm(:, i) + mi
      s0(:, i) = s0(:, i) + s0i
      s1(:, i) = s1(:, i) + s1i
    end do
    if (prm%binned) acc(:, 1:n) = acc(:, 1:n) + acc(:, ntot + 1:ntot + n)
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
      if (prm%binned) then
        ! (B1) the products rounded before each sum, and no norm2 (its
        ! scaled sum is not symmetric in x and y): the same bits for a
        ! particle and its image
        nu = (inv(:, 1) * s0(1, i)) + (inv(:, 2) * s0(2, i)) + (inv(:, 3) * s0(3, i))
        a = sqrt((nu(1)**2) + (nu(2)**2) + (nu(3)**2))
        if (.not. a > 0) cycle
        nn_ = -nu / a
        dr(:, i) = dr(:, i) - ((dr(1, i) * nn_(1)) + (dr(2, i) * nn_(2)) + (dr(3, i) * nn_(3))) &
                              * nn_
        cycle
      end if
      nu = matmul(inv, s0(:, i))
      a = norm2(nu)
      if (.not. a > 0) cycle
      nn_ = -nu / a
      dr(:, i) = dr(:, i) - sum(dr(:, i) * nn_) * nn_
    end do
    end associate
  end subroutine rhs_shift

end module fluid_rhs
