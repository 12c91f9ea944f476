!> The derivatives of the model's equations as whole matrices, in one pass over the bodies and
!> O(1) work per entry (rotorcable_inverse_dynamics_derivatives): the equation-of-motion residual
!> M vdot - k - G^T lambda by q and v (and M), with every load's and support B's part, and support
!> B's rows: G^T mu by q, g by q, G v + g_t by q and v.  The same derivatives, column by column,
!> are the tangent sweeps of rotorcable_model (eom_residual_tangent) and of the supports, kept
!> as their check (tests/test_analytic_derivatives.py, 1e-12).
!>
!> Each load and the support state their derivatives by the motion of the body they act on
!> (load_term%add_force_jacobians, support_type%wrench_jacobian and rows_jacobian); the chain's
!> recursion carries them to every coordinate.
module rotorcable_model_derivatives
  use rotorcable_kinds, only: dp
  use rotorcable_model, only: model_type, tangent_base_point
  use rotorcable_inverse_dynamics_derivatives, only: derivatives_allocate, inverse_dynamics_derivatives
  use rotorcable_spatial_algebra, only: force_cross, to_origin, twist_at, wrench_about_origin, point_wrench_to_cm
  use rotorcable_rotations, only: cross, skew
  implicit none
  private
  public :: eom_derivatives, constraint_derivatives

