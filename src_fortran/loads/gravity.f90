!> Weight m_j g at every centre of mass, eq. 4.46; potential -sum m_j g . C_j.
!> Parameters: g(3) [m/s^2] in the model frame (the rotor axis is vertical,
!> so gravity is constant in the hub frame too).
module rotorcable_loads_gravity
  use rotorcable_kinds, only: dp
  use rotorcable_errors, only: error_type
  use rotorcable_chain, only: chain_type
  use rotorcable_kinematics, only: chain_state
  use rotorcable_kinematics_tangent, only: chain_tangent
  use rotorcable_frame, only: frame_state
  use rotorcable_loads_type, only: load_term, load_slot
  use rotorcable_parameter_block, only: parameter_block, get_reals
  implicit none
  private
  public :: gravity_load, new_gravity

  !> Uniform gravity field.
  type, extends(load_term) :: gravity_load
    real(dp) :: g(3) = 0.0_dp                 !< gravitational acceleration [m/s^2]
  contains
    procedure :: add_forces
    procedure :: add_force_tangent
    procedure :: add_force_jacobians
    procedure :: potential
  end type gravity_load

contains

  !> Build from its parameter block: g(3) [m/s^2].
  subroutine new_gravity(slot, chain, params, error)
    include 'constructor_arguments.inc'
    type(gravity_load) :: load
    call get_reals(params, 'g', load%g, error)
    if (error%code /= 0) return
    load%label = 'gravity'
    load%conservative = .true.
    allocate (slot%term, source=load)
  end subroutine new_gravity

  pure subroutine add_forces(self, chain, st, fs, t, q, v, force, moment, tau)
    class(gravity_load), intent(in) :: self
    include 'force_arguments.inc'
    integer :: j
    do j = 1, chain%n_bodies
      force(:, j) = force(:, j) + chain%mass(j)*self%g
    end do
  end subroutine add_forces

  pure subroutine add_force_tangent(self, chain, st, dst, fs, t, q, v, dq, dv, dforce, dmoment, dtau)
    class(gravity_load), intent(in) :: self
    include 'force_tangent_arguments.inc'
    ! m g at the CM does not change; its moment about the joint point moves with the CM, which
    ! the Newton-Euler tangent takes care of.
  end subroutine add_force_tangent

  pure subroutine add_force_jacobians(self, chain, st, fs, t, q, v, pose, motion, joint_q, joint_v)
    class(gravity_load), intent(in) :: self
    include 'force_jacobians_arguments.inc'
    ! The same constant force at the CM, whichever way the body moves (its turn against a world-fixed
    ! m g is the caller's: the force's value is all it needs).
  end subroutine add_force_jacobians

  pure real(dp) function potential(self, chain, st, q) result(e)
    class(gravity_load), intent(in) :: self
    include 'potential_arguments.inc'
    integer :: j
    e = 0.0_dp
    do j = 1, chain%n_bodies
      e = e - chain%mass(j)*dot_product(self%g, st%cm(:, j))
    end do
  end function potential

end module rotorcable_loads_gravity
