!> Static equilibrium  -k(q, 0) - G(q)^T lambda = 0,  g(q) = 0  (eq. 3.50 with qdd = qd = 0,
!> eq. 3.51), solved by Newton's method on the constraint manifold with LAPACK.
module rotorcable_statics
  use rotorcable_kinds, only: dp
  use rotorcable_errors, only: error_type, fatal_error
  use rotorcable_model, only: model_type, support_b_key, eom_residual, constraint_residual, &
                              constraint_jacobian, total_energy, &
                              all_conservative
  use rotorcable_projection, only: project_positions, constraint_rank_margin, rank_loss_message, RANK_TOL
  use rotorcable_linalg, only: solve_least_norm, null_space, solve_spd, solve_dense
  use rotorcable_model_derivatives, only: eom_derivatives
  implicit none
  private
  public :: static_settings, static_result, solve_static, tangent_stiffness, damping_matrix, static_system

  !> Newton settings (from the deck's &solver group) and the time of the equilibrium (a
  !> moving support's pose, the rotor speed of a hub-frame run are taken at that time).
  type :: static_settings
    real(dp) :: t = 0.0_dp                    !< time [s]
    real(dp) :: tol_force = 1.0e-10_dp        !< max |generalized force residual| [Nm]
    real(dp) :: tol_constraint = 1.0e-12_dp   !< max |g| [m, rad]
    integer :: max_iterations = 200           !< Newton iterations
  end type static_settings

  !> Outcome of the Newton solve.
  type :: static_result
    integer :: iterations = 0                 !< Newton iterations taken
    integer :: residual_evals = 0             !< residual evaluations
    integer :: jacobian_evals = 0             !< Jacobian formations
    integer :: line_search_cuts = 0           !< step halvings
    real(dp) :: force_residual = 0.0_dp       !< final max |F_q| [Nm]
    real(dp) :: constraint_residual = 0.0_dp  !< final max |g|
  end type static_result

contains

  !> Why a start shape could not be closed: dependent constraints (a straight or taut chain)
  !> or simply too far.
  subroutine closure_failure(model, t, q, error)
    type(model_type), intent(inout) :: model  !< model
    real(dp), intent(in) :: t, q(:)           !< time, the shape where the projection stopped
    type(error_type), intent(inout) :: error  !< status
    real(dp) :: margin
    margin = constraint_rank_margin(model, t, q)
    if (margin < RANK_TOL) then
      call fatal_error(error, rank_loss_message(model, t, q, margin), key=support_b_key(model))
    else
      call fatal_error(error, 'the start shape cannot be closed onto clamp B (projection failed); '// &
                       'start from a shape nearer the clamp', key=support_b_key(model))
    end if
  end subroutine closure_failure

  !> Force residual f0 = -k(q, 0) (no multipliers) at rest relative to the model frame.
  subroutine rest_forces(model, t, q, lambda, f, n_eval)
    type(model_type), intent(inout) :: model
    real(dp), intent(in) :: t, q(:)
    real(dp), intent(in), optional :: lambda(:)    !< multipliers (none: lambda = 0)
    real(dp), intent(out) :: f(:)
    integer, intent(inout) :: n_eval
    real(dp) :: zero(model%nq), lam(max(model%nc, 1))
    zero = 0.0_dp
    lam = 0.0_dp
    if (present(lambda)) lam(1:model%nc) = lambda
    call eom_residual(model, t, q, zero, zero, lam, f)
    n_eval = n_eval + 1
  end subroutine rest_forces

  !> Tangent stiffness K = d(-k(q,0) - G^T lambda)/dq at fixed lambda (includes the
  !> curvature of the constraints weighted by lambda): the analytic tangent of the O(n)
  !> residual at rest, one sweep per coordinate (rest_tangent).
  subroutine tangent_stiffness(model, t, q, lambda, k_tan, n_eval)
    type(model_type), intent(inout) :: model  !< model
    real(dp), intent(in) :: t                 !< time [s]
    real(dp), intent(in) :: q(:)              !< coordinates [rad]
    real(dp), intent(in) :: lambda(:)         !< multipliers
    real(dp), intent(out) :: k_tan(:, :)      !< (nq,nq) [Nm/rad]
    integer, intent(inout) :: n_eval          !< residual evaluation counter
    call rest_tangent(model, t, q, lambda, .false., k_tan)
    n_eval = n_eval + 1
  end subroutine tangent_stiffness

  !> Linear damping matrix D = dF/dv at v = 0 (joint dampers, Coriolis and gyroscopic terms of a
  !> turning frame, drag): the analytic tangent of the residual at rest (rest_tangent).
  subroutine damping_matrix(model, t, q, lambda, d_mat)
    type(model_type), intent(inout) :: model  !< model
    real(dp), intent(in) :: t                 !< time [s]
    real(dp), intent(in) :: q(:)              !< coordinates [rad]
    real(dp), intent(in) :: lambda(:)         !< multipliers
    real(dp), intent(out) :: d_mat(:, :)      !< (nq,nq) [Nms/rad]
    call rest_tangent(model, t, q, lambda, .true., d_mat)
  end subroutine damping_matrix

  !> d(residual at rest)/dq (rates = .false.) or d/dv (rates = .true.) at v = vdot = 0 and
  !> fixed lambda: the whole matrices of one recursive pass (eom_derivatives, issue 39), exact;
  !> the same columns by one tangent sweep each (eom_residual_tangent) are their check
  !> (tests/test_analytic_derivatives.py).  Central differences cost two residuals per column
  !> and carried ~1e-10 of truncation and round-off.
  subroutine rest_tangent(model, t, q, lambda, rates, mat)
    type(model_type), intent(inout) :: model  !< model
    real(dp), intent(in) :: t                 !< time [s]
    real(dp), intent(in) :: q(:)              !< coordinates [rad]
    real(dp), intent(in) :: lambda(:)         !< multipliers
    logical, intent(in) :: rates              !< derivative with respect to the rates
    real(dp), intent(out) :: mat(:, :)        !< (nq,nq)
    real(dp) :: zero(size(q)), lam(max(model%nc, 1))
    real(dp), allocatable :: other(:, :)      ! the derivative not asked for (heap: nq^2 can be MBs)
    zero = 0.0_dp
    lam = 0.0_dp
    lam(1:model%nc) = lambda
    allocate (other(size(q), size(q)))
    if (rates) then
      call eom_derivatives(model, t, q, zero, zero, lam, other, mat)
    else
      call eom_derivatives(model, t, q, zero, zero, lam, mat, other)
    end if
  end subroutine rest_tangent

  !> The equilibrium equations at a given state and their Jacobian, for the implicit function
  !> theorem of the design sensitivities (pydriver/analyses/sensitivities.py): the residual
  !> R = (-k(q,0) - G^T lambda, g) of eq. 3.50/3.51 at rest, and, when asked, its Jacobian in
  !> (q, lambda), [[K, -G^T], [G, 0]], with K the tangent stiffness at fixed lambda
  !> (rest_tangent, exact) and G the constraint Jacobian.  Nothing is solved.
  subroutine static_system(model, t, q, lambda, with_jacobian, res, g, k_tan, g_jac)
    type(model_type), intent(inout) :: model  !< model
    real(dp), intent(in) :: t                 !< time [s]
    real(dp), intent(in) :: q(:)              !< coordinates [rad]
    real(dp), intent(in) :: lambda(:)         !< multipliers (size nc)
    logical, intent(in) :: with_jacobian      !< also form K and G
    real(dp), intent(out) :: res(:)           !< (nq) force residual [Nm]
    real(dp), intent(out) :: g(:)             !< (nc) constraint residual [m, rad]
    real(dp), intent(out) :: k_tan(:, :)      !< (nq,nq) dres/dq at fixed lambda [Nm/rad] (if asked)
    real(dp), intent(out) :: g_jac(:, :)      !< (nc,nq) G (if asked)
    integer :: n_eval
    n_eval = 0
    k_tan = 0.0_dp
    g_jac = 0.0_dp
    g = 0.0_dp
    call rest_forces(model, t, q, lambda, res, n_eval)
    if (model%nc > 0) call constraint_residual(model, t, q, g)
    if (.not. with_jacobian) return
    call tangent_stiffness(model, t, q, lambda, k_tan, n_eval)
    if (model%nc > 0) call constraint_jacobian(model, t, q, g_jac)
  end subroutine static_system

  !> Multipliers by least squares (G^T lambda = f0), the equilibrium residual f0 - G^T lambda,
  !> the null-space basis of G and the reduced gradient N^T f0.
  subroutine reduced_gradient(model, t, q, lambda, f, basis, grad, n_eval)
    type(model_type), intent(inout) :: model
    real(dp), intent(in) :: t, q(:)
    real(dp), intent(out) :: lambda(:), f(:), basis(:, :), grad(:)
    integer, intent(inout) :: n_eval
    real(dp) :: g_jac(model%nc, model%nq)
    integer :: info
    call rest_forces(model, t, q, f=f, n_eval=n_eval)
    if (model%nc > 0) then
      call constraint_jacobian(model, t, q, g_jac)
      call solve_least_norm(transpose(g_jac), f, lambda, info)
      f = f - matmul(lambda, g_jac)
    end if
    call null_space(g_jac, basis, info)
    grad = matmul(f, basis)
  end subroutine reduced_gradient

  !> Static equilibrium from the deck's start shape; q and lambda are updated in place.
  !>
  !> 1. Close the start shape onto clamp B (project_positions): the thesis's consistent
  !>    "Anfangsposition" (section 5.3).
  !> 2. Newton on the constraint manifold with Levenberg-Marquardt step control: with N a
  !>    null-space basis of G, solve (N^T K N + mu I) z = -N^T f0, step q + N z, project
  !>    back onto g = 0, accept if the potential energy (gravity, rotor field, springs)
  !>    decreases (Armijo) or the reduced gradient halves; with a non-conservative load
  !>    (drag), K unsymmetric and accept if the reduced gradient decreases.  K = d(f0 - G^T lambda)/dq at fixed
  !>    lambda is the tangent stiffness including the constraint curvature (the
  !>    analytic tangent of the O(n) residual, rest_tangent).  mu -> 0 near the solution: quadratic convergence;
  !>    mu > 0 far from it or where N^T K N is indefinite: a descent step, so the iteration
  !>    settles into a stable equilibrium like the thesis's damped settling does.
  !> 3. lambda from G^T lambda = f0 (least squares; exact at equilibrium), eq. 3.50.
  subroutine solve_static(model, settings, q, lambda, res, error)
    type(model_type), intent(inout) :: model      !< model
    type(static_settings), intent(in) :: settings !< tolerances
    real(dp), intent(inout) :: q(:)               !< start shape -> equilibrium [rad]
    real(dp), intent(inout) :: lambda(:)          !< multipliers (size nc)
    type(static_result), intent(out) :: res       !< statistics
    type(error_type), intent(inout) :: error      !< status
    integer :: nq, nc, nf, it, i, info, cut
    real(dp) :: f(model%nq), k_tan(model%nq, model%nq)
    real(dp) :: basis(model%nq, model%nq - model%nc), grad(model%nq - model%nc)
    real(dp) :: hess(model%nq - model%nc, model%nq - model%nc), hm(model%nq - model%nc, model%nq - model%nc)
    real(dp) :: z(model%nq - model%nc), q_try(model%nq), lam_try(model%nc), f_try(model%nq)
    real(dp) :: basis_try(model%nq, model%nq - model%nc), grad_try(model%nq - model%nc), g(max(model%nc, 1))
    real(dp) :: zero(model%nq), mu, scale_h, v_now, v_try, t, margin, floor, rhs(model%nq - model%nc)
    logical :: accepted, converged, conservative
    character(len=96) :: buf

    nq = model%nq; nc = model%nc; nf = nq - nc
    zero = 0.0_dp
    t = settings%t
    ! With a load that is non-conservative at rest (drag in a stream or a turning frame) the
    ! potential energy is no merit function and the tangent stiffness is not symmetric:
    ! Levenberg-Marquardt on the reduced gradient instead.  A load that vanishes at rest (drag in
    ! still air) keeps the energy's path, bit for bit the run without it (issue 35).
    conservative = all_conservative(model, t)
    if (project_positions(model, t, q) > 1.0e-9_dp) then
      call closure_failure(model, t, q, error)
      return
    end if
    mu = 0.0_dp
    converged = .false.
    floor = 0.0_dp
    call reduced_gradient(model, t, q, lambda, f, basis, grad, res%residual_evals)
    v_now = total_energy(model, t, q, zero)
    do it = 0, settings%max_iterations
      res%force_residual = maxval(abs(f))
      res%constraint_residual = 0.0_dp
      if (nc > 0) then
        call constraint_residual(model, t, q, g)
        res%constraint_residual = maxval(abs(g))
      end if
      ! The test: below newton_tol, or at the round-off floor of the forces in balance (a stiff
      ! chain carries joint moments ~ c dq whose sum cannot cancel better than ~1e3 eps of
      ! their size; newton_tol = 1e-10 Nm is below that floor for c ~ 1e4 Nm/rad).
      converged = res%force_residual <= max(settings%tol_force, floor) .and. &
                  res%constraint_residual <= settings%tol_constraint
      if (converged .or. it == settings%max_iterations) exit
      res%iterations = it + 1
      call tangent_stiffness(model, t, q, lambda, k_tan, res%residual_evals)
      res%jacobian_evals = res%jacobian_evals + 1
      floor = 1.0e3_dp*epsilon(1.0_dp)*maxval(abs(k_tan))*max(1.0_dp, maxval(abs(q)))
      hess = matmul(transpose(basis), matmul(k_tan, basis))
      accepted = .false.
      if (conservative) then
        hess = 0.5_dp*(hess + transpose(hess))
        rhs = -grad
      else
        ! A non-conservative load: first Newton's step on the reduced residual with
        ! backtracking on |N^T f| (quadratic near the solution however ill-conditioned), then,
        ! if that fails, Levenberg-Marquardt on H^T H, whose steps descend |N^T f|^2 for any mu
        ! (for an unsymmetric H, -g alone need not).
        hm = hess
        z = -grad
        call solve_dense(hm, z, info)
        if (info == 0) then
          do cut = 0, 6
            q_try = q + 0.5_dp**cut*matmul(basis, z)
            if (project_positions(model, t, q_try) <= 1.0e-9_dp) then
              call reduced_gradient(model, t, q_try, lam_try, f_try, basis_try, grad_try, res%residual_evals)
              accepted = norm2(grad_try) <= (1.0_dp - 1.0e-4_dp*0.5_dp**cut)*norm2(grad)
              if (accepted) exit
            end if
            res%line_search_cuts = res%line_search_cuts + 1
          end do
          if (accepted) v_try = total_energy(model, t, q_try, zero)
        end if
        rhs = -matmul(grad, hess)
        hess = matmul(transpose(hess), hess)
      end if
      scale_h = max(maxval(abs(hess)), tiny(1.0_dp))
      do cut = 0, 60
        if (accepted) exit
        hm = hess
        do i = 1, nf
          hm(i, i) = hm(i, i) + mu
        end do
        z = rhs
        call solve_spd(hm, z, info)
        if (info == 0) then
          q_try = q + matmul(basis, z)
          if (project_positions(model, t, q_try) <= 1.0e-9_dp) then
            call reduced_gradient(model, t, q_try, lam_try, f_try, basis_try, grad_try, res%residual_evals)
            v_try = total_energy(model, t, q_try, zero)
            if (conservative) then
              accepted = v_try <= v_now + 1.0e-4_dp*dot_product(grad, z) .or. &
                         norm2(grad_try) <= 0.5_dp*norm2(grad)
            else
              accepted = norm2(grad_try) <= (1.0_dp - 1.0e-4_dp)*norm2(grad)
            end if
            if (accepted) exit
          end if
        end if
        mu = max(4.0_dp*mu, 1.0e-8_dp*scale_h)
        res%line_search_cuts = res%line_search_cuts + 1
      end do
      if (.not. accepted) exit
      q = q_try; lambda = lam_try; f = f_try; basis = basis_try; grad = grad_try; v_now = v_try
      mu = 0.25_dp*mu
      if (mu < 1.0e-12_dp*scale_h) mu = 0.0_dp
    end do
    ! Converged only when the test passed: an iteration limit or a line search stalled above
    ! the floor is an error, never "the equilibrium".
    converged = res%force_residual <= max(settings%tol_force, floor) .and. &
                res%constraint_residual <= settings%tol_constraint
    if (.not. converged) then
      write (buf, '(es10.3, a, es10.3, a, i0, a)') res%force_residual, ' Nm, |g| = ', res%constraint_residual, &
        ' after ', res%iterations, ' iterations'
      call fatal_error(error, 'static equilibrium not found: residual force '//trim(buf)// &
                       ' (newton_tol, newton_max_iter in &solver)')
      return
    end if
    if (nc > 0) then
      margin = constraint_rank_margin(model, t, q)
      if (margin < RANK_TOL) call fatal_error(error, rank_loss_message(model, t, q, margin), key=support_b_key(model))
    end if
  end subroutine solve_static

end module rotorcable_statics
