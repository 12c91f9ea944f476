!> The two updatable constants of the spring loads, 'springs.stiffness' and 'springs.damping'
!> (rotorcable_loads_joint_springs, rotorcable_loads_rotation_springs): one value per
!> coordinate of the free joints, in coordinate order, whichever array a load keeps them in.
!> Both loads change and report them here, so their names, their layout and the message for a
!> wrong number of values are written once.
!>
!> A load hands in its stiffness and damping arrays as their entries in array-element order,
!> with a mask `held` of the entries that are coordinates: a joint-spring load's (nq) vector
!> is all coordinates; a rotation-spring load's (3, n) columns arrive as their 3n entries, and
!> a locked joint's column holds none.  The values are then pack(entries, held), and a change
!> is unpack(values, held, entries) (the entries not held keep their value).  The dummies are
!> explicit-shape, not assumed-shape, so that both ranks come in through sequence association
!> (Fortran 2018, 15.5.2.11) without a copy or a specific procedure per rank.
module rotorcable_loads_spring_constants
  use rotorcable_kinds, only: dp
  use rotorcable_errors, only: error_type, fatal_error
  implicit none
  private
  public :: set_spring_constants, get_spring_constants

contains

  !> Change the stiffness or the damping entries if `name` is one of them.
  pure subroutine set_spring_constants(name, values, held, stiffness, damping, found, error)
    character(len=*), intent(in) :: name      !< parameter name
    real(dp), intent(in) :: values(:)         !< one per coordinate
    logical, intent(in) :: held(:)            !< the entries that are coordinates
    real(dp), intent(inout) :: stiffness(size(held))  !< the load's stiffness entries
    real(dp), intent(inout) :: damping(size(held))    !< the load's damping entries
    logical, intent(out) :: found             !< name is one of the two
    type(error_type), intent(inout) :: error  !< status: a wrong number of values
    found = name == 'springs.stiffness' .or. name == 'springs.damping'
    if (.not. found) return
    if (size(values) /= count(held)) then
      call fatal_error(error, 'model parameter '''//name//''' takes one value per coordinate')
    else if (name == 'springs.stiffness') then
      stiffness = unpack(values, held, stiffness)
    else
      damping = unpack(values, held, damping)
    end if
  end subroutine set_spring_constants

  !> The stiffness or the damping values if `name` is one of them (else none).
  pure subroutine get_spring_constants(name, held, stiffness, damping, values, found)
    character(len=*), intent(in) :: name      !< parameter name
    logical, intent(in) :: held(:)            !< the entries that are coordinates
    real(dp), intent(in) :: stiffness(size(held))  !< the load's stiffness entries
    real(dp), intent(in) :: damping(size(held))    !< the load's damping entries
    real(dp), allocatable, intent(out) :: values(:)  !< one per coordinate
    logical, intent(out) :: found             !< name is one of the two
    found = .true.
    select case (name)
    case ('springs.stiffness')
      values = pack(stiffness, held)
    case ('springs.damping')
      values = pack(damping, held)
    case default
      found = .false.
      allocate (values(0))
    end select
  end subroutine get_spring_constants

end module rotorcable_loads_spring_constants
