!> The interface every prototype problem implements: its own namelist group
!> (its variables, one line each in visit, and the rules between them, its
!> largest initial speed), its initial particles,
!> the time-series columns and snapshot fields it adds (typically its exact
!> or reference solution and the errors against it), and its closing summary.
!> A new case is a new module extending case_t plus one line in case_factory.
!>
!> A case must say its group (visit, a line a variable), its largest
!> initial speed (max_speed: the Mach check) and its particles (setup); the
!> rest has defaults here for a case that adds nothing: no rules between its
!> variables, no packing, no columns, the solver's free-surface indicator
!> (and vorticity in 2D) as its snapshot fields, no summary.  The defaults
!> ignore the arguments an override uses, as a case may ignore what it does
!> not need: the Makefile compiles src/cases/case_*.f90 without the
!> unused-argument warning.
module case_base
  use kinds, only: wp, i8
  use input_visit, only: visit_t
  use input_params, only: particles_params_t, physics_params_t
  use eos, only: eos_t
  use kernels, only: kernel_t
  use particles, only: particles_t, particles_permute
  use shares, only: share_range
  use parallel_env, only: parallel_env_t
  use mirrors, only: PLANE_SLAB
  implicit none
  private
  public :: case_t, case_fields_t, case_flow_t, case_slot_t, keep_share, flow_field

  !> The names of a case's extra per-particle snapshot fields (their
  !> values come one at a time from case_t%field) and its root attributes.
  type :: case_fields_t
    character(len=32), allocatable :: vector_names(:), scalar_names(:)
    character(len=32), allocatable :: attr_names(:)
    real(wp), allocatable :: attr_values(:)
  end type case_fields_t

  !> Fields of the flow the solver computes for the snapshots on its own
  !> neighbour list (solver_flow_fields), for the owned particles.
  type :: case_flow_t
    real(wp), allocatable :: lambda(:)   !< (n) the free-surface indicator (E9)
    real(wp), allocatable :: omega(:)    !< (n) the vorticity in 2D; empty in 3D
  end type case_flow_t

  type, abstract :: case_t
    character(len=32) :: name = ''       !< the value of run.case and the name of its group
    character(len=60) :: help = ''       !< what the case is, e.g. 'the rotating square patch (2D)'
    !> why placement = 'packed' cannot serve the case, '' if it can
    character(len=60) :: no_packing = 'it has no packing'
    !> why mirror planes cannot serve the case, '' if they can
    character(len=60) :: no_symmetry = 'its flow is not mirror-symmetric'
    integer :: dim = 2
    !> the mirror planes' mask (mirrors; particles.symmetry), 0 for none
    integer :: mirror = 0
    !> > 0: the set-up placed a first guess to be relaxed by the packing
    !> (doc/theory/packing.md) in the ball of this radius, after which
    !> initial_state sets the physical state at the packed positions
    real(wp) :: pack_radius = 0
    !> the packing's slab of each axis's plane, in dx (M5, M6)
    real(wp) :: pack_slab(3) = PLANE_SLAB
  contains
    procedure :: initial_state => no_initial_state
    procedure(visit_i), deferred :: visit
    procedure :: check => no_check
    procedure(max_speed_i), deferred :: max_speed
    procedure(setup_i), deferred :: setup
    procedure :: columns => no_columns
    procedure :: sample => no_sample
    procedure :: fields => flow_fields
    procedure :: field => flow_field
    procedure :: summary => no_summary
  end type case_t

  !> One case of a list of cases of different types.
  type :: case_slot_t
    class(case_t), allocatable :: c
  end type case_slot_t

  abstract interface
    !> The variables of the case's own group, one v%var call each
    !> (input_visit), in the order of the written files.
    subroutine visit_i(self, v)
      import :: case_t, visit_t
      class(case_t), intent(inout) :: self
      type(visit_t), intent(inout) :: v
    end subroutine visit_i

    !> The largest initial speed and how it follows from the group, e.g.
    !> '&circle2d a0 radius' (c0 must be several times larger).
    subroutine max_speed_i(self, speed, formula)
      import :: case_t, wp
      class(case_t), intent(in) :: self
      real(wp), intent(out) :: speed
      character(len=:), allocatable, intent(out) :: formula
    end subroutine max_speed_i

    !> Places this rank's particles and sets their initial state; dx is the
    !> spacing.  share = [r, P]: rank r of P keeps the particles numbered
    !> (their ids) floor(r N/P) + 1 .. floor((r+1) N/P) of the N of the case,
    !> generated without the others where the placement allows it.
    subroutine setup_i(self, particles, physics, eos, parts, dx, share)
      import :: case_t, particles_params_t, physics_params_t, eos_t, &
                particles_t, wp
      class(case_t), intent(inout) :: self
      type(particles_params_t), intent(in) :: particles
      type(physics_params_t), intent(in) :: physics
      type(eos_t), intent(in) :: eos
      type(particles_t), intent(inout) :: parts
      real(wp), intent(out) :: dx
      integer, intent(in) :: share(2)
    end subroutine setup_i
  end interface

