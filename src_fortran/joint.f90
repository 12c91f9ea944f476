!> Joint parametrisations behind one interface.
!>
!> A joint connects body j-1 (or the base) to body j.  Every parametrisation answers
!> the same three questions, so the kinematics, inverse dynamics, mass matrix and
!> constraint code never look at the angles themselves:
!>   * joint_rotation: relative rotation parent -> child for given joint angles,
!>   * joint_axes:     world-frame unit axes (one per coordinate) such that the
!>                     relative angular velocity is  sum_k axes(:,k) * qdot_k,
!>   * joint_bias:     the part of  d/dt(axes) qdot  that is not caused by the parent
!>                     frame's own rotation (that part, w_parent x w_rel, is generic).
!> The thesis's joint (chapter 4.1.1) is JOINT_ZY: gamma about the parent's z, then
!> beta about the new y.  It is singular in meaning (not in the mass matrix) where
!> beta = 0: gamma is then a twist and the bending direction is undefined.
!> JOINT_XY is the singularity-free alternative of the thesis's outlook (chapter 6): two
!> Cardan bending angles, phi about the parent's x axis, then theta about the new y axis.
!> Its singularity (theta = +-90 deg, a right-angle kink) lies far outside the bending a
!> cable segment can take, while beta = 0 (a straight cable) is the common case.  Tables
!> still print the thesis's gamma/beta of the body axis (thesis_angles).  JOINT_XYZ adds
!> the twist of the outlook: psi about the child's own (cable) axis after the two Cardan
!> bending angles, with its own torsion spring and damper; it is singular only where
!> theta = +-90 deg as well.  A further parametrisation is added by extending the
!> select-case blocks.
module rotorcable_joint
  use rotorcable_kinds, only: dp
  use rotorcable_rotations, only: cross
  implicit none
  private
  public :: JOINT_ZY, JOINT_XY, JOINT_XYZ, MAX_JOINT_DOF, joint_ndof, joint_rotation, joint_axes, &
            joint_bias, joint_bias_tangent, thesis_angles, angles_from_thesis

  !> Thesis two-angle joint: R_rel = Rz(gamma) Ry(beta), coordinates (gamma, beta).
  integer, parameter :: JOINT_ZY = 1
  !> Cardan bending joint: R_rel = Rx(phi) Ry(theta), coordinates (phi, theta).
  integer, parameter :: JOINT_XY = 2
  !> Cardan bending + twist: R_rel = Rx(phi) Ry(theta) Rz(psi), coordinates (phi, theta, psi).
  integer, parameter :: JOINT_XYZ = 3
  !> Most coordinates any joint has; joint angle arrays have this size (unused ones zero).
  integer, parameter :: MAX_JOINT_DOF = 3

