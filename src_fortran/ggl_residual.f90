!> The stabilised index-2 DAE of rotorcable in the Gear-Gupta-Leimkuhler form (Gear, Gupta,
!> Leimkuhler 1985; Hairer & Wanner II, ch. VII.1; SUNDIALS example idaSlCrank_dns.c), with
!> unknowns y = (q, v, lambda, mu):
!>   0 = qdot - v + G^T mu                 (velocity projection, mu = 0 exactly)
!>   0 = M vdot - k - G^T lambda           (eq. 3.50, evaluated by inverse dynamics, O(n))
!>   0 = g(q, t)                           (eq. 3.51)
!>   0 = G(q, t) v + g_t                   (eq. 3.53, with the rheonomic term of a moving clamp)
!> Its residual and structured iteration matrix, and the IDA callbacks that use them.
module rotorcable_ggl_residual
  use, intrinsic :: iso_c_binding, only: c_int, c_long, c_double, c_ptr, c_null_ptr, c_f_pointer
  use rotorcable_kinds, only: dp
  use rotorcable_model, only: model_type, eom_residual, eom_residual_tangent, constraint_jacobian, mass_matrix, &
                              tangent_base_point
  use rotorcable_chain_tangent_columns, only: columns_allocate, positions_tangent_columns, &
                                              motion_tangent_columns, inverse_dynamics_tangent_columns, column_of, put, &
                                              COLUMN_BLOCK
  use rotorcable_ida_binding, only: N_VGetArrayPointer, SUNDenseMatrix_Data, IDAGetNumSteps, &
                                    IDAGetNumNonlinSolvConvFails
  use rotorcable_ggl_linear_solver, only: ggl_block_solver
  use rotorcable_model_derivatives, only: eom_derivatives, constraint_derivatives
  use rotorcable_linalg, only: dgemm
  implicit none
  private
  public :: ida_user_data, ggl_residual, ggl_residual_dense, ggl_residual_tangent, ggl_residual_tangent_columns, &
            ggl_residual_columns, ggl_residual_matrix_columns, ggl_jacobian, ggl_jacobian_dense, physics_jacobian

  !> ggl_residual_columns takes the whole matrices (one derivative pass, then BLAS products)
  !> instead of a tangent sweep per column when there are at least as many columns as
  !> coordinates, and at least MATRIX_COLUMNS_MIN, on at most MATRIX_COLUMNS_MAX_NQ coordinates.
  !> The pass costs about as much as 15-20 sweeps and the products O(nq^2) a column against a
  !> sweep's O(nq), so the matrices pay only for many columns on short chains.  Measured per
  !> call (benchmarks/residual_columns.py, its table in benchmarks/README.md), sweeps/matrices:
  !> nq = 20: 0.74-0.79 at 12 columns, 0.99-1.38 at 20, 1.40-1.50 at 40; nq = 42: 0.75 at 20,
  !> 1.03-1.09 at 40; nq = 86: 0.39-0.47 at 20, 0.49-0.62 at 40 (two runs on a shared 2-core
  !> machine).  Either route gives the same numbers to round-off.
  integer, parameter :: MATRIX_COLUMNS_MIN = 16
  integer, parameter :: MATRIX_COLUMNS_MAX_NQ = 64

  !> User data handed to IDA (c_loc), turned back with c_f_pointer in the callbacks.
  type :: ida_user_data
    type(model_type), pointer :: model => null()
    integer :: nq = 0
    integer :: nc = 0
    integer :: jac_residuals = 0              !< residual evaluations inside ggl_jacobian
    type(ggl_block_solver), pointer :: block => null()  !< told cj by ggl_jacobian
    type(c_ptr) :: mem = c_null_ptr           !< IDA memory (step and failure counters)
    real(dp), allocatable :: physics(:, :)    !< kept physics columns of the Jacobian
    real(dp), allocatable :: mass(:, :)       !< M at the state of the physics columns just formed
    logical :: physics_valid = .false.
    integer(c_long) :: physics_step = 0       !< IDA's step count when they were formed
    integer(c_long) :: physics_fails = 0      !< IDA's convergence failures then
    integer :: jacobian_max_age = 1           !< steps before they are formed again
    logical :: analytic = .true.              !< physics columns by tangent sweeps (else differences)
    character(len=512) :: ida_message = ''
    !> Data of a sensitivity residual beyond the model (rotorcable_parameter_sensitivity: the
    !> models rebuilt at p +- h); IDAS hands the sensitivity residual this same user data.
    type(c_ptr) :: extra = c_null_ptr
  end type ida_user_data

