!> Ball B: a spherical support at the chain's far end.  Three constraint rows hold the tip
!> P_{n+1} at p_B(t); the last body turns freely about it, so the support exerts a force and no
!> moment (docs/model.md, "Support B").  p_B is a reference point moved by a prescribed rigid
!> motion (the rotor's carrying round in the inertial frame), or fixed.
!>
!> Rows: g = P_{n+1} - p_B;  G = [a_k x (P_{n+1} - P_k)] per coordinate k of joint k's body;
!> G v + g_t = v_tip - v_B;  d^2g/dt^2 at qdd = 0 = a_tip - a_B (tip velocity and acceleration
!> relative to the model frame; the rows clamp B has for its position,
!> rotorcable_supports_tip_point).  The multipliers are the force on the tip:
!> F_B = lambda, M_B = 0 (eq. 3.50: G^T lambda is the generalized force of F_B at P_{n+1}).
!> Parameters: position(3) [m], and its motion under 'motion.' (rotorcable_motion_builder).
!>
!> Clamp B is a ball support plus orientation rows (rotorcable_supports_clamp extends this
!> type): the position rows, the point's pose and motion and its parameters are written here
!> once, and the clamp's procedures call these for them and add their rows 4:6.
module rotorcable_supports_ball
  use rotorcable_kinds, only: dp
  use rotorcable_errors, only: error_type
  use rotorcable_chain, only: chain_type
  use rotorcable_kinematics, only: chain_state
  use rotorcable_kinematics_tangent, only: chain_tangent
  use rotorcable_frame, only: frame_state
  use rotorcable_rotations, only: skew
  use rotorcable_motion_rotor, only: rotor_state
  use rotorcable_motion_rigid_motion, only: rigid_motion, motion_state, motion_at, point_motion, motion_free
  use rotorcable_motion_builder, only: motion_from_block
  use rotorcable_parameter_block, only: parameter_block, get_reals
  use rotorcable_supports_type, only: support_type
  use rotorcable_supports_tip_point, only: tip_jacobian, add_tip_wrench, add_tip_wrench_tangent, tip_velocity, &
                                           tip_acceleration, tip_velocity_tangent
  implicit none
  private
  public :: ball_support, new_ball, read_tip_point

  !> Ball B.
  type, extends(support_type) :: ball_support
    real(dp) :: position_ref(3) = 0.0_dp      !< p_B in the reference configuration [m]
    type(rigid_motion) :: motion              !< prescribed motion (no hinges: fixed)
    ! The pose and motion at the last update (relative to the model frame):
    real(dp) :: position(3) = 0.0_dp          !< p_B [m] (blended during a continuation)
    real(dp) :: true_position(3) = 0.0_dp     !< p_B at the last update
    real(dp) :: lin_velocity(3) = 0.0_dp      !< dp_B/dt [m/s]
    real(dp) :: lin_acceleration(3) = 0.0_dp  !< d^2p_B/dt^2 [m/s^2]
  contains
    procedure :: rows
    procedure :: update
    procedure :: residual
    procedure :: jacobian
    procedure :: add_jacobian_transpose_times
    procedure :: velocity => velocity_rows
    procedure :: bias
    procedure :: wrench
    procedure :: residual_tangent
    procedure :: velocity_tangent
    procedure :: add_jacobian_transpose_tangent
    procedure :: wrench_tangent
    procedure :: wrench_jacobian
    procedure :: rows_jacobian
    procedure :: closure
    procedure :: closure_rows
    procedure :: blend_target
    procedure :: reach_target
    procedure :: motion_twist
    procedure :: free
    !> Take the pose and motion at a state of the prescribed motion (update's second half).
    procedure :: follow
  end type ball_support

contains

  !> Build from its parameter block: position and the motion under 'motion.'.
  subroutine new_ball(support, chain, params, error)
    class(support_type), allocatable, intent(out) :: support  !< the support built
    type(chain_type), intent(in) :: chain     !< chain description
    type(parameter_block), intent(in) :: params  !< its parameters
    type(error_type), intent(inout) :: error  !< status
    type(ball_support) :: ball
    call read_tip_point(ball, params, 'ball B', 'ball_b.position', error)
    if (error%code /= 0) return
    allocate (support, source=ball)
  end subroutine new_ball

  !> The point p_B (its reference position and its motion) from a support's parameter block,
  !> and the names messages give the support; clamp B reads its position part here too.
  subroutine read_tip_point(ball, params, label, position_key, error)
    class(ball_support), intent(inout) :: ball   !< ball or clamp being built
    type(parameter_block), intent(in) :: params  !< position, motion.*
    character(len=*), intent(in) :: label     !< name in messages ('ball B')
    character(len=*), intent(in) :: position_key  !< deck key of the position
    type(error_type), intent(inout) :: error  !< status
    call get_reals(params, 'position', ball%position_ref, error)
    call motion_from_block(params, 'motion.', ball%motion, error)
    ball%label = label
    ball%position_key = position_key
    ball%position = ball%position_ref
    ball%true_position = ball%position_ref
  end subroutine read_tip_point

  pure integer function rows(self)
    class(ball_support), intent(in) :: self
    rows = 3
  end function rows

  !> A motion without hinges is the identity state (motion_at), which leaves p_B at its
  !> reference position at rest: one path serves fixed and moving supports alike.
  subroutine update(self, t, rs)
    class(ball_support), intent(inout) :: self
    real(dp), intent(in) :: t
    type(rotor_state), intent(in) :: rs
    call self%follow(motion_at(self%motion, t, rs))
  end subroutine update

  !> p_B, v_B, a_B of the reference point moved by the motion state ms.
  subroutine follow(self, ms)
    class(ball_support), intent(inout) :: self  !< support
    type(motion_state), intent(in) :: ms      !< the prescribed motion's state at the update's time
    call point_motion(ms, self%position_ref, self%position, self%lin_velocity, self%lin_acceleration)
    self%true_position = self%position
  end subroutine follow

  pure subroutine residual(self, chain, st, g)
    class(ball_support), intent(in) :: self
    type(chain_type), intent(in) :: chain
    type(chain_state), intent(in) :: st
    real(dp), intent(out) :: g(:)
    g(1:3) = st%joint_point(:, chain%n_bodies + 1) - self%position
  end subroutine residual

  pure subroutine jacobian(self, chain, st, g_jac)
    class(ball_support), intent(in) :: self
    type(chain_type), intent(in) :: chain
    type(chain_state), intent(in) :: st
    real(dp), intent(out) :: g_jac(:, :)
    call tip_jacobian(chain, st, g_jac)
  end subroutine jacobian

  !> (G^T mu)_k = a_k . ((tip - P_j) x mu).
  pure subroutine add_jacobian_transpose_times(self, chain, st, mu, r)
    class(ball_support), intent(in) :: self
    type(chain_type), intent(in) :: chain
    type(chain_state), intent(in) :: st
    real(dp), intent(in) :: mu(:)
    real(dp), intent(inout) :: r(:)
    call add_tip_wrench(chain, st, mu(1:3), [0.0_dp, 0.0_dp, 0.0_dp], r)
  end subroutine add_jacobian_transpose_times

  pure subroutine velocity_rows(self, chain, st, fs, out)
    class(ball_support), intent(in) :: self
    type(chain_type), intent(in) :: chain
    type(chain_state), intent(in) :: st
    type(frame_state), intent(in) :: fs
    real(dp), intent(out) :: out(:)
    out(1:3) = tip_velocity(chain, st, fs, self%lin_velocity)
  end subroutine velocity_rows

  pure subroutine bias(self, chain, st, fs, out)
    class(ball_support), intent(in) :: self
    type(chain_type), intent(in) :: chain
    type(chain_state), intent(in) :: st
    type(frame_state), intent(in) :: fs
    real(dp), intent(out) :: out(:)
    out(1:3) = tip_acceleration(chain, st, fs, self%lin_acceleration)
  end subroutine bias

  !> The force at the tip is the multiplier; a ball transmits no moment.
  pure subroutine wrench(self, chain, st, lambda, force, moment)
    class(ball_support), intent(in) :: self
    type(chain_type), intent(in) :: chain
    type(chain_state), intent(in) :: st
    real(dp), intent(in) :: lambda(:)
    real(dp), intent(out) :: force(3), moment(3)
    force = lambda(1:3)
    moment = 0.0_dp
  end subroutine wrench

  pure subroutine residual_tangent(self, chain, st, dst, dg)
    class(ball_support), intent(in) :: self
    type(chain_type), intent(in) :: chain
    type(chain_state), intent(in) :: st
    type(chain_tangent), intent(in) :: dst
    real(dp), intent(out) :: dg(:)
    dg(1:3) = dst%djoint_point(:, chain%n_bodies + 1)
  end subroutine residual_tangent

  pure subroutine velocity_tangent(self, chain, st, dst, fs, dout)
    class(ball_support), intent(in) :: self
    type(chain_type), intent(in) :: chain
    type(chain_state), intent(in) :: st
    type(chain_tangent), intent(in) :: dst
    type(frame_state), intent(in) :: fs
    real(dp), intent(out) :: dout(:)
    dout(1:3) = tip_velocity_tangent(chain, dst, fs)
  end subroutine velocity_tangent

  pure subroutine add_jacobian_transpose_tangent(self, chain, st, dst, mu, dmu, dr)
    class(ball_support), intent(in) :: self
    type(chain_type), intent(in) :: chain
    type(chain_state), intent(in) :: st
    type(chain_tangent), intent(in) :: dst
    real(dp), intent(in) :: mu(:), dmu(:)
    real(dp), intent(inout) :: dr(:)
    real(dp) :: zero(3)
    zero = 0.0_dp
    call add_tip_wrench_tangent(chain, st, dst, mu(1:3), dmu(1:3), zero, zero, dr)
  end subroutine add_jacobian_transpose_tangent

  pure subroutine wrench_tangent(self, chain, st, dst, lambda, dlambda, dforce, dmoment)
    class(ball_support), intent(in) :: self
    type(chain_type), intent(in) :: chain
    type(chain_state), intent(in) :: st
    type(chain_tangent), intent(in) :: dst
    real(dp), intent(in) :: lambda(:), dlambda(:)
    real(dp), intent(out) :: dforce(3), dmoment(3)
    dforce = dlambda(1:3)
    dmoment = 0.0_dp
  end subroutine wrench_tangent

  !> A force at the tip, fixed by the multipliers: it does not change with the body.
  pure subroutine wrench_jacobian(self, chain, st, lambda, d_wrench)
    class(ball_support), intent(in) :: self
    type(chain_type), intent(in) :: chain
    type(chain_state), intent(in) :: st
    real(dp), intent(in) :: lambda(:)
    real(dp), intent(out) :: d_wrench(6, 6)
    d_wrench = 0.0_dp
  end subroutine wrench_jacobian

  !> g = P_tip - p_B: dg = dP;  G v + g_t = v_tip - Omega x (P_tip - c) - v_B: d = dv - Omega x dP.
  pure subroutine rows_jacobian(self, chain, st, fs, dg_pose, dgv_pose, dgv_motion)
    class(ball_support), intent(in) :: self
    type(chain_type), intent(in) :: chain
    type(chain_state), intent(in) :: st
    type(frame_state), intent(in) :: fs
    real(dp), intent(out) :: dg_pose(:, :), dgv_pose(:, :), dgv_motion(:, :)
    integer :: i
    dg_pose(1:3, :) = 0.0_dp
    dgv_pose(1:3, :) = 0.0_dp
    dgv_motion(1:3, :) = 0.0_dp
    do i = 1, 3
      dg_pose(i, i) = 1.0_dp
      dgv_motion(i, i) = 1.0_dp
    end do
    if (fs%rotating) dgv_pose(1:3, 1:3) = -skew(fs%omega)
  end subroutine rows_jacobian

  !> The position rows themselves: they have no spurious roots (the clamp's orientation rows do).
  pure subroutine closure(self, chain, st, r, r_jac)
    class(ball_support), intent(in) :: self
    type(chain_type), intent(in) :: chain
    type(chain_state), intent(in) :: st
    real(dp), intent(out) :: r(:)
    real(dp), intent(out) :: r_jac(:, :)
    call residual(self, chain, st, r)
    call jacobian(self, chain, st, r_jac)
  end subroutine closure

  pure integer function closure_rows(self)
    class(ball_support), intent(in) :: self
    closure_rows = 3
  end function closure_rows

  !> Target part of the way from p0 to the point of the last update (the orientation is free).
  subroutine blend_target(self, s, p0, r0)
    class(ball_support), intent(inout) :: self
    real(dp), intent(in) :: s
    real(dp), intent(in) :: p0(3), r0(3, 3)
    self%position = p0 + s*(self%true_position - p0)
    if (s >= 1.0_dp) self%position = self%true_position
  end subroutine blend_target

  !> The free part is the whole chain (less a clamped first body) and must reach p_B.
  pure subroutine reach_target(self, chain, point, held, found)
    class(ball_support), intent(in) :: self
    type(chain_type), intent(in) :: chain
    real(dp), intent(out) :: point(3)
    integer, intent(out) :: held
    logical, intent(out) :: found
    point = self%position
    held = 0
    found = .true.
  end subroutine reach_target

  !> v_B; a ball takes no moment, so its rotation rate does no work (reported as 0).
  pure subroutine motion_twist(self, velocity, omega)
    class(ball_support), intent(in) :: self
    real(dp), intent(out) :: velocity(3), omega(3)
    velocity = self%lin_velocity
    omega = 0.0_dp
  end subroutine motion_twist

  subroutine free(self)
    class(ball_support), intent(inout) :: self
    call motion_free(self%motion)
  end subroutine free

end module rotorcable_supports_ball
