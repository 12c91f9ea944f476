!> Error reporting without stopping: library code never stops, it returns a status and a
!> message, and the Python layer raises them as an exception naming the deck and the key (a
!> `stop` or `error stop` in a routine called from Python would end the interpreter).
module rotorcable_errors
  implicit none
  private
  public :: error_type, fatal_error, sundials_flag_error

  !> Status of an operation: code 0 means success.
  type :: error_type
    integer :: code = 0                          !< 0 = ok, > 0 = failure
    character(len=:), allocatable :: message     !< human-readable reason
    character(len=:), allocatable :: key         !< 'group.key' of the input at fault ('' = none)
  end type error_type

contains

  !> Record a failure with its message (keeps the first failure if one is already set).
  pure subroutine fatal_error(error, message, code, key)
    type(error_type), intent(inout) :: error     !< status to set
    character(len=*), intent(in) :: message      !< what went wrong, naming the input
    integer, intent(in), optional :: code        !< error code (default 1)
    character(len=*), intent(in), optional :: key  !< 'group.key' of the input at fault
    if (error%code /= 0) return
    error%code = 1
    if (present(code)) error%code = code
    error%message = message
    error%key = ''
    if (present(key)) error%key = key
  end subroutine fatal_error

  !> A negative SUNDIALS flag becomes the error, with the solver's own message (captured by
  !> its error handler); zero and positive flags (success, warnings) leave the status alone.
  subroutine sundials_flag_error(error, status, what, solver_message)
    type(error_type), intent(inout) :: error     !< status to set
    integer, intent(in) :: status                !< the flag a SUNDIALS call returned
    character(len=*), intent(in) :: what         !< the call, e.g. 'IDASolve'
    character(len=*), intent(in) :: solver_message  !< the solver's last message
    character(len=16) :: buf
    if (status >= 0 .or. error%code /= 0) return
    write (buf, '(i0)') status
    call fatal_error(error, 'SUNDIALS '//what//' failed with flag '//trim(buf)//': '//trim(solver_message))
  end subroutine sundials_flag_error

end module rotorcable_errors
