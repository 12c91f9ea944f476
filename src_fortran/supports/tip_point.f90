!> The rows a support at the chain's far end writes for holding the tip P_{n+1} at a point
!> p_B(t), shared by every such support (clamp B's position rows, ball B's only rows), and the
!> generalized force of a wrench at the tip, with their first-order changes (the analytic
!> Jacobian).  Per coordinate k of joint j (axis a_k through P_j):
!>   dP_{n+1}/dq_k = a_k x (P_{n+1} - P_j),
!>   generalized force of (F at P_{n+1}, M) = a_k . ((P_{n+1} - P_j) x F + M),
!> and the rows' velocity and acceleration are the tip's relative to the model frame less the
!> point's own (rotorcable_frame).
module rotorcable_supports_tip_point
  use rotorcable_kinds, only: dp
  use rotorcable_chain, only: chain_type
  use rotorcable_kinematics, only: chain_state
  use rotorcable_kinematics_tangent, only: chain_tangent
  use rotorcable_frame, only: frame_state, relative_velocity, relative_acceleration
  use rotorcable_rotations, only: cross
  use rotorcable_joint, only: MAX_JOINT_DOF
  implicit none
  private
  public :: tip_jacobian, add_tip_wrench, add_tip_wrench_tangent, tip_velocity, tip_acceleration, &
            tip_velocity_tangent

