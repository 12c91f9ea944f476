!> The load factory: a load kind named in the model description -> its constructor, which reads
!> its values by name from the load's parameter block.  A new load is one new file in
!> src_fortran/loads/ plus its lines here, its declaration in pydriver/components.py and its
!> keys in the deck schema, pydriver/schema.py.
module rotorcable_loads_factory
  use rotorcable_errors, only: error_type, fatal_error
  use rotorcable_chain, only: chain_type
  use rotorcable_loads_type, only: load_slot
  use rotorcable_parameter_block, only: parameter_block
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

contains

  !> Build the load `kind` from its parameter block.
  subroutine new_load(kind, slot, chain, params, error)
    character(len=*), intent(in) :: kind      !< load kind
    type(load_slot), intent(inout) :: slot    !< slot to fill
    type(chain_type), intent(in) :: chain     !< chain description
    type(parameter_block), intent(in) :: params  !< its parameters by name
    type(error_type), intent(inout) :: error  !< status
    select case (kind)
    case ('gravity')
      call new_gravity(slot, chain, params, error)
    case ('pulse')
      call new_pulse(slot, chain, params, error)
    case ('tip_force')
      call new_tip_force(slot, chain, params, error)
    case ('joint_springs')
      call new_joint_springs(slot, chain, params, error)
    case ('rotation_springs')
      call new_rotation_springs(slot, chain, params, error)
    case ('drag')
      call new_drag(slot, chain, params, error)
    case ('anchor')
      call new_anchor(slot, chain, params, error)
    case default
      call fatal_error(error, 'unknown load kind '''//kind//'''')
    end select
  end subroutine new_load

end module rotorcable_loads_factory
