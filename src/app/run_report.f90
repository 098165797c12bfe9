!> What a run prints: the start (case, particles, scales, time step), the
!> progress, the end (costs, parallel efficiency, memory), a stop with the
!> command that continues it, and a blow-up; rank 0 prints all but the
!> blow-up, which every rank that has one reports.
module run_report
  use, intrinsic :: iso_fortran_env, only: output_unit, error_unit
  use kinds, only: wp, i8
  use memory_usage, only: peak_memory_mb
  use neighbours, only: neighbour_counts
  use config, only: config_t, config_resolution_scale
  use solver, only: solver_t
  use decomposition, only: decomp_partners
  use parallel_env, only: parallel_env_t, par_sum, par_max
  use mirrors, only: mirror_word
  use run_setup, only: run_t
  implicit none
  private
  public :: print_start, print_progress, print_end, print_stopped, report_blow_up

contains

  !> The case, the particles and their scales, the scheme, the first time
  !> step and its limits.
  subroutine print_start(cfg, env, s, run, dt)
    type(config_t), intent(in) :: cfg
    type(parallel_env_t), intent(in) :: env
    type(solver_t), intent(in) :: s
    type(run_t), intent(in) :: run
    real(wp), intent(in) :: dt
    real(wp) :: listed, in_range
    integer(i8) :: n_listed, n_in_range
    call neighbour_counts(s%lm%nl, s%parts%n, s%parts%x, s%rhs%kernel%support**2, n_listed, &
                          n_in_range)
    listed = par_sum(env, real(n_listed, wp)) / max(run%n_global, 1_i8)
    in_range = par_sum(env, real(n_in_range, wp)) / max(run%n_global, 1_i8)
    if (env%rank /= 0) return
    write(output_unit, '(a)') 'sph: case ' // trim(cfg%run%case_name) // ', output in ' // run%dir
    write(output_unit, '(a,i0,a,i0,a,es10.3,a,es10.3,a,f5.2,a)') '  particles ', run%n_global, &
      '  dim ', s%parts%dim, '  dx ', run%dx, '  h ', s%rhs%kernel%h, '  (h/dx ', &
      cfg%particles%h_over_dx, ')'
    write(output_unit, '(a,f8.2,a,f6.4,a,f8.1,a,f8.1,a)') '  c0 ', s%rhs%c0, '  Mach ', &
      s%umax / s%rhs%c0, '  neighbours per particle ', in_range, ' (', listed, ' in the list)'
    write(output_unit, '(a)') '  kernel ' // trim(cfg%numerics%kernel) // ', integrator ' // &
      trim(cfg%numerics%integrator) // ', viscosity ' // trim(cfg%numerics%viscosity) // &
      ', diffusion ' // trim(cfg%numerics%diffusion)
    if (cfg%particles%n_ref > 0) write(output_unit, '(a,es10.3,4(a,f8.4),a,f6.3,4(a,f7.3),a)') &
      '  resolution scaling from n_ref ', cfg%particles%n_ref, ': h/dx ', &
      cfg%particles%h_over_dx, ', c0 ', cfg%physics%c0, ', alpha ', cfg%numerics%alpha, &
      ', delta ', cfg%numerics%delta, ' (exponents of (n/n_ref)^(1/dim) = ', &
      config_resolution_scale(cfg), ': ', &
      cfg%particles%h_exponent, ', ', cfg%physics%c0_exponent, ', ', &
      cfg%numerics%alpha_exponent, ', ', cfg%numerics%delta_exponent, ')'
    if (len_trim(cfg%particles%from) > 0) write(output_unit, '(a)') &
      '  packed particles from ' // trim(cfg%particles%from)
    if (run%pack_report%iterations > 0) write(output_unit, '(a,i0,a,f7.2,a,i0,a,es9.2,a,i0,a)') &
      '  packed in ', run%pack_report%iterations, ' iterations, ', run%pack_report%wall, &
      ' s (', run%pack_report%rebuilds, ' list builds, last move ', &
      run%pack_report%last_move, ' dx, ', run%pack_report%clipped, ' moves clipped)'
    write(output_unit, '(a,es10.3,a,es10.3,a,es10.3,a,es10.3,a,es10.3,a)') '  dt ', dt, &
      ' = min(acoustic ', s%dt_cfl, ', force ', s%dt_force, ', viscous ', s%dt_visc, &
      ', diffusive ', s%dt_diff, ')'
    write(output_unit, '(a,f10.4,a,i0,a)') '  end time ', cfg%run%t_end, ', about ', &
      nint(cfg%run%t_end / dt), ' steps'
    flush(output_unit)
  end subroutine print_start

  !> One line: step, time, time step, wall time, the time left and the
  !> imbalance.
  subroutine print_progress(env, step, t, dt, t_start, t_end, wall, imbalance)
    type(parallel_env_t), intent(in) :: env
    integer, intent(in) :: step
    real(wp), intent(in) :: t, dt, t_start, t_end, wall, imbalance
    real(wp) :: eta
    if (env%rank /= 0) return
    eta = 0
    if (t > t_start) eta = wall * (t_end - t) / (t - t_start)
    if (env%nranks > 1) then
      write(output_unit, '(a,i8,a,f10.5,a,es10.3,a,f9.1,a,f9.1,a,f6.3)') 'step ', step, &
        '  t ', t, '  dt ', dt, '  wall ', wall, ' s  ETA ', eta, ' s  imbalance ', imbalance
    else
      write(output_unit, '(a,i8,a,f10.5,a,es10.3,a,f9.1,a,f9.1,a)') 'step ', step, '  t ', t, &
        '  dt ', dt, '  wall ', wall, ' s  ETA ', eta, ' s'
    end if
    flush(output_unit)
  end subroutine print_progress

  !> The costs of the steps: rates, counts, memory, where the time went,
  !> and on several ranks what the decomposition cost.
  subroutine print_end(env, s, run, steps, wall)
    type(parallel_env_t), intent(in) :: env
    type(solver_t), intent(in) :: s
    type(run_t), intent(in) :: run
    integer, intent(in) :: steps
    real(wp), intent(in) :: wall
    real(wp) :: comm, mem_max, mem_total, listed, in_range, halo, partners, partners_max, &
                words, words_max, messages, pairs, t(5), rate, across, images
    integer(i8) :: n_listed, n_in_range
    integer :: k
    comm = par_max(env, s%dc%comm_time)
    ! what the decomposition costs in copies and messages (doc/developer/parallel.md)
    halo = par_sum(env, real(s%parts%n_halo - s%dc%halo%n_images, wp)) / max(run%n_global, 1_i8)
    partners = par_sum(env, real(decomp_partners(s%dc), wp)) / env%nranks
    partners_max = par_max(env, real(decomp_partners(s%dc), wp))
    words = par_sum(env, s%dc%words_sent) / env%nranks
    words_max = par_max(env, s%dc%words_sent)
    messages = par_sum(env, real(s%dc%messages_sent, wp)) / env%nranks
    ! listed pairs with at least one owned particle: those across a cut are
    ! held (and evaluated) on both ranks
    pairs = par_sum(env, real(s%lm%nl%n_pairs, wp)) / max(run%n_global, 1_i8)
    ! where the time went: the largest share over the ranks of each part
    t = [s%timing%pairs, s%timing%rebuild, s%timing%check, s%dc%comm_time, s%timing%integrate]
    do k = 1, 5
      t(k) = par_max(env, t(k)) / max(wall, 1e-9_wp)
    end do
    rate = par_sum(env, s%timing%pair_visits / max(s%timing%pairs, 1e-9_wp)) / env%nranks
    mem_max = par_max(env, peak_memory_mb())
    mem_total = par_sum(env, peak_memory_mb())
    call neighbour_counts(s%lm%nl, s%parts%n, s%parts%x, s%rhs%kernel%support**2, n_listed, &
                          n_in_range)
    listed = par_sum(env, real(n_listed, wp)) / max(run%n_global, 1_i8)
    in_range = par_sum(env, real(n_in_range, wp)) / max(run%n_global, 1_i8)
    across = par_sum(env, real(s%n_across, wp))
    images = par_sum(env, real(s%dc%halo%n_images, wp)) / max(run%n_global, 1_i8)
    if (env%rank /= 0) return
    write(output_unit, '(a,i0,a,f10.2,a,es10.3,a,es10.3,a,i0,a)') 'done: ', steps, ' steps in ', &
      wall, ' s, ', wall / max(steps, 1), ' s/step, ', &
      real(run%n_global, wp) * steps / max(wall, 1e-9_wp), ' particle-steps/s on ', &
      env%nranks, ' rank(s)'
    write(output_unit, '(a,i0,a,i0,a,i0,a,f6.2,a,f9.1,a,f9.1,a)') &
      '  right-hand sides ', s%n_evaluations, ', list rebuilds ', s%lm%n_rebuilds, &
      ', snapshots ', run%n_snapshots, ' (skin ', s%lm%skin / s%rhs%kernel%h, &
      ' h), peak memory ', mem_max, ' MB per rank (max), ', mem_total, ' MB in all'
    write(output_unit, '(a,f8.1,a,f8.1,a)') '  neighbours per particle: ', listed, &
      ' in the list, ', in_range, ' within the kernel support'
    if (run%problem%mirror /= 0) write(output_unit, '(a,f8.4,a,i0,a)') &
      '  mirror planes ' // mirror_word(run%problem%mirror) // ': ', images, &
      ' images per particle (at the last list build); ', nint(across, i8), &
      ' times a particle traded places with its image (M4)'
    write(output_unit, '(a,5(f5.1,a),es10.3,a)') '  time (largest rank): pair passes ', &
      100 * t(1), ' %, list rebuilds ', 100 * t(2), ' %, validity test ', 100 * t(3), &
      ' %, communication ', 100 * t(4), ' %, integration ', 100 * t(5), ' %; ', rate, &
      ' listed pairs per second per rank in the passes'

    if (env%nranks > 1) write(output_unit, '(a,f6.3,a,f6.3,a,i0,a,i0,a,f5.1,a)') &
      '  imbalance (max/mean particles) mean ', run%imb_sum / max(run%imb_n, 1), ', max ', &
      run%imb_max, ', re-balanced ', s%dc%n_balances, ' times, ', s%dc%n_migrated, &
      ' migrations, communication ', 100 * comm / max(wall, 1e-9_wp), ' % of the wall time'
    if (env%nranks > 1) write(output_unit, '(a,f8.4,a,f6.2,a,i0,a,es10.3,a,es10.3,a,f8.2,a)') &
      '  halo: ', halo, ' copies per particle, ', partners, ' partner ranks per rank (max ', &
      nint(partners_max), '); sent per rank and step ', 8 * words / max(steps, 1), &
      ' bytes (max ', 8 * words_max / max(steps, 1), '), ', messages / max(steps, 1), &
      ' messages'
    if (env%nranks > 1) write(output_unit, '(a,f8.4,a,f6.2,a)') '  pairs evaluated ', &
      pairs / max(listed / 2, 1e-300_wp), ' times the one-rank count (', &
      100 * (pairs / max(listed / 2, 1e-300_wp) - 1), ' % across the cuts, twice)'
    flush(output_unit)
  end subroutine print_end

  !> Says why the run stopped, where its checkpoint is and the command that
  !> continues it: this process's own arguments (any run.restart replaced)
  !> under mpirun with the same number of ranks (any other works too).
  subroutine print_stopped(env, reason, path, step, t)
    type(parallel_env_t), intent(in) :: env
    character(len=*), intent(in) :: reason, path   !< path: the checkpoint
    integer, intent(in) :: step
    real(wp), intent(in) :: t
    character(len=:), allocatable :: cmd, arg
    character(len=16) :: np
    integer :: k, length
    if (env%rank /= 0) return
    write(np, '(i0)') env%nranks
    cmd = 'mpirun -np ' // trim(np)
    do k = 0, command_argument_count()
      call get_command_argument(k, length=length)
      allocate(character(len=length) :: arg)
      call get_command_argument(k, arg)
      if (index(arg, 'run.restart=') /= 1) cmd = cmd // ' ' // shell_quoted(arg)
      deallocate(arg)
    end do
    cmd = cmd // ' ' // shell_quoted('run.restart=' // path)
    write(output_unit, '(a,i0,a,es12.5,a)') 'sph: stopped by ' // reason // ' after step ', &
      step, ' (t = ', t, '); checkpoint written to ' // path
    write(output_unit, '(a)') '  continue with: ' // cmd
    flush(output_unit)
  end subroutine print_stopped

  !> word as one shell word: as it is when it is made of safe characters,
  !> else in single quotes (a quote inside written '\'').
  function shell_quoted(word) result(q)
    character(len=*), intent(in) :: word
    character(len=:), allocatable :: q
    character(len=*), parameter :: SAFE = 'abcdefghijklmnopqrstuvwxyzABCDEFGHIJKLMNOPQRSTUVWXYZ' // &
                                          '0123456789_./=:,+-@%'
    integer :: k
    if (len(word) > 0 .and. verify(word, SAFE) == 0) then
      q = word
      return
    end if
    q = "'"
    do k = 1, len(word)
      if (word(k:k) == "'") then
        q = q // "'\''"
      else
        q = q // word(k:k)
      end if
    end do
    q = q // "'"
  end function shell_quoted

  !> A state that is no longer finite: say where and when, on every rank
  !> that has such a particle; earlier outputs stay as they were.
  subroutine report_blow_up(s, step, t, i_bad, mirror)
    type(solver_t), intent(in) :: s
    integer, intent(in) :: step, i_bad, mirror
    real(wp), intent(in) :: t
    integer :: k
    character(len=:), allocatable :: what
    if (i_bad > 0) then
      what = 'the state is no longer finite'
      do k = 1, 3
        if (btest(mirror, k - 1) .and. .not. s%parts%x(k, i_bad) >= 0) &
          what = 'a particle crossed the mirror plane ' // 'xyz'(k:k) // ' = 0'
      end do
      write(error_unit, '(a,i0,a,es12.5,a,i0,a,3es12.4,a,3es12.4,a,es12.4)') &
        'sph: error: ' // what // ' at step ', step, ', t = ', t, &
        ': particle id ', s%parts%id(i_bad), ' at x = ', s%parts%x(:, i_bad), &
        ', u = ', s%parts%u(:, i_bad), ', rho = ', s%parts%rho(i_bad)
      write(error_unit, '(a)') '  (try a smaller numerics.cfl; outputs up to the last ' // &
        'snapshot are intact)'
    end if
  end subroutine report_blow_up

end module run_report
