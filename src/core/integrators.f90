!> The time integrators of the state y = (x, u, rho), dy/dt = k(y) =
!> (u, du, drho) (doc/theory/ T1, T2), by reverse communication: the
!> caller evaluates k at stage s (s = 1 .. integrator_stages) into u, du
!> and drho, then integrator_advance(s) moves the state to the input of
!> stage s + 1, or after the last stage to the end of the step.  So the
!> right-hand side, with its halo exchanges, stays with the caller and no
!> procedure argument is needed.
module integrators
  use kinds, only: wp
  implicit none
  private
  public :: integrator_t, integrator_reserve, integrator_stages, integrator_advance, &
            SCHEME_RK4, SCHEME_PC2

  integer, parameter :: SCHEME_RK4 = 1   !< (T1) classical 4th-order Runge-Kutta
  integer, parameter :: SCHEME_PC2 = 2   !< (T2) 2-stage predictor-corrector

  type :: integrator_t
    integer :: scheme = SCHEME_RK4
    real(wp), allocatable :: xs(:, :), us(:, :), rhos(:)   !< state at the start of a step
    real(wp), allocatable :: xa(:, :), ua(:, :), rhoa(:)   !< RK4 accumulators
  end type integrator_t

contains

  !> Room for cap particles (work arrays only ever grow).
  subroutine integrator_reserve(ig, cap)
    type(integrator_t), intent(inout) :: ig
    integer, intent(in) :: cap
    if (allocated(ig%xs)) then
      if (size(ig%rhos) >= cap) return
      deallocate(ig%xs, ig%us, ig%rhos, ig%xa, ig%ua, ig%rhoa)
    end if
    allocate(ig%xs(3, cap), ig%us(3, cap), ig%rhos(cap), ig%xa(3, cap), ig%ua(3, cap), &
             ig%rhoa(cap))
  end subroutine integrator_reserve

  !> Right-hand-side evaluations per step.
  pure integer function integrator_stages(ig) result(k)
    type(integrator_t), intent(in) :: ig
    k = merge(4, 2, ig%scheme == SCHEME_RK4)
  end function integrator_stages

  !> After the evaluation of stage `stage` of a step of dt at the current
  !> (x, u, rho) of particles 1..n, with du and drho there: the state at
  !> which the next stage is evaluated, or the end of the step.
  subroutine integrator_advance(ig, stage, dt, n, x, u, rho, du, drho)
    type(integrator_t), intent(inout) :: ig
    integer, intent(in) :: stage, n
    real(wp), intent(in) :: dt
    real(wp), intent(inout) :: x(3, n), u(3, n), rho(n)
    real(wp), intent(in) :: du(3, n), drho(n)
    if (stage == 1) then
      ig%xs(:, 1:n) = x
      ig%us(:, 1:n) = u
      ig%rhos(1:n) = rho
    end if
    select case (ig%scheme)
    case (SCHEME_RK4)
      ! (T1) y_{n+1} = y_n + dt/6 (k1 + 2 k2 + 2 k3 + k4), accumulated in
      ! (xa, ua, rhoa) as the stages come
      select case (stage)
      case (1)
        ! k1 at y0; y1 = y0 + dt/2 k1
        ig%xa(:, 1:n) = ig%xs(:, 1:n) + dt / 6 * u
        ig%ua(:, 1:n) = ig%us(:, 1:n) + dt / 6 * du
        ig%rhoa(1:n) = ig%rhos(1:n) + dt / 6 * drho
        call half_stage(0.5_wp * dt)
      case (2)
        ! k2 at y1; y2 = y0 + dt/2 k2
        call accumulate(dt / 3)
        call half_stage(0.5_wp * dt)
      case (3)
        ! k3 at y2; y3 = y0 + dt k3
        call accumulate(dt / 3)
        call half_stage(dt)
      case default
        ! k4 at y3; y = y0 + dt/6 (k1 + 2 k2 + 2 k3 + k4)
        x = ig%xa(:, 1:n) + dt / 6 * u
        u = ig%ua(:, 1:n) + dt / 6 * du
        rho = ig%rhoa(1:n) + dt / 6 * drho
      end select
    case (SCHEME_PC2)
      ! (T2) predictor to the half step, derivatives there, then the
      ! corrector; positions advance with the mean of the old and new
      ! velocities
      if (stage == 1) then
        call half_stage(0.5_wp * dt)
      else
        rho = ig%rhos(1:n) + dt * drho
        u = ig%us(:, 1:n) + dt * du
        x = ig%xs(:, 1:n) + 0.5_wp * dt * (ig%us(:, 1:n) + u)
      end if
    end select

  contains

    !> y = y0 + tau k, with k = (u, du, drho) of the current stage; x first,
    !> while u still holds the stage velocity.
    subroutine half_stage(tau)
      real(wp), intent(in) :: tau
      x = ig%xs(:, 1:n) + tau * u
      u = ig%us(:, 1:n) + tau * du
      rho = ig%rhos(1:n) + tau * drho
    end subroutine half_stage

    subroutine accumulate(w)
      real(wp), intent(in) :: w
      ig%xa(:, 1:n) = ig%xa(:, 1:n) + w * u
      ig%ua(:, 1:n) = ig%ua(:, 1:n) + w * du
      ig%rhoa(1:n) = ig%rhoa(1:n) + w * drho
    end subroutine accumulate

  end subroutine integrator_advance

end module integrators
