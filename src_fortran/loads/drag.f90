!> Aerodynamic drag by the cross-flow principle (Hoerner, Fluid-Dynamic Drag, 1965, ch. 3;
!> the independence principle for yawed cylinders): only the air velocity normal to the body
!> axis loads it, F_j = 1/2 rho C_d d_j L_j |u_n| u_n, applied at the centre of mass, with
!>   u = V_inf - v_C,    u_n = u - (u . e) e,    e = body axis,
!> where V_inf is the free stream (inertial frame, turned into the model frame: in the hub
!> frame it rotates at -Omega) and v_C the body's absolute velocity, which already contains
!> the hub rotation's Omega x r; so u is the rotated free stream minus Omega x r minus the
!> body's own motion (issue 12).  One point per body (its CM): the force converges with n like
!> any midpoint rule; the moment of the velocity's variation along a turning body is left out.
!> Parameters: air_density [kg/m^3], stream(3) [m/s], cd (one per body).
module rotorcable_loads_drag
  use rotorcable_kinds, only: dp
  use rotorcable_errors, only: error_type
  use rotorcable_chain, only: chain_type
  use rotorcable_kinematics, only: chain_state, motion_seed
  use rotorcable_kinematics_tangent, only: chain_tangent
  use rotorcable_rotations, only: cross, skew
  use rotorcable_frame, only: frame_state
  use rotorcable_loads_type, only: load_term, load_slot
  use rotorcable_parameter_block, only: parameter_block, get_real, get_reals
  implicit none
  private
  public :: drag_load, new_drag

  !> Cross-flow drag.
  type, extends(load_term) :: drag_load
    real(dp) :: density = 1.225_dp            !< air density [kg/m^3]
    real(dp) :: stream(3) = 0.0_dp            !< free stream, inertial frame [m/s]
    real(dp), allocatable :: cd_area(:)       !< 1/2 rho C_d d_j L_j per body [kg/m]
    ! The state's factors of the tangent (linearise), shared by all the columns taken there:
    real(dp), allocatable :: axis(:, :)       !< (3,n) body axes e
    real(dp), allocatable :: air(:, :)        !< (3,n) u = stream - v_C [m/s]
    real(dp), allocatable :: normal_air(:, :) !< (3,n) u_n [m/s]
    real(dp), allocatable :: air_along(:)     !< (n) u . e [m/s]
    real(dp), allocatable :: normal_speed(:)  !< (n) |u_n| [m/s]
  contains
    procedure :: add_forces
    procedure :: conservative_at_rest
    procedure :: linearise
    procedure :: add_force_tangent
    procedure :: add_force_jacobians
  end type drag_load

