!> The load interface: every applied load of a scene (gravity, a force pulse, a tip force,
!> joint springs and dampers, aerodynamic drag, ...) is one type extending load_term, in a file
!> of its own (modelled on tblite's container_type, src/tblite/container/type.f90).
!>
!> A load adds forces and moments at the bodies' centres of mass and/or generalized forces on
!> the coordinates, at a kinematic state and a time; it may have a potential (for the energy
!> balance), discontinuities in time (where the integrator must stop and restart), and a
!> constant diagonal joint-space stiffness and damping (what a chain factorisation of the
!> iteration matrix can use exactly; rotorcable_chain_linear_solver).  Before the tangents at
!> a state the model calls linearise once, so that a load may keep what its tangent needs at
!> that state (its trigonometry, or the whole linear map) for all the columns taken there.
module rotorcable_loads_type
  use rotorcable_kinds, only: dp
  use rotorcable_errors, only: error_type
  use rotorcable_chain, only: chain_type
  use rotorcable_kinematics, only: chain_state, motion_seed
  use rotorcable_kinematics_tangent, only: chain_tangent
  use rotorcable_frame, only: frame_state
  implicit none
  private
  public :: load_term, load_slot

  !> One load of a scene.
  type, abstract :: load_term
    character(len=32) :: label = ''           !< name for messages and documentation
    !> The load is conservative with its potential (the energy balance counts it as stored, not
    !> as work done); its constructor says so.
    logical :: conservative = .false.
    !> The load's forces depend on the chain's bodies (their masses, radii) beyond its own
    !> parameters: a design parameter that changes the bodies changes them (gravity, drag).  A
    !> load that reads only the joints' angles and rates and its own constants says .false. in
    !> its constructor, and a difference over models with other bodies skips it when its own
    !> parameters are the same (rotorcable_parameter_sensitivity, bodies_partial).
    logical :: depends_on_bodies = .true.
  contains
    !> Add the load's forces at the state (st: frames and absolute velocities) and time t.
    procedure(add_forces_interface), deferred :: add_forces
    !> Add the first-order change of those forces for a change of the state: dst (frames, points,
    !> velocities of rotorcable_kinematics_tangent) and dq, dv; the analytic Jacobian.  Every
    !> load states its own derivative: a new load is not complete without it.
    procedure(add_force_tangent_interface), deferred :: add_force_tangent
    !> Add the same derivatives as matrices, for the Jacobian taken whole
    !> (rotorcable_model_derivatives): for every body, its forces' derivatives by the body's own
    !> pose and motion, and for every joint, its generalized forces' derivatives by the joint's
    !> own coordinates and rates (force_jacobians_arguments.inc).  A load's force on a body
    !> depends on that body's motion alone, and its generalized forces on their joint's alone:
    !> every load of the registry does (a load coupling bodies would need a matrix of its own).
    !> Called after linearise at the same state.
    procedure(add_force_jacobians_interface), deferred :: add_force_jacobians
    !> Potential energy at the frames in st (0 if the load has none, see has_potential).
    procedure :: potential => no_potential
    !> Whether the load is conservative with the potential above (its `conservative` flag).
    procedure, non_overridable :: has_potential
    !> Whether the load's forces at rest relative to the model frame (v = 0) are those of its
    !> potential, for the frame's motion fs and the base's absolute motion seed at the time of
    !> an equilibrium: what the static solver's merit function needs (rotorcable_statics).  By
    !> default the `conservative` flag; a load that is not conservative in motion but vanishes
    !> at rest (drag in still air, a pulse of zero force) says so, so that its presence does not
    !> change the static solver's path (issue 35: still-air drag had sent the UH-60 part 2
    !> equilibrium to another, unstable one).
    procedure :: conservative_at_rest => potential_at_rest
    !> Times at which the load jumps (the integrator stops exactly there and restarts).
    procedure :: switch_times => no_switch_times
    !> Constant diagonal joint-space stiffness and damping contributed by the load.
    procedure :: joint_diagonal => no_joint_diagonal
    !> Change a named parameter in place (a model that updates instead of being rebuilt,
    !> rotorcable_model_update); found = .false. if the load has no parameter of that name.
    procedure :: set_parameter => no_set_parameter
    procedure :: linearise => no_linearise
    !> The current value of a named parameter; found = .false. if the load has none of that name.
    procedure :: get_parameter => no_get_parameter
  end type load_term

  !> Holder of one polymorphic load (an array of these is the model's load list).
  type :: load_slot
    class(load_term), allocatable :: term
  end type load_slot

  abstract interface
    !> Add forces (3,n) and moments (3,n) at the centres of mass and generalized forces tau (nq).
    pure subroutine add_forces_interface(self, chain, st, fs, t, q, v, force, moment, tau)
      import :: load_term, chain_type, chain_state, frame_state, dp
      class(load_term), intent(in) :: self    !< the load
      include 'force_arguments.inc'
    end subroutine add_forces_interface

    !> Add d(force), d(moment) (3,n) and d(tau) (nq) for the change (dst, dq, dv) at (st, t).
    pure subroutine add_force_tangent_interface(self, chain, st, dst, fs, t, q, v, dq, dv, dforce, dmoment, dtau)
      import :: load_term, chain_type, chain_state, chain_tangent, frame_state, dp
      class(load_term), intent(in) :: self    !< the load
      include 'force_tangent_arguments.inc'
    end subroutine add_force_tangent_interface

    !> Add d(force, moment)/d(pose), /d(motion) (6,6,n) and the joints' d(tau)/dq, d(tau)/dv
    !> (3,3,n) at (st, t).
    pure subroutine add_force_jacobians_interface(self, chain, st, fs, t, q, v, pose, motion, joint_q, joint_v)
      import :: load_term, chain_type, chain_state, frame_state, dp
      class(load_term), intent(in) :: self    !< the load
      include 'force_jacobians_arguments.inc'
    end subroutine add_force_jacobians_interface
  end interface

contains

  pure real(dp) function no_potential(self, chain, st, q) result(e)
    class(load_term), intent(in) :: self      !< the load
    include 'potential_arguments.inc'
    e = 0.0_dp
  end function no_potential

  pure logical function has_potential(self)
    class(load_term), intent(in) :: self      !< the load
    has_potential = self%conservative
  end function has_potential

  pure logical function potential_at_rest(self, fs, seed) result(yes)
    class(load_term), intent(in) :: self      !< the load
    type(frame_state), intent(in) :: fs       !< the model frame's motion at the equilibrium's time
    type(motion_seed), intent(in) :: seed     !< the base's absolute motion at that time
    yes = self%conservative
  end function potential_at_rest

  pure subroutine no_switch_times(self, times)
    class(load_term), intent(in) :: self      !< the load
    real(dp), allocatable, intent(out) :: times(:)  !< switching times [s]
    allocate (times(0))
  end subroutine no_switch_times

  pure subroutine no_joint_diagonal(self, stiffness, damping)
    class(load_term), intent(in) :: self      !< the load
    real(dp), intent(inout) :: stiffness(:)   !< (nq) diagonal stiffness to add to [Nm/rad]
    real(dp), intent(inout) :: damping(:)     !< (nq) diagonal damping to add to [Nms/rad]
  end subroutine no_joint_diagonal

  !> Keep what add_force_tangent needs at the state (t, q, v) of st: nothing, by default.
  subroutine no_linearise(self, chain, st, fs, q, v)
    class(load_term), intent(inout) :: self   !< the load
    type(chain_type), intent(in) :: chain     !< chain description
    type(chain_state), intent(in) :: st       !< frames, velocities at the state
    type(frame_state), intent(in) :: fs       !< the model frame's motion at the state's time
    real(dp), intent(in) :: q(:), v(:)        !< coordinates [rad] and rates [rad/s]
  end subroutine no_linearise

  subroutine no_set_parameter(self, name, values, found, error)
    class(load_term), intent(inout) :: self   !< the load
    include 'set_parameter_arguments.inc'
    found = .false.
  end subroutine no_set_parameter

  subroutine no_get_parameter(self, name, values, found)
    class(load_term), intent(in) :: self      !< the load
    include 'get_parameter_arguments.inc'
    allocate (values(0))
    found = .false.
  end subroutine no_get_parameter

end module rotorcable_loads_type
