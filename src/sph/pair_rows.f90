!> What the passes over the pairs share: the width of a row's partial
!> sums (LANES), the anchors of the binned sums (B1), and the work arrays
!> kept between calls.  The loops are fluid_rhs's (pair_loop.fypi), with
!> the row's partners (row_partners.fypi) compiled with them: inlined there,
!> they give the bits the results were recorded with.
module pair_rows
  use kinds, only: wp, i8
  use neighbours, only: neighbour_list_t, ROW_PAD
  implicit none
  private
  public :: LANES, N_ROWBUF, rhs_work_t, rhs_work_reserve, sums_view, row_capacity, &
            bin_anchors
  public :: R_UX, R_UY, R_UZ, R_RHO, R_P, R_VOL, R_IRHO, R_PF, R_WC, R_LXX, R_LYY, R_LZZ, &
            R_LXY, R_LXZ, R_LYZ, R_RT, R_SXX, R_SYY, R_SZZ, R_SXY, R_SXZ, R_SYZ, REC_SHORT, &
            REC_LONG, REC_RECON

  !> the partial sums of a row (lane_sums): a vector of doubles on AVX-512
  integer, parameter :: LANES = 8
  !> the row buffers of the pair loops (rhs_work_t%rb)
  integer, parameter :: N_ROWBUF = 14
  !> rhs_work_t%rec(:, j): what the pair loop reads of a partner j, in one
  !> place (two cache lines): u, rho, p, V, 1/rho, the pressure and weight
  !> of (H1), L (E3, as xx, yy, zz, xy, xz, yz) and R of (E7); the standard
  !> operators read only the first REC_SHORT (one cache line); (R1) the
  !> reconstructed viscosity adds the strain rate S
  integer, parameter :: R_UX = 1, R_UY = 2, R_UZ = 3, R_RHO = 4, R_P = 5, R_VOL = 6, &
                        R_IRHO = 7, R_PF = 8, R_WC = 9, &
                        R_LXX = 10, R_LYY = 11, R_LZZ = 12, R_LXY = 13, R_LXZ = 14, R_LYZ = 15, &
                        R_RT = 16, &
                        R_SXX = 17, R_SYY = 18, R_SZZ = 19, R_SXY = 20, R_SXZ = 21, R_SYZ = 22
  integer, parameter :: REC_SHORT = R_PF, REC_LONG = R_RT, REC_RECON = 24

  !> Work arrays of the passes, kept between calls (the solver holds one)
  !> and grown only when the particles or the longest row outgrow them, so
  !> that the time loop allocates nothing.  Per particle: V = m/rho, 1/rho,
  !> the pressure and weight of (H1), R of (E7).  Per row: the in-range
  !> partners (in_range_soa), F and W, and the pair terms for i and j.
  type :: rhs_work_t
    real(wp), allocatable :: rec(:, :)
    integer, allocatable :: jl(:)
    real(wp), allocatable :: rb(:, :)     !< (nr, N_ROWBUF) the row buffers of the pair loops
    !> the per-particle sums of a pass, viewed as (rows, ntot) through a
    !> pointer (sums_view): 4 rows in rhs_evaluate (drho, du), 9 in the
    !> first pass (M, G), 12 in rhs_shift; one buffer, sized for the most
    !> rows asked for, since the passes never need theirs at once
    real(wp), allocatable :: sums(:)
    real(wp), allocatable :: vg(:, :)     !< (9, :) (R1) the velocity gradient's sums
  end type rhs_work_t


contains

  !> Sizes w for ntot particles, records of nrec values and the rows of nl (a row's buffers hold
  !> its longest row plus a vector of padding, lane_sums), keeping what
  !> is large enough.
  subroutine rhs_work_reserve(w, ntot, nl, nrec, with_vg, sum_rows)
    type(rhs_work_t), intent(inout) :: w
    integer, intent(in) :: ntot
    type(neighbour_list_t), intent(in) :: nl
    integer, intent(in) :: nrec      !< rows of the particle record: REC_SHORT or REC_LONG
    logical, intent(in), optional :: with_vg   !< (R1) the velocity gradient's sums too
    integer, intent(in) :: sum_rows  !< rows of the pass's sums (rhs_work_t%sums)
    integer :: np, nr
    logical :: yes
    np = max(ntot, 1)
    if (allocated(w%rec)) then
      if (size(w%rec, 2) < np .or. size(w%rec, 1) < nrec) deallocate(w%rec)
    end if
    ! room for the particle count to grow a little between rebuilds
    if (.not. allocated(w%rec)) allocate(w%rec(nrec, np + np / 16))
    if (allocated(w%sums)) then
      if (size(w%sums, kind=i8) < int(sum_rows, i8) * np) deallocate(w%sums)
    end if
    if (.not. allocated(w%sums)) allocate(w%sums(int(sum_rows, i8) * (np + np / 16)))
    ! vg: at least one column, unused where not asked for (the loops take
    ! it as an argument); once grown it stays
    yes = .false.
    if (present(with_vg)) yes = with_vg
    np = merge(size(w%rec, 2), 1, yes)
    if (allocated(w%vg)) then
      if (size(w%vg, 2) < np) deallocate(w%vg)
    end if
    if (.not. allocated(w%vg)) allocate(w%vg(9, np))
    nr = row_capacity(nl)
    if (allocated(w%jl)) then
      if (size(w%jl) < nr) deallocate(w%jl, w%rb)
    end if
    if (.not. allocated(w%jl)) allocate(w%jl(nr), w%rb(nr, N_ROWBUF))
  end subroutine rhs_work_reserve

  !> The first rows * ntot of w%sums as a (rows, ntot) array.
  function sums_view(w, rows, ntot) result(v)
    type(rhs_work_t), intent(in), target :: w
    integer, intent(in) :: rows, ntot
    real(wp), pointer, contiguous :: v(:, :)
    v(1:rows, 1:ntot) => w%sums(1:int(rows, i8) * ntot)
  end function sums_view

  !> Slots of a row buffer: the longest row of nl and the padding of
  !> neighbour_row (ROW_PAD), rounded to whole vectors, plus a vector.
  pure integer function row_capacity(nl) result(nr)
    type(neighbour_list_t), intent(in) :: nl
    integer :: longest
    longest = 1
    if (nl%n_rows > 0) longest = max(1, nl%longest)
    nr = ((longest + max(LANES, ROW_PAD)) / LANES + 1) * LANES
  end function row_capacity

  !> (B1) The anchors m1, m2 of the two bins of a sum whose terms and
  !> total stay well below 2^30 q: m1 = 1.5 2^e with 2^e the power of two
  !> just above 2^30 q, m2 = m1 2^-40.  The first bin's grid is then
  !> about 2^-22 q, the second's 2^-62 q.
  elemental subroutine bin_anchors(q, m1, m2)
    real(wp), intent(in) :: q
    real(wp), intent(out) :: m1, m2
    m1 = scale(1.5_wp, exponent(q) + 30)
    m2 = scale(m1, -40)
  end subroutine bin_anchors

end module pair_rows
