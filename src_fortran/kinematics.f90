!> Recursive chain kinematics, O(n): frames, joint points, centres of mass, joint axes,
!> angular and linear velocities and accelerations, all in the world frame.
!>
!> Recursion (thesis eq. 4.15-4.23, written recursively instead of per body):
!>   R_j = R_{j-1} R_rel(q_j),  P_{j+1} = P_j + R_j (0,0,L_j),  C_j = P_j + R_j (0,0,L_j/2)
!>   w_j = w_{j-1} + sum_k a_k qd_k
!>   alpha_j = alpha_{j-1} + sum_k a_k qdd_k + w_{j-1} x w_rel + joint_bias
!>   acc(P_{j+1}) = acc(P_j) + alpha_j x r + w_j x (w_j x r)          (eq. 3.21)
!> The base (support A) has a pose (R_0, P_1) and an absolute motion (w_0, alpha_0, velocity and
!> acceleration of P_1), the seed of the forward recursion (Featherstone 2008, section 5.3): zero
!> for a clamp fixed in the inertial frame; the hub's rotation and a moving support's motion
!> otherwise (rotorcable_frame).  Velocities and accelerations are absolute, in the coordinates
!> of the model's frame.
module rotorcable_kinematics
  use rotorcable_kinds, only: dp
  use rotorcable_chain, only: chain_type
  use rotorcable_joint, only: joint_rotation, joint_axes, joint_bias, MAX_JOINT_DOF
  use rotorcable_rotations, only: cross
  implicit none
  private
  public :: chain_state, state_allocate, chain_positions, chain_motion, joint_angles, motion_seed

  !> Absolute motion of the base: angular velocity and acceleration of the base frame, velocity
  !> and acceleration of the joint point P_1 (model-frame coordinates).
  type :: motion_seed
    real(dp) :: omega(3) = 0.0_dp
    real(dp) :: alpha(3) = 0.0_dp
    real(dp) :: vel(3) = 0.0_dp
    real(dp) :: acc(3) = 0.0_dp
  end type motion_seed

  !> Kinematic state of every body (world frame).
  type :: chain_state
    real(dp), allocatable :: rot(:, :, :)       !< (3,3,n) world <- body j
    real(dp), allocatable :: joint_point(:, :)  !< (3,n+1) P_j; P_{n+1} is the chain tip
    real(dp), allocatable :: cm(:, :)           !< (3,n) centre of mass C_j
    real(dp), allocatable :: axes(:, :, :)      !< (3,2,n) world axes of joint j's coordinates
    real(dp), allocatable :: omega(:, :)        !< (3,n) angular velocity
    real(dp), allocatable :: alpha(:, :)        !< (3,n) angular acceleration
    real(dp), allocatable :: vel_joint(:, :)    !< (3,n+1) velocity of P_j
    real(dp), allocatable :: acc_joint(:, :)    !< (3,n+1) acceleration of P_j
    real(dp), allocatable :: vel_cm(:, :)       !< (3,n) CM velocity
    real(dp), allocatable :: acc_cm(:, :)       !< (3,n) CM acceleration
    real(dp), allocatable :: joint_force(:, :)  !< (3,n) force of parent (or base) on body j at P_j
    real(dp), allocatable :: joint_moment(:, :) !< (3,n) moment of parent on body j about P_j
  end type chain_state

