!> Time integration of the stabilised index-2 DAE with SUNDIALS IDA.
!>
!> Gear-Gupta-Leimkuhler form (Gear, Gupta, Leimkuhler 1985; Hairer & Wanner II,
!> ch. VII.1; SUNDIALS example idaSlCrank_dns.c), unknowns y = (q, v, lambda, mu):
!>   0 = qdot - v + G^T mu                 (velocity projection, mu = 0 exactly)
!>   0 = M vdot - k - G^T lambda           (eq. 3.50, evaluated by inverse dynamics, O(n))
!>   0 = g(q)                              (eq. 3.51)
!>   0 = G(q) v                            (eq. 3.53)
!> lambda and mu are algebraic (IDASetId = 0) and excluded from the error test
!> (IDASetSuppressAlg).  Consistent initial values are computed here because IDACalcIC
!> covers index 1 only.  An open chain has nc = 0 and the same code path.
module rotorcable_dae_integrator
  use, intrinsic :: iso_c_binding, only: c_int, c_long, c_int64_t, c_double, c_ptr, c_funptr, &
                                         c_loc, c_funloc, c_f_pointer, c_null_ptr, c_associated, c_char
  use rotorcable_kinds, only: dp
  use rotorcable_errors, only: error_type, fatal_error
  use rotorcable_model, only: model_type, eom_residual, constraint_residual, constraint_jacobian, &
                              solve_accelerations, project_positions, project_velocities, mass_matrix
  use rotorcable_constraints, only: clamp_residual, clamp_velocity, add_jacobian_transpose_times
  use rotorcable_ida_binding
  use rotorcable_joint, only: JOINT_ZY
  use rotorcable_nvector_kernels, only: use_fast_kernels
  use rotorcable_ggl_linear_solver, only: ggl_block_solver, block_solver_create, block_solver_destroy
  implicit none
  private
  public :: integrator_settings, solver_stats, consistent_start, integrate, ggl_residual_dense, &
            ggl_jacobian_dense, LINEAR_SOLVER_BLOCK, LINEAR_SOLVER_DENSE

  integer, parameter :: LINEAR_SOLVER_BLOCK = 1  !< Schur-complement factorisation (ggl_linear_solver)
  integer, parameter :: LINEAR_SOLVER_DENSE = 2  !< SUNDIALS's dense LU of the whole matrix

  !> Settings of one time integration (from the deck's &solver group).
  type :: integrator_settings
    real(dp) :: t_end = 1.0_dp                !< end time [s]
    real(dp) :: dt_out = 1.0e-2_dp            !< output interval [s]
    real(dp) :: rtol = 1.0e-8_dp              !< relative tolerance
    real(dp) :: atol = 1.0e-10_dp             !< absolute tolerance on q [rad] and v [rad/s]
    real(dp) :: atol_multiplier = 1.0e4_dp   !< absolute tolerance on lambda, mu [N, Nm] (Newton test only)
    real(dp) :: h_max = 0.0_dp                !< maximum step [s] (0 = IDA's default)
    integer :: max_steps = 500000             !< step budget of the whole run (a run never hangs)
    logical :: structured_jacobian = .true.   !< own Jacobian (jacobian_ggl) instead of IDA's DQ
    integer :: linear_solver = LINEAR_SOLVER_BLOCK  !< block needs the structured Jacobian (cj)
    integer :: jacobian_max_age = 50          !< steps over which the physics Jacobian is kept (CVODE: msbj = 51)
    logical :: compiled_vector_kernels = .true.  !< nvector_kernels instead of libsundials's own
  end type integrator_settings

  !> Solver statistics reported in summary.json.
  type :: solver_stats
    integer :: steps = 0                      !< accepted steps / Newton iterations
    integer :: residual_evals = 0             !< residual evaluations (incl. Jacobian DQ)
    integer :: jacobian_evals = 0             !< Jacobian evaluations
    integer :: error_test_failures = 0        !< local error test failures
    integer :: convergence_failures = 0       !< nonlinear convergence failures
  end type solver_stats

  !> User data handed to IDA (c_loc), turned back with c_f_pointer in the callbacks.
  type :: ida_user_data
    type(model_type), pointer :: model => null()
    integer :: nq = 0
    integer :: nc = 0
    integer :: jac_residuals = 0              !< residual evaluations inside ggl_jacobian
    type(ggl_block_solver), pointer :: block => null()  !< told cj by ggl_jacobian
    type(c_ptr) :: mem = c_null_ptr           !< IDA memory (step and failure counters)
    real(dp), allocatable :: physics(:, :)    !< kept physics columns of the Jacobian
    logical :: physics_valid = .false.
    integer(c_long) :: physics_step = 0       !< IDA's step count when they were formed
    integer(c_long) :: physics_fails = 0      !< IDA's convergence failures then
    integer :: jacobian_max_age = 1           !< steps before they are formed again
    integer :: physics_evals = 0              !< how often they were formed
    character(len=512) :: ida_message = ''
  end type ida_user_data

contains

  !> Project (q, v) onto g = 0 and G v = 0 (Gauss-Newton, minimum-norm steps) and solve
  !> the acceleration-level system for vdot and lambda (eq. 3.55); mu starts at 0.
  subroutine consistent_start(model, t, q, v, vdot, lambda, error)
    type(model_type), intent(inout) :: model  !< model
    real(dp), intent(in) :: t                 !< start time [s]
    real(dp), intent(inout) :: q(:), v(:)     !< start state, projected in place
    real(dp), intent(out) :: vdot(:)          !< consistent accelerations
    real(dp), intent(out) :: lambda(:)        !< consistent multipliers
    type(error_type), intent(inout) :: error  !< status
    integer :: info

    if (project_positions(model, q) > 1.0e-10_dp) then
      call fatal_error(error, 'initial shape cannot be projected onto the clamp constraints '// &
                       '(|g| stays above 1e-10); the end clamp is out of reach of the start shape')
      return
    end if
    call project_velocities(model, q, v)
    call solve_accelerations(model, t, q, v, vdot, lambda, info)
    if (info /= 0) call fatal_error(error, 'singular acceleration system at the start '// &
                                    '(dependent constraints or zero mass)')
  end subroutine consistent_start

  !> GGL residual for IDA.  Returns 0 (success); never stops.
  integer(c_int) function ggl_residual(t, yy, yp, rr, udata) bind(C)
    real(c_double), value :: t
    type(c_ptr), value :: yy, yp, rr, udata
    type(ida_user_data), pointer :: ud
    real(c_double), pointer :: y(:), yd(:), r(:)
    integer :: n

    call c_f_pointer(udata, ud)
    n = 2*ud%nq + 2*ud%nc
    call c_f_pointer(N_VGetArrayPointer(yy), y, [n])
    call c_f_pointer(N_VGetArrayPointer(yp), yd, [n])
    call c_f_pointer(N_VGetArrayPointer(rr), r, [n])
    call ggl_residual_dense(ud%model, t, y, yd, r)
    ! A non-finite residual (a state far off, an overflow) is a recoverable failure: IDA then
    ! cuts the step (SUNDIALS's examples; returning 0 would feed NaN into the Newton update).
    ggl_residual = 0
    if (.not. all(abs(r) <= huge(1.0_dp))) ggl_residual = 1
  end function ggl_residual

  !> The GGL residual on plain arrays, y = (q, v, lambda, mu).  One kinematic pass serves
  !> the inverse dynamics, g and G (the frames of q are still current after eom_residual).
  subroutine ggl_residual_dense(model, t, y, yd, r)
    type(model_type), intent(inout) :: model  !< model
    real(dp), intent(in) :: t                 !< time [s]
    real(dp), intent(in) :: y(:), yd(:)       !< unknowns and their derivatives
    real(dp), intent(out) :: r(:)             !< residual
    integer :: nq, nc, n
    nq = model%nq; nc = model%nc; n = 2*nq + 2*nc
    r(1:nq) = yd(1:nq) - y(nq + 1:2*nq)
    call eom_residual(model, t, y(1:nq), y(nq + 1:2*nq), yd(nq + 1:2*nq), y(2*nq + 1:2*nq + nc), &
                      r(nq + 1:2*nq))
    if (nc > 0) call constraint_rows(model, y(2*nq + nc + 1:n), r(1:nq), r(2*nq + 1:2*nq + nc), &
                                     r(2*nq + nc + 1:n))
  end subroutine ggl_residual_dense

  !> Iteration matrix J = dF/dy + cj dF/dy' of the GGL residual, assembled from its
  !> structure instead of IDA's difference quotients over y and y' together:
  !>   [ cj I + d(G^T mu)/dq      -I             0      G^T ]   q rows
  !>   [ dF_v/dq          cj M + dF_v/dv       -G^T     0   ]   v rows (eq. 3.50)
  !>   [ G                        0              0      0   ]   g rows
  !>   [ d(G v)/dq                G              0      0   ]   G v rows
  !> M comes from the composite-rigid-body algorithm and G, G^T, -I exactly; only the
  !> smooth physics columns dF/dq and dF/dv (stiffness, gyroscopic and damper terms) are
  !> forward differences of the residual at fixed y', which never multiply cj.  IDA's DQ
  !> perturbs y and y' = cj*inc together, so at the tiny first steps of tight tolerances
  !> (cj ~ 1e20) its columns are round-off: the corrector then fails at t = 0.
  subroutine ggl_jacobian_dense(model, t, cj, y, yd, jac)
    type(model_type), intent(inout) :: model  !< model
    real(dp), intent(in) :: t, cj             !< time [s], IDA's cj = alpha/h [1/s]
    real(dp), intent(in) :: y(:), yd(:)       !< unknowns and their derivatives
    real(dp), intent(out) :: jac(:, :)        !< (n,n) iteration matrix
    call physics_jacobian(model, t, y, yd, jac)
    call add_exact_blocks(model, cj, y, jac)
  end subroutine ggl_jacobian_dense

  !> The smooth physics columns dF/dq and dF/dv of the GGL residual (forward differences at
  !> fixed y'); they do not depend on cj and may be kept over several steps.
  subroutine physics_jacobian(model, t, y, yd, jac)
    type(model_type), intent(inout) :: model  !< model
    real(dp), intent(in) :: t                 !< time [s]
    real(dp), intent(in) :: y(:), yd(:)       !< unknowns and their derivatives
    real(dp), intent(out) :: jac(:, :)        !< (n,n); multiplier columns left zero
    real(dp) :: r0(size(y)), r1(size(y)), yy(size(y)), inc
    integer :: nq, j
    nq = model%nq
    jac = 0.0_dp
    yy = y
    call ggl_residual_dense(model, t, yy, yd, r0)
    do j = 1, 2*nq
      ! Coordinates are angles and rates of order one: a relative step with a floor.
      inc = sqrt(epsilon(1.0_dp))*max(abs(y(j)), 1.0_dp)
      yy(j) = y(j) + inc
      call ggl_residual_dense(model, t, yy, yd, r1)
      yy(j) = y(j)
      jac(:, j) = (r1 - r0)/inc
    end do
  end subroutine physics_jacobian

  !> Add the exact blocks to a physics Jacobian: the y' terms (cj I, cj M by the composite
  !> rigid bodies at q), the multiplier columns -G^T, G^T and g's rows G.
  subroutine add_exact_blocks(model, cj, y, jac)
    type(model_type), intent(inout) :: model  !< model
    real(dp), intent(in) :: cj                !< IDA's cj = alpha/h [1/s]
    real(dp), intent(in) :: y(:)              !< unknowns
    real(dp), intent(inout) :: jac(:, :)      !< (n,n) iteration matrix
    real(dp) :: g_jac(model%nc, model%nq), m(model%nq, model%nq)
    integer :: nq, nc, j
    nq = model%nq; nc = model%nc
    do j = 1, nq
      jac(j, j) = jac(j, j) + cj
    end do
    call mass_matrix(model, y(1:nq), m)
    jac(nq + 1:2*nq, nq + 1:2*nq) = jac(nq + 1:2*nq, nq + 1:2*nq) + cj*m
    if (nc > 0) then
      call constraint_jacobian(model, y(1:nq), g_jac)
      jac(nq + 1:2*nq, 2*nq + 1:2*nq + nc) = -transpose(g_jac)
      jac(1:nq, 2*nq + nc + 1:) = transpose(g_jac)
      jac(2*nq + 1:2*nq + nc, 1:nq) = g_jac
    end if
  end subroutine add_exact_blocks

  !> IDALsJacFn: fills SUNDIALS's dense matrix (column-major, n x n).  The physics columns
  !> (finite differences, 2 nq residuals) are kept from one call to the next unless IDA had
  !> a convergence failure since, or they are older than jacobian_max_age steps; cj I, cj M
  !> and the constraint blocks are always exact at the current state.  IDA calls this at
  !> every linear-solver setup, i.e. whenever cj has changed by more than 25 %, which on a
  !> smooth stretch happens every few steps while the physics barely moves.
  integer(c_int) function ggl_jacobian(t, cj, yy, yp, rr, jmat, udata, tmp1, tmp2, tmp3) bind(C)
    real(c_double), value :: t, cj
    type(c_ptr), value :: yy, yp, rr, jmat, udata, tmp1, tmp2, tmp3
    type(ida_user_data), pointer :: ud
    real(c_double), pointer :: y(:), yd(:), a(:, :)
    integer(c_long) :: steps, fails
    integer(c_int) :: flag
    integer :: n
    call c_f_pointer(udata, ud)
    n = 2*ud%nq + 2*ud%nc
    call c_f_pointer(N_VGetArrayPointer(yy), y, [n])
    call c_f_pointer(N_VGetArrayPointer(yp), yd, [n])
    call c_f_pointer(SUNDenseMatrix_Data(jmat), a, [n, n])
    flag = IDAGetNumSteps(ud%mem, steps)
    flag = IDAGetNumNonlinSolvConvFails(ud%mem, fails)
    if (.not. ud%physics_valid .or. fails /= ud%physics_fails .or. steps < ud%physics_step .or. &
        steps - ud%physics_step >= ud%jacobian_max_age) then
      call physics_jacobian(ud%model, t, y, yd, ud%physics)
      ud%jac_residuals = ud%jac_residuals + 2*ud%nq + 1
      ud%physics_evals = ud%physics_evals + 1
      ud%physics_valid = .true.
      ud%physics_step = steps
      ud%physics_fails = fails
    end if
    a = ud%physics
    call add_exact_blocks(ud%model, cj, y, a)
    if (associated(ud%block)) ud%block%cj = cj
    ggl_jacobian = 0
  end function ggl_jacobian

  !> Constraint parts of the GGL residual at the current frames and velocities (left by
  !> eom_residual): G^T mu added to the q rows, g(q), and G v as the tip velocity and T w_n
  !> of the chain's own motion (clamp_velocity), so G itself is never formed here.
  subroutine constraint_rows(model, mu, r_q, r_g, r_gv)
    type(model_type), intent(inout) :: model
    real(dp), intent(in) :: mu(:)
    real(dp), intent(inout) :: r_q(:)
    real(dp), intent(out) :: r_g(:), r_gv(:)
    r_g = clamp_residual(model%clamp, model%st)
    r_gv = clamp_velocity(model%clamp, model%st)
    call add_jacobian_transpose_times(model%chain, model%clamp, model%st, mu, r_q)
  end subroutine constraint_rows

  !> Diagnostic appended to a failed run: the joint nearest its coordinate singularity, if
  !> it is near.  The thesis's zy joint is singular at beta = 0 (gamma stops being a bending
  !> direction; near: within 2 deg); the Cardan xy/xyz joints at theta = +-90 deg (phi and psi
  !> turn about one axis), where the joint rates grow like 1/cos theta: IDA gives up well
  !> before (the undamped six-link xy swing fails at |cos theta| = 0.11), so near means
  !> within 12 deg, a kink no cable takes over one body length.
  function singularity_hint(model, q) result(hint)
    type(model_type), intent(in) :: model     !< model
    real(dp), intent(in) :: q(:)              !< coordinates at the failure
    character(len=:), allocatable :: hint
    real(dp) :: margin, margin_min
    integer :: j, j_min, i0
    character(len=200) :: buf
    hint = ''
    margin_min = huge(1.0_dp)
    j_min = 0
    do j = 1, model%chain%n_bodies
      i0 = model%chain%first_coord(j)
      if (i0 == 0) cycle
      margin = singularity_margin(model%chain%joint_kind(j), q(i0:i0 + 1))
      if (margin < margin_min) then
        margin_min = margin
        j_min = j
      end if
    end do
    if (j_min == 0) return
    if (model%chain%joint_kind(j_min) == JOINT_ZY .and. margin_min >= sin(2.0_dp*acos(-1.0_dp)/180.0_dp)) return
    if (model%chain%joint_kind(j_min) /= JOINT_ZY .and. margin_min >= sin(12.0_dp*acos(-1.0_dp)/180.0_dp)) return
    if (model%chain%joint_kind(j_min) == JOINT_ZY) then
      write (buf, '(a, i0, a, f6.3, a)') '; joint ', j_min, ' is near beta = 0 (|sin beta| = ', margin_min, &
        '), the singularity of the thesis''s zy joint: try &chain joint = ''xy'''
    else
      write (buf, '(a, i0, a, f6.3, a)') '; joint ', j_min, ' is near theta = +-90 deg (|cos theta| = ', &
        margin_min, '), the singularity of the Cardan joint (a right-angle kink in one body length): '// &
        'use more bodies or add bending damping'
    end if
    hint = trim(buf)
  end function singularity_hint

  !> Distance of a joint from its coordinate singularity: |sin beta| for the thesis's zy
  !> joint, |cos theta| for the Cardan joints (0 = singular, 1 = farthest).
  pure real(dp) function singularity_margin(kind, angles)
    integer, intent(in) :: kind               !< parametrisation
    real(dp), intent(in) :: angles(2)         !< the joint's first two coordinates [rad]
    if (kind == JOINT_ZY) then
      singularity_margin = abs(sin(angles(2)))
    else
      singularity_margin = abs(cos(angles(2)))
    end if
  end function singularity_margin

  !> IDA error handler: keep the message for the Python exception instead of printing it.
  subroutine ida_error_handler(code, module_name, function_name, msg, udata) bind(C)
    integer(c_int), value :: code
    type(c_ptr), value :: module_name, function_name, msg, udata
    type(ida_user_data), pointer :: ud
    character(kind=c_char), pointer :: chars(:)
    integer :: i
    if (.not. c_associated(udata) .or. .not. c_associated(msg)) return
    call c_f_pointer(udata, ud)
    call c_f_pointer(msg, chars, [len(ud%ida_message)])
    ud%ida_message = ''
    do i = 1, len(ud%ida_message)
      if (chars(i) == achar(0)) exit
      ud%ida_message(i:i) = chars(i)
    end do
    if (code == 0) ud%ida_message = ''
  end subroutine ida_error_handler

  !> Integrate from t = 0 to settings%t_end; returns the state (q, v) at the output times.
  subroutine integrate(model, settings, q0, v0, t_out, q_out, v_out, stats, error)
    type(model_type), intent(inout), target :: model  !< model
    type(integrator_settings), intent(in) :: settings !< tolerances and output times
    real(dp), intent(in) :: q0(:), v0(:)              !< start state (projected here)
    real(dp), intent(in) :: t_out(:)                  !< output times, t_out(1) = start
    real(dp), intent(out) :: q_out(:, :), v_out(:, :) !< (nq, n_out) states at t_out
    type(solver_stats), intent(out) :: stats          !< solver statistics
    type(error_type), intent(inout) :: error          !< status
    type(ida_user_data), target :: ud
    type(ggl_block_solver), target :: block
    logical :: use_block
    type(c_ptr) :: ctx, mem, yy, yp, id, atol, mat, ls
    real(c_double), pointer :: y(:), yd(:), idv(:), av(:)
    real(dp) :: q(model%nq), v(model%nq), vdot(model%nq), lambda(max(model%nc, 1))
    real(c_double) :: tret
    integer(c_int) :: flag
    integer(c_int64_t) :: n64
    integer(c_long) :: counter, steps_before
    integer :: nq, nc, n, k

    nq = model%nq; nc = model%nc; n = 2*nq + 2*nc
    steps_before = 0
    ! IDA's time reached; set before any IDASolve (a stale value skipped whole runs: 0 steps).
    tret = real(t_out(1), c_double)
    q = q0; v = v0
    call consistent_start(model, t_out(1), q, v, vdot, lambda(1:nc), error)
    if (error%code /= 0) return
    q_out(:, 1) = q; v_out(:, 1) = v

    ud%model => model
    ud%nq = nq; ud%nc = nc
    ctx = c_null_ptr; mem = c_null_ptr
    flag = SUNContext_Create(c_null_ptr, ctx)
    n64 = int(n, c_int64_t)
    yy = N_VNew_Serial(n64, ctx); yp = N_VNew_Serial(n64, ctx)
    id = N_VNew_Serial(n64, ctx); atol = N_VNew_Serial(n64, ctx)
    if (settings%compiled_vector_kernels) then
      call use_fast_kernels(yy); call use_fast_kernels(yp)
      call use_fast_kernels(id); call use_fast_kernels(atol)
    end if
    call c_f_pointer(N_VGetArrayPointer(yy), y, [n])
    call c_f_pointer(N_VGetArrayPointer(yp), yd, [n])
    call c_f_pointer(N_VGetArrayPointer(id), idv, [n])
    call c_f_pointer(N_VGetArrayPointer(atol), av, [n])
    y = 0.0_dp; yd = 0.0_dp
    y(1:nq) = q; y(nq + 1:2*nq) = v
    if (nc > 0) y(2*nq + 1:2*nq + nc) = lambda(1:nc)
    yd(1:nq) = v; yd(nq + 1:2*nq) = vdot
    ! Differential (1) for q and v, algebraic (0) for lambda and mu.
    idv = 0.0_dp; idv(1:2*nq) = 1.0_dp
    ! Loose absolute tolerances on the multipliers: they only steer the Newton test,
    ! an atol of 1e-10 there makes IDA fail at the first step (TOOLCHAIN.md).
    av = settings%atol_multiplier; av(1:2*nq) = settings%atol

    mem = IDACreate(ctx)
    ud%mem = mem
    ud%jacobian_max_age = settings%jacobian_max_age
    allocate (ud%physics(n, n))
    call check(IDAInit(mem, c_funloc(ggl_residual), real(t_out(1), c_double), yy, yp), 'IDAInit')
    call check(IDASVtolerances(mem, real(settings%rtol, c_double), atol), 'IDASVtolerances')
    call check(IDASetUserData(mem, c_loc(ud)), 'IDASetUserData')
    call check(IDASetErrHandlerFn(mem, c_funloc(ida_error_handler), c_loc(ud)), 'IDASetErrHandlerFn')
    call check(IDASetId(mem, id), 'IDASetId')
    call check(IDASetSuppressAlg(mem, 1_c_int), 'IDASetSuppressAlg')
    mat = SUNDenseMatrix(n64, n64, ctx)
    use_block = settings%linear_solver == LINEAR_SOLVER_BLOCK .and. settings%structured_jacobian
    if (use_block) then
      call block_solver_create(block, nq, nc, ctx)
      ud%block => block
      ls = block%handle
    else
      ls = SUNLinSol_Dense(yy, mat, ctx)
    end if
    call check(IDASetLinearSolver(mem, ls, mat), 'IDASetLinearSolver')
    if (settings%structured_jacobian) call check(IDASetJacFn(mem, c_funloc(ggl_jacobian)), 'IDASetJacFn')
    if (settings%h_max > 0.0_dp) call check(IDASetMaxStep(mem, real(settings%h_max, c_double)), 'IDASetMaxStep')
    if (model%loads%pulse_body > 0) then
      ! Step exactly onto the pulse switching times: the force is discontinuous there.
      call integrate_pulse_aware()
    else
      do k = 2, size(t_out)
        if (error%code /= 0) exit
        call advance(t_out(k))
        q_out(:, k) = y(1:nq); v_out(:, k) = y(nq + 1:2*nq)
      end do
    end if

    if (c_associated(mem)) then
      call add_counters()
      stats%steps = int(steps_before)
      stats%residual_evals = stats%residual_evals + ud%jac_residuals
      call IDAFree(mem)
    end if
    if (use_block) then
      call block_solver_destroy(block)
    else
      flag = SUNLinSolFree(ls)
    end if
    call SUNMatDestroy(mat)
    call N_VDestroy(yy); call N_VDestroy(yp); call N_VDestroy(id); call N_VDestroy(atol)
    flag = SUNContext_Free(ctx)

  contains

    subroutine check(status, what)
      integer(c_int), intent(in) :: status
      character(len=*), intent(in) :: what
      character(len=16) :: buf
      if (status < 0 .and. error%code == 0) then
        write (buf, '(i0)') status
        call fatal_error(error, 'SUNDIALS '//what//' failed with flag '//trim(buf)//': '//trim(ud%ida_message))
      end if
    end subroutine check

    !> Add IDA's counters to the run's statistics (IDAReInit zeroes them).  The steps go to
    !> steps_before, which also serves the step budget.
    subroutine add_counters()
      flag = IDAGetNumSteps(mem, counter); steps_before = steps_before + counter
      flag = IDAGetNumResEvals(mem, counter); stats%residual_evals = stats%residual_evals + int(counter)
      flag = IDAGetNumLinResEvals(mem, counter); stats%residual_evals = stats%residual_evals + int(counter)
      flag = IDAGetNumJacEvals(mem, counter); stats%jacobian_evals = stats%jacobian_evals + int(counter)
      flag = IDAGetNumErrTestFails(mem, counter)
      stats%error_test_failures = stats%error_test_failures + int(counter)
      flag = IDAGetNumNonlinSolvConvFails(mem, counter)
      stats%convergence_failures = stats%convergence_failures + int(counter)
    end subroutine add_counters

    !> IDASolve to t_target within what is left of the run's step budget; a spent budget
    !> becomes an error that says where and, near beta = 0, why.
    subroutine advance(t_target)
      real(dp), intent(in) :: t_target
      integer(c_long) :: used
      character(len=96) :: buf
      if (error%code /= 0) return
      flag = IDAGetNumSteps(mem, used)
      used = used + steps_before
      if (used >= settings%max_steps) then
        flag = -1_c_int
      else
        call check(IDASetMaxNumSteps(mem, int(settings%max_steps, c_long) - used), 'IDASetMaxNumSteps')
        flag = IDASolve(mem, real(t_target, c_double), tret, yy, yp, IDA_NORMAL)
      end if
      if (flag == -1_c_int) then      ! IDA_TOO_MUCH_WORK
        write (buf, '(a, i0, a, es10.3, a)') 'step budget (solver max_steps = ', settings%max_steps, &
          ') used up at t = ', tret, ' s'
        call fatal_error(error, trim(buf)//'; the motion is too fast for the tolerances'// &
                         singularity_hint(model, y(1:nq)))
        return
      end if
      call check(flag, 'IDASolve')
      if (error%code /= 0) error%message = trim(error%message)//singularity_hint(model, y(1:nq))
    end subroutine advance

    subroutine integrate_pulse_aware()
      real(dp) :: t_switch(2), t_target
      integer :: kk, s
      t_switch = [model%loads%pulse_start, model%loads%pulse_end]
      s = 1
      do kk = 2, size(t_out)
        if (error%code /= 0) exit
        do while (s <= 2)
          if (t_switch(s) > t_out(kk - 1) .and. t_switch(s) <= t_out(kk)) exit
          if (t_switch(s) > t_out(kk)) exit
          s = s + 1
        end do
        t_target = t_out(kk)
        if (s <= 2) then
          if (t_switch(s) > t_out(kk - 1) .and. t_switch(s) <= t_out(kk)) then
            call check(IDASetStopTime(mem, real(t_switch(s), c_double)), 'IDASetStopTime')
            call advance(t_switch(s))
            if (error%code /= 0) exit
            ! Restart the multistep history at the discontinuity, and lift the stop time
            ! (SUNDIALS 6.4 has no IDAClearStopTime).
            call add_counters()                      ! IDAReInit zeroes IDA's counters
            ud%physics_valid = .false.               ! and the force has jumped
            call check(IDAReInit(mem, tret, yy, yp), 'IDAReInit')
            call check(IDASetStopTime(mem, real(2.0_dp*t_out(size(t_out)) + 1.0_dp, c_double)), 'IDASetStopTime')
            s = s + 1
          end if
        end if
        if (t_target > tret .and. error%code == 0) call advance(t_target)
        q_out(:, kk) = y(1:nq); v_out(:, kk) = y(nq + 1:2*nq)
      end do
    end subroutine integrate_pulse_aware

  end subroutine integrate

end module rotorcable_dae_integrator
