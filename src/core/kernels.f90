!> Smoothing kernels (doc/theory/ K1-K3), normalised exactly in 2D and 3D.
!>
!> With q = r/h, each kernel gives W(r) and the gradient factor F(r) = W'(r)/r,
!> so that grad_i W_ij = F(r_ij) (x_i - x_j) without a division by r.
module kernels
  use kinds, only: wp, pi
  implicit none
  private
  public :: kernel_t, kernel_init, kernel_kind_of, kernel_w, kernel_f, kernel_f_list, kernel_w_list
  public :: KERNEL_WENDLAND_C2, KERNEL_CUBIC_SPLINE, KERNEL_GAUSSIAN

  integer, parameter :: KERNEL_WENDLAND_C2 = 1   !< (K1)
  integer, parameter :: KERNEL_CUBIC_SPLINE = 2  !< (K2)
  integer, parameter :: KERNEL_GAUSSIAN = 3      !< (K3), truncated at 3h

  !> A kernel with its smoothing length and dimension-dependent constants.
  type :: kernel_t
    integer :: kind = KERNEL_WENDLAND_C2
    integer :: dim = 2
    real(wp) :: h = 1.0_wp
    real(wp) :: support = 2.0_wp   !< radius of the support, kappa h
    real(wp) :: norm = 0.0_wp      !< a_d, or 1/C_d for the Gaussian
    real(wp) :: inv_h = 1.0_wp
    real(wp) :: inv_h2 = 1.0_wp
    real(wp) :: w_cut = 0.0_wp     !< exp(-9), the Gaussian's offset at 3h
  end type kernel_t

