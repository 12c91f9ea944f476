!> The rotor: its speed Omega(t) about the deck's z axis through the rotor centre, and the
!> rotor angle psi(t) = integral of Omega dt (psi(0) = 0).
!>
!> Speed profiles:
!>  * constant Omega;
!>  * run-up from Omega_0 to Omega_1 over [t_0, t_0 + T] with the smooth step
!>    s(tau) = tau - sin(2 pi tau)/(2 pi): Omega-dot = (Omega_1 - Omega_0)/T (1 - cos 2 pi tau)
!>    starts and ends at zero, so the Euler force has no jump;
!>  * a table Omega(t_k), natural cubic spline (GSL), held after its last time.
module rotorcable_motion_rotor
  use rotorcable_kinds, only: dp
  use rotorcable_errors, only: error_type, fatal_error
  use rotorcable_parameter_block, only: parameter_block, parameter_size, get_real, get_reals, get_word
  use rotorcable_motion_table_spline, only: table_spline, spline_init, spline_eval, spline_integral, spline_free
  implicit none
  private
  public :: rotor_type, rotor_state, rotor_at, set_constant_speed, set_runup_speed, set_table_speed, rotor_free, &
            change_constant_speed, rotor_from_block, &
            ROTOR_STILL, ROTOR_CONSTANT, ROTOR_RUNUP, ROTOR_TABLE

  integer, parameter :: ROTOR_STILL = 0, ROTOR_CONSTANT = 1, ROTOR_RUNUP = 2, ROTOR_TABLE = 3
  real(dp), parameter :: TWO_PI = 2.0_dp*acos(-1.0_dp)

  !> Rotor speed profile and centre.
  type :: rotor_type
    integer :: kind = ROTOR_STILL
    logical :: given = .false.                !< a profile was set (a model may have no rotor)
    real(dp) :: centre(3) = 0.0_dp            !< rotor centre in the deck frame [m] (axis = deck z)
    real(dp) :: omega_0 = 0.0_dp              !< constant speed, or speed before the run-up [rad/s]
    real(dp) :: omega_1 = 0.0_dp              !< speed after the run-up [rad/s]
    real(dp) :: t_start = 0.0_dp              !< run-up start [s]
    real(dp) :: duration = 0.0_dp             !< run-up duration [s]
    type(table_spline) :: table               !< Omega(t) table
  end type rotor_type

  !> Rotor angle, speed and acceleration at one time.
  type :: rotor_state
    real(dp) :: psi = 0.0_dp                  !< rotor angle [rad]
    real(dp) :: omega = 0.0_dp                !< speed [rad/s]
    real(dp) :: omega_dot = 0.0_dp            !< angular acceleration [rad/s^2]
  end type rotor_state

