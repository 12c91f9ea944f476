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
    dst%first = first
    call positions_tangent_pass(chain%n_bodies, size(dq), first, chain%n_joint_coords, chain%first_coord, &
                                st%joint_point, st%axes, dq, dst%dtheta, dst%djoint_point, dst%dcm, dst%daxes)
  end subroutine positions_tangent

  !> positions_tangent's recursion on explicit-shape arrays (why: motion_tangent_pass).
  pure subroutine positions_tangent_pass(n, nq, first, n_joint_coords, first_coord, joint_point, axes, dq, &
                                         dtheta, djoint_point, dcm, daxes)
    integer, intent(in) :: n, nq, first
    integer, intent(in) :: n_joint_coords(n), first_coord(n)
    real(dp), intent(in) :: joint_point(3, n + 1), axes(3, MAX_JOINT_DOF, n), dq(nq)
    real(dp), intent(inout) :: dtheta(3, n), djoint_point(3, n + 1), dcm(3, n), daxes(3, MAX_JOINT_DOF, n)
    real(dp) :: w(3), a(3), r(3), th(3)
    integer :: j, k, i0, nd
    dtheta(:, 1:first - 1) = 0.0_dp
    djoint_point(:, 1:first) = 0.0_dp
    dcm(:, 1:first - 1) = 0.0_dp
    daxes(:, :, 1:first - 1) = 0.0_dp
    w = 0.0_dp                                ! the bodies before `first` do not turn
    do j = first, n
      nd = n_joint_coords(j)
      i0 = first_coord(j) - 1
      do k = 1, nd
        a = axes(:, k, j)
        daxes(:, k, j) = cross(w, a)
        w = w + a*dq(i0 + k)
      end do
      dtheta(:, j) = w
      th = w
      r = joint_point(:, j + 1) - joint_point(:, j)
      r = cross(th, r)
      dcm(:, j) = djoint_point(:, j) + 0.5_dp*r
      djoint_point(:, j + 1) = djoint_point(:, j) + r
    end do
  end subroutine positions_tangent_pass

  !> Tangent of the velocities and accelerations for (dq, dv, dvdot), positions tangent current
  !> (positions_tangent), from body dst%first on; chain_motion must be current in st.
  pure subroutine motion_tangent(chain, seed, st, qd, qdd, dqd, dqdd, dst)
    type(chain_type), intent(in) :: chain      !< chain description
    type(motion_seed), intent(in) :: seed      !< absolute motion of the base (no tangent)
    type(chain_state), intent(in) :: st        !< positions and motion at (q, qd, qdd)
    real(dp), intent(in) :: qd(:), qdd(:)      !< rates and accelerations
    real(dp), intent(in) :: dqd(:), dqdd(:)    !< their directions
    type(chain_tangent), intent(inout) :: dst  !< tangent (motion filled)
    call motion_tangent_pass(chain%n_bodies, size(qd), dst%first, chain%n_joint_coords, chain%first_coord, &
                             chain%joint_kind, seed%omega, st%omega, st%alpha, st%joint_point, st%axes, qd, qdd, &
                             dqd, dqdd, dst%dtheta, dst%daxes, dst%domega, dst%dalpha, dst%dvel_joint, &
                             dst%dacc_joint, dst%dvel_cm, dst%dacc_cm)
  end subroutine motion_tangent

  !> motion_tangent's recursion on explicit-shape arrays.  Why a second routine: the tangent
  !> runs once per body and column (a Jacobian's 44 columns, 8 parameters x 2 corrector
  !> iterations a step), and through the derived types' allocatable components every access
  !> re-derives its address from a descriptor; here the arrays are plain contiguous dummies and
  !> the joint's axes are read in place.  The arithmetic is the same, in the same order.
  pure subroutine motion_tangent_pass(n, nq, first, n_joint_coords, first_coord, joint_kind, seed_omega, &
                                      omega, alpha, joint_point, axes, qd, qdd, dqd, dqdd, dtheta, daxes, &
                                      domega, dalpha, dvel_joint, dacc_joint, dvel_cm, dacc_cm)
    integer, intent(in) :: n, nq, first
    integer, intent(in) :: n_joint_coords(n), first_coord(n), joint_kind(n)
    real(dp), intent(in) :: seed_omega(3), omega(3, n), alpha(3, n), joint_point(3, n + 1)
    real(dp), intent(in) :: axes(3, MAX_JOINT_DOF, n), qd(nq), qdd(nq), dqd(nq), dqdd(nq)
    real(dp), intent(in) :: dtheta(3, n), daxes(3, MAX_JOINT_DOF, n)
    real(dp), intent(inout) :: domega(3, n), dalpha(3, n), dvel_joint(3, n + 1), dacc_joint(3, n + 1)
    real(dp), intent(inout) :: dvel_cm(3, n), dacc_cm(3, n)
    real(dp) :: w_parent(3), dw_parent(3), da_parent(3), w_rel(3), dw_rel(3), r(3), dr(3), dvr(3), ddvr(3), dda(3)
    real(dp) :: a(3), da(3), dw(3), dal(3), rt(MAX_JOINT_DOF), drt(MAX_JOINT_DOF)
    integer :: j, k, i0, nd
    domega(:, 1:first - 1) = 0.0_dp
    dalpha(:, 1:first - 1) = 0.0_dp
    dvel_joint(:, 1:first) = 0.0_dp
    dacc_joint(:, 1:first) = 0.0_dp
    dvel_cm(:, 1:first - 1) = 0.0_dp
    dacc_cm(:, 1:first - 1) = 0.0_dp
    dw_parent = 0.0_dp
    da_parent = 0.0_dp
    do j = first, n
      w_parent = seed_omega
      if (j > 1) then
        w_parent = omega(:, j - 1)
        dw_parent = domega(:, j - 1)
        da_parent = dalpha(:, j - 1)
      end if
      nd = n_joint_coords(j)
      dw = dw_parent
      dal = da_parent
      if (nd > 0) then
        i0 = first_coord(j) - 1
        w_rel = 0.0_dp
        dw_rel = 0.0_dp
        ! The rates as joint_bias_tangent's fixed-size arguments; the axes are read in place
        ! (a joint reads only its first nd columns: nd is 0 or its parametrisation's count).
        rt = 0.0_dp; drt = 0.0_dp
        do k = 1, nd
          a = axes(:, k, j)
          da = daxes(:, k, j)
          rt(k) = qd(i0 + k); drt(k) = dqd(i0 + k)
          w_rel = w_rel + a*qd(i0 + k)
          dw_rel = dw_rel + da*qd(i0 + k) + a*dqd(i0 + k)
          dal = dal + da*qdd(i0 + k) + a*dqdd(i0 + k)
        end do
        dw = dw + dw_rel
        dal = dal + cross(dw_parent, w_rel) + cross(w_parent, dw_rel) &
              + joint_bias_tangent(joint_kind(j), axes(:, :, j), daxes(:, :, j), rt, drt)
      end if
      domega(:, j) = dw
      dalpha(:, j) = dal
      ! Rigid-body transport along the body (eq. 3.14, 3.21) and its product rule.
      r = joint_point(:, j + 1) - joint_point(:, j)
      dr = cross(dtheta(:, j), r)
      dvr = cross(omega(:, j), r)
      ddvr = cross(dw, r) + cross(omega(:, j), dr)
      dda = cross(dal, r) + cross(alpha(:, j), dr) + cross(dw, dvr) + cross(omega(:, j), ddvr)
      dvel_cm(:, j) = dvel_joint(:, j) + 0.5_dp*ddvr
      dacc_cm(:, j) = dacc_joint(:, j) + 0.5_dp*dda
      dvel_joint(:, j + 1) = dvel_joint(:, j) + ddvr
      dacc_joint(:, j + 1) = dacc_joint(:, j) + dda
    end do
  end subroutine motion_tangent_pass

end module rotorcable_kinematics_tangent
