!> How N numbered items (particles, rows of a snapshot) are shared among P
!> ranks when nothing better is known: rank r of P takes the contiguous
!> numbers floor(r N/P) + 1 .. floor((r+1) N/P).  The placements, the cases
!> that set up all their particles and the snapshot reader use this one
!> rule, so that their shares agree.
module shares
  use kinds, only: i8
  implicit none
  private
  public :: share_range

contains

  !> The numbers first..last (1-based; last = first - 1 when empty) of rank
  !> `rank` of `nranks` among n_total.
  pure subroutine share_range(n_total, rank, nranks, first, last)
    integer(i8), intent(in) :: n_total
    integer, intent(in) :: rank, nranks
    integer(i8), intent(out) :: first, last
    first = n_total * rank / nranks + 1
    last = n_total * (rank + 1) / nranks
  end subroutine share_range

end module shares
