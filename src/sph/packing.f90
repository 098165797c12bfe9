!> Particle packing (doc/theory/packing.md): relaxes the particles of a disc (2D)
!> or ball (3D) of radius R, all of volume V = |Omega|/N, towards a uniform
!> arrangement by descending the gradient of the kernel sum
!>   (P1) Gamma_i = Sum_j W_ij V + E(|x_i|),
!>        E(r) = integral of W(x - y) over the y outside the body,
!> which is 1 for every particle of a uniform arrangement, inside or at the
!> free surface: the exterior integral E stands for the fluid the
!> truncated sum misses, so the surface needs no ghost particles.  Each
!> iteration moves every particle by
!>   (P2) d_i = -beta h^2 grad_i Gamma_i,  |d_i| <= d_max dx,
!>        grad_i Gamma_i = Sum_j F(r_ij) x_ij V + E'(r_i) x_i/r_i,
!> with heavy-ball momentum, v_i <- mu v_i + d_i, x_i <- x_i + v_i, and a
!> particle that would leave the body is put back inside at R - dx/4
!> (P3).  Sums run over the solver's canonical half list, so the result is
!> bitwise the same for any number of ranks.
module packing
  use kinds, only: wp, i8, pi
  use kernels, only: kernel_t, kernel_w, kernel_f_list, kernel_w_list
  use pair_rows, only: row_capacity
  use neighbours, only: neighbour_list_t, neighbour_row
  use solver, only: solver_t, solver_rebuild
  use decomposition, only: decomp_refresh
  use parallel_env, only: parallel_env_t, par_max, par_sum, par_sum_exact, wall_time
  use mirrors, only: plane_weights, planes_on, hold_normal, PLANE_SLAB
  implicit none
  private
  public :: packing_params_t, packing_report_t, pack_ball, exterior_table_t, &
            exterior_table_init, exterior_slope, PACK_TABLE_SIZE

  integer, parameter :: PACK_TABLE_SIZE = 2048
  !> The bulk level of the kernel sum (one kernel value per pair) is taken
  !> at every iteration up to LEVEL_EARLY, then every LEVEL_EVERY: over ten
  !> iterations it moves by 6e-2, 4e-3, 1e-3 in the first thirty, 2e-4 by
  !> iteration 50, 1e-5 by 170 (30k particles, 3D), and W for every pair in
  !> every iteration was about a tenth of the packing's time.
  integer, parameter :: LEVEL_EARLY = 50, LEVEL_EVERY = 10

  !> The iteration's constants.
  type :: packing_params_t
    real(wp) :: radius = 1        !< R
    real(wp) :: dx = 0            !< (|Omega|/N)^(1/dim)
    integer :: max_iterations = 300
    real(wp) :: beta = 0.2_wp     !< step of (P2) in units of h^2
    real(wp) :: mu = 0.8_wp       !< momentum of the heavy ball
    real(wp) :: d_max = 0.1_wp    !< largest move per iteration, in dx
    real(wp) :: tolerance = 1e-4_wp   !< stop when every move is below it (in dx)
    real(wp) :: slab(3) = PLANE_SLAB  !< each axis's plane's slab, in dx (M5, M6)
  end type packing_params_t

  !> What the relaxation did.
  type :: packing_report_t
    integer :: iterations = 0
    integer :: rebuilds = 0
    integer :: clipped = 0        !< moves put back inside the body (all iterations)
    real(wp) :: last_move = 0     !< largest |v_i| of the last iteration / dx
    real(wp) :: level = 1         !< bulk kernel sum over its integral (last evaluation)
    real(wp) :: wall = 0          !< seconds
  end type packing_report_t

  !> E'(r) of (P1) on a uniform grid of r over [R - S, R + S], S the
  !> kernel support; E' = 0 below R - S.
  type :: exterior_table_t
    real(wp) :: r_lo = 0, dr = 1
    real(wp) :: slope(0:PACK_TABLE_SIZE) = 0
    real(wp) :: total = 1         !< E(R + S), the kernel's integral by the same rule
  end type exterior_table_t

