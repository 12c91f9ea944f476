!> Clamp B: six constraint rows holding the tip P_{n+1} at p_B(t) and the last body's full
!> orientation, twist included, at R_B(t) (eq. 4.92-4.109, extended to orientation and to a
!> moving, rheonomic clamp).  The clamp pose is a reference pose (p_B0, R_B0) moved by a
!> prescribed rigid motion (the blade's flap, lag and pitch; rotorcable_motion_rigid_motion),
!> or fixed.
!>
!> Rows: g_pos = P_{n+1} - p_B; with E = R_n R_B^T, g_rot = vee(E - E^T)/2, which vanishes
!> exactly when E = I near the solution.  With Edot = [w_n] E - E [w_B] (w relative to the
!> model frame):  g_rot-dot = T w_n - T^T w_B,  T = (tr(E) I - E)/2  (T = I on g = 0), so
!>   G = [a_k x (P_{n+1} - p_k); T a_k] per coordinate k,
!>   G v + g_t = (v_tip - v_B;  T w_n - T^T w_B),
!>   d^2g/dt^2 at qdd = 0 = (a_tip - a_B;  Tdot w_n + T alpha_n - Tdot^T w_B - T^T alpha_B),
!> with tip velocity/acceleration and w_n, alpha_n relative to the model frame
!> (rotorcable_frame) and Tdot = (tr(Edot) I - Edot)/2.  The multipliers are the clamp wrench on
!> the chain: F_B = lambda_pos, M_B = T^T lambda_rot (eq. 3.50: G^T lambda is the generalized
!> force of that wrench).
!> Parameters: position(3) [m], rotation(9) (R_B0 column by column), and its motion under
!> 'motion.' (rotorcable_motion_builder).
!>
!> A clamp is ball B plus orientation rows, so clamp_support extends ball_support: the ball's
!> procedures write the position rows 1:3 (and p_B's pose, motion and parameters), and each
!> procedure here adds rows 4:6.  add_jacobian_transpose_times and its tangent are the clamp's
!> own: they pass the force and the clamp's moment to the tip wrench together, one sweep over
!> the bodies, where the ball's force-only sweep plus a moment sweep would be two.
module rotorcable_supports_clamp
  use rotorcable_kinds, only: dp
  use rotorcable_errors, only: error_type
  use rotorcable_chain, only: chain_type
  use rotorcable_kinematics, only: chain_state
  use rotorcable_kinematics_tangent, only: chain_tangent
  use rotorcable_frame, only: frame_state, relative_velocity, relative_acceleration
  use rotorcable_rotations, only: cross, skew, vee, identity3, rotation_log, rotation_exp
  use rotorcable_motion_rigid_motion, only: motion_state
  use rotorcable_parameter_block, only: parameter_block, get_reals
  use rotorcable_supports_type, only: support_type
  use rotorcable_supports_ball, only: ball_support, read_tip_point
  use rotorcable_supports_tip_point, only: add_tip_wrench, add_tip_wrench_tangent
  implicit none
  private
  public :: clamp_support, new_clamp

  !> Clamp B: ball B's point p_B (position_ref, motion, position, lin_velocity, ...) and R_B.
  type, extends(ball_support) :: clamp_support
    real(dp) :: rotation_ref(3, 3) = 0.0_dp   !< R_B in the reference configuration
    ! The orientation at the time of the last update (relative to the model frame):
    real(dp) :: rotation(3, 3) = 0.0_dp       !< R_B (blended during a continuation)
    real(dp) :: omega(3) = 0.0_dp             !< w_B [rad/s]
    real(dp) :: alpha(3) = 0.0_dp             !< dw_B/dt [rad/s^2]
    real(dp) :: true_rotation(3, 3) = 0.0_dp  !< R_B at the last update
    ! E and T at the state of the last linearise, which the tangents there read: a state's
    ! columns (8 parameters x 2 corrector iterations, a Jacobian's 44) and each column's four
    ! tangent procedures share them instead of forming E = R_n R_B^T nine times a column.
    real(dp) :: e_lin(3, 3) = 0.0_dp          !< E
    real(dp) :: t_lin(3, 3) = 0.0_dp          !< T = rate_map(E)
  contains
    procedure :: linearise
    procedure :: rows
    procedure :: follow
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
  end type clamp_support

contains

  !> A clamp at the reference pose (position, rotation), moved by its motion if it has hinges.
  subroutine new_clamp(support, chain, params, error)
    class(support_type), allocatable, intent(out) :: support  !< the support built
    type(chain_type), intent(in) :: chain     !< chain description
    type(parameter_block), intent(in) :: params  !< position, rotation, motion.*
    type(error_type), intent(inout) :: error  !< status
    type(clamp_support) :: clamp
    real(dp) :: rotation(9)
    call read_tip_point(clamp, params, 'clamp B', 'clamp_b.position', error)
    call get_reals(params, 'rotation', rotation, error)
    if (error%code /= 0) return
    clamp%rotation_ref = reshape(rotation, [3, 3])
    clamp%rotation = clamp%rotation_ref
    clamp%true_rotation = clamp%rotation_ref
    allocate (support, source=clamp)
  end subroutine new_clamp

  pure integer function rows(self)
    class(clamp_support), intent(in) :: self
    rows = 6
  end function rows

  !> The ball's p_B, v_B, a_B, and R_B, w_B, dw_B/dt of the same motion state.
  subroutine follow(self, ms)
    class(clamp_support), intent(inout) :: self  !< support
    type(motion_state), intent(in) :: ms      !< the prescribed motion's state at the update's time
    call self%ball_support%follow(ms)
    self%rotation = matmul(ms%rot, self%rotation_ref)
    self%omega = ms%omega
    self%alpha = ms%omega_dot
    self%true_rotation = self%rotation
  end subroutine follow

  !> E and T at the state of st, for the tangents there.
  subroutine linearise(self, chain, st)
    class(clamp_support), intent(inout) :: self
    type(chain_type), intent(in) :: chain
    type(chain_state), intent(in) :: st
    self%e_lin = orientation_error(self, st)
    self%t_lin = rate_map(self%e_lin)
  end subroutine linearise

  pure function orientation_error(self, st) result(e)
    class(clamp_support), intent(in) :: self
    type(chain_state), intent(in) :: st
    real(dp) :: e(3, 3)
    e = matmul(st%rot(:, :, size(st%rot, 3)), transpose(self%rotation))
  end function orientation_error

  pure function rate_map(e) result(t)
    real(dp), intent(in) :: e(3, 3)
    real(dp) :: t(3, 3)
    t = 0.5_dp*((e(1, 1) + e(2, 2) + e(3, 3))*identity3() - e)
  end function rate_map

  pure subroutine residual(self, chain, st, g)
    class(clamp_support), intent(in) :: self
    type(chain_type), intent(in) :: chain
    type(chain_state), intent(in) :: st
    real(dp), intent(out) :: g(:)
    real(dp) :: e(3, 3)
    call self%ball_support%residual(chain, st, g)
    e = orientation_error(self, st)
    g(4:6) = 0.5_dp*vee(e - transpose(e))
  end subroutine residual

  pure subroutine jacobian(self, chain, st, g_jac)
    class(clamp_support), intent(in) :: self
    type(chain_type), intent(in) :: chain
    type(chain_state), intent(in) :: st
    real(dp), intent(out) :: g_jac(:, :)
    real(dp) :: t(3, 3)
    integer :: j, kk
    call self%ball_support%jacobian(chain, st, g_jac)
    t = rate_map(orientation_error(self, st))
    do j = 1, chain%n_bodies
      do kk = 1, chain%n_joint_coords(j)
        g_jac(4:6, chain%first_coord(j) + kk - 1) = matmul(t, st%axes(:, kk, j))
      end do
    end do
  end subroutine jacobian

  !> (G^T mu)_k = a_k . ((tip - P_j) x mu_t + T^T mu_r): the generalized force of the wrench
  !> (mu_t at the tip, T^T mu_r).
  pure subroutine add_jacobian_transpose_times(self, chain, st, mu, r)
    class(clamp_support), intent(in) :: self
    type(chain_type), intent(in) :: chain
    type(chain_state), intent(in) :: st
    real(dp), intent(in) :: mu(:)
    real(dp), intent(inout) :: r(:)
    call add_tip_wrench(chain, st, mu(1:3), matmul(mu(4:6), rate_map(orientation_error(self, st))), r)
  end subroutine add_jacobian_transpose_times

  pure subroutine velocity_rows(self, chain, st, fs, out)
    class(clamp_support), intent(in) :: self
    type(chain_type), intent(in) :: chain
    type(chain_state), intent(in) :: st
    type(frame_state), intent(in) :: fs
    real(dp), intent(out) :: out(:)
    real(dp) :: w_n(3), t(3, 3)
    integer :: n
    n = chain%n_bodies
    call self%ball_support%velocity(chain, st, fs, out)
    t = rate_map(orientation_error(self, st))
    w_n = st%omega(:, n) - fs%omega
    out(4:6) = matmul(t, w_n) - matmul(self%omega, t)
  end subroutine velocity_rows

  pure subroutine bias(self, chain, st, fs, out)
    class(clamp_support), intent(in) :: self
    type(chain_type), intent(in) :: chain
    type(chain_state), intent(in) :: st
    type(frame_state), intent(in) :: fs
    real(dp), intent(out) :: out(:)
    real(dp) :: w_n(3), al_n(3), e(3, 3), edot(3, 3), t(3, 3), tdot(3, 3)
    integer :: n
    n = chain%n_bodies
    call self%ball_support%bias(chain, st, fs, out)
    w_n = st%omega(:, n) - fs%omega
    al_n = st%alpha(:, n) - fs%omega_dot - cross(fs%omega, w_n)
    e = orientation_error(self, st)
    edot = matmul(skew(w_n), e) - matmul(e, skew(self%omega))
    t = rate_map(e)
    tdot = rate_map(edot)
    out(4:6) = matmul(tdot, w_n) + matmul(t, al_n) - matmul(self%omega, tdot) - matmul(self%alpha, t)
  end subroutine bias

  pure subroutine wrench(self, chain, st, lambda, force, moment)
    class(clamp_support), intent(in) :: self
    type(chain_type), intent(in) :: chain
    type(chain_state), intent(in) :: st
    real(dp), intent(in) :: lambda(:)
    real(dp), intent(out) :: force(3), moment(3)
    call self%ball_support%wrench(chain, st, lambda, force, moment)
    moment = matmul(lambda(4:6), rate_map(orientation_error(self, st)))   ! T^T lambda_rot
  end subroutine wrench

  !> dE = [dtheta_n] E: the last body's frame turns by dtheta_n, the clamp's does not (it moves
  !> with time only); T is linear in E, so dT = rate_map(dE).  E of the state from linearise.
  pure function orientation_error_tangent(self, st, dst) result(de)
    class(clamp_support), intent(in) :: self
    type(chain_state), intent(in) :: st
    type(chain_tangent), intent(in) :: dst
    real(dp) :: de(3, 3)
    de = matmul(skew(dst%dtheta(:, size(st%rot, 3))), self%e_lin)
  end function orientation_error_tangent

  pure subroutine residual_tangent(self, chain, st, dst, dg)
    class(clamp_support), intent(in) :: self
    type(chain_type), intent(in) :: chain
    type(chain_state), intent(in) :: st
    type(chain_tangent), intent(in) :: dst
    real(dp), intent(out) :: dg(:)
    real(dp) :: de(3, 3)
    call self%ball_support%residual_tangent(chain, st, dst, dg)
    de = orientation_error_tangent(self, st, dst)
    dg(4:6) = 0.5_dp*vee(de - transpose(de))
  end subroutine residual_tangent

  !> d(G v + g_t): the tip's relative velocity (v - Omega x (x - c)) and T w_n - T^T w_B, w_n
  !> relative to the frame, by the product rule (w_B is prescribed: no change).
  pure subroutine velocity_tangent(self, chain, st, dst, fs, dout)
    class(clamp_support), intent(in) :: self
    type(chain_type), intent(in) :: chain
    type(chain_state), intent(in) :: st
    type(chain_tangent), intent(in) :: dst
    type(frame_state), intent(in) :: fs
    real(dp), intent(out) :: dout(:)
    real(dp) :: t(3, 3), dt(3, 3), w_n(3)
    integer :: n
    n = chain%n_bodies
    call self%ball_support%velocity_tangent(chain, st, dst, fs, dout)
    t = self%t_lin
    dt = rate_map(orientation_error_tangent(self, st, dst))
    w_n = st%omega(:, n) - fs%omega
    dout(4:6) = matmul(dt, w_n) + matmul(t, dst%domega(:, n)) - matmul(self%omega, dt)
  end subroutine velocity_tangent

  !> d(G^T mu): the tip wrench's tangent with the moment T^T mu_r and its change
  !> dT^T mu_r + T^T dmu_r.
  pure subroutine add_jacobian_transpose_tangent(self, chain, st, dst, mu, dmu, dr)
    class(clamp_support), intent(in) :: self
    type(chain_type), intent(in) :: chain
    type(chain_state), intent(in) :: st
    type(chain_tangent), intent(in) :: dst
    real(dp), intent(in) :: mu(:), dmu(:)
    real(dp), intent(inout) :: dr(:)
    real(dp) :: t_mu(3), dt_mu(3)
    t_mu = matmul(mu(4:6), self%t_lin)
    dt_mu = matmul(mu(4:6), rate_map(orientation_error_tangent(self, st, dst))) + matmul(dmu(4:6), self%t_lin)
    call add_tip_wrench_tangent(chain, st, dst, mu(1:3), dmu(1:3), t_mu, dt_mu, dr)
  end subroutine add_jacobian_transpose_tangent

  !> dF_B = dlambda_pos, dM_B = dT^T lambda_rot + T^T dlambda_rot.
  pure subroutine wrench_tangent(self, chain, st, dst, lambda, dlambda, dforce, dmoment)
    class(clamp_support), intent(in) :: self
    type(chain_type), intent(in) :: chain
    type(chain_state), intent(in) :: st
    type(chain_tangent), intent(in) :: dst
    real(dp), intent(in) :: lambda(:), dlambda(:)
    real(dp), intent(out) :: dforce(3), dmoment(3)
    call self%ball_support%wrench_tangent(chain, st, dst, lambda, dlambda, dforce, dmoment)
    dmoment = matmul(lambda(4:6), rate_map(orientation_error_tangent(self, st, dst))) &
              + matmul(dlambda(4:6), self%t_lin)
  end subroutine wrench_tangent

  !> The ball's force at the tip and the moment M_B = T^T lambda_rot, dM_B = dT^T lambda_rot with
  !> dT = rate_map([dtheta_n] E): column k the turn about e_k (the moment is linear in dtheta).
  pure subroutine wrench_jacobian(self, chain, st, lambda, d_wrench)
    class(clamp_support), intent(in) :: self
    type(chain_type), intent(in) :: chain
    type(chain_state), intent(in) :: st
    real(dp), intent(in) :: lambda(:)
    real(dp), intent(out) :: d_wrench(6, 6)
    real(dp) :: e(3, 3)
    integer :: k
    call self%ball_support%wrench_jacobian(chain, st, lambda, d_wrench)
    e = orientation_error(self, st)
    do k = 1, 3
      d_wrench(4:6, 3 + k) = matmul(lambda(4:6), rate_map(matmul(skew(unit(k)), e)))
    end do
  end subroutine wrench_jacobian

  !> The ball's position rows and the orientation rows: dg_rot = vee(dE - dE^T)/2, d(T w_n - T^T w_B)
  !> = dT w_n + T dw_n - dT^T w_B (w_n relative to the frame), dE = [dtheta_n] E, column by column.
  pure subroutine rows_jacobian(self, chain, st, fs, dg_pose, dgv_pose, dgv_motion)
    class(clamp_support), intent(in) :: self
    type(chain_type), intent(in) :: chain
    type(chain_state), intent(in) :: st
    type(frame_state), intent(in) :: fs
    real(dp), intent(out) :: dg_pose(:, :), dgv_pose(:, :), dgv_motion(:, :)
    real(dp) :: e(3, 3), de(3, 3), dt(3, 3), w_n(3)
    integer :: k
    call self%ball_support%rows_jacobian(chain, st, fs, dg_pose, dgv_pose, dgv_motion)
    e = orientation_error(self, st)
    w_n = st%omega(:, chain%n_bodies) - fs%omega
    dg_pose(4:6, :) = 0.0_dp
    dgv_pose(4:6, :) = 0.0_dp
    dgv_motion(4:6, :) = 0.0_dp
    do k = 1, 3
      de = matmul(skew(unit(k)), e)
      dt = rate_map(de)
      dg_pose(4:6, 3 + k) = 0.5_dp*vee(de - transpose(de))
      dgv_pose(4:6, 3 + k) = matmul(dt, w_n) - matmul(self%omega, dt)
    end do
    dgv_motion(4:6, 4:6) = rate_map(e)
  end subroutine rows_jacobian

  !> The unit vector e_k.
  pure function unit(k) result(u)
    integer, intent(in) :: k
    real(dp) :: u(3)
    u = 0.0_dp
    u(k) = 1.0_dp
  end function unit

  !> (tip - p_B, E - I), 3 + 9 rows, and its Jacobian (dE/dq_k = [a_k] E).  g_rot also vanishes
  !> at a half-turn error (E = 2uu^T - I, where T has rank 1), so a Gauss-Newton closure on g
  !> alone can stop at a flipped end; E - I vanishes only at E = I.
  pure subroutine closure(self, chain, st, r, r_jac)
    class(clamp_support), intent(in) :: self
    type(chain_type), intent(in) :: chain
    type(chain_state), intent(in) :: st
    real(dp), intent(out) :: r(:)
    real(dp), intent(out) :: r_jac(:, :)
    real(dp) :: e(3, 3), de(3, 3)
    integer :: j, kk
    call self%ball_support%closure(chain, st, r, r_jac)   ! the position rows and their Jacobian
    e = orientation_error(self, st)
    r(4:12) = reshape(e - identity3(), [9])
    do j = 1, chain%n_bodies
      do kk = 1, chain%n_joint_coords(j)
        de = matmul(skew(st%axes(:, kk, j)), e)
        r_jac(4:12, chain%first_coord(j) + kk - 1) = reshape(de, [9])
      end do
    end do
  end subroutine closure

  pure integer function closure_rows(self)
    class(clamp_support), intent(in) :: self
    closure_rows = 12
  end function closure_rows

  !> Target part of the way from (p0, R0) to the clamp's pose of the last update: position
  !> linearly, orientation along the geodesic R0 exp(s log(R0^T R_B)); s = 1 restores it.
  subroutine blend_target(self, s, p0, r0)
    class(clamp_support), intent(inout) :: self
    real(dp), intent(in) :: s
    real(dp), intent(in) :: p0(3), r0(3, 3)
    call self%ball_support%blend_target(s, p0, r0)
    self%rotation = matmul(r0, rotation_exp(s*rotation_log(matmul(transpose(r0), self%true_rotation))))
    if (s >= 1.0_dp) self%rotation = self%true_rotation
  end subroutine blend_target

  !> The free part ends where the held last body starts: p_B - L_n R_B e_z.
  pure subroutine reach_target(self, chain, point, held, found)
    class(clamp_support), intent(in) :: self
    type(chain_type), intent(in) :: chain
    real(dp), intent(out) :: point(3)
    integer, intent(out) :: held
    logical, intent(out) :: found
    point = self%position - chain%length(chain%n_bodies)*self%rotation(:, 3)
    held = 1
    found = .true.
  end subroutine reach_target

  pure subroutine motion_twist(self, velocity, omega)
    class(clamp_support), intent(in) :: self
    real(dp), intent(out) :: velocity(3), omega(3)
    call self%ball_support%motion_twist(velocity, omega)
    omega = self%omega
  end subroutine motion_twist

end module rotorcable_supports_clamp
