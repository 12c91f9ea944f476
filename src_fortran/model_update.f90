!> Models that update (issue 23 item 2): a named parameter of a built model changed in place,
!> so that an analysis that varies it (the Campbell diagram's rotor speed, the statics of a deck
!> with a pulse, a spring study) changes one number instead of rebuilding the model from its
!> deck.  The parameters, each owned by one component:
!>
!>   rotor.omega        constant rotor speed [rad/s]       rotorcable_motion_rotor
!>   loads.pulse        force pulse on (1) or off (0)      rotorcable_loads_pulse
!>   springs.stiffness  joint spring constants [Nm/rad]    rotorcable_loads_joint_springs,
!>   springs.damping    joint damper constants [Nms/rad]   rotorcable_loads_rotation_springs
!>
!> A load declares its own parameters (load_term%set_parameter); the rotor's speed is the
!> model's.  After a change nothing prepared for the old value may remain: the time-dependent
!> state of model_prepare (rotor state, frame motion, support poses) and the workspace record
!> (what model%st and the forces hold) are marked stale (model_stale).
module rotorcable_model_update
  use rotorcable_kinds, only: dp
  use rotorcable_errors, only: error_type, fatal_error
  use rotorcable_model, only: model_type, model_stale
  use rotorcable_motion_rotor, only: change_constant_speed, ROTOR_CONSTANT, ROTOR_STILL
  implicit none
  private
  public :: update_parameter, parameter_value

  !> For the message of a name that no component owns.
  character(len=*), parameter :: UPDATABLE = 'rotor.omega, loads.pulse, springs.stiffness, springs.damping'

contains

  !> Change the parameter `name` of a built model to `values`; an error naming the parameter if
  !> no component of the model has it or the value does not fit.
  subroutine update_parameter(model, name, values, error)
    type(model_type), intent(inout) :: model  !< built model
    character(len=*), intent(in) :: name      !< parameter name (see the module's table)
    real(dp), intent(in) :: values(:)         !< new value(s)
    type(error_type), intent(inout) :: error  !< status
    type(error_type) :: why
    logical :: found, any_found
    integer :: i
    any_found = .false.
    if (name == 'rotor.omega') then
      any_found = .true.
      if (size(values) /= 1) then
        call fatal_error(why, 'takes one value [rad/s]')
      else
        call change_constant_speed(model%rotor, values(1), why)
      end if
    else
      do i = 1, size(model%loads)
        call model%loads(i)%term%set_parameter(name, values, found, why)
        any_found = any_found .or. found
      end do
    end if
    if (.not. any_found) then
      call fatal_error(error, 'model parameter '''//name//''': no component of this model has it (parameters '// &
                       'that update: '//UPDATABLE//')')
    else if (why%code /= 0) then
      call fatal_error(error, 'model parameter '''//name//''': '//why%message)
    end if
    ! Whatever happened, nothing prepared before the call is trusted after it.
    call model_stale(model)
  end subroutine update_parameter

  !> The current value of the parameter `name` (for a caller that restores it afterwards).
  subroutine parameter_value(model, name, values, error)
    type(model_type), intent(in) :: model     !< built model
    character(len=*), intent(in) :: name      !< parameter name
    real(dp), allocatable, intent(out) :: values(:)  !< its value(s)
    type(error_type), intent(inout) :: error  !< status
    logical :: found
    integer :: i
    allocate (values(0))
    if (name == 'rotor.omega') then
      if (model%rotor%given .and. (model%rotor%kind == ROTOR_CONSTANT .or. model%rotor%kind == ROTOR_STILL)) then
        values = [model%rotor%omega_0]
      else
        call fatal_error(error, 'model parameter ''rotor.omega'': the model has no rotor of constant speed')
      end if
      return
    end if
    do i = 1, size(model%loads)
      call model%loads(i)%term%get_parameter(name, values, found)
      if (found) return
    end do
    call fatal_error(error, 'model parameter '''//name//''': no component of this model has it (parameters '// &
                     'that update: '//UPDATABLE//')')
  end subroutine parameter_value

end module rotorcable_model_update
