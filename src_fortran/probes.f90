!> Probes for the tests and benchmarks, kept apart from the run API (rotorcable_api): every
!> model quantity at a state (to check against independent formulations and finite
!> differences), the GGL residual and iteration matrix, timed kernels and a timed
!> integration.  Same handle and status conventions as rotorcable_api.
module rotorcable_probes
  use, intrinsic :: iso_c_binding, only: c_double, c_int, c_null_ptr
  use rotorcable_kinds, only: dp
  use rotorcable_errors, only: error_type, fatal_error
  use rotorcable_model, only: model_type, eom_residual, generalized_forces, mass_matrix, constraint_residual, &
                              constraint_jacobian, constraint_bias, constraint_velocity, solve_accelerations, &
                              total_energy, positions_at
  use rotorcable_model_registry, only: lookup_model
  use rotorcable_mass_matrix, only: mass_matrix_jourdain
  use rotorcable_dae_integrator, only: integrator_settings, settings_from_flat, solver_stats, consistent_start, &
                                       integrate
  use rotorcable_ggl_residual, only: ggl_residual_dense, ggl_jacobian_dense, ggl_residual_tangent, &
                                     ggl_residual_tangent_columns, ggl_residual_columns, ggl_residual_matrix_columns
  use rotorcable_ggl_linear_solver, only: ggl_block_solver, block_factorise, block_solve
  use rotorcable_chain_linear_solver, only: ggl_chain_solver, chain_solver_create, chain_factorise, chain_solve, &
                                            chain_iteration_matrix
  use rotorcable_ode_integrator, only: ode_settings, integrate_ode, ode_jacobian_matrix, ode_right_hand_side, ODE_RK8PD, ODE_MSBDF
  use rotorcable_linalg, only: dgetrf, dgetrs
  use rotorcable_projection, only: constraint_rank_margin
  use rotorcable_articulated_body, only: articulated_factors, articulated_factorise, articulated_solve
  use rotorcable_parameter_sensitivity, only: difference_points, parameter_partial
  use rotorcable_model_derivatives, only: eom_derivatives
  implicit none
  private
  public :: rc_probe_evaluate, rc_probe_consistent_start, rc_probe_ggl_residual, rc_probe_iteration_matrix, &
            rc_probe_time_kernels, rc_probe_integrate, rc_probe_rank_margin, rc_probe_chain_solver, &
            rc_probe_residual_tangent, rc_probe_residual_tangent_columns, rc_probe_articulated_solve, &
            rc_probe_parameter_partial, rc_probe_eom_derivatives, rc_probe_ode_jacobian

