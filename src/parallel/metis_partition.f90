!> Graph partitioning with METIS 5 (METIS_PartGraphKway) through its C
!> interface: 32-bit idx_t and real_t (metis.h of Debian), 0-based numbering.
module metis_partition
  use, intrinsic :: iso_c_binding, only: c_int32_t, c_float, c_ptr, c_null_ptr
  implicit none
  private
  public :: partition_graph

  integer, parameter :: METIS_NOPTIONS = 40
  integer, parameter :: METIS_OK = 1
  integer, parameter :: OPT_SEED = 8, OPT_NUMBERING = 17

  interface
    integer(c_int32_t) function metis_setdefaultoptions(options) &
        bind(c, name='METIS_SetDefaultOptions')
      import :: c_int32_t
      integer(c_int32_t), intent(inout) :: options(*)
    end function metis_setdefaultoptions

    integer(c_int32_t) function metis_partgraphkway(nvtxs, ncon, xadj, adjncy, vwgt, vsize, &
        adjwgt, nparts, tpwgts, ubvec, options, edgecut, part) bind(c, name='METIS_PartGraphKway')
      import :: c_int32_t, c_ptr
      integer(c_int32_t), intent(in) :: nvtxs, ncon, nparts
      integer(c_int32_t), intent(in) :: xadj(*), adjncy(*), vwgt(*)
      type(c_ptr), value :: vsize, adjwgt, tpwgts, ubvec
      integer(c_int32_t), intent(in) :: options(*)
      integer(c_int32_t), intent(out) :: edgecut
      integer(c_int32_t), intent(out) :: part(*)
    end function metis_partgraphkway
  end interface

contains

  !> Splits the graph of nv vertices (CSR xadj(nv+1), adjncy, 0-based; vertex
  !> weights vwgt) into nparts parts of balanced weight with few cut edges:
  !> part(v) in 0..nparts-1.  One part, or no more vertices than parts, is
  !> handled here (METIS fails on one part).  A fixed seed makes the result
  !> the same on every run.
  subroutine partition_graph(nv, xadj, adjncy, vwgt, nparts, part)
    integer, intent(in) :: nv, nparts
    integer, intent(in) :: xadj(:), adjncy(:), vwgt(:)
    integer, intent(out) :: part(:)
    integer(c_int32_t) :: options(0:METIS_NOPTIONS - 1), edgecut, status
    integer(c_int32_t), allocatable :: p(:)
    integer :: v
    if (nparts == 1) then
      part(1:nv) = 0
      return
    else if (nv <= nparts) then
      part(1:nv) = [(v, v = 0, nv - 1)]
      return
    end if
    status = metis_setdefaultoptions(options)
    options(OPT_NUMBERING) = 0
    options(OPT_SEED) = 7
    allocate(p(nv))
    status = metis_partgraphkway(int(nv, c_int32_t), 1_c_int32_t, int(xadj, c_int32_t), &
                                 int(adjncy, c_int32_t), int(vwgt, c_int32_t), c_null_ptr, &
                                 c_null_ptr, int(nparts, c_int32_t), c_null_ptr, c_null_ptr, &
                                 options, edgecut, p)
    if (status /= METIS_OK) error stop 'partition_graph: METIS_PartGraphKway failed'
    part(1:nv) = int(p)
  end subroutine partition_graph

end module metis_partition
