!> Builds a prescribed rigid motion from flat arrays (what crosses the f2py boundary).
!>
!> ints  = (n_hinges, then per hinge: angle kind, number of angle parameters)
!> reals = per hinge: axis(3), point(3), then the angle parameters:
!>   constant: (value)                                               [rad]
!>   fourier:  (azimuth_0, A, w, phi, a_0, c_1, s_1, c_2, s_2, ...)   [rad, rad, rad/s, rad, rad...]
!>   table:    (t_1 .. t_m, theta_1 .. theta_m)                       [s, rad]
!>   rotor:    (offset)                                               [rad]
module rotorcable_motion_builder
  use rotorcable_kinds, only: dp
  use rotorcable_errors, only: error_type, fatal_error
  use rotorcable_motion_angle_function, only: set_fourier_angle, set_table_angle, set_rotor_angle, &
                                              ANGLE_CONSTANT, ANGLE_FOURIER, ANGLE_TABLE, ANGLE_ROTOR
  use rotorcable_motion_rigid_motion, only: rigid_motion
  use rotorcable_parameter_block, only: parameter_block, parameter_size, get_ints, get_reals
  implicit none
  private
  public :: motion_from_flat, motion_from_block

contains

  !> The motion described by (ints, reals); an empty description gives no hinges.
  subroutine motion_from_flat(ints, reals, motion, error)
    integer, intent(in) :: ints(:)            !< hinge count, kinds and parameter counts
    real(dp), intent(in) :: reals(:)          !< axes, points and angle parameters
    type(rigid_motion), intent(out) :: motion !< motion
    type(error_type), intent(inout) :: error  !< status
    integer :: nh, k, kind, np, ir, m
    real(dp) :: axis(3)
    allocate (motion%hinges(0))
    if (size(ints) == 0) return
    nh = ints(1)
    if (nh == 0) return
    if (size(ints) /= 1 + 2*nh) then
      call fatal_error(error, 'motion description: wrong number of integers')
      return
    end if
    deallocate (motion%hinges)
    allocate (motion%hinges(nh))
    ir = 0
    do k = 1, nh
      kind = ints(2*k)
      np = ints(2*k + 1)
      if (ir + 6 + np > size(reals)) then
        call fatal_error(error, 'motion description: too few reals')
        return
      end if
      axis = reals(ir + 1:ir + 3)
      if (.not. (norm2(axis) > 0.0_dp)) then
        call fatal_error(error, 'a hinge axis must not be zero')
        return
      end if
      motion%hinges(k)%axis = axis/norm2(axis)
      motion%hinges(k)%point = reals(ir + 4:ir + 6)
      ir = ir + 6
      associate (p => reals(ir + 1:ir + np), f => motion%hinges(k)%angle)
        select case (kind)
        case (ANGLE_CONSTANT)
          f%mean = p(1)
        case (ANGLE_FOURIER)
          call set_fourier_angle(f, p(5:), p(1), p(2), p(3), p(4))
        case (ANGLE_TABLE)
          m = np/2
          call set_table_angle(f, p(1:m), p(m + 1:2*m), error)
        case (ANGLE_ROTOR)
          call set_rotor_angle(f, p(1))
        case default
          call fatal_error(error, 'motion description: unknown angle kind')
        end select
      end associate
      ir = ir + np
    end do
  end subroutine motion_from_flat

  !> The motion a support's parameter block describes in its parameters motion_ints and
  !> motion_reals (the layout above; both empty: no hinges).
  subroutine motion_from_block(params, motion, error)
    type(parameter_block), intent(in) :: params  !< the support's parameters
    type(rigid_motion), intent(out) :: motion !< motion
    type(error_type), intent(inout) :: error  !< status
    integer, allocatable :: ints(:)
    real(dp), allocatable :: reals(:)
    allocate (ints(max(parameter_size(params, 'motion_ints'), 0)), reals(max(parameter_size(params, 'motion_reals'), 0)))
    call get_ints(params, 'motion_ints', ints, error)
    call get_reals(params, 'motion_reals', reals, error)
    if (error%code /= 0) then
      allocate (motion%hinges(0))
      return
    end if
    call motion_from_flat(ints, reals, motion, error)
  end subroutine motion_from_block

end module rotorcable_motion_builder
