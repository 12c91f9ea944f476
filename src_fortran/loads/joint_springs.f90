!> Linear torsion springs and viscous dampers on every joint coordinate, eq. 4.78-4.86.  A
!> torque pair along a joint axis does power only on that axis's own rate, so the spring
!> moments project onto the coordinates diagonally: Q = -c (q - q_rest) - d qdot; potential
!> sum c (q - q_rest)^2 / 2.  Parameters: stiffness, damping, rest (nq each).
!> Updatable: 'springs.stiffness' c(1:nq), 'springs.damping' d(1:nq) (rotorcable_loads_spring_constants).
module rotorcable_loads_joint_springs
  use rotorcable_kinds, only: dp
  use rotorcable_errors, only: error_type
  use rotorcable_chain, only: chain_type
  use rotorcable_kinematics, only: chain_state
  use rotorcable_kinematics_tangent, only: chain_tangent
  use rotorcable_frame, only: frame_state
  use rotorcable_loads_type, only: load_term, load_slot
  use rotorcable_parameter_block, only: parameter_block, get_reals
  use rotorcable_loads_spring_constants, only: set_spring_constants, get_spring_constants
  implicit none
  private
  public :: joint_springs_load, new_joint_springs

  !> Springs and dampers per coordinate.
  type, extends(load_term) :: joint_springs_load
    real(dp), allocatable :: stiffness(:)     !< c [Nm/rad]
    real(dp), allocatable :: damping(:)       !< d [Nms/rad]
    real(dp), allocatable :: rest(:)          !< q_rest [rad]
  contains
    procedure :: add_forces
    procedure :: add_force_tangent
    procedure :: add_force_jacobians
    procedure :: potential
    procedure :: joint_diagonal
    procedure :: set_parameter
    procedure :: get_parameter
  end type joint_springs_load

contains

  !> Build from its parameter block: stiffness c [Nm/rad], damping d [Nms/rad], rest q_rest [rad],
  !> one value per coordinate each.
  subroutine new_joint_springs(slot, chain, params, error)
    include 'constructor_arguments.inc'
    type(joint_springs_load) :: load
    integer :: nq
    nq = chain%n_coords
    allocate (load%stiffness(nq), load%damping(nq), load%rest(nq))
    call get_reals(params, 'stiffness', load%stiffness, error)
    call get_reals(params, 'damping', load%damping, error)
    call get_reals(params, 'rest', load%rest, error)
    if (error%code /= 0) return
    load%label = 'joint springs'
    load%conservative = .true.
    load%depends_on_bodies = .false.   ! the joints' angles and rates and its own constants only
    allocate (slot%term, source=load)
  end subroutine new_joint_springs

  pure subroutine add_forces(self, chain, st, fs, t, q, v, force, moment, tau)
    class(joint_springs_load), intent(in) :: self
    include 'force_arguments.inc'
    tau = tau - self%stiffness*(q - self%rest) - self%damping*v
  end subroutine add_forces

  pure subroutine add_force_tangent(self, chain, st, dst, fs, t, q, v, dq, dv, dforce, dmoment, dtau)
    class(joint_springs_load), intent(in) :: self
    include 'force_tangent_arguments.inc'
    dtau = dtau - self%stiffness*dq - self%damping*dv
  end subroutine add_force_tangent

  pure subroutine add_force_jacobians(self, chain, st, fs, t, q, v, pose, motion, joint_q, joint_v)
    class(joint_springs_load), intent(in) :: self
    include 'force_jacobians_arguments.inc'
    integer :: j, l, k
    do j = 1, chain%n_bodies
      do l = 1, chain%n_joint_coords(j)
        k = chain%first_coord(j) + l - 1
        joint_q(l, l, j) = joint_q(l, l, j) - self%stiffness(k)
        joint_v(l, l, j) = joint_v(l, l, j) - self%damping(k)
      end do
    end do
  end subroutine add_force_jacobians

  pure real(dp) function potential(self, chain, st, q) result(e)
    class(joint_springs_load), intent(in) :: self
    include 'potential_arguments.inc'
    e = 0.5_dp*sum(self%stiffness*(q - self%rest)**2)
  end function potential

  pure subroutine joint_diagonal(self, stiffness, damping)
    class(joint_springs_load), intent(in) :: self
    real(dp), intent(inout) :: stiffness(:), damping(:)
    stiffness = stiffness + self%stiffness
    damping = damping + self%damping
  end subroutine joint_diagonal

  !> 'springs.stiffness' or 'springs.damping': every entry is a coordinate's.
  subroutine set_parameter(self, name, values, found, error)
    class(joint_springs_load), intent(inout) :: self
    include 'set_parameter_arguments.inc'
    call set_spring_constants(name, values, spread(.true., 1, size(self%stiffness)), self%stiffness, self%damping, &
                              found, error)
  end subroutine set_parameter

  subroutine get_parameter(self, name, values, found)
    class(joint_springs_load), intent(in) :: self
    include 'get_parameter_arguments.inc'
    call get_spring_constants(name, spread(.true., 1, size(self%stiffness)), self%stiffness, self%damping, values, found)
  end subroutine get_parameter

end module rotorcable_loads_joint_springs