contains

  !> The kernel kind for its input name ('wendland_c2', 'cubic_spline',
  !> 'gaussian'; config has validated it, Wendland C2 otherwise).
  pure integer function kernel_kind_of(name) result(kind)
    character(len=*), intent(in) :: name
    select case (name)
    case ('cubic_spline')
      kind = KERNEL_CUBIC_SPLINE
    case ('gaussian')
      kind = KERNEL_GAUSSIAN
    case default
      kind = KERNEL_WENDLAND_C2
    end select
  end function kernel_kind_of

  !> Sets up kernel `kind` in dimension `dim` with smoothing length h.
  function kernel_init(kind, dim, h) result(k)
    integer, intent(in) :: kind, dim
    real(wp), intent(in) :: h
    type(kernel_t) :: k
    k%kind = kind
    k%dim = dim
    k%h = h
    k%inv_h = 1.0_wp / h
    k%inv_h2 = 1.0_wp / h**2
    select case (kind)
    case (KERNEL_WENDLAND_C2)
      k%support = 2.0_wp * h
      if (dim == 2) then
        k%norm = 7.0_wp / (4.0_wp * pi * h**2)
      else
        k%norm = 21.0_wp / (16.0_wp * pi * h**3)
      end if
    case (KERNEL_CUBIC_SPLINE)
      k%support = 2.0_wp * h
      if (dim == 2) then
        k%norm = 10.0_wp / (7.0_wp * pi * h**2)
      else
        k%norm = 1.0_wp / (pi * h**3)
      end if
    case (KERNEL_GAUSSIAN)
      k%support = 3.0_wp * h
      k%w_cut = exp(-9.0_wp)
      ! C_d = integral over the ball of radius 3h of (exp(-q^2) - exp(-9)):
      ! C_2 = pi h^2 (1 - 10 e^-9); C_3 = h^3 (pi^1.5 erf(3) - 42 pi e^-9).
      if (dim == 2) then
        k%norm = 1.0_wp / (pi * h**2 * (1.0_wp - 10.0_wp * k%w_cut))
      else
        k%norm = 1.0_wp / (h**3 * (pi**1.5_wp * erf(3.0_wp) - 42.0_wp * pi * k%w_cut))
      end if
    end select
  end function kernel_init

  !> W(r); zero outside the support.
  pure elemental function kernel_w(k, r) result(w)
    type(kernel_t), intent(in) :: k
    real(wp), intent(in) :: r
    real(wp) :: w, q, s
    q = r * k%inv_h
    w = 0.0_wp
    select case (k%kind)
    case (KERNEL_WENDLAND_C2)
      if (q < 2.0_wp) then
        s = 1.0_wp - 0.5_wp * q
        w = k%norm * s**4 * (2.0_wp * q + 1.0_wp)
      end if
    case (KERNEL_CUBIC_SPLINE)
      if (q < 1.0_wp) then
        w = k%norm * (1.0_wp - 1.5_wp * q**2 + 0.75_wp * q**3)
      else if (q < 2.0_wp) then
        w = k%norm * 0.25_wp * (2.0_wp - q)**3
      end if
    case (KERNEL_GAUSSIAN)
      if (q < 3.0_wp) w = k%norm * (exp(-q**2) - k%w_cut)
    end select
  end function kernel_w

  !> F(r) = W'(r)/r, so that grad_i W_ij = F(r_ij) (x_i - x_j); zero outside.
  pure elemental function kernel_f(k, r) result(f)
    type(kernel_t), intent(in) :: k
    real(wp), intent(in) :: r
    real(wp) :: f, q, s
    q = r * k%inv_h
    f = 0.0_wp
    select case (k%kind)
    case (KERNEL_WENDLAND_C2)
      ! d/dq [(1 - q/2)^4 (2q + 1)] = -5 q (1 - q/2)^3
      if (q < 2.0_wp) then
        s = 1.0_wp - 0.5_wp * q
        f = -5.0_wp * k%norm * s**3 * k%inv_h2
      end if
    case (KERNEL_CUBIC_SPLINE)
      if (q < 1.0_wp) then
        f = k%norm * (-3.0_wp + 2.25_wp * q) * k%inv_h2
      else if (q < 2.0_wp) then
        f = -0.75_wp * k%norm * (2.0_wp - q)**2 / q * k%inv_h2
      end if
    case (KERNEL_GAUSSIAN)
      if (q < 3.0_wp) f = -2.0_wp * k%norm * exp(-q**2) * k%inv_h2
    end select
  end function kernel_f

  !> F for a list of squared distances r2(1:n), zero outside the support
  !> as kernel_f: one call per particle instead of one per pair, and a loop
  !> without branches (the kind is chosen once, outside it; masks instead of
  !> tests) that the compiler vectorises.  Pairs listed within the skin but
  !> beyond the support thus contribute exact zeros.
  pure subroutine kernel_f_list(k, n, r2, f)
    type(kernel_t), intent(in) :: k
    integer, intent(in) :: n
    real(wp), intent(in) :: r2(n)
    real(wp), intent(out) :: f(n)
    real(wp) :: q, s, c, s2
    integer :: l
    select case (k%kind)
    case (KERNEL_WENDLAND_C2)
      c = -5.0_wp * k%norm * k%inv_h2
      do l = 1, n
        s = max(0.0_wp, 1.0_wp - 0.5_wp * sqrt(r2(l)) * k%inv_h)
        f(l) = c * s**3
      end do
    case (KERNEL_CUBIC_SPLINE)
      do l = 1, n
        q = sqrt(r2(l)) * k%inv_h
        s = max(0.0_wp, 2.0_wp - q)
        ! the outer branch divides by q: bounded below where it is masked
        f(l) = merge(k%norm * (-3.0_wp + 2.25_wp * q) * k%inv_h2, &
                     -0.75_wp * k%norm * s**2 / max(q, 0.5_wp) * k%inv_h2, q < 1.0_wp)
      end do
    case (KERNEL_GAUSSIAN)
      c = -2.0_wp * k%norm * k%inv_h2
      s2 = k%support**2
      do l = 1, n
        f(l) = merge(c * exp(-min(r2(l), s2) * k%inv_h2), 0.0_wp, r2(l) < s2)
      end do
    end select
  end subroutine kernel_f_list

  !> W for a list of squared distances r2(1:n), zero outside the support
  !> (the companion of kernel_f_list, for terms that need the kernel value,
  !> such as the tensile instability control E7).
  pure subroutine kernel_w_list(k, n, r2, w)
    type(kernel_t), intent(in) :: k
    integer, intent(in) :: n
    real(wp), intent(in) :: r2(n)
    real(wp), intent(out) :: w(n)
    real(wp) :: q, s, s2
    integer :: l
    select case (k%kind)
    case (KERNEL_WENDLAND_C2)
      do l = 1, n
        q = sqrt(r2(l)) * k%inv_h
        s = max(0.0_wp, 1.0_wp - 0.5_wp * q)
        w(l) = k%norm * s**4 * (2.0_wp * q + 1.0_wp)
      end do
    case (KERNEL_CUBIC_SPLINE)
      do l = 1, n
        q = sqrt(r2(l)) * k%inv_h
        s = max(0.0_wp, 2.0_wp - q)
        w(l) = merge(k%norm * (1.0_wp - 1.5_wp * q**2 + 0.75_wp * q**3), &
                     k%norm * 0.25_wp * s**3, q < 1.0_wp)
      end do
    case (KERNEL_GAUSSIAN)
      s2 = k%support**2
      do l = 1, n
        w(l) = merge(k%norm * (exp(-min(r2(l), s2) * k%inv_h2) - k%w_cut), 0.0_wp, r2(l) < s2)
      end do
    end select
  end subroutine kernel_w_list

end module kernels
