!> File-system helpers for the output layer: mkdir -p, atomic rename, exists,
!> remove, path pieces, and the rule every output follows (write to a hidden
!> temporary name in the same directory, then rename it over the final name,
!> so that a reader sees a file complete or not at all).
!>
!> The C library is reached through bind(c) with null-terminated strings.
!> Error texts come from strerror(errno); errno is read through glibc's (and
!> musl's) __errno_location, the one Linux-specific call here.
!>
!> agree_ok is the one collective routine: it makes a success flag and its
!> message the same on every rank, so that all ranks take the same branch
!> after an I/O step that only some of them (or only rank 0) performed.
module fileutil
  use, intrinsic :: iso_c_binding, only: c_char, c_int, c_long, c_ptr, c_null_char, &
                                         c_associated, c_f_pointer, c_size_t
  use kinds, only: i8
  use mpi_f08, only: MPI_Comm, MPI_Comm_rank, MPI_Comm_size, MPI_Allreduce, &
                     MPI_Bcast, MPI_IN_PLACE, MPI_INTEGER, MPI_MIN, MPI_CHARACTER
  implicit none
  private
  public :: make_directory, rename_file, file_exists, remove_file, is_directory
  public :: make_temp_directory, temp_path, base_name, dir_name, join_path
  public :: agree_ok, free_bytes
  public :: text_buffer_t, text_append, write_file_atomic

  !> A growing text: s(1:n) is the content, the rest spare capacity, so that
  !> appending line after line costs amortised O(length).
  type :: text_buffer_t
    character(len=:), allocatable :: s
    integer :: n = 0
  end type text_buffer_t

  integer(c_int), parameter :: EEXIST = 17_c_int   !< Linux errno value
  integer(c_int), parameter :: F_OK = 0_c_int
  integer(c_int), parameter :: MODE_DIR = int(o'755', c_int)

  interface
    function c_mkdir(path, mode) bind(c, name='mkdir') result(r)
      import :: c_char, c_int
      character(kind=c_char), intent(in) :: path(*)
      integer(c_int), value :: mode   ! mode_t is a 32-bit unsigned int on Linux
      integer(c_int) :: r
    end function c_mkdir

    function c_rename(old, new) bind(c, name='rename') result(r)
      import :: c_char, c_int
      character(kind=c_char), intent(in) :: old(*), new(*)
      integer(c_int) :: r
    end function c_rename

    function c_remove(path) bind(c, name='remove') result(r)
      import :: c_char, c_int
      character(kind=c_char), intent(in) :: path(*)
      integer(c_int) :: r
    end function c_remove

    function c_access(path, mode) bind(c, name='access') result(r)
      import :: c_char, c_int
      character(kind=c_char), intent(in) :: path(*)
      integer(c_int), value :: mode
      integer(c_int) :: r
    end function c_access

    function c_opendir(path) bind(c, name='opendir') result(d)
      import :: c_char, c_ptr
      character(kind=c_char), intent(in) :: path(*)
      type(c_ptr) :: d
    end function c_opendir

    function c_closedir(d) bind(c, name='closedir') result(r)
      import :: c_ptr, c_int
      type(c_ptr), value :: d
      integer(c_int) :: r
    end function c_closedir

    function c_mkdtemp(template) bind(c, name='mkdtemp') result(p)
      import :: c_char, c_ptr
      character(kind=c_char), intent(inout) :: template(*)
      type(c_ptr) :: p
    end function c_mkdtemp

    function c_errno_location() bind(c, name='__errno_location') result(p)
      import :: c_ptr
      type(c_ptr) :: p
    end function c_errno_location

    function c_strerror(errnum) bind(c, name='strerror') result(p)
      import :: c_int, c_ptr
      integer(c_int), value :: errnum
      type(c_ptr) :: p
    end function c_strerror

    ! struct statvfs is 11 unsigned longs and 6 ints on x86_64 and aarch64
    ! glibc; `buf` is larger than that, and only words 2 (f_frsize) and 5
    ! (f_bavail) are read
    function c_statvfs(path, buf) bind(c, name='statvfs') result(r)
      import :: c_char, c_int, c_long
      character(kind=c_char), intent(in) :: path(*)
      integer(c_long), intent(out) :: buf(*)
      integer(c_int) :: r
    end function c_statvfs

    function c_strlen(s) bind(c, name='strlen') result(n)
      import :: c_ptr, c_size_t
      type(c_ptr), value :: s
      integer(c_size_t) :: n
    end function c_strlen
  end interface

