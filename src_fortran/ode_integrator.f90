!> The thesis's route for comparison: the index-1 ODE of eq. 3.55/3.58 integrated with
!> GSL's gsl_odeiv2 (explicit rk8pd, implicit msbdf), same Fortran model underneath.
!>
!> State y = (q, v).  At every right-hand side the acceleration-level system eq. 3.55 is
!> solved for vdot and lambda.  Eq. 3.58 alone lets g and G v drift (it enforces only
!> gdd = 0); Baumgarte's stabilisation (Baumgarte 1972, Comput. Methods Appl. Mech. Eng. 1,
!> 1-16) replaces gdd = 0 by  gdd + 2 w gd + w^2 g = 0  (critically damped drift, time
!> constant 1/w), i.e. the constraint rows of eq. 3.55 read
!>   G vdot = -Gdot v - 2 w G v - w^2 g.
!> The projection onto the constraint manifold at the start is shared with the DAE route.
module rotorcable_ode_integrator
  use, intrinsic :: iso_c_binding, only: c_int, c_long, c_double, c_size_t, c_ptr, c_funptr, c_loc, &
                                         c_funloc, c_f_pointer, c_null_ptr, c_associated
  use rotorcable_kinds, only: dp
  use rotorcable_errors, only: error_type, fatal_error
  use rotorcable_model, only: model_type, solve_accelerations, switch_times
  use rotorcable_dae_integrator, only: solver_stats, consistent_start
  use rotorcable_gsl_ode_binding
  implicit none
  private
  public :: ode_settings, integrate_ode, ODE_RK8PD, ODE_MSBDF

  integer, parameter :: ODE_RK8PD = 1   !< GSL rk8pd: explicit Runge-Kutta Prince-Dormand 8(9)
  integer, parameter :: ODE_MSBDF = 2   !< GSL msbdf: variable-order BDF with Newton iterations

  !> Settings of one ODE-route integration.
  type :: ode_settings
    integer :: method = ODE_RK8PD             !< ODE_RK8PD or ODE_MSBDF
    real(dp) :: rtol = 1.0e-8_dp              !< relative tolerance (GSL epsrel)
    real(dp) :: atol = 1.0e-10_dp             !< absolute tolerance (GSL epsabs) on q and v
    real(dp) :: baumgarte_omega = 50.0_dp     !< Baumgarte constant w [1/s] (see module comment)
    real(dp) :: h_max = 0.0_dp                !< maximum step [s] (0 = none)
    integer :: max_steps = 10000000           !< maximum steps per interval
  end type ode_settings

  !> User data handed to GSL (c_loc), turned back with c_f_pointer in the callbacks.
  type :: ode_user_data
    type(model_type), pointer :: model => null()
    real(dp) :: omega = 0.0_dp
    integer :: nq = 0
    integer :: rhs_evals = 0
    integer :: jac_evals = 0
  end type ode_user_data

