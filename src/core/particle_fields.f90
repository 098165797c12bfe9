!> The registry of per-particle fields: each field of particles_t declared
!> once, with its snapshot dataset name, its number of components and the
!> transports it takes part in.  Migration, the halo, snapshots and restarts
!> loop over this table instead of naming the fields (doc/parallel.md).
!>
!> Adding a field: its FIELD_ constant and row here, and in
!> src/core/particles.f90 its array in particles_t, its allocation and its case
!> in particles_field (or particles_field_i8).
module particle_fields
  implicit none
  private
  public :: field_t, FIELD_TABLE, N_FIELDS
  public :: FIELD_X, FIELD_U, FIELD_RHO, FIELD_P, FIELD_M, FIELD_ID, FIELD_X0, FIELD_XREF
  public :: MIGRATE_FIELDS, HALO_FIELDS, REFRESH_FIELDS, SNAPSHOT_FIELDS, RESTART_FIELDS, &
            CHECKPOINT_FIELDS
  public :: MIGRATE_WORDS, HALO_WORDS, REFRESH_WORDS

  !> A field: ncomp = 3 is a vector (3 rows in memory, dim of them in a
  !> snapshot), integer8 an int64 field (travels bit for bit in real buffers).
  type :: field_t
    integer :: key        !< its FIELD_ constant, its position in the table
    character(len=24) :: name
    integer :: ncomp
    logical :: integer8
    logical :: migrate    !< moves with its particle to a new owner
    logical :: halo       !< copied into the halo when it is built
    logical :: refresh    !< brought up to date in the halo before every right-hand side
    logical :: snapshot   !< a dataset of every snapshot (and an XDMF attribute)
    logical :: restart    !< read back from a snapshot on restart
    !> written to a checkpoint besides the snapshot fields, and read back
    !> from it: the state a run carries from step to step (simulation.f90)
    logical :: checkpoint
  end type field_t

  integer, parameter :: FIELD_X = 1, FIELD_U = 2, FIELD_RHO = 3, FIELD_P = 4, FIELD_M = 5, &
                        FIELD_ID = 6, FIELD_X0 = 7, FIELD_XREF = 8

  logical, parameter :: T = .true., F = .false.
  !> In snapshot order: position first (the XDMF geometry), the standard
  !> datasets of doc/output.md, then position_initial (for restarts);
  !> position_reference, the owned positions at the last neighbour-list
  !> build (the validity test's reference), only in checkpoints.
  type(field_t), parameter :: FIELD_TABLE(*) = [ &
    !      key         name           ncomp int8 migrate halo refresh snapshot restart checkpoint
    field_t(FIELD_X,    'position',           3, F,  T,      T,   T,      T,       T,      F), &
    field_t(FIELD_U,    'velocity',           3, F,  T,      T,   T,      T,       T,      F), &
    field_t(FIELD_RHO,  'density',            1, F,  T,      T,   T,      T,       T,      F), &
    field_t(FIELD_P,    'pressure',           1, F,  T,      F,   F,      T,       T,      F), &
    field_t(FIELD_M,    'mass',               1, F,  T,      T,   F,      T,       T,      F), &
    field_t(FIELD_ID,   'id',                 1, T,  T,      T,   F,      T,       T,      F), &
    field_t(FIELD_X0,   'position_initial',   3, F,  T,      F,   F,      T,       T,      F), &
    field_t(FIELD_XREF, 'position_reference', 3, F,  T,      F,   F,      F,       F,      T)]
  integer, parameter :: N_FIELDS = size(FIELD_TABLE)

  !> The fields of each transport, in table order.
  integer, parameter :: MIGRATE_FIELDS(*) = pack(FIELD_TABLE%key, FIELD_TABLE%migrate)
  integer, parameter :: HALO_FIELDS(*) = pack(FIELD_TABLE%key, FIELD_TABLE%halo)
  integer, parameter :: REFRESH_FIELDS(*) = pack(FIELD_TABLE%key, FIELD_TABLE%refresh)
  integer, parameter :: SNAPSHOT_FIELDS(*) = pack(FIELD_TABLE%key, FIELD_TABLE%snapshot)
  integer, parameter :: RESTART_FIELDS(*) = pack(FIELD_TABLE%key, FIELD_TABLE%restart)
  integer, parameter :: CHECKPOINT_FIELDS(*) = pack(FIELD_TABLE%key, FIELD_TABLE%checkpoint)
  !> Reals per particle in the message buffers of the transports.
  integer, parameter :: MIGRATE_WORDS = sum(FIELD_TABLE(MIGRATE_FIELDS)%ncomp)
  integer, parameter :: HALO_WORDS = sum(FIELD_TABLE(HALO_FIELDS)%ncomp)
  integer, parameter :: REFRESH_WORDS = sum(FIELD_TABLE(REFRESH_FIELDS)%ncomp)

end module particle_fields
