!> Domain decomposition, migration and halo exchange, at whatever number of
!> ranks the suite runs with (1, 2 and 3 in `make test`): balance of the
!> slab cuts and METIS partitions, migration moving every particle to its
!> owner with its fields intact, and the halo set against a brute-force
!> selection from all particles.
module test_decomposition
  use kinds, only: wp, i8
  use particles, only: particles_t, particles_allocate
  use domain, only: domain_t, domain_balance, domain_owner, domain_imbalance, &
                    DECOMP_SLAB, DECOMP_METIS
  use halo_exchange, only: halo_t, migrate, halo_build, halo_refresh
  use metis_partition, only: partition_graph
  use parallel_env, only: parallel_env_t, par_from_comm, par_sum, par_sum_array
  use testing, only: run_test, assert_equal, assert_true, test_comm, same_bits
  implicit none
  private
  public :: suite_decomposition

  integer, parameter :: NG = 3000   !< particles in the test clouds

contains

  subroutine suite_decomposition()
    call run_test('decomposition', 'slab_cuts_balance_counts', slab_balance)
    call run_test('decomposition', 'migration_keeps_every_particle_intact', migration)
    call run_test('decomposition', 'halo_equals_brute_force_selection_slab', halo_slab)
    call run_test('decomposition', 'halo_equals_brute_force_selection_metis', halo_metis)
    call run_test('decomposition', 'metis_partition_of_a_grid_graph', metis_grid)
  end subroutine suite_decomposition

  !> Position of global particle k (1..NG) of an elongated 2D or 3D cloud:
  !> a deterministic scramble, the same on every rank.
  function position_of(k, dim) result(x)
    integer, intent(in) :: k, dim
    real(wp) :: x(3)
    x(1) = 3 * modulo(0.6180339887_wp * k, 1.0_wp)
    x(2) = modulo(0.7548776662_wp * k, 1.0_wp)
    x(3) = 0
    if (dim == 3) x(3) = 0.5_wp * modulo(0.5698402910_wp * k, 1.0_wp)
  end function position_of

  !> All fields of global particle k, computed in one place so that the
  !> reference values round exactly as the stored ones (FMA contraction
  !> may differ between two copies of the same expression).
  subroutine fields_of(k, dim, x, u, x0, rho, p, m)
    integer, intent(in) :: k, dim
    real(wp), intent(out) :: x(3), u(3), x0(3), rho, p, m
    x = position_of(k, dim)
    u = [real(k, wp), -real(k, wp), 0.5_wp * k]
    x0 = x + 1
    rho = 1 + 1e-3_wp * k
    p = 2 * k
    m = 1e-4_wp * k
  end subroutine fields_of

  !> Every rank starts with an arbitrary share (every P-th particle), with
  !> fields that are functions of the id.
  subroutine make_cloud(env, dim, parts)
    type(parallel_env_t), intent(in) :: env
    integer, intent(in) :: dim
    type(particles_t), intent(out) :: parts
    integer :: k, n
    call particles_allocate(parts, dim, NG)
    n = 0
    do k = 1 + env%rank, NG, env%nranks
      n = n + 1
      call fields_of(k, dim, parts%x(:, n), parts%u(:, n), parts%x0(:, n), parts%rho(n), &
                     parts%p(n), parts%m(n))
      parts%id(n) = k
    end do
    parts%n = n
  end subroutine make_cloud

  subroutine slab_balance()
    type(parallel_env_t) :: env
    type(particles_t) :: parts
    type(domain_t) :: d
    real(wp), allocatable :: w(:)
    integer :: dim, n_left
    env = par_from_comm(test_comm())
    do dim = 2, 3
      call make_cloud(env, dim, parts)
      allocate(w(parts%n))
      w = 1
      call domain_balance(d, env, DECOMP_SLAB, dim, parts%n, parts%x, w, 0.1_wp)
      call assert_equal(1, d%axis, 'slabs cut along the longest axis (x, 3 units)')
      call migrate(env, d, parts, n_left)
      ! bisection on distinct coordinates: counts equal within one particle
      call assert_true(abs(parts%n - NG / env%nranks) <= 1, 'equal particle counts')
      call assert_true(domain_imbalance(env, real(parts%n, wp)) <= &
                       1 + 2.0_wp * env%nranks / NG, 'imbalance within one particle')
      deallocate(w)
    end do
  end subroutine slab_balance

  !> After migration, every particle lives on its owner, each id exactly
  !> once over all ranks, with every field as it was.
  subroutine migration()
    type(parallel_env_t) :: env
    type(particles_t) :: parts
    type(domain_t) :: d
    real(wp), allocatable :: w(:), seen(:)
    integer :: i, k, n_left, wrong_owner, wrong_field, kind
    real(wp) :: x(3), u(3), x0(3), rho, p, m
    env = par_from_comm(test_comm())
    do kind = DECOMP_SLAB, DECOMP_METIS
      call make_cloud(env, 3, parts)
      allocate(w(parts%n), seen(NG))
      w = 1
      call domain_balance(d, env, kind, 3, parts%n, parts%x, w, 0.2_wp)
      call migrate(env, d, parts, n_left)
      seen = 0
      wrong_owner = 0
      wrong_field = 0
      do i = 1, parts%n
        k = int(parts%id(i))
        seen(k) = seen(k) + 1
        if (domain_owner(d, parts%x(:, i)) /= env%rank) wrong_owner = wrong_owner + 1
        call fields_of(k, 3, x, u, x0, rho, p, m)
        if (.not. same_bits([parts%x(:, i), parts%u(:, i), parts%x0(:, i), parts%rho(i), &
                             parts%p(i), parts%m(i)], [x, u, x0, rho, p, m])) &
          wrong_field = wrong_field + 1
      end do
      call par_sum_array(env, seen)
      call assert_true(all(abs(seen - 1) < 0.5_wp), 'each id exactly once over all ranks')
      call assert_equal(0, wrong_owner, 'particles on a rank that does not own them')
      call assert_equal(0, wrong_field, 'particles whose fields changed')
      deallocate(w, seen)
    end do
  end subroutine migration

  subroutine halo_slab()
    call check_halo(DECOMP_SLAB)
  end subroutine halo_slab

  subroutine halo_metis()
    call check_halo(DECOMP_METIS)
  end subroutine halo_metis

  !> The halo copies on each rank must include every particle of another
  !> rank within R of one of its own particles (brute force over all
  !> particles), must only hold particles of other ranks, and must carry
  !> their fields (refreshed after a change).
  subroutine check_halo(kind)
    integer, intent(in) :: kind
    type(parallel_env_t) :: env
    type(particles_t) :: parts
    type(domain_t) :: d
    type(halo_t) :: h
    real(wp), allocatable :: w(:), allx(:, :), owner_of(:)
    logical, allocatable :: in_halo(:)
    integer :: i, j, k, n_left, missing, foreign, stale
    real(wp), parameter :: r = 0.12_wp
    env = par_from_comm(test_comm())
    call make_cloud(env, 2, parts)
    allocate(w(parts%n))
    w = 1
    call domain_balance(d, env, kind, 2, parts%n, parts%x, w, r)
    call migrate(env, d, parts, n_left)
    call halo_build(h, env, d, parts, r)
    ! every particle's position and owner, known to all ranks
    allocate(allx(3, NG), owner_of(NG), in_halo(NG))
    allx = 0
    owner_of = 0
    do i = 1, parts%n
      allx(:, parts%id(i)) = parts%x(:, i)
      owner_of(parts%id(i)) = env%rank
    end do
    call par_sum_array(env, allx(1, :))
    call par_sum_array(env, allx(2, :))
    call par_sum_array(env, owner_of)
    in_halo = .false.
    foreign = 0
    do k = parts%n + 1, parts%n + parts%n_halo
      if (in_halo(parts%id(k))) foreign = foreign + 1       ! a duplicate
      in_halo(parts%id(k)) = .true.
      if (nint(owner_of(parts%id(k))) == env%rank) foreign = foreign + 1
    end do
    missing = 0
    do j = 1, NG
      if (nint(owner_of(j)) == env%rank .or. in_halo(j)) cycle
      do i = 1, parts%n
        if (sum((parts%x(1:2, i) - allx(1:2, j))**2) < r**2) then
          missing = missing + 1
          exit
        end if
      end do
    end do
    call assert_equal(0, missing, 'particles within R of an owned one but not in the halo')
    call assert_equal(0, foreign, 'halo copies of own particles, or duplicates')
    if (env%nranks > 1) call assert_true(parts%n_halo > 0, 'there is a halo')
    ! refresh: owners change their fields, the copies follow
    do i = 1, parts%n
      parts%u(1, i) = -7 * parts%id(i)
      parts%rho(i) = 3
    end do
    call halo_refresh(h, env, parts)
    stale = count(abs(parts%u(1, parts%n + 1:parts%n + parts%n_halo) &
                      + 7 * parts%id(parts%n + 1:parts%n + parts%n_halo)) > 0 .or. &
                  abs(parts%rho(parts%n + 1:parts%n + parts%n_halo) - 3) > 0)
    call assert_equal(0, stale, 'halo copies not refreshed')
  end subroutine check_halo

  !> METIS on a 12 x 12 grid graph: every part gets cells, the weights are
  !> balanced within METIS's default 3 % (+ one vertex), one part is done
  !> without METIS.
  subroutine metis_grid()
    integer, parameter :: m = 12, nv = m * m
    integer :: xadj(nv + 1), adjncy(4 * nv), vwgt(nv), part(nv), i, j, v, ne, np, k
    real(wp) :: wp_max
    ne = 0
    xadj(1) = 0
    do j = 0, m - 1
      do i = 0, m - 1
        v = i + m * j
        if (i > 0) call edge(v - 1)
        if (i < m - 1) call edge(v + 1)
        if (j > 0) call edge(v - m)
        if (j < m - 1) call edge(v + m)
        xadj(v + 2) = ne
      end do
    end do
    vwgt = 1
    do np = 1, 4
      call partition_graph(nv, xadj, adjncy(1:ne), vwgt, np, part)
      call assert_true(all(part >= 0 .and. part < np), 'parts in range')
      wp_max = 0
      do k = 0, np - 1
        call assert_true(count(part == k) > 0, 'every part has cells')
        wp_max = max(wp_max, real(count(part == k), wp))
      end do
      call assert_true(wp_max <= 1.03_wp * nv / np + 1, 'balanced parts')
    end do
  contains
    subroutine edge(u)
      integer, intent(in) :: u
      ne = ne + 1
      adjncy(ne) = u
    end subroutine edge
  end subroutine metis_grid

end module test_decomposition
