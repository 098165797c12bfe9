!> Bit-for-bit equality of real arrays, for the tests of decomposition
!> independence (they ask for identical bits, not for closeness).  A module
!> of its own: the tests use it with pFUnit and with tests/testing.f90.
module bitwise
  use kinds, only: wp, i8
  implicit none
  private
  public :: same_bits

contains

  pure logical function same_bits(a, b)
    real(wp), intent(in) :: a(:), b(:)
    same_bits = size(a) == size(b)
    if (same_bits) same_bits = all(transfer(a, 1_i8, size(a)) == transfer(b, 1_i8, size(b)))
  end function same_bits

end module bitwise
