!> The rotating square patch (2D): its group &square_rotation (side L,
!> omega), the initial rigid rotation u = omega y, v = -omega x with
!> Laplacian p0 = 2 rho omega^2 (doc/theory/ X3), the pressure at the centre
!> A and its acoustic frequency, the kinetic energy against KE0 =
!> rho omega^2 L^4/12; the lattice and the symmetry and topology
!> diagnostics are case_square's.
module case_square_rotation
  use kinds, only: wp
  use input_visit, only: visit_t
  use case_base, only: case_fields_t
  use case_square, only: square_patch_t, square_columns, square_sample, square_fields, &
                         square_topology_summary
  use kernels, only: kernel_t
  use particles, only: particles_t
  use diagnostics, only: probe_pressure, kinetic_energy
  use flow_diagnostics, only: angular_momentum
  use spectrum, only: dominant_frequency
  use parallel_env, only: parallel_env_t
  use, intrinsic :: ieee_arithmetic, only: ieee_is_nan
  implicit none
  private
  public :: square_rotation_t, square_rotation_case

  !> Lowest frequency searched for the acoustic peak of p_A, as a fraction
  !> of the lowest acoustic mode c0/(sqrt(2) L) (X6): the filter's cut-off.
  !> A fixed 0.8 omega let the slow rise that the detrend leaves win over
  !> the acoustic peak at 90,000 particles (1.20 omega found, f0 4.95).
  real(wp), parameter :: F_MIN_OVER_F0 = 0.5_wp

  type, extends(square_patch_t) :: square_rotation_t
    ! the centre pressure history, for its spectrum
    integer :: n_hist = 0
    real(wp), allocatable :: t_hist(:), p_hist(:)
  contains
    procedure :: visit => square_rotation_visit
    procedure :: max_speed => square_rotation_max_speed
    procedure :: initial_velocity => rotation_velocity
    procedure :: pressure_source => rotation_source
    procedure :: initial_vorticity => rotation_vorticity
    procedure :: time_unit => rotation_time_unit
    procedure :: columns => rotation_columns
    procedure :: sample => rotation_sample
    procedure :: fields => rotation_fields
    procedure :: summary => rotation_summary
  end type square_rotation_t