contains

  !> The model of a handle, or an error.
  function model_of(handle, error) result(model)
    integer(c_int), intent(in) :: handle
    type(error_type), intent(inout) :: error
    type(model_type), pointer :: model
    model => lookup_model(handle)
    if (.not. associated(model)) call fatal_error(error, 'no model with this handle (freed?)')
  end function model_of

  subroutine to_status(error, stat, msg)
    type(error_type), intent(in) :: error
    integer(c_int), intent(out) :: stat
    character(len=1024), intent(out) :: msg
    stat = 0; msg = ''
    if (error%code /= 0) then
      stat = 2
      msg = error%message
    end if
  end subroutine to_status

  !> Every model quantity at one state.
  subroutine rc_probe_evaluate(handle, t, nq, q, v, vdot, ncd, lambda, mass_crba, mass_jourdain, k_gen, res, &
                               g, g_jac, g_bias, g_vel, vdot_acc, lambda_acc, wrenches, energy, stat, msg)
    integer(c_int), intent(in) :: handle          !< model handle
    real(c_double), intent(in) :: t               !< time [s]
    integer(c_int), intent(in) :: nq, ncd         !< coordinates, max(1, nc)
    real(c_double), intent(in) :: q(nq), v(nq), vdot(nq)  !< state and accelerations
    real(c_double), intent(in) :: lambda(ncd)     !< multipliers
    real(c_double), intent(out) :: mass_crba(nq, nq)      !< M by composite rigid bodies
    real(c_double), intent(out) :: mass_jourdain(nq, nq)  !< M by the thesis's Jourdain form
    real(c_double), intent(out) :: k_gen(nq)      !< k(q, v, t)
    real(c_double), intent(out) :: res(nq)        !< M vdot - k - G^T lambda by inverse dynamics
    real(c_double), intent(out) :: g(ncd)         !< g(q, t)
    real(c_double), intent(out) :: g_jac(ncd, nq) !< G(q, t)
    real(c_double), intent(out) :: g_bias(ncd)    !< d^2 g/dt^2 at vdot = 0
    real(c_double), intent(out) :: g_vel(ncd)     !< G v + g_t
    real(c_double), intent(out) :: vdot_acc(nq)   !< accelerations from eq. 3.55
    real(c_double), intent(out) :: lambda_acc(ncd)  !< multipliers from eq. 3.55
    real(c_double), intent(out) :: wrenches(12)   !< support wrenches for (vdot_acc, lambda_acc)
    real(c_double), intent(out) :: energy         !< total energy [J]
    integer(c_int), intent(out) :: stat           !< 0 = ok
    character(len=1024), intent(out) :: msg       !< why not
    type(model_type), pointer :: model
    type(error_type) :: error
    real(dp) :: r(nq)
    integer :: nc, info
    mass_crba = 0; mass_jourdain = 0; k_gen = 0; res = 0; g = 0; g_jac = 0; g_bias = 0; g_vel = 0
    vdot_acc = 0; lambda_acc = 0; wrenches = 0; energy = 0
    model => model_of(handle, error)
    if (error%code == 0) then
      nc = model%nc
      call mass_matrix(model, t, q, mass_crba)
      call mass_matrix_jourdain(model%chain, model%st, mass_jourdain)
      call generalized_forces(model, t, q, v, k_gen)
      call eom_residual(model, t, q, v, vdot, lambda, res)
      if (nc > 0) then
        call constraint_residual(model, t, q, g(1:nc))
        call constraint_jacobian(model, t, q, g_jac(1:nc, :))
        call constraint_bias(model, t, q, v, g_bias(1:nc))
        call constraint_velocity(model, t, q, v, g_vel(1:nc))
      end if
      call solve_accelerations(model, t, q, v, vdot_acc, lambda_acc(1:nc), info)
      if (info /= 0) call fatal_error(error, 'singular acceleration system')
      call eom_residual(model, t, q, v, vdot_acc, lambda_acc, r, wrenches)
      energy = total_energy(model, t, q, v)
    end if
    call to_status(error, stat, msg)
  end subroutine rc_probe_evaluate

  !> The equation-of-motion residual's derivatives as whole matrices at (t, q, v, vdot, lambda):
  !> d(res)/dq, d(res)/dv at fixed lambda and M = d(res)/d(vdot) (eom_derivatives, one pass; the
  !> check is rc_probe_residual_tangent's columns and rc_probe_evaluate's M).
  subroutine rc_probe_eom_derivatives(handle, t, nq, q, v, vdot, ncd, lambda, dres_dq, dres_dv, mass, stat, msg)
    integer(c_int), intent(in) :: handle          !< model handle
    real(c_double), intent(in) :: t               !< time [s]
    integer(c_int), intent(in) :: nq, ncd         !< coordinates, max(1, nc)
    real(c_double), intent(in) :: q(nq), v(nq), vdot(nq)  !< state and accelerations
    real(c_double), intent(in) :: lambda(ncd)     !< multipliers
    real(c_double), intent(out) :: dres_dq(nq, nq)  !< d(res)/dq [Nm/rad]
    real(c_double), intent(out) :: dres_dv(nq, nq)  !< d(res)/dv [Nms/rad]
    real(c_double), intent(out) :: mass(nq, nq)     !< M [kg m^2]
    integer(c_int), intent(out) :: stat           !< 0 = ok
    character(len=1024), intent(out) :: msg       !< why not
    type(model_type), pointer :: model
    type(error_type) :: error
    dres_dq = 0.0_dp; dres_dv = 0.0_dp; mass = 0.0_dp
    model => model_of(handle, error)
    if (error%code == 0) call eom_derivatives(model, t, q, v, vdot, lambda, dres_dq, dres_dv, mass)
    call to_status(error, stat, msg)
  end subroutine rc_probe_eom_derivatives

  !> The consistent start from (q, v) at t, as the GGL unknowns y = (q, v, lambda, mu = 0) and
  !> their derivatives yd = (v, vdot, 0, 0).
  subroutine rc_probe_consistent_start(handle, t, nq, q, v, n, y, yd, stat, msg)
    integer(c_int), intent(in) :: handle          !< model handle
    real(c_double), intent(in) :: t               !< time [s]
    integer(c_int), intent(in) :: nq, n           !< coordinates, 2 nq + 2 nc
    real(c_double), intent(in) :: q(nq), v(nq)    !< start state
    real(c_double), intent(out) :: y(n), yd(n)    !< GGL unknowns and derivatives
    integer(c_int), intent(out) :: stat           !< 0 = ok
    character(len=1024), intent(out) :: msg       !< why not
    type(model_type), pointer :: model
    type(error_type) :: error
    real(dp) :: qq(nq), vv(nq), vdot(nq), lam(n)
    y = 0.0_dp; yd = 0.0_dp
    model => model_of(handle, error)
    if (error%code == 0) then
      if (n /= 2*nq + 2*model%nc) call fatal_error(error, 'n must be 2 nq + 2 nc')
    end if
    if (error%code == 0) then
      qq = q; vv = v
      call consistent_start(model, t, qq, vv, vdot, lam(1:model%nc), error)
      y(1:nq) = qq; y(nq + 1:2*nq) = vv; y(2*nq + 1:2*nq + model%nc) = lam(1:model%nc)
      yd(1:nq) = vv; yd(nq + 1:2*nq) = vdot
    end if
    call to_status(error, stat, msg)
  end subroutine rc_probe_consistent_start

  !> The GGL residual F(t, y, y') of the integrator at any (y, y').
  subroutine rc_probe_ggl_residual(handle, t, n, y, yd, r, stat, msg)
    integer(c_int), intent(in) :: handle          !< model handle
    real(c_double), intent(in) :: t               !< time [s]
    integer(c_int), intent(in) :: n               !< 2 nq + 2 nc
    real(c_double), intent(in) :: y(n), yd(n)     !< unknowns and their derivatives
    real(c_double), intent(out) :: r(n)           !< residual
    integer(c_int), intent(out) :: stat           !< 0 = ok
    character(len=1024), intent(out) :: msg       !< why not
    type(model_type), pointer :: model
    type(error_type) :: error
    r = 0.0_dp
    model => model_of(handle, error)
    if (error%code == 0) then
      if (n /= 2*model%nq + 2*model%nc) call fatal_error(error, 'n must be 2 nq + 2 nc')
    end if
    if (error%code == 0) call ggl_residual_dense(model, t, y, yd, r)
    call to_status(error, stat, msg)
  end subroutine rc_probe_ggl_residual

  !> The explicit partial F_p = sum_i w_i F(model_i) / h of one design parameter at (t, y, y'),
  !> as the sensitivity integration takes it: from the rebuilt models' whole residuals, or
  !> (loads_only = 1) from their loads' generalized forces on this model's kinematics, or (2)
  !> from their bodies' and loads' Newton-Euler pass on it, of the load slots where changed /= 0.
  subroutine rc_probe_parameter_partial(handle, npts, handles, weights, h, loads_only, nl, changed, t, n, y, yd, fp, &
                                        stat, msg)
    integer(c_int), intent(in) :: handle          !< the run's model
    integer(c_int), intent(in) :: npts            !< difference points
    integer(c_int), intent(in) :: handles(npts)   !< their models (0: the run's own)
    real(c_double), intent(in) :: weights(npts)   !< difference weights
    real(c_double), intent(in) :: h               !< step [unit of p]
    integer(c_int), intent(in) :: loads_only      !< 1: loads' generalized forces; 2: bodies and loads
    integer(c_int), intent(in) :: nl              !< load slots
    integer(c_int), intent(in) :: changed(nl)     !< 1: the slot's load is differenced
    real(c_double), intent(in) :: t               !< time [s]
    integer(c_int), intent(in) :: n               !< 2 nq + 2 nc
    real(c_double), intent(in) :: y(n), yd(n)     !< unknowns and their derivatives
    real(c_double), intent(out) :: fp(n)          !< dF/dp
    integer(c_int), intent(out) :: stat           !< 0 = ok
    character(len=1024), intent(out) :: msg       !< why not
    type(model_type), pointer :: model
    type(difference_points) :: points
    type(error_type) :: error
    integer :: i
    fp = 0.0_dp
    model => model_of(handle, error)
    if (error%code == 0) then
      if (n /= 2*model%nq + 2*model%nc) call fatal_error(error, 'n must be 2 nq + 2 nc')
    end if
    if (error%code == 0) then
      allocate (points%model(npts, 1))
      points%offset = reshape([(0.0_dp, i = 1, npts)], [npts, 1])
      points%weight = reshape(weights, [npts, 1])
      points%h = [h]
      points%loads_only = [loads_only == 1]
      points%bodies_and_loads = [loads_only == 2]
      points%changed_load = reshape(changed /= 0, [nl, 1])
      points%base => model
      do i = 1, npts
        if (handles(i) /= 0) points%model(i, 1)%m => model_of(handles(i), error)
      end do
    end if
    if (error%code == 0) call parameter_partial(points, 1, t, y, yd, fp)
    call to_status(error, stat, msg)
  end subroutine rc_probe_parameter_partial

  !> The first-order change of the GGL residual at (t, y, y') for the change (dy, dyd), by the
  !> tangent sweep of the analytic Jacobian (ggl_residual_tangent, from body 1), which evaluates
  !> its base point itself unless the workspace holds it (nothing is evaluated before it here).
  subroutine rc_probe_residual_tangent(handle, t, n, y, yd, dy, dyd, dr, stat, msg)
    integer(c_int), intent(in) :: handle          !< model handle
    real(c_double), intent(in) :: t               !< time [s]
    integer(c_int), intent(in) :: n               !< GGL unknowns 2 nq + 2 nc
    real(c_double), intent(in) :: y(n), yd(n)     !< state
    real(c_double), intent(in) :: dy(n), dyd(n)   !< direction
    real(c_double), intent(out) :: dr(n)          !< change of the residual
    integer(c_int), intent(out) :: stat           !< 0 = ok
    character(len=1024), intent(out) :: msg       !< why not
    type(model_type), pointer :: model
    type(error_type) :: error
    dr = 0.0_dp
    model => model_of(handle, error)
    if (error%code == 0) then
      if (n /= 2*model%nq + 2*model%nc) call fatal_error(error, 'n must be 2 nq + 2 nc')
    end if
    if (error%code == 0) then
      call ggl_residual_tangent(model, t, y, yd, dy, dyd, 1, dr)
    end if
    call to_status(error, stat, msg)
  end subroutine rc_probe_residual_tangent

  !> The same for m directions at once: route 0 the sensitivity residuals' choice
  !> (ggl_residual_columns), 1 the tangent sweeps (ggl_residual_tangent_columns: column c must
  !> be rc_probe_residual_tangent of column c, bit for bit), 2 the whole matrices
  !> (ggl_residual_matrix_columns).
  subroutine rc_probe_residual_tangent_columns(handle, t, n, y, yd, m, dy, dyd, route, dr, stat, msg)
    integer(c_int), intent(in) :: handle          !< model handle
    real(c_double), intent(in) :: t               !< time [s]
    integer(c_int), intent(in) :: n               !< GGL unknowns 2 nq + 2 nc
    real(c_double), intent(in) :: y(n), yd(n)     !< state
    integer(c_int), intent(in) :: m               !< directions
    real(c_double), intent(in) :: dy(n, m), dyd(n, m)  !< the directions
    integer(c_int), intent(in) :: route           !< 0 chosen, 1 sweeps, 2 matrices
    real(c_double), intent(out) :: dr(n, m)       !< changes of the residual
    integer(c_int), intent(out) :: stat           !< 0 = ok
    character(len=1024), intent(out) :: msg       !< why not
    type(model_type), pointer :: model
    type(error_type) :: error
    dr = 0.0_dp
    model => model_of(handle, error)
    if (error%code == 0) then
      if (n /= 2*model%nq + 2*model%nc) call fatal_error(error, 'n must be 2 nq + 2 nc')
    end if
    if (error%code == 0) then
      select case (route)
      case (1)
        call ggl_residual_tangent_columns(model, t, y, yd, dy, dyd, dr)
      case (2)
        call ggl_residual_matrix_columns(model, t, y, yd, dy, dyd, dr)
      case default
        call ggl_residual_columns(model, t, y, yd, dy, dyd, dr)
      end select
    end if
    call to_status(error, stat, msg)
  end subroutine rc_probe_residual_tangent_columns

  !> (M(q) + diag(armature))^-1 tau by the articulated-body factorisation, at the frames of q at t.
  subroutine rc_probe_articulated_solve(handle, t, nq, q, armature, tau, x, stat, msg)
    integer(c_int), intent(in) :: handle          !< model handle
    real(c_double), intent(in) :: t               !< time [s]
    integer(c_int), intent(in) :: nq              !< coordinates
    real(c_double), intent(in) :: q(nq), armature(nq), tau(nq)  !< state, diagonal, right-hand side
    real(c_double), intent(out) :: x(nq)          !< solution
    integer(c_int), intent(out) :: stat           !< 0 = ok
    character(len=1024), intent(out) :: msg       !< why not
    type(model_type), pointer :: model
    type(error_type) :: error
    type(articulated_factors) :: f
    real(dp) :: rhs(nq, 1), sol(nq, 1)
    integer :: info
    x = 0.0_dp
    model => model_of(handle, error)
    if (error%code == 0) then
      call positions_at(model, t, q)
      call articulated_factorise(model%chain, model%st, armature, f, info)
      if (info /= 0) call fatal_error(error, 'articulated factorisation: singular')
    end if
    if (error%code == 0) then
      rhs(:, 1) = tau
      call articulated_solve(model%chain, f, rhs, sol)
      x = sol(:, 1)
    end if
    call to_status(error, stat, msg)
  end subroutine rc_probe_articulated_solve

  !> The approximate iteration matrix of the chain solver (rotorcable_chain_linear_solver) at
  !> (t, q, cj), dense, with the chain solver's solutions of J x = b and the block solver's
  !> solutions of the same dense matrix, and the chain solver's wall time per factorisation and
  !> per solve.
  subroutine rc_probe_chain_solver(handle, t, cj, n, y, n_rhs, b, n_rep, jac, x_chain, x_block, ns_factor, &
                                   ns_solve, stat, msg)
    integer(c_int), intent(in) :: handle          !< model handle
    real(c_double), intent(in) :: t, cj           !< time [s], IDA's cj [1/s]
    integer(c_int), intent(in) :: n, n_rhs        !< GGL unknowns 2 nq + 2 nc, right-hand sides
    real(c_double), intent(in) :: y(n)            !< state (only q is used)
    real(c_double), intent(in) :: b(n, n_rhs)     !< right-hand sides
    integer(c_int), intent(in) :: n_rep           !< repetitions of each timed operation
    real(c_double), intent(out) :: jac(n, n)      !< the approximate iteration matrix
    real(c_double), intent(out) :: x_chain(n, n_rhs)  !< chain solutions
    real(c_double), intent(out) :: x_block(n, n_rhs)  !< block solutions of jac
    real(c_double), intent(out) :: ns_factor, ns_solve  !< chain: ns per factorisation, per solve
    integer(c_int), intent(out) :: stat           !< 0 = ok
    character(len=1024), intent(out) :: msg       !< why not
    type(model_type), pointer :: model
    type(error_type) :: error
    type(ggl_chain_solver), target :: chain
    type(ggl_block_solver) :: block
    integer(kind=8) :: k0, k1, rate
    integer :: nq, nc, i, k, info
    jac = 0.0_dp; x_chain = 0.0_dp; x_block = 0.0_dp; ns_factor = 0.0_dp; ns_solve = 0.0_dp
    model => model_of(handle, error)
    if (error%code == 0) then
      if (n /= 2*model%nq + 2*model%nc) call fatal_error(error, 'n must be 2 nq + 2 nc')
    end if
    if (error%code /= 0) then
      call to_status(error, stat, msg)
      return
    end if
    nq = model%nq; nc = model%nc
    call chain_solver_create(chain, model, c_null_ptr)
    call chain_iteration_matrix(chain, t, cj, y(1:nq), jac)
    call system_clock(k0, rate)
    do i = 1, max(n_rep, 1)
      call chain_factorise(chain, t, cj, y(1:nq), info)
    end do
    call system_clock(k1)
    ns_factor = 1.0e9_dp*real(k1 - k0, dp)/real(rate, dp)/max(n_rep, 1)
    if (info /= 0) call fatal_error(error, 'chain factorisation: singular')
    if (error%code == 0) then
      call system_clock(k0)
      do i = 1, max(n_rep, 1)
        do k = 1, n_rhs
          call chain_solve(chain, b(:, k), x_chain(:, k))
        end do
      end do
      call system_clock(k1)
      ns_solve = 1.0e9_dp*real(k1 - k0, dp)/real(rate, dp)/max(n_rep, 1)/max(n_rhs, 1)
      block%nq = nq; block%nc = nc; block%cj = cj
      allocate (block%k(nq, nq), block%k_pivots(nq), block%kq(nq, nq), block%b1_rows(nq + 2*nc, nq), &
                block%g_t(nq, nc), block%cq(nc, nq), block%c_rows(2*nc, nq), block%kinv_b(nq, 2*nc), &
                block%s(2*nc, 2*nc), block%s_pivots(2*nc))
      call block_factorise(block, jac, info)
      if (info /= 0) call fatal_error(error, 'block factorisation of the chain matrix: singular')
      do k = 1, n_rhs
        if (error%code == 0) call block_solve(block, b(:, k), x_block(:, k))
      end do
    end if
    call to_status(error, stat, msg)
  end subroutine rc_probe_chain_solver

  !> The GGL iteration matrix J = dF/dy + cj dF/dy' at (y, y') and the block (Schur-complement)
  !> solution of J x = b, with wall time per factorisation and per solve, block against
  !> LAPACK's dense LU (dgetrf/dgetrs) of the whole matrix.
  subroutine rc_probe_iteration_matrix(handle, t, cj, n, y, yd, analytic, n_rhs, b, n_rep, jac, x_block, &
                                       ns_block_factor, ns_block_solve, ns_dense_factor, ns_dense_solve, stat, msg)
    integer(c_int), intent(in) :: handle          !< model handle
    !> physics columns: 1 analytic (whole matrices), 2 analytic by tangent sweeps, 0 differences
    integer(c_int), intent(in) :: analytic
    real(c_double), intent(in) :: t, cj           !< time [s], IDA's cj = alpha/h [1/s]
    integer(c_int), intent(in) :: n, n_rhs        !< GGL unknowns 2 nq + 2 nc, right-hand sides
    real(c_double), intent(in) :: y(n), yd(n)     !< state of the matrix
    real(c_double), intent(in) :: b(n, n_rhs)     !< right-hand sides
    integer(c_int), intent(in) :: n_rep           !< repetitions of each timed operation
    real(c_double), intent(out) :: jac(n, n)      !< iteration matrix
    real(c_double), intent(out) :: x_block(n, n_rhs)  !< block solutions
    real(c_double), intent(out) :: ns_block_factor, ns_block_solve   !< block: ns per factorisation, per solve
    real(c_double), intent(out) :: ns_dense_factor, ns_dense_solve   !< dense LU: the same
    integer(c_int), intent(out) :: stat           !< 0 = ok
    character(len=1024), intent(out) :: msg       !< why not
    type(model_type), pointer :: model
    type(error_type) :: error
    type(ggl_block_solver) :: block
    real(dp), allocatable :: lu(:, :), x(:)
    integer, allocatable :: pivots(:)
    integer(kind=8) :: k0, k1, rate
    integer :: nq, nc, i, k, info
    jac = 0.0_dp; x_block = 0.0_dp
    ns_block_factor = 0.0_dp; ns_block_solve = 0.0_dp; ns_dense_factor = 0.0_dp; ns_dense_solve = 0.0_dp
    model => model_of(handle, error)
    if (error%code == 0) then
      if (n /= 2*model%nq + 2*model%nc) call fatal_error(error, 'n must be 2 nq + 2 nc')
    end if
    if (error%code /= 0) then
      call to_status(error, stat, msg)
      return
    end if
    nq = model%nq; nc = model%nc
    allocate (lu(n, n), x(n), pivots(n))
    call ggl_jacobian_dense(model, t, cj, y, yd, jac, analytic /= 0, sweeps=analytic == 2)
    block%nq = nq; block%nc = nc; block%cj = cj
    allocate (block%k(nq, nq), block%k_pivots(nq), block%kq(nq, nq), block%b1_rows(nq + 2*nc, nq), block%g_t(nq, nc), &
              block%cq(nc, nq), block%c_rows(2*nc, nq), block%kinv_b(nq, 2*nc), &
              block%s(2*nc, 2*nc), block%s_pivots(2*nc))
    call system_clock(k0, rate)
    do i = 1, max(n_rep, 1)
      call block_factorise(block, jac, info)
    end do
    call system_clock(k1)
    ns_block_factor = 1.0e9_dp*real(k1 - k0, dp)/real(rate, dp)/max(n_rep, 1)
    if (info /= 0) then
      stat = 3
      msg = 'block factorisation: singular K or S'
      return
    end if
    call system_clock(k0)
    do i = 1, max(n_rep, 1)
      do k = 1, n_rhs
        call block_solve(block, b(:, k), x_block(:, k))
      end do
    end do
    call system_clock(k1)
    ns_block_solve = 1.0e9_dp*real(k1 - k0, dp)/real(rate, dp)/max(n_rep, 1)/max(n_rhs, 1)
    call system_clock(k0)
    do i = 1, max(n_rep, 1)
      lu = jac
      call dgetrf(n, n, lu, n, pivots, info)
    end do
    call system_clock(k1)
    ns_dense_factor = 1.0e9_dp*real(k1 - k0, dp)/real(rate, dp)/max(n_rep, 1)
    call system_clock(k0)
    do i = 1, max(n_rep, 1)
      do k = 1, n_rhs
        x = b(:, k)
        call dgetrs('N', n, 1, lu, n, pivots, x, n, info)
      end do
    end do
    call system_clock(k1)
    ns_dense_solve = 1.0e9_dp*real(k1 - k0, dp)/real(rate, dp)/max(n_rep, 1)/max(n_rhs, 1)
    stat = 0; msg = ''
  end subroutine rc_probe_iteration_matrix

  !> Cost of the integrator's kernels at (y, y'), timed in a loop here (no Python call
  !> overhead): one GGL residual, one structured Jacobian, the equation of motion's derivatives
  !> and one mass matrix.  Every residual, Jacobian and derivatives call is at a new time t +
  !> 1e-12 i, so that none finds its base pass in the workspace: each pays for its own
  !> evaluation (as a peer's RNEA derivatives do).  The Jacobians and derivatives are timed
  !> after one untimed call (first touch of the arrays).
  subroutine rc_probe_time_kernels(handle, t, n, y, yd, n_rep, residual, ns_residual, ns_jacobian, ns_jacobian_fd, &
                                   ns_mass, ns_jacobian_sweeps, ns_derivatives, stat, msg)
    integer(c_int), intent(in) :: handle          !< model handle
    real(c_double), intent(in) :: t               !< time [s]
    integer(c_int), intent(in) :: n               !< GGL unknowns 2 nq + 2 nc
    real(c_double), intent(in) :: y(n), yd(n)     !< state
    integer(c_int), intent(in) :: n_rep           !< repetitions of the residual (Jacobian: n_rep/100 + 1)
    real(c_double), intent(out) :: residual(n)    !< residual at the state
    real(c_double), intent(out) :: ns_residual    !< wall time per residual [ns]
    real(c_double), intent(out) :: ns_jacobian    !< wall time per Jacobian, analytic physics columns [ns]
    real(c_double), intent(out) :: ns_jacobian_sweeps  !< the same by tangent sweeps [ns]
    real(c_double), intent(out) :: ns_jacobian_fd !< the same with finite-difference columns [ns]
    real(c_double), intent(out) :: ns_mass        !< wall time per mass matrix [ns]
    !> wall time per d(res)/dq, d(res)/dv and M as whole matrices (eom_derivatives) [ns]
    real(c_double), intent(out) :: ns_derivatives
    integer(c_int), intent(out) :: stat           !< 0 = ok
    character(len=1024), intent(out) :: msg       !< why not
    type(model_type), pointer :: model
    type(error_type) :: error
    real(dp), allocatable :: jac(:, :), m(:, :), dq(:, :), dv(:, :)
    integer(kind=8) :: k0, k1, rate
    integer :: i, n_jac, nq, nc
    real(dp) :: sink
    residual = 0.0_dp; ns_residual = 0.0_dp; ns_jacobian = 0.0_dp; ns_jacobian_fd = 0.0_dp; ns_mass = 0.0_dp
    ns_jacobian_sweeps = 0.0_dp; ns_derivatives = 0.0_dp
    model => model_of(handle, error)
    if (error%code /= 0) then
      call to_status(error, stat, msg)
      return
    end if
    allocate (jac(n, n), m(model%nq, model%nq))
    sink = 0.0_dp
    call system_clock(k0, rate)
    do i = 1, n_rep
      ! Vary t slightly so that the loop cannot be hoisted.
      call ggl_residual_dense(model, t + 1.0e-12_dp*i, y, yd, residual)
      sink = sink + residual(1)
    end do
    call system_clock(k1)
    ns_residual = 1.0e9_dp*real(k1 - k0, dp)/real(rate, dp)/n_rep
    n_jac = n_rep/100 + 1
    ns_jacobian = ns_per_jacobian(.true., .false.)
    ns_jacobian_sweeps = ns_per_jacobian(.true., .true.)
    ns_jacobian_fd = ns_per_jacobian(.false., .false.)
    nq = model%nq; nc = model%nc
    allocate (dq(nq, nq), dv(nq, nq))
    call eom_derivatives(model, t - 1.0e-12_dp, y(1:nq), y(nq + 1:2*nq), yd(nq + 1:2*nq), &
                         y(2*nq + 1:2*nq + nc), dq, dv, m)   ! untimed, as the Jacobian's first
    call system_clock(k0)
    do i = 1, n_jac
      call eom_derivatives(model, t + 1.0e-12_dp*i, y(1:nq), y(nq + 1:2*nq), yd(nq + 1:2*nq), &
                           y(2*nq + 1:2*nq + nc), dq, dv, m)
      sink = sink + dq(1, 1) + dv(1, 1) + m(1, 1)
    end do
    call system_clock(k1)
    ns_derivatives = 1.0e9_dp*real(k1 - k0, dp)/real(rate, dp)/n_jac
    call system_clock(k0)
    do i = 1, n_rep
      call mass_matrix(model, t, y(1:model%nq), m)
      sink = sink + m(1, 1)
    end do
    call system_clock(k1)
    ns_mass = 1.0e9_dp*real(k1 - k0, dp)/real(rate, dp)/n_rep
    call ggl_residual_dense(model, t, y, yd, residual)
    stat = 0; msg = ''
    if (sink /= sink) msg = 'NaN'   ! keeps sink alive

  contains

    !> Wall time of one iteration matrix [ns], physics columns analytic (whole or by sweeps) or
    !> by differences.
    real(dp) function ns_per_jacobian(analytic, sweeps)
      logical, intent(in) :: analytic, sweeps
      ! One call untimed: the first touches the matrix's pages and sizes the work arrays, as
      ! an integrator's first does once for the whole run.
      call ggl_jacobian_dense(model, t - 1.0e-12_dp, 1.0e3_dp, y, yd, jac, analytic, sweeps)
      call system_clock(k0)
      do i = 1, n_jac
        call ggl_jacobian_dense(model, t + 1.0e-12_dp*i, 1.0e3_dp, y, yd, jac, analytic, sweeps)
        sink = sink + jac(1, 1)
      end do
      call system_clock(k1)
      ns_per_jacobian = 1.0e9_dp*real(k1 - k0, dp)/real(rate, dp)/n_jac
    end function ns_per_jacobian
  end subroutine rc_probe_time_kernels

  !> One timed integration from a consistent start (q0, v0) at t0 to t_end, for the
  !> work-precision comparison: method 1 = IDA on the GGL index-2 DAE (the default route),
  !> 2 = GSL rk8pd and 3 = GSL msbdf on the Baumgarte-stabilised index-1 ODE (thesis route).
  !> Only the integration is timed; returns the CMs at ns equally spaced samples.  The integrator
  !> settings come as a parameter block sent flat (pydriver/components.py SOLVER).
  subroutine rc_probe_integrate(handle, method, real_names, nrn, real_sizes, nr, reals, int_names, nin, int_sizes, ni, &
                                ints, baumgarte_omega, &
                                t0, t_end, nq, q0, v0, ns, nb, cm_samples, q_end, v_end, stats, cpu_s, wall_s, stat, msg)
    integer(c_int), intent(in) :: handle          !< model handle
    integer(c_int), intent(in) :: method          !< 1 IDA-GGL, 2 GSL rk8pd, 3 GSL msbdf
    include 'flat_block_arguments.inc'
    real(c_double), intent(in) :: baumgarte_omega !< Baumgarte constant of the ODE route [1/s]
    real(c_double), intent(in) :: t0, t_end       !< start and end [s]
    integer(c_int), intent(in) :: nq              !< coordinates
    real(c_double), intent(in) :: q0(nq), v0(nq)  !< start state
    integer(c_int), intent(in) :: ns, nb          !< samples (>= 2), bodies
    real(c_double), intent(out) :: cm_samples(3, nb, ns)  !< CMs at the samples [m]
    real(c_double), intent(out) :: q_end(nq), v_end(nq)  !< state at t_end
    integer(c_int), intent(out) :: stats(5)       !< steps, rhs/residual evals, Jacobians, error-test fails, conv fails
    real(c_double), intent(out) :: cpu_s, wall_s  !< CPU and wall time of the integration [s]
    integer(c_int), intent(out) :: stat           !< 0 = ok
    character(len=1024), intent(out) :: msg       !< why not
    type(model_type), pointer :: model
    type(error_type) :: error
    type(integrator_settings) :: settings
    type(solver_stats) :: ss
    type(ode_settings) :: ode
    real(dp) :: t(max(ns, 2)), q_out(nq, max(ns, 2)), v_out(nq, max(ns, 2)), c0, c1
    integer(kind=8) :: k0, k1, rate
    integer :: k, m
    cm_samples = 0.0_dp; q_end = 0.0_dp; v_end = 0.0_dp; stats = 0; cpu_s = 0.0_dp; wall_s = 0.0_dp
    model => model_of(handle, error)
    if (error%code /= 0) then
      call to_status(error, stat, msg)
      return
    end if
    m = max(ns, 2)
    do k = 1, m
      t(k) = t0 + (t_end - t0)*real(k - 1, dp)/real(m - 1, dp)
    end do
    t(m) = t_end
    call settings_from_flat(real_names, real_sizes, reals, int_names, int_sizes, ints, settings, error)
    if (error%code /= 0) then
      call to_status(error, stat, msg)
      return
    end if
    call system_clock(k0, rate)
    call cpu_time(c0)
    select case (method)
    case (1)
      call integrate(model, settings, q0, v0, t, q_out, v_out, ss, error)
    case (2, 3)
      ode%method = merge(ODE_RK8PD, ODE_MSBDF, method == 2)
      ode%rtol = settings%rtol
      ode%atol = settings%atol
      ode%baumgarte_omega = baumgarte_omega
      ode%h_max = settings%h_max
      call integrate_ode(model, ode, q0, v0, t, q_out, v_out, ss, error)
    case default
      call fatal_error(error, 'unknown integration method')
    end select
    call cpu_time(c1)
    call system_clock(k1)
    cpu_s = c1 - c0
    wall_s = real(k1 - k0, dp)/real(rate, dp)
    stats = [ss%steps, ss%residual_evals, ss%jacobian_evals, ss%error_test_failures, ss%convergence_failures]
    if (error%code == 0) then
      do k = 1, min(ns, m)
        call positions_at(model, t(k), q_out(:, k))
        cm_samples(:, :, k) = model%st%cm
      end do
      q_end = q_out(:, m)
      v_end = v_out(:, m)
    end if
    call to_status(error, stat, msg)
  end subroutine rc_probe_integrate

  !> The ODE route's right-hand side y' and Jacobian d(y')/dy at (t, q, v) (GSL msbdf's), analytic
  !> and by forward differences of the right-hand side (ode_integrator's ode_jacobian_matrix).
  subroutine rc_probe_ode_jacobian(handle, t, nq, q, v, baumgarte_omega, n, ydot, jac_analytic, jac_differences, &
                                   stat, msg)
    integer(c_int), intent(in) :: handle          !< model handle
    real(c_double), intent(in) :: t               !< time [s]
    integer(c_int), intent(in) :: nq, n           !< coordinates, 2 nq
    real(c_double), intent(in) :: q(nq), v(nq)    !< state
    real(c_double), intent(in) :: baumgarte_omega !< Baumgarte constant [1/s]
    real(c_double), intent(out) :: ydot(n)        !< right-hand side y'
    real(c_double), intent(out) :: jac_analytic(n, n)     !< analytic
    real(c_double), intent(out) :: jac_differences(n, n)  !< forward differences
    integer(c_int), intent(out) :: stat           !< 0 = ok
    character(len=1024), intent(out) :: msg       !< why not
    type(model_type), pointer :: model
    type(error_type) :: error
    integer :: info_a, info_d, info_f
    ydot = 0.0_dp; jac_analytic = 0.0_dp; jac_differences = 0.0_dp
    model => model_of(handle, error)
    if (error%code == 0 .and. n /= 2*nq) call fatal_error(error, 'n must be 2 nq')
    if (error%code == 0) then
      call ode_jacobian_matrix(model, t, q, v, baumgarte_omega, .true., jac_analytic, info_a)
      call ode_jacobian_matrix(model, t, q, v, baumgarte_omega, .false., jac_differences, info_d)
      call ode_right_hand_side(model, t, q, v, baumgarte_omega, ydot, info_f)
      if (info_a /= 0 .or. info_d /= 0 .or. info_f /= 0) call fatal_error(error, 'singular acceleration system')
    end if
    call to_status(error, stat, msg)
  end subroutine rc_probe_ode_jacobian

  !> sigma_min/sigma_max of the constraint Jacobian at (q, t) (rank test of the supports).
  subroutine rc_probe_rank_margin(handle, t, nq, q, margin)
    integer(c_int), intent(in) :: handle          !< model handle
    real(c_double), intent(in) :: t               !< time [s]
    integer(c_int), intent(in) :: nq              !< coordinates
    real(c_double), intent(in) :: q(nq)           !< coordinates [rad]
    real(c_double), intent(out) :: margin         !< sigma_min/sigma_max (1 for a free end)
    type(model_type), pointer :: model
    margin = 0.0_dp
    model => lookup_model(handle)
    if (associated(model)) margin = constraint_rank_margin(model, t, q)
  end subroutine rc_probe_rank_margin

end module rotorcable_probes
