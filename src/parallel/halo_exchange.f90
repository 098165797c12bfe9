!> Moving particles between ranks: migration of owned particles to the rank
!> that owns their position, and halo copies of the particles within the
!> list radius of other ranks' regions, refreshed before every right-hand
!> side.  Counts travel by MPI_Alltoall, data by non-blocking point-to-point
!> messages to the ranks concerned only.  Works for any domain_t (slabs or
!> a cell map) through domain_owner and domain_ranks_near.
module halo_exchange
  use kinds, only: wp, i8
  use particles, only: particles_t, particles_reserve, particles_permute, particles_pack, &
                       particles_unpack, particles_field, particles_field_i8
  use particle_fields, only: FIELD_TABLE, N_FIELDS, MIGRATE_FIELDS, HALO_FIELDS, &
                             REFRESH_FIELDS, MIGRATE_WORDS, HALO_WORDS, REFRESH_WORDS, FIELD_ID
  use mirrors, only: mirror_codes, reflect, plane_distance2, image_id, image_code, &
                     reflect_column, REFLECT_VECTOR
  use domain, only: domain_t, domain_owner, domain_ranks_near
  use parallel_env, only: parallel_env_t
  use mpi_f08, only: MPI_Alltoall, MPI_Isend, MPI_Irecv, MPI_Waitall, MPI_Request, &
                     MPI_INTEGER, MPI_DOUBLE_PRECISION, MPI_STATUSES_IGNORE
  implicit none
  private
  public :: halo_t, migrate, halo_build, halo_refresh, halo_refresh_field

  !> Who gets which halo copies: owned particles send_idx(send_start(q)+1 :
  !> send_start(q+1)) go to rank q; copies from rank q land in slots
  !> n + recv_start(q) + 1 .. n + recv_start(q+1).  send_code(k) is the
  !> reflection of send_idx(k) (0: a plain copy); flip lists the k with a
  !> nonzero code.  The block to this rank itself holds only images.
  type :: halo_t
    integer, allocatable :: send_start(:), send_idx(:), recv_start(:)
    integer, allocatable :: send_code(:), flip(:)
    integer :: mirror = 0     !< the planes' mask (mirrors), 0 for none
    integer :: rank = 0
    integer :: n_sent = 0, n_received = 0
    integer :: n_self = 0     !< images this rank made for itself
    integer :: n_images = 0   !< images among the received
    !> the refreshes' message buffers, sized at the build and reused (the
    !> time loop allocates nothing for them)
    real(wp), allocatable :: sbuf(:), rbuf(:)
  end type halo_t

