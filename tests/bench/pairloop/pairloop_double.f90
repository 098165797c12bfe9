!> The pair-loop benchmark's loops in double precision
!> (pairloop_kernels.inc, compiled once per real kind).
module pairloop_double
  use pairloop_layout, only: rk => dp, i8, LANES, REC_LEN, R_RHO, R_P, R_VOL, R_IRHO, &
                             P_DX, P_DY, P_DZ, P_R2, P_U, P_V, P_W, P_RHO, P_P, P_VOL, P_IRHO, &
                             Q_X, Q_Y, Q_Z, Q_U, Q_V, Q_W, Q_RHO, Q_P, Q_VOL, Q_IRHO
  implicit none
  private
  public :: half_rows, body_only, clusters
contains
  include 'pairloop_kernels.inc'
end module pairloop_double
