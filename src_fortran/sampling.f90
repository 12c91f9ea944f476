!> What an output sample reports at a state (q, v, t): support reactions, energies, the
!> constraint violation, and the loads the cable carries at every joint.
!>
!> Reactions come from the multipliers of eq. 3.55 (= eq. 3.56/3.57 without explicit inverses)
!> at the integrated (q, v), passed through the Newton-Euler backward pass for the reaction at
!> A and the joint wrenches: the thesis's route (eq. 3.57), free of the lower accuracy of the
!> index-2 multipliers of a BDF method.  Two kinematic passes per sample.
module rotorcable_sampling
  use rotorcable_kinds, only: dp
  use rotorcable_model, only: model_type, solve_accelerations, eom_residual, state_energies, positions_at, &
                              model_prepare, workspace_holds, HOLDS_EOM
  use rotorcable_kinematics, only: joint_angles
  use rotorcable_joint, only: thesis_angles
  use rotorcable_rotations, only: cross
  implicit none
  private
  public :: sample_state, joint_loads, shape_of, support_motion

contains

  !> Reactions, energies and max |g| of the position rows at (q, v, t).  On return the workspace
  !> holds the frames, motion and joint wrenches of this state (model%ws%solved: with the
  !> accelerations and multipliers of eq. 3.55), which joint_loads reads.
  subroutine sample_state(model, t, q, v, wrenches, kinetic, potential, g_max, info, multipliers)
    type(model_type), intent(inout) :: model  !< model
    real(dp), intent(in) :: t                 !< time [s]
    real(dp), intent(in) :: q(:), v(:)        !< coordinates and rates
    real(dp), intent(out) :: wrenches(12)     !< F_A, M_A, F_B, M_B (support on chain)
    real(dp), intent(out) :: kinetic          !< kinetic energy relative to the model frame [J]
    real(dp), intent(out) :: potential        !< potential energy [J]
    real(dp), intent(out) :: g_max            !< max |g| of the position rows [m]
    integer, intent(out) :: info              !< LAPACK status of eq. 3.55
    real(dp), intent(out), optional :: multipliers(:)  !< lambda of eq. 3.55 (size nc)
    real(dp) :: vdot(model%nq), lambda(max(model%nc, 1)), res(model%nq), g(max(model%nc, 1))
    lambda = 0.0_dp
    call solve_accelerations(model, t, q, v, vdot, lambda(1:model%nc), info)
    call eom_residual(model, t, q, v, vdot, lambda, res, wrenches)   ! the frames of q reused
    model%ws%solved = info == 0
    if (present(multipliers)) multipliers = lambda(1:model%nc)
    call state_energies(model, t, q, v, kinetic, potential)
    g_max = 0.0_dp
    if (model%nc > 0) then
      call model%support_b%residual(model%chain, model%st, g(1:model%nc))
      g_max = maxval(abs(g(1:min(3, model%nc))))
    end if
  end subroutine sample_state

  !> The wrench every joint transmits at the sampled state (q, v, t) (parent on child, at the
  !> joint point; sample_state's pass, evaluated here unless the workspace holds it), resolved
  !> along the child's axis e, and the joint's bending angle.
  !> axial = -f.e (positive in tension: a parent pulls its child back along -e), shear =
  !> |f - (f.e) e|, torsion = n.e, bending = |n - (n.e) e|; bend angle = the angle between the
  !> parent's axis (the base frame's z for joint 1) and the child's, 0 at a locked joint.
  !> Signed components for fatigue (a magnitude folds a reversing moment onto one sign and
  !> halves its cycles): moment_xy = (n.e1, n.e2) and the bend vector kappa_xy = theta/sin(theta)
  !> ((e_parent x e).e1, (e_parent x e).e2), both in the child's body axes e1, e2, so they
  !> turn with the jacket when it twists (docs/model.md, "Fatigue").
  subroutine joint_loads(model, t, q, v, axial, shear, bending, torsion, bend_angle, moment_xy, bend_xy)
    type(model_type), intent(inout) :: model  !< model
    real(dp), intent(in) :: t                 !< time [s]
    real(dp), intent(in) :: q(:), v(:)        !< coordinates and rates
    real(dp), intent(out) :: axial(:)         !< (n) axial force [N]
    real(dp), intent(out) :: shear(:)         !< (n) shear force [N]
    real(dp), intent(out) :: bending(:)       !< (n) bending moment [Nm]
    real(dp), intent(out) :: torsion(:)       !< (n) torsional moment [Nm]
    real(dp), intent(out) :: bend_angle(:)    !< (n) bending angle [rad]
    real(dp), intent(out) :: moment_xy(:, :)  !< (2,n) bending moment in the child's axes [Nm]
    real(dp), intent(out) :: bend_xy(:, :)    !< (2,n) bend vector in the child's axes [rad]
    real(dp) :: e(3), e_parent(3), f(3), m(3), axis(3), s, theta, scale
    real(dp) :: wrenches(12), kinetic, potential, g_max
    integer :: j, info
    if (.not. (model%ws%solved .and. workspace_holds(model, HOLDS_EOM, t, q, v))) &
      call sample_state(model, t, q, v, wrenches, kinetic, potential, g_max, info)
    e_parent = model%base_rot(:, 3)
    do j = 1, model%chain%n_bodies
      e = model%st%rot(:, 3, j)
      f = model%st%joint_force(:, j)
      m = model%st%joint_moment(:, j)
      axial(j) = -dot_product(f, e)
      shear(j) = norm2(f - dot_product(f, e)*e)
      torsion(j) = dot_product(m, e)
      bending(j) = norm2(m - dot_product(m, e)*e)
      moment_xy(1, j) = dot_product(m, model%st%rot(:, 1, j))
      moment_xy(2, j) = dot_product(m, model%st%rot(:, 2, j))
      bend_angle(j) = 0.0_dp
      bend_xy(:, j) = 0.0_dp
      if (.not. model%chain%locked(j)) then
        axis = cross(e_parent, e)
        s = norm2(axis)
        theta = atan2(s, dot_product(e_parent, e))
        bend_angle(j) = theta
        ! theta/sin(theta) -> 1 as theta -> 0; near theta = pi the axis itself is undefined.
        scale = 1.0_dp
        if (s > 1.0e-12_dp) scale = theta / s
        bend_xy(1, j) = scale * dot_product(axis, model%st%rot(:, 1, j))
        bend_xy(2, j) = scale * dot_product(axis, model%st%rot(:, 2, j))
      end if
      e_parent = e
    end do
  end subroutine joint_loads

  !> The thesis's (gamma, beta) of every body [rad] for q, and the CMs, joint points and the last
  !> body's rotation at (q, t) (the frames of q, evaluated unless the workspace holds them).
  subroutine shape_of(model, t, q, angles, cm, joints, last_rotation, rotations)
    type(model_type), intent(inout) :: model  !< model
    real(dp), intent(in) :: t                 !< time [s]
    real(dp), intent(in) :: q(:)              !< coordinates [rad]
    real(dp), intent(out) :: angles(:, :)     !< (2,n) gamma, beta [rad]
    real(dp), intent(out) :: cm(:, :)         !< (3,n) centres of mass [m]
    real(dp), intent(out) :: joints(:, :)     !< (3,n+1) joint points [m]
    real(dp), intent(out), optional :: last_rotation(3, 3)  !< R_n
    real(dp), intent(out), optional :: rotations(:, :, :)   !< (3,3,n) R_j: model frame <- body j
    integer :: j
    call positions_at(model, t, q)
    do j = 1, model%chain%n_bodies
      angles(:, j) = thesis_angles(model%chain%joint_kind(j), joint_angles(model%chain, q, j))
    end do
    cm = model%st%cm
    joints = model%st%joint_point
    if (present(last_rotation)) last_rotation = model%st%rot(:, :, model%chain%n_bodies)
    if (present(rotations)) rotations = model%st%rot
  end subroutine shape_of

  !> Velocities of the supports relative to the model frame at time t: P_1 and the base
  !> frame's rotation rate, clamp B's point and rotation rate (zero when fixed).  With the
  !> reactions they give the power the supports put into the chain.
  subroutine support_motion(model, t, twists)
    type(model_type), intent(inout) :: model  !< model
    real(dp), intent(in) :: t                 !< time [s]
    real(dp), intent(out) :: twists(12)       !< v_A, w_A, v_B, w_B [m/s, rad/s]
    call model_prepare(model, t)
    twists = 0.0_dp
    twists(1:3) = model%base_vel
    twists(4:6) = model%base_omega
    if (.not. allocated(model%support_b)) return
    call model%support_b%motion_twist(twists(7:9), twists(10:12))
  end subroutine support_motion

end module rotorcable_sampling
