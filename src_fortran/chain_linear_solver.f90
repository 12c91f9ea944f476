!> An O(n) linear solver of an approximate GGL iteration matrix that fits a chain, handed to
!> IDA as a matrix-embedded SUNLinearSolver: IDA forms no matrix and calls no Jacobian.  The
!> solver reads cj, y and t from IDA itself (IDAGetCurrentCj/Y/Time) and decides itself when
!> to factorise again: SUNDIALS 6.4's IDA never calls the setup of a solver without a matrix
!> (idaLsInitialize sets lsetup = NULL when there is no matrix and no preconditioner setup;
!> checked here: with a preconditioner setup it still did not call it).  The policy: factorise
!> when cj has moved by more than CJ_WINDOW (5 %) since the factorisation, after a nonlinear
!> convergence failure, and at least every jacobian_max_age steps; IDA's own window for its
!> matrix-based solvers ([0.6, 1.67] cj_old) is too wide here (CJ_WINDOW).
!>
!> The iteration matrix of rotorcable_ggl_residual (unknowns (a, w, l, m) = corrections of
!> (q, v, lambda, mu)) is replaced by
!>   [ cj I      -I               0      G^T ] [a]   [b1]
!>   [ C         cj M + D        -G^T    0   ] [w] = [b2]
!>   [ G          0               0      0   ] [l]   [b3]
!>   [ 0          G               0      0   ] [m]   [b4]
!> where C and D are the constant diagonal joint stiffness and damping of the loads
!> (load_term%joint_diagonal: the joint springs and dampers, eq. 4.78-4.86).  Dropped are the
!> rest of dF_v/dq and dF_v/dv (geometric stiffness of gravity, of the centrifugal field and
!> of the clamp reaction G^T lambda; gyroscopic, Coriolis and drag damping), d(G^T mu)/dq
!> (O(|mu|), mu = 0 on the exact solution) and d(G v)/dq.  Why IDA's modified Newton still
!> converges: after dividing the v rows by cj^2, every dropped term is O((h w)^2) (stiffness
!> against cj^2 M, w the frequency of that stiffness: pendulum, centrifugal ~ Omega) or
!> O(h w) (damping against cj M, w = Omega or the drag rate; d(G v)/dq against cj G, w ~ |v|/L)
!> relative to what is kept, with h ~ 1/cj the step.  The error control keeps h w small for
!> every motion the solution resolves (h Omega << 1 on a rotor deck: the forcing is at
!> Omega), so the iteration contracts like a Newton iteration with a slightly old matrix.
!> What can be stiff - the joint springs and dampers, whose modes the steps do not resolve -
!> is kept exactly.  If the iteration fails anyway IDA cuts the step, which shrinks h w.
!> Where it does not hold: a large internal force T (the centrifugal tension of a turning
!> cable) gives a geometric stiffness of T/l per joint, whose "string" modes reach n times the
!> fundamental, so its w is not resolved by the step either; measured contraction factors
!> rho(J_chain^-1 (J - J_chain)) on the forward-flight decks: 0.8 (thesis chain) and 2.7 (the
!> cable deck) at cj = 1e3, 0.02 and 0.18 at 1e4, against 0.04 at 1e4 for the decay deck.
!> There the iteration needs the exact matrix (docs/jacobian.md).
!>
!> Elimination as in rotorcable_ggl_linear_solver with Kq = C, Cq = 0:
!>   K = cj M + D + C/cj = cj (M + A),  A = (D + C/cj)/cj: an articulated-body
!>   factorisation with armature A (rotorcable_articulated_body), O(n), no matrix formed;
!>   K^-1 B, B = [G^T, C G^T/cj], in one blocked pass of O(n nc); S = [G; G] K^-1 B - [0, G G^T; 0, 0]
!>   (2 nc x 2 nc, LAPACK LU).  Setup O(n nc), solve O(n nc).
module rotorcable_chain_linear_solver
  use, intrinsic :: iso_c_binding, only: c_int, c_double, c_ptr, c_long, c_null_ptr, c_funloc, c_loc, &
                                         c_f_pointer, c_associated
  use rotorcable_kinds, only: dp
  use rotorcable_linalg, only: dgetrf, dgemm, small_gemv, lu_solve
  use rotorcable_model, only: model_type, positions_at, joint_diagonal, mass_matrix
  use rotorcable_articulated_body, only: articulated_factors, articulated_factorise, articulated_solve
  use rotorcable_ida_binding, only: sun_linear_solver, sun_linear_solver_ops, SUNLinSolNewEmpty, &
                                    SUNLinSolFreeEmpty, N_VGetArrayPointer, SUNLINEARSOLVER_MATRIX_EMBEDDED, &
                                    SUNLS_SUCCESS, SUNLS_LUFACT_FAIL, IDAGetCurrentCj, IDAGetCurrentY, &
                                    IDAGetCurrentTime, IDAGetNumSteps, &
                                    IDAGetNumNonlinSolvConvFails
  implicit none
  private
  public :: ggl_chain_solver, chain_solver_create, chain_solver_destroy, chain_factorise, chain_solve, &
            chain_iteration_matrix

  integer(c_int), parameter :: SUNLINEARSOLVER_CUSTOM = 17  !< SUNLinearSolver_ID
  !> Factorise again when cj has moved by more than this fraction since the factorisation.  IDA
  !> scales the Newton correction by 2/(1 + cj/cj_old) only for matrix-based solvers
  !> (ida_ls.c: scalesol = matrixbased), and for this index-2 system that scaling does not fit
  !> anyway (tried: 1.5x the steps); without it a matrix at an older cj leaves the first Newton
  !> iterate off by O(1 - cj/cj_old), which IDA accepts and its error test then rejects.
  !> Measured steps / factorisations on the 200-body decay (0.05 s) and the 176-body flight
  !> (one revolution): IDA's own window [0.6, 1/0.6] 891 / 97 and 2107 / 369; 20 % 837 / 82
  !> and 1811 / 530; 5 % 666 / 98 and 1377 / 452; 1 % 683 / 103 and 1417 / 464.
  real(dp), parameter :: CJ_WINDOW = 0.05_dp

  !> The factors of one setup and what the solves need.
  type :: ggl_chain_solver
    integer :: nq = 0, nc = 0
    type(model_type), pointer :: model => null()
    type(c_ptr) :: mem = c_null_ptr           !< IDA memory (cj, y, t at setup)
    real(dp) :: cj = 1.0_dp                   !< cj of the factors [1/s]
    integer :: factorisations = 0             !< setups so far
    logical :: factorised = .false.           !< factors exist
    integer :: max_age = 50                   !< steps the factors are kept at most
    integer(c_long) :: factor_step = 0        !< IDA's step count at the factorisation
    integer(c_long) :: factor_fails = 0       !< IDA's convergence failures then
    real(dp), allocatable :: stiffness(:)     !< C, diagonal joint stiffness [Nm/rad]
    real(dp), allocatable :: damping(:)       !< D, diagonal joint damping [Nms/rad]
    type(articulated_factors) :: aba          !< factors of M + A
    real(dp), allocatable :: g(:, :)          !< G (nc x nq)
    real(dp), allocatable :: b_cols(:, :)     !< B/cj (nq x 2 nc), the Schur columns' right-hand sides
    real(dp), allocatable :: kinv_b(:, :)     !< K^-1 B (nq x 2 nc)
    real(dp), allocatable :: s(:, :)          !< LU factors of S (2 nc x 2 nc)
    integer, allocatable :: s_pivots(:)
    type(c_ptr) :: handle = c_null_ptr        !< the SUNLinearSolver wrapping this object
  end type ggl_chain_solver

