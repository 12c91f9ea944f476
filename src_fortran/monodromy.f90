!> The monodromy matrix of a periodic run: the first-order map of a start perturbation over one
!> period, in coordinates on the constraint manifold (issue 21, docs/model.md "Monodromy matrix").
!>
!> The independent state is x = (a, b): q = q0 + N a, v = v0 + N b + (velocity correction), N an
!> orthonormal null-space basis of the constraint Jacobian G(q0, t0).  Each column of the
!> monodromy Phi = dx(t0 + T)/dx(t0) is one forward sensitivity s = dy/dx_k of the GGL unknowns
!> y = (q, v, lambda, mu), integrated by SUNDIALS IDAS together with the state (IDASensInit,
!> staggered corrector, sensitivities in the error test; IDAS user guide, Hindmarsh, Serban et
!> al., "User Documentation for IDAS", SUNDIALS 6.4, sections 2.5 and 5.3).  The sensitivity
!> residual F_y s + F_y' s' is the analytic tangent sweep of the GGL residual
!> (ggl_residual_tangent, O(n) per column), not IDAS's difference quotients.
!>
!> IDACalcIC covers index 1 only, so the consistent initial sensitivities are computed here,
!> as consistent_start does for the state: s_q = N a satisfies G s_q = 0; s_v = N b - G^+ H s_q
!> with H = d(G v + g_t)/dq satisfies the differentiated velocity rows H s_q + G s_v = 0;
!> s_q' = s_v (mu = 0); s_v' and s_lambda are the directional derivative of the
!> acceleration-level solve (eq. 3.55) along (s_q, s_v).
module rotorcable_monodromy
  use, intrinsic :: iso_c_binding, only: c_int, c_long, c_double, c_ptr, c_loc, c_funloc, &
                                         c_f_pointer, c_associated, c_int64_t, c_null_ptr
  use rotorcable_kinds, only: dp
  use rotorcable_errors, only: error_type, fatal_error
  use rotorcable_model, only: model_type, solve_accelerations, constraint_jacobian
  use rotorcable_linalg, only: null_space, solve_least_norm
  use rotorcable_ggl_residual, only: ida_user_data, ggl_residual_dense, ggl_residual_tangent
  use rotorcable_ida_binding, only: N_VNew_Serial, N_VDestroy, N_VGetArrayPointer, IDASensInit, &
                                    IDASensSVtolerances, IDASetSensErrCon, IDAGetSens, IDASensFree, &
                                    IDAGetSensNumResEvals, IDA_STAGGERED, IDASetInitStep
  use rotorcable_nvector_kernels, only: use_fast_kernels
  use rotorcable_dae_integrator, only: integrator_settings, solver_stats, dae_session, session_start, &
                                       session_advance, session_end
  implicit none
  private
  public :: monodromy_run, initial_sensitivities, sensitivity_residual

  !> Step of the central difference of the acceleration-level solve per unit of the direction.
  !> s_v' and s_lambda only seed the predictor of IDAS's first step (BDF's corrector determines
  !> the new values from the residual alone), so their O(eps^2) truncation error costs at most a
  !> step size, never accuracy.
  real(dp), parameter :: ACCEL_STEP = 1.0e-6_dp

  !> First step of a sensitivity run, in periods (see monodromy_run).
  real(dp), parameter :: INIT_STEP = 1.0e-7_dp

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
    type(dae_session) :: s
    type(c_ptr), allocatable, target :: ys(:), yps(:), atols(:)
    real(c_double), pointer :: col(:)
    real(dp), allocatable :: ys0(:, :), yps0(:, :)
    real(c_double) :: tret
    integer(c_long) :: counter
    integer :: nq, nc, nf, n, ns, k

    nq = model%nq; nc = model%nc; nf = nq - nc; n = 2*nq + 2*nc; ns = 2*nf
    q_out = 0.0_dp; v_out = 0.0_dp; basis = 0.0_dp; phi = 0.0_dp; sens_residual_evals = 0
    call session_start(s, model, settings, t0, q0, v0, error)
    if (error%code == 0) then
      if (size(s%t_switch) > 0) then
        if (s%t_switch(1) <= t_out(size(t_out))) call fatal_error(error, 'the monodromy matrix needs loads '// &
          'without switch times within the period (a pulse makes the motion non-periodic)')
      end if
    end if
    if (error%code == 0) then
      allocate (ys0(n, ns), yps0(n, ns))
      call initial_sensitivities(model, t0, q0, v0, basis, ys0, yps0, error)
    end if
    if (error%code == 0) then
      allocate (ys(ns), yps(ns), atols(ns))
      ys = c_null_ptr; yps = c_null_ptr       ! the clean-up below frees only what was made
      do k = 1, ns
        ys(k) = N_VNew_Serial(int(n, c_int64_t), s%ctx)
        yps(k) = N_VNew_Serial(int(n, c_int64_t), s%ctx)
        if (.not. (c_associated(ys(k)) .and. c_associated(yps(k)))) then
          ! The constructor reports no flag; the vectors made so far are freed below.
          call fatal_error(error, 'SUNDIALS N_VNew_Serial returned NULL for a sensitivity vector (out of memory?)')
          exit
        end if
        if (settings%compiled_vector_kernels) then
          call use_fast_kernels(ys(k)); call use_fast_kernels(yps(k))
        end if
        call c_f_pointer(N_VGetArrayPointer(ys(k)), col, [n]); col = ys0(:, k)
        call c_f_pointer(N_VGetArrayPointer(yps(k)), col, [n]); col = yps0(:, k)
        ! The sensitivities are per unit of x (rad, rad/s): the state's own absolute tolerances.
        atols(k) = s%atol
      end do
    end if
    if (error%code == 0) then
      call check(IDASensInit(s%mem, int(ns, c_int), IDA_STAGGERED, c_funloc(sensitivity_residual), &
                             c_loc(ys), c_loc(yps)), 'IDASensInit', s, error)
      call check(IDASensSVtolerances(s%mem, real(settings%rtol, c_double), c_loc(atols)), &
                 'IDASensSVtolerances', s, error)
      ! Sensitivities in the local error test: the monodromy is as accurate as the state.
      call check(IDASetSensErrCon(s%mem, 1_c_int), 'IDASetSensErrCon', s, error)
      ! IDAS's first step is 0.5/||(y', s')||: the stiff twist modes give s_v' ~ w^2 ~ 1e7/s^2,
      ! which at atol 1e-12 means h ~ 1e-25 s, where cj^2 amplifies the round-off of the index-2
      ! multiplier sensitivities beyond any Newton tolerance (the corrector failed at t = 0 at
      ! rtol 1e-10).  A first step of INIT_STEP periods lets the error test shorten it instead.
      call check(IDASetInitStep(s%mem, real(INIT_STEP*(t_out(size(t_out)) - t0), c_double)), 'IDASetInitStep', &
                 s, error)
    end if
    if (error%code == 0) call session_advance(s, t_out, q_out, v_out, error)
    if (error%code == 0) then
      call check(IDAGetSens(s%mem, tret, c_loc(ys)), 'IDAGetSens', s, error)
      if (error%code == 0 .and. abs(tret - t_out(size(t_out))) > 1.0e-12_dp*max(1.0_dp, abs(tret))) &
        call fatal_error(error, 'IDAGetSens returned the sensitivities at another time than the period''s end')
    end if
    if (error%code == 0) then
      do k = 1, ns
        call c_f_pointer(N_VGetArrayPointer(ys(k)), col, [n])
        phi(1:nf, k) = matmul(col(1:nq), basis)
        phi(nf + 1:ns, k) = matmul(col(nq + 1:2*nq), basis)
      end do
    end if
    if (c_associated(s%mem)) then
      if (IDAGetSensNumResEvals(s%mem, counter) == 0) sens_residual_evals = int(counter)
      call IDASensFree(s%mem)
    end if
    call session_end(s)
    stats = s%stats
    if (allocated(ys)) then
      do k = 1, ns
        if (c_associated(ys(k))) call N_VDestroy(ys(k))
        if (c_associated(yps(k))) call N_VDestroy(yps(k))
      end do
    end if
  end subroutine monodromy_run

  !> Consistent initial sensitivities of the GGL unknowns for the 2 nf unit directions of
  !> x = (a, b) at a consistent start (q, v): column k <= nf moves a_k, column nf + k moves b_k.
  subroutine initial_sensitivities(model, t, q, v, basis, ys, yps, error)
    type(model_type), intent(inout) :: model  !< model
    real(dp), intent(in) :: t                 !< time [s]
    real(dp), intent(in) :: q(:), v(:)        !< consistent state
    real(dp), intent(out) :: basis(:, :)      !< (nq, nf) orthonormal N with G N = 0
    real(dp), intent(out) :: ys(:, :)         !< (n, 2 nf) s = dy/dx
    real(dp), intent(out) :: yps(:, :)        !< (n, 2 nf) s' = dy'/dx
    type(error_type), intent(inout) :: error  !< status
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
    do k = 1, 2*nf
      sq = 0.0_dp; sv = 0.0_dp
      if (k <= nf) then
        sq = basis(:, k)
      else
        sv = basis(:, k - nf)
      end if
      if (nc > 0 .and. k <= nf) then
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

  !> IDASensResFn: resval_k = F_y s_k + F_y' s_k' for every column, by the analytic tangent of
  !> the GGL residual at (t, y, y').  Returns 0, or 1 (recoverable: IDAS cuts the step) on a
  !> non-finite value.
  integer(c_int) function sensitivity_residual(ns, t, yy, yp, rr, yys, yps, rrs, udata, tmp1, tmp2, tmp3) bind(C)
    integer(c_int), value :: ns
    real(c_double), value :: t
    type(c_ptr), value :: yy, yp, rr, yys, yps, rrs, udata, tmp1, tmp2, tmp3
    type(ida_user_data), pointer :: ud
    type(c_ptr), pointer :: ps(:), pps(:), prs(:)
    real(c_double), pointer :: y(:), yd(:), r(:), s(:), sd(:), rs(:)
    integer :: n, k
    call c_f_pointer(udata, ud)
    n = 2*ud%nq + 2*ud%nc
    call c_f_pointer(N_VGetArrayPointer(yy), y, [n])
    call c_f_pointer(N_VGetArrayPointer(yp), yd, [n])
    call c_f_pointer(N_VGetArrayPointer(tmp1), r, [n])
    call c_f_pointer(yys, ps, [ns]); call c_f_pointer(yps, pps, [ns]); call c_f_pointer(rrs, prs, [ns])
    ! The tangent reuses the kinematics and loads of the last residual: evaluate it here, at
    ! (t, y, y'), into scratch (IDAS's resval is left as it is).
    call ggl_residual_dense(ud%model, t, y, yd, r)
    sensitivity_residual = 0
    do k = 1, ns
      call c_f_pointer(N_VGetArrayPointer(ps(k)), s, [n])
      call c_f_pointer(N_VGetArrayPointer(pps(k)), sd, [n])
      call c_f_pointer(N_VGetArrayPointer(prs(k)), rs, [n])
      call ggl_residual_tangent(ud%model, t, y, yd, s, sd, 1, rs)
      if (.not. all(abs(rs) <= huge(1.0_dp))) sensitivity_residual = 1
    end do
  end function sensitivity_residual

  !> A negative SUNDIALS flag becomes the error, with IDAS's own message.
  subroutine check(status, what, s, error)
    integer(c_int), intent(in) :: status
    character(len=*), intent(in) :: what
    type(dae_session), intent(in) :: s
    type(error_type), intent(inout) :: error
    character(len=16) :: buf
    if (status < 0 .and. error%code == 0) then
      write (buf, '(i0)') status
      call fatal_error(error, 'SUNDIALS '//what//' failed with flag '//trim(buf)//': '//trim(s%ud%ida_message))
    end if
  end subroutine check

end module rotorcable_monodromy
