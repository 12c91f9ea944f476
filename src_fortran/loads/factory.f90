!> The load factory: a load kind named in the model description -> its constructor, which reads
!> its values by name from the load's parameter block.  A new load is one new file in
!> src_fortran/loads/ plus its entry in the table below, its declaration in
!> pydriver/components.py and its keys in the deck schema, pydriver/schema.py.
module rotorcable_loads_factory
  use rotorcable_errors, only: error_type
  use rotorcable_chain, only: chain_type
  use rotorcable_loads_type, only: load_slot
  use rotorcable_parameter_block, only: parameter_block
  use rotorcable_component_kinds, only: find_kind
  use rotorcable_loads_gravity, only: new_gravity
  use rotorcable_loads_pulse, only: new_pulse
  use rotorcable_loads_tip_force, only: new_tip_force
  use rotorcable_loads_joint_springs, only: new_joint_springs
  use rotorcable_loads_drag, only: new_drag
  use rotorcable_loads_rotation_springs, only: new_rotation_springs
  use rotorcable_loads_anchor, only: new_anchor
  implicit none
  private
  public :: new_load

  abstract interface
    !> Every load's constructor (their dummy arguments are declared once, in the include).
    subroutine load_constructor(slot, chain, params, error)
      import :: load_slot, chain_type, parameter_block, error_type
      include 'constructor_arguments.inc'
    end subroutine load_constructor
  end interface

  !> One entry of the table of load kinds.
  type :: load_kind
    character(len=32) :: name = ''           !< the kind's word in the model description
    procedure(load_constructor), pointer, nopass :: build => null()  !< its constructor
  end type load_kind

contains

  !> Build the load `kind` from its parameter block.
  subroutine new_load(kind, slot, chain, params, error)
    character(len=*), intent(in) :: kind      !< load kind
    type(load_slot), intent(inout) :: slot    !< slot to fill
    type(chain_type), intent(in) :: chain     !< chain description
    type(parameter_block), intent(in) :: params  !< its parameters by name
    type(error_type), intent(inout) :: error  !< status
    type(load_kind) :: kinds(7)
    character(len=32) :: names(7)
    integer :: i
    ! Built here, not a named constant: gfortran 12 does not take a procedure as a constant
    ! structure constructor's component (Fortran 2008 allows it).
    kinds = [load_kind('gravity', new_gravity), load_kind('pulse', new_pulse), &
             load_kind('tip_force', new_tip_force), load_kind('joint_springs', new_joint_springs), &
             load_kind('rotation_springs', new_rotation_springs), load_kind('drag', new_drag), &
             load_kind('anchor', new_anchor)]
    ! The names as an array of their own: the strided section kinds%name as an actual argument
    ! makes a temporary, which the debug build (-fcheck=all) reports on stderr at every build.
    names = kinds%name
    call find_kind(names, kind, 'load', i, error)
    if (i > 0) call kinds(i)%build(slot, chain, params, error)
  end subroutine new_load

end module rotorcable_loads_factory
