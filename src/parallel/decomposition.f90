!> The domain decomposition of the time stepper (the parallel layer, over
!> domain and halo_exchange): re-balancing when the work is uneven,
!> migration of particles to their owners, the halo copies within the list
!> radius and their refresh, with counts and the time spent communicating
!> (doc/developer/parallel.md).
module decomposition
  use kinds, only: wp, i8
  use particles, only: particles_t
  use parallel_env, only: parallel_env_t, wall_time
  use domain, only: domain_t, domain_balance, domain_imbalance, DECOMP_SLAB
  use halo_exchange, only: halo_t, migrate, halo_build, halo_refresh, halo_refresh_field
  use particle_fields, only: MIGRATE_WORDS, HALO_WORDS, REFRESH_WORDS
  implicit none
  private
  public :: decomposition_t, decomp_redistribute, decomp_halo_build, decomp_refresh, &
            decomp_refresh_field, decomp_measure, decomp_partners, BALANCE_PARTICLES, &
            BALANCE_PAIRS

  integer, parameter :: BALANCE_PARTICLES = 1, BALANCE_PAIRS = 2   !< work measures

  type :: decomposition_t
    type(domain_t) :: dom
    type(halo_t) :: halo
    integer :: method = DECOMP_SLAB
    integer :: balance = BALANCE_PARTICLES
    real(wp) :: imbalance_threshold = 0.1_wp   !< re-balance when max/mean work exceeds 1 + this
    real(wp) :: imbalance = 1                  !< max/mean work after the last rebuild
    integer :: n_balances = 0
    integer(i8) :: n_migrated = 0              !< particles that changed rank
    real(wp) :: comm_time = 0                  !< wall time in halo exchanges and migration
    !> what this rank sent to others: reals (migration, halo builds and
    !> refreshes) and point-to-point messages
    real(wp) :: words_sent = 0
    integer(i8) :: messages_sent = 0
  end type decomposition_t

contains

  !> Re-balances the decomposition when needed (`first`, or imbalance of
  !> the work w of the owned particles above the threshold), then migrates
  !> the particles to their owners.
  subroutine decomp_redistribute(dc, env, pt, w, radius, first)
    type(decomposition_t), intent(inout) :: dc
    type(parallel_env_t), intent(in) :: env
    type(particles_t), intent(inout) :: pt
    real(wp), intent(in) :: w(:), radius
    logical, intent(in) :: first
    real(wp) :: imbalance, t0
    integer :: n_left
    ! collective: evaluated on every rank, never inside a short-circuit
    imbalance = domain_imbalance(env, sum(w))
    if (first .or. imbalance > 1 + dc%imbalance_threshold) then
      call domain_balance(dc%dom, env, dc%method, pt%dim, pt%n, pt%x, w, radius)
      dc%n_balances = dc%n_balances + 1
    end if
    t0 = wall_time()
    call migrate(env, dc%dom, pt, n_left)
    dc%n_migrated = dc%n_migrated + n_left
    dc%words_sent = dc%words_sent + real(MIGRATE_WORDS, wp) * n_left
    dc%comm_time = dc%comm_time + (wall_time() - t0)
  end subroutine decomp_redistribute

  !> Brings in the halo copies within radius of the owned particles.
  subroutine decomp_halo_build(dc, env, pt, radius)
    type(decomposition_t), intent(inout) :: dc
    type(parallel_env_t), intent(in) :: env
    type(particles_t), intent(inout) :: pt
    real(wp), intent(in) :: radius
    real(wp) :: t0
    t0 = wall_time()
    call halo_build(dc%halo, env, dc%dom, pt, radius)
    dc%comm_time = dc%comm_time + (wall_time() - t0)
    call count_sent(dc, HALO_WORDS)
  end subroutine decomp_halo_build

  !> The halo copies brought to the owners' current state.
  subroutine decomp_refresh(dc, env, pt)
    type(decomposition_t), intent(inout) :: dc
    type(parallel_env_t), intent(in) :: env
    type(particles_t), intent(inout) :: pt
    real(wp) :: t0
    t0 = wall_time()
    call halo_refresh(dc%halo, env, pt)
    dc%comm_time = dc%comm_time + (wall_time() - t0)
    call count_sent(dc, REFRESH_WORDS)
  end subroutine decomp_refresh

  !> The halo slots n+1.. of a per-particle field a(:, ntot) from their owners.
  !> kind: how its mirror images reflect (mirrors, REFLECT_*).
  subroutine decomp_refresh_field(dc, env, n, a, kind)
    type(decomposition_t), intent(inout) :: dc
    type(parallel_env_t), intent(in) :: env
    integer, intent(in) :: n, kind
    real(wp), intent(inout) :: a(:, :)
    real(wp) :: t0
    t0 = wall_time()
    call halo_refresh_field(dc%halo, env, n, a, kind)
    dc%comm_time = dc%comm_time + (wall_time() - t0)
    call count_sent(dc, size(a, 1))
  end subroutine decomp_refresh_field

  !> The imbalance (max/mean over the ranks) of the work w of the owned
  !> particles, after a rebuild (collective).
  subroutine decomp_measure(dc, env, w)
    type(decomposition_t), intent(inout) :: dc
    type(parallel_env_t), intent(in) :: env
    real(wp), intent(in) :: w(:)
    dc%imbalance = domain_imbalance(env, sum(w))
  end subroutine decomp_measure

  !> Counts a halo exchange of `words` reals per copy (the images this rank
  !> makes for itself are no message).
  subroutine count_sent(dc, words)
    type(decomposition_t), intent(inout) :: dc
    integer, intent(in) :: words
    integer :: q
    if (.not. allocated(dc%halo%send_start)) return
    dc%words_sent = dc%words_sent + real(words, wp) * (dc%halo%n_sent - dc%halo%n_self)
    do q = 0, size(dc%halo%send_start) - 2
      if (q == dc%halo%rank) cycle
      if (dc%halo%send_start(q + 1) > dc%halo%send_start(q)) &
        dc%messages_sent = dc%messages_sent + 1
    end do
  end subroutine count_sent

  !> The number of other ranks this rank's halo exchanges with (sends to or
  !> receives from).
  integer function decomp_partners(dc) result(k)
    type(decomposition_t), intent(in) :: dc
    integer :: q
    k = 0
    if (.not. allocated(dc%halo%send_start)) return
    do q = 0, size(dc%halo%send_start) - 2
      if (q == dc%halo%rank) cycle
      if (dc%halo%send_start(q + 1) > dc%halo%send_start(q) .or. &
          dc%halo%recv_start(q + 1) > dc%halo%recv_start(q)) k = k + 1
    end do
  end function decomp_partners

end module decomposition
