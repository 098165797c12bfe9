!> Peak resident memory of this process (Linux: VmHWM in /proc/self/status).
module memory_usage
  use kinds, only: wp
  implicit none
  private
  public :: peak_memory_mb

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

end module memory_usage
