!> FFTW 3's Fortran 2003 interface (/usr/include/fftw3.f03) as a module.
module fftw3
  use, intrinsic :: iso_c_binding
  implicit none
  include 'fftw3.f03'
end module fftw3