contains

  !> Creates directory `path` and any missing parents (mkdir -p); an existing
  !> directory is success, an existing non-directory is an error.
  subroutine make_directory(path, ok, errmsg)
    character(len=*), intent(in) :: path
    logical, intent(out) :: ok
    character(len=:), allocatable, intent(out) :: errmsg
    integer :: k, n
    integer(c_int) :: err
    n = len_trim(path)
    ok = .false.
    if (n == 0) then
      errmsg = 'make_directory: empty path'
      return
    end if
    ! every prefix that ends before a '/', then the whole path
    do k = 2, n + 1
      if (k <= n) then
        if (path(k:k) /= '/' .or. path(k-1:k-1) == '/') cycle
      end if
      if (c_mkdir(c_str(path(1:k-1)), MODE_DIR) /= 0) then
        err = errno()
        if (err /= EEXIST) then
          errmsg = 'cannot create directory "' // path(1:k-1) // '": ' // strerror(err)
          return
        end if
      end if
    end do
    if (.not. is_directory(path(1:n))) then
      errmsg = 'cannot create directory "' // path(1:n) // &
               '": a file of that name exists and is not a directory'
      return
    end if
    ok = .true.
    errmsg = ''
  end subroutine make_directory

  !> Renames `old` to `new`, replacing `new` if it exists; atomic on POSIX
  !> when both are on the same file system (same directory: always).
  subroutine rename_file(old, new, ok, errmsg)
    character(len=*), intent(in) :: old, new
    logical, intent(out) :: ok
    character(len=:), allocatable, intent(out) :: errmsg
    ok = c_rename(c_str(old), c_str(new)) == 0
    if (ok) then
      errmsg = ''
    else
      errmsg = 'cannot rename "' // old // '" to "' // new // '": ' // strerror(errno())
    end if
  end subroutine rename_file

  !> The bytes an unprivileged writer may still use on the file system of
  !> `path` (statvfs: f_bavail f_frsize); -1 if that cannot be told.
  integer(i8) function free_bytes(path)
    character(len=*), intent(in) :: path
    integer(c_long) :: buf(32)
    buf = 0
    free_bytes = -1
    if (c_statvfs(c_str(path), buf) == 0) free_bytes = int(buf(5), i8) * int(buf(2), i8)
  end function free_bytes

  !> True if `path` names an existing file or directory.
  logical function file_exists(path)
    character(len=*), intent(in) :: path
    file_exists = c_access(c_str(path), F_OK) == 0
  end function file_exists

  !> True if `path` names a directory that can be opened.
  logical function is_directory(path)
    character(len=*), intent(in) :: path
    type(c_ptr) :: d
    integer(c_int) :: r
    d = c_opendir(c_str(path))
    is_directory = c_associated(d)
    if (is_directory) r = c_closedir(d)
  end function is_directory

  !> Removes a file (or an empty directory); `ok` says whether it worked.
  !> A missing file is not an error when ok is not asked for.
  subroutine remove_file(path, ok)
    character(len=*), intent(in) :: path
    logical, intent(out), optional :: ok
    integer(c_int) :: r
    r = c_remove(c_str(path))
    if (present(ok)) ok = r == 0
  end subroutine remove_file

  !> Creates a fresh directory `prefix`XXXXXX (mkdtemp) and returns its name,
  !> or an empty string if that failed.
  function make_temp_directory(prefix) result(path)
    character(len=*), intent(in) :: prefix
    character(len=:), allocatable :: path
    character(kind=c_char, len=len(prefix) + 7) :: template
    type(c_ptr) :: p
    template = prefix // 'XXXXXX' // c_null_char
    p = c_mkdtemp(template)
    if (c_associated(p)) then
      path = template(1:len(prefix) + 6)
    else
      path = ''
    end if
  end function make_temp_directory

  !> The temporary name an output `path` is written to before its rename:
  !> the same directory, a hidden name, '.tmp' appended ("dir/.name.tmp").
  function temp_path(path) result(tmp)
    character(len=*), intent(in) :: path
    character(len=:), allocatable :: tmp
    tmp = join_path(dir_name(path), '.' // base_name(path) // '.tmp')
  end function temp_path

  !> The last component of a path ("a/b/c.h5" -> "c.h5").
  function base_name(path) result(name)
    character(len=*), intent(in) :: path
    character(len=:), allocatable :: name
    integer :: k
    k = index(trim(path), '/', back=.true.)
    name = trim(path(k+1:))
  end function base_name

  !> The directory part of a path ("a/b/c.h5" -> "a/b", "c.h5" -> ".",
  !> "/c.h5" -> "/").
  function dir_name(path) result(dir)
    character(len=*), intent(in) :: path
    character(len=:), allocatable :: dir
    integer :: k
    k = index(trim(path), '/', back=.true.)
    if (k == 0) then
      dir = '.'
    else if (k == 1) then
      dir = '/'
    else
      dir = path(1:k-1)
    end if
  end function dir_name

  !> dir // '/' // name, without doubling a trailing '/'; "." is dropped.
  function join_path(dir, name) result(path)
    character(len=*), intent(in) :: dir, name
    character(len=:), allocatable :: path
    integer :: n
    n = len_trim(dir)
    if (n == 0 .or. dir(1:n) == '.') then
      path = name
    else if (dir(n:n) == '/') then
      path = dir(1:n) // name
    else
      path = dir(1:n) // '/' // name
    end if
  end function join_path

  !> Appends `str` to the buffer, doubling its capacity when needed.
  subroutine text_append(buf, str)
    type(text_buffer_t), intent(inout) :: buf
    character(len=*), intent(in) :: str
    character(len=:), allocatable :: grown
    integer :: cap
    if (.not. allocated(buf%s)) then
      allocate(character(len=max(4096, 2 * len(str))) :: buf%s)
      buf%n = 0
    end if
    if (buf%n + len(str) > len(buf%s)) then
      cap = max(2 * len(buf%s), buf%n + len(str))
      allocate(character(len=cap) :: grown)
      grown(1:buf%n) = buf%s(1:buf%n)
      call move_alloc(grown, buf%s)
    end if
    buf%s(buf%n+1:buf%n+len(str)) = str
    buf%n = buf%n + len(str)
  end subroutine text_append

  !> Writes `text` (bytes as given, no added newline) to `path` atomically:
  !> to temp_path(path) first, then renamed over `path`.  On failure the
  !> temporary file is removed and `path` is left as it was.
  subroutine write_file_atomic(path, text, ok, errmsg)
    character(len=*), intent(in) :: path, text
    logical, intent(out) :: ok
    character(len=:), allocatable, intent(out) :: errmsg
    character(len=:), allocatable :: tmp
    character(len=256) :: msg
    integer :: u, ios
    tmp = temp_path(path)
    ok = .false.
    open(newunit=u, file=tmp, access='stream', form='unformatted', status='replace', &
         action='write', iostat=ios, iomsg=msg)
    if (ios /= 0) then
      errmsg = 'cannot open "' // tmp // '" for writing: ' // trim(msg)
      return
    end if
    write(u, iostat=ios, iomsg=msg) text
    if (ios /= 0) then
      errmsg = 'cannot write "' // tmp // '": ' // trim(msg)
      close(u, status='delete')
      return
    end if
    close(u, iostat=ios, iomsg=msg)
    if (ios /= 0) then
      errmsg = 'cannot close "' // tmp // '": ' // trim(msg)
      call remove_file(tmp)
      return
    end if
    call rename_file(tmp, path, ok, errmsg)
    if (.not. ok) call remove_file(tmp)
  end subroutine write_file_atomic

  !> Collective over `comm`: afterwards every rank has ok = .false. if any
  !> rank had, and the message of the lowest such rank.
  subroutine agree_ok(comm, ok, errmsg)
    type(MPI_Comm), intent(in) :: comm
    logical, intent(inout) :: ok
    character(len=:), allocatable, intent(inout) :: errmsg
    integer :: rank, nranks, first, n
    call MPI_Comm_rank(comm, rank)
    call MPI_Comm_size(comm, nranks)
    first = merge(nranks, rank, ok)
    call MPI_Allreduce(MPI_IN_PLACE, first, 1, MPI_INTEGER, MPI_MIN, comm)
    ok = first == nranks
    if (ok) then
      if (.not. allocated(errmsg)) errmsg = ''
      return
    end if
    if (.not. allocated(errmsg)) errmsg = 'unknown error'
    n = len(errmsg)
    call MPI_Bcast(n, 1, MPI_INTEGER, first, comm)
    if (rank /= first) then
      deallocate(errmsg)
      allocate(character(len=n) :: errmsg)
    end if
    if (n > 0) call MPI_Bcast(errmsg, n, MPI_CHARACTER, first, comm)
  end subroutine agree_ok

  ! ---- internals ----

  !> A Fortran string as a null-terminated C string.
  pure function c_str(s) result(c)
    character(len=*), intent(in) :: s
    character(kind=c_char, len=len(s) + 1) :: c
    c = s // c_null_char
  end function c_str

  integer(c_int) function errno()
    integer(c_int), pointer :: e
    call c_f_pointer(c_errno_location(), e)
    errno = e
  end function errno

  function strerror(err) result(msg)
    integer(c_int), intent(in) :: err
    character(len=:), allocatable :: msg
    type(c_ptr) :: p
    character(kind=c_char), pointer :: chars(:)
    integer :: k, n
    p = c_strerror(err)
    if (.not. c_associated(p)) then
      msg = 'unknown error'
      return
    end if
    n = int(c_strlen(p))
    call c_f_pointer(p, chars, [n])
    allocate(character(len=n) :: msg)
    do k = 1, n
      msg(k:k) = chars(k)
    end do
  end function strerror

end module fileutil
