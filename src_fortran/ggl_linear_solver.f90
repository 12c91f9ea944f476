!> Block factorisation of the GGL iteration matrix, handed to IDA as a user-supplied
!> SUNLinearSolver (type DIRECT: IDA still fills the dense matrix through ggl_jacobian and
!> calls setup after every Jacobian, solve at every Newton iteration).
!>
!> The iteration matrix of rotorcable_dae_integrator, unknowns (a, w, l, m) = corrections of
!> (q, v, lambda, mu):
!>   [ cj I      -I      0     G^T ] [a]   [b1]   q rows
!>   [ Kq        A22    -G^T   0   ] [w] = [b2]   v rows: A22 = cj M + dF_v/dv, Kq = dF_v/dq
!>   [ G          0      0     0   ] [l]   [b3]   g rows
!>   [ Cq         G      0     0   ] [m]   [b4]   G v rows: Cq = d(G v)/dq
!> The block d(G^T mu)/dq of the q rows is O(|mu|), and mu = 0 on the exact GGL solution
!> (Hairer & Wanner II, VII.1), so it is left out: IDA's modified Newton iteration only needs
!> an approximate iteration matrix (it already keeps one over several steps).
!> Eliminating a = (b1 + w - G^T m)/cj leaves (nq + 2 nc unknowns)
!>   K w - G^T l - P m = r2        K = A22 + Kq/cj,  P = Kq G^T/cj,  r2 = b2 - Kq b1/cj
!>   C w + D z         = rc        C = [G; G + Cq/cj],  D = [0, -G G^T; 0, -Cq G^T/cj],
!>                                 rc = [cj b3 - G b1; b4 - Cq b1/cj],  z = (l, m)
!> and with w = K^-1 (r2 + B z), B = [G^T, P], the Schur complement on the constraints
!>   S z = rc - C K^-1 r2,         S = C K^-1 B + D        (2 nc x 2 nc).
!> Setup is one LU of K (nq x nq) and one of S, about 2/3 nq^3 flops against
!> 2/3 (2 nq + 2 nc)^3 for the dense LU of the whole matrix, i.e. 8 to 13 times fewer; a
!> solve is two triangular pairs of order nq and some products of order nq nc.
!> K is not symmetric (damping, gyroscopic and geometric-stiffness terms), hence LU (LAPACK
!> dgetrf/dgetrs) rather than Cholesky.  Hand-written only in the block elimination above,
!> which no library offers for this matrix; every factorisation is LAPACK's.
!>
!> Very short steps: the elimination divides by cj and multiplies the g rows by cj, and the v
!> and lambda parts of its solution lose digits as cj grows (UH-60 decay, random right-hand
!> sides, largest error of each block against LAPACK's LU of the whole matrix: 3e-9 at
!> cj = 1e6/s, 2e-7 at 1e8, 4e-4 at 1e12, 15 % at 1e14).  Such steps occur only right after a
!> start or a switch time at a tight atol (IDA's first step there is ~0.5/||y'||_WRMS, 5e-15 s at
!> atol 1e-12), where IDA's Newton iteration then failed down to hmin.  Above CJ_DENSE the
!> solver therefore factorises the whole matrix (dgetrf) instead: a handful of factorisations
!> per start, each of the cost of a few steps.
module rotorcable_ggl_linear_solver
  use, intrinsic :: iso_c_binding, only: c_int, c_double, c_ptr, c_null_ptr, c_funloc, c_loc, &
                                         c_f_pointer, c_associated
  use rotorcable_kinds, only: dp
  use rotorcable_linalg, only: dgetrf, dgetrs, dgemm, small_gemv, lu_solve
  use rotorcable_ida_binding, only: sun_linear_solver, sun_linear_solver_ops, SUNLinSolNewEmpty, &
                                    SUNLinSolFreeEmpty, SUNDenseMatrix_Data, N_VGetArrayPointer, &
                                    SUNLINEARSOLVER_DIRECT, SUNLS_SUCCESS, SUNLS_LUFACT_FAIL
  implicit none
  private
  public :: ggl_block_solver, block_solver_create, block_solver_destroy, block_factorise, block_solve, &
            block_solve_columns

  integer(c_int), parameter :: SUNLINEARSOLVER_CUSTOM = 17  !< SUNLinearSolver_ID
  !> cj [1/s] above which the whole matrix is factorised (module header: steps below ~1 us).
  real(dp), parameter :: CJ_DENSE = 1.0e6_dp

  !> Factors and blocks kept from one setup to the solves that follow.
  type :: ggl_block_solver
    integer :: nq = 0, nc = 0
    real(dp) :: cj = 1.0_dp                   !< IDA's cj of the current matrix (set by the Jacobian)
    real(dp), allocatable :: k(:, :)          !< LU factors of K = A22 + Kq/cj
    integer, allocatable :: k_pivots(:)
    real(dp), allocatable :: kq(:, :)         !< dF_v/dq
    real(dp), allocatable :: b1_rows(:, :)    !< [Kq/cj; G; Cq/cj]: everything that multiplies b1
    real(dp), allocatable :: g_t(:, :)        !< G^T (nq x nc)
    real(dp), allocatable :: cq(:, :)         !< d(G v)/dq (nc x nq)
    real(dp), allocatable :: c_rows(:, :)     !< C = [G; G + Cq/cj] (2 nc x nq)
    real(dp), allocatable :: kinv_b(:, :)     !< K^-1 B (nq x 2 nc)
    real(dp), allocatable :: s(:, :)          !< LU factors of S (2 nc x 2 nc)
    integer, allocatable :: s_pivots(:)
    logical :: whole = .false.                !< the current factors are those of the whole matrix
    real(dp), allocatable :: lu(:, :)         !< LU factors of the whole matrix (cj > CJ_DENSE)
    integer, allocatable :: lu_pivots(:)
    type(c_ptr) :: handle = c_null_ptr        !< the SUNLinearSolver wrapping this object
  end type ggl_block_solver