contains

  !> Tabulates E(r) = integral over |y| > R of W(|x - y|) dy at |x| = r:
  !> the sphere (circle) of radius s about x lies outside the body where
  !> cos(theta) > c = (R^2 - r^2 - s^2)/(2 r s), theta measured from x/r,
  !> so E = Int_0^S W(s) A_out(s) ds with A_out = 2 pi s^2 (1 - c) in 3D
  !> and 2 s acos(c) in 2D (c clipped to [-1, 1]); Simpson's rule in s,
  !> then E' by central differences on the table.
  function exterior_table_init(kernel, dim, radius) result(tab)
    type(kernel_t), intent(in) :: kernel
    integer, intent(in) :: dim
    real(wp), intent(in) :: radius
    type(exterior_table_t) :: tab
    integer, parameter :: ns = 4096
    real(wp) :: e(-1:PACK_TABLE_SIZE + 1), r, s, ds, c, a, wgt
    integer :: k, l
    tab%r_lo = radius - kernel%support
    tab%dr = 2 * kernel%support / PACK_TABLE_SIZE
    ds = kernel%support / ns
    do k = -1, PACK_TABLE_SIZE + 1
      r = max(tab%r_lo + k * tab%dr, 1e-12_wp * radius)
      e(k) = 0
      do l = 0, ns
        s = l * ds
        if (s <= 0) cycle
        c = max(-1.0_wp, min(1.0_wp, (radius**2 - r**2 - s**2) / (2 * r * s)))
        if (dim == 3) then
          a = 2 * pi * s**2 * (1 - c)
        else
          a = 2 * s * acos(c)
        end if
        wgt = merge(1.0_wp, merge(4.0_wp, 2.0_wp, mod(l, 2) == 1), l == ns)
        e(k) = e(k) + wgt * kernel_w(kernel, s) * a
      end do
      e(k) = e(k) * ds / 3
    end do
    do k = 0, PACK_TABLE_SIZE
      tab%slope(k) = (e(k + 1) - e(k - 1)) / (2 * tab%dr)
    end do
    tab%total = e(PACK_TABLE_SIZE)
  end function exterior_table_init

  !> E'(r) by linear interpolation in the table.
  pure function exterior_slope(tab, r) result(ep)
    type(exterior_table_t), intent(in) :: tab
    real(wp), intent(in) :: r
    real(wp) :: ep, t
    integer :: k
    ep = 0
    t = (r - tab%r_lo) / tab%dr
    if (t <= 0) return
    k = min(int(t), PACK_TABLE_SIZE - 1)
    t = min(t - k, 1.0_wp)
    ep = (1 - t) * tab%slope(k) + t * tab%slope(k + 1)
  end function exterior_slope

  !> grad_i of Sum_j W_ij V (the pair part of P2) for the n owned
  !> particles, from the half list in canonical order, and with_sum the
  !> sum itself (the pair part of P1, else gam is 0); halo slots get
  !> partial sums that are not used.  Every listed pair is summed, the ones
  !> beyond the support with F = W = 0 (kernel_f_list): in this light loop
  !> sorting them out costs more than their exact zeros.
  subroutine sum_gradient(kernel, n, ntot, x, vol, w, nl, with_sum, grad, gam)
    type(kernel_t), intent(in) :: kernel
    integer, intent(in) :: n, ntot
    real(wp), intent(in) :: x(3, ntot), vol, w(ntot)
    type(neighbour_list_t), intent(in) :: nl
    logical, intent(in) :: with_sum
    real(wp), intent(out) :: grad(3, ntot), gam(ntot)
    real(wp), allocatable :: rb(:, :)
    integer, allocatable :: jl(:)
    integer :: nr
    nr = row_capacity(nl)
    allocate(rb(nr, 5))
    allocate(jl(nr))
    call gradient_rows(kernel, ntot, x, w, nl, with_sum, nr, jl, rb(:, 1), rb(:, 2), &
                       rb(:, 3), rb(:, 4), rb(:, 5), grad, gam)
    grad(:, 1:n) = vol * grad(:, 1:n)
    gam(1:n) = vol * (gam(1:n) + w(1:n) * kernel_w(kernel, 0.0_wp))
    grad(:, n + 1:ntot) = 0
    gam(n + 1:ntot) = 0
  end subroutine sum_gradient

  !> The rows of sum_gradient, with explicit-shape buffers (vectorised).
  subroutine gradient_rows(kernel, ntot, x, w, nl, with_sum, nr, jl, dx, dy, dz, r2l, fl, &
                           grad, gam)
    type(kernel_t), intent(in) :: kernel
    integer, intent(in) :: ntot, nr
    real(wp), intent(in) :: x(3, ntot), w(ntot)
    type(neighbour_list_t), intent(in) :: nl
    logical, intent(in) :: with_sum
    integer, intent(inout) :: jl(nr)        !< the row's partners (neighbour_row)
    real(wp), intent(inout), dimension(nr) :: dx, dy, dz, r2l, fl
    real(wp), intent(out) :: grad(3, ntot), gam(ntot)
    real(wp) :: gi(3), g(3), si, xi(3)
    integer :: kk, i, j, l, nn
    grad = 0
    gam = 0
    do kk = 1, nl%n_rows
      i = nl%row(kk)
      call neighbour_row(nl, kk, jl, nn)
      xi = x(:, i)
      do l = 1, nn
        j = jl(l)
        dx(l) = xi(1) - x(1, j)
        dy(l) = xi(2) - x(2, j)
        dz(l) = xi(3) - x(3, j)
        r2l(l) = dx(l)**2 + dy(l)**2 + dz(l)**2
      end do
      call kernel_f_list(kernel, nn, r2l, fl)
      gi = 0
      do l = 1, nn
        j = jl(l)
        g = fl(l) * [dx(l), dy(l), dz(l)]
        gi = gi + w(j) * g
        grad(:, j) = grad(:, j) - w(i) * g
      end do
      grad(:, i) = grad(:, i) + gi
      if (.not. with_sum) cycle
      call kernel_w_list(kernel, nn, r2l, fl)
      si = 0
      do l = 1, nn
        j = jl(l)
        si = si + w(j) * fl(l)
        gam(j) = gam(j) + w(i) * fl(l)
      end do
      gam(i) = gam(i) + si
    end do
  end subroutine gradient_rows

  !> Relaxes the owned particles of s%parts (P2, P3) in place, on the
  !> solver's decomposition, halo and neighbour list (rebuilt when the
  !> particles have moved by half the skin since the last build).  The
  !> velocities serve as the momentum of the heavy ball and are zero on
  !> return; the caller sets the physical state afterwards.
  subroutine pack_ball(s, env, prm, rep)
    type(solver_t), intent(inout) :: s
    type(parallel_env_t), intent(in) :: env
    type(packing_params_t), intent(in) :: prm
    type(packing_report_t), intent(out) :: rep
    type(exterior_table_t) :: tab
    real(wp), allocatable :: grad(:, :), gam(:)
    real(wp) :: vol, coef, level, dmax_abs, r_clip, r, d(3), dn, moved, vmax, t0, h
    integer :: i, it, n, ntot, clipped
    logical :: new_level, hit
    t0 = wall_time()
    associate(kern => s%rhs%kernel)
    h = kern%h
    vol = prm%dx**s%parts%dim
    coef = prm%beta * h**2
    dmax_abs = prm%d_max * prm%dx
    r_clip = prm%radius - 0.25_wp * prm%dx
    tab = exterior_table_init(kern, s%parts%dim, prm%radius)
    s%lm%skin = s%lm%skin_min
    call solver_rebuild(s, env)
    rep%rebuilds = 1
    s%parts%u = 0
    moved = 0
    clipped = 0
    do it = 1, prm%max_iterations
      if (moved > 0.5_wp * s%lm%skin) then
        call solver_rebuild(s, env)
        rep%rebuilds = rep%rebuilds + 1
        moved = 0
      end if
      call decomp_refresh(s%dc, env, s%parts)
      n = s%parts%n
      ntot = n + s%parts%n_halo
      ! work arrays as large as the particle arrays, which migration and
      ! the halo may have grown at the rebuild
      if (allocated(grad)) then
        if (size(grad, 2) < ntot) deallocate(grad, gam)
      end if
      if (.not. allocated(grad)) allocate(grad(3, size(s%parts%x, 2)), gam(size(s%parts%x, 2)))
      new_level = it <= LEVEL_EARLY .or. mod(it - 1, LEVEL_EVERY) == 0
      call sum_gradient(kern, n, ntot, s%parts%x, vol, &
                        plane_weights(s%parts%x(:, 1:ntot), s%dc%halo%mirror), s%lm%nl, &
                        new_level, grad, gam)
      ! the level of the discrete kernel sum in the bulk (above 1 by the
      ! kernel's discretisation error, 0.3 % at h = 1.6 dx in 3D) scales the
      ! exterior part, so that the free surface is in balance with the bulk
      if (new_level) then
        level = bulk_level(env, s%parts%x(:, 1:n), gam(1:n), prm%radius - 2 * kern%support, &
                           tab%total)
        rep%level = level
      end if
      vmax = 0
      associate(x => s%parts%x, v => s%parts%u)
        do i = 1, n
          r = norm2(x(:, i))
          if (r > 0) grad(:, i) = grad(:, i) + (level * exterior_slope(tab, r) / r) * x(:, i)
          d = -coef * grad(:, i)
          call hold_normal(x(:, i), s%dc%halo%mirror, d)
          dn = norm2(d)
          if (dn > dmax_abs) d = d * (dmax_abs / dn)
          v(:, i) = prm%mu * v(:, i) + d
          x(:, i) = x(:, i) + v(:, i)
          hit = off_planes(x(:, i), v(:, i))
          r = norm2(x(:, i))
          if (r > r_clip) then
            x(:, i) = x(:, i) * (r_clip / r)
            v(:, i) = 0
            hit = .true.
          end if
          ! (a call of its own: an operand of .or. need not be evaluated)
          if (off_planes(x(:, i), v(:, i))) hit = .true.
          if (hit) clipped = clipped + 1
          vmax = max(vmax, norm2(v(:, i)))
        end do
      end associate
      vmax = par_max(env, vmax)
      ! every particle moved by at most vmax: the radial clip is a projection
      ! onto the ball, the planes' onto half-spaces, each holding the old
      ! position, so they never add to a move
      moved = moved + vmax
      rep%iterations = it
      rep%last_move = vmax / prm%dx
      if (vmax < prm%tolerance * prm%dx) exit
    end do
    end associate
    rep%clipped = nint(par_sum(env, real(clipped, wp)))
    s%parts%u = 0
    rep%wall = wall_time() - t0

  contains

    !> (M5) A particle on a plane stays on it; one across another plane is
    !> reflected back, and one on no plane is kept the plane's slab off each
    !> (its image twice that away), its move along that normal stopped.  No particle joins a
    !> plane here: one that did would lose half its weight, a deficit the
    !> packing would draw in from afar (doc/studies/symmetry.md, "The start-up dip").
    logical function off_planes(x, v) result(moved_back)
      real(wp), intent(inout) :: x(3), v(3)
      integer :: k, mask
      logical :: free
      mask = s%dc%halo%mirror
      moved_back = .false.
      free = planes_on(x, mask) == 0
      do k = 1, 3
        if (.not. btest(mask, k - 1)) cycle
        if (x(k) < 0) then
          x(k) = -x(k)
          v(k) = 0
          moved_back = .true.
        end if
        if (free .and. x(k) < prm%slab(k) * prm%dx) then
          x(k) = prm%slab(k) * prm%dx
          v(k) = 0
          moved_back = .true.
        end if
      end do
    end function off_planes

  end subroutine pack_ball

  !> The level of the discrete kernel sum gam in the bulk (the particles x
  !> within radius `inner` of the centre), over all ranks, relative to the
  !> exterior table's total; 1 when no particle is that deep.
  real(wp) function bulk_level(env, x, gam, inner, total) result(level)
    type(parallel_env_t), intent(in) :: env
    real(wp), intent(in) :: x(:, :), gam(:), inner, total
    real(wp) :: sums(2)
    real(wp), allocatable :: part(:, :)
    integer :: i
    allocate(part(2, size(gam)))
    do i = 1, size(gam)
      part(:, i) = merge([gam(i), 1.0_wp], [0.0_wp, 0.0_wp], norm2(x(:, i)) < inner)
    end do
    sums = par_sum_exact(env, part)
    level = 1
    if (sums(2) > 0) level = sums(1) / (sums(2) * total)
  end function bulk_level

end module packing
