!> The vortical square patch (2D): its group &square_vortical (side L, V0),
!> the initial u = V0 (f(y) - e^-4), v = -V0 (f(x) - e^-4),
!> f(s) = exp(-(4s/L)^2) with Laplacian p0 = 2 rho V0^2 f'(x) f'(y)
!> (doc/theory/ X4), its summary; the lattice and the symmetry and topology
!> diagnostics are case_square's.
module case_square_vortical
  use kinds, only: wp
  use input_visit, only: visit_t
  use case_base, only: case_fields_t
  use case_square, only: square_patch_t, square_fields, square_topology_summary
  use kernels, only: kernel_t
  use particles, only: particles_t
  use poisson_square, only: poisson_square_nodes
  use diagnostics, only: kinetic_energy, total_momentum
  use flow_diagnostics, only: angular_momentum
  use parallel_env, only: parallel_env_t
  implicit none
  private
  public :: square_vortical_t, square_vortical_case, vortical_velocity, vortical_vorticity

  type, extends(square_patch_t) :: square_vortical_t
  contains
    procedure :: visit => square_vortical_visit
    procedure :: max_speed => square_vortical_max_speed
    procedure :: initial_velocity => vortical_initial_velocity
    procedure :: pressure_source => vortical_source
    procedure :: initial_vorticity => vortical_initial_vorticity
    procedure :: time_unit => vortical_time_unit
    procedure :: fields => vortical_fields
    procedure :: summary => vortical_summary
  end type square_vortical_t

