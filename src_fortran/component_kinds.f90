!> The lookup of a component kind named in the model description ('drag', 'clamp', ...) in a
!> factory's table of kinds (rotorcable_loads_factory, rotorcable_supports_factory).  Each
!> factory keeps its own table of names and constructors, because a load's constructor and a
!> support's take different arguments; the lookup and its message are the same, and are here.
module rotorcable_component_kinds
  use rotorcable_errors, only: error_type, fatal_error
  implicit none
  private
  public :: find_kind

contains

  !> Where `kind` stands in a table's names; 0, and the error naming it, if it is not there.
  pure subroutine find_kind(names, kind, what, index, error)
    character(len=*), intent(in) :: names(:)  !< the kinds a factory knows
    character(len=*), intent(in) :: kind      !< the kind asked for
    character(len=*), intent(in) :: what      !< 'load' or 'support', for the message
    integer, intent(out) :: index             !< its entry in names, 0 if none
    type(error_type), intent(inout) :: error  !< status: an unknown kind
    index = findloc(names, kind, 1)
    if (index == 0) call fatal_error(error, 'unknown '//what//' kind '''//kind//'''')
  end subroutine find_kind

end module rotorcable_component_kinds