contains

  !> g_jac(1:3, k) = a_k x (P_{n+1} - P_j) for every coordinate k.
  pure subroutine tip_jacobian(chain, st, g_jac)
    type(chain_type), intent(in) :: chain     !< chain description
    type(chain_state), intent(in) :: st       !< frames and points
    real(dp), intent(inout) :: g_jac(:, :)    !< rows 1:3 are written
    real(dp) :: tip(3), arm(3)
    integer :: j, kk
    tip = st%joint_point(:, chain%n_bodies + 1)
    do j = 1, chain%n_bodies
      arm = tip - st%joint_point(:, j)        ! a local: no heap temporary for cross
      do kk = 1, chain%n_joint_coords(j)
        g_jac(1:3, chain%first_coord(j) + kk - 1) = cross(st%axes(:, kk, j), arm)
      end do
    end do
  end subroutine tip_jacobian

  !> r_k = r_k + a_k . ((P_{n+1} - P_j) x F + M): one 3-vector per body instead of a row per
  !> coordinate (G^T mu of the tip rows with F = mu; M carries a support's moment rows).
  pure subroutine add_tip_wrench(chain, st, force, moment, r)
    type(chain_type), intent(in) :: chain     !< chain description
    type(chain_state), intent(in) :: st       !< frames and points
    real(dp), intent(in) :: force(3)          !< F at the tip
    real(dp), intent(in) :: moment(3)         !< M
    real(dp), intent(inout) :: r(:)           !< (nq) generalized forces to add to
    real(dp) :: tip(3), arm(3), w(3)
    integer :: j, kk
    tip = st%joint_point(:, chain%n_bodies + 1)
    do j = 1, chain%n_bodies
      if (chain%n_joint_coords(j) == 0) cycle
      arm = tip - st%joint_point(:, j)
      w = cross(arm, force) + moment
      do kk = 1, chain%n_joint_coords(j)
        r(chain%first_coord(j) + kk - 1) = r(chain%first_coord(j) + kk - 1) + dot_product(st%axes(:, kk, j), w)
      end do
    end do
  end subroutine add_tip_wrench

  !> d(add_tip_wrench)_k = da_k . w_j + a_k . dw_j,  w_j = (P_{n+1} - P_j) x F + M,
  !> dw_j = d(P_{n+1} - P_j) x F + (P_{n+1} - P_j) x dF + dM.
  pure subroutine add_tip_wrench_tangent(chain, st, dst, force, dforce, moment, dmoment, dr)
    type(chain_type), intent(in) :: chain     !< chain description
    type(chain_state), intent(in) :: st       !< frames and points
    type(chain_tangent), intent(in) :: dst    !< their first-order change
    real(dp), intent(in) :: force(3), dforce(3)    !< F and its change
    real(dp), intent(in) :: moment(3), dmoment(3)  !< M and its change
    real(dp), intent(inout) :: dr(:)          !< (nq) changes to add to
    call tip_wrench_tangent_pass(chain%n_bodies, size(dr), chain%n_joint_coords, chain%first_coord, &
                                 st%joint_point, st%axes, dst%djoint_point, dst%daxes, force, dforce, moment, &
                                 dmoment, dr)
  end subroutine add_tip_wrench_tangent

  !> add_tip_wrench_tangent's loop on explicit-shape arrays: it runs per column (a Jacobian's,
  !> a sensitivity's), and the derived types' allocatable components cost an address from a
  !> descriptor at every access (rotorcable_kinematics_tangent, motion_tangent_pass).
  pure subroutine tip_wrench_tangent_pass(n, nq, n_joint_coords, first_coord, joint_point, axes, djoint_point, &
                                          daxes, force, dforce, moment, dmoment, dr)
    integer, intent(in) :: n, nq
    integer, intent(in) :: n_joint_coords(n), first_coord(n)
    real(dp), intent(in) :: joint_point(3, n + 1), axes(3, MAX_JOINT_DOF, n)
    real(dp), intent(in) :: djoint_point(3, n + 1), daxes(3, MAX_JOINT_DOF, n)
    real(dp), intent(in) :: force(3), dforce(3), moment(3), dmoment(3)
    real(dp), intent(inout) :: dr(nq)
    real(dp) :: tip(3), dtip(3), arm(3), darm(3), w(3), dw(3)
    integer :: j, kk, k
    tip = joint_point(:, n + 1)
    dtip = djoint_point(:, n + 1)
    do j = 1, n
      if (n_joint_coords(j) == 0) cycle
      arm = tip - joint_point(:, j)
      darm = dtip - djoint_point(:, j)
      w = cross(arm, force) + moment
      dw = cross(darm, force) + cross(arm, dforce) + dmoment
      do kk = 1, n_joint_coords(j)
        k = first_coord(j) + kk - 1
        dr(k) = dr(k) + dot_product(daxes(:, kk, j), w) + dot_product(axes(:, kk, j), dw)
      end do
    end do
  end subroutine tip_wrench_tangent_pass

  !> The tip's velocity relative to the model frame less the point's: G v + g_t of the rows.
  pure function tip_velocity(chain, st, fs, point_velocity) result(out)
    type(chain_type), intent(in) :: chain     !< chain description
    type(chain_state), intent(in) :: st       !< frames and velocities
    type(frame_state), intent(in) :: fs       !< the model frame's motion
    real(dp), intent(in) :: point_velocity(3) !< dp_B/dt [m/s]
    real(dp) :: out(3)
    integer :: n
    n = chain%n_bodies
    out = relative_velocity(fs, st%joint_point(:, n + 1), st%vel_joint(:, n + 1)) - point_velocity
  end function tip_velocity

  !> The tip's acceleration at qdd = 0 relative to the model frame less the point's: the bias.
  pure function tip_acceleration(chain, st, fs, point_acceleration) result(out)
    type(chain_type), intent(in) :: chain     !< chain description
    type(chain_state), intent(in) :: st       !< frames, velocities, accelerations at qdd = 0
    type(frame_state), intent(in) :: fs       !< the model frame's motion
    real(dp), intent(in) :: point_acceleration(3)  !< d^2p_B/dt^2 [m/s^2]
    real(dp) :: out(3), tip(3), v_rel(3)
    integer :: n
    n = chain%n_bodies
    tip = st%joint_point(:, n + 1)
    v_rel = relative_velocity(fs, tip, st%vel_joint(:, n + 1))
    out = relative_acceleration(fs, tip, v_rel, st%acc_joint(:, n + 1)) - point_acceleration
  end function tip_acceleration

  !> d(v_tip - Omega x (tip - c)) = dv_tip - Omega x dtip (the point moves with time only).
  pure function tip_velocity_tangent(chain, dst, fs) result(dout)
    type(chain_type), intent(in) :: chain     !< chain description
    type(chain_tangent), intent(in) :: dst    !< first-order change of the chain state
    type(frame_state), intent(in) :: fs       !< the model frame's motion
    real(dp) :: dout(3)
    integer :: n
    n = chain%n_bodies
    dout = dst%dvel_joint(:, n + 1)
    if (fs%rotating) dout = dout - cross(fs%omega, dst%djoint_point(:, n + 1))
  end function tip_velocity_tangent

end module rotorcable_supports_tip_point
