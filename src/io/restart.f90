!> Restart from a snapshot: the particle state, the time and the step count
!> it was written at, and the history of the run directory (the XDMF index
!> of the earlier snapshots; the time series is reloaded by the caller).
!> Any number of ranks can read a snapshot written by any other: each reads
!> a block of rows, and the first list build migrates them to their owners.
module restart
  use kinds, only: wp, i8
  use particles, only: particles_t
  use particle_io, only: particles_from_snapshot, particles_from_checkpoint, &
                         particles_drop_images
  use mirrors, only: mirror_word
  use parallel_env, only: parallel_env_t
  use fileutil, only: join_path, file_exists, base_name
  use snapshot_io, only: snapshot_t, snapshot_read, snapshot_filename, xdmf_index_t, xdmf_add
  implicit none
  private
  public :: restart_read, restart_index_history, snapshot_number, restart_info_t, &
            history_attributes, mirror_attributes

  !> Root attributes of the step history (solver: step_history_t): every
  !> snapshot stores the largest acceleration of the last right-hand side,
  !> a checkpoint the list's skin, whether a rebuild is due and how many
  !> snapshots the run had written.
  character(len=*), parameter :: ATTR_ACCEL_MAX = 'history_accel_max', &
                                 ATTR_LIST_SKIN = 'history_list_skin', &
                                 ATTR_FORCE_REBUILD = 'history_force_rebuild', &
                                 ATTR_SNAPSHOTS = 'history_snapshots_written'
  !> the mirror planes' mask of the run and the copies of the part the
  !> file holds (1: the part; 2^planes: the whole body, output.mirror)
  character(len=*), parameter :: ATTR_SYMMETRY = 'symmetry_mask', &
                                 ATTR_COPIES = 'mirror_copies'

  !> What a snapshot or a checkpoint says of the steps before it.
  type :: restart_info_t
    logical :: checkpoint = .false.    !< position_reference and the list history are there
    logical :: has_accel = .false.     !< ATTR_ACCEL_MAX is there (snapshots of 2026-12 on)
    real(wp) :: accel_max = 0
    real(wp) :: list_skin = 0
    !> a snapshot was followed by a list rebuild in the run that wrote it
    logical :: force_rebuild = .true.
    integer :: snapshots_written = -1  !< checkpoint: the next snapshot's number
  end type restart_info_t

