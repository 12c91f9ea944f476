!> A prescribed angle theta(t) with its first two time derivatives: the angles of the blade's
!> flap, lead-lag and pitch hinges, and the rotor angle for supports carried by the rotor.
!>
!> Kinds:
!>  * constant;
!>  * Fourier series in the blade azimuth psi_b = psi(t) + azimuth_0 (coning plus 1/rev, 2/rev,
!>    ...): theta = a_0 + sum_k (c_k cos k psi_b + s_k sin k psi_b), with
!>    theta-dot = theta'(psi_b) Omega and theta-ddot = theta''(psi_b) Omega^2 + theta'(psi_b) Omega-dot,
!>    plus an extra oscillation A sin(w t + phi) at its own frequency (the lead-lag mode at
!>    1/4 to 1/3 of the rotor frequency, thesis chapter 6);
!>  * time table, natural cubic spline (C2, rotorcable_motion_table_spline);
!>  * the rotor angle psi(t) itself (a support carried round by the rotor).
module rotorcable_motion_angle_function
  use rotorcable_kinds, only: dp
  use rotorcable_errors, only: error_type, fatal_error
  use rotorcable_parameter_block, only: parameter_block, parameter_size, get_real, get_reals, get_word
  use rotorcable_motion_rotor, only: rotor_state
  use rotorcable_motion_table_spline, only: table_spline, spline_init, spline_eval, spline_free
  implicit none
  private
  public :: angle_function, angle_eval, set_fourier_angle, set_table_angle, set_rotor_angle, angle_free, &
            angle_from_block, &
            ANGLE_CONSTANT, ANGLE_FOURIER, ANGLE_TABLE, ANGLE_ROTOR

  integer, parameter :: ANGLE_CONSTANT = 0, ANGLE_FOURIER = 1, ANGLE_TABLE = 2, ANGLE_ROTOR = 3

  !> One prescribed angle.
  type :: angle_function
    integer :: kind = ANGLE_CONSTANT
    real(dp) :: mean = 0.0_dp                 !< constant value or a_0 [rad]
    real(dp), allocatable :: cos_coef(:)      !< c_k, k = 1.. [rad]
    real(dp), allocatable :: sin_coef(:)      !< s_k, k = 1.. [rad]
    real(dp) :: azimuth_0 = 0.0_dp            !< blade azimuth at t = 0 [rad]
    real(dp) :: extra_amplitude = 0.0_dp      !< A [rad]
    real(dp) :: extra_omega = 0.0_dp          !< w [rad/s]
    real(dp) :: extra_phase = 0.0_dp          !< phi [rad]
    type(table_spline) :: table               !< theta(t) table
  end type angle_function