contains

  !> The case at its defaults: L = omega = 1.
  function square_rotation_case() result(c)
    type(square_rotation_t) :: c
    c%name = 'square_rotation'
    c%help = 'the rotating square patch (2D)'
    c%no_packing = 'the square patches are always on a lattice'
    c%no_symmetry = 'the rotating square has no mirror plane'
    c%dim = 2
    c%sym = reshape([0.0_wp, 1.0_wp, -1.0_wp, 0.0_wp], [2, 2])   ! (x, y) -> (-y, x)
  end function square_rotation_case

  !> &square_rotation (input_visit); omega is the patch's rate.
  subroutine square_rotation_visit(self, v)
    class(square_rotation_t), intent(inout) :: self
    type(visit_t), intent(inout) :: v
    call v%var('side', self%side, 'side L of the initial square, centred at the origin', &
               gt=0.0_wp)
    call v%var('omega', self%rate, 'omega: initial rigid rotation u = omega y, v = -omega x', &
               gt=0.0_wp, &
               doc='omega: initial rigid rotation u = omega y, v = -omega x; the pressure ' // &
                   'solves Laplacian p = 2 rho0 omega^2, p = 0 on the edges')
  end subroutine square_rotation_visit

  !> u = omega (y, -x): omega L/sqrt(2) at the corners.
  subroutine square_rotation_max_speed(self, speed, formula)
    class(square_rotation_t), intent(in) :: self
    real(wp), intent(out) :: speed
    character(len=:), allocatable, intent(out) :: formula
    speed = self%rate * self%side / sqrt(2.0_wp)
    formula = '&square_rotation omega side/sqrt(2)'
  end subroutine square_rotation_max_speed

  !> (X3) The rigid rotation u = omega y, v = -omega x.
  pure function rotation_velocity(self, x, y) result(u)
    class(square_rotation_t), intent(in) :: self
    real(wp), intent(in) :: x, y
    real(wp) :: u(3)
    u = [self%rate * y, -self%rate * x, 0.0_wp]
  end function rotation_velocity

  !> (X3) Laplacian p0 = 2 rho omega^2.
  function rotation_source(self, ng) result(f)
    class(square_rotation_t), intent(in) :: self
    integer, intent(in) :: ng
    real(wp), allocatable :: f(:, :)
    allocate(f(ng, ng))
    f = 2 * self%rho0 * self%rate**2
  end function rotation_source

  !> -2 omega everywhere.
  function rotation_vorticity(self, x0) result(w)
    class(square_rotation_t), intent(in) :: self
    real(wp), intent(in) :: x0(:, :)
    real(wp), allocatable :: w(:)
    allocate(w(size(x0, 2)))
    w = -2 * self%rate
  end function rotation_vorticity

  !> 1/omega.
  pure function rotation_time_unit(self) result(t)
    class(square_rotation_t), intent(in) :: self
    real(wp) :: t
    t = 1 / self%rate
  end function rotation_time_unit

  !> The exact flow's kinetic energy KE0 = rho omega^2 L^4/12.
  pure function ke_ref(self)
    class(square_rotation_t), intent(in) :: self
    real(wp) :: ke_ref
    ke_ref = self%rho0 * self%rate**2 * self%side**4 / 12
  end function ke_ref

  !> p_centre, p_centre_initial, kinetic_energy_ref, then the squares'.
  subroutine rotation_columns(self, names)
    class(square_rotation_t), intent(in) :: self
    character(len=32), allocatable, intent(out) :: names(:)
    call square_columns(self, names)
    names = [character(len=32) :: 'p_centre', 'p_centre_initial', 'kinetic_energy_ref', names]
  end subroutine rotation_columns

  !> p_centre: pressure at A (Shepard interpolation), recorded for its
  !> spectrum; p_centre_initial: p_A(0) of the Poisson solution;
  !> kinetic_energy_ref: rho omega^2 L^4/12; then the squares' values.
  subroutine rotation_sample(self, env, t, parts, kernel, values)
    class(square_rotation_t), intent(inout) :: self
    type(parallel_env_t), intent(in) :: env
    real(wp), intent(in) :: t
    type(particles_t), intent(in) :: parts
    type(kernel_t), intent(in) :: kernel
    real(wp), allocatable, intent(out) :: values(:)
    real(wp) :: p_centre
    call square_sample(self, env, t, parts, kernel, values)
    p_centre = probe_pressure(env, parts, kernel, [0.0_wp, 0.0_wp, 0.0_wp])
    call record(self, t, p_centre)
    values = [p_centre, self%p_centre0, ke_ref(self), values]
  end subroutine rotation_sample

  !> Appends (t, p) to the centre-pressure history (a NaN, no particle near
  !> the centre, is left out).
  subroutine record(self, t, p)
    class(square_rotation_t), intent(inout) :: self
    real(wp), intent(in) :: t, p
    real(wp), allocatable :: tmp(:)
    if (ieee_is_nan(p)) return
    if (.not. allocated(self%t_hist)) allocate(self%t_hist(1024), self%p_hist(1024))
    if (self%n_hist == size(self%t_hist)) then
      allocate(tmp(2 * self%n_hist))
      tmp(1:self%n_hist) = self%t_hist
      call move_alloc(tmp, self%t_hist)
      allocate(tmp(2 * self%n_hist))
      tmp(1:self%n_hist) = self%p_hist
      call move_alloc(tmp, self%p_hist)
    end if
    self%n_hist = self%n_hist + 1
    self%t_hist(self%n_hist) = t
    self%p_hist(self%n_hist) = p
  end subroutine record

  !> The squares' fields; attributes time_scaled (t omega),
  !> p_centre_initial, kinetic_energy_ref.
  subroutine rotation_fields(self, t, f)
    class(square_rotation_t), intent(inout) :: self
    real(wp), intent(in) :: t
    type(case_fields_t), intent(out) :: f
    call square_fields(self, t, f)
    f%attr_names = [character(len=32) :: 'time_scaled', 'p_centre_initial', &
                    'kinetic_energy_ref']
    f%attr_values = [t * self%rate, self%p_centre0, ke_ref(self)]
  end subroutine rotation_fields

  !> The closing summary (rank 0 prints; collective).
  subroutine rotation_summary(self, env, unit, t, parts, kernel)
    class(square_rotation_t), intent(inout) :: self
    type(parallel_env_t), intent(in) :: env
    integer, intent(in) :: unit
    real(wp), intent(in) :: t
    type(particles_t), intent(in) :: parts
    type(kernel_t), intent(in) :: kernel
    real(wp) :: ke, lz, p_centre, f0, freq, scale_p
    integer :: j, k
    ke = kinetic_energy(env, parts)
    lz = angular_momentum(env, parts)
    p_centre = probe_pressure(env, parts, kernel, [0.0_wp, 0.0_wp, 0.0_wp])
    if (env%rank /= 0) return
    associate(l => self%side, rate => self%rate, rho0 => self%rho0)
    write(unit, '(a)') ''
    scale_p = rho0 * rate**2 * l**2
    f0 = self%c0 / (sqrt(2.0_wp) * l)
    write(unit, '(a,f8.4,a,i0,a,f8.5,a)') 'Rotating square at t omega = ', t * rate, &
      ' (', self%n_global, ' particles, dx = ', self%dx / l, ' L):'
    write(unit, '(2x,a,f10.6,a,f10.6,a)') 'pressure at A: initial ', &
      self%p_centre0 / scale_p, ' (series -0.147343), now (raw) ', p_centre / scale_p, &
      ' rho omega^2 L^2'
    ! the acoustic frequency of p_A in windows of 1/omega: the first one
    ! against the lowest mode of the square, the later ones as the patch
    ! deforms (its core shrinks and the frequency rises)
    freq = window_frequency(self, 0.0_wp, 1 / rate)
    if (freq > 0) then
      write(unit, '(2x,a,f8.4,a,f8.4,a,f7.2,a)') 'dominant frequency of raw p_A over ' // &
        '0 <= t omega <= 1: ', freq / rate, ' omega; lowest acoustic mode c0/(sqrt(2) L) = ', &
        f0 / rate, ' omega: ', 100 * (freq / f0 - 1), ' %'
    else
      write(unit, '(2x,a)') 'dominant frequency of raw p_A: too few samples (it needs ' // &
        '32 over 0 <= t omega <= 1: t_end >= 1/omega and a small output.probe_every)'
    end if
    k = 1
    do while (k < 16)
      if (.not. window_frequency(self, k / rate, (k + 1) / rate) > 0) exit
      k = k + 1
    end do
    if (k > 1) write(unit, '(2x,a,15f7.3)') 'later, in windows of 1/omega: ', &
      (window_frequency(self, j / rate, (j + 1) / rate) / rate, j = 1, k - 1)
    write(unit, '(2x,a,f8.5,a,f8.3,a)') 'kinetic energy / KE0 (rho omega^2 L^4/12) ', &
      ke / ke_ref(self), ', change since t = 0 ', 100 * (ke / self%ke_start - 1), ' %'
    write(unit, '(2x,a,es10.3)') 'angular momentum: relative change since t = 0 ', &
      (lz - self%lz_start) / abs(self%lz_start)
    write(unit, '(2x,a,es10.3,a,es10.3,a)') '4-fold symmetry error: RMS ', self%sym_rms, &
      ' dx, largest ', self%sym_max, ' dx'
    call square_topology_summary(self, unit, 't omega', rate, .false.)
    end associate
  end subroutine rotation_summary

  !> Dominant frequency (dominant_frequency, above F_MIN_OVER_F0 f0)
  !> of the recorded p_A over t0 <= t <= t1; 0 unless the record covers the
  !> window with at least 32 samples.
  function window_frequency(self, t0, t1) result(freq)
    class(square_rotation_t), intent(in) :: self
    real(wp), intent(in) :: t0, t1
    real(wp) :: freq, eps
    integer :: i0, i1
    freq = 0
    if (self%n_hist < 32) return
    eps = 1e-9_wp * (t1 - t0)
    if (self%t_hist(self%n_hist) < t1 - eps) return
    i0 = 1
    do while (self%t_hist(i0) < t0 - eps)
      i0 = i0 + 1
    end do
    i1 = i0
    do while (i1 < self%n_hist)
      if (self%t_hist(i1 + 1) > t1 + eps) exit
      i1 = i1 + 1
    end do
    if (i1 - i0 + 1 < 32) return
    freq = dominant_frequency(self%t_hist(i0:i1), self%p_hist(i0:i1), &
                              F_MIN_OVER_F0 * self%c0 / (sqrt(2.0_wp) * self%side))
  end function window_frequency

end module case_square_rotation
