!> Mirror symmetry planes through the origin (doc/theory/mirrors.md, M1-M5).
!>
!> A run with planes holds the part x_k >= 0 of the body on each mirrored
!> axis k; a particle on a plane is one with its images there (M5).  A
!> mask names the planes (bit 0: x = 0, bit 1: y = 0, bit 2: z = 0); a
!> code, a nonzero submask of it, names a reflection: the one that flips
!> the axes in the code.  Each particle within the list radius
!> of the planes gets an image per code, made by the halo (halo_exchange):
!> positions and polar vectors flip the code's components, scalars are
!> copied, symmetric tensors flip their mixed entries (a, b) by s_a s_b.
!> An image carries the id id + code 2^32, so that its place in the
!> neighbour list's canonical order depends on the particle and the code
!> only, never on the rank that made it.
module mirrors
  use kinds, only: wp, i8
  implicit none
  private
  public :: mirror_mask, mirror_word, mirror_copies, mirror_codes, mirror_signs, reflect, &
            image_id, original_id, image_code, plane_distance2, reflect_column, on_plane, &
            planes_on, plane_weights, set_weight, hold_normal, IMAGE_ID_STRIDE, REFLECT_SCALAR, &
            REFLECT_VECTOR, REFLECT_SYM6, REFLECT_PSEUDO, PLANE_SLAB, PLANE_SLAB_APPROACH, &
            plane_slabs

  !> ids of images: id + code IMAGE_ID_STRIDE (particle ids stay below 2^31)
  integer(i8), parameter :: IMAGE_ID_STRIDE = 2_i8**32
  !> How a per-particle field reflects: copied (scalar), polar vector
  !> (component a times s_a), symmetric tensor stored (xx, yy, zz, xy, xz,
  !> yz) (entry (a, b) times s_a s_b), pseudo-scalar of the x-y plane (the
  !> 2D vorticity: times s_x s_y).
  integer, parameter :: REFLECT_SCALAR = 1, REFLECT_VECTOR = 2, REFLECT_SYM6 = 3, &
                        REFLECT_PSEUDO = 4
  !> (M5) The slab next to a plane that the points on it stand for, in dx:
  !> the packing's first guess gives each plane a lattice whose points, at
  !> weight 1/2, fill it, and the guess and the packing keep every other
  !> particle this far off each plane (doc/studies/symmetry.md, "The start-up dip").
  real(wp), parameter :: PLANE_SLAB = 0.25_wp
  !> (M6) The slab of a plane the flow approaches (its normal rate negative):
  !> deeper, so that no particle starts within dx/2 of such a plane and none
  !> faces its own image closer than dx.  A particle and its image cannot
  !> slide past each other as two particles of the whole body do, and the
  !> compression normal to the plane brings them together (doc/studies/symmetry.md,
  !> "M6").
  real(wp), parameter :: PLANE_SLAB_APPROACH = 0.5_wp

