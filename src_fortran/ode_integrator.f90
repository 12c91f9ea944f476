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
  use rotorcable_model, only: model_type, solve_accelerations, switch_times, constraint_jacobian, constraint_bias
  use rotorcable_model_derivatives, only: eom_derivatives, constraint_derivatives
  use rotorcable_linalg, only: dgetrf, dgetrs
  use rotorcable_dae_integrator, only: solver_stats, consistent_start
  use rotorcable_gsl_ode_binding
  implicit none
  private
  public :: ode_settings, integrate_ode, ode_jacobian_matrix, ode_right_hand_side, ODE_RK8PD, ODE_MSBDF

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

  !> Jacobian for the implicit stepper (GSL msbdf): the analytic one of ode_jacobian_matrix.
  !> dfdt = 0: the comparisons use scenes whose only explicit time dependence is the
  !> piecewise-constant force pulse.
  integer(c_int) function ode_jacobian(t, y, dfdy, dfdt, params) bind(C)
    real(c_double), value :: t
    real(c_double), intent(in) :: y(*)
    real(c_double), intent(out) :: dfdy(*), dfdt(*)
    type(c_ptr), value :: params
    type(ode_user_data), pointer :: ud
    real(dp), allocatable :: jac(:, :)
    integer :: n, i
    call c_f_pointer(params, ud)
    n = 2*ud%nq
    allocate (jac(n, n))
    ud%jac_evals = ud%jac_evals + 1
    ode_jacobian = jacobian_analytic(ud, t, y(1:n), jac)
    ! GSL stores dfdy row-major: dfdy(i*n + j) = d f_i / d y_j (0-based i, j).
    do i = 1, n
      dfdy((i - 1)*n + 1:i*n) = jac(i, :)
    end do
    dfdt(1:n) = 0.0_dp
  end function ode_jacobian

  !> d(y')/dy of the ODE route at (t, y = (q, v)), column-major (2 nq, 2 nq), analytic or by
  !> forward differences of the right-hand side (what msbdf got before, and what a user of the
  !> thesis's route would write).  info /= 0: the acceleration system was singular.
  subroutine ode_jacobian_matrix(model, t, q, v, baumgarte_omega, analytic, jac, info)
    type(model_type), intent(inout), target :: model  !< model
    real(dp), intent(in) :: t                 !< time [s]
    real(dp), intent(in) :: q(:), v(:)        !< coordinates and rates
    real(dp), intent(in) :: baumgarte_omega   !< Baumgarte constant w [1/s]
    logical, intent(in) :: analytic           !< analytic (else forward differences)
    real(dp), intent(out) :: jac(:, :)        !< (2 nq, 2 nq) d(y')/dy
    integer, intent(out) :: info              !< 0 = ok
    type(ode_user_data) :: ud
    real(dp) :: y(2*model%nq)
    ud%model => model
    ud%omega = baumgarte_omega
    ud%nq = model%nq
    y(1:model%nq) = q
    y(model%nq + 1:) = v
    if (analytic) then
      info = jacobian_analytic(ud, t, y, jac)
    else
      info = jacobian_differences(ud, t, y, jac)
    end if
  end subroutine ode_jacobian_matrix

  !> The right-hand side y' = (v, vdot) at (t, q, v) (for the checks of the Jacobian).
  subroutine ode_right_hand_side(model, t, q, v, baumgarte_omega, ydot, info)
    type(model_type), intent(inout), target :: model  !< model
    real(dp), intent(in) :: t                 !< time [s]
    real(dp), intent(in) :: q(:), v(:)        !< coordinates and rates
    real(dp), intent(in) :: baumgarte_omega   !< Baumgarte constant w [1/s]
    real(dp), intent(out) :: ydot(:)          !< (2 nq) y'
    integer, intent(out) :: info              !< 0 = ok
    type(ode_user_data) :: ud
    real(dp) :: y(2*model%nq)
    ud%model => model
    ud%omega = baumgarte_omega
    ud%nq = model%nq
    y(1:model%nq) = q
    y(model%nq + 1:) = v
    info = rhs(ud, t, y, ydot)
  end subroutine ode_right_hand_side

  !> Forward differences of the right-hand side, one solve of eq. 3.55 per column (the step
  !> sqrt(eps) |y_j| is round-off-bound here: eq. 3.55 is ill-conditioned on chains with light
  !> axial inertias, so these columns carry percent-level errors on the UH-60 chain).
  integer(c_int) function jacobian_differences(ud, t, y, jac) result(status)
    type(ode_user_data), intent(inout) :: ud
    real(dp), intent(in) :: t, y(:)
    real(dp), intent(out) :: jac(:, :)
    real(dp) :: f0(size(y)), f1(size(y)), yy(size(y)), h
    integer :: j
    yy = y
    jac = 0.0_dp
    status = rhs(ud, t, yy, f0)
    do j = 1, size(y)
      if (status /= GSL_SUCCESS) return
      h = sqrt(epsilon(1.0_dp))*max(abs(yy(j)), 1.0e-2_dp)
      yy(j) = y(j) + h
      status = rhs(ud, t, yy, f1)
      yy(j) = y(j)
      jac(:, j) = (f1 - f0)/h
    end do
  end function jacobian_differences

  !> The analytic Jacobian.  y' = (v, vdot) with vdot, lambda from the stabilised eq. 3.55:
  !>   r = M vdot - k - G^T lambda = 0,   c = G vdot + b + w^2 g + 2 w (G v + g_t) = 0,
  !> b the acceleration bias (d^2 g/dt^2 at vdot = 0).  Differentiating both at the solution,
  !>   [M G^T; G 0] [d vdot; -d lambda] = -[dr; dc]   (for dq and for dv),
  !> the same matrix as eq. 3.55.  dr/dq and dr/dv at fixed vdot, lambda are the analytic
  !> whole matrices of eom_derivatives (loads and support B's wrench included); dg/dq = G and
  !> d(G v + g_t)/d(q, v) are constraint_derivatives'.  Only d(G vdot + b)/d(q, v) at fixed vdot
  !> would need the constraints' second derivatives, which the core does not have: they are
  !> central differences of G vdot + b (nc = 6 rows; a kinematic pass per column, no solve), exact
  !> up to round-off in v (b is quadratic in v) and O(h^2) ~ 1e-10 relative in q.
  integer(c_int) function jacobian_analytic(ud, t, y, jac) result(status)
    type(ode_user_data), intent(inout) :: ud
    real(dp), intent(in) :: t, y(:)
    real(dp), intent(out) :: jac(:, :)
    real(dp) :: vdot(ud%nq), lambda(max(ud%model%nc, 1))
    real(dp) :: dres_dq(ud%nq, ud%nq), dres_dv(ud%nq, ud%nq), mass(ud%nq, ud%nq)
    real(dp) :: a(ud%nq + ud%model%nc, ud%nq + ud%model%nc), b(ud%nq + ud%model%nc, 2*ud%nq)
    real(dp) :: dgt_mu_dq(ud%nq, ud%nq), dg_dq(ud%model%nc, ud%nq), dgv_dq(ud%model%nc, ud%nq)
    real(dp) :: dgv_dv(ud%model%nc, ud%nq), gdd_p(ud%model%nc), gdd_m(ud%model%nc)
    real(dp) :: qq(ud%nq), vv(ud%nq), h, w
    integer :: ipiv(ud%nq + ud%model%nc), nq, nc, j, info
    nq = ud%nq; nc = ud%model%nc; w = ud%omega
    jac = 0.0_dp
    status = 9_c_int                          ! GSL_EBADFUNC until the solve succeeds
    associate (model => ud%model, q => y(1:nq), v => y(nq + 1:2*nq))
      call solve_accelerations(model, t, q, v, vdot, lambda(1:nc), info, baumgarte_omega=w)
      if (info /= 0) return
      dres_dq = 0.0_dp; dres_dv = 0.0_dp; mass = 0.0_dp
      call eom_derivatives(model, t, q, v, vdot, lambda(1:nc), dres_dq, dres_dv, mass)
      a = 0.0_dp
      a(1:nq, 1:nq) = mass
      b(1:nq, 1:nq) = -dres_dq
      b(1:nq, nq + 1:) = -dres_dv
      if (nc > 0) then
        call constraint_derivatives(model, lambda(1:nc), dgt_mu_dq, dg_dq, dgv_dq, dgv_dv)
        a(nq + 1:, 1:nq) = dg_dq
        a(1:nq, nq + 1:) = transpose(dg_dq)
        b(nq + 1:, 1:nq) = -(w**2*dg_dq + 2.0_dp*w*dgv_dq)
        b(nq + 1:, nq + 1:) = -2.0_dp*w*dgv_dv
        ! The second-derivative part, d(G vdot + b)/dq and /dv: central differences.
        qq = q
        vv = v
        do j = 1, nq
          h = epsilon(1.0_dp)**(1.0_dp/3.0_dp)*max(abs(q(j)), 1.0_dp)
          qq(j) = q(j) + h
          call constraint_acceleration(qq, v, gdd_p)
          qq(j) = q(j) - h
          call constraint_acceleration(qq, v, gdd_m)
          qq(j) = q(j)
          b(nq + 1:, j) = b(nq + 1:, j) - (gdd_p - gdd_m)/(2.0_dp*h)
          h = max(abs(v(j)), 1.0_dp)
          vv(j) = v(j) + h
          call constraint_acceleration(q, vv, gdd_p)
          vv(j) = v(j) - h
          call constraint_acceleration(q, vv, gdd_m)
          vv(j) = v(j)
          b(nq + 1:, nq + j) = b(nq + 1:, nq + j) - (gdd_p - gdd_m)/(2.0_dp*h)
        end do
      end if
      call dgetrf(nq + nc, nq + nc, a, nq + nc, ipiv, info)
      if (info /= 0) return
      call dgetrs('N', nq + nc, 2*nq, a, nq + nc, ipiv, b, nq + nc, info)
      if (info /= 0) return
      do j = 1, nq
        jac(j, nq + j) = 1.0_dp
      end do
      jac(nq + 1:, :) = b(1:nq, :)
      if (any(jac /= jac)) return
    end associate
    status = GSL_SUCCESS

  contains

    !> G(q) vdot + b(q, v) at the solution's vdot.
    subroutine constraint_acceleration(qx, vx, gdd)
      real(dp), intent(in) :: qx(:), vx(:)
      real(dp), intent(out) :: gdd(:)
      real(dp) :: g_jac(nc, nq)
      call constraint_jacobian(ud%model, t, qx, g_jac)
      call constraint_bias(ud%model, t, qx, vx, gdd)
      gdd = gdd + matmul(g_jac, vdot)
    end subroutine constraint_acceleration
  end function jacobian_analytic

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
