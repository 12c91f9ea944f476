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
  use rotorcable_kinematics, only: chain_state
  use rotorcable_kinematics_tangent, only: chain_tangent
  use rotorcable_rotations, only: cross
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
  contains
    procedure :: add_forces
    procedure :: add_force_tangent
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

  !> d(|u_n| u_n) = |u_n| du_n + (u_n . du_n / |u_n|) u_n with du = -dv_C (the stream is fixed at
  !> t) and de = dtheta x e: du_n = du - (du.e + u.de) e - (u.e) de.  |u_n| u_n is continuously
  !> differentiable at u_n = 0, where its derivative vanishes.
  pure subroutine add_force_tangent(self, chain, st, dst, fs, t, q, v, dq, dv, dforce, dmoment, dtau)
    class(drag_load), intent(in) :: self
    include 'force_tangent_arguments.inc'
    real(dp) :: stream(3), u(3), e(3), de(3), du(3), un(3), dun(3), th(3), size_un
    integer :: j
    stream = matmul(self%stream, fs%rotation)
    do j = dst%first, chain%n_bodies
      e = st%rot(:, 3, j)
      th = dst%dtheta(:, j)
      de = cross(th, e)
      u = stream - st%vel_cm(:, j)
      du = -dst%dvel_cm(:, j)
      un = u - dot_product(u, e)*e
      size_un = norm2(un)
      if (.not. size_un > 0.0_dp) cycle
      dun = du - (dot_product(du, e) + dot_product(u, de))*e - dot_product(u, e)*de
      dforce(:, j) = dforce(:, j) + self%cd_area(j)*(size_un*dun + dot_product(un, dun)/size_un*un)
    end do
  end subroutine add_force_tangent

end module rotorcable_loads_drag
