!> Thin, checked wrappers around the LAPACK routines rotorcable uses.
module rotorcable_linalg
  use rotorcable_kinds, only: dp
  implicit none
  private
  public :: solve_dense, solve_least_norm

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
  end interface

contains

  !> Solve A x = b in place (LU with partial pivoting, LAPACK dgesv); info /= 0 if singular.
  subroutine solve_dense(a, b, info)
    real(dp), intent(inout) :: a(:, :)        !< (n,n) matrix, overwritten by its LU factors
    real(dp), intent(inout) :: b(:)           !< right-hand side, overwritten by the solution
    integer, intent(out) :: info              !< LAPACK status (0 = ok)
    integer :: ipiv(size(a, 1)), n
    n = size(a, 1)
    if (n == 0) then
      info = 0
      return
    end if
    call dgesv(n, 1, a, n, ipiv, b, n, info)
  end subroutine solve_dense

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
    m = size(a, 1); n = size(a, 2); ldb = max(m, n)
    aw = a
    allocate (bw(ldb), s(min(m, n)))
    bw = 0.0_dp
    bw(1:m) = b
    call dgelsd(m, n, 1, aw, m, bw, ldb, s, -1.0_dp, rank, wq, -1, iwq, info)
    lwork = int(wq(1)); liwork = max(1, iwq(1))
    allocate (work(lwork), iwork(liwork))
    call dgelsd(m, n, 1, aw, m, bw, ldb, s, -1.0_dp, rank, work, lwork, iwork, info)
    x = bw(1:n)
  end subroutine solve_least_norm

end module rotorcable_linalg
