!> Tangent (forward-mode) of the chain kinematics: the first-order change of every frame, point,
!> axis, velocity and acceleration of rotorcable_kinematics for a change (dq, dv, dvdot) of the
!> coordinates, rates and accelerations, O(n) per direction.  With the tangent of the loads, of
!> the supports and of the Newton-Euler pass it gives the analytic Jacobian of the residual, one
!> column per direction (Carpentier and Mansard, "Analytical derivatives of rigid body dynamics
!> algorithms", RSS 2018, derive the same quantities for the RNEA; here the recursion is written
!> in this code's world-frame, joint-point form).
!>
!> Rotations are perturbed on the left, R_j -> (I + [dtheta_j]) R_j, so a body's frame change is
!> one world vector dtheta_j, and a vector fixed in body j changes by dtheta_j x (vector).
!> Recursion (the derivative of rotorcable_kinematics, eq. 4.15-4.23):
!>   dtheta_j = dtheta_{j-1} + sum_k a_k dq_k
!>   da_l     = (dtheta_{j-1} + sum_{k<l} a_k dq_k) x a_l     (axis l is fixed in the frame after
!>              the joint's rotations 1 .. l-1, rotorcable_joint)
!>   dP_{j+1} = dP_j + dtheta_j x r_j,   dC_j = dP_j + dtheta_j x r_j / 2,   r_j = P_{j+1} - P_j
!> and the rates and accelerations by the product rule on chain_motion.  The base (support A)
!> moves with time only: its tangent is zero.
module rotorcable_kinematics_tangent
  use rotorcable_kinds, only: dp
  use rotorcable_chain, only: chain_type
  use rotorcable_kinematics, only: chain_state, motion_seed
  use rotorcable_joint, only: joint_bias_tangent, MAX_JOINT_DOF
  use rotorcable_rotations, only: cross
  implicit none
  private
  public :: chain_tangent, tangent_allocate, positions_tangent, motion_tangent

  !> First-order change of a chain_state (world frame).  Bodies before `first` do not move.
  type :: chain_tangent
    integer :: first = 1                         !< first body with a nonzero tangent
    real(dp), allocatable :: dtheta(:, :)        !< (3,n) rotation of body j's frame [rad]
    real(dp), allocatable :: djoint_point(:, :)  !< (3,n+1) dP_j [m]
    real(dp), allocatable :: dcm(:, :)           !< (3,n) dC_j [m]
    real(dp), allocatable :: daxes(:, :, :)      !< (3,3,n) d a_k of joint j
    real(dp), allocatable :: domega(:, :)        !< (3,n)
    real(dp), allocatable :: dalpha(:, :)        !< (3,n)
    real(dp), allocatable :: dvel_joint(:, :)    !< (3,n+1)
    real(dp), allocatable :: dacc_joint(:, :)    !< (3,n+1)
    real(dp), allocatable :: dvel_cm(:, :)       !< (3,n)
    real(dp), allocatable :: dacc_cm(:, :)       !< (3,n)
  end type chain_tangent

contains

  !> Allocate (zeroed) tangent arrays for a chain.
  pure subroutine tangent_allocate(chain, dst)
    type(chain_type), intent(in) :: chain      !< chain description
    type(chain_tangent), intent(out) :: dst    !< tangent to allocate
    integer :: n
    n = chain%n_bodies
    allocate (dst%dtheta(3, n), dst%djoint_point(3, n + 1), dst%dcm(3, n), dst%daxes(3, MAX_JOINT_DOF, n))
    allocate (dst%domega(3, n), dst%dalpha(3, n), dst%dvel_joint(3, n + 1), dst%dacc_joint(3, n + 1))
    allocate (dst%dvel_cm(3, n), dst%dacc_cm(3, n))
    dst%first = 1
    dst%dtheta = 0.0_dp; dst%djoint_point = 0.0_dp; dst%dcm = 0.0_dp; dst%daxes = 0.0_dp
    dst%domega = 0.0_dp; dst%dalpha = 0.0_dp; dst%dvel_joint = 0.0_dp; dst%dacc_joint = 0.0_dp
    dst%dvel_cm = 0.0_dp; dst%dacc_cm = 0.0_dp
  end subroutine tangent_allocate

  !> Tangent of the frames, joint points, CMs and axes for dq, from body `first` on (dq must
  !> vanish on the joints before it; the tangent there is set to zero).
  pure subroutine positions_tangent(chain, st, dq, first, dst)
    type(chain_type), intent(in) :: chain      !< chain description
    type(chain_state), intent(in) :: st        !< positions at q
    real(dp), intent(in) :: dq(:)              !< coordinate direction
    integer, intent(in) :: first               !< first body whose joint has dq /= 0
    type(chain_tangent), intent(inout) :: dst  !< tangent (positions filled)
    real(dp) :: w(3), a(3), r(3), th(3)
    integer :: j, k, i0, nd
    dst%first = first
    dst%dtheta(:, 1:first - 1) = 0.0_dp
    dst%djoint_point(:, 1:first) = 0.0_dp
    dst%dcm(:, 1:first - 1) = 0.0_dp
    dst%daxes(:, :, 1:first - 1) = 0.0_dp
    w = 0.0_dp                                ! the bodies before `first` do not turn
    do j = first, chain%n_bodies
      nd = chain%n_joint_coords(j)
      i0 = chain%first_coord(j) - 1
      do k = 1, nd
        a = st%axes(:, k, j)
        dst%daxes(:, k, j) = cross(w, a)
        w = w + a*dq(i0 + k)
      end do
      dst%dtheta(:, j) = w
      th = w
      r = st%joint_point(:, j + 1) - st%joint_point(:, j)
      r = cross(th, r)
      dst%dcm(:, j) = dst%djoint_point(:, j) + 0.5_dp*r
      dst%djoint_point(:, j + 1) = dst%djoint_point(:, j) + r
    end do
  end subroutine positions_tangent

  !> Tangent of the velocities and accelerations for (dq, dv, dvdot), positions tangent current
  !> (positions_tangent), from body dst%first on; chain_motion must be current in st.
  pure subroutine motion_tangent(chain, seed, st, qd, qdd, dqd, dqdd, dst)
    type(chain_type), intent(in) :: chain      !< chain description
    type(motion_seed), intent(in) :: seed      !< absolute motion of the base (no tangent)
    type(chain_state), intent(in) :: st        !< positions and motion at (q, qd, qdd)
    real(dp), intent(in) :: qd(:), qdd(:)      !< rates and accelerations
    real(dp), intent(in) :: dqd(:), dqdd(:)    !< their directions
    type(chain_tangent), intent(inout) :: dst  !< tangent (motion filled)
    real(dp) :: w_parent(3), dw_parent(3), da_parent(3), w_rel(3), dw_rel(3), r(3), dr(3), dvr(3), ddvr(3), dda(3)
    real(dp) :: a(3), da(3), dw(3), dal(3), ax(3, MAX_JOINT_DOF), dax(3, MAX_JOINT_DOF), rt(MAX_JOINT_DOF), drt(MAX_JOINT_DOF)
    integer :: j, k, i0, nd, first
    first = dst%first
    dst%domega(:, 1:first - 1) = 0.0_dp
    dst%dalpha(:, 1:first - 1) = 0.0_dp
    dst%dvel_joint(:, 1:first) = 0.0_dp
    dst%dacc_joint(:, 1:first) = 0.0_dp
    dst%dvel_cm(:, 1:first - 1) = 0.0_dp
    dst%dacc_cm(:, 1:first - 1) = 0.0_dp
    dw_parent = 0.0_dp
    da_parent = 0.0_dp
    do j = first, chain%n_bodies
      w_parent = seed%omega
      if (j > 1) then
        w_parent = st%omega(:, j - 1)
        dw_parent = dst%domega(:, j - 1)
        da_parent = dst%dalpha(:, j - 1)
      end if
      nd = chain%n_joint_coords(j)
      dw = dw_parent
      dal = da_parent
      if (nd > 0) then
        i0 = chain%first_coord(j) - 1
        w_rel = 0.0_dp
        dw_rel = 0.0_dp
        ! Fixed-size copies of the joint's axes and rates (joint_bias_tangent's arguments).
        ax = 0.0_dp; dax = 0.0_dp; rt = 0.0_dp; drt = 0.0_dp
        do k = 1, nd
          a = st%axes(:, k, j)
          da = dst%daxes(:, k, j)
          ax(:, k) = a; dax(:, k) = da; rt(k) = qd(i0 + k); drt(k) = dqd(i0 + k)
          w_rel = w_rel + a*qd(i0 + k)
          dw_rel = dw_rel + da*qd(i0 + k) + a*dqd(i0 + k)
          dal = dal + da*qdd(i0 + k) + a*dqdd(i0 + k)
        end do
        dw = dw + dw_rel
        dal = dal + cross(dw_parent, w_rel) + cross(w_parent, dw_rel) &
              + joint_bias_tangent(chain%joint_kind(j), ax, dax, rt, drt)
      end if
      dst%domega(:, j) = dw
      dst%dalpha(:, j) = dal
      ! Rigid-body transport along the body (eq. 3.14, 3.21) and its product rule.
      r = st%joint_point(:, j + 1) - st%joint_point(:, j)
      dr = cross(dst%dtheta(:, j), r)
      dvr = cross(st%omega(:, j), r)
      ddvr = cross(dw, r) + cross(st%omega(:, j), dr)
      dda = cross(dal, r) + cross(st%alpha(:, j), dr) + cross(dw, dvr) + cross(st%omega(:, j), ddvr)
      dst%dvel_cm(:, j) = dst%dvel_joint(:, j) + 0.5_dp*ddvr
      dst%dacc_cm(:, j) = dst%dacc_joint(:, j) + 0.5_dp*dda
      dst%dvel_joint(:, j + 1) = dst%dvel_joint(:, j) + ddvr
      dst%dacc_joint(:, j + 1) = dst%dacc_joint(:, j) + dda
    end do
  end subroutine motion_tangent

end module rotorcable_kinematics_tangent