contains

  !> The rules between the variables of the group that their ranges cannot
  !> say: var = '' if they hold, else the variable at fault, what is wrong
  !> ('rates = ... sum to ...') and a hint.  None by default.
  subroutine no_check(self, var, what, hint)
    class(case_t), intent(in) :: self
    character(len=:), allocatable, intent(out) :: var, what, hint
    var = ''
    what = ''
    hint = ''
  end subroutine no_check

  !> The state at the current positions of particles of volume m/rho, for
  !> cases that pack (none here).
  subroutine no_initial_state(self, eos, parts)
    class(case_t), intent(inout) :: self
    type(eos_t), intent(in) :: eos
    type(particles_t), intent(inout) :: parts
    if (self%pack_radius > 0) error stop 'case_t: a case that packs must set its initial_state'
  end subroutine no_initial_state

  !> Names of the time-series columns the case adds after the generic ones:
  !> none by default.
  subroutine no_columns(self, names)
    class(case_t), intent(in) :: self
    character(len=32), allocatable, intent(out) :: names(:)
    allocate(names(0))
  end subroutine no_columns

  !> Values of those columns at time t (collective over env).
  subroutine no_sample(self, env, t, parts, kernel, values)
    class(case_t), intent(inout) :: self
    type(parallel_env_t), intent(in) :: env
    real(wp), intent(in) :: t
    type(particles_t), intent(in) :: parts
    type(kernel_t), intent(in) :: kernel
    real(wp), allocatable, intent(out) :: values(:)
    allocate(values(0))
  end subroutine no_sample

  !> The names of the extra snapshot fields and the attributes at time t:
  !> by default the solver's free-surface indicator `free_surface_lambda`
  !> (E9) and, in 2D, its `vorticity`; no attributes.
  subroutine flow_fields(self, t, f)
    class(case_t), intent(inout) :: self
    real(wp), intent(in) :: t
    type(case_fields_t), intent(out) :: f
    allocate(f%vector_names(0), f%attr_names(0), f%attr_values(0))
    f%scalar_names = [character(len=32) :: 'free_surface_lambda']
    if (self%dim == 2) f%scalar_names = [character(len=32) :: 'vorticity', f%scalar_names]
  end subroutine flow_fields

  !> The values at time t of the extra snapshot field `name` (one that
  !> fields names) for the local particles, which may use the solver's
  !> fields of the flow: v(3, n) for a vector, s(n) for a scalar, the
  !> other left unallocated.  One field a call, so that a snapshot holds
  !> one beside the particles (at a million particles on 2 ranks, all at
  !> once took a rank above 400 MB: doc/studies/ellipsoid3d.md).  By
  !> default the solver's fields of flow_fields; an override calls this
  !> one for them.
  subroutine flow_field(self, t, name, parts, flow, v, s)
    class(case_t), intent(inout) :: self
    real(wp), intent(in) :: t
    character(len=*), intent(in) :: name
    type(particles_t), intent(in) :: parts
    type(case_flow_t), intent(in) :: flow
    real(wp), allocatable, intent(out) :: v(:, :), s(:)
    select case (name)
    case ('vorticity')
      s = flow%omega(1:parts%n)
    case ('free_surface_lambda')
      s = flow%lambda(1:parts%n)
    case default
      error stop trim(self%name) // ': no snapshot field ' // name
    end select
  end subroutine flow_field

  !> The closing summary (rank 0 writes to unit; collective over env): none
  !> by default.
  subroutine no_summary(self, env, unit, t, parts, kernel)
    class(case_t), intent(inout) :: self
    type(parallel_env_t), intent(in) :: env
    integer, intent(in) :: unit
    real(wp), intent(in) :: t
    type(particles_t), intent(in) :: parts
    type(kernel_t), intent(in) :: kernel
  end subroutine no_summary

  !> For a case that sets up all its particles (ids 1..N in order): keeps
  !> the share of setup_i's rule.
  subroutine keep_share(parts, share)
    type(particles_t), intent(inout) :: parts
    integer, intent(in) :: share(2)
    integer(i8) :: lo, hi
    integer :: k
    if (share(2) == 1) return
    call share_range(int(parts%n, i8), share(1), share(2), lo, hi)
    call particles_permute(parts, [(k, k = int(lo), int(hi))])
    parts%n = int(hi - lo + 1)
  end subroutine keep_share

end module case_base