contains

  !> d(residual)/dq, d(residual)/dv and (when asked) M of eom_residual's residual
  !> M vdot - k - G^T lambda at (t, q, v, vdot, lambda), lambda held fixed: the pass is
  !> evaluated here unless the workspace holds it (or `held`), and the loads and the support
  !> linearise there (tangent_base_point, as the tangent sweeps).  The model's derivative work
  !> then holds the state's axes for constraint_derivatives.
  subroutine eom_derivatives(model, t, q, v, vdot, lambda, dres_dq, dres_dv, mass, held)
    type(model_type), intent(inout) :: model  !< model
    real(dp), intent(in) :: t                 !< time [s]
    real(dp), intent(in) :: q(:), v(:), vdot(:)  !< coordinates, rates, accelerations
    real(dp), intent(in) :: lambda(:)         !< multipliers (size nc)
    real(dp), intent(inout) :: dres_dq(:, :)  !< (nq,nq) [Nm/rad]
    real(dp), intent(inout) :: dres_dv(:, :)  !< (nq,nq) [Nms/rad]
    real(dp), intent(inout), optional :: mass(:, :)  !< (nq,nq) M [kg m^2]
    logical, intent(in), optional :: held     !< the workspace holds the point (tangent_base_point)
    real(dp) :: f_b(3), m_b(3), d_b(6, 6), r(3)
    integer :: i, n
    call tangent_base_point(model, t, q, v, vdot, lambda, held)
    call derivatives_allocate(model%chain, model%derivs)
    n = model%chain%n_bodies
    associate (w => model%derivs)
      w%ext_pose = 0.0_dp
      w%ext_motion = 0.0_dp
      w%joint_q = 0.0_dp
      w%joint_v = 0.0_dp
      do i = 1, size(model%loads)
        call model%loads(i)%term%add_force_jacobians(model%chain, model%st, model%fs, t, q, v, w%ext_pose, &
                                                     w%ext_motion, w%joint_q, w%joint_v)
      end do
      ! The residual's net force on a body is its inertia less the loads and, on the last body,
      ! less support B's wrench (inverse_dynamics: the tip's "child" exerts -F_B, -M_B).
      w%ext_pose = -w%ext_pose
      w%ext_motion = -w%ext_motion
      w%ext_force = -model%force
      w%ext_moment = -model%moment
      if (model%nc > 0) then
        call model%support_b%wrench(model%chain, model%st, lambda(1:model%nc), f_b, m_b)
        call model%support_b%wrench_jacobian(model%chain, model%st, lambda(1:model%nc), d_b)
        r = model%st%joint_point(:, n + 1) - model%st%cm(:, n)
        w%ext_pose(:, :, n) = w%ext_pose(:, :, n) - point_wrench_to_cm(d_b, f_b, r)
        w%ext_force(:, n) = w%ext_force(:, n) - f_b
        w%ext_moment(:, n) = w%ext_moment(:, n) - m_b - cross(r, f_b)
      end if
    end associate
    if (model%fs%rotating .and. .not. model%fs%body_couples) then
      call inverse_dynamics_derivatives(model%chain, model%st, model%seed, v, vdot, model%lin_inertia%inertia, &
                                        model%derivs, dres_dq, dres_dv, mass, model%fs%omega, model%fs%omega_dot)
    else
      call inverse_dynamics_derivatives(model%chain, model%st, model%seed, v, vdot, model%lin_inertia%inertia, &
                                        model%derivs, dres_dq, dres_dv, mass)
    end if
  end subroutine eom_derivatives

  !> Support B's rows by q and v at the state of the last eom_derivatives (its axes are in the
  !> model's derivative work): d(G^T mu)/dq, G = dg/dq, d(G v + g_t)/dq and d(G v + g_t)/dv.
  !>
  !> G^T mu is the generalized force of one wrench W of the last body (the multipliers' force at
  !> the tip and moment), W about O the same for every joint: (G^T mu)_k = S_k . W.  So its
  !> derivative is the inverse dynamics' with one body and no motion: S_k . (Qhat S_m) for every
  !> k, m, plus S_k . (S_m x* W) for k <= m (rotorcable_inverse_dynamics_derivatives), with Qhat
  !> the part of W's change that does not turn with the body.  The rows follow the last body:
  !> under a coordinate m it turns by S_m (at the tip X_p S_m), and its velocity changes by
  !> S_m x nu_n + c_m, about the tip (xi_w x v_tip, xi_w x w_n) + X_p c_m; under a rate, by S_m.
  subroutine constraint_derivatives(model, mu, dgt_mu_dq, dg_dq, dgv_dq, dgv_dv)
    type(model_type), intent(inout) :: model  !< model (after eom_derivatives at the state)
    real(dp), intent(in) :: mu(:)             !< the projection multipliers (size nc)
    real(dp), intent(inout) :: dgt_mu_dq(:, :)  !< (nq,nq) d(G^T mu)/dq
    real(dp), intent(inout) :: dg_dq(:, :)    !< (nc,nq) G
    real(dp), intent(inout) :: dgv_dq(:, :)   !< (nc,nq) d(G v + g_t)/dq
    real(dp), intent(inout) :: dgv_dv(:, :)   !< (nc,nq) d(G v + g_t)/dv = G
    real(dp) :: f(3), m(3), d(6, 6), p(3), w_o(6), s(6), xt(6), ct(6), u(6), up(6), v_tip(3), w_n(3)
    real(dp) :: yg(model%nc, 6), yp(model%nc, 6), ym(model%nc, 6)
    integer :: nq, nc, n, k, l
    nq = model%nq; nc = model%nc; n = model%chain%n_bodies
    if (nc == 0) return
    associate (w => model%derivs, st => model%st)
      p = st%joint_point(:, n + 1) - w%origin
      call model%support_b%wrench(model%chain, st, mu(1:nc), f, m)
      call model%support_b%wrench_jacobian(model%chain, st, mu(1:nc), d)
      d(1:3, 4:6) = d(1:3, 4:6) + skew(f)      ! less the change that turns with the body
      d(4:6, 4:6) = d(4:6, 4:6) + skew(m)
      d = to_origin(d, p)
      w_o = wrench_about_origin(f, m, p)
      call model%support_b%rows_jacobian(model%chain, st, model%fs, yg, yp, ym)
      v_tip = st%vel_joint(:, n + 1)
      w_n = st%omega(:, n)
      do l = 1, nq
        s = w%axis(:, l)
        u = matmul(d, s)
        up = u + force_cross(s, w_o)
        do k = 1, l
          dgt_mu_dq(k, l) = dot_product(w%axis(:, k), up)
        end do
        do k = l + 1, nq
          dgt_mu_dq(k, l) = dot_product(w%axis(:, k), u)
        end do
        xt = twist_at(s, p)
        ct = twist_at(w%vel_axis(:, l), p)
        ct(1:3) = ct(1:3) + cross(xt(4:6), v_tip)
        ct(4:6) = ct(4:6) + cross(xt(4:6), w_n)
        dg_dq(:, l) = matmul(yg, xt)
        dgv_dq(:, l) = matmul(yp, xt) + matmul(ym, ct)
        dgv_dv(:, l) = matmul(ym, xt)
      end do
    end associate
  end subroutine constraint_derivatives

end module rotorcable_model_derivatives
