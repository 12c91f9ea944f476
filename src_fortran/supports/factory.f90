!> The support factory: a support kind named in the model description -> its constructor, which
!> reads its values by name from the support's parameter block (as loads/factory.f90 does for
!> loads).  A new support is one new file in src_fortran/supports/ plus its entry in the table
!> below, its declaration in pydriver/components.py and its keys in the deck schema,
!> pydriver/schema.py.
module rotorcable_supports_factory
  use rotorcable_errors, only: error_type
  use rotorcable_chain, only: chain_type
  use rotorcable_parameter_block, only: parameter_block
  use rotorcable_component_kinds, only: find_kind
  use rotorcable_supports_type, only: support_type
  use rotorcable_supports_clamp, only: new_clamp
  use rotorcable_supports_ball, only: new_ball
  implicit none
  private
  public :: new_support

  abstract interface
    !> Every support's constructor.
    subroutine support_constructor(support, chain, params, error)
      import :: support_type, chain_type, parameter_block, error_type
      class(support_type), allocatable, intent(out) :: support  !< the support built
      type(chain_type), intent(in) :: chain     !< chain description
      type(parameter_block), intent(in) :: params  !< its parameters by name
      type(error_type), intent(inout) :: error  !< status
    end subroutine support_constructor
  end interface

  !> One entry of the table of support kinds.
  type :: support_kind
    character(len=32) :: name = ''           !< the kind's word in the model description
    procedure(support_constructor), pointer, nopass :: build => null()  !< its constructor
  end type support_kind

contains

  !> Build the support `kind` at the chain's far end from its parameter block.
  subroutine new_support(kind, support, chain, params, error)
    character(len=*), intent(in) :: kind      !< support kind
    class(support_type), allocatable, intent(out) :: support  !< the support built
    type(chain_type), intent(in) :: chain     !< chain description
    type(parameter_block), intent(in) :: params  !< its parameters by name
    type(error_type), intent(inout) :: error  !< status
    type(support_kind) :: kinds(2)
    character(len=32) :: names(2)
    integer :: i
    ! Built here, not a named constant (as in loads/factory.f90).
    kinds = [support_kind('clamp', new_clamp), support_kind('ball', new_ball)]
    ! The names as an array of their own: the strided section kinds%name as an actual argument
    ! makes a temporary, which the debug build (-fcheck=all) reports on stderr at every build.
    names = kinds%name
    call find_kind(names, kind, 'support', i, error)
    if (i > 0) call kinds(i)%build(support, chain, params, error)
  end subroutine new_support

end module rotorcable_supports_factory
