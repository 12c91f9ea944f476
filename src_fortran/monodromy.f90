!> The monodromy matrix of a periodic run: the first-order map of a start perturbation over one
!> period, in coordinates on the constraint manifold (issue 21, docs/model.md "Monodromy matrix").
!>
!> The independent state is x = (a, b): q = q0 + N a, v = v0 + N b + (velocity correction), N an
!> orthonormal null-space basis of the constraint Jacobian G(q0, t0).  Each column of the
!> monodromy Phi = dx(t0 + T)/dx(t0) is one forward sensitivity s = dy/dx_k of the GGL unknowns
!> y = (q, v, lambda, mu).  The state and the 2 nf sensitivities are integrated as one DAE by
!> SUNDIALS IDA (tangent integration): Y = (y, s_1 ... s_ns), residual (F(t, y, y'),
!> F_y s_k + F_y' s_k'), the latter the analytic tangent sweep of the GGL residual
!> (ggl_residual_tangent, O(n) per column) or, for many columns on a short chain, the whole
!> derivative matrices times the columns (ggl_residual_columns).
!>
!> Why not IDAS's forward sensitivities (IDASensInit, which this module used before): IDAS
!> chooses the BDF order on the state's error estimates alone.  IDATestError (idas.c, SUNDIALS
!> 6.4.1) sets knew = k - 1 when max(terr_km1, terr_km2) <= terr_k, and IDASensTestError does
!> not reconsider once the state has asked for it.  From an equilibrium (hover: at rest in the
!> hub frame) the state's estimates are all zero or round-off, so the test is 0 <= 0 (or noise)
!> and the order is lowered at every step: the sensitivities, which oscillate at the stiff
!> twist frequencies, were integrated at order 1-2 with steps of ~1e-11 s (measured: 20000
!> steps reached t = 1.4e-6 s of a 0.23 s period).  One error norm and one order decision over
!> the whole Y avoid it.  The norm is IDA's WRMS over all of Y, so one column's error counts
!> at least 1/sqrt(ns + 1) of what IDAS's max over the columns counted.  The corrector's linear
!> solve is exact for the block lower-triangular Newton matrix of Y (tangent_ls_solve: the
!> state's LU and the coupling of the sensitivity rows on the state), so the moving starts of a
!> flight converge as well as the state alone.
!>
!> IDACalcIC covers index 1 only, so the consistent initial sensitivities are computed here,
!> as consistent_start does for the state: s_q = N a satisfies G s_q = 0; s_v = N b - G^+ H s_q
!> with H = d(G v + g_t)/dq satisfies the differentiated velocity rows H s_q + G s_v = 0;
!> s_q' = s_v (mu = 0); s_v' and s_lambda are the directional derivative of the
!> acceleration-level solve (eq. 3.55) along (s_q, s_v).
module rotorcable_monodromy
  use, intrinsic :: iso_c_binding, only: c_int, c_long, c_double, c_ptr, c_loc, c_funloc, c_char, &
                                         c_f_pointer, c_associated, c_int64_t, c_null_ptr
  use rotorcable_kinds, only: dp
  use rotorcable_errors, only: error_type, fatal_error, sundials_flag_error
  use rotorcable_model, only: model_type, solve_accelerations, constraint_jacobian, switch_times
  use rotorcable_linalg, only: null_space, solve_least_norm
  use rotorcable_ggl_linear_solver, only: ggl_block_solver, block_solver_create, block_solver_destroy, &
                                          block_factorise, block_solve, block_solve_columns
  use rotorcable_ggl_residual, only: ggl_residual_dense, ggl_residual_tangent, ggl_residual_columns, &
                                     ggl_jacobian_dense
  use rotorcable_ida_binding, only: SUNContext_Create, SUNContext_Free, N_VNew_Serial, N_VDestroy, &
                                    N_VGetArrayPointer, IDACreate, IDAInit, IDASVtolerances, IDASetUserData, &
                                    IDASetErrHandlerFn, IDASetId, IDASetSuppressAlg, IDASetMaxNumSteps, &
                                    IDASetMaxStep, IDASetInitStep, IDASetLinearSolver, IDASolve, IDAFree, &
                                    IDA_NORMAL, IDAGetNumSteps, IDAGetNumResEvals, IDAGetNumErrTestFails, &
                                    IDAGetNumNonlinSolvConvFails, IDAGetCurrentCj, sun_linear_solver, &
                                    sun_linear_solver_ops, SUNLinSolNewEmpty, SUNLinSolFreeEmpty, &
                                    SUNLINEARSOLVER_MATRIX_EMBEDDED, SUNLS_SUCCESS, SUNLS_LUFACT_FAIL, SUNLS_PACKAGE_FAIL_REC, &
                                    copy_solver_message
  use rotorcable_dae_integrator, only: integrator_settings, solver_stats, consistent_start
  use rotorcable_nvector_kernels, only: use_fast_kernels
  implicit none
  private
  public :: monodromy_run, monodromy_columns_run, initial_sensitivities

  !> Step of the central difference of the acceleration-level solve per unit of the direction.
  !> s_v' and s_lambda only seed the predictor of IDA's first step (BDF's corrector determines
  !> the new values from the residual alone), so their O(eps^2) truncation error costs at most a
  !> step size, never accuracy.
  real(dp), parameter :: ACCEL_STEP = 1.0e-6_dp

  !> First step of a sensitivity run, in periods (see monodromy_run).
  real(dp), parameter :: INIT_STEP = 1.0e-7_dp

  !> Factorise the iteration matrix again when cj has moved by more than this fraction since
  !> (IDA's own rule for a matrix-based solver's setup, idas_ls.c: dcj = 0.25).
  real(dp), parameter :: CJ_WINDOW = 0.25_dp

  integer(c_int), parameter :: SUNLINEARSOLVER_CUSTOM = 17  !< SUNLinearSolver_ID

  !> User data of the tangent system's IDA run and content of its linear solver.
  type :: tangent_data
    type(model_type), pointer :: model => null()
    integer :: nq = 0, nc = 0, ns = 0
    type(c_ptr) :: mem = c_null_ptr           !< IDA memory (cj, step and failure counters)
    real(dp) :: t = 0.0_dp                    !< time of the last residual [s]
    real(dp), allocatable :: y(:), yd(:)      !< state (y, y') of the last residual
    real(dp), allocatable :: s(:, :), sd(:, :) !< sensitivities (s_k, s_k') of the last residual
    real(dp), allocatable :: jac(:, :)        !< the state's iteration matrix (its factors: block)
    type(ggl_block_solver) :: block           !< their block factorisation (rotorcable_ggl_linear_solver)
    logical :: factorised = .false.
    logical :: analytic = .true.              !< physics columns by tangent sweeps (else differences)
    real(dp) :: cj = 1.0_dp                   !< cj of the factors
    integer(c_long) :: factor_step = 0, factor_fails = 0
    integer :: max_age = 100                  !< steps over which the factors are kept
    integer :: factorisations = 0
    integer :: column_evals = 0               !< evaluations of all the columns (one per Newton iteration)
    character(len=512) :: ida_message = ''
  end type tangent_data

contains

  !> Integrate one period from (q0, v0) at t0 with the forward sensitivities of the 2 nf
  !> independent coordinates; returns the states at the output times and the monodromy matrix.
  subroutine monodromy_run(model, settings, t0, q0, v0, t_out, q_out, v_out, basis, phi, stats, &
                           sens_residual_evals, error)
    type(model_type), intent(inout), target :: model  !< model
    type(integrator_settings), intent(in) :: settings !< tolerances (also those of the sensitivities)
    real(dp), intent(in) :: t0                        !< start time [s]
    real(dp), intent(inout) :: q0(:), v0(:)           !< start state, made consistent in place
    real(dp), intent(in) :: t_out(:)                  !< increasing output times > t0; the last ends the period
    real(dp), intent(out) :: q_out(:, :), v_out(:, :) !< (nq, size(t_out)) states
    real(dp), intent(out) :: basis(:, :)              !< (nq, nf) N at the start
    real(dp), intent(out) :: phi(:, :)                !< (2 nf, 2 nf) monodromy in x = (a, b)
    type(solver_stats), intent(out) :: stats          !< solver statistics
    integer, intent(out) :: sens_residual_evals       !< sensitivity residual evaluations (all columns at once)
    type(error_type), intent(inout) :: error          !< status
    call tangent_run(model, settings, settings%atol, t0, q0, v0, t_out, q_out, v_out, basis, phi, stats, &
                     sens_residual_evals, error)
  end subroutine monodromy_run

  !> The monodromy applied to k start perturbations: one period from (q0, v0) at t0 with the
  !> forward sensitivities of the start directions x_j = (N^T dq_j, N^T dv_j), returning
  !> Phi [x_1 ... x_k] (a subspace of the monodromy, for the least damped Floquet modes without
  !> the 2 nf columns of the whole matrix; pydriver/analyses/floquet_subspace.py).  The
  !> perturbations are given in q so that a caller needs no basis before the first call; the
  !> same start gives the same N, so a later call may pass N x for a direction x.  The
  !> sensitivities' absolute tolerance is column_atol (per unit of the perturbation), the
  !> state's stays settings%atol: a multiplier far below the state's tolerance is resolved only
  !> when the columns are held to a tolerance below it.
  subroutine monodromy_columns_run(model, settings, column_atol, t0, q0, v0, t_out, dq, dv, q_out, v_out, basis, &
                                   images, stats, sens_residual_evals, error)
    type(model_type), intent(inout), target :: model  !< model
    type(integrator_settings), intent(in) :: settings !< tolerances of the state (rtol also of the columns)
    real(dp), intent(in) :: column_atol               !< absolute tolerance of the columns' q and v rows
    real(dp), intent(in) :: t0                        !< start time [s]
    real(dp), intent(inout) :: q0(:), v0(:)           !< start state, made consistent in place
    real(dp), intent(in) :: t_out(:)                  !< increasing output times > t0; the last ends the period
    real(dp), intent(in) :: dq(:, :), dv(:, :)        !< (nq, k) start perturbations of q and v
    real(dp), intent(out) :: q_out(:, :), v_out(:, :) !< (nq, size(t_out)) states
    real(dp), intent(out) :: basis(:, :)              !< (nq, nf) N at the start
    real(dp), intent(out) :: images(:, :)             !< (2 nf, k) Phi x_j in x = (a, b)
    type(solver_stats), intent(out) :: stats          !< solver statistics
    integer, intent(out) :: sens_residual_evals       !< sensitivity residual evaluations (all columns at once)
    type(error_type), intent(inout) :: error          !< status
    call tangent_run(model, settings, column_atol, t0, q0, v0, t_out, q_out, v_out, basis, images, stats, &
                     sens_residual_evals, error, dq, dv)
  end subroutine monodromy_columns_run

  !> One period of the state with ns = size(images, 2) tangent columns: the unit directions of
  !> x (the monodromy) or, with dq and dv, the given start perturbations projected onto x.
  subroutine tangent_run(model, settings, column_atol, t0, q0, v0, t_out, q_out, v_out, basis, images, stats, &
                         sens_residual_evals, error, dq, dv)
    type(model_type), intent(inout), target :: model
    type(integrator_settings), intent(in) :: settings
    real(dp), intent(in) :: column_atol
    real(dp), intent(in) :: t0
    real(dp), intent(inout) :: q0(:), v0(:)
    real(dp), intent(in) :: t_out(:)
    real(dp), intent(out) :: q_out(:, :), v_out(:, :)
    real(dp), intent(out) :: basis(:, :)
    real(dp), intent(out) :: images(:, :)
    type(solver_stats), intent(out) :: stats
    integer, intent(out) :: sens_residual_evals
    type(error_type), intent(inout) :: error
    real(dp), intent(in), optional :: dq(:, :), dv(:, :)
    type(tangent_data), pointer :: td
    type(sun_linear_solver), pointer :: ls
    type(sun_linear_solver_ops), pointer :: ops
    type(c_ptr) :: ctx, mem, yy, yp, id, atol, lsol
    real(c_double), pointer :: y(:), yd(:), idv(:), av(:)
    real(dp), allocatable :: ys0(:, :), yps0(:, :), t_switch(:)
    real(dp) :: vdot(model%nq), lambda(max(model%nc, 1))
    real(c_double) :: tret
    integer(c_long) :: counter
    integer(c_int) :: flag
    integer :: nq, nc, nf, n, ns, k, big, j
    character(len=96) :: buf

    nq = model%nq; nc = model%nc; nf = nq - nc; n = 2*nq + 2*nc; ns = size(images, 2); big = n*(ns + 1)
    q_out = 0.0_dp; v_out = 0.0_dp; basis = 0.0_dp; images = 0.0_dp; sens_residual_evals = 0
    stats = solver_stats()
    ctx = c_null_ptr; mem = c_null_ptr; yy = c_null_ptr; yp = c_null_ptr; id = c_null_ptr; atol = c_null_ptr
    lsol = c_null_ptr
    call consistent_start(model, t0, q0, v0, vdot, lambda(1:nc), error)
    if (error%code /= 0) return
    call switch_times(model, t_switch)
    t_switch = pack(t_switch, t_switch > t0)
    if (size(t_switch) > 0) then
      if (t_switch(1) <= t_out(size(t_out))) then
        call fatal_error(error, 'the monodromy matrix needs loads '// &
                         'without switch times within the period (a pulse makes the motion non-periodic)')
        return
      end if
    end if
    allocate (ys0(n, ns), yps0(n, ns))
    call initial_sensitivities(model, t0, q0, v0, basis, ys0, yps0, error, dq, dv)
    if (error%code /= 0) return

    allocate (td)
    td%model => model
    td%nq = nq; td%nc = nc; td%ns = ns
    td%max_age = settings%jacobian_max_age
    td%analytic = settings%analytic_jacobian
    allocate (td%jac(n, n), td%y(n), td%yd(n), td%s(n, ns), td%sd(n, ns))
    if (SUNContext_Create(c_null_ptr, ctx) /= 0 .or. .not. c_associated(ctx)) then
      call fatal_error(error, 'SUNDIALS SUNContext_Create failed')
      deallocate (td)
      return
    end if
    call block_solver_create(td%block, nq, nc, ctx)
    yy = N_VNew_Serial(int(big, c_int64_t), ctx); yp = N_VNew_Serial(int(big, c_int64_t), ctx)
    id = N_VNew_Serial(int(big, c_int64_t), ctx); atol = N_VNew_Serial(int(big, c_int64_t), ctx)
    if (.not. (c_associated(yy) .and. c_associated(yp) .and. c_associated(id) .and. c_associated(atol))) &
      call fatal_error(error, 'SUNDIALS N_VNew_Serial returned NULL for the tangent system (out of memory?)')
    if (error%code == 0 .and. settings%compiled_vector_kernels) then
      ! The compiled vector kernels, as the state's integration takes them (nvector_kernels:
      ! libsundials's own are built without optimisation); here they run over the state and all
      ! the columns, and took a third of a Newton-Picard revolution's time (perf, 10 columns).
      call use_fast_kernels(yy); call use_fast_kernels(yp)
      call use_fast_kernels(id); call use_fast_kernels(atol)
    end if
    if (error%code == 0) then
      call c_f_pointer(N_VGetArrayPointer(yy), y, [big])
      call c_f_pointer(N_VGetArrayPointer(yp), yd, [big])
      call c_f_pointer(N_VGetArrayPointer(id), idv, [big])
      call c_f_pointer(N_VGetArrayPointer(atol), av, [big])
      y = 0.0_dp; yd = 0.0_dp
      y(1:nq) = q0; y(nq + 1:2*nq) = v0; y(2*nq + 1:2*nq + nc) = lambda(1:nc)
      yd(1:nq) = v0; yd(nq + 1:2*nq) = vdot
      do k = 1, ns
        y(k*n + 1:(k + 1)*n) = ys0(:, k); yd(k*n + 1:(k + 1)*n) = yps0(:, k)
      end do
      ! Every block as the state's: q and v differential with atol (the sensitivities are per
      ! unit of x, rad and rad/s; the columns' own column_atol), lambda and mu algebraic with the
      ! loose atol_multiplier and out of the error test (IDASetSuppressAlg; as in
      ! dae_integrator.f90's session_start).
      do k = 0, ns
        j = k*n
        idv(j + 1:j + 2*nq) = 1.0_dp; idv(j + 2*nq + 1:j + n) = 0.0_dp
        av(j + 1:j + 2*nq) = merge(settings%atol, column_atol, k == 0)
        av(j + 2*nq + 1:j + n) = settings%atol_multiplier
      end do
      mem = IDACreate(ctx)
      if (.not. c_associated(mem)) call fatal_error(error, 'SUNDIALS IDACreate returned NULL')
    end if
    if (error%code == 0) then
      td%mem = mem
      call check(IDAInit(mem, c_funloc(tangent_residual), real(t0, c_double), yy, yp), 'IDAInit', td, error)
      call check(IDASVtolerances(mem, real(settings%rtol, c_double), atol), 'IDASVtolerances', td, error)
      call check(IDASetUserData(mem, c_loc(td)), 'IDASetUserData', td, error)
      call check(IDASetErrHandlerFn(mem, c_funloc(tangent_error_handler), c_loc(td)), 'IDASetErrHandlerFn', td, &
                 error)
      call check(IDASetId(mem, id), 'IDASetId', td, error)
      call check(IDASetSuppressAlg(mem, 1_c_int), 'IDASetSuppressAlg', td, error)
      call check(IDASetMaxNumSteps(mem, int(settings%max_steps, c_long)), 'IDASetMaxNumSteps', td, error)
      if (settings%h_max > 0.0_dp) &
        call check(IDASetMaxStep(mem, real(settings%h_max, c_double)), 'IDASetMaxStep', td, error)
      ! IDA's first step is 0.5/||y'||: the stiff twist modes give s_v' ~ w^2 ~ 1e7/s^2, which at
      ! atol 1e-12 means h ~ 1e-25 s, where cj^2 amplifies the round-off of the index-2
      ! multiplier sensitivities beyond any Newton tolerance (the corrector failed at t = 0 at
      ! rtol 1e-10).  A first step of INIT_STEP periods lets the error test shorten it instead.
      call check(IDASetInitStep(mem, real(INIT_STEP*(t_out(size(t_out)) - t0), c_double)), 'IDASetInitStep', &
                 td, error)
      lsol = SUNLinSolNewEmpty(ctx)
      if (.not. c_associated(lsol)) call fatal_error(error, 'SUNDIALS SUNLinSolNewEmpty returned NULL')
    end if
    if (error%code == 0) then
      call c_f_pointer(lsol, ls)
      ls%content = c_loc(td)
      call c_f_pointer(ls%ops, ops)
      ops%gettype = c_funloc(tangent_ls_gettype)
      ops%getid = c_funloc(tangent_ls_getid)
      ops%solve = c_funloc(tangent_ls_solve)
      call check(IDASetLinearSolver(mem, lsol, c_null_ptr), 'IDASetLinearSolver', td, error)
    end if
    if (error%code == 0) then
      tret = real(t0, c_double)
      do k = 1, size(t_out)
        flag = IDASolve(mem, real(t_out(k), c_double), tret, yy, yp, IDA_NORMAL)
        if (flag == -1_c_int) then      ! IDA_TOO_MUCH_WORK
          write (buf, '(a, i0, a, es10.3, a)') 'step budget (solver max_steps = ', settings%max_steps, &
            ') used up at t = ', tret, ' s'
          call fatal_error(error, trim(buf)//' in the monodromy''s tangent integration')
          exit
        end if
        call check(flag, 'IDASolve', td, error)
        if (error%code /= 0) exit
        q_out(:, k) = y(1:nq); v_out(:, k) = y(nq + 1:2*nq)
      end do
    end if
    if (error%code == 0) then
      do k = 1, ns
        images(1:nf, k) = matmul(y(k*n + 1:k*n + nq), basis)
        images(nf + 1:2*nf, k) = matmul(y(k*n + nq + 1:k*n + 2*nq), basis)
      end do
    end if
    if (c_associated(mem)) then
      if (IDAGetNumSteps(mem, counter) == 0) stats%steps = int(counter)
      if (IDAGetNumResEvals(mem, counter) == 0) stats%residual_evals = int(counter)
      if (IDAGetNumErrTestFails(mem, counter) == 0) stats%error_test_failures = int(counter)
      if (IDAGetNumNonlinSolvConvFails(mem, counter) == 0) stats%convergence_failures = int(counter)
      stats%jacobian_evals = td%factorisations
      ! The linear solver evaluates all the sensitivity columns once a Newton iteration
      ! (tangent_ls_solve); the residuals do not.
      sens_residual_evals = td%column_evals
      call IDAFree(mem)
    end if
    if (c_associated(lsol)) then
      call c_f_pointer(lsol, ls)
      ls%content = c_null_ptr
      call SUNLinSolFreeEmpty(lsol)
    end if
    if (c_associated(yy)) call N_VDestroy(yy)
    if (c_associated(yp)) call N_VDestroy(yp)
    if (c_associated(id)) call N_VDestroy(id)
    if (c_associated(atol)) call N_VDestroy(atol)
    call block_solver_destroy(td%block)
    if (c_associated(ctx)) flag = SUNContext_Free(ctx)
    deallocate (td)
  end subroutine tangent_run

  !> IDAResFn of the tangent system Y = (y, s_1 ... s_ns): the GGL residual F(t, y, y') of the
  !> state, and zero in the columns' rows.  The columns' residuals F_y s_k + F_y' s_k' are taken
  !> by the linear solver at the state's Newton update instead (tangent_ls_solve: one evaluation
  !> of all the columns per Newton iteration, not two), and IDA uses a residual only as the
  !> right-hand side of that solve.  Returns 0, or 1 (recoverable: IDA cuts the step) on a
  !> non-finite value.
  integer(c_int) function tangent_residual(t, yy, yp, rr, udata) bind(C)
    real(c_double), value :: t
    type(c_ptr), value :: yy, yp, rr, udata
    type(tangent_data), pointer :: td
    real(c_double), pointer :: y(:), yd(:), r(:)
    integer :: n, big
    call c_f_pointer(udata, td)
    n = 2*td%nq + 2*td%nc; big = n*(td%ns + 1)
    call c_f_pointer(N_VGetArrayPointer(yy), y, [big])
    call c_f_pointer(N_VGetArrayPointer(yp), yd, [big])
    call c_f_pointer(N_VGetArrayPointer(rr), r, [big])
    call ggl_residual_dense(td%model, t, y(1:n), yd(1:n), r(1:n))
    r(n + 1:big) = 0.0_dp
    ! The iterate of this residual: where a factorisation that follows is taken, and the
    ! columns' values of the Newton update.
    td%t = t; td%y = y(1:n); td%yd = yd(1:n)
    td%s = reshape(y(n + 1:big), [n, td%ns]); td%sd = reshape(yd(n + 1:big), [n, td%ns])
    tangent_residual = 0
    if (.not. all(abs(r(1:n)) <= huge(1.0_dp))) tangent_residual = 1
  end function tangent_residual

  !> SUNLinSolSolve of the tangent system.  Its Newton matrix is block lower triangular,
  !>   [ J    0 ] [dy ]   [b_0]      J   = F_y + cj F_y' (the state's GGL iteration matrix),
  !>   [ C_k  J ] [ds_k] = [b_k],    C_k = d(F_y s_k + F_y' s_k')/dy + cj d(...)/dy',
  !> b_k = -(F_y s_k + F_y' s_k') at the iterate (y, y'), and is solved by forward substitution:
  !> dy = J^-1 b_0, then ds_k = J^-1 (b_k - C_k dy).  The columns' rows are linear in s, so
  !> b_k - C_k dy = -(F_y s_k + F_y' s_k') at the updated state (y + dy, y' + cj dy), to
  !> O(|dy|^2), the order Newton's step already neglects: one evaluation of all the columns per
  !> Newton iteration, there (tangent_residual leaves them out).  Before, the columns were
  !> evaluated at the iterate (the residual) and again at y + eps dy (C_k dy by a forward
  !> difference): twice as many, and on the main job's cable at n = 11 (54 columns) those
  !> evaluations were most of a Floquet revolution's time.  The coupling must not be dropped.
  !> With the block diagonal alone (this module's first tangent version) the corrector is a
  !> modified Newton whose sensitivity corrections miss C_k dy, and its convergence test, which
  !> sees only the size and rate of the last correction, accepts iterates whose iteration error
  !> (so we read the counts below) the error test then takes for local error.  Measured on the
  !> free 4-body chain in the stream (tests/test_monodromy.py, rtol 1e-8): 16 796 error-test
  !> failures and 2 convergence failures in 20 000 steps, stalled at t = 0.163 s of the 0.23 s
  !> period with steps of ~4e-8 s; with the coupling 4 676 steps, 180 error-test failures, none
  !> of convergence.  J is factorised (block elimination, rotorcable_ggl_linear_solver) at the
  !> last residual's iterate when cj has moved by more than CJ_WINDOW, after a convergence
  !> failure, or after max_age steps; IDA calls no setup for a matrix-embedded solver
  !> (chain_linear_solver's header).  A singular factor or a non-finite column is recoverable.
  integer(c_int) function tangent_ls_solve(lsol, a, x, b, tol) bind(C)
    type(c_ptr), value :: lsol, a, x, b
    real(c_double), value :: tol
    type(sun_linear_solver), pointer :: wrapper
    type(tangent_data), pointer :: td
    real(c_double), pointer :: xv(:), bv(:)
    real(c_double), pointer, contiguous :: xs(:, :)
    real(dp), allocatable :: yp(:), ydp(:), r0(:)
    real(c_double) :: cj
    integer(c_long) :: steps, fails
    integer(c_int) :: flag
    integer :: n, info
    call c_f_pointer(lsol, wrapper)
    call c_f_pointer(wrapper%content, td)
    tangent_ls_solve = SUNLS_SUCCESS
    flag = IDAGetCurrentCj(td%mem, cj)
    flag = IDAGetNumSteps(td%mem, steps)
    flag = IDAGetNumNonlinSolvConvFails(td%mem, fails)
    if (.not. td%factorised .or. abs(cj/td%cj - 1.0_dp) > CJ_WINDOW .or. fails /= td%factor_fails .or. &
        steps - td%factor_step >= td%max_age .or. steps < td%factor_step) then
      ! The block elimination of the GGL matrix (rotorcable_ggl_linear_solver: LU of order nq and
      ! 2 nc instead of 2 nq + 2 nc, 8-13x fewer flops; it leaves out d(G^T mu)/dq, O(|mu|),
      ! as the state's own integration does): at n = 44 the dense LU of order 276 took a third
      ! of a Floquet revolution's time.
      call ggl_jacobian_dense(td%model, td%t, cj, td%y, td%yd, td%jac, td%analytic)
      td%block%cj = cj
      call block_factorise(td%block, td%jac, info)
      td%factorised = info == 0
      td%factorisations = td%factorisations + 1
      td%cj = cj; td%factor_step = steps; td%factor_fails = fails
      if (info /= 0) then
        tangent_ls_solve = SUNLS_LUFACT_FAIL
        return
      end if
    end if
    n = 2*td%nq + 2*td%nc
    call c_f_pointer(N_VGetArrayPointer(x), xv, [n*(td%ns + 1)])
    call c_f_pointer(N_VGetArrayPointer(b), bv, [n*(td%ns + 1)])
    xv(1:n) = bv(1:n)
    call block_solve(td%block, bv(1:n), xv(1:n))
    ! The columns' right-hand sides at the updated state (this function's doc).
    allocate (yp(n), ydp(n), r0(n))
    yp = td%y + xv(1:n); ydp = td%yd + cj*xv(1:n)
    call ggl_residual_dense(td%model, td%t, yp, ydp, r0)
    xs(1:n, 1:td%ns) => xv(n + 1:n*(td%ns + 1))
    call ggl_residual_columns(td%model, td%t, yp, ydp, td%s, td%sd, xs, held=.true.)
    td%column_evals = td%column_evals + 1
    if (.not. all(abs(xs) <= huge(1.0_dp))) then
      tangent_ls_solve = SUNLS_PACKAGE_FAIL_REC
      return
    end if
    xs = -xs
    ! The model's kinematics and loads back at the iterate (a factorisation reads them).
    call ggl_residual_dense(td%model, td%t, td%y, td%yd, r0)
    ! All the columns in one call (matrix products and LAPACK solves over the block, BLAS level
    ! 3) instead of one triangular pair each: those were a fifth of a Newton-Picard revolution's
    ! time on the main job's cable (perf, 10 columns of order 78).
    call block_solve_columns(td%block, xs)
  end function tangent_ls_solve

  !> SUNLinSolGetType: a solver that holds its own matrix.
  integer(c_int) function tangent_ls_gettype(lsol) bind(C)
    type(c_ptr), value :: lsol
    tangent_ls_gettype = SUNLINEARSOLVER_MATRIX_EMBEDDED
  end function tangent_ls_gettype

  !> SUNLinSolGetID.
  integer(c_int) function tangent_ls_getid(lsol) bind(C)
    type(c_ptr), value :: lsol
    tangent_ls_getid = SUNLINEARSOLVER_CUSTOM
  end function tangent_ls_getid

  !> IDA error handler: keep the message for the Python exception instead of printing it.
  subroutine tangent_error_handler(code, module_name, function_name, msg, udata) bind(C)
    integer(c_int), value :: code
    type(c_ptr), value :: module_name, function_name, msg, udata
    type(tangent_data), pointer :: td
    if (.not. c_associated(udata)) return
    call c_f_pointer(udata, td)
    call copy_solver_message(code, msg, td%ida_message)
  end subroutine tangent_error_handler

  !> Consistent initial sensitivities of the GGL unknowns for the 2 nf unit directions of
  !> x = (a, b) at a consistent start (q, v): column k <= nf moves a_k, column nf + k moves b_k;
  !> or, with dq and dv, for the directions x_k = (N^T dq_k, N^T dv_k) of given perturbations.
  subroutine initial_sensitivities(model, t, q, v, basis, ys, yps, error, dq, dv)
    type(model_type), intent(inout) :: model  !< model
    real(dp), intent(in) :: t                 !< time [s]
    real(dp), intent(in) :: q(:), v(:)        !< consistent state
    real(dp), intent(out) :: basis(:, :)      !< (nq, nf) orthonormal N with G N = 0
    real(dp), intent(out) :: ys(:, :)         !< (n, 2 nf, or k) s = dy/dx
    real(dp), intent(out) :: yps(:, :)        !< (n, 2 nf, or k) s' = dy'/dx
    type(error_type), intent(inout) :: error  !< status
    real(dp), intent(in), optional :: dq(:, :), dv(:, :)  !< (nq, k) perturbations (absent: unit directions)
    real(dp) :: g_jac(model%nc, model%nq), y(size(ys, 1)), yd(size(ys, 1)), dy(size(ys, 1)), dyd(size(ys, 1))
    real(dp) :: dr(size(ys, 1)), vdot(model%nq), lambda(model%nc), corr(model%nq)
    real(dp) :: vd_p(model%nq), vd_m(model%nq), la_p(model%nc), la_m(model%nc), sq(model%nq), sv(model%nq), h
    integer :: nq, nc, nf, n, k, info

    nq = model%nq; nc = model%nc; nf = nq - nc; n = size(ys, 1)
    ys = 0.0_dp; yps = 0.0_dp
    if (nc > 0) call constraint_jacobian(model, t, q, g_jac)
    call null_space(g_jac, basis, info)
    if (info /= 0) then
      call fatal_error(error, 'monodromy: null space of the constraint Jacobian failed (LAPACK dgesvd)')
      return
    end if
    call solve_accelerations(model, t, q, v, vdot, lambda, info)
    if (info /= 0) then
      call fatal_error(error, 'monodromy: singular acceleration system at the start')
      return
    end if
    y = 0.0_dp; yd = 0.0_dp
    y(1:nq) = q; y(nq + 1:2*nq) = v; y(2*nq + 1:2*nq + nc) = lambda
    yd(1:nq) = v; yd(nq + 1:2*nq) = vdot
    dyd = 0.0_dp
    do k = 1, size(ys, 2)
      sq = 0.0_dp; sv = 0.0_dp
      if (present(dq)) then
        ! The perturbation's part in the tangent space (G N a = 0); its normal part would move
        ! the start off the constraints, which no consistent start can.
        sq = matmul(basis, matmul(dq(:, k), basis))
        sv = matmul(basis, matmul(dv(:, k), basis))
      else if (k <= nf) then
        sq = basis(:, k)
      else
        sv = basis(:, k - nf)
      end if
      if (nc > 0 .and. (k <= nf .or. present(dq))) then
        ! H s_q: the velocity rows of the residual's tangent at fixed v (state set just before).
        call ggl_residual_dense(model, t, y, yd, dr)
        dy = 0.0_dp; dy(1:nq) = sq
        call ggl_residual_tangent(model, t, y, yd, dy, dyd, 1, dr)
        call solve_least_norm(g_jac, dr(2*nq + nc + 1:n), corr, info)
        if (info /= 0) then
          call fatal_error(error, 'monodromy: velocity correction of a sensitivity failed (LAPACK dgelsd)')
          return
        end if
        sv = sv - corr
      end if
      ! s_v', s_lambda: central difference of the acceleration-level solve along (s_q, s_v).
      h = ACCEL_STEP/max(1.0_dp, maxval(abs(sq)), maxval(abs(sv)))
      call solve_accelerations(model, t, q + h*sq, v + h*sv, vd_p, la_p, info)
      if (info == 0) call solve_accelerations(model, t, q - h*sq, v - h*sv, vd_m, la_m, info)
      if (info /= 0) then
        call fatal_error(error, 'monodromy: singular acceleration system near the start')
        return
      end if
      ys(1:nq, k) = sq
      ys(nq + 1:2*nq, k) = sv
      ys(2*nq + 1:2*nq + nc, k) = (la_p - la_m)/(2.0_dp*h)
      yps(1:nq, k) = sv
      yps(nq + 1:2*nq, k) = (vd_p - vd_m)/(2.0_dp*h)
    end do
  end subroutine initial_sensitivities

  !> A negative SUNDIALS flag becomes the error, with IDA's own message.
  subroutine check(status, what, td, error)
    integer(c_int), intent(in) :: status
    character(len=*), intent(in) :: what
    type(tangent_data), intent(in) :: td
    type(error_type), intent(inout) :: error
    call sundials_flag_error(error, status, what, td%ida_message)
  end subroutine check

end module rotorcable_monodromy
