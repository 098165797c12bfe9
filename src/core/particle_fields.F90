!> The registry of per-particle fields: each field of particles_t declared
!> once, in particle_fields.inc, with its snapshot dataset name, its number
!> of components and the transports it takes part in.  Migration, the halo,
!> snapshots and restarts loop over this table instead of naming the fields
!> (doc/developer/parallel.md).  Adding a field is its line in particle_fields.inc.
module particle_fields
  implicit none
  private
  public :: field_t, FIELD_TABLE, N_FIELDS
  public :: MIGRATE_FIELDS, HALO_FIELDS, REFRESH_FIELDS, SNAPSHOT_FIELDS, RESTART_FIELDS, &
            CHECKPOINT_FIELDS
  public :: MIGRATE_WORDS, HALO_WORDS, REFRESH_WORDS
  ! the FIELD_ constants
#define FIELD(key, mem, kind, dset, mi, ha, re, sn, rs, ck) public :: key
#include "particle_fields.inc"
#undef FIELD

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

  !> FIELD_X = 1, FIELD_U = 2, ...: the fields numbered in their order
  enum, bind(c)
    enumerator :: NO_FIELD = 0
#define FIELD(key, mem, kind, dset, mi, ha, re, sn, rs, ck) enumerator :: key
#include "particle_fields.inc"
#undef FIELD
  end enum

  logical, parameter :: T = .true., F = .false.
  !> the kinds as (ncomp, integer8)
#define VECTOR 3, F
#define SCALAR 1, F
#define INT8 1, T
#define FIELD(key, mem, kind, dset, mi, ha, re, sn, rs, ck) \
  , field_t(key, dset, kind, mi, ha, re, sn, rs, ck) &
  type(field_t), parameter :: FIELD_TABLE(*) = [[field_t ::] &
#include "particle_fields.inc"
    ]
#undef FIELD
#undef VECTOR
#undef SCALAR
#undef INT8
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