contains

  !> (M6) The slab of each axis's plane for a flow with the initial normal
  !> rates alpha_k (any scale): PLANE_SLAB_APPROACH where alpha_k < 0, else
  !> PLANE_SLAB.
  pure function plane_slabs(rates) result(slab)
    real(wp), intent(in) :: rates(3)
    real(wp) :: slab(3)
    slab = merge(PLANE_SLAB_APPROACH, PLANE_SLAB, rates < 0)
  end function plane_slabs

  !> The mask of a word of the letters x, y, z (each at most once, any
  !> order; 'none' or '' for no plane), -1 if the word is not one.
  pure integer function mirror_mask(word) result(mask)
    character(len=*), intent(in) :: word
    integer :: i, bit
    mask = 0
    if (trim(word) == 'none') return
    do i = 1, len_trim(word)
      bit = index('xyz', word(i:i)) - 1
      if (bit < 0) then
        mask = -1
        return
      end if
      if (btest(mask, bit)) then
        mask = -1
        return
      end if
      mask = ibset(mask, bit)
    end do
  end function mirror_mask

  !> The word of a mask, in the order x, y, z ('none' for 0).
  pure function mirror_word(mask) result(word)
    integer, intent(in) :: mask
    character(len=:), allocatable :: word
    integer :: bit
    word = ''
    do bit = 0, 2
      if (btest(mask, bit)) word = word // 'xyz'(bit + 1:bit + 1)
    end do
    if (len(word) == 0) word = 'none'
  end function mirror_word

  !> How many copies of the part make the whole body: 2^(number of planes).
  pure integer function mirror_copies(mask) result(c)
    integer, intent(in) :: mask
    c = 2**popcnt(mask)
  end function mirror_copies

  !> The reflections of a mask: its nonzero submasks, ascending.
  pure function mirror_codes(mask) result(codes)
    integer, intent(in) :: mask
    integer, allocatable :: codes(:)
    integer :: c
    allocate(codes(0))
    do c = 1, 7
      if (iand(c, mask) == c) codes = [codes, c]
    end do
  end function mirror_codes

  !> s_a = -1 for the axes a in the code, else +1.
  pure function mirror_signs(code) result(s)
    integer, intent(in) :: code
    real(wp) :: s(3)
    integer :: a
    do a = 1, 3
      s(a) = merge(-1.0_wp, 1.0_wp, btest(code, a - 1))
    end do
  end function mirror_signs

  !> (M1) The image R x of a point: the code's coordinates negated (exact).
  pure function reflect(x, code) result(y)
    real(wp), intent(in) :: x(3)
    integer, intent(in) :: code
    real(wp) :: y(3)
    y = x * mirror_signs(code)
  end function reflect

  !> The squared distance between x and its image under the code, over 4:
  !> sum of x_a^2 over the code's axes.  An image can be within r of the
  !> part x_a > 0 only when this is below r^2 (the nearest point of the
  !> part to R x has those coordinates 0).
  pure real(wp) function plane_distance2(x, code) result(d2)
    real(wp), intent(in) :: x(3)
    integer, intent(in) :: code
    integer :: a
    d2 = 0
    do a = 1, 3
      if (btest(code, a - 1)) d2 = d2 + x(a)**2
    end do
  end function plane_distance2

  !> The id of the image of particle `id` under the code.
  elemental integer(i8) function image_id(id, code) result(j)
    integer(i8), intent(in) :: id
    integer, intent(in) :: code
    j = id + int(code, i8) * IMAGE_ID_STRIDE
  end function image_id

  !> The particle an id stands for (the id itself for a particle).
  elemental integer(i8) function original_id(id) result(j)
    integer(i8), intent(in) :: id
    j = modulo(id, IMAGE_ID_STRIDE)
  end function original_id

  !> The reflection an id was made by (0 for a particle).
  elemental integer function image_code(id) result(code)
    integer(i8), intent(in) :: id
    code = int(id / IMAGE_ID_STRIDE)
  end function image_code

  !> (M2) One particle's value of a field of the given kind, reflected in
  !> place by the code.
  pure subroutine reflect_column(kind, code, a)
    integer, intent(in) :: kind, code
    real(wp), intent(inout) :: a(:)
    real(wp) :: s(3)
    s = mirror_signs(code)
    select case (kind)
    case (REFLECT_VECTOR)
      a(1:3) = a(1:3) * s
    case (REFLECT_SYM6)
      a(4) = a(4) * (s(1) * s(2))
      a(5) = a(5) * (s(1) * s(3))
      a(6) = a(6) * (s(2) * s(3))
    case (REFLECT_PSEUDO)
      a(1) = a(1) * (s(1) * s(2))
    end select
  end subroutine reflect_column

  !> A coordinate exactly 0, of either sign (an image's is -0): the
  !> particle lies on the plane (M5).
  pure elemental logical function on_plane(c)
    real(wp), intent(in) :: c
    on_plane = .not. (abs(c) > 0)
  end function on_plane

  !> (M5) The planes of mask a particle at x lies on, as a mask.
  pure integer function planes_on(x, mask) result(on)
    real(wp), intent(in) :: x(3)
    integer, intent(in) :: mask
    integer :: k
    on = 0
    do k = 1, 3
      if (btest(mask, k - 1) .and. on_plane(x(k))) on = ibset(on, k - 1)
    end do
  end function planes_on

  !> (M5) The weight of each particle: 2^-k for one lying on k of the planes
  !> (x_a = 0 exactly; -0 for an image), 1 otherwise.  A particle on a plane
  !> and its images there coincide: together they are one particle.
  pure function plane_weights(x, mask) result(w)
    real(wp), intent(in) :: x(:, :)
    integer, intent(in) :: mask
    real(wp) :: w(size(x, 2))
    integer :: i
    do i = 1, size(x, 2)
      w(i) = set_weight(planes_on(x(:, i), mask))
    end do
  end function plane_weights

  !> (M5) The weight of a particle on the planes of the set `on`
  !> (planes_on): 2^-k on k planes.
  pure elemental real(wp) function set_weight(on) result(w)
    integer, intent(in) :: on
    w = 0.5_wp**popcnt(on)
  end function set_weight

  !> (M5) A particle at x on planes of mask moves along them only: the
  !> normal components of its move (velocity, acceleration) v are 0.
  pure subroutine hold_normal(x, mask, v)
    real(wp), intent(in) :: x(3)
    integer, intent(in) :: mask
    real(wp), intent(inout) :: v(3)
    integer :: on, k
    on = planes_on(x, mask)
    do k = 1, 3
      if (btest(on, k - 1)) v(k) = 0
    end do
  end subroutine hold_normal

end module mirrors
