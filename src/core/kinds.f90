!> Kinds and mathematical constants shared by every module.
module kinds
  use, intrinsic :: iso_fortran_env, only: real64, int64
  implicit none
  private
  public :: wp, i8, pi

  integer, parameter :: wp = real64   !< working precision of all reals
  integer, parameter :: i8 = int64    !< global particle ids and counters
  real(wp), parameter :: pi = 3.141592653589793238462643383279502884_wp
end module kinds
