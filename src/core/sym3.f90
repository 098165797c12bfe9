!> Small dense algebra of symmetric 3 x 3 matrices (in 2D their leading
!> 2 x 2 block), shared by the renormalisation (E3), the free-surface
!> indicator (E9) and the neighbour-list validity test (affine_motion),
!> and the one elimination of small symmetric positive definite systems
!> (solve_spd: also the quadratic probe's normal equations, D5).
!> A packed symmetric matrix is stored as (xx, yy, zz, xy, xz, yz).
module sym3
  use kinds, only: wp
  implicit none
  private
  public :: sym_min_eigenvalue, invert_sym, invert_spd, solve_spd, sigma_min

contains

  !> Smallest eigenvalue of the symmetric dim x dim matrix stored as (xx, yy,
  !> zz, xy, xz, yz): closed form in 2D, the trigonometric form in 3D.
  pure function sym_min_eigenvalue(dim, a) result(lam)
    integer, intent(in) :: dim
    real(wp), intent(in) :: a(6)
    real(wp) :: lam, q, p1, p2, p, b(6), r, phi
    if (dim == 2) then
      lam = 0.5_wp * (a(1) + a(2)) - sqrt(0.25_wp * (a(1) - a(2))**2 + a(4)**2)
      return
    end if
    p1 = a(4)**2 + a(5)**2 + a(6)**2
    q = (a(1) + a(2) + a(3)) / 3
    if (p1 <= epsilon(1.0_wp) * q**2) then
      lam = minval(a(1:3))
      return
    end if
    p2 = (a(1) - q)**2 + (a(2) - q)**2 + (a(3) - q)**2 + 2 * p1
    p = sqrt(p2 / 6)
    b(1:3) = (a(1:3) - q) / p
    b(4:6) = a(4:6) / p
    ! r = det(B)/2 with B = (A - q I)/p
    r = 0.5_wp * (b(1) * (b(2) * b(3) - b(6)**2) - b(4) * (b(4) * b(3) - b(6) * b(5)) &
                  + b(5) * (b(4) * b(6) - b(2) * b(5)))
    r = max(-1.0_wp, min(1.0_wp, r))
    phi = acos(r) / 3
    lam = q + 2 * p * cos(phi + 2 * acos(-1.0_wp) / 3)
  end function sym_min_eigenvalue

  !> Inverse of the symmetric dim x dim matrix stored as (xx, yy, zz, xy, xz,
  !> yz), and its determinant; the unused rows of a 2D inverse are zero.
  pure subroutine invert_sym(dim, a, inv, det)
    integer, intent(in) :: dim
    real(wp), intent(in) :: a(6)
    real(wp), intent(out) :: inv(3, 3), det
    inv = 0
    if (dim == 2) then
      det = a(1) * a(2) - a(4)**2
      if (det <= 0) return
      inv(1, 1) = a(2) / det
      inv(2, 2) = a(1) / det
      inv(1, 2) = -a(4) / det
      inv(2, 1) = inv(1, 2)
    else
      inv(1, 1) = a(2) * a(3) - a(6)**2
      inv(1, 2) = a(5) * a(6) - a(4) * a(3)
      inv(1, 3) = a(4) * a(6) - a(5) * a(2)
      inv(2, 2) = a(1) * a(3) - a(5)**2
      inv(2, 3) = a(4) * a(5) - a(1) * a(6)
      inv(3, 3) = a(1) * a(2) - a(4)**2
      det = a(1) * inv(1, 1) + a(4) * inv(1, 2) + a(5) * inv(1, 3)
      if (det <= 0) return
      inv(2, 1) = inv(1, 2); inv(3, 1) = inv(1, 3); inv(3, 2) = inv(2, 3)
      inv = inv / det
    end if
  end subroutine invert_sym

  !> Inverse of the leading dim x dim block of a symmetric positive matrix
  !> (solve_spd with the identity); false if it is (numerically) singular.
  logical function invert_spd(dim, c, inv) result(ok)
    integer, intent(in) :: dim
    real(wp), intent(in) :: c(3, 3)
    real(wp), intent(out) :: inv(3, 3)
    real(wp) :: a(dim, dim)
    integer :: k
    inv = 0
    a = c(1:dim, 1:dim)
    do k = 1, dim
      inv(k, k) = 1
    end do
    ok = solve_spd(a, inv(1:dim, 1:dim), 1e-12_wp)
    if (.not. ok) inv = 0
  end function invert_spd

  !> Solves a x = b for the columns of b (overwritten by x) by Gauss-Jordan
  !> elimination, a symmetric positive definite: the diagonal pivots stay
  !> positive without row exchanges.  False, b undefined, when a pivot falls
  !> to tol times the largest diagonal entry or below (numerically singular).
  logical function solve_spd(a, b, tol) result(ok)
    real(wp), intent(inout) :: a(:, :)    !< destroyed
    real(wp), intent(inout) :: b(:, :)
    real(wp), intent(in) :: tol
    real(wp) :: piv, scale
    integer :: k, l, n
    ok = .false.
    n = size(a, 1)
    scale = maxval([(abs(a(k, k)), k = 1, n)])
    if (.not. scale > 0) return
    do k = 1, n
      piv = a(k, k)
      if (piv <= tol * scale) return
      a(k, :) = a(k, :) / piv
      b(k, :) = b(k, :) / piv
      do l = 1, n
        if (l == k) cycle
        b(l, :) = b(l, :) - a(l, k) * b(k, :)
        a(l, :) = a(l, :) - a(l, k) * a(k, :)
      end do
    end do
    ok = .true.
  end function solve_spd

  !> Smallest singular value of the leading dim x dim block of f: the
  !> square root of the smallest eigenvalue of f^T f, by cyclic Jacobi
  !> rotations (converged to rounding in a few sweeps for 3 x 3).
  function sigma_min(dim, f) result(smin)
    integer, intent(in) :: dim
    real(wp), intent(in) :: f(3, 3)
    real(wp) :: smin
    real(wp) :: g(3, 3), th, c, s, t, gpp, gqq, gpq
    integer :: sweep, p, q, k
    g = 0
    g(1:dim, 1:dim) = matmul(transpose(f(1:dim, 1:dim)), f(1:dim, 1:dim))
    do sweep = 1, 50
      if (sum([((g(p, q)**2, q = p + 1, dim), p = 1, dim)]) <= &
          1e-30_wp * sum([(g(p, p)**2, p = 1, dim)])) exit
      do p = 1, dim - 1
        do q = p + 1, dim
          gpq = g(p, q)
          if (abs(gpq) <= tiny(gpq)) cycle
          gpp = g(p, p)
          gqq = g(q, q)
          th = (gqq - gpp) / (2 * gpq)
          t = sign(1.0_wp, th) / (abs(th) + sqrt(th**2 + 1))
          c = 1 / sqrt(t**2 + 1)
          s = t * c
          ! g <- J^T g J with the rotation J in the (p, q) plane
          do k = 1, dim
            th = g(k, p)
            g(k, p) = c * th - s * g(k, q)
            g(k, q) = s * th + c * g(k, q)
          end do
          do k = 1, dim
            th = g(p, k)
            g(p, k) = c * th - s * g(q, k)
            g(q, k) = s * th + c * g(q, k)
          end do
        end do
      end do
    end do
    smin = sqrt(max(0.0_wp, minval([(g(p, p), p = 1, dim)])))
  end function sigma_min

end module sym3