contains

  !> The case at its defaults: L = V0 = 1.
  function square_vortical_case() result(c)
    type(square_vortical_t) :: c
    c%name = 'square_vortical'
    c%help = 'the vortical square patch (2D)'
    c%no_packing = 'the square patches are always on a lattice'
    c%no_symmetry = 'its only mirror line is y = -x, not a coordinate plane'
    c%dim = 2
    c%sym = reshape([0.0_wp, -1.0_wp, -1.0_wp, 0.0_wp], [2, 2])  ! (x, y) -> (-y, -x)
  end function square_vortical_case

  !> &square_vortical (input_visit); v0 is the patch's rate.
  subroutine square_vortical_visit(self, v)
    class(square_vortical_t), intent(inout) :: self
    type(visit_t), intent(inout) :: v
    call v%var('side', self%side, 'side L of the initial square, centred at the origin', &
               gt=0.0_wp)
    call v%var('v0', self%rate, 'V0: initial u = V0 (f(y) - e^-4), v = -V0 (f(x) - e^-4), ' // &
               'f(s) = exp(-(4s/L)^2)', gt=0.0_wp, &
               doc='V0: initial u = V0 (f(y) - e^-4), v = -V0 (f(x) - e^-4), f(s) = ' // &
                   'exp(-(4 s/L)^2); the pressure solves Laplacian p = 2 rho0 (32 V0/L^2)^2 ' // &
                   'x y f(x) f(y), p = 0 on the edges ([theory](../theory/solutions.md) X4)')
  end subroutine square_vortical_visit

  !> |u| = sqrt(2) V0 (1 - e^-4) at the centre.
  subroutine square_vortical_max_speed(self, speed, formula)
    class(square_vortical_t), intent(in) :: self
    real(wp), intent(out) :: speed
    character(len=:), allocatable, intent(out) :: formula
    speed = sqrt(2.0_wp) * self%rate * (1 - exp(-4.0_wp))
    formula = '&square_vortical sqrt(2) (1 - e^-4) v0'
  end subroutine square_vortical_max_speed

  !> (X4) The initial velocity.
  pure function vortical_initial_velocity(self, x, y) result(u)
    class(square_vortical_t), intent(in) :: self
    real(wp), intent(in) :: x, y
    real(wp) :: u(3)
    u = vortical_velocity(x, y, self%side, self%rate)
  end function vortical_initial_velocity

  !> (X4) Laplacian p0 = 2 rho V0^2 f'(x) f'(y).
  function vortical_source(self, ng) result(f)
    class(square_vortical_t), intent(in) :: self
    integer, intent(in) :: ng
    real(wp), allocatable :: f(:, :)
    real(wp) :: g(ng)
    integer :: i, j
    g = -self%rate * dfdx(poisson_square_nodes(self%side, ng), self%side)  ! -V0 f'(x)
    allocate(f(ng, ng))
    do j = 1, ng
      do i = 1, ng
        f(i, j) = 2 * self%rho0 * g(i) * g(j)
      end do
    end do
  end function vortical_source

  !> vortical_vorticity at the initial positions.
  function vortical_initial_vorticity(self, x0) result(w)
    class(square_vortical_t), intent(in) :: self
    real(wp), intent(in) :: x0(:, :)
    real(wp), allocatable :: w(:)
    w = vortical_vorticity(x0(1, :), x0(2, :), self%side, self%rate)
  end function vortical_initial_vorticity

  !> L/V0.
  pure function vortical_time_unit(self) result(t)
    class(square_vortical_t), intent(in) :: self
    real(wp) :: t
    t = self%side / self%rate
  end function vortical_time_unit

  !> f'(s) for f(s) = exp(-(4 s/L)^2).
  elemental function dfdx(s, l) result(d)
    real(wp), intent(in) :: s, l
    real(wp) :: d
    d = -32 * s / l**2 * exp(-(4 * s / l)**2)
  end function dfdx

  !> The vortical patch's initial velocity (X4) at (x, y).
  pure function vortical_velocity(x, y, l, v0) result(u)
    real(wp), intent(in) :: x, y, l, v0
    real(wp) :: u(3)
    u = [v0 * (exp(-(4 * y / l)**2) - exp(-4.0_wp)), &
         -v0 * (exp(-(4 * x / l)**2) - exp(-4.0_wp)), 0.0_wp]
  end function vortical_velocity

  !> Its vorticity dv/dx - du/dy = -V0 (f'(x) + f'(y)), carried unchanged
  !> by each fluid particle in inviscid 2D flow.
  elemental function vortical_vorticity(x, y, l, v0) result(w)
    real(wp), intent(in) :: x, y, l, v0
    real(wp) :: w
    w = -v0 * (dfdx(x, l) + dfdx(y, l))
  end function vortical_vorticity

  !> The squares' fields; attribute time_scaled (t V0/L).
  subroutine vortical_fields(self, t, f)
    class(square_vortical_t), intent(inout) :: self
    real(wp), intent(in) :: t
    type(case_fields_t), intent(out) :: f
    call square_fields(self, t, f)
    f%attr_names = [character(len=32) :: 'time_scaled']
    f%attr_values = [t * self%rate / self%side]
  end subroutine vortical_fields

  !> The closing summary (rank 0 prints; collective).
  subroutine vortical_summary(self, env, unit, t, parts, kernel)
    class(square_vortical_t), intent(inout) :: self
    type(parallel_env_t), intent(in) :: env
    integer, intent(in) :: unit
    real(wp), intent(in) :: t
    type(particles_t), intent(in) :: parts
    type(kernel_t), intent(in) :: kernel
    real(wp) :: ke, lz, mom(3), scale_p
    ke = kinetic_energy(env, parts)
    lz = angular_momentum(env, parts)
    mom = total_momentum(env, parts)
    if (env%rank /= 0) return
    associate(l => self%side, rate => self%rate, rho0 => self%rho0)
    write(unit, '(a)') ''
    scale_p = rho0 * rate**2
    write(unit, '(a,f8.4,a,i0,a,f8.5,a)') 'Vortical square at t V0/L = ', t * rate / l, &
      ' (', self%n_global, ' particles, dx = ', self%dx / l, ' L):'
    write(unit, '(2x,a,f10.6,a)') 'initial pressure p0(L/4, L/4) ', &
      self%p_quarter0 / scale_p, ' rho V0^2 (doc/theory/ X4: -0.229452)'
    write(unit, '(2x,a,f8.3,a)') 'kinetic energy change since t = 0 ', &
      100 * (ke / self%ke_start - 1), ' %'
    write(unit, '(2x,a,es10.3,a)') 'angular momentum change since t = 0 ', &
      (lz - self%lz_start) / (rho0 * rate * l**3), ' rho V0 L^3'
    write(unit, '(2x,a,2f10.6,a,2f10.6,a)') 'momentum ', mom(1:2) / (rho0 * rate * l**2), &
      ' rho V0 L^2 (initial ', self%mom_start(1:2) / (rho0 * rate * l**2), ')'
    write(unit, '(2x,a,es10.3,a,es10.3,a)') 'mirror-symmetry error: RMS ', self%sym_rms, &
      ' dx, largest ', self%sym_max, ' dx'
    call square_topology_summary(self, unit, 't V0/L', rate / l, .true.)
    end associate
  end subroutine vortical_summary

end module case_square_vortical
