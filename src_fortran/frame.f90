!> The frame the equations are written in: the inertial frame, or the hub frame that turns
!> with the rotor (angular velocity Omega e_z about the axis through the rotor centre).
!>
!> In the hub frame the chain's kinematics are computed with every vector expressed in hub
!> coordinates, but velocities and accelerations absolute (inertial): the forward recursion is
!> seeded with the hub's Omega, Omega-dot and the absolute motion of the base point
!> (Featherstone 2008, section 5.3, a moving base), so the Newton-Euler equations carry every
!> term of thesis eq. 5.7: centrifugal, Coriolis and Euler forces on every body and the
!> gyroscopic and centrifugal couples on each body's rotational inertia.  Relative quantities
!> (for the constraints and the output) follow from
!>   v_rel = v - Omega x r,   a_rel = a - 2 Omega x v_rel - Omega-dot x r - Omega x (Omega x r),
!>   w_rel = w - Omega,       alpha_rel = alpha - Omega-dot - Omega x w_rel,
!> with r measured from the rotor centre.  body_couples = .false. leaves the rotational inertia
!> out of the frame terms (the thesis's point-mass centrifugal field, section 5.5).
module rotorcable_frame
  use rotorcable_kinds, only: dp
  use rotorcable_rotations, only: cross, rot_z, identity3
  use rotorcable_motion_rotor, only: rotor_state
  implicit none
  private
  public :: frame_type, frame_state, frame_at, relative_velocity, relative_acceleration

  !> The equations' frame.
  type :: frame_type
    logical :: hub = .false.                  !< hub frame turning with the rotor, else inertial
    logical :: body_couples = .true.          !< rotational inertia takes part in the frame terms
    real(dp) :: centre(3) = 0.0_dp            !< a point on the rotor axis (deck z) [m]
  end type frame_type

  !> The frame's motion at one time (all zero for the inertial frame).
  type :: frame_state
    logical :: rotating = .false.             !< omega or omega_dot nonzero
    logical :: body_couples = .true.          !< see frame_type
    real(dp) :: omega(3) = 0.0_dp             !< angular velocity [rad/s]
    real(dp) :: omega_dot(3) = 0.0_dp         !< angular acceleration [rad/s^2]
    real(dp) :: centre(3) = 0.0_dp            !< point on the axis [m]
    real(dp) :: rotation(3, 3) = reshape([1.0_dp, 0.0_dp, 0.0_dp, 0.0_dp, 1.0_dp, 0.0_dp, 0.0_dp, 0.0_dp, &
                                          1.0_dp], [3, 3])  !< inertial <- frame coordinates
  end type frame_state

contains

  !> The frame's state for the rotor state rs.
  pure function frame_at(f, rs) result(s)
    type(frame_type), intent(in) :: f         !< frame
    type(rotor_state), intent(in) :: rs       !< rotor angle, speed, acceleration
    type(frame_state) :: s
    s%body_couples = f%body_couples
    s%centre = f%centre
    if (.not. f%hub) return
    s%omega = [0.0_dp, 0.0_dp, rs%omega]
    s%omega_dot = [0.0_dp, 0.0_dp, rs%omega_dot]
    s%rotating = rs%omega /= 0.0_dp .or. rs%omega_dot /= 0.0_dp
    s%rotation = rot_z(rs%psi)
  end function frame_at

  !> Velocity relative to the frame of a point at x with absolute velocity v.
  pure function relative_velocity(s, x, v) result(v_rel)
    type(frame_state), intent(in) :: s        !< frame state
    real(dp), intent(in) :: x(3), v(3)        !< position [m], absolute velocity [m/s]
    real(dp) :: v_rel(3)
    v_rel = v
    if (s%rotating) v_rel = v - cross(s%omega, x - s%centre)
  end function relative_velocity

  !> Acceleration relative to the frame of a point at x (absolute acceleration a, relative
  !> velocity v_rel).
  pure function relative_acceleration(s, x, v_rel, a) result(a_rel)
    type(frame_state), intent(in) :: s        !< frame state
    real(dp), intent(in) :: x(3), v_rel(3), a(3)  !< position, relative velocity, absolute acceleration
    real(dp) :: a_rel(3), r(3)
    a_rel = a
    if (.not. s%rotating) return
    r = x - s%centre
    a_rel = a - 2.0_dp*cross(s%omega, v_rel) - cross(s%omega_dot, r) - cross(s%omega, cross(s%omega, r))
  end function relative_acceleration

end module rotorcable_frame
