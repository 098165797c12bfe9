!> Kinds and layout of the pair-loop benchmark's data (make
!> bench-pairloop): the real kinds it compares, the record of a particle
!> (rec(:, j), as the solver's pair-loop record), the columns of the
!> compacted partner data of body_only, the per-quantity arrays of the
!> cluster order.
module pairloop_layout
  use, intrinsic :: iso_fortran_env, only: real32, real64, int64
  implicit none
  private
  public :: sp, dp, i8
  public :: LANES, REC_LEN, R_RHO, R_P, R_VOL, R_IRHO
  public :: P_DX, P_DY, P_DZ, P_R2, P_U, P_V, P_W, P_RHO, P_P, P_VOL, P_IRHO, P_COLS
  public :: Q_X, Q_Y, Q_Z, Q_U, Q_V, Q_W, Q_RHO, Q_P, Q_VOL, Q_IRHO, Q_COLS
  !> the two precisions compared, and the counters' integer kind
  integer, parameter :: sp = real32, dp = real64, i8 = int64
  !> lane sums per row, as src/sph/fluid_rhs.f90
  integer, parameter :: LANES = 8
  !> record: u (1:3), rho, p, V, 1/rho, a spare
  integer, parameter :: REC_LEN = 8, R_RHO = 4, R_P = 5, R_VOL = 6, R_IRHO = 7
  integer, parameter :: P_DX = 1, P_DY = 2, P_DZ = 3, P_R2 = 4, P_U = 5, P_V = 6, P_W = 7, &
                        P_RHO = 8, P_P = 9, P_VOL = 10, P_IRHO = 11, P_COLS = 11
  integer, parameter :: Q_X = 1, Q_Y = 2, Q_Z = 3, Q_U = 4, Q_V = 5, Q_W = 6, Q_RHO = 7, &
                        Q_P = 8, Q_VOL = 9, Q_IRHO = 10, Q_COLS = 10
end module pairloop_layout