contains

  !> A rotor turning at constant speed.
  subroutine set_constant_speed(r, omega, centre)
    type(rotor_type), intent(inout) :: r      !< rotor
    real(dp), intent(in) :: omega             !< speed [rad/s]
    real(dp), intent(in) :: centre(3)         !< rotor centre [m]
    r%kind = merge(ROTOR_CONSTANT, ROTOR_STILL, omega /= 0.0_dp)
    r%omega_0 = omega
    r%centre = centre
    r%given = .true.
  end subroutine set_constant_speed

  !> A new constant speed for a rotor built with a constant one (the Campbell diagram's speed
  !> steps); a run-up or a table has no single speed to change, and a model without a rotor
  !> has no hub frame or centre for one.
  subroutine change_constant_speed(r, omega, error)
    type(rotor_type), intent(inout) :: r      !< rotor
    real(dp), intent(in) :: omega             !< speed [rad/s]
    type(error_type), intent(inout) :: error  !< status
    if (.not. r%given) then
      call fatal_error(error, 'the model has no rotor')
    else if (r%kind /= ROTOR_CONSTANT .and. r%kind /= ROTOR_STILL) then
      call fatal_error(error, 'the rotor''s speed profile is not constant (a run-up or a table)')
    else
      call set_constant_speed(r, omega, r%centre)
    end if
  end subroutine change_constant_speed

  !> A run-up from omega_0 to omega_1 between t_start and t_start + duration.
  subroutine set_runup_speed(r, omega_0, omega_1, t_start, duration, centre, error)
    type(rotor_type), intent(inout) :: r      !< rotor
    real(dp), intent(in) :: omega_0, omega_1  !< speeds before and after [rad/s]
    real(dp), intent(in) :: t_start, duration !< start [s] and duration [s] of the run-up
    real(dp), intent(in) :: centre(3)         !< rotor centre [m]
    type(error_type), intent(inout) :: error  !< status
    if (.not. (duration > 0.0_dp)) then
      call fatal_error(error, 'the run-up duration must be positive')
      return
    end if
    r%kind = ROTOR_RUNUP
    r%given = .true.
    r%omega_0 = omega_0; r%omega_1 = omega_1
    r%t_start = t_start; r%duration = duration
    r%centre = centre
  end subroutine set_runup_speed

  !> A tabulated speed Omega(t_k).
  subroutine set_table_speed(r, t, omega, centre, error)
    type(rotor_type), intent(inout) :: r      !< rotor
    real(dp), intent(in) :: t(:), omega(:)    !< times [s] and speeds [rad/s]
    real(dp), intent(in) :: centre(3)         !< rotor centre [m]
    type(error_type), intent(inout) :: error  !< status
    r%kind = ROTOR_TABLE
    r%given = .true.
    r%centre = centre
    call spline_init(r%table, t, omega, error)
    if (error%code == 0 .and. t(1) > 0.0_dp) &
      call fatal_error(error, 'the speed table must start at t = 0 or earlier')
  end subroutine set_table_speed

  !> The rotor a parameter block describes (pydriver/motions.py, ROTOR_PROFILES, declares the
  !> names): profile (a word), centre(3) [m], and the profile's parameters:
  !>   constant: omega [rad/s];
  !>   runup: omega_start, omega_end [rad/s], t_start, duration [s];
  !>   table: t [s], omega [rad/s] (as many).
  subroutine rotor_from_block(r, params, error)
    type(rotor_type), intent(inout) :: r      !< rotor
    type(parameter_block), intent(in) :: params  !< its parameters
    type(error_type), intent(inout) :: error  !< status
    character(len=:), allocatable :: profile
    real(dp) :: centre(3), omega_0, omega_1, t_start, duration
    real(dp), allocatable :: t(:), omega(:)
    call get_reals(params, 'centre', centre, error)
    call get_word(params, 'profile', profile, error)
    if (error%code /= 0) return
    select case (profile)
    case ('constant')
      call get_real(params, 'omega', omega_0, error)
      if (error%code == 0) call set_constant_speed(r, omega_0, centre)
    case ('runup')
      call get_real(params, 'omega_start', omega_0, error)
      call get_real(params, 'omega_end', omega_1, error)
      call get_real(params, 't_start', t_start, error)
      call get_real(params, 'duration', duration, error)
      if (error%code == 0) call set_runup_speed(r, omega_0, omega_1, t_start, duration, centre, error)
    case ('table')
      allocate (t(max(parameter_size(params, 't'), 0)))
      call get_reals(params, 't', t, error)
      allocate (omega(size(t)))
      call get_reals(params, 'omega', omega, error)
      if (error%code == 0) call set_table_speed(r, t, omega, centre, error)
    case default
      call fatal_error(error, 'rotor: '''//profile//''' is not a speed profile of the core', key='rotor.profile')
    end select
  end subroutine rotor_from_block

  !> Rotor angle, speed and acceleration at time t.
  function rotor_at(r, t) result(s)
    type(rotor_type), intent(in) :: r         !< rotor
    real(dp), intent(in) :: t                 !< time [s]
    type(rotor_state) :: s
    real(dp) :: tau, dw, f, df, ddf
    select case (r%kind)
    case (ROTOR_CONSTANT)
      s%psi = r%omega_0*t
      s%omega = r%omega_0
    case (ROTOR_RUNUP)
      dw = r%omega_1 - r%omega_0
      tau = min(1.0_dp, max(0.0_dp, (t - r%t_start)/r%duration))
      s%omega = r%omega_0 + dw*(tau - sin(TWO_PI*tau)/TWO_PI)
      s%omega_dot = 0.0_dp
      if (tau > 0.0_dp .and. tau < 1.0_dp) s%omega_dot = dw/r%duration*(1.0_dp - cos(TWO_PI*tau))
      ! psi = Omega_0 t + dw T S(tau) (+ dw (t - t_0 - T) after), S = tau^2/2 + (cos 2 pi tau - 1)/(2 pi)^2
      s%psi = r%omega_0*t + dw*r%duration*(0.5_dp*tau**2 + (cos(TWO_PI*tau) - 1.0_dp)/TWO_PI**2)
      if (t > r%t_start + r%duration) s%psi = s%psi + dw*(t - r%t_start - r%duration)
    case (ROTOR_TABLE)
      call spline_eval(r%table, t, f, df, ddf)
      s%omega = f
      s%omega_dot = df
      s%psi = spline_integral(r%table, t) - spline_integral(r%table, 0.0_dp)
    case default
      s = rotor_state()
    end select
  end function rotor_at

  !> Release the table spline.
  subroutine rotor_free(r)
    type(rotor_type), intent(inout) :: r      !< rotor
    call spline_free(r%table)
  end subroutine rotor_free

end module rotorcable_motion_rotor
