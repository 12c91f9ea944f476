!> Handles for the objects that live between calls from Python: built models and integration
!> sessions (dftd4's api.f90 hands out C pointers; f2py cannot pass pointers, so the handle
!> is an integer index into this registry).
!>
!> This is the one place with module state, on purpose: an object built once must outlive the
!> call that built it.  Handles are never reused within a process, so a stale handle is an
!> error, not another object; the registry is only touched from Python calls, which hold the GIL.
module rotorcable_model_registry
  use rotorcable_model, only: model_type, model_free
  use rotorcable_dae_integrator, only: dae_session, session_end
  implicit none
  private
  public :: register_model, lookup_model, release_model, register_session, lookup_session, release_session, &
            open_sessions

  type :: model_slot
    type(model_type), pointer :: model => null()
  end type model_slot

  type :: session_slot
    type(dae_session), pointer :: session => null()
    integer :: model_handle = 0               !< the model the session integrates
  end type session_slot

  type(model_slot), allocatable, save :: models(:)
  type(session_slot), allocatable, save :: sessions(:)

contains

  !> A new, empty model and its handle.
  subroutine register_model(model, handle)
    type(model_type), pointer, intent(out) :: model  !< the new model
    integer, intent(out) :: handle            !< its handle
    type(model_slot), allocatable :: grown(:)
    if (.not. allocated(models)) allocate (models(0))
    allocate (grown(size(models) + 1))
    grown(1:size(models)) = models
    call move_alloc(grown, models)
    allocate (model)
    handle = size(models)
    models(handle)%model => model
  end subroutine register_model

  !> The model of a handle (null if there is none).
  function lookup_model(handle) result(model)
    integer, intent(in) :: handle             !< handle
    type(model_type), pointer :: model
    model => null()
    if (.not. allocated(models)) return
    if (handle < 1 .or. handle > size(models)) return
    model => models(handle)%model
  end function lookup_model

  !> Free a model (and any session still integrating it).
  subroutine release_model(handle)
    integer, intent(in) :: handle             !< handle
    type(model_type), pointer :: model
    integer :: i
    model => lookup_model(handle)
    if (.not. associated(model)) return
    if (allocated(sessions)) then
      do i = 1, size(sessions)
        if (sessions(i)%model_handle == handle) call release_session(i)
      end do
    end if
    call model_free(model)
    deallocate (model)
    models(handle)%model => null()
  end subroutine release_model

  !> A new, empty session for the model `model_handle`, and its handle.
  subroutine register_session(model_handle, session, handle)
    integer, intent(in) :: model_handle       !< the model integrated
    type(dae_session), pointer, intent(out) :: session  !< the new session
    integer, intent(out) :: handle            !< its handle
    type(session_slot), allocatable :: grown(:)
    if (.not. allocated(sessions)) allocate (sessions(0))
    allocate (grown(size(sessions) + 1))
    grown(1:size(sessions)) = sessions
    call move_alloc(grown, sessions)
    allocate (session)
    handle = size(sessions)
    sessions(handle)%session => session
    sessions(handle)%model_handle = model_handle
  end subroutine register_session

  !> The session of a handle (null if there is none).
  function lookup_session(handle) result(session)
    integer, intent(in) :: handle             !< handle
    type(dae_session), pointer :: session
    session => null()
    if (.not. allocated(sessions)) return
    if (handle < 1 .or. handle > size(sessions)) return
    session => sessions(handle)%session
  end function lookup_session

  !> End and free a session.
  subroutine release_session(handle)
    integer, intent(in) :: handle             !< handle
    type(dae_session), pointer :: session
    session => lookup_session(handle)
    if (.not. associated(session)) return
    call session_end(session)
    deallocate (session)
    sessions(handle)%session => null()
    sessions(handle)%model_handle = 0
  end subroutine release_session

  !> How many sessions are integrating the model `model_handle` (a model must not change under
  !> a running integration: its switch times and iteration matrix were taken from the old one).
  integer function open_sessions(model_handle) result(n)
    integer, intent(in) :: model_handle       !< the model
    integer :: i
    n = 0
    if (.not. allocated(sessions)) return
    do i = 1, size(sessions)
      if (associated(sessions(i)%session) .and. sessions(i)%model_handle == model_handle) n = n + 1
    end do
  end function open_sessions

end module rotorcable_model_registry
