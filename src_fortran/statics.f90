!> Static equilibrium by Newton's method on
!>   F(q, lambda) = [ -k(q, 0) - G(q)^T lambda ; g(q) ] = 0
!> (eq. 3.50 with qdd = qd = 0 and eq. 3.51), solved with LAPACK.
!>
!> The blocks with respect to lambda are exact (-G^T and 0); the tangent stiffness
!> d(-k - G^T lambda)/dq is formed by central differences of the O(n) inverse-dynamics
!> residual (2 nq evaluations, truncation error ~h^2 ~ 1e-12 relative).  A backtracking
!> line search on a dimensionally consistent merit (constraint rows scaled by the chain
!> weight and length) keeps Newton from diverging on far starts.
module rotorcable_statics
  use rotorcable_kinds, only: dp
  use rotorcable_errors, only: error_type, fatal_error
  use rotorcable_model, only: model_type, eom_residual, constraint_residual, constraint_jacobian
  use rotorcable_linalg, only: solve_dense
  implicit none
  private
  public :: static_settings, static_result, solve_static

  !> Newton settings (from the deck's &solver group).
  type :: static_settings
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

  subroutine static_residual(model, q, lambda, f, n_eval)
    type(model_type), intent(inout) :: model
    real(dp), intent(in) :: q(:), lambda(:)
    real(dp), intent(out) :: f(:)
    integer, intent(inout) :: n_eval
    real(dp) :: zero(model%nq), lam(max(model%nc, 1))
    zero = 0.0_dp
    lam = 0.0_dp
    lam(1:model%nc) = lambda
    call eom_residual(model, 0.0_dp, q, zero, zero, lam, f(1:model%nq))
    if (model%nc > 0) call constraint_residual(model, q, f(model%nq + 1:))
    n_eval = n_eval + 1
  end subroutine static_residual

  !> Newton iteration from (q, lambda); both are updated in place.
  subroutine solve_static(model, settings, q, lambda, res, error)
    type(model_type), intent(inout) :: model      !< model
    type(static_settings), intent(in) :: settings !< tolerances
    real(dp), intent(inout) :: q(:)               !< start shape -> equilibrium [rad]
    real(dp), intent(inout) :: lambda(:)          !< multipliers (size nc)
    type(static_result), intent(out) :: res       !< statistics
    type(error_type), intent(inout) :: error      !< status
    integer :: nq, nc, n, it, i, info, cut
    real(dp) :: f(model%nq + model%nc), f_try(model%nq + model%nc), jac(model%nq + model%nc, model%nq + model%nc)
    real(dp) :: fp(model%nq + model%nc), fm(model%nq + model%nc), dx(model%nq + model%nc)
    real(dp) :: q_try(model%nq), lam_try(model%nc), scale(model%nq + model%nc), h, step, merit, merit_try
    character(len=64) :: buf

    nq = model%nq; nc = model%nc; n = nq + nc
    ! Merit weights: constraint rows (m, rad) times weight x length become moments [Nm].
    scale = 1.0_dp
    if (nc > 0) scale(nq + 1:) = max(sum(model%chain%mass)*max(norm2(model%loads%gravity), 1.0_dp) &
                                     *sum(model%chain%length), 1.0e-12_dp)
    call static_residual(model, q, lambda, f, res%residual_evals)
    do it = 1, settings%max_iterations
      res%force_residual = maxval(abs(f(1:nq)))
      res%constraint_residual = 0.0_dp
      if (nc > 0) res%constraint_residual = maxval(abs(f(nq + 1:)))
      if (res%force_residual <= settings%tol_force .and. res%constraint_residual <= settings%tol_constraint) exit
      res%iterations = it
      ! Jacobian: central differences in q, exact in lambda.
      jac = 0.0_dp
      do i = 1, nq
        h = 1.0e-6_dp*max(1.0_dp, abs(q(i)))
        q_try = q; q_try(i) = q(i) + h
        call static_residual(model, q_try, lambda, fp, res%residual_evals)
        q_try(i) = q(i) - h
        call static_residual(model, q_try, lambda, fm, res%residual_evals)
        jac(:, i) = (fp - fm)/(2.0_dp*h)
      end do
      if (nc > 0) then
        call constraint_jacobian(model, q, jac(nq + 1:, 1:nq))
        jac(1:nq, nq + 1:) = -transpose(jac(nq + 1:, 1:nq))
      end if
      res%jacobian_evals = res%jacobian_evals + 1
      dx = -f
      call solve_dense(jac, dx, info)
      if (info /= 0) then
        call fatal_error(error, 'static Newton: singular Jacobian (the equilibrium is not isolated; '// &
                         'add springs or check the clamp geometry)')
        return
      end if
      ! Backtracking line search on the scaled residual norm.
      merit = norm2(f*scale/scale(1))
      step = 1.0_dp
      do cut = 0, 30
        q_try = q + step*dx(1:nq)
        lam_try = lambda + step*dx(nq + 1:)
        call static_residual(model, q_try, lam_try, f_try, res%residual_evals)
        merit_try = norm2(f_try*scale/scale(1))
        if (merit_try < (1.0_dp - 1.0e-4_dp*step)*merit .or. merit < 1.0e-9_dp) exit
        step = 0.5_dp*step
        res%line_search_cuts = res%line_search_cuts + 1
      end do
      q = q_try
      lambda = lam_try
      f = f_try
    end do
    res%force_residual = maxval(abs(f(1:nq)))
    if (nc > 0) res%constraint_residual = maxval(abs(f(nq + 1:)))
    if (res%force_residual > 1.0e3_dp*settings%tol_force .or. &
        res%constraint_residual > 1.0e3_dp*settings%tol_constraint) then
      write (buf, '(es10.3,a,es10.3)') res%force_residual, ' / ', res%constraint_residual
      call fatal_error(error, 'static Newton did not converge (residual force / constraint = '//trim(buf)//')')
    end if
  end subroutine solve_static

end module rotorcable_statics
