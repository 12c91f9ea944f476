!> A prescribed rigid motion: a sequence of hinges, each a rotation by a prescribed angle about
!> an axis through a point, both given in the reference configuration (all angles zero).  The
!> blade's flap, lead-lag and pitch hinges are such a sequence (flap outermost: the lag and
!> pitch hinges move with the flap); a support carried round by the rotor adds the rotor axis
!> in front.
!>
!> Product of exponentials (Brockett 1984; Murray, Li, Sastry, "A Mathematical Introduction to
!> Robotic Manipulation", 1994, ch. 3): T(t) = T_1(theta_1) T_2(theta_2) ... maps the reference
!> configuration to the current one.  With the prefix P_{k-1} = T_1 ... T_{k-1}, hinge k's current
!> axis is u_k' = R_P u_k through h_k' = P_{k-1}(h_k), its unit twist xi_k' = (u_k', h_k' x u_k'), and
!>   spatial velocity      V = sum_k xi_k' theta-dot_k,
!>   its time derivative   V-dot = sum_k (xi_k' theta-ddot_k + (V_{k-1} x xi_k') theta-dot_k),
!> where V_{k-1} is the velocity of the prefix and (w, v) x (u, z) = (w x u, w x z + v x u) is
!> the motion cross product (Featherstone 2008, eq. 2.31).  V = (w, v_O) is given at the model
!> frame's origin: a point x moving with the body has velocity v_O + w x x and acceleration
!> v_O-dot + w-dot x x + w x (v_O + w x x).
module rotorcable_motion_rigid_motion
  use rotorcable_kinds, only: dp
  use rotorcable_rotations, only: cross, identity3, rotation_exp
  use rotorcable_motion_rotor, only: rotor_state
  use rotorcable_motion_angle_function, only: angle_function, angle_eval, angle_free
  implicit none
  private
  public :: hinge_type, rigid_motion, motion_state, motion_at, point_motion, motion_free

  !> One hinge: rotation by angle(t) about axis through point (reference configuration).
  type :: hinge_type
    real(dp) :: axis(3) = [0.0_dp, 0.0_dp, 1.0_dp]  !< unit axis
    real(dp) :: point(3) = 0.0_dp             !< a point on the axis [m]
    type(angle_function) :: angle             !< prescribed angle
  end type hinge_type

  !> A sequence of hinges (empty: no motion).
  type :: rigid_motion
    type(hinge_type), allocatable :: hinges(:)
  end type rigid_motion

  !> Pose and spatial velocity/acceleration of the moved body at one time.
  type :: motion_state
    real(dp) :: rot(3, 3) = reshape([1.0_dp, 0.0_dp, 0.0_dp, 0.0_dp, 1.0_dp, 0.0_dp, 0.0_dp, 0.0_dp, 1.0_dp], &
                                    [3, 3])   !< x = rot x_ref + shift
    real(dp) :: shift(3) = 0.0_dp
    real(dp) :: omega(3) = 0.0_dp             !< angular velocity [rad/s]
    real(dp) :: v_origin(3) = 0.0_dp          !< velocity of the body point at the origin [m/s]
    real(dp) :: omega_dot(3) = 0.0_dp         !< angular acceleration [rad/s^2]
    real(dp) :: v_origin_dot(3) = 0.0_dp      !< time derivative of v_origin [m/s^2]
  end type motion_state

contains

  !> The motion's state at time t.
  function motion_at(m, t, rs) result(s)
    type(rigid_motion), intent(in) :: m       !< motion
    real(dp), intent(in) :: t                 !< time [s]
    type(rotor_state), intent(in) :: rs       !< rotor angle, speed, acceleration
    type(motion_state) :: s
    real(dp) :: a, ad, add, u(3), h(3), xi_w(3), xi_v(3), r_k(3, 3)
    integer :: k
    s%rot = identity3()
    if (.not. allocated(m%hinges)) return
    do k = 1, size(m%hinges)
      call angle_eval(m%hinges(k)%angle, t, rs, a, ad, add)
      u = matmul(s%rot, m%hinges(k)%axis)
      h = matmul(s%rot, m%hinges(k)%point) + s%shift
      xi_w = u
      xi_v = cross(h, u)
      ! Derivative of the moved twist: V_{k-1} x xi_k' (before V gets hinge k's own part).
      s%omega_dot = s%omega_dot + xi_w*add + cross(s%omega, xi_w)*ad
      s%v_origin_dot = s%v_origin_dot + xi_v*add + (cross(s%omega, xi_v) + cross(s%v_origin, xi_w))*ad
      s%omega = s%omega + xi_w*ad
      s%v_origin = s%v_origin + xi_v*ad
      ! Prefix update P_k = P_{k-1} T_k, T_k: x -> R_k (x - h_k) + h_k in the reference frame.
      r_k = rotation_exp(a*m%hinges(k)%axis)
      s%shift = matmul(s%rot, m%hinges(k)%point - matmul(r_k, m%hinges(k)%point)) + s%shift
      s%rot = matmul(s%rot, r_k)
    end do
  end function motion_at

  !> Position, velocity and acceleration of a point moving with the body (reference x_ref).
  pure subroutine point_motion(s, x_ref, x, v, acc)
    type(motion_state), intent(in) :: s       !< motion state
    real(dp), intent(in) :: x_ref(3)          !< point in the reference configuration [m]
    real(dp), intent(out) :: x(3), v(3), acc(3)  !< current position, velocity, acceleration
    x = matmul(s%rot, x_ref) + s%shift
    v = s%v_origin + cross(s%omega, x)
    acc = s%v_origin_dot + cross(s%omega_dot, x) + cross(s%omega, v)
  end subroutine point_motion

  !> Release the hinges' table splines.
  subroutine motion_free(m)
    type(rigid_motion), intent(inout) :: m    !< motion
    integer :: k
    if (.not. allocated(m%hinges)) return
    do k = 1, size(m%hinges)
      call angle_free(m%hinges(k)%angle)
    end do
  end subroutine motion_free

end module rotorcable_motion_rigid_motion
