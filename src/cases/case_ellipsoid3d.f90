!> The stretching sphere (3D): its group &ellipsoid3d (radius R, A0, the
!> rates of the initial linear velocity u_k = rates(k) A0 x_k and the
!> prepared start I1) and the rules on the rates; the set-up, diagnostics
!> and exact solution are case_stretching's.
module case_ellipsoid3d
  use, intrinsic :: ieee_arithmetic, only: ieee_is_finite
  use kinds, only: wp
  use input_visit, only: visit_t
  use input_text, only: real_str, real_list
  use case_stretching, only: stretching_t
  implicit none
  private
  public :: ellipsoid3d_t, ellipsoid3d_case

  real(wp), parameter :: RATES_SUM_TOL = 1.0e-12_wp   !< incompressibility of the rates

  type, extends(stretching_t) :: ellipsoid3d_t
  contains
    procedure :: visit => ellipsoid3d_visit
    procedure :: check => ellipsoid3d_check
    procedure :: max_speed => ellipsoid3d_max_speed
  end type ellipsoid3d_t

contains

  !> The case at its defaults: R = A0 = 1, rates (-1, -1, 2).
  function ellipsoid3d_case() result(c)
    type(ellipsoid3d_t) :: c
    c%name = 'ellipsoid3d'
    c%help = 'the stretching sphere (3D)'
    c%no_packing = ''
    c%no_symmetry = ''
    c%dim = 3
    c%rates = [-1.0_wp, -1.0_wp, 2.0_wp]
  end function ellipsoid3d_case

  !> &ellipsoid3d (input_visit).
  subroutine ellipsoid3d_visit(self, v)
    class(ellipsoid3d_t), intent(inout) :: self
    type(visit_t), intent(inout) :: v
    call v%var('radius', self%radius, 'radius R of the initial sphere', gt=0.0_wp)
    call v%var('a0', self%a0, 'A0: the unit of the rates', gt=0.0_wp)
    call v%var('rates', self%rates, 'initial velocity u_k = rates(k) A0 x_k (rates in units ' // &
               'of A0)', rule='summing to zero within 1e-12, not all zero')
    call v%var('prepared', self%prepared, 'add the compressible part of the start (I1, ' // &
               'doc/theory/solutions.md): no acoustic mode from P''(0)', &
               doc='add the compressible part of the initial velocity (I1, ' // &
                   '[solutions](../theory/solutions.md)): without it the falling centre ' // &
                   'pressure rings the lowest acoustic mode (6-8 % of P(0) at c0 = 10); ' // &
                   'input/ellipsoid3d.nml sets it')
  end subroutine ellipsoid3d_visit

  !> The rates of a divergence-free linear field sum to zero (doc/theory/ X1).
  subroutine ellipsoid3d_check(self, var, what, hint)
    class(ellipsoid3d_t), intent(in) :: self
    character(len=:), allocatable, intent(out) :: var, what, hint
    character(len=:), allocatable :: head
    real(wp) :: s
    var = 'rates'
    hint = ''
    head = 'rates = ' // real_list(self%rates)
    s = sum(self%rates)
    if (.not. all(ieee_is_finite(self%rates))) then
      what = head // ' are not all finite'
    else if (.not. abs(s) <= RATES_SUM_TOL) then
      what = head // ' sum to ' // real_str(s)
      hint = ': they must sum to zero (incompressible flow), within ' // &
             real_str(RATES_SUM_TOL) // ', e.g. -1.0, -1.0, 2.0'
    else if (.not. maxval(abs(self%rates)) > 0) then
      what = head // ' are all zero'
      hint = ': give a non-zero flow, e.g. -1.0, -1.0, 2.0'
    else
      var = ''
      what = ''
    end if
  end subroutine ellipsoid3d_check

  !> u_k = rates(k) A0 x_k: max|rates| A0 R on the sphere.
  subroutine ellipsoid3d_max_speed(self, speed, formula)
    class(ellipsoid3d_t), intent(in) :: self
    real(wp), intent(out) :: speed
    character(len=:), allocatable, intent(out) :: formula
    speed = maxval(abs(self%rates)) * self%a0 * self%radius
    formula = '&ellipsoid3d max|rates| a0 radius'
  end subroutine ellipsoid3d_max_speed

end module case_ellipsoid3d