contains

  !> Allocate the state arrays for a chain.
  pure subroutine state_allocate(chain, st)
    type(chain_type), intent(in) :: chain      !< chain description
    type(chain_state), intent(out) :: st       !< state to allocate
    integer :: n
    n = chain%n_bodies
    allocate (st%rot(3, 3, n), st%joint_point(3, n + 1), st%cm(3, n), st%axes(3, MAX_JOINT_DOF, n))
    allocate (st%omega(3, n), st%alpha(3, n), st%vel_joint(3, n + 1), st%acc_joint(3, n + 1))
    allocate (st%vel_cm(3, n), st%acc_cm(3, n), st%joint_force(3, n), st%joint_moment(3, n))
    st%axes = 0.0_dp
    st%joint_force = 0.0_dp
    st%joint_moment = 0.0_dp
  end subroutine state_allocate

  !> Joint angles of joint j: the coordinates if free, the locked angles otherwise.
  pure function joint_angles(chain, q, j) result(angles)
    type(chain_type), intent(in) :: chain      !< chain description
    real(dp), intent(in) :: q(:)               !< generalized coordinates [rad]
    integer, intent(in) :: j                   !< joint index
    real(dp) :: angles(MAX_JOINT_DOF)
    angles = 0.0_dp
    if (chain%locked(j)) then
      angles(1:2) = chain%locked_angles(:, j)
    else
      angles(1:chain%n_joint_coords(j)) = q(chain%first_coord(j):chain%first_coord(j) + chain%n_joint_coords(j) - 1)
    end if
  end function joint_angles

  !> Frames, joint points, CMs and joint axes for coordinates q.
  pure subroutine chain_positions(chain, base_rotation, base_position, q, st)
    type(chain_type), intent(in) :: chain      !< chain description
    real(dp), intent(in) :: base_rotation(3, 3)  !< base frame R_0 (model <- base)
    real(dp), intent(in) :: base_position(3)   !< joint point P_1 [m]
    real(dp), intent(in) :: q(:)               !< generalized coordinates [rad]
    type(chain_state), intent(inout) :: st     !< state (positions filled)
    ! Explicit-shape locals let the compiler inline the 3x3 products (no library matmul).
    real(dp) :: r_parent(3, 3), r_rel(3, 3), r_child(3, 3), angles(MAX_JOINT_DOF)
    integer :: j, nd

    r_parent = base_rotation
    st%joint_point(:, 1) = base_position
    do j = 1, chain%n_bodies
      angles = joint_angles(chain, q, j)
      r_rel = joint_rotation(chain%joint_kind(j), angles)
      r_child = matmul(r_parent, r_rel)
      st%rot(:, :, j) = r_child
      nd = chain%n_joint_coords(j)
      if (nd > 0) call joint_axes(chain%joint_kind(j), angles, r_parent, r_child, st%axes(:, 1:nd, j))
      st%cm(:, j) = st%joint_point(:, j) + 0.5_dp*chain%length(j)*r_child(:, 3)
      st%joint_point(:, j + 1) = st%joint_point(:, j) + chain%length(j)*r_child(:, 3)
      r_parent = r_child
    end do
  end subroutine chain_positions

  !> Velocities and accelerations for rates qd and accelerations qdd (positions must be current).
  pure subroutine chain_motion(chain, seed, qd, qdd, st)
    type(chain_type), intent(in) :: chain      !< chain description
    type(motion_seed), intent(in) :: seed      !< absolute motion of the base
    real(dp), intent(in) :: qd(:)              !< coordinate rates [rad/s]
    real(dp), intent(in) :: qdd(:)             !< coordinate accelerations [rad/s^2]
    type(chain_state), intent(inout) :: st     !< state (motion filled)
    real(dp) :: w_parent(3), a_parent(3), w_rel(3), r(3), dv(3), da(3)
    integer :: j, k, i0, nd

    w_parent = seed%omega
    a_parent = seed%alpha
    st%vel_joint(:, 1) = seed%vel
    st%acc_joint(:, 1) = seed%acc
    do j = 1, chain%n_bodies
      st%omega(:, j) = w_parent
      st%alpha(:, j) = a_parent
      nd = chain%n_joint_coords(j)
      if (nd > 0) then
        i0 = chain%first_coord(j) - 1
        w_rel = 0.0_dp
        do k = 1, nd
          w_rel = w_rel + st%axes(:, k, j)*qd(i0 + k)
          st%alpha(:, j) = st%alpha(:, j) + st%axes(:, k, j)*qdd(i0 + k)
        end do
        st%omega(:, j) = st%omega(:, j) + w_rel
        st%alpha(:, j) = st%alpha(:, j) + cross(w_parent, w_rel) &
                         + joint_bias(chain%joint_kind(j), st%axes(:, 1:nd, j), qd(i0 + 1:i0 + nd))
      end if
      ! Rigid-body transport of velocity and acceleration along the body (eq. 3.14, 3.21)
      ! to the next joint; the CM lies halfway (eq. 4.3), so its terms are the halves.
      r = st%joint_point(:, j + 1) - st%joint_point(:, j)
      dv = cross(st%omega(:, j), r)
      da = cross(st%alpha(:, j), r) + cross(st%omega(:, j), dv)
      st%vel_cm(:, j) = st%vel_joint(:, j) + 0.5_dp*dv
      st%acc_cm(:, j) = st%acc_joint(:, j) + 0.5_dp*da
      st%vel_joint(:, j + 1) = st%vel_joint(:, j) + dv
      st%acc_joint(:, j + 1) = st%acc_joint(:, j) + da
      w_parent = st%omega(:, j)
      a_parent = st%alpha(:, j)
    end do
  end subroutine chain_motion

end module rotorcable_kinematics
