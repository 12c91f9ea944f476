!> Thin, checked wrappers around the LAPACK routines rotorcable uses.
module rotorcable_linalg
  use rotorcable_kinds, only: dp
  use rotorcable_fpe_guard, only: fpe_pause, fpe_resume
  implicit none
  private
  public :: solve_dense, solve_least_norm, null_space, solve_spd, singular_values, thin_svd, all_finite
  public :: dgetrf, dgetrs, dgemm   ! factors kept across solves, products (linear solvers)
  public :: lu_solve, small_gemv

  interface
    subroutine dgesv(n, nrhs, a, lda, ipiv, b, ldb, info)
      import :: dp
      integer, intent(in) :: n, nrhs, lda, ldb
      real(dp), intent(inout) :: a(lda, *), b(ldb, *)
      integer, intent(out) :: ipiv(*), info
    end subroutine dgesv
    subroutine dgelsd(m, n, nrhs, a, lda, b, ldb, s, rcond, rank, work, lwork, iwork, info)
      import :: dp
      integer, intent(in) :: m, n, nrhs, lda, ldb, lwork
      real(dp), intent(inout) :: a(lda, *), b(ldb, *)
      real(dp), intent(out) :: s(*), work(*)
      real(dp), intent(in) :: rcond
      integer, intent(out) :: rank, iwork(*), info
    end subroutine dgelsd
    subroutine dgesvd(jobu, jobvt, m, n, a, lda, s, u, ldu, vt, ldvt, work, lwork, info)
      import :: dp
      character, intent(in) :: jobu, jobvt
      integer, intent(in) :: m, n, lda, ldu, ldvt, lwork
      real(dp), intent(inout) :: a(lda, *)
      real(dp), intent(out) :: s(*), u(ldu, *), vt(ldvt, *), work(*)
      integer, intent(out) :: info
    end subroutine dgesvd
    subroutine dgetrf(m, n, a, lda, ipiv, info)
      import :: dp
      integer, intent(in) :: m, n, lda
      real(dp), intent(inout) :: a(lda, *)
      integer, intent(out) :: ipiv(*), info
    end subroutine dgetrf
    subroutine dgetrs(trans, n, nrhs, a, lda, ipiv, b, ldb, info)
      import :: dp
      character, intent(in) :: trans
      integer, intent(in) :: n, nrhs, lda, ldb
      real(dp), intent(in) :: a(lda, *)
      integer, intent(in) :: ipiv(*)
      real(dp), intent(inout) :: b(ldb, *)
      integer, intent(out) :: info
    end subroutine dgetrs
    subroutine dgemm(transa, transb, m, n, k, alpha, a, lda, b, ldb, beta, c, ldc)
      import :: dp
      character, intent(in) :: transa, transb
      integer, intent(in) :: m, n, k, lda, ldb, ldc
      real(dp), intent(in) :: alpha, beta, a(lda, *), b(ldb, *)
      real(dp), intent(inout) :: c(ldc, *)
    end subroutine dgemm
    subroutine dpotrf(uplo, n, a, lda, info)
      import :: dp
      character, intent(in) :: uplo
      integer, intent(in) :: n, lda
      real(dp), intent(inout) :: a(lda, *)
      integer, intent(out) :: info
    end subroutine dpotrf
    subroutine dpotrs(uplo, n, nrhs, a, lda, b, ldb, info)
      import :: dp
      character, intent(in) :: uplo
      integer, intent(in) :: n, nrhs, lda, ldb
      real(dp), intent(in) :: a(lda, *)
      real(dp), intent(inout) :: b(ldb, *)
      integer, intent(out) :: info
    end subroutine dpotrs
  end interface

  !> Status returned by the wrappers when their input is not finite (LAPACK would otherwise
  !> report an illegal argument through xerbla, which prints and cannot be caught).
  integer, parameter, public :: INFO_NOT_FINITE = -1000
  !> Largest order whose LU solves are compiled loops here (lu_solve) rather than dgetrs.
  integer, parameter :: SMALL_LU_ORDER = 64

