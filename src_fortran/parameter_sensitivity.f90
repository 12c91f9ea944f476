!> Forward sensitivities of a time integration to design parameters (issue 24, flight runs;
!> docs/model.md "Design sensitivities of a flight").
!>
!> For each parameter p_k the GGL unknowns y = (q, v, lambda, mu) have the sensitivity
!> s_k = dy/dp_k, integrated by SUNDIALS IDAS with the state (IDASensInit, staggered corrector,
!> sensitivities in the error test; IDAS user guide, Hindmarsh, Serban et al., SUNDIALS 6.4,
!> sections 2.5 and 5.3) from the residual
!>
!>     F_y s_k + F_y' s_k' + F_p_k = 0.
!>
!> F_y s + F_y' s' is the analytic tangent of the GGL residual (ggl_residual_tangent, as in
!> rotorcable_monodromy); the explicit partial F_p = dF/dp at fixed (t, y, y') is a difference
!> of the GGL residual of the models rebuilt at p + s_i h (s_i = +-1 for a central difference),
!> F_p ~ sum_i w_i F(t, y, y'; p + s_i h) / h, O(h^2) (Nocedal & Wright, Numerical Optimization,
!> eq. 8.9; Python chooses h = eps^(1/3) max(|p|, 1 unit), pydriver.design.step: truncation and
!> round-off both ~1e-11 relative, far below the integration's tolerances).
!>
!> The initial sensitivities are made consistent here (IDACalcIC covers index 1 only): s_q and
!> s_v are corrected by least-norm steps onto the differentiated position and velocity rows
!> (G s_q + g_p = 0, H s_q + G s_v + (G v + g_t)_p = 0); s_q' = s_v; s_v' and s_lambda are the
!> difference of the acceleration-level solve (eq. 3.55) along (q + s_i h s_q, v + s_i h s_v) on
!> the rebuilt models.  As in rotorcable_monodromy, these two only seed IDAS's first predictor.
module rotorcable_parameter_sensitivity
  use, intrinsic :: iso_c_binding, only: c_int, c_long, c_double, c_ptr, c_loc, c_funloc, &
                                         c_f_pointer, c_associated, c_int64_t, c_null_ptr
  use rotorcable_kinds, only: dp
  use rotorcable_errors, only: error_type, fatal_error, sundials_flag_error
  use rotorcable_model, only: model_type, solve_accelerations, constraint_jacobian, add_load_forces, &
                              applied_generalized_forces, other_bodies_residual
  use rotorcable_linalg, only: solve_least_norm
  use rotorcable_ggl_residual, only: ida_user_data, ggl_residual_dense, ggl_residual_tangent, ggl_residual_columns
  use rotorcable_ida_binding, only: N_VNew_Serial, N_VDestroy, N_VGetArrayPointer, IDASensInit, &
                                    IDASensSVtolerances, IDASetSensErrCon, IDAGetSens, IDASensFree, &
                                    IDAGetSensNumResEvals, IDA_STAGGERED, IDASetInitStep, IDASensReInit, IDAReInit
  use rotorcable_nvector_kernels, only: use_fast_kernels
  use rotorcable_dae_integrator, only: integrator_settings, solver_stats, dae_session, session_start, &
                                       session_advance, session_end, session_step_onto_switch, session_restart, &
                                       LINEAR_SOLVER_BLOCK
  use rotorcable_sensitivity_newton, only: batched_newton, newton_attach, newton_free
  implicit none
  private
  public :: model_pointer, difference_points, parameter_sensitivity_run, parameter_partial

  !> A model by pointer (arrays of pointers need a wrapper type).
  type :: model_pointer
    type(model_type), pointer :: m => null()  !< null: the run's own model
  end type model_pointer

  !> The difference formula of every parameter: F_p = sum_i weight(i, k) F(model(i, k)) / h(k).
  type :: difference_points
    type(model_pointer), allocatable :: model(:, :)  !< (points, np) rebuilt models
    real(dp), allocatable :: offset(:, :)            !< (points, np) s_i, in steps
    real(dp), allocatable :: weight(:, :)            !< (points, np) w_i (0 = unused point)
    real(dp), allocatable :: h(:)                    !< (np) steps [unit of p]
    !> (np) the rebuilt models differ from the run's in their loads only (pydriver decides it
    !> from what was built): F_p is then that of the loads' generalized forces (loads_partial)
    logical, allocatable :: loads_only(:)
    !> (np) the rebuilt models have the run's kinematics (geometry, joints, supports, rotor) and
    !> differ in their bodies' masses and inertias and their loads (pydriver decides it): F_p is
    !> then that of their Newton-Euler pass on the run's motion (bodies_partial)
    logical, allocatable :: bodies_and_loads(:)
    !> (load slots, np) with loads_only or bodies_and_loads: the slots whose load the rebuilt
    !> models change; the others give the same forces at every point and cancel in the
    !> difference (weights sum to 0)
    logical, allocatable :: changed_load(:, :)
    type(model_type), pointer :: base => null()      !< the run's own model
    !> F_p of the last (t, y, y'): IDAS's staggered corrector calls the sensitivity residual at
    !> the state's converged (t, y, y') once per iteration, and F_p does not depend on s.
    real(dp), allocatable :: fp(:, :)                !< (n, np) cached F_p
    real(dp), allocatable :: y_at(:), yd_at(:)       !< where it was taken
    real(dp) :: t_at = -huge(1.0_dp)
    logical :: cached = .false.
  end type difference_points

  !> First step of a sensitivity run, in units of the run's length (rotorcable_monodromy's
  !> reason: the stiff twist modes make IDAS's own first step ~1e-25 s).
  real(dp), parameter :: INIT_STEP = 1.0e-7_dp

contains

  !> Integrate from (q0, v0) at t0 through the output times with the sensitivities of the
  !> np parameters, starting from the state sensitivities (sq0, sv0); returns the states and
  !> the sensitivities (s_q, s_v) at every output time.
  subroutine parameter_sensitivity_run(model, points, pbar, settings, t0, q0, v0, sq0, sv0, t_out, q_out, v_out, &
                                       sq_out, sv_out, stats, sens_residual_evals, error, sq_start, sv_start, &
                                       tolerance_scale)
    type(model_type), intent(inout), target :: model  !< the run's model
    type(difference_points), intent(inout), target :: points  !< rebuilt models and weights
    real(dp), intent(in) :: pbar(:)                   !< (np) parameter scales: atol of s_k = atol / pbar_k
    type(integrator_settings), intent(in) :: settings !< tolerances (also those of the sensitivities)
    real(dp), intent(in) :: t0                        !< start time [s]
    real(dp), intent(inout) :: q0(:), v0(:)           !< start state, made consistent in place
    real(dp), intent(in) :: sq0(:, :), sv0(:, :)      !< (nq, np) start sensitivities of q, v
    real(dp), intent(in) :: t_out(:)                  !< increasing output times > t0
    real(dp), intent(out) :: q_out(:, :), v_out(:, :) !< (nq, nt) states
    real(dp), intent(out) :: sq_out(:, :, :), sv_out(:, :, :)  !< (nq, nt, np) sensitivities
    type(solver_stats), intent(out) :: stats          !< solver statistics
    integer, intent(out) :: sens_residual_evals       !< sensitivity residual evaluations (all columns at once)
    type(error_type), intent(inout) :: error          !< status
    real(dp), intent(out), optional :: sq_start(:, :), sv_start(:, :)  !< (nq, np) the consistent start sensitivities
    !> the sensitivities' rtol and atol are the state's times this (default 1): products that
    !> enter a result with a small weight need proportionally less accuracy (inexact Krylov,
    !> Simoncini & Szyld, SIAM J. Sci. Comput. 25 (2003) 454; pydriver's periodic start)
    real(dp), intent(in), optional :: tolerance_scale
    real(dp) :: scale
    type(dae_session) :: s
    type(batched_newton), target :: newton
    type(c_ptr), allocatable, target :: ys(:), yps(:), atols(:)
    real(c_double), pointer :: col(:), base_atol(:)
    real(dp), allocatable :: ys0(:, :), yps0(:, :)
    real(c_double) :: tret
    integer(c_long) :: counter
    integer :: nq, nc, n, np, k, i

    nq = model%nq; nc = model%nc; n = 2*nq + 2*nc; np = size(pbar)
    scale = 1.0_dp
    if (present(tolerance_scale)) scale = tolerance_scale
    q_out = 0.0_dp; v_out = 0.0_dp; sq_out = 0.0_dp; sv_out = 0.0_dp; sens_residual_evals = 0
    points%base => model
    call session_start(s, model, settings, t0, q0, v0, error)
    if (error%code == 0) then
      allocate (ys0(n, np), yps0(n, np))
      call initial_sensitivities(model, points, t0, q0, v0, sq0, sv0, ys0, yps0, error)
      if (present(sq_start)) sq_start = ys0(1:nq, :)
      if (present(sv_start)) sv_start = ys0(nq + 1:2*nq, :)
    end if
    if (error%code == 0) then
      allocate (ys(np), yps(np), atols(np))
      ys = c_null_ptr; yps = c_null_ptr; atols = c_null_ptr   ! the clean-up frees only what was made
      call c_f_pointer(N_VGetArrayPointer(s%atol), base_atol, [n])
      do k = 1, np
        ys(k) = N_VNew_Serial(int(n, c_int64_t), s%ctx)
        yps(k) = N_VNew_Serial(int(n, c_int64_t), s%ctx)
        atols(k) = N_VNew_Serial(int(n, c_int64_t), s%ctx)
        if (.not. (c_associated(ys(k)) .and. c_associated(yps(k)) .and. c_associated(atols(k)))) then
          call fatal_error(error, 'SUNDIALS N_VNew_Serial returned NULL for a sensitivity vector (out of memory?)')
          exit
        end if
        if (settings%compiled_vector_kernels) then
          call use_fast_kernels(ys(k)); call use_fast_kernels(yps(k)); call use_fast_kernels(atols(k))
        end if
        call c_f_pointer(N_VGetArrayPointer(ys(k)), col, [n]); col = ys0(:, k)
        call c_f_pointer(N_VGetArrayPointer(yps(k)), col, [n]); col = yps0(:, k)
        ! s_k = dy/dp_k: a change pbar_k of p_k moves y by pbar_k s_k, which is held to the
        ! state's own tolerances (IDAS's pbar scaling, user guide 2.5).
        call c_f_pointer(N_VGetArrayPointer(atols(k)), col, [n]); col = scale*base_atol/pbar(k)
      end do
    end if
    if (error%code == 0) then
      s%ud%extra = c_loc(points)
      call check(IDASensInit(s%mem, int(np, c_int), IDA_STAGGERED, c_funloc(parameter_residual), &
                             c_loc(ys), c_loc(yps)), 'IDASensInit', s, error)
      call check(IDASensSVtolerances(s%mem, real(scale*settings%rtol, c_double), c_loc(atols)), &
                 'IDASensSVtolerances', s, error)
      ! Sensitivities OUT of the local error test (unlike the monodromy's): F_p is a difference
      ! quotient whose round-off, eps |F| / h ~ 1e-11 of the loads' scale, is noise from step to
      ! step, and the error test would chase it (rtol 1e-9: 180 000 steps a revolution against
      ! 4 600 for the state).  The sensitivities take the state's steps and the corrector's
      ! convergence test; their accuracy is checked against whole-run differences
      ! (tests/test_flight_sensitivities.py).
      call check(IDASetSensErrCon(s%mem, 0_c_int), 'IDASetSensErrCon', s, error)
      ! With the block solver, the corrector solves all the columns at once
      ! (rotorcable_sensitivity_newton).
      if (error%code == 0 .and. settings%linear_solver == LINEAR_SOLVER_BLOCK .and. associated(s%block)) &
        call check(newton_attach(newton, s%mem, s%ctx, np, n, s%block), 'IDASetNonlinearSolverSensStg', s, error)
      call check(IDASetInitStep(s%mem, real(INIT_STEP*(t_out(size(t_out)) - t0), c_double)), 'IDASetInitStep', &
                 s, error)
    end if
    if (error%code == 0) then
      ! One output time at a time: IDAGetSens interpolates the sensitivities at the time reached.
      do i = 1, size(t_out)
        ! A pulse edge on the way: the state is restarted there (IDAReInit), and so must the
        ! sensitivities be.  s_q, s_v are continuous across it (the switch times do not depend
        ! on p); s_v' and s_lambda jump with the loads and are made consistent again.
        do while (session_step_onto_switch(s, t_out(i), error))
          call restart_sensitivities(s, model, points, ys, yps, n, np, error)
          if (error%code /= 0) exit
        end do
        if (error%code /= 0) exit
        call session_advance(s, t_out(i:i), q_out(:, i:i), v_out(:, i:i), error)
        if (error%code /= 0) exit
        call check(IDAGetSens(s%mem, tret, c_loc(ys)), 'IDAGetSens', s, error)
        if (error%code /= 0) exit
        do k = 1, np
          call c_f_pointer(N_VGetArrayPointer(ys(k)), col, [n])
          sq_out(:, i, k) = col(1:nq)
          sv_out(:, i, k) = col(nq + 1:2*nq)
        end do
      end do
    end if
    if (c_associated(s%mem)) then
      if (IDAGetSensNumResEvals(s%mem, counter) == 0) sens_residual_evals = int(counter)
      call IDASensFree(s%mem)
    end if
    call session_end(s)
    call newton_free(newton)
    stats = s%stats
    if (allocated(ys)) then
      do k = 1, np
        if (c_associated(ys(k))) call N_VDestroy(ys(k))
        if (c_associated(yps(k))) call N_VDestroy(yps(k))
        if (c_associated(atols(k))) call N_VDestroy(atols(k))
      end do
    end if
  end subroutine parameter_sensitivity_run

  !> At a discontinuity of the loads (the session stands on it): read s, restart the state, make
  !> (s, s') consistent with the loads after the switch and restart IDAS's sensitivity history.
  subroutine restart_sensitivities(s, model, points, ys, yps, n, np, error)
    type(dae_session), intent(inout) :: s     !< session on the discontinuity
    type(model_type), intent(inout) :: model  !< the run's model
    type(difference_points), intent(inout) :: points  !< rebuilt models and weights
    type(c_ptr), intent(in), target :: ys(:), yps(:)  !< IDAS's sensitivity vectors
    integer, intent(in) :: n, np              !< unknowns, parameters
    type(error_type), intent(inout) :: error  !< status
    real(c_double), pointer :: col(:), y(:), yd(:)
    real(dp) :: sq(model%nq, np), sv(model%nq, np), ys1(n, np), yps1(n, np), q(model%nq), v(model%nq)
    real(dp) :: vd(model%nq), la(model%nc)
    real(c_double) :: tret
    integer :: k, nq, info
    nq = model%nq
    call check(IDAGetSens(s%mem, tret, c_loc(ys)), 'IDAGetSens', s, error)
    if (error%code /= 0) return
    do k = 1, np
      call c_f_pointer(N_VGetArrayPointer(ys(k)), col, [n])
      sq(:, k) = col(1:nq); sv(:, k) = col(nq + 1:2*nq)
    end do
    call session_restart(s, error)
    if (error%code /= 0) return
    call c_f_pointer(N_VGetArrayPointer(s%yy), y, [n])
    q = y(1:nq); v = y(nq + 1:2*nq)
    ! The state's rates after the switch too (the session restarts from the rates before it):
    ! with a fixed first step (IDASetInitStep) a stale v' is an O(h |jump of v'|) error in v that
    ! no step above ~1e-13 s passes at rtol 1e-10.
    call solve_accelerations(model, s%t_now, q, v, vd, la, info)
    if (info /= 0) then
      call fatal_error(error, 'parameter sensitivities: singular acceleration system at a pulse edge')
      return
    end if
    call c_f_pointer(N_VGetArrayPointer(s%yp), yd, [n])
    yd = 0.0_dp; yd(1:nq) = v; yd(nq + 1:2*nq) = vd
    y(2*nq + 1:2*nq + model%nc) = la
    call check(IDAReInit(s%mem, real(s%t_now, c_double), s%yy, s%yp), 'IDAReInit', s, error)
    if (error%code /= 0) return
    points%cached = .false.                    ! F_p of the loads before the switch
    call initial_sensitivities(model, points, s%t_now, q, v, sq, sv, ys1, yps1, error)
    if (error%code /= 0) return
    do k = 1, np
      call c_f_pointer(N_VGetArrayPointer(ys(k)), col, [n]); col = ys1(:, k)
      call c_f_pointer(N_VGetArrayPointer(yps(k)), col, [n]); col = yps1(:, k)
    end do
    call check(IDASensReInit(s%mem, IDA_STAGGERED, c_loc(ys), c_loc(yps)), 'IDASensReInit', s, error)
  end subroutine restart_sensitivities

  !> F_p of parameter k at (t, y, y'): the difference of the rebuilt models' GGL residuals.
  !> A one-sided difference evaluates the run's own model too, so callers evaluate its residual
  !> again before a tangent (which reuses the kinematics of the last residual).
  subroutine parameter_partial(points, k, t, y, yd, fp)
    include 'partial_arguments.inc'
    real(dp) :: r(size(fp))
    integer :: i
    fp = 0.0_dp
    ! No rebuilt model among the points: the formula differences the run's own model with
    ! itself (the state-transition products of the Krylov periodic start), F_p = 0 exactly.
    if (.not. any([(associated(points%model(i, k)%m), i = 1, size(points%weight, 1))])) return
    if (allocated(points%loads_only)) then
      if (points%loads_only(k)) then
        call loads_partial(points, k, t, y, yd, fp)
        return
      end if
    end if
    if (allocated(points%bodies_and_loads)) then
      if (points%bodies_and_loads(k)) then
        call bodies_partial(points, k, t, y, yd, fp)
        return
      end if
    end if
    do i = 1, size(points%weight, 1)
      if (points%weight(i, k) == 0.0_dp) cycle
      if (associated(points%model(i, k)%m)) then
        call ggl_residual_dense(points%model(i, k)%m, t, y, yd, r)
      else
        call ggl_residual_dense(points%base, t, y, yd, r)
      end if
      fp = fp + points%weight(i, k)*r
    end do
    fp = fp/points%h(k)
  end subroutine parameter_partial

  !> F_p of a parameter that changes the loads only.  Then only the equations of motion depend
  !> on it, through the loads' generalized forces Q (eom residual = inertia terms - Q), and Q is
  !> linear in the loads' forces at fixed kinematics (of the load slots it changes: the others
  !> give the same forces at every point, and the weights sum to 0):
  !>
  !>     F_p (v rows) = -J^T (sum_i w_i (force_i, moment_i)) / h - sum_i w_i tau_i / h,
  !>
  !> the rebuilt models' loads evaluated on the run's kinematics at (t, q, v) and mapped by one
  !> backward pass of J^T (applied_generalized_forces): no kinematics, inertia or constraint
  !> rows per point, which the whole residuals of the rebuilt models repeat.  The
  !> same difference formula as parameter_partial's, so the same truncation and round-off.
  subroutine loads_partial(points, k, t, y, yd, fp)
    include 'partial_arguments.inc'
    type(model_type), pointer :: base, m
    real(dp), allocatable :: force(:, :), moment(:, :), tau(:), gen(:)
    integer :: i, nq
    base => points%base
    nq = base%nq
    allocate (force(3, base%chain%n_bodies), moment(3, base%chain%n_bodies), tau(nq), gen(nq))
    force = 0.0_dp; moment = 0.0_dp; tau = 0.0_dp
    do i = 1, size(points%weight, 1)
      if (points%weight(i, k) == 0.0_dp) cycle
      m => point_model(points, i, k)
      call add_load_forces(base, m%loads, points%weight(i, k), t, y(1:nq), y(nq + 1:2*nq), force, moment, tau, &
                           changed_slots(points, k, size(m%loads)))
    end do
    call applied_generalized_forces(base, t, y(1:nq), y(nq + 1:2*nq), force, moment, tau, gen)
    fp = 0.0_dp
    fp(nq + 1:2*nq) = -gen/points%h(k)
  end subroutine loads_partial

  !> F_p of a parameter whose rebuilt models have the run's kinematics and other bodies (masses,
  !> inertias) and loads.  Then only the equations of motion depend on it, and their residual
  !> at the run's motion (t, q, v, v') is each rebuilt model's Newton-Euler pass with its bodies
  !> and loads (other_bodies_residual):
  !>
  !>     F_p (v rows) = sum_i w_i (pass_i - tau_i) / h,
  !>
  !> the terms that every point shares (the support's wrench, the load slots the parameter
  !> does not change and whose forces do not depend on the bodies, load_term%depends_on_bodies)
  !> cancelling (the weights sum to 0).  No kinematics, constraint rows or
  !> unchanged loads per point, which the whole residuals of the rebuilt models repeat; the
  !> same difference formula as parameter_partial's, so the same truncation and round-off.
  subroutine bodies_partial(points, k, t, y, yd, fp)
    include 'partial_arguments.inc'
    type(model_type), pointer :: base, m
    real(dp), allocatable :: res(:), sum_res(:)
    logical, allocatable :: only(:)
    integer :: i, j, nq
    base => points%base
    nq = base%nq
    allocate (res(nq), sum_res(nq))
    sum_res = 0.0_dp
    do i = 1, size(points%weight, 1)
      if (points%weight(i, k) == 0.0_dp) cycle
      m => point_model(points, i, k)
      only = changed_slots(points, k, size(m%loads))
      do j = 1, size(m%loads)
        only(j) = only(j) .or. m%loads(j)%term%depends_on_bodies
      end do
      call other_bodies_residual(base, m, t, y(1:nq), y(nq + 1:2*nq), yd(nq + 1:2*nq), only, res)
      sum_res = sum_res + points%weight(i, k)*res
    end do
    fp = 0.0_dp
    fp(nq + 1:2*nq) = sum_res/points%h(k)
  end subroutine bodies_partial

  !> The model of difference point i of parameter k: its rebuilt model, or the run's own.
  function point_model(points, i, k) result(m)
    type(difference_points), intent(in) :: points  !< rebuilt models and weights
    integer, intent(in) :: i, k               !< point, parameter
    type(model_type), pointer :: m
    m => points%model(i, k)%m
    if (.not. associated(m)) m => points%base
  end function point_model

  !> Which of a rebuilt model's nl load slots parameter k changes (points%changed_load; a slot
  !> it does not describe, or no description at all: changed).
  pure function changed_slots(points, k, nl) result(only)
    type(difference_points), intent(in) :: points  !< rebuilt models and weights
    integer, intent(in) :: k, nl              !< parameter, load slots
    logical :: only(nl)
    integer :: i
    only = .true.
    if (.not. allocated(points%changed_load)) return
    do i = 1, min(nl, size(points%changed_load, 1))
      only(i) = points%changed_load(i, k)
    end do
  end function changed_slots

  !> Consistent initial sensitivities of the GGL unknowns for every parameter (module comment).
  subroutine initial_sensitivities(model, points, t, q, v, sq0, sv0, ys, yps, error)
    type(model_type), intent(inout) :: model  !< model
    type(difference_points), intent(inout) :: points  !< rebuilt models and weights
    real(dp), intent(in) :: t                 !< time [s]
    real(dp), intent(in) :: q(:), v(:)        !< consistent state
    real(dp), intent(in) :: sq0(:, :), sv0(:, :)  !< (nq, np) given sensitivities of q and v
    real(dp), intent(out) :: ys(:, :)         !< (n, np) s
    real(dp), intent(out) :: yps(:, :)        !< (n, np) s'
    type(error_type), intent(inout) :: error  !< status
    real(dp) :: g_jac(model%nc, model%nq), y(size(ys, 1)), yd(size(ys, 1)), dy(size(ys, 1)), dyd(size(ys, 1))
    real(dp) :: dr(size(ys, 1)), fp(size(ys, 1)), vdot(model%nq), lambda(model%nc), corr(model%nq)
    real(dp) :: vd(model%nq), la(model%nc), d_vd(model%nq), d_la(model%nc), sq(model%nq), sv(model%nq), e
    integer :: nq, nc, n, k, i, info
    type(model_type), pointer :: m

    nq = model%nq; nc = model%nc; n = size(ys, 1)
    ys = 0.0_dp; yps = 0.0_dp
    call solve_accelerations(model, t, q, v, vdot, lambda, info)
    if (info /= 0) then
      call fatal_error(error, 'parameter sensitivities: singular acceleration system at the start')
      return
    end if
    y = 0.0_dp; yd = 0.0_dp
    y(1:nq) = q; y(nq + 1:2*nq) = v; y(2*nq + 1:2*nq + nc) = lambda
    yd(1:nq) = v; yd(nq + 1:2*nq) = vdot
    dyd = 0.0_dp
    if (nc > 0) call constraint_jacobian(model, t, q, g_jac)
    do k = 1, size(ys, 2)
      sq = sq0(:, k); sv = sv0(:, k)
      if (nc > 0) then
        call parameter_partial(points, k, t, y, yd, fp)
        ! Position rows G s_q + g_p = 0, then velocity rows H s_q + G s_v + (G v + g_t)_p = 0
        ! (the tangent at fixed v and y' gives G s_q and H s_q + G s_v), by least-norm steps.
        call ggl_residual_dense(model, t, y, yd, dr)
        dy = 0.0_dp; dy(1:nq) = sq
        call ggl_residual_tangent(model, t, y, yd, dy, dyd, 1, dr)
        call solve_least_norm(g_jac, dr(2*nq + 1:2*nq + nc) + fp(2*nq + 1:2*nq + nc), corr, info)
        if (info == 0) then
          sq = sq - corr
          dy = 0.0_dp; dy(1:nq) = sq; dy(nq + 1:2*nq) = sv
          call ggl_residual_tangent(model, t, y, yd, dy, dyd, 1, dr)
          call solve_least_norm(g_jac, dr(2*nq + nc + 1:n) + fp(2*nq + nc + 1:n), corr, info)
        end if
        if (info /= 0) then
          call fatal_error(error, 'parameter sensitivities: correction of a start sensitivity failed (LAPACK dgelsd)')
          return
        end if
        sv = sv - corr
      end if
      ! s_v', s_lambda: the same difference of the acceleration-level solve on the rebuilt models.
      d_vd = 0.0_dp; d_la = 0.0_dp
      do i = 1, size(points%weight, 1)
        if (points%weight(i, k) == 0.0_dp) cycle
        m => point_model(points, i, k)
        e = points%offset(i, k)*points%h(k)
        call solve_accelerations(m, t, q + e*sq, v + e*sv, vd, la, info)
        if (info /= 0) then
          call fatal_error(error, 'parameter sensitivities: singular acceleration system near the start')
          return
        end if
        d_vd = d_vd + points%weight(i, k)*vd
        d_la = d_la + points%weight(i, k)*la
      end do
      ys(1:nq, k) = sq
      ys(nq + 1:2*nq, k) = sv
      ys(2*nq + 1:2*nq + nc, k) = d_la/points%h(k)
      yps(1:nq, k) = sv
      yps(nq + 1:2*nq, k) = d_vd/points%h(k)
    end do
  end subroutine initial_sensitivities

  !> IDASensResFn: resval_k = F_y s_k + F_y' s_k' + F_p_k for every parameter.  Returns 0, or 1
  !> (recoverable: IDAS cuts the step) on a non-finite value.
  integer(c_int) function parameter_residual(ns, t, yy, yp, rr, yys, yps, rrs, udata, tmp1, tmp2, tmp3) bind(C)
    integer(c_int), value :: ns
    real(c_double), value :: t
    type(c_ptr), value :: yy, yp, rr, yys, yps, rrs, udata, tmp1, tmp2, tmp3
    type(ida_user_data), pointer :: ud
    type(difference_points), pointer :: points
    type(c_ptr), pointer :: ps(:), pps(:), prs(:)
    real(c_double), pointer :: y(:), yd(:), s(:), sd(:), rs(:)
    real(dp), allocatable :: columns(:, :), rates(:, :), changes(:, :)
    integer :: n, k
    call c_f_pointer(udata, ud)
    call c_f_pointer(ud%extra, points)
    n = 2*ud%nq + 2*ud%nc
    call c_f_pointer(N_VGetArrayPointer(yy), y, [n])
    call c_f_pointer(N_VGetArrayPointer(yp), yd, [n])
    allocate (columns(n, ns), rates(n, ns), changes(n, ns))
    call c_f_pointer(yys, ps, [ns]); call c_f_pointer(yps, pps, [ns]); call c_f_pointer(rrs, prs, [ns])
    parameter_residual = 0
    ! F_p of every column first (other models; or kept from the last call at this (t, y, y')),
    ! then the tangents of the run's model: the first evaluates its base point at (t, y, y')
    ! unless the model's workspace holds it already (eom_residual_tangent), as at the corrector's
    ! second iteration of a step, and the other columns reuse it.
    if (.not. allocated(points%fp)) allocate (points%fp(n, ns), points%y_at(n), points%yd_at(n))
    if (.not. (points%cached .and. t == points%t_at .and. all(y == points%y_at) .and. all(yd == points%yd_at))) then
      do k = 1, ns
        call parameter_partial(points, k, t, y, yd, points%fp(:, k))
      end do
      points%t_at = t; points%y_at = y; points%yd_at = yd; points%cached = .true.
    end if
    ! The tangents of all the columns at once, by the cheaper route for this many columns
    ! (ggl_residual_columns).
    do k = 1, ns
      call c_f_pointer(N_VGetArrayPointer(ps(k)), s, [n])
      call c_f_pointer(N_VGetArrayPointer(pps(k)), sd, [n])
      columns(:, k) = s
      rates(:, k) = sd
    end do
    call ggl_residual_columns(ud%model, t, y, yd, columns, rates, changes)
    do k = 1, ns
      call c_f_pointer(N_VGetArrayPointer(prs(k)), rs, [n])
      rs = points%fp(:, k) + changes(:, k)
      if (.not. all(abs(rs) <= huge(1.0_dp))) parameter_residual = 1
    end do
  end function parameter_residual

  !> A negative SUNDIALS flag becomes the error, with IDAS's own message.
  subroutine check(status, what, s, error)
    integer(c_int), intent(in) :: status
    character(len=*), intent(in) :: what
    type(dae_session), intent(in) :: s
    type(error_type), intent(inout) :: error
    call sundials_flag_error(error, status, what, s%ud%ida_message)
  end subroutine check

end module rotorcable_parameter_sensitivity