contains

  !> Allocate the blocks and wrap the object as a SUNLinearSolver for IDASetLinearSolver.
  !> The object must stay in place (target) until block_solver_destroy.
  subroutine block_solver_create(self, nq, nc, ctx)
    type(ggl_block_solver), intent(inout), target :: self  !< solver object
    integer, intent(in) :: nq, nc             !< coordinates, constraint rows
    type(c_ptr), intent(in) :: ctx            !< SUNContext
    type(sun_linear_solver), pointer :: ls
    type(sun_linear_solver_ops), pointer :: ops
    self%nq = nq; self%nc = nc
    allocate (self%k(nq, nq), self%k_pivots(nq), self%kq(nq, nq), self%b1_rows(nq + 2*nc, nq), self%g_t(nq, nc), &
              self%cq(nc, nq), self%c_rows(2*nc, nq), self%kinv_b(nq, 2*nc), &
              self%s(2*nc, 2*nc), self%s_pivots(2*nc))
    self%handle = SUNLinSolNewEmpty(ctx)
    if (.not. c_associated(self%handle)) return   ! out of memory: the caller reports the NULL handle
    call c_f_pointer(self%handle, ls)
    ls%content = c_loc(self)
    call c_f_pointer(ls%ops, ops)
    ops%gettype = c_funloc(block_gettype)
    ops%getid = c_funloc(block_getid)
    ops%setup = c_funloc(block_setup)
    ops%solve = c_funloc(block_solve_c)
  end subroutine block_solver_create

  !> Release the SUNLinearSolver wrapper (the content is Fortran's and is not freed by C).
  subroutine block_solver_destroy(self)
    type(ggl_block_solver), intent(inout) :: self  !< solver object
    type(sun_linear_solver), pointer :: ls
    if (.not. c_associated(self%handle)) return
    call c_f_pointer(self%handle, ls)
    ls%content = c_null_ptr
    call SUNLinSolFreeEmpty(self%handle)
    self%handle = c_null_ptr
  end subroutine block_solver_destroy

  !> Factorise the iteration matrix jac (n x n, n = 2 nq + 2 nc) at self%cj.
  subroutine block_factorise(self, jac, info)
    type(ggl_block_solver), intent(inout) :: self  !< solver object
    real(dp), intent(in) :: jac(:, :)         !< iteration matrix (as from ggl_jacobian_dense)
    integer, intent(out) :: info              !< 0, or > 0 if K or S is singular
    integer :: nq, nc, n
    real(dp) :: cj
    nq = self%nq; nc = self%nc; cj = self%cj
    self%whole = cj > CJ_DENSE
    if (self%whole) then
      n = 2*nq + 2*nc
      if (.not. allocated(self%lu)) allocate (self%lu(n, n), self%lu_pivots(n))
      self%lu = jac
      call dgetrf(n, n, self%lu, n, self%lu_pivots, info)
      return
    end if
    self%kq = jac(nq + 1:2*nq, 1:nq)
    self%k = jac(nq + 1:2*nq, nq + 1:2*nq) + self%kq/cj
    self%b1_rows(1:nq, :) = self%kq/cj
    call dgetrf(nq, nq, self%k, nq, self%k_pivots, info)
    if (info /= 0 .or. nc == 0) return
    self%g_t = transpose(jac(2*nq + 1:2*nq + nc, 1:nq))
    self%cq = jac(2*nq + nc + 1:2*nq + 2*nc, 1:nq)
    self%b1_rows(nq + 1:nq + nc, :) = jac(2*nq + 1:2*nq + nc, 1:nq)
    self%b1_rows(nq + nc + 1:nq + 2*nc, :) = self%cq/cj
    self%c_rows(1:nc, :) = jac(2*nq + 1:2*nq + nc, 1:nq)
    self%c_rows(nc + 1:2*nc, :) = jac(2*nq + 1:2*nq + nc, 1:nq) + self%cq/cj
    self%kinv_b(:, 1:nc) = self%g_t
    self%kinv_b(:, nc + 1:2*nc) = matmul(self%kq, self%g_t)/cj
    call dgetrs('N', nq, 2*nc, self%k, nq, self%k_pivots, self%kinv_b, nq, info)
    self%s = matmul(self%c_rows, self%kinv_b)
    self%s(1:nc, nc + 1:2*nc) = self%s(1:nc, nc + 1:2*nc) - matmul(transpose(self%g_t), self%g_t)
    self%s(nc + 1:2*nc, nc + 1:2*nc) = self%s(nc + 1:2*nc, nc + 1:2*nc) - matmul(self%cq, self%g_t)/cj
    call dgetrf(2*nc, 2*nc, self%s, 2*nc, self%s_pivots, info)
  end subroutine block_factorise

  !> Solve J x = b with the factors of block_factorise (x may not alias b): four
  !> matrix-vector products (small_gemv: compiled loops, as the chain solver's) and two LU
  !> solves (one LU solve of the whole matrix above CJ_DENSE).
  subroutine block_solve(self, b, x)
    type(ggl_block_solver), intent(in) :: self  !< factorised solver
    real(dp), intent(in) :: b(:)              !< right-hand side (b1, b2, b3, b4)
    real(dp), intent(out) :: x(:)             !< solution (a, w, l, m)
    real(dp) :: t(self%nq + 2*self%nc), w(self%nq), z(2*self%nc), cj
    integer :: nq, nc, m
    nq = self%nq; nc = self%nc; cj = self%cj; m = nq + 2*nc
    if (self%whole) then
      x = b
      call lu_solve(size(b), self%lu, self%lu_pivots, x)
      return
    end if
    call small_gemv('N', m, nq, 1.0_dp, self%b1_rows, b, 0.0_dp, t)       ! [Kq/cj; G; Cq/cj] b1
    w = b(nq + 1:2*nq) - t(1:nq)                                           ! r2
    call lu_solve(nq, self%k, self%k_pivots, w)                            ! K^-1 r2
    x(1:nq) = b(1:nq)
    if (nc > 0) then
      z(1:nc) = cj*b(2*nq + 1:2*nq + nc) - t(nq + 1:nq + nc)               ! rc
      z(nc + 1:2*nc) = b(2*nq + nc + 1:2*nq + 2*nc) - t(nq + nc + 1:m)
      call small_gemv('N', 2*nc, nq, -1.0_dp, self%c_rows, w, 1.0_dp, z)          ! - C K^-1 r2
      call lu_solve(2*nc, self%s, self%s_pivots, z)
      call small_gemv('N', nq, 2*nc, 1.0_dp, self%kinv_b, z, 1.0_dp, w)           ! + K^-1 B z
      call small_gemv('N', nq, nc, -1.0_dp, self%g_t, z(nc + 1:), 1.0_dp, x)      ! b1 - G^T m
      x(2*nq + 1:2*nq + 2*nc) = z
    end if
    x(1:nq) = (x(1:nq) + w)/cj
    x(nq + 1:2*nq) = w
  end subroutine block_solve

  !> Solve J X = B for k right-hand sides at once (block_solve's steps as matrix products, LAPACK
  !> dgemm and dgetrs): the sensitivity columns of one corrector iteration share every read of
  !> the factors (rotorcable_sensitivity_newton).  B is overwritten by X.
  subroutine block_solve_columns(self, b)
    type(ggl_block_solver), intent(in) :: self  !< factorised solver
    real(dp), intent(inout) :: b(:, :)        !< (n, k) right-hand sides, then solutions
    real(dp) :: t(self%nq + 2*self%nc, size(b, 2)), w(self%nq, size(b, 2)), z(2*self%nc, size(b, 2)), cj
    integer :: nq, nc, m, k, n, info, j
    nq = self%nq; nc = self%nc; cj = self%cj; m = nq + 2*nc; k = size(b, 2); n = size(b, 1)
    if (k == 0) return
    if (self%whole) then
      call dgetrs('N', n, k, self%lu, n, self%lu_pivots, b, n, info)
      return
    end if
    call dgemm('N', 'N', m, k, nq, 1.0_dp, self%b1_rows, m, b, n, 0.0_dp, t, m)   ! [Kq/cj; G; Cq/cj] b1
    w = b(nq + 1:2*nq, :) - t(1:nq, :)                                              ! r2
    call dgetrs('N', nq, k, self%k, nq, self%k_pivots, w, nq, info)                 ! K^-1 r2
    if (nc > 0) then
      z(1:nc, :) = cj*b(2*nq + 1:2*nq + nc, :) - t(nq + 1:nq + nc, :)               ! rc
      z(nc + 1:2*nc, :) = b(2*nq + nc + 1:2*nq + 2*nc, :) - t(nq + nc + 1:m, :)
      call dgemm('N', 'N', 2*nc, k, nq, -1.0_dp, self%c_rows, 2*nc, w, nq, 1.0_dp, z, 2*nc)        ! - C K^-1 r2
      do j = 1, k                             ! 2 nc x 2 nc: dgetrs's overhead exceeds the arithmetic
        call lu_solve(2*nc, self%s, self%s_pivots, z(:, j))
      end do
      call dgemm('N', 'N', nq, k, 2*nc, 1.0_dp, self%kinv_b, nq, z, 2*nc, 1.0_dp, w, nq)           ! + K^-1 B z
      call dgemm('N', 'N', nq, k, nc, -1.0_dp, self%g_t, nq, z(nc + 1:, :), nc, 1.0_dp, b, n)      ! b1 - G^T m
      b(2*nq + 1:2*nq + 2*nc, :) = z
    end if
    b(1:nq, :) = (b(1:nq, :) + w)/cj
    b(nq + 1:2*nq, :) = w
  end subroutine block_solve_columns

  !> SUNLinSolGetType: a direct solver (IDA fills and hands over the matrix).
  integer(c_int) function block_gettype(ls) bind(C)
    type(c_ptr), value :: ls
    block_gettype = SUNLINEARSOLVER_DIRECT
  end function block_gettype

  !> SUNLinSolGetID.
  integer(c_int) function block_getid(ls) bind(C)
    type(c_ptr), value :: ls
    block_getid = SUNLINEARSOLVER_CUSTOM
  end function block_getid

  !> SUNLinSolSetup: factorise the dense matrix IDA has just filled.  A singular block is
  !> reported as recoverable (IDA then cuts the step), as SUNDIALS's dense solver does.
  integer(c_int) function block_setup(ls, a) bind(C)
    type(c_ptr), value :: ls, a
    type(sun_linear_solver), pointer :: wrapper
    type(ggl_block_solver), pointer :: self
    real(c_double), pointer :: jac(:, :)
    integer :: n, info
    call c_f_pointer(ls, wrapper)
    call c_f_pointer(wrapper%content, self)
    n = 2*self%nq + 2*self%nc
    call c_f_pointer(SUNDenseMatrix_Data(a), jac, [n, n])
    call block_factorise(self, jac, info)
    block_setup = SUNLS_SUCCESS
    if (info /= 0) block_setup = SUNLS_LUFACT_FAIL
  end function block_setup

  !> SUNLinSolSolve: x = J^-1 b (tol is for iterative solvers).
  integer(c_int) function block_solve_c(ls, a, x, b, tol) bind(C)
    type(c_ptr), value :: ls, a, x, b
    real(c_double), value :: tol
    type(sun_linear_solver), pointer :: wrapper
    type(ggl_block_solver), pointer :: self
    real(c_double), pointer :: xv(:), bv(:)
    integer :: n
    call c_f_pointer(ls, wrapper)
    call c_f_pointer(wrapper%content, self)
    n = 2*self%nq + 2*self%nc
    call c_f_pointer(N_VGetArrayPointer(x), xv, [n])
    call c_f_pointer(N_VGetArrayPointer(b), bv, [n])
    call block_solve(self, bv, xv)
    block_solve_c = SUNLS_SUCCESS
  end function block_solve_c

end module rotorcable_ggl_linear_solver
