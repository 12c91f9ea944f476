!> The support factory: a support kind named in the model description -> its constructor, which
!> reads its values by name from the support's parameter block (as loads/factory.f90 does for
!> loads).  A new support is one new file in src_fortran/supports/ plus its lines here, its
!> declaration in pydriver/components.py and its keys in the deck schema, pydriver/schema.py.
module rotorcable_supports_factory
  use rotorcable_errors, only: error_type, fatal_error
  use rotorcable_chain, only: chain_type
  use rotorcable_parameter_block, only: parameter_block
  use rotorcable_supports_type, only: support_type
  use rotorcable_supports_clamp, only: new_clamp
  use rotorcable_supports_ball, only: new_ball
  implicit none
  private
  public :: new_support

contains

  !> Build the support `kind` at the chain's far end from its parameter block.
  subroutine new_support(kind, support, chain, params, error)
    character(len=*), intent(in) :: kind      !< support kind
    class(support_type), allocatable, intent(out) :: support  !< the support built
    type(chain_type), intent(in) :: chain     !< chain description
    type(parameter_block), intent(in) :: params  !< its parameters by name
    type(error_type), intent(inout) :: error  !< status
    select case (kind)
    case ('clamp')
      call new_clamp(support, chain, params, error)
    case ('ball')
      call new_ball(support, chain, params, error)
    case default
      call fatal_error(error, 'unknown support kind '''//kind//'''')
    end select
  end subroutine new_support

end module rotorcable_supports_factory