contains

  !> Right-hand side y' = (v, vdot) with vdot from the stabilised eq. 3.55.
  integer(c_int) function ode_rhs(t, y, dydt, params) bind(C)
    real(c_double), value :: t
    real(c_double), intent(in) :: y(*)
    real(c_double), intent(out) :: dydt(*)
    type(c_ptr), value :: params
    type(ode_user_data), pointer :: ud
    call c_f_pointer(params, ud)
    ode_rhs = rhs(ud, t, y(1:2*ud%nq), dydt(1:2*ud%nq))
  end function ode_rhs

  integer(c_int) function rhs(ud, t, y, dydt)
    type(ode_user_data), intent(inout) :: ud
    real(dp), intent(in) :: t, y(:)
    real(dp), intent(out) :: dydt(:)
    real(dp) :: lambda(max(ud%model%nc, 1))
    integer :: nq, info
    nq = ud%nq
    ud%rhs_evals = ud%rhs_evals + 1
    dydt(1:nq) = y(nq + 1:2*nq)
    call solve_accelerations(ud%model, t, y(1:nq), y(nq + 1:2*nq), dydt(nq + 1:2*nq), &
                             lambda(1:ud%model%nc), info, baumgarte_omega=ud%omega)
    rhs = GSL_SUCCESS
    if (info /= 0 .or. any(dydt(1:2*nq) /= dydt(1:2*nq))) rhs = 9_c_int   ! GSL_EBADFUNC
  end function rhs

  !> Jacobian for the implicit stepper, by forward differences of the right-hand side
  !> (as a user of the thesis's route would do; the DAE route has the structured one).
  !> dfdt = 0: the comparisons use scenes whose only explicit time dependence is the
!> piecewise-constant force pulse.
  integer(c_int) function ode_jacobian(t, y, dfdy, dfdt, params) bind(C)
    real(c_double), value :: t
    real(c_double), intent(in) :: y(*)
    real(c_double), intent(out) :: dfdy(*), dfdt(*)
    type(c_ptr), value :: params
    type(ode_user_data), pointer :: ud
    real(dp), allocatable :: f0(:), f1(:), yy(:)
    real(dp) :: h
    integer :: n, j, i
    call c_f_pointer(params, ud)
    n = 2*ud%nq
    ud%jac_evals = ud%jac_evals + 1
    allocate (f0(n), f1(n), yy(n))
    yy = y(1:n)
    ode_jacobian = rhs(ud, t, yy, f0)
    do j = 1, n
      if (ode_jacobian /= GSL_SUCCESS) return
      h = sqrt(epsilon(1.0_dp))*max(abs(yy(j)), 1.0e-2_dp)
      yy(j) = y(j) + h
      ode_jacobian = rhs(ud, t, yy, f1)
      yy(j) = y(j)
      ! GSL stores dfdy row-major: dfdy(i*n + j) = d f_i / d y_j (0-based i, j).
      do i = 1, n
        dfdy((i - 1)*n + j) = (f1(i) - f0(i))/h
      end do
    end do
    dfdt(1:n) = 0.0_dp
  end function ode_jacobian

  !> Integrate from t_out(1) to t_out(size); returns (q, v) at the output times.  Steps
  !> stop exactly at the pulse switching times, where the multistep history is restarted.
  subroutine integrate_ode(model, settings, q0, v0, t_out, q_out, v_out, stats, error)
    type(model_type), intent(inout), target :: model  !< model
    type(ode_settings), intent(in) :: settings        !< method and tolerances
    real(dp), intent(in) :: q0(:), v0(:)              !< start state (projected here)
    real(dp), intent(in) :: t_out(:)                  !< output times, t_out(1) = start
    real(dp), intent(out) :: q_out(:, :), v_out(:, :) !< (nq, n_out) states at t_out
    type(solver_stats), intent(out) :: stats          !< steps, rhs evals, Jacobians, failed steps
    type(error_type), intent(inout) :: error          !< status
    type(ode_user_data), target :: ud
    type(gsl_odeiv2_system), target :: sys
    type(gsl_odeiv2_driver), pointer :: drv
    type(gsl_odeiv2_evolve), pointer :: evo
    type(c_ptr) :: d, old_handler, step_type
    real(dp) :: y(2*model%nq), vdot(model%nq), lambda(max(model%nc, 1)), t_stop
    real(dp), allocatable :: t_switch(:)
    real(c_double) :: t
    integer(c_int) :: flag
    integer :: nq, k, s
    character(len=32) :: buf

    nq = model%nq
    y(1:nq) = q0; y(nq + 1:) = v0
    call consistent_start(model, t_out(1), y(1:nq), y(nq + 1:), vdot, lambda(1:model%nc), error)
    if (error%code /= 0) return
    q_out(:, 1) = y(1:nq); v_out(:, 1) = y(nq + 1:)

    ud%model => model
    ud%omega = settings%baumgarte_omega
    ud%nq = nq
    sys%function = c_funloc(ode_rhs)
    sys%jacobian = c_funloc(ode_jacobian)
    sys%dimension = int(2*nq, c_size_t)
    sys%params = c_loc(ud)
    ! GSL's default handler aborts the process; the library reports statuses instead.
    ! The handler is process-wide, and off is the only safe setting inside Python.
    old_handler = gsl_set_error_handler_off()
    if (settings%method == ODE_MSBDF) then
      step_type = gsl_step_msbdf
    else
      step_type = gsl_step_rk8pd
    end if
    d = gsl_odeiv2_driver_alloc_y_new(c_loc(sys), step_type, 1.0e-6_c_double, &
                                      real(settings%atol, c_double), real(settings%rtol, c_double))
    if (.not. c_associated(d)) then
      call fatal_error(error, 'GSL could not allocate the ODE driver')
      return
    end if
    flag = gsl_odeiv2_driver_set_nmax(d, int(settings%max_steps, c_long))
    if (flag == GSL_SUCCESS .and. settings%h_max > 0.0_dp) &
      flag = gsl_odeiv2_driver_set_hmax(d, real(settings%h_max, c_double))
    if (flag /= GSL_SUCCESS) then
      write (buf, '(i0)') flag
      call fatal_error(error, 'GSL could not set the ODE driver''s step limit or maximum step (status '// &
                       trim(buf)//')')
      call gsl_odeiv2_driver_free(d)
      return
    end if

    call switch_times(model, t_switch)
    t = t_out(1)
    s = 1
    do k = 2, size(t_out)
      do while (s <= size(t_switch))
        if (t_switch(s) > t_out(k)) exit
        if (t_switch(s) > t) then
          t_stop = t_switch(s)
          flag = gsl_odeiv2_driver_apply(d, t, real(t_stop, c_double), y)
          if (flag /= GSL_SUCCESS) exit
          call harvest_counts()       ! the reset zeroes GSL's counters
          flag = gsl_odeiv2_driver_reset(d)
          if (flag /= GSL_SUCCESS) exit
        end if
        s = s + 1
      end do
      if (flag == GSL_SUCCESS .and. t_out(k) > t) flag = gsl_odeiv2_driver_apply(d, t, real(t_out(k), c_double), y)
      if (flag /= GSL_SUCCESS) then
        write (buf, '(i0, a, es10.3)') flag, ' at t = ', t
        call fatal_error(error, 'GSL gsl_odeiv2_driver_apply or _reset failed with status '//trim(buf)// &
                         ' (step size underflow, step limit or singular acceleration system)')
        exit
      end if
      q_out(:, k) = y(1:nq); v_out(:, k) = y(nq + 1:)
    end do

    call harvest_counts()
    stats%residual_evals = ud%rhs_evals
    stats%jacobian_evals = ud%jac_evals
    call gsl_odeiv2_driver_free(d)

  contains

    subroutine harvest_counts()
      call c_f_pointer(d, drv)
      call c_f_pointer(drv%e, evo)
      stats%steps = stats%steps + int(evo%count)
      stats%error_test_failures = stats%error_test_failures + int(evo%failed_steps)
    end subroutine harvest_counts

  end subroutine integrate_ode

end module rotorcable_ode_integrator