contains

  !> Sends every owned particle whose position belongs to another rank to
  !> that rank and appends the ones received; returns how many left this rank.
  subroutine migrate(env, d, parts, n_left)
    type(parallel_env_t), intent(in) :: env
    type(domain_t), intent(in) :: d
    type(particles_t), intent(inout) :: parts
    integer, intent(out) :: n_left
    integer, allocatable :: dest(:), send_start(:), recv_start(:), fill(:), keep(:), order(:)
    real(wp), allocatable :: sbuf(:, :), rbuf(:, :)
    integer :: i, q, p, n, nrecv, nkeep
    p = env%nranks
    n = parts%n
    n_left = 0
    if (p == 1) return
    allocate(dest(n))
    do i = 1, n
      dest(i) = domain_owner(d, parts%x(:, i))
    end do
    call counts_to_offsets(env, dest, send_start, recv_start, fill)
    ! the leaving particles in send order, by destination
    allocate(order(send_start(p)))
    do i = 1, n
      q = dest(i)
      if (q == env%rank) cycle
      fill(q) = fill(q) + 1
      order(fill(q)) = i
    end do
    allocate(sbuf(MIGRATE_WORDS, max(1, send_start(p))))
    call particles_pack(parts, MIGRATE_FIELDS, order, sbuf)
    nrecv = recv_start(p)
    allocate(rbuf(MIGRATE_WORDS, max(1, nrecv)))
    call exchange(env, MIGRATE_WORDS, send_start, sbuf, recv_start, rbuf)
    ! keep the particles that stay, in their order, then append arrivals
    allocate(keep, source=pack([(i, i = 1, n)], dest == env%rank))
    nkeep = size(keep)
    n_left = n - nkeep
    call particles_permute(parts, keep)
    call particles_reserve(parts, nkeep + nrecv)
    call particles_unpack(parts, MIGRATE_FIELDS, nkeep, nrecv, rbuf)
    parts%n = nkeep + nrecv
    parts%n_halo = 0
  end subroutine migrate

  !> Decides the halo (every owned particle within `radius` of another
  !> rank's region is copied there) and brings in the copies from the other
  !> ranks as particles n+1 .. n+n_halo.
  subroutine halo_build(h, env, d, parts, radius)
    type(halo_t), intent(inout) :: h
    type(parallel_env_t), intent(in) :: env
    type(domain_t), intent(in) :: d
    type(particles_t), intent(inout) :: parts
    real(wp), intent(in) :: radius
    integer, allocatable :: counts(:), rcounts(:), fill(:), codes(:)
    real(wp), allocatable :: sbuf(:, :), rbuf(:, :)
    real(wp) :: xm(3)
    integer :: ranks(env%nranks), nr, i, q, p, n, j, pass, c
    p = env%nranks
    n = parts%n
    h%rank = env%rank
    parts%n_halo = 0
    if (allocated(h%send_start)) deallocate(h%send_start, h%send_idx, h%recv_start)
    if (allocated(h%send_code)) deallocate(h%send_code, h%flip)
    allocate(h%send_start(0:p), h%recv_start(0:p), counts(0:p - 1), rcounts(0:p - 1))
    h%send_start = 0
    h%recv_start = 0
    h%n_sent = 0
    h%n_received = 0
    h%n_self = 0
    h%n_images = 0
    if (p == 1 .and. h%mirror == 0) then
      allocate(h%send_idx(0), h%send_code(0), h%flip(0))
      return
    end if
    codes = mirror_codes(h%mirror)
    ! two passes over the particles: count, then fill the send lists; per
    ! particle its copies (code 0), then its images by ascending code
    counts = 0
    do pass = 1, 2
      if (pass == 2) then
        do q = 0, p - 1
          h%send_start(q + 1) = h%send_start(q) + counts(q)
        end do
        allocate(h%send_idx(h%send_start(p)), h%send_code(h%send_start(p)), fill(0:p - 1))
        fill = h%send_start(0:p - 1)
      end if
      do i = 1, n
        call domain_ranks_near(d, parts%x(:, i), radius, ranks, nr)
        do j = 1, nr
          call add(ranks(j), i, 0)
        end do
        do c = 1, size(codes)
          if (plane_distance2(parts%x(:, i), codes(c)) >= radius**2) cycle
          xm = reflect(parts%x(:, i), codes(c))
          call add(domain_owner(d, xm), i, codes(c))
          call domain_ranks_near(d, xm, radius, ranks, nr)
          do j = 1, nr
            call add(ranks(j), i, codes(c))
          end do
        end do
      end do
    end do
    call MPI_Alltoall(counts, 1, MPI_INTEGER, rcounts, 1, MPI_INTEGER, env%comm)
    do q = 0, p - 1
      h%recv_start(q + 1) = h%recv_start(q) + rcounts(q)
    end do
    h%n_sent = h%send_start(p)
    h%n_received = h%recv_start(p)
    h%n_self = counts(env%rank)
    h%flip = pack([(j, j = 1, h%n_sent)], h%send_code /= 0)
    allocate(sbuf(HALO_WORDS, max(1, h%n_sent)), rbuf(HALO_WORDS, max(1, h%n_received)))
    call particles_pack(parts, HALO_FIELDS, h%send_idx, sbuf)
    call reflect_packed(h, HALO_FIELDS, sbuf)
    call exchange(env, HALO_WORDS, h%send_start, sbuf, h%recv_start, rbuf)
    call particles_reserve(parts, n + h%n_received)
    call particles_unpack(parts, HALO_FIELDS, n, h%n_received, rbuf)
    call clear_halo_slots(parts, .not. FIELD_TABLE%halo, n, h%n_received)
    ! the images among the arrivals carry an image id (mirrors)
    if (h%mirror /= 0) h%n_images = count(image_code(parts%id(n + 1:n + h%n_received)) /= 0)
    parts%n_halo = h%n_received
    call reserve_buffer(h%sbuf, REFRESH_WORDS * h%n_sent)
    call reserve_buffer(h%rbuf, REFRESH_WORDS * h%n_received)

  contains

    !> Particle i goes to rank q, reflected by the code.
    subroutine add(q, i, code)
      integer, intent(in) :: q, i, code
      if (pass == 1) then
        counts(q) = counts(q) + 1
      else
        fill(q) = fill(q) + 1
        h%send_idx(fill(q)) = i
        h%send_code(fill(q)) = code
      end if
    end subroutine add

  end subroutine halo_build

  !> (M2) The images among the packed columns of buf (the fields `list`,
  !> packed by particles_pack) reflected: polar vectors flip the code's
  !> components, the id becomes the image's, scalars stay.
  subroutine reflect_packed(h, list, buf)
    type(halo_t), intent(in) :: h
    integer, intent(in) :: list(:)
    real(wp), intent(inout) :: buf(:, :)
    integer :: j, f, r, nc, l, k
    r = 0
    do j = 1, size(list)
      f = list(j)
      nc = FIELD_TABLE(f)%ncomp
      if (f == FIELD_ID) then
        do l = 1, size(h%flip)
          k = h%flip(l)
          buf(r + 1, k) = transfer(image_id(transfer(buf(r + 1, k), 1_i8), h%send_code(k)), &
                                   1.0_wp)
        end do
      else if (nc == 3) then
        do l = 1, size(h%flip)
          k = h%flip(l)
          call reflect_column(REFLECT_VECTOR, h%send_code(k), buf(r + 1:r + 3, k))
        end do
      end if
      r = r + nc
    end do
  end subroutine reflect_packed

  !> buf holds at least `words` reals (at least one), reallocated only to
  !> grow or when it is more than twice too large.
  subroutine reserve_buffer(buf, words)
    real(wp), allocatable, intent(inout) :: buf(:)
    integer, intent(in) :: words
    if (allocated(buf)) then
      if (size(buf) >= max(words, 1) .and. size(buf) <= 2 * max(words, 1)) return
      deallocate(buf)
    end if
    allocate(buf(max(words, 1)))
  end subroutine reserve_buffer

  !> Brings the halo copies of the fields refreshed before every right-hand
  !> side (positions, velocities, densities) up to date.
  subroutine halo_refresh(h, env, parts)
    type(halo_t), intent(inout), target :: h
    type(parallel_env_t), intent(in) :: env
    type(particles_t), intent(inout) :: parts
    real(wp), pointer, contiguous :: sbuf(:, :), rbuf(:, :)
    if (env%nranks == 1 .and. h%mirror == 0) return
    sbuf(1:REFRESH_WORDS, 1:max(1, h%n_sent)) => h%sbuf
    rbuf(1:REFRESH_WORDS, 1:max(1, h%n_received)) => h%rbuf
    call particles_pack(parts, REFRESH_FIELDS, h%send_idx, sbuf)
    call reflect_packed(h, REFRESH_FIELDS, sbuf)
    call exchange(env, REFRESH_WORDS, h%send_start, sbuf, h%recv_start, rbuf)
    call particles_unpack(parts, REFRESH_FIELDS, parts%n, h%n_received, rbuf)
  end subroutine halo_refresh

  !> Copies a per-particle field a(ncomp, :) of the owned particles into the
  !> halo slots n+1.. of the other ranks (e.g. the density gradient); kind
  !> says how its images reflect (mirrors: REFLECT_SCALAR, _VECTOR, _SYM6).
  subroutine halo_refresh_field(h, env, n, a, kind)
    type(halo_t), intent(inout), target :: h
    type(parallel_env_t), intent(in) :: env
    integer, intent(in) :: n, kind
    real(wp), intent(inout) :: a(:, :)
    real(wp), pointer, contiguous :: sbuf(:, :), rbuf(:, :)
    integer :: k, nc, l
    if (env%nranks == 1 .and. h%mirror == 0) return
    nc = size(a, 1)
    if (nc > REFRESH_WORDS) error stop 'halo_refresh_field: more components than the buffers hold'
    sbuf(1:nc, 1:max(1, h%n_sent)) => h%sbuf
    rbuf(1:nc, 1:max(1, h%n_received)) => h%rbuf
    do k = 1, h%n_sent
      sbuf(:, k) = a(:, h%send_idx(k))
    end do
    do l = 1, size(h%flip)
      k = h%flip(l)
      call reflect_column(kind, h%send_code(k), sbuf(:, k))
    end do
    call exchange(env, nc, h%send_start, sbuf, h%recv_start, rbuf)
    do k = 1, h%n_received
      a(:, n + k) = rbuf(:, k)
    end do
  end subroutine halo_refresh_field

  !> Zeroes the fields selected by `clear` in the halo slots n+1 .. n+count:
  !> the halo does not carry them.
  subroutine clear_halo_slots(parts, clear, n, count)
    type(particles_t), intent(inout), target :: parts
    logical, intent(in) :: clear(:)
    integer, intent(in) :: n, count
    real(wp), pointer, contiguous :: a(:, :)
    integer(i8), pointer, contiguous :: ia(:)
    integer :: f
    do f = 1, N_FIELDS
      if (.not. clear(f)) cycle
      if (FIELD_TABLE(f)%integer8) then
        ia => particles_field_i8(parts, f)
        ia(n + 1:n + count) = 0
      else
        a => particles_field(parts, f)
        a(:, n + 1:n + count) = 0
      end if
    end do
  end subroutine clear_halo_slots

  !> Send offsets from the destination of each owned particle (this rank's
  !> own particles excluded), the matching receive offsets, and the fill
  !> pointers for packing.
  subroutine counts_to_offsets(env, dest, send_start, recv_start, fill)
    type(parallel_env_t), intent(in) :: env
    integer, intent(in) :: dest(:)
    integer, allocatable, intent(out) :: send_start(:), recv_start(:), fill(:)
    integer, allocatable :: counts(:), rcounts(:)
    integer :: i, q, p
    p = env%nranks
    allocate(counts(0:p - 1), rcounts(0:p - 1), send_start(0:p), recv_start(0:p), fill(0:p - 1))
    counts = 0
    do i = 1, size(dest)
      if (dest(i) /= env%rank) counts(dest(i)) = counts(dest(i)) + 1
    end do
    call MPI_Alltoall(counts, 1, MPI_INTEGER, rcounts, 1, MPI_INTEGER, env%comm)
    send_start(0) = 0
    recv_start(0) = 0
    do q = 0, p - 1
      send_start(q + 1) = send_start(q) + counts(q)
      recv_start(q + 1) = recv_start(q) + rcounts(q)
    end do
    fill = send_start(0:p - 1)
  end subroutine counts_to_offsets

  !> Point-to-point exchange of columns of `words` reals: columns
  !> send_start(q)+1 .. send_start(q+1) of sbuf go to rank q, and columns
  !> recv_start(q)+1 .. recv_start(q+1) of rbuf come from rank q; the block
  !> of this rank itself (images, in a migration empty) is copied.
  subroutine exchange(env, words, send_start, sbuf, recv_start, rbuf)
    type(parallel_env_t), intent(in) :: env
    integer, intent(in) :: words, send_start(0:), recv_start(0:)
    real(wp), intent(in), contiguous, target :: sbuf(:, :)
    real(wp), intent(inout), contiguous, target :: rbuf(:, :)
    type(MPI_Request), allocatable :: req(:)
    integer :: q, nreq, cnt
    allocate(req(2 * env%nranks))
    nreq = 0
    do q = 0, env%nranks - 1
      cnt = recv_start(q + 1) - recv_start(q)
      if (cnt == 0 .or. q == env%rank) cycle
      nreq = nreq + 1
      call MPI_Irecv(rbuf(:, recv_start(q) + 1:), words * cnt, MPI_DOUBLE_PRECISION, q, 17, &
                     env%comm, req(nreq))
    end do
    do q = 0, env%nranks - 1
      cnt = send_start(q + 1) - send_start(q)
      if (cnt == 0 .or. q == env%rank) cycle
      nreq = nreq + 1
      call MPI_Isend(sbuf(:, send_start(q) + 1:), words * cnt, MPI_DOUBLE_PRECISION, q, 17, &
                     env%comm, req(nreq))
    end do
    q = env%rank
    cnt = send_start(q + 1) - send_start(q)
    if (cnt > 0) rbuf(:, recv_start(q) + 1:recv_start(q) + cnt) = &
      sbuf(:, send_start(q) + 1:send_start(q) + cnt)
    call MPI_Waitall(nreq, req(1:nreq), MPI_STATUSES_IGNORE)
  end subroutine exchange

end module halo_exchange
