!> A linear translational spring from one joint point P_j of the chain to an anchor point a fixed
!> in the model frame (docs/model.md, "Anchor spring"): F = -k (P_j - a) at P_j, on body b =
!> min(j, n) (P_j starts body j; P_{n+1}, the tip, ends body n), applied as that force at the CM
!> C_b plus the moment (P_j - C_b) x F; potential k |P_j - a|^2 / 2.  A spring of zero rest
!> length: the anchor is where it pulls to.
!> Parameters: joint (integer, 1 ... n+1), point(3) [m], stiffness [N/m].
module rotorcable_loads_anchor
  use rotorcable_kinds, only: dp
  use rotorcable_errors, only: error_type, fatal_error
  use rotorcable_chain, only: chain_type
  use rotorcable_kinematics, only: chain_state
  use rotorcable_kinematics_tangent, only: chain_tangent
  use rotorcable_frame, only: frame_state
  use rotorcable_rotations, only: cross, skew
  use rotorcable_loads_type, only: load_term, load_slot
  use rotorcable_parameter_block, only: parameter_block, get_real, get_reals, get_int
  implicit none
  private
  public :: anchor_load, new_anchor

  !> Spring from joint point P_j to the anchor point.
  type, extends(load_term) :: anchor_load
    integer :: joint = 0                      !< j: the spring's end on the chain is P_j
    integer :: body = 0                       !< b = min(j, n): the body P_j is a point of
    real(dp) :: point(3) = 0.0_dp             !< anchor point a, model frame [m]
    real(dp) :: stiffness = 0.0_dp            !< k [N/m]
  contains
    procedure :: add_forces
    procedure :: add_force_tangent
    procedure :: add_force_jacobians
    procedure :: potential
  end type anchor_load

contains

  !> Build from its parameter block: joint, point(3) [m], stiffness [N/m].
  subroutine new_anchor(slot, chain, params, error)
    include 'constructor_arguments.inc'
    type(anchor_load) :: load
    call get_int(params, 'joint', load%joint, error)
    call get_reals(params, 'point', load%point, error)
    call get_real(params, 'stiffness', load%stiffness, error)
    if (error%code /= 0) return
    if (load%joint < 1 .or. load%joint > chain%n_bodies + 1) then
      ! Named by its parameter: pydriver.core turns that into the deck key that fed it.
      call fatal_error(error, 'the anchored joint must be 1 ... n_bodies + 1 (the tip)', key='joint')
      return
    end if
    load%label = 'anchor spring'
    load%body = min(load%joint, chain%n_bodies)
    load%conservative = .true.
    allocate (slot%term, source=load)
  end subroutine new_anchor

  pure subroutine add_forces(self, chain, st, fs, t, q, v, force, moment, tau)
    class(anchor_load), intent(in) :: self
    include 'force_arguments.inc'
    real(dp) :: f(3)
    integer :: b
    b = self%body
    f = -self%stiffness*(st%joint_point(:, self%joint) - self%point)
    force(:, b) = force(:, b) + f
    moment(:, b) = moment(:, b) + cross(st%joint_point(:, self%joint) - st%cm(:, b), f)
  end subroutine add_forces

  !> dF = -k dP_j;  dM = (dP_j - dC_b) x F + (P_j - C_b) x dF.
  pure subroutine add_force_tangent(self, chain, st, dst, fs, t, q, v, dq, dv, dforce, dmoment, dtau)
    class(anchor_load), intent(in) :: self
    include 'force_tangent_arguments.inc'
    real(dp) :: f(3), df(3)
    integer :: b, j
    b = self%body
    j = self%joint
    f = -self%stiffness*(st%joint_point(:, j) - self%point)
    df = -self%stiffness*dst%djoint_point(:, j)
    dforce(:, b) = dforce(:, b) + df
    dmoment(:, b) = dmoment(:, b) + cross(dst%djoint_point(:, j) - dst%dcm(:, b), f) &
                    + cross(st%joint_point(:, j) - st%cm(:, b), df)
  end subroutine add_force_tangent

  !> With r = P_j - C_b (dP_j = dC - [r] dtheta): dF = -k dC + k [r] dtheta and
  !> dM = (dtheta x r) x F + r x dF = -k [r] dC + ([F] [r] + k [r] [r]) dtheta.
  pure subroutine add_force_jacobians(self, chain, st, fs, t, q, v, pose, motion, joint_q, joint_v)
    class(anchor_load), intent(in) :: self
    include 'force_jacobians_arguments.inc'
    real(dp) :: f(3), r(3, 3)
    integer :: b, j, i
    b = self%body
    j = self%joint
    f = -self%stiffness*(st%joint_point(:, j) - self%point)
    r = skew(st%joint_point(:, j) - st%cm(:, b))
    do i = 1, 3
      pose(i, i, b) = pose(i, i, b) - self%stiffness
    end do
    pose(1:3, 4:6, b) = pose(1:3, 4:6, b) + self%stiffness*r
    pose(4:6, 1:3, b) = pose(4:6, 1:3, b) - self%stiffness*r
    pose(4:6, 4:6, b) = pose(4:6, 4:6, b) + matmul(skew(f), r) + self%stiffness*matmul(r, r)
  end subroutine add_force_jacobians

  pure real(dp) function potential(self, chain, st, q) result(e)
    class(anchor_load), intent(in) :: self
    include 'potential_arguments.inc'
    e = 0.5_dp*self%stiffness*sum((st%joint_point(:, self%joint) - self%point)**2)
  end function potential

end module rotorcable_loads_anchor
