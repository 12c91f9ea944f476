!> Time integration of the stabilised index-2 DAE (rotorcable_ggl_residual) with SUNDIALS IDA,
!> as a session that can be advanced in pieces: start (consistent initial values, IDA set-up),
!> advance to any list of output times (as often as wanted: outputs stream out in chunks),
!> end.  lambda and mu are algebraic (IDASetId = 0) and excluded from the error test
!> (IDASetSuppressAlg).  Consistent initial values are computed here because IDACalcIC covers
!> index 1 only.  An open chain has nc = 0 and the same code path.  At every discontinuity of
!> a load (a pulse edge) the integration stops exactly there and IDA's history restarts.
module rotorcable_dae_integrator
  use, intrinsic :: iso_c_binding, only: c_int, c_long, c_int64_t, c_double, c_ptr, c_funptr, &
                                         c_loc, c_funloc, c_f_pointer, c_null_ptr, c_associated, c_char
  use rotorcable_kinds, only: dp
  use rotorcable_errors, only: error_type, fatal_error, sundials_flag_error
  use rotorcable_parameter_block, only: parameter_block, block_from_flat, get_real, get_int, get_word
  use rotorcable_model, only: model_type, support_b_key, solve_accelerations, switch_times
  use rotorcable_projection, only: project_positions, project_velocities, constraint_rank_margin, &
                                   rank_loss_message, RANK_TOL
  use rotorcable_ggl_residual, only: ida_user_data, ggl_residual, ggl_jacobian
  use rotorcable_ida_binding
  use rotorcable_joint, only: JOINT_ZY
  use rotorcable_nvector_kernels, only: use_fast_kernels
  use rotorcable_ggl_linear_solver, only: ggl_block_solver, block_solver_create, block_solver_destroy
  use rotorcable_chain_linear_solver, only: ggl_chain_solver, chain_solver_create, chain_solver_destroy
  implicit none
  private
  public :: integrator_settings, settings_from_block, settings_from_flat, solver_stats, consistent_start, dae_session, &
            session_start, &
            session_advance, session_end, integrate, session_step_onto_switch, session_restart, &
            LINEAR_SOLVER_BLOCK, LINEAR_SOLVER_DENSE, LINEAR_SOLVER_CHAIN

  integer, parameter :: LINEAR_SOLVER_BLOCK = 1  !< Schur-complement factorisation (ggl_linear_solver)
  integer, parameter :: LINEAR_SOLVER_DENSE = 2  !< SUNDIALS's dense LU of the whole matrix
  !> O(n) articulated-body solve of an approximate iteration matrix (chain_linear_solver)
  integer, parameter :: LINEAR_SOLVER_CHAIN = 3

  !> Settings of one time integration (from the deck's &solver group).
  type :: integrator_settings
    real(dp) :: rtol = 1.0e-8_dp              !< relative tolerance
    real(dp) :: atol = 1.0e-10_dp             !< absolute tolerance on q [rad] and v [rad/s]
    real(dp) :: atol_multiplier = 1.0e4_dp    !< absolute tolerance on lambda, mu [N, Nm] (Newton test only)
    real(dp) :: h_max = 0.0_dp                !< maximum step [s] (0 = IDA's default)
    integer :: max_steps = 500000             !< step budget of the whole run (a run never hangs)
    integer :: linear_solver = LINEAR_SOLVER_BLOCK  !< block, dense or chain (block and dense use ggl_jacobian)
    integer :: jacobian_max_age = 100         !< steps over which the physics Jacobian is kept (docs/model.md)
    logical :: compiled_vector_kernels = .true.  !< nvector_kernels instead of libsundials's own
    logical :: analytic_jacobian = .true.     !< physics Jacobian by tangent sweeps (else differences)
  end type integrator_settings

  !> Solver statistics reported in summary.json.
  type :: solver_stats
    integer :: steps = 0                      !< accepted steps / Newton iterations
    integer :: residual_evals = 0             !< residual evaluations (incl. Jacobian DQ)
    integer :: jacobian_evals = 0             !< Jacobian evaluations
    integer :: error_test_failures = 0        !< local error test failures
    integer :: convergence_failures = 0       !< nonlinear convergence failures
  end type solver_stats

  !> One integration in progress: IDA's memory, vectors and linear solver, kept between calls.
  type :: dae_session
    type(model_type), pointer :: model => null()
    type(integrator_settings) :: settings
    type(ida_user_data), pointer :: ud => null()
    type(ggl_block_solver), pointer :: block => null()
    type(ggl_chain_solver), pointer :: chain => null()
    type(c_ptr) :: ctx = c_null_ptr, mem = c_null_ptr, yy = c_null_ptr, yp = c_null_ptr
    type(c_ptr) :: id = c_null_ptr, atol = c_null_ptr, mat = c_null_ptr, ls = c_null_ptr
    real(dp) :: t_now = 0.0_dp                !< time reached [s]
    real(dp), allocatable :: t_switch(:)      !< discontinuities still ahead [s]
    type(solver_stats) :: earlier             !< counters of IDA's earlier lives (IDAReInit zeroes them)
    type(solver_stats) :: stats               !< statistics so far
    logical :: failed = .false.               !< a failed session cannot advance
  end type dae_session

contains

  !> Project (q, v) onto g = 0 and G v + g_t = 0 (minimum-norm steps) and solve the
  !> acceleration-level system for vdot and lambda (eq. 3.55); mu starts at 0.  Dependent
  !> constraints (a taut or straight chain) are refused: their reactions are not determined.
  subroutine consistent_start(model, t, q, v, vdot, lambda, error)
    type(model_type), intent(inout) :: model  !< model
    real(dp), intent(in) :: t                 !< start time [s]
    real(dp), intent(inout) :: q(:), v(:)     !< start state, projected in place
    real(dp), intent(out) :: vdot(:)          !< consistent accelerations
    real(dp), intent(out) :: lambda(:)        !< consistent multipliers
    type(error_type), intent(inout) :: error  !< status
    integer :: info
    real(dp) :: margin

    vdot = 0.0_dp
    lambda = 0.0_dp
    if (project_positions(model, t, q) > 1.0e-10_dp) then
      call fatal_error(error, 'initial shape cannot be projected onto the clamp constraints '// &
                       '(|g| stays above 1e-10); the end clamp is out of reach of the start shape', &
                       key=support_b_key(model))
      return
    end if
    if (model%nc > 0) then
      margin = constraint_rank_margin(model, t, q)
      if (margin < RANK_TOL) then
        call fatal_error(error, rank_loss_message(model, t, q, margin), key=support_b_key(model))
        return
      end if
    end if
    call project_velocities(model, t, q, v)
    call solve_accelerations(model, t, q, v, vdot, lambda, info)
    if (info /= 0) call fatal_error(error, 'singular acceleration system at the start '// &
                                    '(dependent constraints, zero mass or a non-finite state)')
  end subroutine consistent_start

  !> Settings from their parameter block (pydriver/components.py, SOLVER, declares the names;
  !> the deck's &solver keys).  The linear solver, the Jacobian and the vector kernels come as
  !> words, the deck's own choices; a word this core does not know is an error naming its key.
  subroutine settings_from_block(block, settings, error)
    type(parameter_block), intent(in) :: block        !< the 'solver' block
    type(integrator_settings), intent(out) :: settings  !< the settings
    type(error_type), intent(inout) :: error          !< status: a missing name, an unknown word
    character(len=:), allocatable :: word
    call get_real(block, 'rtol', settings%rtol, error)
    call get_real(block, 'atol', settings%atol, error)
    call get_real(block, 'atol_multiplier', settings%atol_multiplier, error)
    call get_real(block, 'h_max', settings%h_max, error)
    call get_int(block, 'max_steps', settings%max_steps, error)
    call get_int(block, 'jacobian_max_age', settings%jacobian_max_age, error)
    call get_word(block, 'linear_solver', word, error)
    if (error%code /= 0) return
    ! The schema's choices but 'auto' (pydriver/schema.py LINEAR_SOLVERS; pydriver.model resolves
    ! 'auto'); tests/test_components.py checks that every one of them is known here.
    select case (word)
    case ('block')
      settings%linear_solver = LINEAR_SOLVER_BLOCK
    case ('dense')
      settings%linear_solver = LINEAR_SOLVER_DENSE
    case ('chain')
      settings%linear_solver = LINEAR_SOLVER_CHAIN
    case default
      call fatal_error(error, 'linear solver '''//word//''' is not one of this core''s', key='solver.linear_solver')
    end select
    call get_word(block, 'jacobian', word, error)
    if (error%code /= 0) return
    select case (word)
    case ('analytic', 'finite_difference')
      settings%analytic_jacobian = word == 'analytic'
    case default
      call fatal_error(error, 'physics Jacobian '''//word//''' is not one of this core''s', key='solver.jacobian')
    end select
    call get_word(block, 'vector_kernels', word, error)
    if (error%code /= 0) return
    select case (word)
    case ('compiled', 'sundials')
      settings%compiled_vector_kernels = word == 'compiled'
    case default
      call fatal_error(error, 'vector kernels '''//word//''' are not one of this core''s', key='solver.vector_kernels')
    end select
  end subroutine settings_from_block

  !> Settings from the flat layout of their block at the f2py boundary (api.f90, probes.f90).
  subroutine settings_from_flat(real_names, real_sizes, reals, int_names, int_sizes, ints, settings, error)
    character(len=*), intent(in) :: real_names    !< names of the real arrays, blank-separated
    integer, intent(in) :: real_sizes(:)          !< size of each real array
    real(dp), intent(in) :: reals(:)              !< their values
    character(len=*), intent(in) :: int_names     !< names of the integer arrays
    integer, intent(in) :: int_sizes(:)           !< size of each integer array
    integer, intent(in) :: ints(:)                !< their values
    type(integrator_settings), intent(out) :: settings  !< the settings
    type(error_type), intent(inout) :: error      !< status
    type(parameter_block) :: block
    call block_from_flat('solver', real_names, real_sizes, reals, int_names, int_sizes, ints, block, error)
    if (error%code == 0) call settings_from_block(block, settings, error)
  end subroutine settings_from_flat

  !> Set up IDA for the model from (q0, v0) at t0 (made consistent here).  On return
  !> q0, v0 hold the consistent start.
  subroutine session_start(s, model, settings, t0, q0, v0, error)
    type(dae_session), intent(inout) :: s              !< session (fresh)
    type(model_type), intent(inout), target :: model   !< model (must outlive the session)
    type(integrator_settings), intent(in) :: settings  !< tolerances
    real(dp), intent(in) :: t0                         !< start time [s]
    real(dp), intent(inout) :: q0(:), v0(:)            !< start state, made consistent
    type(error_type), intent(inout) :: error           !< status
    real(c_double), pointer :: y(:), yd(:), idv(:), av(:)
    real(dp) :: vdot(model%nq), lambda(max(model%nc, 1))
    integer(c_int64_t) :: n64
    integer :: nq, nc, n

    nq = model%nq; nc = model%nc; n = 2*nq + 2*nc
    s%model => model
    s%settings = settings
    s%t_now = t0
    call consistent_start(model, t0, q0, v0, vdot, lambda(1:nc), error)
    if (error%code /= 0) then
      s%failed = .true.
      return
    end if
    call switch_times(model, s%t_switch)
    s%t_switch = pack(s%t_switch, s%t_switch > t0)

    allocate (s%ud)
    s%ud%model => model
    s%ud%nq = nq; s%ud%nc = nc
    call check(s, SUNContext_Create(c_null_ptr, s%ctx), 'SUNContext_Create', error)
    if (error%code == 0) call require(s%ctx, 'SUNContext_Create', error)
    if (error%code /= 0) then
      s%failed = .true.
      return
    end if
    n64 = int(n, c_int64_t)
    s%yy = N_VNew_Serial(n64, s%ctx); s%yp = N_VNew_Serial(n64, s%ctx)
    s%id = N_VNew_Serial(n64, s%ctx); s%atol = N_VNew_Serial(n64, s%ctx)
    call require(s%yy, 'N_VNew_Serial', error); call require(s%yp, 'N_VNew_Serial', error)
    call require(s%id, 'N_VNew_Serial', error); call require(s%atol, 'N_VNew_Serial', error)
    if (error%code /= 0) then
      s%failed = .true.
      return
    end if
    if (settings%compiled_vector_kernels) then
      call use_fast_kernels(s%yy); call use_fast_kernels(s%yp)
      call use_fast_kernels(s%id); call use_fast_kernels(s%atol)
    end if
    call c_f_pointer(N_VGetArrayPointer(s%yy), y, [n])
    call c_f_pointer(N_VGetArrayPointer(s%yp), yd, [n])
    call c_f_pointer(N_VGetArrayPointer(s%id), idv, [n])
    call c_f_pointer(N_VGetArrayPointer(s%atol), av, [n])
    y = 0.0_dp; yd = 0.0_dp
    y(1:nq) = q0; y(nq + 1:2*nq) = v0
    if (nc > 0) y(2*nq + 1:2*nq + nc) = lambda(1:nc)
    yd(1:nq) = v0; yd(nq + 1:2*nq) = vdot
    ! Differential (1) for q and v, algebraic (0) for lambda and mu.
    idv = 0.0_dp; idv(1:2*nq) = 1.0_dp
    ! Loose absolute tolerances on the multipliers: they only steer the Newton test; an atol
    ! of 1e-10 on every variable makes IDA fail at the first step (IDA_CONV_FAIL at h ~ 3e-15,
    ! SUNDIALS 6.4.1 on the GGL index-2 system).
    av = settings%atol_multiplier; av(1:2*nq) = settings%atol

    s%mem = IDACreate(s%ctx)
    call require(s%mem, 'IDACreate', error)
    if (error%code /= 0) then
      s%failed = .true.
      return
    end if
    s%ud%mem = s%mem
    s%ud%jacobian_max_age = settings%jacobian_max_age
    s%ud%analytic = settings%analytic_jacobian
    call check(s, IDAInit(s%mem, c_funloc(ggl_residual), real(t0, c_double), s%yy, s%yp), 'IDAInit', error)
    call check(s, IDASVtolerances(s%mem, real(settings%rtol, c_double), s%atol), 'IDASVtolerances', error)
    call check(s, IDASetUserData(s%mem, c_loc(s%ud)), 'IDASetUserData', error)
    call check(s, IDASetErrHandlerFn(s%mem, c_funloc(ida_error_handler), c_loc(s%ud)), 'IDASetErrHandlerFn', error)
    call check(s, IDASetId(s%mem, s%id), 'IDASetId', error)
    call check(s, IDASetSuppressAlg(s%mem, 1_c_int), 'IDASetSuppressAlg', error)
    if (settings%linear_solver == LINEAR_SOLVER_CHAIN) then
      ! No matrix and no Jacobian at all: the solver factorises its own (O(n) memory and work).
      allocate (s%chain)
      call chain_solver_create(s%chain, model, s%mem, s%ctx, settings%jacobian_max_age)
      s%ls = s%chain%handle
      call require(s%ls, 'SUNLinSolNewEmpty (chain solver)', error)
      call check(s, IDASetLinearSolver(s%mem, s%ls, c_null_ptr), 'IDASetLinearSolver', error)
      call finish_start(s, settings, error)
      return
    end if
    allocate (s%ud%physics(n, n))
    s%mat = SUNDenseMatrix(n64, n64, s%ctx)
    call require(s%mat, 'SUNDenseMatrix', error)
    if (error%code /= 0) then
      s%failed = .true.
      return
    end if
    if (settings%linear_solver == LINEAR_SOLVER_BLOCK) then
      allocate (s%block)
      call block_solver_create(s%block, nq, nc, s%ctx)
      s%ud%block => s%block
      s%ls = s%block%handle
      call require(s%ls, 'SUNLinSolNewEmpty (block solver)', error)
    else
      s%ls = SUNLinSol_Dense(s%yy, s%mat, s%ctx)
      call require(s%ls, 'SUNLinSol_Dense', error)
    end if
    call check(s, IDASetLinearSolver(s%mem, s%ls, s%mat), 'IDASetLinearSolver', error)
    call check(s, IDASetJacFn(s%mem, c_funloc(ggl_jacobian)), 'IDASetJacFn', error)
    call finish_start(s, settings, error)
  end subroutine session_start

  !> The settings every linear solver shares: maximum step, first stop time.
  subroutine finish_start(s, settings, error)
    type(dae_session), intent(inout) :: s
    type(integrator_settings), intent(in) :: settings
    type(error_type), intent(inout) :: error
    if (settings%h_max > 0.0_dp) &
      call check(s, IDASetMaxStep(s%mem, real(settings%h_max, c_double)), 'IDASetMaxStep', error)
    if (size(s%t_switch) > 0) &
      call check(s, IDASetStopTime(s%mem, real(s%t_switch(1), c_double)), 'IDASetStopTime', error)
    if (error%code /= 0) s%failed = .true.
  end subroutine finish_start

  !> Advance to each of the increasing times t_out (all later than the time reached) and
  !> return the state there.  Each time is reached exactly (IDA's normal mode interpolates
  !> onto it); discontinuities of the loads in between are stepped onto and restarted from.
  subroutine session_advance(s, t_out, q_out, v_out, error)
    type(dae_session), intent(inout) :: s     !< started session
    real(dp), intent(in) :: t_out(:)          !< output times [s]
    real(dp), intent(out) :: q_out(:, :)      !< (nq, size(t_out)) coordinates
    real(dp), intent(out) :: v_out(:, :)      !< (nq, size(t_out)) rates
    type(error_type), intent(inout) :: error  !< status
    real(c_double), pointer :: y(:)
    integer :: k, nq
    nq = s%model%nq
    q_out = 0.0_dp; v_out = 0.0_dp
    if (s%failed) then
      call fatal_error(error, 'the integration has failed before and cannot go on')
      return
    end if
    call c_f_pointer(N_VGetArrayPointer(s%yy), y, [2*nq + 2*s%model%nc])
    do k = 1, size(t_out)
      if (t_out(k) < s%t_now) then
        call fatal_error(error, 'output times must not go back in time')
        exit
      end if
      ! Step onto every discontinuity before t_out(k) and restart there.
      do while (size(s%t_switch) > 0)
        if (s%t_switch(1) > t_out(k)) exit
        call advance_to(s, s%t_switch(1), error)
        if (error%code /= 0) exit
        call restart(s, error)
        if (error%code /= 0) exit
      end do
      if (error%code /= 0) exit
      if (t_out(k) > s%t_now) call advance_to(s, t_out(k), error)
      if (error%code /= 0) exit
      q_out(:, k) = y(1:nq); v_out(:, k) = y(nq + 1:2*nq)
    end do
    if (error%code /= 0) s%failed = .true.
    call collect_stats(s)
  end subroutine session_advance

  !> Step onto the next discontinuity of the loads if it lies at or before t_limit, without
  !> restarting there (a caller with state of its own beside IDA's, the parameter
  !> sensitivities, reads it first and then calls session_restart).  Returns whether it stepped.
  logical function session_step_onto_switch(s, t_limit, error) result(stepped)
    type(dae_session), intent(inout) :: s     !< started session
    real(dp), intent(in) :: t_limit           !< latest time to stop at [s]
    type(error_type), intent(inout) :: error  !< status
    stepped = .false.
    if (size(s%t_switch) == 0) return
    if (s%t_switch(1) > t_limit) return
    call advance_to(s, s%t_switch(1), error)
    if (error%code /= 0) then
      s%failed = .true.
      return
    end if
    stepped = .true.
  end function session_step_onto_switch

  !> Restart IDA at the discontinuity the session stands on (after session_step_onto_switch).
  subroutine session_restart(s, error)
    type(dae_session), intent(inout) :: s     !< session on a discontinuity
    type(error_type), intent(inout) :: error  !< status
    call restart(s, error)
    if (error%code /= 0) s%failed = .true.
  end subroutine session_restart

  !> IDASolve to t_target within what is left of the run's step budget; a spent budget
  !> becomes an error that says where and, near a joint singularity, why.
  subroutine advance_to(s, t_target, error)
    type(dae_session), intent(inout) :: s
    real(dp), intent(in) :: t_target
    type(error_type), intent(inout) :: error
    real(c_double), pointer :: y(:)
    real(c_double) :: tret
    integer(c_long) :: used
    integer(c_int) :: flag
    character(len=96) :: buf
    call c_f_pointer(N_VGetArrayPointer(s%yy), y, [2*s%model%nq + 2*s%model%nc])
    tret = real(s%t_now, c_double)
    call check(s, IDAGetNumSteps(s%mem, used), 'IDAGetNumSteps', error)
    if (error%code /= 0) return
    used = used + s%earlier%steps
    if (used >= s%settings%max_steps) then
      flag = -1_c_int
    else
      call check(s, IDASetMaxNumSteps(s%mem, int(s%settings%max_steps, c_long) - used), 'IDASetMaxNumSteps', error)
      flag = IDASolve(s%mem, real(t_target, c_double), tret, s%yy, s%yp, IDA_NORMAL)
    end if
    if (flag == -1_c_int) then      ! IDA_TOO_MUCH_WORK
      write (buf, '(a, i0, a, es10.3, a)') 'step budget (solver max_steps = ', s%settings%max_steps, &
        ') used up at t = ', tret, ' s'
      call fatal_error(error, trim(buf)//'; the motion is too fast for the tolerances'// &
                       singularity_hint(s%model, y(1:s%model%nq)))
      return
    end if
    call check(s, flag, 'IDASolve', error)
    if (error%code /= 0) then
      error%message = trim(error%message)//singularity_hint(s%model, y(1:s%model%nq))
      return
    end if
    s%t_now = tret
  end subroutine advance_to

  !> Restart IDA's history at a discontinuity (the session stands exactly on s%t_switch(1)),
  !> and set the stop time to the next one (SUNDIALS 6.4 has no IDAClearStopTime: beyond the
  !> last one the stop time goes far away).
  subroutine restart(s, error)
    type(dae_session), intent(inout) :: s
    type(error_type), intent(inout) :: error
    real(dp) :: next
    call add_counters(s, s%earlier)            ! IDAReInit zeroes IDA's counters
    s%ud%physics_valid = .false.               ! and the force has jumped
    call check(s, IDAReInit(s%mem, real(s%t_now, c_double), s%yy, s%yp), 'IDAReInit', error)
    s%t_switch = s%t_switch(2:)
    next = huge(1.0_dp)
    if (size(s%t_switch) > 0) next = s%t_switch(1)
    call check(s, IDASetStopTime(s%mem, real(min(next, 1.0e300_dp), c_double)), 'IDASetStopTime', error)
  end subroutine restart

  !> Release everything IDA holds.
  subroutine session_end(s)
    type(dae_session), intent(inout) :: s     !< session
    integer(c_int) :: flag
    if (c_associated(s%mem)) then
      call collect_stats(s)
      call IDAFree(s%mem)
    end if
    if (associated(s%block)) then
      call block_solver_destroy(s%block)
      deallocate (s%block)
    else if (associated(s%chain)) then
      call chain_solver_destroy(s%chain)
      deallocate (s%chain)
    else if (c_associated(s%ls)) then
      flag = SUNLinSolFree(s%ls)
    end if
    if (c_associated(s%mat)) call SUNMatDestroy(s%mat)
    if (c_associated(s%yy)) call N_VDestroy(s%yy)
    if (c_associated(s%yp)) call N_VDestroy(s%yp)
    if (c_associated(s%id)) call N_VDestroy(s%id)
    if (c_associated(s%atol)) call N_VDestroy(s%atol)
    if (c_associated(s%ctx)) flag = SUNContext_Free(s%ctx)
    if (associated(s%ud)) deallocate (s%ud)
    s%mem = c_null_ptr; s%ls = c_null_ptr; s%mat = c_null_ptr; s%ctx = c_null_ptr
    s%yy = c_null_ptr; s%yp = c_null_ptr; s%id = c_null_ptr; s%atol = c_null_ptr
    s%failed = .true.
  end subroutine session_end

  !> Integrate from t_out(1) through the output times; returns the state (q, v) there.
  subroutine integrate(model, settings, q0, v0, t_out, q_out, v_out, stats, error)
    type(model_type), intent(inout), target :: model  !< model
    type(integrator_settings), intent(in) :: settings !< tolerances
    real(dp), intent(in) :: q0(:), v0(:)              !< start state (projected here)
    real(dp), intent(in) :: t_out(:)                  !< output times, t_out(1) = start
    real(dp), intent(out) :: q_out(:, :), v_out(:, :) !< (nq, n_out) states at t_out
    type(solver_stats), intent(out) :: stats          !< solver statistics
    type(error_type), intent(inout) :: error          !< status
    type(dae_session) :: s
    real(dp) :: q(model%nq), v(model%nq)
    q = q0; v = v0
    q_out = 0.0_dp; v_out = 0.0_dp
    call session_start(s, model, settings, t_out(1), q, v, error)
    if (error%code == 0) then
      q_out(:, 1) = q; v_out(:, 1) = v
      if (size(t_out) > 1) call session_advance(s, t_out(2:), q_out(:, 2:), v_out(:, 2:), error)
    end if
    call session_end(s)
    stats = s%stats
  end subroutine integrate

  !> Statistics so far: those of IDA's earlier lives plus the current counters.
  subroutine collect_stats(s)
    type(dae_session), intent(inout) :: s
    if (.not. c_associated(s%mem)) return
    s%stats = s%earlier
    call add_counters(s, s%stats)
    s%stats%residual_evals = s%stats%residual_evals + s%ud%jac_residuals
    ! The chain solver forms no Jacobian: its factorisations count instead.
    if (associated(s%chain)) s%stats%jacobian_evals = s%stats%jacobian_evals + s%chain%factorisations
  end subroutine collect_stats

  !> Add IDA's current counters to a statistics record.
  subroutine add_counters(s, stats)
    type(dae_session), intent(in) :: s
    type(solver_stats), intent(inout) :: stats
    integer(c_long) :: counter
    integer(c_int) :: flag
    flag = IDAGetNumSteps(s%mem, counter); stats%steps = stats%steps + int(counter)
    flag = IDAGetNumResEvals(s%mem, counter); stats%residual_evals = stats%residual_evals + int(counter)
    flag = IDAGetNumLinResEvals(s%mem, counter); stats%residual_evals = stats%residual_evals + int(counter)
    flag = IDAGetNumJacEvals(s%mem, counter); stats%jacobian_evals = stats%jacobian_evals + int(counter)
    flag = IDAGetNumErrTestFails(s%mem, counter)
    stats%error_test_failures = stats%error_test_failures + int(counter)
    flag = IDAGetNumNonlinSolvConvFails(s%mem, counter)
    stats%convergence_failures = stats%convergence_failures + int(counter)
  end subroutine add_counters

  !> Turn a negative SUNDIALS flag into the error (with IDA's own message).
  subroutine check(s, status, what, error)
    type(dae_session), intent(in) :: s
    integer(c_int), intent(in) :: status
    character(len=*), intent(in) :: what
    type(error_type), intent(inout) :: error
    call sundials_flag_error(error, status, what, s%ud%ida_message)
  end subroutine check

  !> A SUNDIALS constructor that returned NULL (out of memory, or an invalid context) becomes
  !> the error; the constructors report no flag and call no error handler.
  subroutine require(ptr, what, error)
    type(c_ptr), intent(in) :: ptr
    character(len=*), intent(in) :: what
    type(error_type), intent(inout) :: error
    if (.not. c_associated(ptr)) call fatal_error(error, 'SUNDIALS '//what//' returned NULL (out of memory?)')
  end subroutine require

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
    if (.not. c_associated(udata)) return
    call c_f_pointer(udata, ud)
    call copy_solver_message(code, msg, ud%ida_message)
  end subroutine ida_error_handler

end module rotorcable_dae_integrator
