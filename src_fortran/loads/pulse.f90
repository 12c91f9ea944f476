!> A rectangular force pulse on one body's centre of mass, thesis section 5.4 (decay test):
!> the force acts for t_start <= t < t_end; the integrator stops at both edges.
!> Parameters: ints = (body); reals = (F_x, F_y, F_z [N], t_start, t_end [s]).
module rotorcable_loads_pulse
  use rotorcable_kinds, only: dp
  use rotorcable_errors, only: error_type, fatal_error
  use rotorcable_chain, only: chain_type
  use rotorcable_kinematics, only: chain_state
  use rotorcable_kinematics_tangent, only: chain_tangent
  use rotorcable_frame, only: frame_state
  use rotorcable_loads_type, only: load_term, load_slot
  implicit none
  private
  public :: pulse_load, new_pulse

  !> Force pulse.
  type, extends(load_term) :: pulse_load
    integer :: body = 0                       !< loaded body
    real(dp) :: force(3) = 0.0_dp             !< force [N]
    real(dp) :: t_start = 0.0_dp              !< start [s]
    real(dp) :: t_end = 0.0_dp                !< end [s]
  contains
    procedure :: add_forces
    procedure :: add_force_tangent
    procedure :: switch_times
  end type pulse_load

contains

  !> Build from the flat parameters.
  subroutine new_pulse(slot, chain, ints, reals, error)
    type(load_slot), intent(inout) :: slot    !< slot to fill
    type(chain_type), intent(in) :: chain     !< chain description
    integer, intent(in) :: ints(:)            !< body index
    real(dp), intent(in) :: reals(:)          !< force [N], start, end [s]
    type(error_type), intent(inout) :: error  !< status
    type(pulse_load) :: load
    if (size(ints) /= 1 .or. size(reals) /= 5) then
      call fatal_error(error, 'a pulse needs its body, 3 force components, start and end')
      return
    end if
    if (ints(1) < 1 .or. ints(1) > chain%n_bodies) then
      call fatal_error(error, 'the pulse body is not a body of the chain')
      return
    end if
    if (.not. (reals(5) > reals(4))) then
      call fatal_error(error, 'the pulse must end after it starts')
      return
    end if
    load%label = 'pulse'
    load%body = ints(1)
    load%force = reals(1:3)
    load%t_start = reals(4)
    load%t_end = reals(5)
    allocate (slot%term, source=load)
  end subroutine new_pulse

  pure subroutine add_forces(self, chain, st, fs, t, q, v, force, moment, tau)
    class(pulse_load), intent(in) :: self
    type(chain_type), intent(in) :: chain
    type(chain_state), intent(in) :: st
    type(frame_state), intent(in) :: fs
    real(dp), intent(in) :: t, q(:), v(:)
    real(dp), intent(inout) :: force(:, :), moment(:, :), tau(:)
    if (t >= self%t_start .and. t < self%t_end) force(:, self%body) = force(:, self%body) + self%force
  end subroutine add_forces

  pure subroutine add_force_tangent(self, chain, st, dst, fs, t, q, v, dq, dv, dforce, dmoment, dtau)
    class(pulse_load), intent(in) :: self
    type(chain_type), intent(in) :: chain
    type(chain_state), intent(in) :: st
    type(chain_tangent), intent(in) :: dst
    type(frame_state), intent(in) :: fs
    real(dp), intent(in) :: t, q(:), v(:), dq(:), dv(:)
    real(dp), intent(inout) :: dforce(:, :), dmoment(:, :), dtau(:)
    ! A constant force at the CM: no change (its lever arm is the Newton-Euler tangent's).
  end subroutine add_force_tangent

  pure subroutine switch_times(self, times)
    class(pulse_load), intent(in) :: self
    real(dp), allocatable, intent(out) :: times(:)
    times = [self%t_start, self%t_end]
  end subroutine switch_times

end module rotorcable_loads_pulse
