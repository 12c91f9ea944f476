!> A constant force at the free tip P_{n+1} of an open chain (the cantilever check): applied
!> to the last body as the force at its CM plus the moment (P_{n+1} - C_n) x F; potential
!> -F . P_{n+1}.  Parameters: force(3) [N].
module rotorcable_loads_tip_force
  use rotorcable_kinds, only: dp
  use rotorcable_errors, only: error_type
  use rotorcable_chain, only: chain_type
  use rotorcable_kinematics, only: chain_state
  use rotorcable_kinematics_tangent, only: chain_tangent
  use rotorcable_frame, only: frame_state
  use rotorcable_rotations, only: cross, skew
  use rotorcable_loads_type, only: load_term, load_slot
  use rotorcable_parameter_block, only: parameter_block, get_reals
  implicit none
  private
  public :: tip_force_load, new_tip_force

  !> Constant tip force.
  type, extends(load_term) :: tip_force_load
    real(dp) :: force(3) = 0.0_dp             !< force [N]
  contains
    procedure :: add_forces
    procedure :: add_force_tangent
    procedure :: add_force_jacobians
    procedure :: potential
  end type tip_force_load

contains

  !> Build from its parameter block: force(3) [N].
  subroutine new_tip_force(slot, chain, params, error)
    include 'constructor_arguments.inc'
    type(tip_force_load) :: load
    call get_reals(params, 'force', load%force, error)
    if (error%code /= 0) return
    load%label = 'tip force'
    load%conservative = .true.
    allocate (slot%term, source=load)
  end subroutine new_tip_force

  pure subroutine add_forces(self, chain, st, fs, t, q, v, force, moment, tau)
    class(tip_force_load), intent(in) :: self
    include 'force_arguments.inc'
    real(dp) :: arm(3)
    integer :: n
    n = chain%n_bodies
    arm = st%joint_point(:, n + 1) - st%cm(:, n)
    force(:, n) = force(:, n) + self%force
    moment(:, n) = moment(:, n) + cross(arm, self%force)
  end subroutine add_forces

  pure subroutine add_force_tangent(self, chain, st, dst, fs, t, q, v, dq, dv, dforce, dmoment, dtau)
    class(tip_force_load), intent(in) :: self
    include 'force_tangent_arguments.inc'
    real(dp) :: darm(3)
    integer :: n
    ! d((P_{n+1} - C_n) x F): the arm turns with the last body.
    n = chain%n_bodies
    darm = dst%djoint_point(:, n + 1) - dst%dcm(:, n)
    dmoment(:, n) = dmoment(:, n) + cross(darm, self%force)
  end subroutine add_force_tangent

  !> The moment (P_{n+1} - C_n) x F turns with the last body: d = (dtheta x r) x F = [F] [r] dtheta.
  pure subroutine add_force_jacobians(self, chain, st, fs, t, q, v, pose, motion, joint_q, joint_v)
    class(tip_force_load), intent(in) :: self
    include 'force_jacobians_arguments.inc'
    integer :: n
    n = chain%n_bodies
    pose(4:6, 4:6, n) = pose(4:6, 4:6, n) + matmul(skew(self%force), skew(st%joint_point(:, n + 1) - st%cm(:, n)))
  end subroutine add_force_jacobians

  pure real(dp) function potential(self, chain, st, q) result(e)
    class(tip_force_load), intent(in) :: self
    include 'potential_arguments.inc'
    e = -dot_product(self%force, st%joint_point(:, chain%n_bodies + 1))
  end function potential

end module rotorcable_loads_tip_force
