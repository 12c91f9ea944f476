!> Builds a prescribed rigid motion from a parameter block, by name (pydriver/motions.py,
!> `motion_parameters`, packs it; its HINGE and ANGLES declare the names).  Under a prefix
!> (a support's block: 'motion.'):
!>
!>   hinges                    number of hinges (0: no motion), outermost first
!>   hinge<k>.axis (3)         hinge axis (any length > 0)
!>   hinge<k>.point (3)        a point on it [m]
!>   hinge<k>.angle            the angle's kind (a word) and its parameters hinge<k>.<name>
!>                             (rotorcable_motion_angle_function, angle_from_block)
module rotorcable_motion_builder
  use rotorcable_kinds, only: dp
  use rotorcable_errors, only: error_type, fatal_error
  use rotorcable_motion_angle_function, only: angle_from_block
  use rotorcable_motion_rigid_motion, only: rigid_motion
  use rotorcable_parameter_block, only: parameter_block, get_int, get_reals
  implicit none
  private
  public :: motion_from_block

contains

  !> The motion the block describes under `prefix` (prefix//'hinges' = 0: no hinges).
  subroutine motion_from_block(params, prefix, motion, error)
    type(parameter_block), intent(in) :: params  !< the block (a support's parameters)
    character(len=*), intent(in) :: prefix    !< the motion's names' prefix ('motion.')
    type(rigid_motion), intent(out) :: motion !< motion
    type(error_type), intent(inout) :: error  !< status
    integer :: nh, k
    real(dp) :: axis(3)
    character(len=24) :: hinge
    allocate (motion%hinges(0))
    call get_int(params, prefix//'hinges', nh, error)
    if (error%code /= 0 .or. nh == 0) return
    if (nh < 0) then
      call fatal_error(error, params%owner//': a negative number of hinges')
      return
    end if
    deallocate (motion%hinges)
    allocate (motion%hinges(nh))
    do k = 1, nh
      write (hinge, '(a, i0, a)') 'hinge', k, '.'
      call get_reals(params, prefix//trim(hinge)//'axis', axis, error)
      call get_reals(params, prefix//trim(hinge)//'point', motion%hinges(k)%point, error)
      if (error%code /= 0) return
      if (.not. (norm2(axis) > 0.0_dp)) then
        call fatal_error(error, 'a hinge axis must not be zero')
        return
      end if
      motion%hinges(k)%axis = axis/norm2(axis)
      call angle_from_block(motion%hinges(k)%angle, params, prefix//trim(hinge), error)
      if (error%code /= 0) return
    end do
  end subroutine motion_from_block

end module rotorcable_motion_builder
