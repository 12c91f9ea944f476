!> The linearised equations about an equilibrium of the constrained chain, for its modes.
!>
!> Linearising M qdd = k + G^T lambda about (q*, lambda*) on the constraint manifold,
!> q = q* + N z with N an orthonormal null-space basis of G(q*), gives
!>   M_r zdd + D_r zd + K_r z = 0,  M_r = N^T M N,  D_r = N^T D N,  K_r = N^T K N,
!> where K = d(-k - G^T lambda*)/dq is the tangent stiffness including the constraint
!> curvature weighted by lambda* (rotorcable_statics) and D = d(-k)/dqdot.
!> The modes of these equations (undamped, damped, zero-stiffness) are solved in one place,
!> pydriver/analyses/linear_modes.py, for the modal analysis and the Campbell diagram alike
!> (issue 23 item 3: the damped modes were solved here too, by a second method).
module rotorcable_modal
  use rotorcable_kinds, only: dp
  use rotorcable_errors, only: error_type, fatal_error
  use rotorcable_model, only: model_type, mass_matrix, constraint_jacobian
  use rotorcable_statics, only: tangent_stiffness, damping_matrix
  use rotorcable_linalg, only: null_space, INFO_NOT_FINITE
  implicit none
  private
  public :: reduced_matrices

contains

  !> The linearised equations on the constraint manifold: an orthonormal null-space basis N of
  !> G(q*) (LAPACK dgesvd), the full mass matrix and M_r = N^T M N, K_r = N^T K N, D_r = N^T D N.
  !> M_r is made symmetric (it is, round-off aside).  K_r and D_r keep their skew parts: D_r's is
  !> the gyroscopic (Coriolis) coupling of a turning frame that splits the modes with the rotor
  !> speed; K_r's is the circulatory part of a follower load: the drag of the still air through
  !> which a turning cable moves (6.4e-4 of K_r on the main job's cable in hover; 4e-16 with
  !> cd = 0 or without rotation).  Symmetrising it away shifted the 16 Hz hover mode's eigenvalue
  !> by 4.47e-3/s in its real part, the gap between Campbell and the Floquet exponents of the
  !> time-domain model.  The undamped problem takes K_r's symmetric part
  !> (pydriver/analyses/linear_modes.py).  A failed null space (a non-finite G, or dgesvd not
  !> converging) is an error, and the matrices are then left zero.
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

end module rotorcable_modal