contains

  !> A Fourier series in the blade azimuth: coefficients (a_0, c_1, s_1, c_2, s_2, ...) [rad].
  subroutine set_fourier_angle(f, coefficients, azimuth_0, extra_amplitude, extra_omega, extra_phase)
    type(angle_function), intent(inout) :: f  !< angle
    real(dp), intent(in) :: coefficients(:)   !< a_0, c_1, s_1, ... [rad]
    real(dp), intent(in) :: azimuth_0         !< blade azimuth at t = 0 [rad]
    real(dp), intent(in) :: extra_amplitude, extra_omega, extra_phase  !< A [rad], w [rad/s], phi [rad]
    integer :: k, nh
    f%kind = ANGLE_FOURIER
    f%mean = 0.0_dp
    if (size(coefficients) > 0) f%mean = coefficients(1)
    nh = size(coefficients)/2
    allocate (f%cos_coef(nh), f%sin_coef(nh))
    f%cos_coef = 0.0_dp; f%sin_coef = 0.0_dp
    do k = 1, nh
      if (2*k <= size(coefficients)) f%cos_coef(k) = coefficients(2*k)
      if (2*k + 1 <= size(coefficients)) f%sin_coef(k) = coefficients(2*k + 1)
    end do
    f%azimuth_0 = azimuth_0
    f%extra_amplitude = extra_amplitude
    f%extra_omega = extra_omega
    f%extra_phase = extra_phase
  end subroutine set_fourier_angle

  !> A time table theta(t_k) [rad].
  subroutine set_table_angle(f, t, theta, error)
    type(angle_function), intent(inout) :: f  !< angle
    real(dp), intent(in) :: t(:), theta(:)    !< times [s], angles [rad]
    type(error_type), intent(inout) :: error  !< status
    f%kind = ANGLE_TABLE
    call spline_init(f%table, t, theta, error)
  end subroutine set_table_angle

  !> The rotor angle psi(t) + offset.
  subroutine set_rotor_angle(f, offset)
    type(angle_function), intent(inout) :: f  !< angle
    real(dp), intent(in) :: offset            !< constant added to psi [rad]
    f%kind = ANGLE_ROTOR
    f%mean = offset
  end subroutine set_rotor_angle

  !> The angle a parameter block describes under `prefix` (pydriver/motions.py, ANGLES, declares
  !> the names): `prefix`angle, the kind as a word, and that kind's parameters:
  !>   constant: value [rad];  rotor: offset [rad];  table: t [s], theta [rad] (as many);
  !>   fourier: azimuth0 [rad], extra_amplitude [rad], extra_frequency [rad/s], extra_phase [rad],
  !>            coefficients (a_0, c_1, s_1, c_2, s_2, ...) [rad].
  subroutine angle_from_block(f, params, prefix, error)
    type(angle_function), intent(out) :: f    !< angle
    type(parameter_block), intent(in) :: params  !< the block holding it
    character(len=*), intent(in) :: prefix    !< its names' prefix ('motion.hinge2.')
    type(error_type), intent(inout) :: error  !< status
    character(len=:), allocatable :: kind
    real(dp), allocatable :: values(:), times(:)
    real(dp) :: azimuth_0, amplitude, omega, phase
    call get_word(params, prefix//'angle', kind, error)
    if (error%code /= 0) return
    select case (kind)
    case ('constant')
      call get_real(params, prefix//'value', f%mean, error)
    case ('rotor')
      call get_real(params, prefix//'offset', phase, error)
      if (error%code == 0) call set_rotor_angle(f, phase)
    case ('fourier')
      call get_real(params, prefix//'azimuth0', azimuth_0, error)
      call get_real(params, prefix//'extra_amplitude', amplitude, error)
      call get_real(params, prefix//'extra_frequency', omega, error)
      call get_real(params, prefix//'extra_phase', phase, error)
      allocate (values(max(parameter_size(params, prefix//'coefficients'), 0)))
      call get_reals(params, prefix//'coefficients', values, error)
      if (error%code == 0) call set_fourier_angle(f, values, azimuth_0, amplitude, omega, phase)
    case ('table')
      allocate (times(max(parameter_size(params, prefix//'t'), 0)))
      call get_reals(params, prefix//'t', times, error)
      allocate (values(size(times)))
      call get_reals(params, prefix//'theta', values, error)
      if (error%code == 0) call set_table_angle(f, times, values, error)
    case default
      call fatal_error(error, params%owner//': '''//kind//''' is not an angle kind of the core ('//prefix//'angle)')
    end select
  end subroutine angle_from_block

  !> theta, theta-dot, theta-ddot at time t for the rotor state rs.
  subroutine angle_eval(f, t, rs, a, ad, add)
    type(angle_function), intent(in) :: f     !< angle
    real(dp), intent(in) :: t                 !< time [s]
    type(rotor_state), intent(in) :: rs       !< rotor angle, speed, acceleration
    real(dp), intent(out) :: a, ad, add       !< angle [rad], rate [rad/s], acceleration [rad/s^2]
    real(dp) :: psi_b, d1, d2, c, s, w
    integer :: k
    select case (f%kind)
    case (ANGLE_FOURIER)
      psi_b = rs%psi + f%azimuth_0
      a = f%mean; d1 = 0.0_dp; d2 = 0.0_dp
      do k = 1, size(f%cos_coef)
        c = cos(k*psi_b); s = sin(k*psi_b)
        a = a + f%cos_coef(k)*c + f%sin_coef(k)*s
        d1 = d1 + k*(f%sin_coef(k)*c - f%cos_coef(k)*s)
        d2 = d2 - k**2*(f%cos_coef(k)*c + f%sin_coef(k)*s)
      end do
      ad = d1*rs%omega
      add = d2*rs%omega**2 + d1*rs%omega_dot
      if (f%extra_amplitude /= 0.0_dp) then
        w = f%extra_omega
        a = a + f%extra_amplitude*sin(w*t + f%extra_phase)
        ad = ad + f%extra_amplitude*w*cos(w*t + f%extra_phase)
        add = add - f%extra_amplitude*w**2*sin(w*t + f%extra_phase)
      end if
    case (ANGLE_TABLE)
      call spline_eval(f%table, t, a, ad, add, ends_on_spline=.true.)
    case (ANGLE_ROTOR)
      a = rs%psi + f%mean
      ad = rs%omega
      add = rs%omega_dot
    case default
      a = f%mean; ad = 0.0_dp; add = 0.0_dp
    end select
  end subroutine angle_eval

  !> Release a table spline.
  subroutine angle_free(f)
    type(angle_function), intent(inout) :: f  !< angle
    call spline_free(f%table)
  end subroutine angle_free

end module rotorcable_motion_angle_function
