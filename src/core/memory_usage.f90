!> Peak resident memory of this process (Linux: VmHWM in /proc/self/status).
module memory_usage
  use, intrinsic :: iso_c_binding, only: c_int
  use kinds, only: wp
  implicit none
  private
  public :: peak_memory_mb, map_large_arrays

contains

  !> Peak resident set size in MiB, or -1 where /proc is not available.
  function peak_memory_mb() result(mb)
    real(wp) :: mb
    character(len=256) :: line
    integer :: u, ios
    real(wp) :: kb
    mb = -1
    open(newunit=u, file='/proc/self/status', status='old', action='read', iostat=ios)
    if (ios /= 0) return
    do
      read(u, '(a)', iostat=ios) line
      if (ios /= 0) exit
      if (line(1:6) == 'VmHWM:') then
        read(line(7:), *, iostat=ios) kb
        if (ios == 0) mb = kb / 1024
        exit
      end if
    end do
    close(u)
  end function peak_memory_mb

  !> Large arrays (1 MiB and more) from their own mappings, returned to the
  !> system when freed.  glibc otherwise raises its mmap threshold up to
  !> 32 MiB each time such an array is freed, after which arrays of that
  !> size come from the heap, where what the set-up freed (the packing's
  !> work arrays, the first list builds) stays resident under the time
  !> loop's arrays: a million packed particles on 2 ranks peaked at 425 MB
  !> per rank with the dynamic threshold and 373 MB with this one
  !> (doc/studies/ellipsoid3d.md).  glibc's mallopt (Debian's C library).
  subroutine map_large_arrays()
    interface
      integer(c_int) function mallopt(param, value) bind(C, name='mallopt')
        import :: c_int
        integer(c_int), value :: param, value
      end function mallopt
    end interface
    integer(c_int), parameter :: M_MMAP_THRESHOLD = -3, ONE_MIB = 1048576
    integer(c_int) :: done
    done = mallopt(M_MMAP_THRESHOLD, ONE_MIB)
  end subroutine map_large_arrays

end module memory_usage