contains

  !> Build from its parameter block: air_density rho [kg/m^3], stream V_inf(3) [m/s], cd C_d per body.
  subroutine new_drag(slot, chain, params, error)
    include 'constructor_arguments.inc'
    type(drag_load) :: load
    real(dp) :: cd(chain%n_bodies)
    call get_real(params, 'air_density', load%density, error)
    call get_reals(params, 'stream', load%stream, error)
    call get_reals(params, 'cd', cd, error)
    if (error%code /= 0) return
    load%label = 'drag'
    ! d_j = 2 R_j: the projected area per length of a cylinder in cross flow.
    load%cd_area = 0.5_dp*load%density*cd*2.0_dp*chain%radius*chain%length
    allocate (slot%term, source=load)
  end subroutine new_drag

  pure subroutine add_forces(self, chain, st, fs, t, q, v, force, moment, tau)
    class(drag_load), intent(in) :: self
    include 'force_arguments.inc'
    real(dp) :: stream(3), u(3), e(3)
    integer :: j
    stream = matmul(self%stream, fs%rotation)        ! R^T V_inf: inertial -> model frame
    do j = 1, chain%n_bodies
      e = st%rot(:, 3, j)
      u = stream - st%vel_cm(:, j)
      u = u - dot_product(u, e)*e
      force(:, j) = force(:, j) + self%cd_area(j)*norm2(u)*u
    end do
  end subroutine add_forces

  !> At rest relative to the model frame every body moves with the frame and the base: in still
  !> air (no stream), an inertial frame and a base at rest that is u = 0 on every body, so the
  !> drag vanishes at rest whatever the shape (a potential of 0); so does a drag of zero C_d or
  !> density.  In a turning frame or a stream it does not (the hover shape carries its drag).
  pure logical function conservative_at_rest(self, fs, seed) result(yes)
    class(drag_load), intent(in) :: self
    type(frame_state), intent(in) :: fs       !< the model frame's motion at the equilibrium's time
    type(motion_seed), intent(in) :: seed     !< the base's absolute motion at that time
    yes = all(self%cd_area == 0.0_dp)
    if (.not. yes) yes = all(self%stream == 0.0_dp) .and. .not. fs%rotating .and. all(seed%vel == 0.0_dp) &
                         .and. all(seed%omega == 0.0_dp)
  end function conservative_at_rest

  !> The tangent's state-only factors at the state (t, q, v) of st: each body's axis, air
  !> velocity and its normal part and size, formed once for all the columns taken there (a
  !> Jacobian's 44, 8 parameters x 2 corrector iterations) instead of per column.
  subroutine linearise(self, chain, st, fs, q, v)
    class(drag_load), intent(inout) :: self
    type(chain_type), intent(in) :: chain     !< chain description
    type(chain_state), intent(in) :: st       !< frames, velocities at the state
    type(frame_state), intent(in) :: fs       !< the model frame's motion at the state's time
    real(dp), intent(in) :: q(:), v(:)        !< coordinates [rad] and rates [rad/s] (not needed)
    real(dp) :: stream(3), u(3), e(3)
    integer :: j, n
    n = chain%n_bodies
    if (allocated(self%air_along)) then
      if (size(self%air_along) /= n) deallocate (self%axis, self%air, self%normal_air, self%air_along, self%normal_speed)
    end if
    if (.not. allocated(self%air_along)) allocate (self%axis(3, n), self%air(3, n), self%normal_air(3, n), &
                                                   self%air_along(n), self%normal_speed(n))
    stream = matmul(self%stream, fs%rotation)
    do j = 1, n
      e = st%rot(:, 3, j)
      u = stream - st%vel_cm(:, j)
      self%axis(:, j) = e
      self%air(:, j) = u
      self%air_along(j) = dot_product(u, e)
      self%normal_air(:, j) = u - dot_product(u, e)*e
      self%normal_speed(j) = norm2(self%normal_air(:, j))
    end do
  end subroutine linearise

  !> d(|u_n| u_n) = |u_n| du_n + (u_n . du_n / |u_n|) u_n with du = -dv_C (the stream is fixed at
  !> t) and de = dtheta x e: du_n = du - (du.e + u.de) e - (u.e) de.  |u_n| u_n is continuously
  !> differentiable at u_n = 0, where its derivative vanishes.  The state's factors from linearise.
  pure subroutine add_force_tangent(self, chain, st, dst, fs, t, q, v, dq, dv, dforce, dmoment, dtau)
    class(drag_load), intent(in) :: self
    include 'force_tangent_arguments.inc'
    call drag_tangent_pass(chain%n_bodies, dst%first, self%cd_area, self%axis, self%air, self%normal_air, &
                           self%air_along, self%normal_speed, dst%dtheta, dst%dvel_cm, dforce)
  end subroutine add_force_tangent

  !> add_force_tangent's formula as matrices: with D = d(|u_n| u_n)/du_n = |u_n| I + u_n u_n^T / |u_n|
  !> and P = I - e e^T, du_n = -P dv_C + (e (u x e)^T + (u . e) [e]) dtheta (de = -[e] dtheta,
  !> u . de = (u x e) . dtheta), so dF = -k D P dv_C + k D (e (u x e)^T + (u . e) [e]) dtheta.
  !> The state's factors from linearise.
  pure subroutine add_force_jacobians(self, chain, st, fs, t, q, v, pose, motion, joint_q, joint_v)
    class(drag_load), intent(in) :: self
    include 'force_jacobians_arguments.inc'
    real(dp) :: d(3, 3), p(3, 3), ue(3), e(3), un(3), size_un
    integer :: j, i
    do j = 1, chain%n_bodies
      size_un = self%normal_speed(j)
      if (.not. size_un > 0.0_dp) cycle
      e = self%axis(:, j)
      un = self%normal_air(:, j)
      ue = cross(self%air(:, j), e)
      do i = 1, 3
        d(:, i) = self%cd_area(j)*(un*un(i)/size_un)
        d(i, i) = d(i, i) + self%cd_area(j)*size_un
        p(:, i) = -e*e(i)
        p(i, i) = p(i, i) + 1.0_dp
      end do
      motion(1:3, 1:3, j) = motion(1:3, 1:3, j) - matmul(d, p)
      do i = 1, 3
        p(:, i) = e*ue(i)
      end do
      p = p + self%air_along(j)*skew(e)
      pose(1:3, 4:6, j) = pose(1:3, 4:6, j) + matmul(d, p)
    end do
  end subroutine add_force_jacobians

  !> add_force_tangent's loop on explicit-shape arrays (why: rotorcable_kinematics_tangent,
  !> motion_tangent_pass); the arithmetic of the formula above, in its order.
  pure subroutine drag_tangent_pass(n, first, cd_area, axis, air, normal_air, air_along, normal_speed, dtheta, &
                                    dvel_cm, dforce)
    integer, intent(in) :: n, first
    real(dp), intent(in) :: cd_area(n), axis(3, n), air(3, n), normal_air(3, n), air_along(n), normal_speed(n)
    real(dp), intent(in) :: dtheta(3, n), dvel_cm(3, n)
    real(dp), intent(inout) :: dforce(3, n)
    real(dp) :: u(3), e(3), de(3), du(3), un(3), dun(3), size_un
    integer :: j
    do j = first, n
      size_un = normal_speed(j)
      if (.not. size_un > 0.0_dp) cycle
      e = axis(:, j)
      u = air(:, j)
      un = normal_air(:, j)
      de = cross(dtheta(:, j), e)
      du = -dvel_cm(:, j)
      dun = du - (dot_product(du, e) + dot_product(u, de))*e - air_along(j)*de
      dforce(:, j) = dforce(:, j) + cd_area(j)*(size_un*dun + dot_product(un, dun)/size_un*un)
    end do
  end subroutine drag_tangent_pass

end module rotorcable_loads_drag
