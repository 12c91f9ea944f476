!> Closure constraint of the far clamp B (eq. 4.92-4.109, extended to orientation).
!>
!> The clamp holds the tip point P_{n+1} at p_B (3 rows, eq. 4.94) and the last body's
!> full orientation R_n at R_B, twist included (3 rows).  The orientation rows use
!> E = R_n R_B^T and g_rot = vee(E - E^T)/2, which vanishes exactly when E = I and whose
!> rate is g_rot' = T w_n with T = (tr(E) I - E)/2 (T = I on the constraint manifold).
!> Hence G = [a_k x (P_{n+1} - p_k); T a_k] per coordinate k, and the multipliers map to
!> the clamp wrench on the chain as F_B = lambda_pos, M_B = T^T lambda_rot (eq. 3.50:
!> G^T lambda is the generalized force of that wrench).
module rotorcable_constraints
  use rotorcable_kinds, only: dp
  use rotorcable_chain, only: chain_type
  use rotorcable_kinematics, only: chain_state
  use rotorcable_rotations, only: cross, skew, vee, identity3
  implicit none
  private
  public :: clamp_type, clamp_rows, clamp_residual, clamp_jacobian, clamp_bias, clamp_velocity, clamp_wrench, &
            add_jacobian_transpose_times, &
            clamp_closure

  !> Far clamp B.
  type :: clamp_type
    logical :: active = .false.               !< clamp present (6 constraint rows) or free end
    real(dp) :: position(3) = 0.0_dp          !< clamp point p_B [m]
    real(dp) :: rotation(3, 3) = 0.0_dp       !< clamped orientation R_B of the last body
  end type clamp_type

