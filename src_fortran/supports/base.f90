!> Support A: the locked base of the chain.  It fixes the joint point P_1 and the base frame
!> R_0 (joint 1 turns relative to it; a clamped first body is a locked joint 1), and it may move
!> rigidly with the blade (a prescribed rigid motion, rotorcable_motion_rigid_motion).  It has
!> no constraint rows: its reaction is the Newton-Euler backward pass's wrench on body 1.
!> Its pose and motion relative to the model frame, composed with the frame's own rotation,
!> seed the chain's forward recursion (rotorcable_kinematics, motion_seed).
module rotorcable_supports_base
  use rotorcable_kinds, only: dp
  use rotorcable_rotations, only: cross, identity3
  use rotorcable_kinematics, only: motion_seed
  use rotorcable_frame, only: frame_state
  use rotorcable_motion_rotor, only: rotor_state
  use rotorcable_motion_rigid_motion, only: rigid_motion, motion_state, motion_at, point_motion, motion_free
  implicit none
  private
  public :: base_support, base_pose, base_free

  !> Support A.
  type :: base_support
    real(dp) :: position(3) = 0.0_dp          !< P_1 in the reference configuration [m]
    real(dp) :: rotation(3, 3) = reshape([1.0_dp, 0.0_dp, 0.0_dp, 0.0_dp, 1.0_dp, 0.0_dp, 0.0_dp, 0.0_dp, &
                                          1.0_dp], [3, 3])  !< R_0 in the reference configuration
    logical :: moving = .false.               !< prescribed motion present
    type(rigid_motion) :: motion              !< prescribed motion (moving only)
  end type base_support

contains

  !> Pose of the base at time t and the seed of the forward recursion.
  subroutine base_pose(base, t, rs, fs, rotation, position, seed, velocity_rel, omega_rel)
    type(base_support), intent(in) :: base    !< support A
    real(dp), intent(in) :: t                 !< time [s]
    type(rotor_state), intent(in) :: rs       !< rotor state
    type(frame_state), intent(in) :: fs       !< the model frame's motion
    real(dp), intent(out) :: rotation(3, 3)   !< R_0(t)
    real(dp), intent(out) :: position(3)      !< P_1(t) [m]
    type(motion_seed), intent(out) :: seed    !< absolute motion of the base
    real(dp), intent(out), optional :: velocity_rel(3)  !< velocity of P_1 relative to the frame [m/s]
    real(dp), intent(out), optional :: omega_rel(3)     !< angular velocity relative to the frame [rad/s]
    type(motion_state) :: ms
    real(dp) :: v_rel(3), a_rel(3), w_rel(3), al_rel(3), r(3)
    rotation = base%rotation
    position = base%position
    v_rel = 0.0_dp; a_rel = 0.0_dp; w_rel = 0.0_dp; al_rel = 0.0_dp
    if (base%moving) then
      ms = motion_at(base%motion, t, rs)
      call point_motion(ms, base%position, position, v_rel, a_rel)
      rotation = matmul(ms%rot, base%rotation)
      w_rel = ms%omega
      al_rel = ms%omega_dot
    end if
    if (present(velocity_rel)) velocity_rel = v_rel
    if (present(omega_rel)) omega_rel = w_rel
    seed%omega = w_rel
    seed%alpha = al_rel
    seed%vel = v_rel
    seed%acc = a_rel
    if (fs%rotating) then
      ! Absolute motion = frame motion composed with the motion relative to the frame.
      r = position - fs%centre
      seed%omega = fs%omega + w_rel
      seed%alpha = fs%omega_dot + al_rel + cross(fs%omega, w_rel)
      seed%vel = v_rel + cross(fs%omega, r)
      seed%acc = a_rel + 2.0_dp*cross(fs%omega, v_rel) + cross(fs%omega_dot, r) + &
                 cross(fs%omega, cross(fs%omega, r))
    end if
  end subroutine base_pose

  !> Release the motion's table splines.
  subroutine base_free(base)
    type(base_support), intent(inout) :: base !< support A
    call motion_free(base%motion)
  end subroutine base_free

end module rotorcable_supports_base
