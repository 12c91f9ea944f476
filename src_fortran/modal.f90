!> Modal analysis about an equilibrium of the constrained chain.
!>
!> Linearising M qdd = k + G^T lambda about (q*, lambda*) on the constraint manifold,
!> q = q* + N z with N an orthonormal null-space basis of G(q*), gives
!>   M_r zdd + D_r zd + K_r z = 0,  M_r = N^T M N,  D_r = N^T D N,  K_r = N^T K N,
!> where K = d(-k - G^T lambda*)/dq is the tangent stiffness including the constraint
!> curvature weighted by lambda* (rotorcable_statics) and D = d(-k)/dqdot.
!> Undamped modes: K_r phi = w^2 M_r phi (LAPACK dsygv).  Damped modes: the first-order
!> system in the undamped modal coordinates eta (z = Z eta, Z^T M_r Z = I, Z^T K_r Z = W),
!> [0 I; -W -Z^T D_r Z], a standard eigenproblem (LAPACK dgeev; the pencil
!> [0 I; -K_r -D_r] - s [I 0; 0 M_r] transformed by diag(Z, Z), same eigenvalues, a third of
!> dggev's QZ cost); every undamped mode is paired with the damped eigenvalue whose displacement
!> part matches it best (modal assurance criterion, mass weighted: in eta the mass is I).
!> Overdamped modes (real s) get f_damped = 0 and the modal damping ratio phi^T D_r phi / (2 w).
!> Cost O(nf^3): issue 21 measured n^3.6 with a per-pair product in q.
module rotorcable_modal
  use rotorcable_kinds, only: dp
  use rotorcable_errors, only: error_type, fatal_error
  use rotorcable_model, only: model_type, mass_matrix, constraint_jacobian
  use rotorcable_statics, only: tangent_stiffness, damping_matrix
  use rotorcable_linalg, only: null_space, all_finite, INFO_NOT_FINITE
  use rotorcable_fpe_guard, only: fpe_pause, fpe_resume
  implicit none
  private
  public :: modal_analysis, reduced_matrices

  interface
    subroutine dsygv(itype, jobz, uplo, n, a, lda, b, ldb, w, work, lwork, info)
      import :: dp
      integer, intent(in) :: itype, n, lda, ldb, lwork
      character, intent(in) :: jobz, uplo
      real(dp), intent(inout) :: a(lda, *), b(ldb, *)
      real(dp), intent(out) :: w(*), work(*)
      integer, intent(out) :: info
    end subroutine dsygv
    subroutine dgeev(jobvl, jobvr, n, a, lda, wr, wi, vl, ldvl, vr, ldvr, work, lwork, info)
      import :: dp
      character, intent(in) :: jobvl, jobvr
      integer, intent(in) :: n, lda, ldvl, ldvr, lwork
      real(dp), intent(inout) :: a(lda, *)
      real(dp), intent(out) :: wr(*), wi(*), vl(ldvl, *), vr(ldvr, *), work(*)
      integer, intent(out) :: info
    end subroutine dgeev
  end interface

  real(dp), parameter :: TWO_PI = 2.0_dp*acos(-1.0_dp)

contains

  !> The linearised equations on the constraint manifold: an orthonormal null-space basis N of
  !> G(q*) (LAPACK dgesvd), the full mass matrix and M_r = N^T M N, K_r = N^T K N, D_r = N^T D N.
  !> M_r is made symmetric (it is, round-off aside).  K_r and D_r keep their skew parts: D_r's is
  !> the gyroscopic (Coriolis) coupling of a turning frame that splits the modes with the rotor
  !> speed; K_r's is the circulatory part of a follower load: the drag of the still air through
  !> which a turning cable moves (6.4e-4 of K_r on the main job's cable in hover; 4e-16 with
  !> cd = 0 or without rotation).  Symmetrising it away shifted the 16 Hz hover mode's eigenvalue
  !> by 4.47e-3/s in its real part, the gap between Campbell and the Floquet exponents of the
  !> time-domain model.  The undamped problem takes K_r's symmetric part (modal_analysis).  A failed null space (a non-finite G, or dgesvd not converging)
  !> is an error, and the matrices are then left zero.
  subroutine reduced_matrices(model, t, q, lambda, basis, m_full, m_r, k_r, d_r, error)
    type(model_type), intent(inout) :: model  !< model
    real(dp), intent(in) :: t                 !< time of the equilibrium [s]
    real(dp), intent(in) :: q(:)              !< equilibrium coordinates [rad]
    real(dp), intent(in) :: lambda(:)         !< equilibrium multipliers
    real(dp), intent(out) :: basis(:, :)      !< (nq,nf) N
    real(dp), intent(out) :: m_full(:, :)     !< (nq,nq) M
    real(dp), intent(out) :: m_r(:, :), k_r(:, :), d_r(:, :)  !< (nf,nf) reduced matrices
    type(error_type), intent(inout) :: error  !< status
    real(dp) :: g_jac(model%nc, model%nq), k_full(model%nq, model%nq), d_full(model%nq, model%nq)
    integer :: info, n_eval
    character(len=16) :: buf
    basis = 0.0_dp; m_full = 0.0_dp; m_r = 0.0_dp; k_r = 0.0_dp; d_r = 0.0_dp
    if (model%nc > 0) call constraint_jacobian(model, t, q, g_jac)
    call null_space(g_jac, basis, info)
    if (info == INFO_NOT_FINITE) then
      call fatal_error(error, 'modal analysis: non-finite constraint Jacobian G at the equilibrium '// &
                       '(null space of G not formed)')
      return
    else if (info /= 0) then
      write (buf, '(i0)') info
      call fatal_error(error, 'modal analysis: null space of the constraint Jacobian G failed '// &
                       '(LAPACK dgesvd info = '//trim(buf)//')')
      return
    end if
    call mass_matrix(model, t, q, m_full)
    n_eval = 0
    call tangent_stiffness(model, t, q, lambda, k_full, n_eval)
    call damping_matrix(model, t, q, lambda, d_full)
    m_r = matmul(transpose(basis), matmul(m_full, basis))
    k_r = matmul(transpose(basis), matmul(k_full, basis))
    d_r = matmul(transpose(basis), matmul(d_full, basis))
    m_r = 0.5_dp*(m_r + transpose(m_r))
  end subroutine reduced_matrices

  !> Natural frequencies, damped frequencies, damping ratios and mode shapes.
  subroutine modal_analysis(model, t, q, lambda, f_undamped, f_damped, zeta, shapes, error)
    type(model_type), intent(inout) :: model  !< model
    real(dp), intent(in) :: t                 !< time of the equilibrium [s]
    real(dp), intent(in) :: q(:)              !< equilibrium coordinates [rad]
    real(dp), intent(in) :: lambda(:)         !< equilibrium multipliers
    real(dp), intent(out) :: f_undamped(:)    !< (nf) undamped natural frequencies [Hz], ascending
    real(dp), intent(out) :: f_damped(:)      !< (nf) damped frequencies [Hz] (0 = overdamped)
    real(dp), intent(out) :: zeta(:)          !< (nf) damping ratios
    real(dp), intent(out) :: shapes(:, :)     !< (nq,nf) mode shapes in q, mass-normalised
    type(error_type), intent(inout) :: error  !< status
    integer :: nq, nc, nf, info, i, k, best, lwork
    real(dp), allocatable :: basis(:, :), m_full(:, :)
    real(dp), allocatable :: m_r(:, :), k_r(:, :), d_r(:, :), a(:, :), b(:, :), w(:), work(:)
    real(dp), allocatable :: ar(:), ai(:), vr(:, :), vl(:, :), z(:, :), w_raw(:), d_eta(:, :), k_skew(:, :)
    real(dp), allocatable :: norm_v(:)
    logical :: halting(3)
    real(dp) :: wq(1), mac, mac_best, omega, s_re, s_im, w_zero, num_r, num_i, den_x

    nq = model%nq; nc = model%nc; nf = nq - nc
    allocate (basis(nq, nf), m_full(nq, nq), m_r(nf, nf), k_r(nf, nf), d_r(nf, nf))
    call reduced_matrices(model, t, q, lambda, basis, m_full, m_r, k_r, d_r, error)
    if (error%code /= 0) return
    if (.not. (all_finite(m_r) .and. all_finite(k_r) .and. all_finite(d_r))) then
      call fatal_error(error, 'modal analysis: non-finite mass, stiffness or damping matrix')
      return
    end if
    ! Undamped: sym(K_r) phi = w^2 M_r phi (the conservative part; the circulatory skew part of
    ! K_r enters the damped system below, as the gyroscopic part of D_r does).
    a = 0.5_dp*(k_r + transpose(k_r)); b = m_r
    allocate (w(nf))
    call fpe_pause(halting)
    call dsygv(1, 'V', 'U', nf, a, nf, b, nf, w, wq, -1, info)
    lwork = int(wq(1)); allocate (work(lwork))
    call dsygv(1, 'V', 'U', nf, a, nf, b, nf, w, work, lwork, info)
    call fpe_resume(halting)
    if (info /= 0) then
      call fatal_error(error, 'modal analysis: generalized symmetric eigenproblem failed (dsygv)')
      return
    end if
    ! Eigenvalues within round-off of zero are zero-stiffness (rigid-body) modes: a free pivot
    ! without springs, a twist without a twist spring.  Only a clearly negative one means an
    ! unstable equilibrium.
    w_zero = 1.0e-9_dp*max(maxval(abs(w)), tiny(1.0_dp))
    if (w(1) < -w_zero) then
      call fatal_error(error, 'modal analysis: the equilibrium is unstable (negative stiffness eigenvalue)')
      return
    end if
    w_raw = w                                 ! the damped system keeps K_r as it is
    where (w < w_zero) w = 0.0_dp
    z = a                                     ! M_r-normalised eigenvectors, columns
    f_undamped = sqrt(w)/TWO_PI
    shapes = matmul(basis, z)

    ! Damped: first-order system of size 2 nf in the undamped modal coordinates.  Z^T sym(K_r) Z
    ! is diag(w) to round-off (dsygv's own residual), so it is taken diagonal; Z^T skew(K_r) Z
    ! (circulatory) and D are not.
    deallocate (a, b, work)
    d_eta = matmul(transpose(z), matmul(d_r, z))
    k_skew = matmul(transpose(z), matmul(0.5_dp*(k_r - transpose(k_r)), z))
    allocate (a(2*nf, 2*nf), ar(2*nf), ai(2*nf), vr(2*nf, 2*nf), vl(1, 1))
    a = 0.0_dp
    a(nf + 1:, 1:nf) = -k_skew
    do i = 1, nf
      a(i, nf + i) = 1.0_dp
      a(nf + i, i) = -w_raw(i)
    end do
    a(nf + 1:, nf + 1:) = -d_eta
    call fpe_pause(halting)
    call dgeev('N', 'V', 2*nf, a, 2*nf, ar, ai, vl, 1, vr, 2*nf, wq, -1, info)
    lwork = int(wq(1)); allocate (work(lwork))
    call dgeev('N', 'V', 2*nf, a, 2*nf, ar, ai, vl, 1, vr, 2*nf, work, lwork, info)
    call fpe_resume(halting)
    if (info /= 0) then
      call fatal_error(error, 'modal analysis: damped eigenproblem failed (dgeev)')
      return
    end if
    ! Pairing: a damped vector's displacement part is x = N Z eta and an undamped shape
    ! phi_i = N Z e_i, so x^T M phi_i = eta^T Z^T M_r Z e_i = eta_i and x^T M x = |eta|^2
    ! (M_r = N^T M N, Z^T M_r Z = I): the MAC of every pair is read off the eigenvectors, where
    ! the products in q for every pair cost O(nf^4).
    allocate (norm_v(2*nf))
    norm_v = sum(vr(1:nf, :)**2, dim=1)
    do i = 1, nf
      omega = sqrt(w(i))
      best = 0; mac_best = -1.0_dp
      do k = 1, 2*nf
        ! Displacement part of eigenvector k (complex pairs stored as re, im columns).
        if (ai(k) > 0.0_dp) then
          num_r = vr(i, k); num_i = vr(i, k + 1)
          den_x = norm_v(k) + norm_v(k + 1)
        else if (ai(k) < 0.0_dp) then
          cycle
        else
          num_r = vr(i, k); num_i = 0.0_dp
          den_x = norm_v(k)
        end if
        mac = (num_r**2 + num_i**2)/max(den_x, tiny(1.0_dp))
        if (mac > mac_best) then
          mac_best = mac; best = k
        end if
      end do
      f_damped(i) = 0.0_dp
      zeta(i) = 0.0_dp                        ! a zero-stiffness (rigid-body) mode has no ratio
      if (best == 0) cycle
      s_re = ar(best); s_im = ai(best)
      if (s_im > 0.0_dp) then
        f_damped(i) = s_im/TWO_PI
        zeta(i) = -s_re/sqrt(s_re**2 + s_im**2)
      else if (omega > 0.0_dp) then
        zeta(i) = d_eta(i, i)/(2.0_dp*omega)
      end if
    end do
  end subroutine modal_analysis

end module rotorcable_modal