contains

  !> Size the solver for the model; with ctx, also wrap it as a SUNLinearSolver (then the
  !> object must stay in place, target, until chain_solver_destroy).
  subroutine chain_solver_create(self, model, mem, ctx, max_age)
    type(ggl_chain_solver), intent(inout), target :: self  !< solver object
    type(model_type), intent(in), target :: model  !< model (outlives the solver)
    type(c_ptr), intent(in) :: mem            !< IDA memory (c_null_ptr for a probe)
    type(c_ptr), intent(in), optional :: ctx  !< SUNContext
    integer, intent(in), optional :: max_age  !< steps the factors are kept at most
    type(sun_linear_solver), pointer :: ls
    type(sun_linear_solver_ops), pointer :: ops
    self%model => model
    self%mem = mem
    self%nq = model%nq; self%nc = model%nc
    if (present(max_age)) self%max_age = max_age
    allocate (self%stiffness(self%nq), self%damping(self%nq), self%g(self%nc, self%nq), &
              self%kinv_b(self%nq, 2*self%nc), self%b_cols(self%nq, 2*self%nc), self%s(2*self%nc, 2*self%nc), &
              self%s_pivots(2*self%nc))
    if (.not. present(ctx)) return
    self%handle = SUNLinSolNewEmpty(ctx)
    if (.not. c_associated(self%handle)) return   ! out of memory: the caller reports the NULL handle
    call c_f_pointer(self%handle, ls)
    ls%content = c_loc(self)
    call c_f_pointer(ls%ops, ops)
    ops%gettype = c_funloc(chain_gettype)
    ops%getid = c_funloc(chain_getid)
    ops%setup = c_funloc(chain_setup)
    ops%solve = c_funloc(chain_solve_c)
  end subroutine chain_solver_create

  !> Release the SUNLinearSolver wrapper (the content is Fortran's).
  subroutine chain_solver_destroy(self)
    type(ggl_chain_solver), intent(inout) :: self  !< solver object
    if (c_associated(self%handle)) call SUNLinSolFreeEmpty(self%handle)
    self%handle = c_null_ptr
  end subroutine chain_solver_destroy

  !> Factorise the approximate iteration matrix at (t, q) and cj.  info > 0: singular.
  subroutine chain_factorise(self, t, cj, q, info)
    type(ggl_chain_solver), intent(inout) :: self  !< solver object
    real(dp), intent(in) :: t, cj             !< time [s], IDA's cj [1/s]
    real(dp), intent(in) :: q(:)              !< coordinates [rad]
    integer, intent(out) :: info              !< 0 = ok
    integer :: nq, nc, k
    nq = self%nq; nc = self%nc
    self%cj = cj
    self%factorised = .false.
    self%factorisations = self%factorisations + 1
    call positions_at(self%model, t, q)
    call joint_diagonal(self%model, self%stiffness, self%damping)
    call articulated_factorise(self%model%chain, self%model%st, (self%damping + self%stiffness/cj)/cj, self%aba, info)
    self%factorised = info == 0
    if (info /= 0 .or. nc == 0) return
    call self%model%support_b%jacobian(self%model%chain, self%model%st, self%g)
    ! K^-1 B, B = [G^T, C G^T/cj], all 2 nc columns in one pass: K^-1 = (M + A)^-1/cj.
    do k = 1, nc
      self%b_cols(:, k) = self%g(k, :)/cj
      self%b_cols(:, nc + k) = self%stiffness*self%g(k, :)/cj**2
    end do
    call articulated_solve(self%model%chain, self%aba, self%b_cols, self%kinv_b)
    call dgemm('N', 'N', nc, 2*nc, nq, 1.0_dp, self%g, nc, self%kinv_b, nq, 0.0_dp, self%s, 2*nc)
    self%s(nc + 1:2*nc, :) = self%s(1:nc, :)
    call dgemm('N', 'T', nc, nc, nq, -1.0_dp, self%g, nc, self%g, nc, 1.0_dp, self%s(1, nc + 1), 2*nc)
    call dgetrf(2*nc, 2*nc, self%s, 2*nc, self%s_pivots, info)
    self%factorised = info == 0
  end subroutine chain_factorise

  !> Solve the approximate iteration matrix: x = J^-1 b (x may not alias b), O(n nc).  The
  !> articulated-body factors in their stable form (rotorcable_articulated_body) give a backward
  !> error of the order of LU's (tests/test_chain_solver.py), so no iterative refinement.
  subroutine chain_solve(self, b, x)
    type(ggl_chain_solver), intent(in) :: self  !< factorised solver
    real(dp), intent(in) :: b(:)              !< right-hand side (b1, b2, b3, b4)
    real(dp), intent(out) :: x(:)             !< solution (a, w, l, m)
    real(dp) :: r2(self%nq, 1), w(self%nq, 1), gw(self%nc), z(2*self%nc), cj
    integer :: nq, nc, info
    nq = self%nq; nc = self%nc; cj = self%cj
    r2(:, 1) = (b(nq + 1:2*nq) - self%stiffness*b(1:nq)/cj)/cj               ! r2 / cj
    call articulated_solve(self%model%chain, self%aba, r2, w)                ! K^-1 r2
    x(1:nq) = b(1:nq)
    if (nc > 0) then
      call small_gemv('N', nc, nq, 1.0_dp, self%g, w, 0.0_dp, gw)
      z(nc + 1:2*nc) = b(2*nq + nc + 1:2*nq + 2*nc) - gw                     ! rc - C K^-1 r2
      call small_gemv('N', nc, nq, -1.0_dp, self%g, b, -1.0_dp, gw)
      z(1:nc) = cj*b(2*nq + 1:2*nq + nc) + gw
      call lu_solve(2*nc, self%s, self%s_pivots, z)
      call small_gemv('N', nq, 2*nc, 1.0_dp, self%kinv_b, z, 1.0_dp, w)      ! + K^-1 B z
      call small_gemv('T', nc, nq, -1.0_dp, self%g, z(nc + 1:), 1.0_dp, x)   ! b1 - G^T m
      x(2*nq + 1:2*nq + 2*nc) = z
    end if
    x(1:nq) = (x(1:nq) + w(:, 1))/cj
    x(nq + 1:2*nq) = w(:, 1)
  end subroutine chain_solve

  !> The approximate iteration matrix that chain_solve inverts, dense (n x n), for the tests:
  !> O(n^2) memory and O(n^2) work by the composite rigid bodies, never used in a run.
  subroutine chain_iteration_matrix(self, t, cj, q, jac)
    type(ggl_chain_solver), intent(inout) :: self  !< solver object
    real(dp), intent(in) :: t, cj             !< time [s], cj [1/s]
    real(dp), intent(in) :: q(:)              !< coordinates
    real(dp), intent(out) :: jac(:, :)        !< (n, n)
    real(dp) :: m(self%nq, self%nq)
    integer :: nq, nc, k
    nq = self%nq; nc = self%nc
    jac = 0.0_dp
    call mass_matrix(self%model, t, q, m)
    call joint_diagonal(self%model, self%stiffness, self%damping)
    jac(nq + 1:2*nq, nq + 1:2*nq) = cj*m
    do k = 1, nq
      jac(k, k) = cj
      jac(k, nq + k) = -1.0_dp
      jac(nq + k, k) = self%stiffness(k)
      jac(nq + k, nq + k) = jac(nq + k, nq + k) + self%damping(k)
    end do
    if (nc > 0) then
      call self%model%support_b%jacobian(self%model%chain, self%model%st, self%g)
      jac(1:nq, 2*nq + nc + 1:) = transpose(self%g)
      jac(nq + 1:2*nq, 2*nq + 1:2*nq + nc) = -transpose(self%g)
      jac(2*nq + 1:2*nq + nc, 1:nq) = self%g
      jac(2*nq + nc + 1:, nq + 1:2*nq) = self%g
    end if
  end subroutine chain_iteration_matrix

  integer(c_int) function chain_gettype(ls) bind(C)
    type(c_ptr), value :: ls
    chain_gettype = SUNLINEARSOLVER_MATRIX_EMBEDDED
  end function chain_gettype

  integer(c_int) function chain_getid(ls) bind(C)
    type(c_ptr), value :: ls
    chain_getid = SUNLINEARSOLVER_CUSTOM
  end function chain_getid

  !> SUNLinSolSetup (a = NULL): kept for a SUNDIALS that calls it; factorises at IDA's
  !> current iterate.
  integer(c_int) function chain_setup(ls, a) bind(C)
    type(c_ptr), value :: ls, a
    type(sun_linear_solver), pointer :: wrapper
    type(ggl_chain_solver), pointer :: self
    call c_f_pointer(ls, wrapper)
    call c_f_pointer(wrapper%content, self)
    chain_setup = SUNLS_SUCCESS
    if (.not. factorise_at_current(self)) chain_setup = SUNLS_LUFACT_FAIL
  end function chain_setup

  !> Factorise at IDA's current cj, iterate y and time; .false. if a factor is singular.
  logical function factorise_at_current(self) result(ok)
    type(ggl_chain_solver), intent(inout) :: self
    type(c_ptr) :: ycur
    real(c_double), pointer :: y(:)
    real(c_double) :: cj, t
    integer(c_int) :: flag
    integer :: info
    flag = IDAGetCurrentCj(self%mem, cj)
    flag = IDAGetCurrentTime(self%mem, t)
    flag = IDAGetCurrentY(self%mem, ycur)
    flag = IDAGetNumSteps(self%mem, self%factor_step)
    flag = IDAGetNumNonlinSolvConvFails(self%mem, self%factor_fails)
    call c_f_pointer(N_VGetArrayPointer(ycur), y, [2*self%nq + 2*self%nc])
    call chain_factorise(self, t, cj, y(1:self%nq), info)
    ok = info == 0
  end function factorise_at_current

  !> SUNLinSolSolve: x = J^-1 b, factorising first when the policy of the module header says
  !> so.  No scaling of the correction for a changed cj (CJ_WINDOW).  A singular factor is
  !> recoverable (IDA cuts the step).
  integer(c_int) function chain_solve_c(ls, a, x, b, tol) bind(C)
    type(c_ptr), value :: ls, a, x, b
    real(c_double), value :: tol
    type(sun_linear_solver), pointer :: wrapper
    type(ggl_chain_solver), pointer :: self
    real(c_double), pointer :: xv(:), bv(:)
    real(c_double) :: cj, ratio
    integer(c_long) :: steps, fails
    integer(c_int) :: flag
    integer :: n
    call c_f_pointer(ls, wrapper)
    call c_f_pointer(wrapper%content, self)
    chain_solve_c = SUNLS_SUCCESS
    flag = IDAGetCurrentCj(self%mem, cj)
    flag = IDAGetNumSteps(self%mem, steps)
    flag = IDAGetNumNonlinSolvConvFails(self%mem, fails)
    ratio = 0.0_dp
    if (self%factorised) ratio = cj/self%cj
    if (abs(ratio - 1.0_dp) > CJ_WINDOW .or. fails /= self%factor_fails .or. &
        steps - self%factor_step >= self%max_age .or. steps < self%factor_step) then
      if (.not. factorise_at_current(self)) then
        chain_solve_c = SUNLS_LUFACT_FAIL
        return
      end if
    end if
    n = 2*self%nq + 2*self%nc
    call c_f_pointer(N_VGetArrayPointer(x), xv, [n])
    call c_f_pointer(N_VGetArrayPointer(b), bv, [n])
    call chain_solve(self, bv, xv)
  end function chain_solve_c

end module rotorcable_chain_linear_solver