contains

  !> Number of constraint rows.
  pure integer function clamp_rows(clamp)
    type(clamp_type), intent(in) :: clamp     !< clamp
    clamp_rows = merge(6, 0, clamp%active)
  end function clamp_rows

  pure function orientation_error(clamp, st) result(e)
    type(clamp_type), intent(in) :: clamp
    type(chain_state), intent(in) :: st
    real(dp) :: e(3, 3)
    e = matmul(st%rot(:, :, size(st%rot, 3)), transpose(clamp%rotation))
  end function orientation_error

  pure function rate_map(e) result(t)
    real(dp), intent(in) :: e(3, 3)
    real(dp) :: t(3, 3)
    t = 0.5_dp*((e(1, 1) + e(2, 2) + e(3, 3))*identity3() - e)
  end function rate_map

  !> Constraint residual g(q), eq. 4.94 plus orientation rows.
  pure function clamp_residual(clamp, st) result(g)
    type(clamp_type), intent(in) :: clamp     !< clamp
    type(chain_state), intent(in) :: st       !< state with current positions
    real(dp) :: g(6)
    real(dp) :: e(3, 3)
    g(1:3) = st%joint_point(:, size(st%joint_point, 2)) - clamp%position
    e = orientation_error(clamp, st)
    g(4:6) = 0.5_dp*vee(e - transpose(e))
  end function clamp_residual

  !> Constraint Jacobian G = dg/dq, eq. 4.95-4.102.
  pure subroutine clamp_jacobian(chain, clamp, st, g_jac)
    type(chain_type), intent(in) :: chain     !< chain description
    type(clamp_type), intent(in) :: clamp     !< clamp
    type(chain_state), intent(in) :: st       !< state with current positions
    real(dp), intent(out) :: g_jac(:, :)      !< (6,nq)
    real(dp) :: t(3, 3), tip(3), arm(3)
    integer :: j, kk, k
    t = rate_map(orientation_error(clamp, st))
    tip = st%joint_point(:, chain%n_bodies + 1)
    do j = 1, chain%n_bodies
      arm = tip - st%joint_point(:, j)        ! a local: no heap temporary for cross
      do kk = 1, chain%n_joint_coords(j)
        k = chain%first_coord(j) + kk - 1
        g_jac(1:3, k) = cross(st%axes(:, kk, j), arm)
        g_jac(4:6, k) = matmul(t, st%axes(:, kk, j))
      end do
    end do
  end subroutine clamp_jacobian

  !> r = r + G^T mu without forming G: column k of G is (a_k x (tip - P_j), T a_k) for the
  !> axis a_k of coordinate k at joint j, so (G^T mu)_k = a_k . ((tip - P_j) x mu_t + T^T mu_r)
  !> (the same rows as clamp_jacobian, one 3-vector per body instead of 6 per coordinate).
  pure subroutine add_jacobian_transpose_times(chain, clamp, st, mu, r)
    type(chain_type), intent(in) :: chain     !< chain description
    type(clamp_type), intent(in) :: clamp     !< clamp
    type(chain_state), intent(in) :: st       !< state with current positions
    real(dp), intent(in) :: mu(6)             !< (translation, rotation) multipliers
    real(dp), intent(inout) :: r(:)           !< (nq) vector to add to
    real(dp) :: t_mu(3), tip(3), arm(3), w(3)
    integer :: j, kk
    t_mu = matmul(mu(4:6), rate_map(orientation_error(clamp, st)))     ! T^T mu_r
    tip = st%joint_point(:, chain%n_bodies + 1)
    do j = 1, chain%n_bodies
      if (chain%n_joint_coords(j) == 0) cycle
      arm = tip - st%joint_point(:, j)
      w = cross(arm, mu(1:3)) + t_mu
      do kk = 1, chain%n_joint_coords(j)
        r(chain%first_coord(j) + kk - 1) = r(chain%first_coord(j) + kk - 1) + dot_product(st%axes(:, kk, j), w)
      end do
    end do
  end subroutine add_jacobian_transpose_times

  !> Constraint velocity G qd = (tip velocity, T w_n); needs chain_motion.
  pure function clamp_velocity(clamp, st) result(gv)
    type(clamp_type), intent(in) :: clamp     !< clamp
    type(chain_state), intent(in) :: st       !< state with velocities
    real(dp) :: gv(6)
    integer :: n
    n = size(st%omega, 2)
    gv(1:3) = st%vel_joint(:, n + 1)
    gv(4:6) = matmul(rate_map(orientation_error(clamp, st)), st%omega(:, n))
  end function clamp_velocity

  !> Bias term  Gdot qd  (eq. 4.103-4.109): the constraint acceleration when qdd = 0.
  !> Needs chain_motion evaluated with qdd = 0.
  pure function clamp_bias(clamp, st) result(gb)
    type(clamp_type), intent(in) :: clamp     !< clamp
    type(chain_state), intent(in) :: st       !< state with velocities, accelerations at qdd = 0
    real(dp) :: gb(6)
    real(dp) :: e(3, 3), edot(3, 3), w(3)
    integer :: n
    n = size(st%omega, 2)
    w = st%omega(:, n)
    e = orientation_error(clamp, st)
    edot = matmul(skew(w), e)
    gb(1:3) = st%acc_joint(:, n + 1)
    gb(4:6) = matmul(rate_map(edot), w) + matmul(rate_map(e), st%alpha(:, n))
  end function clamp_bias

  !> Wrench of clamp B on the chain from the multipliers: F_B at the tip, moment M_B.
  pure subroutine clamp_wrench(clamp, st, lambda, force, moment)
    type(clamp_type), intent(in) :: clamp     !< clamp
    type(chain_state), intent(in) :: st       !< state with current positions
    real(dp), intent(in) :: lambda(6)         !< multipliers
    real(dp), intent(out) :: force(3)         !< force on the chain [N]
    real(dp), intent(out) :: moment(3)        !< moment on the chain [Nm]
    force = lambda(1:3)
    moment = matmul(lambda(4:6), rate_map(orientation_error(clamp, st)))   ! T^T lambda_rot
  end subroutine clamp_wrench

  !> Closure residual without spurious roots, for driving a far start onto the clamp:
  !> (tip - p_B, E - I) with 3 + 9 rows and its Jacobian (dE/dq_k = skew(a_k) E).
  !> g_rot = vee(E - E^T)/2 also vanishes at a half-turn error (E = 2uu^T - I, where T has
  !> rank 1), so a Gauss-Newton closure on g alone can stop at a flipped end orientation;
  !> E - I vanishes only at E = I.
  pure subroutine clamp_closure(chain, clamp, st, r, r_jac)
    type(chain_type), intent(in) :: chain     !< chain description
    type(clamp_type), intent(in) :: clamp     !< clamp
    type(chain_state), intent(in) :: st       !< state with current positions
    real(dp), intent(out) :: r(12)            !< residual
    real(dp), intent(out) :: r_jac(:, :)      !< (12,nq)
    real(dp) :: e(3, 3), de(3, 3), tip(3)
    integer :: j, kk, k
    e = orientation_error(clamp, st)
    tip = st%joint_point(:, chain%n_bodies + 1)
    r(1:3) = tip - clamp%position
    r(4:12) = reshape(e - identity3(), [9])
    do j = 1, chain%n_bodies
      do kk = 1, chain%n_joint_coords(j)
        k = chain%first_coord(j) + kk - 1
        r_jac(1:3, k) = cross(st%axes(:, kk, j), tip - st%joint_point(:, j))
        de = matmul(skew(st%axes(:, kk, j)), e)
        r_jac(4:12, k) = reshape(de, [9])
      end do
    end do
  end subroutine clamp_closure

end module rotorcable_constraints