contains

  !> True when every element of a is a finite number.
  pure logical function all_finite(a)
    real(dp), intent(in) :: a(..)             !< array of any rank
    select rank (a)
    rank (1)
      all_finite = all(abs(a) <= huge(1.0_dp))
    rank (2)
      all_finite = all(abs(a) <= huge(1.0_dp))
    rank default
      all_finite = .false.
    end select
  end function all_finite

  !> Solve A x = b in place with the LU factors and pivots of LAPACK's dgetrf (as dgetrs does).
  !> Up to SMALL_LU_ORDER the row interchanges and both triangular substitutions are compiled loops
  !> here: OpenBLAS's dgetrs costs about ten times the arithmetic on the 20 x 20 and 12 x 12
  !> factors of a short chain (measured with callgrind: 13.7 % of the UH-60 decay's integration,
  !> ~4300 instructions per 20 x 20 solve); above it, dgetrs.
  subroutine lu_solve(n, lu, pivots, b)
    integer, intent(in) :: n                  !< order
    real(dp), intent(in) :: lu(n, n)          !< factors from dgetrf
    integer, intent(in) :: pivots(n)          !< pivots from dgetrf
    real(dp), intent(inout) :: b(n)           !< right-hand side, then solution
    real(dp) :: s, s2
    integer :: i, k, info
    if (n > SMALL_LU_ORDER) then
      call dgetrs('N', n, 1, lu, n, pivots, b, n, info)
      return
    end if
    do i = 1, n                               ! P b
      k = pivots(i)
      if (k /= i) then
        s = b(i); b(i) = b(k); b(k) = s
      end if
    end do
    ! Both substitutions take two columns a sweep, so b is read and written once per pair; the
    ! subtractions keep the column-by-column order (the same bits as one column a sweep).
    k = 1
    do while (k + 1 <= n)                     ! L y = P b, unit lower
      s = b(k)
      b(k + 1) = b(k + 1) - lu(k + 1, k)*s
      s2 = b(k + 1)
      do i = k + 2, n
        b(i) = b(i) - lu(i, k)*s - lu(i, k + 1)*s2
      end do
      k = k + 2
    end do
    k = n
    do while (k - 1 >= 1)                     ! U x = y
      b(k) = b(k)/lu(k, k)
      s = b(k)
      b(k - 1) = (b(k - 1) - lu(k - 1, k)*s)/lu(k - 1, k - 1)
      s2 = b(k - 1)
      do i = 1, k - 2
        b(i) = b(i) - lu(i, k)*s - lu(i, k - 1)*s2
      end do
      k = k - 2
    end do
    if (k == 1) b(1) = b(1)/lu(1, 1)
  end subroutine lu_solve

  !> y = alpha op(A) x + beta y, op(A) = A (trans 'N') or A^T ('T'), A (m, n), as BLAS dgemv
  !> does, in compiled loops: the chain solver's products are 6 x 33 and 33 x 12, where
  !> OpenBLAS's dgemv cost about 1200 instructions a call, a malloc and free of its buffer
  !> included, against ~300 here (callgrind, the 8-parameter flight sensitivities: 4 calls per
  !> solve, 3 % of the run); a fixed summation order also gives the same bits on every CPU.
  pure subroutine small_gemv(trans, m, n, alpha, a, x, beta, y)
    character, intent(in) :: trans            !< 'N' or 'T'
    integer, intent(in) :: m, n               !< A's rows and columns
    real(dp), intent(in) :: alpha, beta       !< factors
    real(dp), intent(in) :: a(m, n)           !< matrix
    real(dp), intent(in) :: x(*)              !< (n) for 'N', (m) for 'T'
    real(dp), intent(inout) :: y(*)           !< (m) for 'N', (n) for 'T'
    real(dp) :: s, s2, s3, s4
    integer :: i, j
    if (trans == 'N') then
      if (beta == 0.0_dp) then
        y(1:m) = 0.0_dp
      else
        y(1:m) = beta*y(1:m)
      end if
      ! Four columns a sweep, so y is read and written once per four (the sums keep the
      ! column-by-column order: the same bits as one column a sweep).
      j = 1
      do while (j + 3 <= n)
        s = alpha*x(j); s2 = alpha*x(j + 1); s3 = alpha*x(j + 2); s4 = alpha*x(j + 3)
        do i = 1, m
          y(i) = y(i) + a(i, j)*s + a(i, j + 1)*s2 + a(i, j + 2)*s3 + a(i, j + 3)*s4
        end do
        j = j + 4
      end do
      do while (j <= n)
        s = alpha*x(j)
        do i = 1, m
          y(i) = y(i) + a(i, j)*s
        end do
        j = j + 1
      end do
    else
      do j = 1, n
        s = 0.0_dp
        do i = 1, m
          s = s + a(i, j)*x(i)
        end do
        if (beta == 0.0_dp) then
          y(j) = alpha*s
        else
          y(j) = beta*y(j) + alpha*s
        end if
      end do
    end if
  end subroutine small_gemv

  !> Singular values of an (m,n) matrix, descending (LAPACK dgesvd, no vectors).
  subroutine singular_values(a, s, info)
    real(dp), intent(in) :: a(:, :)           !< (m,n) matrix
    real(dp), intent(out) :: s(:)             !< (min(m,n)) singular values
    integer, intent(out) :: info              !< LAPACK status (0 = ok)
    real(dp) :: u(1, 1), vt(1, 1)
    call svd_lapack('N', a, u, s, vt, info)
  end subroutine singular_values

  !> Solve A x = b in place (LU with partial pivoting, LAPACK dgesv); info /= 0 if singular.
  subroutine solve_dense(a, b, info)
    real(dp), intent(inout) :: a(:, :)        !< (n,n) matrix, overwritten by its LU factors
    real(dp), intent(inout) :: b(:)           !< right-hand side, overwritten by the solution
    integer, intent(out) :: info              !< LAPACK status (0 = ok)
    integer :: ipiv(size(a, 1)), n
    logical :: halting(3)
    n = size(a, 1)
    if (n == 0) then
      info = 0
      return
    end if
    if (.not. (all_finite(a) .and. all_finite(b))) then
      info = INFO_NOT_FINITE
      return
    end if
    call fpe_pause(halting)
    call dgesv(n, 1, a, n, ipiv, b, n, info)
    call fpe_resume(halting)
  end subroutine solve_dense

  !> Thin singular value decomposition A = U diag(s) V^T of an (m,n) matrix (LAPACK dgesvd):
  !> U (m,k), s (k) descending, V^T (k,n), k = min(m,n).
  subroutine thin_svd(a, u, s, vt, info)
    real(dp), intent(in) :: a(:, :)           !< (m,n) matrix
    real(dp), intent(out) :: u(:, :)          !< (m,k) left singular vectors
    real(dp), intent(out) :: s(:)             !< (k) singular values
    real(dp), intent(out) :: vt(:, :)         !< (k,n) right singular vectors, transposed
    integer, intent(out) :: info              !< LAPACK status (0 = ok)
    call svd_lapack('S', a, u, s, vt, info)
  end subroutine thin_svd

  !> dgesvd with job 'N' (values only; u, vt are 1 x 1 placeholders) or 'S' (thin vectors), its
  !> workspace query, the finiteness guard and the trap pause shared by both callers.
  subroutine svd_lapack(job, a, u, s, vt, info)
    character, intent(in) :: job
    real(dp), intent(in) :: a(:, :)
    real(dp), intent(out) :: u(:, :), s(:), vt(:, :)
    integer, intent(out) :: info
    real(dp), allocatable :: aw(:, :), work(:)
    real(dp) :: wq(1)
    logical :: halting(3)
    u = 0.0_dp; s = 0.0_dp; vt = 0.0_dp
    if (.not. all_finite(a)) then
      info = INFO_NOT_FINITE
      return
    end if
    aw = a
    call fpe_pause(halting)
    call dgesvd(job, job, size(a, 1), size(a, 2), aw, size(a, 1), s, u, size(u, 1), vt, size(vt, 1), &
                wq, -1, info)
    allocate (work(int(wq(1))))
    call dgesvd(job, job, size(a, 1), size(a, 2), aw, size(a, 1), s, u, size(u, 1), vt, size(vt, 1), &
                work, size(work), info)
    call fpe_resume(halting)
  end subroutine svd_lapack

  !> Minimum-norm least-squares solution of A x = b (LAPACK dgelsd), A of shape (m,n).
  subroutine solve_least_norm(a, b, x, info)
    real(dp), intent(in) :: a(:, :)           !< (m,n) matrix
    real(dp), intent(in) :: b(:)              !< (m) right-hand side
    real(dp), intent(out) :: x(:)             !< (n) minimum-norm solution
    integer, intent(out) :: info              !< LAPACK status (0 = ok)
    real(dp), allocatable :: aw(:, :), bw(:), s(:), work(:)
    integer, allocatable :: iwork(:)
    integer :: m, n, ldb, rank, lwork, liwork
    real(dp) :: wq(1)
    integer :: iwq(1)
    logical :: halting(3)
    m = size(a, 1); n = size(a, 2); ldb = max(m, n)
    x = 0.0_dp
    if (.not. (all_finite(a) .and. all_finite(b))) then
      info = INFO_NOT_FINITE
      return
    end if
    aw = a
    allocate (bw(ldb), s(min(m, n)))
    bw = 0.0_dp
    bw(1:m) = b
    call fpe_pause(halting)
    call dgelsd(m, n, 1, aw, m, bw, ldb, s, -1.0_dp, rank, wq, -1, iwq, info)
    lwork = int(wq(1)); liwork = max(1, iwq(1))
    allocate (work(lwork), iwork(liwork))
    call dgelsd(m, n, 1, aw, m, bw, ldb, s, -1.0_dp, rank, work, lwork, iwork, info)
    call fpe_resume(halting)
    x = bw(1:n)
  end subroutine solve_least_norm

  !> Orthonormal basis of the null space of a full-row-rank (m,n) matrix, m <= n, from its
  !> singular value decomposition (LAPACK dgesvd): the last n - m right singular vectors.
  subroutine null_space(a, basis, info)
    real(dp), intent(in) :: a(:, :)           !< (m,n) matrix
    real(dp), intent(out) :: basis(:, :)      !< (n, n-m) orthonormal columns with a basis = 0
    integer, intent(out) :: info              !< LAPACK status (0 = ok)
    real(dp), allocatable :: aw(:, :), s(:), vt(:, :), work(:)
    real(dp) :: u(1, 1), wq(1)
    integer :: m, n, lwork
    logical :: halting(3)
    m = size(a, 1); n = size(a, 2)
    if (m == 0) then
      basis = 0.0_dp
      do lwork = 1, n
        basis(lwork, lwork) = 1.0_dp
      end do
      info = 0
      return
    end if
    basis = 0.0_dp
    if (.not. all_finite(a)) then
      info = INFO_NOT_FINITE
      return
    end if
    aw = a
    allocate (s(min(m, n)), vt(n, n))
    call fpe_pause(halting)
    call dgesvd('N', 'A', m, n, aw, m, s, u, 1, vt, n, wq, -1, info)
    lwork = int(wq(1))
    allocate (work(lwork))
    call dgesvd('N', 'A', m, n, aw, m, s, u, 1, vt, n, work, lwork, info)
    call fpe_resume(halting)
    basis = transpose(vt(m + 1:n, :))
  end subroutine null_space

  !> Solve A x = b for symmetric positive definite A (Cholesky, LAPACK dpotrf/dpotrs).
  !> info > 0 if A is not positive definite (A is then left factorised partially).
  subroutine solve_spd(a, b, info)
    real(dp), intent(inout) :: a(:, :)        !< (n,n) SPD matrix, overwritten by its factor
    real(dp), intent(inout) :: b(:)           !< right-hand side -> solution
    integer, intent(out) :: info              !< LAPACK status (0 = ok)
    integer :: n
    logical :: halting(3)
    n = size(a, 1)
    info = 0
    if (n == 0) return
    if (.not. (all_finite(a) .and. all_finite(b))) then
      info = INFO_NOT_FINITE
      return
    end if
    call fpe_pause(halting)
    call dpotrf('L', n, a, n, info)
    if (info == 0) call dpotrs('L', n, 1, a, n, b, n, info)
    call fpe_resume(halting)
  end subroutine solve_spd

end module rotorcable_linalg
