!> The one sort of the code: a stable bottom-up merge sort of an index
!> array by keys.  Stable, so that sorting by several keys is a sort by
!> each, least significant first; O(n log n) whatever the input.
module sorting
  use kinds, only: wp, i8
  implicit none
  private
  public :: sort_index

  !> sort_index(key, idx): reorders idx so that key(idx) ascends, equal
  !> keys keeping their order in idx.
  interface sort_index
    module procedure sort_index_i8, sort_index_wp
  end interface sort_index

contains

  pure subroutine sort_index_i8(key, idx)
    integer(i8), intent(in) :: key(:)
    integer, intent(inout) :: idx(:)
    integer, allocatable :: merged(:)
    integer :: n, width, lo, mid, hi, i, j, k
    n = size(idx)
    if (n < 2) return
    allocate(merged(n))
    width = 1
    do while (width < n)
      do lo = 1, n, 2 * width
        mid = min(lo + width, n + 1)      ! runs lo..mid-1 and mid..hi-1
        hi = min(lo + 2 * width, n + 1)
        i = lo
        j = mid
        do k = lo, hi - 1
          if (j >= hi) then
            merged(k) = idx(i); i = i + 1
          else if (i >= mid) then
            merged(k) = idx(j); j = j + 1
          else if (key(idx(j)) < key(idx(i))) then
            merged(k) = idx(j); j = j + 1
          else
            merged(k) = idx(i); i = i + 1
          end if
        end do
      end do
      idx = merged
      width = 2 * width
    end do
  end subroutine sort_index_i8

  !> Real keys through integers of the same order: the IEEE bits as a
  !> signed integer order the non-negative values; flipping all but the
  !> sign bit orders the negative ones.  -0 and +0 map alike (equal keys).
  pure subroutine sort_index_wp(key, idx)
    real(wp), intent(in) :: key(:)
    integer, intent(inout) :: idx(:)
    integer(i8), allocatable :: ikey(:)
    integer :: k
    allocate(ikey(size(key)))
    do k = 1, size(key)
      ikey(k) = 0
      if (abs(key(k)) > 0) ikey(k) = transfer(key(k), 0_i8)
      if (ikey(k) < 0) ikey(k) = ieor(ikey(k), huge(0_i8))
    end do
    call sort_index_i8(ikey, idx)
  end subroutine sort_index_wp

end module sorting