contains

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
  !> the inverse dynamics, g and G: the constraint rows read the frames and velocities that
  !> eom_residual has just filled in (the same call, not an order rule across routines; the
  !> residual runs ~10^4 times per run, and a check of the workspace record here cost 7 %).
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
    if (nc == 0) return
    ! G^T mu added to the q rows, g(q, t), and G v + g_t from the tip velocity and end rotation
    ! rate the recursion already has, so G itself is never formed here.
    call model%support_b%residual(model%chain, model%st, r(2*nq + 1:2*nq + nc))
    call model%support_b%velocity(model%chain, model%st, model%fs, r(2*nq + nc + 1:n))
    call model%support_b%add_jacobian_transpose_times(model%chain, model%st, y(2*nq + nc + 1:n), r(1:nq))
  end subroutine ggl_residual_dense

  !> Iteration matrix J = dF/dy + cj dF/dy' of the GGL residual, assembled from its
  !> structure instead of IDA's difference quotients over y and y' together:
  !>   [ cj I + d(G^T mu)/dq      -I             0      G^T ]   q rows
  !>   [ dF_v/dq          cj M + dF_v/dv       -G^T     0   ]   v rows (eq. 3.50)
  !>   [ G                        0              0      0   ]   g rows
  !>   [ d(G v)/dq                G              0      0   ]   G v rows
  !> M comes from the composite-rigid-body algorithm and G, G^T, -I exactly; the smooth
  !> physics columns dF/dq and dF/dv (stiffness, gyroscopic and damper terms), which never
  !> multiply cj, are tangent sweeps or central differences at fixed y' (physics_jacobian).
  !> IDA's DQ perturbs y and y' = cj*inc together, so at the tiny first steps of tight
  !> tolerances (cj ~ 1e20) its columns would be round-off: the corrector then fails at t = 0.
  !> Analytic columns come whole (physics_jacobian_whole), and M with them.
  subroutine ggl_jacobian_dense(model, t, cj, y, yd, jac, analytic, sweeps)
    type(model_type), intent(inout) :: model  !< model
    real(dp), intent(in) :: t, cj             !< time [s], IDA's cj = alpha/h [1/s]
    real(dp), intent(in) :: y(:), yd(:)       !< unknowns and their derivatives
    real(dp), intent(out) :: jac(:, :)        !< (n,n) iteration matrix
    logical, intent(in) :: analytic           !< analytic physics columns, else differences
    !> analytic columns by one tangent sweep each (physics_jacobian_sweeps: the check of the
    !> whole-matrix derivatives) instead of whole
    logical, intent(in), optional :: sweeps
    real(dp) :: m(model%nq, model%nq)
    if (analytic .and. .not. optional_true(sweeps)) then
      call physics_jacobian_whole(model, t, y, yd, jac, m)
      call add_exact_blocks(model, t, cj, y, jac, m)
    else
      call physics_jacobian(model, t, y, yd, jac, analytic, sweeps)
      call add_exact_blocks(model, t, cj, y, jac)
    end if
  end subroutine ggl_jacobian_dense

  !> An optional logical's value, .false. when absent.
  pure logical function optional_true(flag)
    logical, intent(in), optional :: flag
    optional_true = .false.
    if (present(flag)) optional_true = flag
  end function optional_true

  !> The smooth physics columns dF/dq and dF/dv of the GGL residual at fixed y'; they do not
  !> depend on cj and may be kept over several steps.  Analytic: the whole matrices in one pass
  !> over the bodies and O(1) work per entry (physics_jacobian_whole), exact to round-off; or,
  !> with `sweeps`, one tangent sweep (ggl_residual_tangent) per column, each starting at the
  !> body whose joint the column moves, O(n) a column: the independent check of the whole
  !> matrices (tests/test_analytic_derivatives.py).  Otherwise central differences, the check
  !> of both (tests/test_analytic_jacobian.py).
  subroutine physics_jacobian(model, t, y, yd, jac, analytic, sweeps, mass)
    type(model_type), intent(inout) :: model  !< model
    real(dp), intent(in) :: t                 !< time [s]
    real(dp), intent(in) :: y(:), yd(:)       !< unknowns and their derivatives
    real(dp), intent(out) :: jac(:, :)        !< (n,n); multiplier columns left zero
    logical, intent(in) :: analytic           !< analytic, else central differences
    logical, intent(in), optional :: sweeps   !< analytic by tangent sweeps instead of whole
    !> M at y, when the columns come whole (they give it with them); untouched otherwise
    real(dp), intent(inout), optional :: mass(:, :)
    if (analytic .and. optional_true(sweeps)) then
      call physics_jacobian_sweeps(model, t, y, yd, jac)
    else if (analytic) then
      call physics_jacobian_whole(model, t, y, yd, jac, mass)
    else
      call physics_jacobian_differences(model, t, y, yd, jac)
    end if
  end subroutine physics_jacobian

  !> The physics columns as whole matrices (rotorcable_model_derivatives): rows by rows,
  !>   q rows:   d(G^T mu)/dq        -I
  !>   v rows:   d(res)/dq           d(res)/dv        (eq. 3.50's residual, lambda fixed)
  !>   g rows:   G                   0
  !>   Gv rows:  d(G v + g_t)/dq     G
  !> and zero multiplier columns, each entry written once; M with them when asked.
  subroutine physics_jacobian_whole(model, t, y, yd, jac, mass)
    type(model_type), intent(inout) :: model  !< model
    real(dp), intent(in) :: t                 !< time [s]
    real(dp), intent(in) :: y(:), yd(:)       !< unknowns and their derivatives
    real(dp), intent(out) :: jac(:, :)        !< (n,n)
    real(dp), intent(inout), optional :: mass(:, :)  !< (nq,nq) M at y
    integer :: nq, nc, n, k
    nq = model%nq; nc = model%nc; n = 2*nq + 2*nc
    call eom_derivatives(model, t, y(1:nq), y(nq + 1:2*nq), yd(nq + 1:2*nq), y(2*nq + 1:2*nq + nc), &
                         jac(nq + 1:2*nq, 1:nq), jac(nq + 1:2*nq, nq + 1:2*nq), mass)
    jac(1:nq, nq + 1:2*nq) = 0.0_dp
    do k = 1, nq
      jac(k, nq + k) = -1.0_dp
    end do
    if (nc > 0) then
      call constraint_derivatives(model, y(2*nq + nc + 1:n), jac(1:nq, 1:nq), jac(2*nq + 1:2*nq + nc, 1:nq), &
                                  jac(2*nq + nc + 1:n, 1:nq), jac(2*nq + nc + 1:n, nq + 1:2*nq))
      jac(2*nq + 1:2*nq + nc, nq + 1:2*nq) = 0.0_dp
      jac(:, 2*nq + 1:n) = 0.0_dp
    else
      jac(1:nq, 1:nq) = 0.0_dp
    end if
  end subroutine physics_jacobian_whole

  !> The physics columns by tangent sweeps: column k moves coordinate k (or its rate) alone.
  subroutine physics_jacobian_sweeps(model, t, y, yd, jac)
    type(model_type), intent(inout) :: model
    real(dp), intent(in) :: t
    real(dp), intent(in) :: y(:), yd(:)
    real(dp), intent(out) :: jac(:, :)
    real(dp) :: r0(size(y)), dy(size(y)), dyd(size(y))
    integer :: nq, j, k
    nq = model%nq
    jac = 0.0_dp
    dy = 0.0_dp
    dyd = 0.0_dp
    call ggl_residual_dense(model, t, y, yd, r0)
    ! Every column at the base point just evaluated: the workspace holds it (held).
    do j = 1, model%chain%n_bodies
      do k = model%chain%first_coord(j), model%chain%first_coord(j) + model%chain%n_joint_coords(j) - 1
        dy(k) = 1.0_dp
        call ggl_residual_tangent(model, t, y, yd, dy, dyd, j, jac(:, k), held=.true.)
        dy(k) = 0.0_dp
        dy(nq + k) = 1.0_dp
        call ggl_residual_tangent(model, t, y, yd, dy, dyd, j, jac(:, nq + k), held=.true.)
        dy(nq + k) = 0.0_dp
      end do
    end do
  end subroutine physics_jacobian_sweeps

  !> First-order change dr of the GGL residual for the change (dy, dyd) of (y, y'), O(n), about
  !> (t, y, y') (eom_residual_tangent evaluates the base pass unless the workspace holds it, so a
  !> Jacobian's columns share one).  dy and dyd must vanish on the joints before body `first`
  !> (1: any direction).
  !> With dyd = cj dy this is the iteration matrix times dy.
  subroutine ggl_residual_tangent(model, t, y, yd, dy, dyd, first, dr, held)
    type(model_type), intent(inout) :: model  !< model
    real(dp), intent(in) :: t                 !< time [s]
    real(dp), intent(in) :: y(:), yd(:)       !< unknowns and their derivatives
    real(dp), intent(in) :: dy(:), dyd(:)     !< their change
    integer, intent(in) :: first              !< first body with a change
    real(dp), intent(out) :: dr(:)            !< change of the residual
    !> the caller has just evaluated the base point (t, y, y') on this model (an earlier column
    !> of the same point): the workspace's record is not compared again (eom_residual_tangent)
    logical, intent(in), optional :: held
    integer :: nq, nc, n
    nq = model%nq; nc = model%nc; n = 2*nq + 2*nc
    dr(1:nq) = dyd(1:nq) - dy(nq + 1:2*nq)
    call eom_residual_tangent(model, t, y(1:nq), y(nq + 1:2*nq), yd(nq + 1:2*nq), y(2*nq + 1:2*nq + nc), dy(1:nq), &
                              dy(nq + 1:2*nq), dyd(nq + 1:2*nq), dy(2*nq + 1:2*nq + nc), first, dr(nq + 1:2*nq), held)
    if (nc == 0) return
    call model%support_b%residual_tangent(model%chain, model%st, model%dst, dr(2*nq + 1:2*nq + nc))
    call model%support_b%velocity_tangent(model%chain, model%st, model%dst, model%fs, dr(2*nq + nc + 1:n))
    call model%support_b%add_jacobian_transpose_tangent(model%chain, model%st, model%dst, y(2*nq + nc + 1:n), &
                                                  dy(2*nq + nc + 1:n), dr(1:nq))
  end subroutine ggl_residual_tangent

  !> ggl_residual_tangent for m columns (dy(:, c), dyd(:, c)) at once, each from body 1 on:
  !> dr(:, c) the same bits as ggl_residual_tangent(..., dy(:, c), dyd(:, c), 1, dr(:, c)).
  !> The chain's kinematics and Newton-Euler tangents run over blocks of COLUMN_BLOCK columns
  !> (rotorcable_chain_tangent_columns: each body's state read once a block, the columns'
  !> arithmetic vectorised); the loads' and the support's tangents, a few flops a body, column
  !> by column on model%dst.  A block of one or two columns goes column by column instead.
  subroutine ggl_residual_tangent_columns(model, t, y, yd, dy, dyd, dr, held)
    type(model_type), intent(inout) :: model  !< model
    real(dp), intent(in) :: t                 !< time [s]
    real(dp), intent(in) :: y(:), yd(:)       !< unknowns and their derivatives
    real(dp), intent(in) :: dy(:, :), dyd(:, :)  !< (n, m) their changes
    real(dp), intent(out) :: dr(:, :)         !< (n, m) changes of the residual
    !> the caller has just evaluated the base point on this model (ggl_residual_tangent's held)
    logical, intent(in), optional :: held
    real(dp) :: f_b(3), m_b(3), df_b(3), dm_b(3)
    integer :: nq, nc, n, m, c, b, i, k, width
    nq = model%nq; nc = model%nc; n = 2*nq + 2*nc; m = size(dy, 2)
    call tangent_base_point(model, t, y(1:nq), y(nq + 1:2*nq), yd(nq + 1:2*nq), y(2*nq + 1:2*nq + nc), held)
    call columns_allocate(model%chain, model%dst_columns)
    f_b = 0.0_dp
    if (nc > 0) call model%support_b%wrench(model%chain, model%st, y(2*nq + 1:2*nq + nc), f_b, m_b)
    associate (tc => model%dst_columns)
      do b = 1, m, COLUMN_BLOCK
        width = min(COLUMN_BLOCK, m - b + 1)
        if (width <= 2) then
          ! One or two columns left: a block would spend half or more of its lanes on padding,
          ! so the single-column sweep is cheaper (the same bits either way).
          do k = b, m
            call ggl_residual_tangent(model, t, y, yd, dy(:, k), dyd(:, k), 1, dr(:, k), held=.true.)
          end do
          exit
        end if
        ! The block's directions, column first (zero columns pad the last block).
        if (width < COLUMN_BLOCK) then
          tc%dq = 0.0_dp; tc%dv = 0.0_dp; tc%dvdot = 0.0_dp
        end if
        do c = 1, width
          call put(dy(1:nq, b + c - 1), c, nq, tc%dq)
          call put(dy(nq + 1:2*nq, b + c - 1), c, nq, tc%dv)
          call put(dyd(nq + 1:2*nq, b + c - 1), c, nq, tc%dvdot)
        end do
        call positions_tangent_columns(model%chain, model%st, tc)
        call motion_tangent_columns(model%chain, model%seed, model%st, y(nq + 1:2*nq), yd(nq + 1:2*nq), tc)
        if (width < COLUMN_BLOCK) then            ! the padding: no loads' changes
          tc%dforce = 0.0_dp; tc%dmoment = 0.0_dp; tc%dtau = 0.0_dp
          tc%dtip_force = 0.0_dp; tc%dtip_moment = 0.0_dp
        end if
        do c = 1, width
          k = b + c - 1
          ! The loads' and the support's tangents of column k (as eom_residual_tangent and
          ! ggl_residual_tangent take them).
          call column_of(tc, c, model%dst)
          model%dforce = 0.0_dp
          model%dmoment = 0.0_dp
          model%dtau = 0.0_dp
          do i = 1, size(model%loads)
            call model%loads(i)%term%add_force_tangent(model%chain, model%st, model%dst, model%fs, t, y(1:nq), &
                                                       y(nq + 1:2*nq), dy(1:nq, k), dy(nq + 1:2*nq, k), &
                                                       model%dforce, model%dmoment, model%dtau)
          end do
          call put(model%dforce, c, size(model%dforce), tc%dforce)
          call put(model%dmoment, c, size(model%dmoment), tc%dmoment)
          call put(model%dtau, c, nq, tc%dtau)
          df_b = 0.0_dp; dm_b = 0.0_dp
          dr(1:nq, k) = dyd(1:nq, k) - dy(nq + 1:2*nq, k)
          if (nc > 0) then
            call model%support_b%wrench_tangent(model%chain, model%st, model%dst, y(2*nq + 1:2*nq + nc), &
                                                dy(2*nq + 1:2*nq + nc, k), df_b, dm_b)
            call model%support_b%residual_tangent(model%chain, model%st, model%dst, dr(2*nq + 1:2*nq + nc, k))
            call model%support_b%velocity_tangent(model%chain, model%st, model%dst, model%fs, dr(2*nq + nc + 1:n, k))
            call model%support_b%add_jacobian_transpose_tangent(model%chain, model%st, model%dst, y(2*nq + nc + 1:n), &
                                                                dy(2*nq + nc + 1:n, k), dr(1:nq, k))
          end if
          tc%dtip_force(c, :) = df_b
          tc%dtip_moment(c, :) = dm_b
        end do
        if (model%fs%rotating .and. .not. model%fs%body_couples) then
          call inverse_dynamics_tangent_columns(model%chain, model%st, model%lin_inertia, model%force, f_b, tc, &
                                                model%fs%omega, model%fs%omega_dot)
        else
          call inverse_dynamics_tangent_columns(model%chain, model%st, model%lin_inertia, model%force, f_b, tc)
        end if
        do c = 1, width
          dr(nq + 1:2*nq, b + c - 1) = tc%dres(c, :) - tc%dtau(c, :)
        end do
      end do
    end associate
  end subroutine ggl_residual_tangent_columns

  !> The changes F_y dy + F_y' dyd of the GGL residual for m directions, by the route that is
  !> cheaper for m columns on this chain (MATRIX_COLUMNS_MIN): the whole derivative matrices
  !> (ggl_residual_matrix_columns) or the tangent sweeps (ggl_residual_tangent_columns).  The
  !> two agree to round-off (tests/test_residual_columns.py, 1e-12 relative).  The sensitivity
  !> residuals (monodromy, parameter sensitivities) take their columns here.
  subroutine ggl_residual_columns(model, t, y, yd, dy, dyd, dr, held)
    type(model_type), intent(inout) :: model  !< model
    real(dp), intent(in) :: t                 !< time [s]
    real(dp), intent(in) :: y(:), yd(:)       !< unknowns and their derivatives
    real(dp), intent(in) :: dy(:, :), dyd(:, :)  !< (n, m) their changes
    real(dp), intent(out) :: dr(:, :)         !< (n, m) changes of the residual
    logical, intent(in), optional :: held     !< the caller has just evaluated the base point
    if (size(dy, 2) >= max(MATRIX_COLUMNS_MIN, model%nq) .and. model%nq <= MATRIX_COLUMNS_MAX_NQ) then
      call ggl_residual_matrix_columns(model, t, y, yd, dy, dyd, dr, held)
    else
      call ggl_residual_tangent_columns(model, t, y, yd, dy, dyd, dr, held)
    end if
  end subroutine ggl_residual_columns

  !> ggl_residual_tangent_columns by the whole matrices of the Jacobian's structure
  !> (ggl_jacobian_dense's comment), rows by rows:
  !>   q rows:   dq' - dv + d(G^T mu)/dq dq + G^T dmu
  !>   v rows:   d(res)/dq dq + d(res)/dv dv + M dv' - G^T dlambda     (eq. 3.50's residual)
  !>   g rows:   G dq
  !>   Gv rows:  d(G v + g_t)/dq dq + G dv
  !> The matrices come from one derivative pass (eom_derivatives, constraint_derivatives:
  !> Carpentier & Mansard 2018's structure), the products from BLAS dgemm on copies of the
  !> directions' row blocks (contiguous operands, no array temporaries).
  subroutine ggl_residual_matrix_columns(model, t, y, yd, dy, dyd, dr, held)
    type(model_type), intent(inout) :: model  !< model
    real(dp), intent(in) :: t                 !< time [s]
    real(dp), intent(in) :: y(:), yd(:)       !< unknowns and their derivatives
    real(dp), intent(in) :: dy(:, :), dyd(:, :)  !< (n, m) their changes
    real(dp), intent(out) :: dr(:, :)         !< (n, m) changes of the residual
    logical, intent(in), optional :: held     !< the caller has just evaluated the base point
    ! Each row block is one product of the blocks side by side with the directions stacked (one
    ! dgemm with a longer inner dimension runs faster than three short ones):
    !   v rows  [d(res)/dq  d(res)/dv  M  -G^T] [dq; dv; dv'; dlambda]
    !   q rows  [d(G^T mu)/dq  G^T] [dq; dmu]
    !   g, Gv   [G  0; d(G v + g_t)/dq  G] [dq; dv]
    real(dp), allocatable :: v_rows(:, :), q_rows(:, :), c_rows(:, :), operand(:, :), prod(:, :)
    real(dp), allocatable :: g(:, :), gv_v(:, :)
    integer :: nq, nc, n, m
    nq = model%nq; nc = model%nc; n = 2*nq + 2*nc; m = size(dy, 2)
    allocate (v_rows(nq, 3*nq + nc), operand(3*nq + nc, m), prod(nq, m))
    call eom_derivatives(model, t, y(1:nq), y(nq + 1:2*nq), yd(nq + 1:2*nq), y(2*nq + 1:2*nq + nc), &
                         v_rows(:, 1:nq), v_rows(:, nq + 1:2*nq), v_rows(:, 2*nq + 1:3*nq), held)
    operand(1:2*nq, :) = dy(1:2*nq, :)
    operand(2*nq + 1:3*nq, :) = dyd(nq + 1:2*nq, :)
    if (nc > 0) then
      allocate (q_rows(nq, nq + nc), c_rows(2*nc, 2*nq), g(nc, nq), gv_v(nc, nq))
      call constraint_derivatives(model, y(2*nq + nc + 1:n), q_rows(:, 1:nq), g, c_rows(nc + 1:2*nc, 1:nq), gv_v)
      v_rows(:, 3*nq + 1:3*nq + nc) = -transpose(g)
      operand(3*nq + 1:3*nq + nc, :) = dy(2*nq + 1:2*nq + nc, :)     ! dlambda
    end if
    call dgemm('N', 'N', nq, m, 3*nq + nc, 1.0_dp, v_rows, nq, operand, 3*nq + nc, 0.0_dp, prod, nq)
    dr(nq + 1:2*nq, :) = prod
    if (nc == 0) then
      dr(1:nq, :) = dyd(1:nq, :) - dy(nq + 1:2*nq, :)
      return
    end if
    q_rows(:, nq + 1:nq + nc) = transpose(g)
    operand(nq + 1:nq + nc, :) = dy(2*nq + nc + 1:n, :)             ! dmu after dq
    call dgemm('N', 'N', nq, m, nq + nc, 1.0_dp, q_rows, nq, operand, 3*nq + nc, 0.0_dp, prod, nq)
    dr(1:nq, :) = dyd(1:nq, :) - dy(nq + 1:2*nq, :) + prod
    c_rows(1:nc, 1:nq) = g
    c_rows(1:nc, nq + 1:2*nq) = 0.0_dp
    c_rows(nc + 1:2*nc, nq + 1:2*nq) = gv_v
    operand(nq + 1:2*nq, :) = dy(nq + 1:2*nq, :)                    ! dv after dq again
    deallocate (prod)
    allocate (prod(2*nc, m))
    call dgemm('N', 'N', 2*nc, m, 2*nq, 1.0_dp, c_rows, 2*nc, operand, 3*nq + nc, 0.0_dp, prod, 2*nc)
    dr(2*nq + 1:n, :) = prod
  end subroutine ggl_residual_matrix_columns

  !> The physics columns by central differences of the residual at fixed y' (the check of the
  !> analytic columns, so accuracy before cost: truncation ~h^2, round-off ~eps/h, balanced at
  !> h = eps^(1/3) per unit of |y|; about 1e-10 relative against 1e-8 for forward differences).
  subroutine physics_jacobian_differences(model, t, y, yd, jac)
    type(model_type), intent(inout) :: model
    real(dp), intent(in) :: t
    real(dp), intent(in) :: y(:), yd(:)
    real(dp), intent(out) :: jac(:, :)
    real(dp) :: r_plus(size(y)), r_minus(size(y)), yy(size(y)), inc
    integer :: nq, j
    nq = model%nq
    jac = 0.0_dp
    yy = y
    do j = 1, 2*nq
      ! Coordinates are angles and rates of order one: a relative step with a floor.
      inc = epsilon(1.0_dp)**(1.0_dp/3.0_dp)*max(abs(y(j)), 1.0_dp)
      yy(j) = y(j) + inc
      call ggl_residual_dense(model, t, yy, yd, r_plus)
      yy(j) = y(j) - inc
      call ggl_residual_dense(model, t, yy, yd, r_minus)
      yy(j) = y(j)
      jac(:, j) = (r_plus - r_minus)/(2.0_dp*inc)
    end do
  end subroutine physics_jacobian_differences

  !> Add the exact blocks to a physics Jacobian: the y' terms (cj I, cj M by the composite
  !> rigid bodies at q), the multiplier columns -G^T, G^T and g's rows G.
  subroutine add_exact_blocks(model, t, cj, y, jac, mass)
    type(model_type), intent(inout) :: model  !< model
    real(dp), intent(in) :: t                 !< time [s]
    real(dp), intent(in) :: cj                !< IDA's cj = alpha/h [1/s]
    real(dp), intent(in) :: y(:)              !< unknowns
    real(dp), intent(inout) :: jac(:, :)      !< (n,n) iteration matrix
    !> M at y, when the caller has it (the whole-matrix derivatives give it); else by the
    !> composite rigid bodies here
    real(dp), intent(in), optional :: mass(:, :)
    real(dp) :: g_jac(model%nc, model%nq), m(model%nq, model%nq)
    integer :: nq, nc, j
    nq = model%nq; nc = model%nc
    do j = 1, nq
      jac(j, j) = jac(j, j) + cj
    end do
    if (present(mass)) then
      jac(nq + 1:2*nq, nq + 1:2*nq) = jac(nq + 1:2*nq, nq + 1:2*nq) + cj*mass
    else
      call mass_matrix(model, t, y(1:nq), m)
      jac(nq + 1:2*nq, nq + 1:2*nq) = jac(nq + 1:2*nq, nq + 1:2*nq) + cj*m
    end if
    if (nc > 0) then
      ! G from the support at y, even where the whole-matrix columns hold one in the g rows:
      ! ggl_jacobian keeps those columns over several steps, and a kept G in the iteration
      ! matrix (tried) let the six-link chain's 100 s run end at a constraint violation of
      ! 1.03e-9 m instead of 1.2e-10 m, above tests/test_hard_cases.py's 1e-9 m.
      call constraint_jacobian(model, t, y(1:nq), g_jac)
      jac(nq + 1:2*nq, 2*nq + 1:2*nq + nc) = -transpose(g_jac)
      jac(1:nq, 2*nq + nc + 1:) = transpose(g_jac)
      jac(2*nq + 1:2*nq + nc, 1:nq) = g_jac
    end if
  end subroutine add_exact_blocks

  !> IDALsJacFn: fills SUNDIALS's dense matrix (column-major, n x n).  The physics columns
  !> (tangent sweeps or differences, physics_jacobian) are kept from one call to the next unless IDA had
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
    logical :: fresh
    call c_f_pointer(udata, ud)
    n = 2*ud%nq + 2*ud%nc
    call c_f_pointer(N_VGetArrayPointer(yy), y, [n])
    call c_f_pointer(N_VGetArrayPointer(yp), yd, [n])
    call c_f_pointer(SUNDenseMatrix_Data(jmat), a, [n, n])
    flag = IDAGetNumSteps(ud%mem, steps)
    flag = IDAGetNumNonlinSolvConvFails(ud%mem, fails)
    fresh = .false.
    if (.not. ud%physics_valid .or. fails /= ud%physics_fails .or. steps < ud%physics_step .or. &
        steps - ud%physics_step >= ud%jacobian_max_age) then
      if (.not. allocated(ud%mass)) allocate (ud%mass(ud%nq, ud%nq))
      call physics_jacobian(ud%model, t, y, yd, ud%physics, ud%analytic, mass=ud%mass)
      fresh = ud%analytic                     ! whole analytic columns bring M at this y
      ud%jac_residuals = ud%jac_residuals + 1
      if (.not. ud%analytic) ud%jac_residuals = ud%jac_residuals + 4*ud%nq - 1
      ud%physics_valid = .true.
      ud%physics_step = steps
      ud%physics_fails = fails
    end if
    a = ud%physics
    if (fresh) then
      call add_exact_blocks(ud%model, t, cj, y, a, ud%mass)
    else
      call add_exact_blocks(ud%model, t, cj, y, a)
    end if
    if (associated(ud%block)) ud%block%cj = cj
    ggl_jacobian = 0
  end function ggl_jacobian

end module rotorcable_ggl_residual