contains

  !> Number of coordinates a joint of this parametrisation has when it is free.
  pure integer function joint_ndof(kind)
    integer, intent(in) :: kind        !< parametrisation (JOINT_ZY)
    select case (kind)
    case (JOINT_ZY, JOINT_XY)
      joint_ndof = 2
    case (JOINT_XYZ)
      joint_ndof = 3
    case default
      joint_ndof = 0
    end select
  end function joint_ndof

  !> Relative rotation parent -> child (active), eq. 4.7/4.8 transposed.
  pure function joint_rotation(kind, angles) result(r_rel)
    integer, intent(in) :: kind        !< parametrisation
    real(dp), intent(in) :: angles(MAX_JOINT_DOF)  !< joint angles [rad] (gamma, beta) for JOINT_ZY
    real(dp) :: r_rel(3, 3)
    real(dp) :: c1, s1, c2, s2, c3, s3, col1(3), col2(3)
    ! The products of the elementary rotations written out (every joint of every residual
    ! passes here: two matrix products cost more than the sines).
    c1 = cos(angles(1)); s1 = sin(angles(1))
    c2 = cos(angles(2)); s2 = sin(angles(2))
    select case (kind)
    case (JOINT_ZY)
      ! Rz(gamma) Ry(beta)
      r_rel(1, 1) = c1*c2; r_rel(2, 1) = s1*c2; r_rel(3, 1) = -s2
      r_rel(1, 2) = -s1;   r_rel(2, 2) = c1;    r_rel(3, 2) = 0.0_dp
      r_rel(1, 3) = c1*s2; r_rel(2, 3) = s1*s2; r_rel(3, 3) = c2
    case (JOINT_XY, JOINT_XYZ)
      ! Rx(phi) Ry(theta)
      r_rel(1, 1) = c2;     r_rel(2, 1) = s1*s2;  r_rel(3, 1) = -c1*s2
      r_rel(1, 2) = 0.0_dp; r_rel(2, 2) = c1;     r_rel(3, 2) = s1
      r_rel(1, 3) = s2;     r_rel(2, 3) = -s1*c2; r_rel(3, 3) = c1*c2
      if (kind == JOINT_XYZ) then
        ! ... Rz(psi): the first two columns turn about the third.
        c3 = cos(angles(3)); s3 = sin(angles(3))
        col1 = r_rel(:, 1); col2 = r_rel(:, 2)
        r_rel(:, 1) = c3*col1 + s3*col2
        r_rel(:, 2) = c3*col2 - s3*col1
      end if
    case default
      r_rel = 0.0_dp
    end select
  end function joint_rotation

  !> World-frame joint axes, eq. 4.11/4.12: gamma turns about the parent's z axis,
  !> beta about the child's y axis.
  pure subroutine joint_axes(kind, angles, r_parent, r_child, axes)
    integer, intent(in) :: kind               !< parametrisation
    real(dp), intent(in) :: angles(MAX_JOINT_DOF)  !< joint angles [rad]
    real(dp), intent(in) :: r_parent(3, 3)    !< world <- parent rotation
    real(dp), intent(in) :: r_child(3, 3)     !< world <- child rotation
    real(dp), intent(out) :: axes(:, :)       !< (3, ndof) unit axes in the world frame
    select case (kind)
    case (JOINT_ZY)
      axes(:, 1) = r_parent(:, 3)
      axes(:, 2) = r_child(:, 2)
    case (JOINT_XY)
      ! phi turns about the parent's x axis, theta about the child's y axis.
      axes(:, 1) = r_parent(:, 1)
      axes(:, 2) = r_child(:, 2)
    case (JOINT_XYZ)
      ! phi about the parent's x; theta about the y axis of the frame after phi,
      ! R_parent Rx(phi) e_y; psi about the child's own z (the body axis).
      axes(:, 1) = r_parent(:, 1)
      axes(:, 2) = cos(angles(1))*r_parent(:, 2) + sin(angles(1))*r_parent(:, 3)
      axes(:, 3) = r_child(:, 3)
    case default
      axes = 0.0_dp
    end select
  end subroutine joint_axes

  !> Joint-intrinsic part of d/dt(axes) qdot.  For JOINT_ZY the gamma axis is fixed in
  !> the parent and the beta axis in the child, so d/dt(a_beta) contains
  !> gammadot a_gamma x a_beta beyond the parent's rotation (derivative of eq. 4.19).
  !> In general (successive rotations) axis l is fixed in the frame after rotations
  !> 1 .. l-1, so the bias is sum_l qdot_l sum_{k<l} qdot_k a_k x a_l.
  pure function joint_bias(kind, axes, rates) result(bias)
    integer, intent(in) :: kind               !< parametrisation
    real(dp), intent(in) :: axes(:, :)        !< (3, ndof) world axes from joint_axes
    real(dp), intent(in) :: rates(:)          !< joint coordinate rates [rad/s]
    real(dp) :: bias(3)
    ! Fixed-size locals: a cross product of assumed-shape sections or of an expression of them
    ! makes gfortran allocate a temporary on the heap, here once per body and residual.
    real(dp) :: a1(3), a2(3), a3(3), w12(3)
    select case (kind)
    case (JOINT_ZY, JOINT_XY)
      ! First axis fixed in the parent, second in the child: same structure for both.
      a1 = axes(:, 1); a2 = axes(:, 2)
      bias = rates(1)*rates(2)*cross(a1, a2)
    case (JOINT_XYZ)
      a1 = axes(:, 1); a2 = axes(:, 2); a3 = axes(:, 3)
      w12 = rates(1)*a1 + rates(2)*a2
      bias = rates(1)*rates(2)*cross(a1, a2) + rates(3)*cross(w12, a3)
    case default
      bias = 0.0_dp
    end select
  end function joint_bias

  !> First-order change of joint_bias for changes of the axes (daxes) and the rates (drates):
  !> the product rule on the same expressions.  Fixed-size arguments (the first ndof columns
  !> used): the tangent runs per body and column, and array descriptors for sections cost more
  !> than its arithmetic.
  pure function joint_bias_tangent(kind, axes, daxes, rates, drates) result(dbias)
    integer, intent(in) :: kind               !< parametrisation
    real(dp), intent(in) :: axes(3, MAX_JOINT_DOF)   !< world axes (ndof used)
    real(dp), intent(in) :: daxes(3, MAX_JOINT_DOF)  !< their change
    real(dp), intent(in) :: rates(MAX_JOINT_DOF)     !< joint coordinate rates [rad/s]
    real(dp), intent(in) :: drates(MAX_JOINT_DOF)    !< their change
    real(dp) :: dbias(3)
    real(dp) :: a1(3), a2(3), a3(3), d1(3), d2(3), d3(3), w12(3), dw12(3)
    select case (kind)
    case (JOINT_ZY, JOINT_XY)
      a1 = axes(:, 1); a2 = axes(:, 2); d1 = daxes(:, 1); d2 = daxes(:, 2)
      dbias = (drates(1)*rates(2) + rates(1)*drates(2))*cross(a1, a2) &
              + rates(1)*rates(2)*(cross(d1, a2) + cross(a1, d2))
    case (JOINT_XYZ)
      a1 = axes(:, 1); a2 = axes(:, 2); a3 = axes(:, 3)
      d1 = daxes(:, 1); d2 = daxes(:, 2); d3 = daxes(:, 3)
      w12 = rates(1)*a1 + rates(2)*a2
      dw12 = drates(1)*a1 + rates(1)*d1 + drates(2)*a2 + rates(2)*d2
      dbias = (drates(1)*rates(2) + rates(1)*drates(2))*cross(a1, a2) &
              + rates(1)*rates(2)*(cross(d1, a2) + cross(a1, d2)) &
              + drates(3)*cross(w12, a3) + rates(3)*(cross(dw12, a3) + cross(w12, d3))
    case default
      dbias = 0.0_dp
    end select
  end function joint_bias_tangent

  !> The thesis's (gamma, beta) of a joint: direction of the child's axis in the parent
  !> frame, d = R_rel e_z = (cos g sin b, sin g sin b, cos b) (eq. 4.7/4.8).  For JOINT_ZY
  !> these are the coordinates themselves; otherwise beta in [0, pi] and gamma = atan2
  !> (0 for a straight joint, where the thesis's gamma is undefined).
  pure function thesis_angles(kind, angles) result(gb)
    integer, intent(in) :: kind        !< parametrisation
    real(dp), intent(in) :: angles(MAX_JOINT_DOF)  !< joint coordinates [rad]
    real(dp) :: gb(2)
    real(dp) :: r(3, 3)
    if (kind == JOINT_ZY) then
      gb = angles(1:2)
      return
    end if
    r = joint_rotation(kind, angles)
    gb(2) = acos(max(-1.0_dp, min(1.0_dp, r(3, 3))))
    gb(1) = 0.0_dp
    if (abs(r(1, 3)) + abs(r(2, 3)) > 0.0_dp) gb(1) = atan2(r(2, 3), r(1, 3))
  end function thesis_angles

  !> Joint coordinates that point the child's axis where the thesis's (gamma, beta) do,
  !> for decks written in the thesis's angles.  JOINT_XY: Rx(phi) Ry(theta) e_z =
  !> (sin t, -sin p cos t, cos p cos t) = d gives theta = asin(cos g sin b),
  !> phi = atan2(-sin g sin b, cos b).  (The twist about the axis is the joint's own:
  !> JOINT_XYZ starts untwisted, psi = 0.)
  pure function angles_from_thesis(kind, gb) result(angles)
    integer, intent(in) :: kind        !< parametrisation
    real(dp), intent(in) :: gb(2)      !< thesis gamma, beta [rad]
    real(dp) :: angles(MAX_JOINT_DOF)
    angles = 0.0_dp
    select case (kind)
    case (JOINT_XY, JOINT_XYZ)
      angles(2) = asin(max(-1.0_dp, min(1.0_dp, cos(gb(1))*sin(gb(2)))))
      angles(1) = atan2(-sin(gb(1))*sin(gb(2)), cos(gb(2)))
    case default
      angles(1:2) = gb
    end select
  end function angles_from_thesis

end module rotorcable_joint