contains

  !> Loads the particles of snapshot `path` (this rank's block of rows) into
  !> parts, with the time and step it was written at.  The snapshot must be
  !> of the same case and dimension and hold every field the registry
  !> restarts from (`position_initial` among them).  A checkpoint (written
  !> when a run is stopped early) gives the reference positions of the
  !> neighbour list too, and info what else the run carried.  The messages
  !> name the input variable that gave path: `variable`, by default
  !> '&run restart' ('&particles from' for packed particles).
  !> mirror: the run's planes (mask); the file's must be the same.
  subroutine restart_read(env, path, case_name, dim, parts, t, step, ok, errmsg, info, variable, &
                          mirror)
    type(parallel_env_t), intent(in) :: env
    character(len=*), intent(in) :: path, case_name
    integer, intent(in) :: dim
    type(particles_t), intent(inout) :: parts
    real(wp), intent(out) :: t
    integer, intent(out) :: step
    logical, intent(out) :: ok
    character(len=:), allocatable, intent(out) :: errmsg
    type(restart_info_t), intent(out), optional :: info
    character(len=*), intent(in), optional :: variable
    integer, intent(in), optional :: mirror
    type(snapshot_t) :: snap
    type(restart_info_t) :: inf
    character(len=:), allocatable :: missing
    character(len=:), allocatable :: name
    integer :: k, file_mask, run_mask, copies
    t = 0
    step = 0
    name = '&run restart'
    if (present(variable)) name = variable
    call snapshot_read(env%comm, path, snap, ok, errmsg)
    if (.not. ok) then
      errmsg = name // ' = ''' // path // ''': ' // errmsg
      return
    end if
    if (snap%case_name /= case_name .or. snap%dim /= dim) then
      ok = .false.
      errmsg = name // ' = ''' // path // ''' is a snapshot of case ''' // &
               snap%case_name // ''': it cannot restart case ''' // case_name // ''''
      return
    end if
    call particles_from_snapshot(snap, dim, parts, ok, missing)
    if (.not. ok) then
      errmsg = name // ' = ''' // path // ''' has no ' // missing // ' dataset ' // &
               '(written by an older version): it cannot be restarted from'
      return
    end if
    ! the step history, when the file has it
    file_mask = 0
    copies = 1
    do k = 1, size(snap%attr_names)
      select case (trim(snap%attr_names(k)))
      case (ATTR_SYMMETRY)
        file_mask = nint(snap%attr_values(k))
      case (ATTR_COPIES)
        copies = nint(snap%attr_values(k))
      case (ATTR_ACCEL_MAX)
        inf%has_accel = .true.
        inf%accel_max = snap%attr_values(k)
      case (ATTR_LIST_SKIN)
        inf%checkpoint = .true.
        inf%list_skin = snap%attr_values(k)
      case (ATTR_FORCE_REBUILD)
        inf%force_rebuild = snap%attr_values(k) > 0
      case (ATTR_SNAPSHOTS)
        inf%snapshots_written = nint(snap%attr_values(k))
      end select
    end do
    run_mask = 0
    if (present(mirror)) run_mask = mirror
    if (file_mask /= run_mask) then
      ok = .false.
      errmsg = name // ' = ''' // path // ''' was written with particles.symmetry = ''' // &
               mirror_word(file_mask) // ''': it cannot serve a run with symmetry = ''' // &
               mirror_word(run_mask) // ''''
      return
    end if
    ! a whole-body snapshot (output.mirror): the part is the rows of no image
    if (copies > 1) call particles_drop_images(parts, run_mask)
    if (inf%checkpoint) then
      call particles_from_checkpoint(snap, dim, parts, ok, missing)
      if (.not. ok) then
        errmsg = name // ' = ''' // path // ''' is a checkpoint without its ' // &
                 missing // ' dataset: it cannot be restarted from'
        return
      end if
    end if
    if (present(info)) info = inf
    t = snap%time
    step = snap%step
  end subroutine restart_read

  !> Appends the mirror planes' root attributes of a file (a run with
  !> planes only): the mask and the copies of the part it holds, which
  !> restart_read checks and reads back.
  subroutine mirror_attributes(mask, copies, names, values)
    integer, intent(in) :: mask, copies
    character(len=32), allocatable, intent(inout) :: names(:)
    real(wp), allocatable, intent(inout) :: values(:)
    if (mask == 0) return
    names = [character(len=32) :: names, ATTR_SYMMETRY, ATTR_COPIES]
    values = [values, real(mask, wp), real(copies, wp)]
  end subroutine mirror_attributes

  !> The root attributes that carry info into a file, as restart_read reads
  !> them back: the largest acceleration alone for a snapshot, the whole
  !> history for a checkpoint (info%checkpoint).
  subroutine history_attributes(info, names, values)
    type(restart_info_t), intent(in) :: info
    character(len=32), allocatable, intent(out) :: names(:)
    real(wp), allocatable, intent(out) :: values(:)
    names = [character(len=32) :: ATTR_ACCEL_MAX]
    values = [info%accel_max]
    if (info%checkpoint) then
      names = [character(len=32) :: names, ATTR_LIST_SKIN, ATTR_FORCE_REBUILD, &
               ATTR_SNAPSHOTS]
      values = [values, info%list_skin, merge(1.0_wp, 0.0_wp, info%force_rebuild), &
                real(info%snapshots_written, wp)]
    end if
  end subroutine history_attributes

  !> The number k of a snapshot file name snap_k.h5 (-1 for another name).
  integer function snapshot_number(path) result(k)
    character(len=*), intent(in) :: path
    character(len=:), allocatable :: b
    integer :: ios
    b = base_name(path)
    k = -1
    if (len(b) /= len('snap_00000.h5')) return
    if (b(1:5) /= 'snap_' .or. b(11:13) /= '.h5') return
    read(b(6:10), '(i5)', iostat=ios) k
    if (ios /= 0) k = -1
  end function snapshot_number

  !> Puts the snapshots 0 .. next-1 that exist in `dir` back into the XDMF
  !> index (their headers only are read), so that the index of a restarted
  !> run keeps the earlier times.
  subroutine restart_index_history(env, dir, next, index, ok, errmsg)
    type(parallel_env_t), intent(in) :: env
    character(len=*), intent(in) :: dir
    integer, intent(in) :: next
    type(xdmf_index_t), intent(inout) :: index
    logical, intent(out) :: ok
    character(len=:), allocatable, intent(out) :: errmsg
    type(snapshot_t) :: snap
    integer :: k
    ok = .true.
    errmsg = ''
    do k = 0, next - 1
      if (.not. file_exists(join_path(dir, snapshot_filename(k)))) cycle
      call snapshot_read(env%comm, join_path(dir, snapshot_filename(k)), snap, ok, errmsg, &
                         header_only=.true.)
      if (.not. ok) return
      call xdmf_add(index, snap%time, snapshot_filename(k), snap%n_global, snap%dim, snap%extra)
    end do
  end subroutine restart_index_history

end module restart
