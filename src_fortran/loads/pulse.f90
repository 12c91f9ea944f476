!> A rectangular force pulse on one body's centre of mass, thesis section 5.4 (decay test):
!> the force acts for t_start <= t < t_end; the integrator stops at both edges.
!> Parameters: body (integer), force(3) [N], t_start, t_end [s].
!> Updatable: 'loads.pulse' (1 on, 0 off).  A pulse switched off adds nothing and has no switch
!> times, so the model is the one built without it (statics and modes of the steady loads).
module rotorcable_loads_pulse
  use rotorcable_kinds, only: dp
  use rotorcable_errors, only: error_type, fatal_error
  use rotorcable_chain, only: chain_type
  use rotorcable_kinematics, only: chain_state
  use rotorcable_kinematics_tangent, only: chain_tangent
  use rotorcable_frame, only: frame_state
  use rotorcable_loads_type, only: load_term, load_slot
  use rotorcable_parameter_block, only: parameter_block, get_real, get_reals, get_int
  implicit none
  private
  public :: pulse_load, new_pulse

  !> Force pulse.
  type, extends(load_term) :: pulse_load
    integer :: body = 0                       !< loaded body
    real(dp) :: force(3) = 0.0_dp             !< force [N]
    real(dp) :: t_start = 0.0_dp              !< start [s]
    real(dp) :: t_end = 0.0_dp                !< end [s]
    logical :: enabled = .true.               !< switched on ('loads.pulse')
  contains
    procedure :: add_forces
    procedure :: add_force_tangent
    procedure :: add_force_jacobians
    procedure :: switch_times
    procedure :: set_parameter
    procedure :: get_parameter
  end type pulse_load

contains

  !> Build from its parameter block: body, force(3) [N], t_start, t_end [s].
  subroutine new_pulse(slot, chain, params, error)
    include 'constructor_arguments.inc'
    type(pulse_load) :: load
    call get_int(params, 'body', load%body, error)
    call get_reals(params, 'force', load%force, error)
    call get_real(params, 't_start', load%t_start, error)
    call get_real(params, 't_end', load%t_end, error)
    if (error%code /= 0) return
    if (load%body < 1 .or. load%body > chain%n_bodies) then
      call fatal_error(error, 'the pulse body is not a body of the chain')
      return
    end if
    if (.not. (load%t_end > load%t_start)) then
      call fatal_error(error, 'the pulse must end after it starts')
      return
    end if
    load%label = 'pulse'
    ! A pulse of zero force is no load (issue 35: a load that is zero changes nothing): no
    ! switch times, conservative with potential 0.
    load%conservative = .not. acts(load)
    allocate (slot%term, source=load)
  end subroutine new_pulse

  pure subroutine add_forces(self, chain, st, fs, t, q, v, force, moment, tau)
    class(pulse_load), intent(in) :: self
    include 'force_arguments.inc'
    if (.not. self%enabled) return
    if (t >= self%t_start .and. t < self%t_end) force(:, self%body) = force(:, self%body) + self%force
  end subroutine add_forces

  pure subroutine add_force_tangent(self, chain, st, dst, fs, t, q, v, dq, dv, dforce, dmoment, dtau)
    class(pulse_load), intent(in) :: self
    include 'force_tangent_arguments.inc'
    ! A constant force at the CM: no change (its lever arm is the Newton-Euler tangent's).
  end subroutine add_force_tangent

  pure subroutine add_force_jacobians(self, chain, st, fs, t, q, v, pose, motion, joint_q, joint_v)
    class(pulse_load), intent(in) :: self
    include 'force_jacobians_arguments.inc'
    ! A constant force at the CM: no change (as add_force_tangent).
  end subroutine add_force_jacobians

  pure subroutine switch_times(self, times)
    class(pulse_load), intent(in) :: self
    real(dp), allocatable, intent(out) :: times(:)
    if (acts(self)) then
      times = [self%t_start, self%t_end]
    else
      allocate (times(0))
    end if
  end subroutine switch_times

  !> 'loads.pulse': 1 switches the pulse on, 0 off.
  subroutine set_parameter(self, name, values, found, error)
    class(pulse_load), intent(inout) :: self
    include 'set_parameter_arguments.inc'
    found = name == 'loads.pulse'
    if (.not. found) return
    if (size(values) /= 1) then
      call fatal_error(error, 'model parameter ''loads.pulse'' takes one value (1 on, 0 off)')
    else if (values(1) /= 0.0_dp .and. values(1) /= 1.0_dp) then
      call fatal_error(error, 'model parameter ''loads.pulse'' is 1 (on) or 0 (off)')
    else
      self%enabled = values(1) == 1.0_dp
      ! A pulse switched off is conservative with potential 0 (load_term's default), so that a
      ! model with its pulse off is, to the statics' merit function too, the model built without it.
      self%conservative = .not. acts(self)
    end if
  end subroutine set_parameter

  !> Whether the pulse puts a force on the chain at all: switched on and of nonzero force.
  pure logical function acts(self)
    class(pulse_load), intent(in) :: self
    acts = self%enabled .and. any(self%force /= 0.0_dp)
  end function acts

  subroutine get_parameter(self, name, values, found)
    class(pulse_load), intent(in) :: self
    include 'get_parameter_arguments.inc'
    found = name == 'loads.pulse'
    if (found) then
      values = [merge(1.0_dp, 0.0_dp, self%enabled)]
    else
      allocate (values(0))
    end if
  end subroutine get_parameter

end module rotorcable_loads_pulse
