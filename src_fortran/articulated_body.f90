!> Articulated-body factorisation of M(q) + A for the chain, A a diagonal joint-space
!> "armature" (Featherstone, Rigid Body Dynamics Algorithms, 2008, ch. 7, the articulated-body
!> algorithm, with the joint armature of section 7.3 / eq. 7.40: D_i = S_i^T I^A_i S_i + A_i).
!> One factorisation costs O(n) and each solve of (M + A) x = tau then O(n): ABA run with zero
!> velocities, zero gravity and joint forces tau returns exactly (M + A)^-1 tau, because M is
!> the joint-space inertia of the same kinematic tree (Featherstone 2008, section 6.1).
!>
!> Spatial vectors are written in world-frame orientation at a point of each body: motions
!> (w, v_P) and forces (n_P, f) at the joint point P_j of body j.  Not one common origin: the
!> chain may lie metres from it (a rotor blade), and inertias about a far origin carry
!> m |c|^2 terms that cancel in the recursion and cost up to (r/L)^2 in accuracy.  Between
!> body j and its child the transform is the pure translation by r_j = P_{j+1} - P_j:
!>   motion  (w, v) at P_j      -> (w, v + w x r_j) at P_{j+1}  (X_j)
!>   force   (n, f) at P_{j+1}  -> (n + r_j x f, f) at P_j      (X_j^T)
!> The joint of body j turns about its axes a_k through P_j: S_j = [a_k; 0] (6 x nd).
module rotorcable_articulated_body
  use rotorcable_kinds, only: dp
  use rotorcable_chain, only: chain_type
  use rotorcable_kinematics, only: chain_state
  use rotorcable_rotations, only: cross, skew
  implicit none
  private
  public :: articulated_factors, articulated_factorise, articulated_solve, articulated_mass_times

  !> The factors one articulated-body pass leaves for the solves.
  type :: articulated_factors
    integer :: n = 0                          !< bodies
    real(dp), allocatable :: u(:, :, :)       !< (6,3,n) U_j = I^A_j S_j at P_j
    real(dp), allocatable :: d_inv(:, :, :)   !< (3,3,n) (S_j^T U_j + A_j)^-1
    real(dp), allocatable :: axes(:, :, :)    !< (3,3,n) joint axes a_k (angular part of S_j)
    real(dp), allocatable :: arm(:, :)        !< (3,n) r_j = P_{j+1} - P_j [m]
    real(dp), allocatable :: body(:, :, :)    !< (6,6,n) body j's own spatial inertia at P_j
  end type articulated_factors

contains

  !> Factorise M(q) + diag(armature) at the frames in st (positions current), O(n).
  !> info = j > 0 if joint j's D_j is singular (zero mass, or a negative armature).
  pure subroutine articulated_factorise(chain, st, armature, f, info)
    type(chain_type), intent(in) :: chain     !< chain description
    type(chain_state), intent(in) :: st       !< frames, joint points, axes at q
    real(dp), intent(in) :: armature(:)       !< (nq) diagonal added to M [kg m^2]
    type(articulated_factors), intent(inout) :: f  !< factors
    integer, intent(out) :: info              !< 0, or the joint with a singular D_j
    real(dp) :: ia(6, 6), ia_pass(6, 6), x(6, 6), c(3), rot(3, 3), ic(3, 3), d(3, 3)
    integer :: j, nd, i0, k, n
    n = chain%n_bodies
    info = 0
    if (f%n /= n) then
      if (allocated(f%u)) deallocate (f%u, f%d_inv, f%axes, f%arm, f%body)
      allocate (f%u(6, 3, n), f%d_inv(3, 3, n), f%axes(3, 3, n), f%arm(3, n), f%body(6, 6, n))
      f%n = n
    end if
    f%u = 0.0_dp; f%d_inv = 0.0_dp; f%axes = 0.0_dp
    ia_pass = 0.0_dp
    do j = n, 1, -1
      f%arm(:, j) = st%joint_point(:, j + 1) - st%joint_point(:, j)
      ! The child's articulated inertia moved from P_{j+1} to P_j: X_j^T I X_j.
      x = translation(f%arm(:, j))
      ia = matmul(transpose(x), matmul(ia_pass, x))
      ! Body j's own spatial inertia at P_j: [Ic + m [c][c]^T, m [c]; m [c]^T, m 1], c = C_j - P_j.
      c = st%cm(:, j) - st%joint_point(:, j)
      rot = st%rot(:, :, j)
      ic = matmul(rot, spread(chain%inertia(:, j), 2, 3)*transpose(rot))
      f%body(:, :, j) = 0.0_dp
      f%body(1:3, 1:3, j) = ic + chain%mass(j)*matmul(skew(c), transpose(skew(c)))
      f%body(1:3, 4:6, j) = chain%mass(j)*skew(c)
      f%body(4:6, 1:3, j) = chain%mass(j)*transpose(skew(c))
      do k = 1, 3
        f%body(3 + k, 3 + k, j) = chain%mass(j)
      end do
      ia = ia + f%body(:, :, j)
      nd = chain%n_joint_coords(j)
      ia_pass = ia
      if (nd == 0) cycle
      i0 = chain%first_coord(j) - 1
      f%axes(:, 1:nd, j) = st%axes(:, 1:nd, j)
      f%u(:, 1:nd, j) = matmul(ia(:, 1:3), st%axes(:, 1:nd, j))
      d = 0.0_dp
      d(1:nd, 1:nd) = matmul(transpose(st%axes(:, 1:nd, j)), f%u(1:3, 1:nd, j))
      do k = 1, nd
        d(k, k) = d(k, k) + armature(i0 + k)
      end do
      call small_inverse(nd, d, f%d_inv(:, :, j), info)
      if (info /= 0) then
        info = j
        return
      end if
      ! Articulated inertia handed to the parent: I^A - U D^-1 U^T (Featherstone eq. 7.35).
      ia_pass = ia - matmul(f%u(:, 1:nd, j), matmul(f%d_inv(1:nd, 1:nd, j), transpose(f%u(:, 1:nd, j))))
    end do
  end subroutine articulated_factorise

  !> Solve (M + A) x = tau with the factors: a backward pass of the bias forces and a forward
  !> pass of the accelerations (Featherstone 2008, table 7.1, with zero velocity terms), O(n).
  pure subroutine articulated_solve(chain, f, tau, x)
    type(chain_type), intent(in) :: chain     !< chain description
    type(articulated_factors), intent(in) :: f  !< factors of articulated_factorise
    real(dp), intent(in) :: tau(:)            !< (nq) joint forces
    real(dp), intent(out) :: x(:)             !< (nq) solution
    real(dp) :: p(6), a(6), u_j(3, f%n)
    integer :: j, nd, i0
    p = 0.0_dp
    u_j = 0.0_dp
    do j = f%n, 1, -1
      nd = chain%n_joint_coords(j)
      ! p holds the child's force passed through its joint, still at P_{j+1}: move it to P_j.
      p(1:3) = p(1:3) + cross(f%arm(:, j), p(4:6))
      if (nd == 0) cycle
      i0 = chain%first_coord(j) - 1
      u_j(1:nd, j) = tau(i0 + 1:i0 + nd) - matmul(p(1:3), f%axes(:, 1:nd, j))
      p = p + matmul(f%u(:, 1:nd, j), matmul(f%d_inv(1:nd, 1:nd, j), u_j(1:nd, j)))
    end do
    a = 0.0_dp                                ! the base does not accelerate in this system
    do j = 1, f%n
      if (j > 1) a(4:6) = a(4:6) + cross(a(1:3), f%arm(:, j - 1))   ! P_{j-1} -> P_j
      nd = chain%n_joint_coords(j)
      if (nd == 0) cycle
      i0 = chain%first_coord(j) - 1
      x(i0 + 1:i0 + nd) = matmul(f%d_inv(1:nd, 1:nd, j), u_j(1:nd, j) - matmul(a, f%u(:, 1:nd, j)))
      a(1:3) = a(1:3) + matmul(f%axes(:, 1:nd, j), x(i0 + 1:i0 + nd))
    end do
  end subroutine articulated_solve

  !> tau = M(q) w by the recursive Newton-Euler algorithm with zero velocities and no applied
  !> forces (Featherstone 2008, table 5.1), O(n), from the data of the factorisation: the
  !> residual of iterative refinement (rotorcable_chain_linear_solver).
  pure subroutine articulated_mass_times(chain, f, w, tau)
    type(chain_type), intent(in) :: chain     !< chain description
    type(articulated_factors), intent(in) :: f  !< factors of articulated_factorise
    real(dp), intent(in) :: w(:)              !< (nq) joint accelerations
    real(dp), intent(out) :: tau(:)           !< (nq) M w
    real(dp) :: a(6, f%n), p(6), acc(6)
    integer :: j, nd, i0
    acc = 0.0_dp
    do j = 1, f%n
      if (j > 1) acc(4:6) = acc(4:6) + cross(acc(1:3), f%arm(:, j - 1))
      nd = chain%n_joint_coords(j)
      if (nd > 0) then
        i0 = chain%first_coord(j) - 1
        acc(1:3) = acc(1:3) + matmul(f%axes(:, 1:nd, j), w(i0 + 1:i0 + nd))
      end if
      a(:, j) = acc
    end do
    p = 0.0_dp
    do j = f%n, 1, -1
      p(1:3) = p(1:3) + cross(f%arm(:, j), p(4:6))
      p = p + matmul(f%body(:, :, j), a(:, j))
      nd = chain%n_joint_coords(j)
      if (nd == 0) cycle
      i0 = chain%first_coord(j) - 1
      tau(i0 + 1:i0 + nd) = matmul(p(1:3), f%axes(:, 1:nd, j))
    end do
  end subroutine articulated_mass_times

  !> Motion transform of the translation by r: (w, v) -> (w, v + w x r) = (w, v - [r] w).
  pure function translation(r) result(x)
    real(dp), intent(in) :: r(3)
    real(dp) :: x(6, 6)
    integer :: k
    x = 0.0_dp
    do k = 1, 6
      x(k, k) = 1.0_dp
    end do
    x(4:6, 1:3) = -skew(r)
  end function translation

  !> Inverse of a symmetric positive definite matrix of order 1 to 3 in closed form (the
  !> adjugate over the determinant).  Hand-written because LAPACK's call overhead would
  !> dominate an O(n) pass of 3 x 3 blocks; D_j is SPD (a projected articulated inertia plus
  !> a non-negative armature) with a condition number bounded by the body's inertia ratio
  !> (L^2/(6 R^2) for a cylinder's bending against its twist), so the adjugate loses no
  !> more than that factor.  info = 1 if the determinant is not positive relative to the
  !> product of the diagonal (a singular or indefinite D).
  pure subroutine small_inverse(nd, d, d_inv, info)
    integer, intent(in) :: nd
    real(dp), intent(in) :: d(3, 3)
    real(dp), intent(out) :: d_inv(3, 3)
    integer, intent(out) :: info
    real(dp) :: det, scale
    integer :: k
    info = 0
    d_inv = 0.0_dp
    scale = 1.0_dp
    do k = 1, nd
      scale = scale*abs(d(k, k))
    end do
    select case (nd)
    case (1)
      det = d(1, 1)
      if (.not. det > 0.0_dp) then
        info = 1
        return
      end if
      d_inv(1, 1) = 1.0_dp/det
    case (2)
      det = d(1, 1)*d(2, 2) - d(1, 2)*d(2, 1)
      if (.not. det > 1.0e-14_dp*scale) then
        info = 1
        return
      end if
      d_inv(1, 1) = d(2, 2)/det; d_inv(2, 2) = d(1, 1)/det
      d_inv(1, 2) = -d(1, 2)/det; d_inv(2, 1) = -d(2, 1)/det
    case (3)
      d_inv(1, 1) = d(2, 2)*d(3, 3) - d(2, 3)*d(3, 2)
      d_inv(1, 2) = d(1, 3)*d(3, 2) - d(1, 2)*d(3, 3)
      d_inv(1, 3) = d(1, 2)*d(2, 3) - d(1, 3)*d(2, 2)
      d_inv(2, 1) = d(2, 3)*d(3, 1) - d(2, 1)*d(3, 3)
      d_inv(2, 2) = d(1, 1)*d(3, 3) - d(1, 3)*d(3, 1)
      d_inv(2, 3) = d(1, 3)*d(2, 1) - d(1, 1)*d(2, 3)
      d_inv(3, 1) = d(2, 1)*d(3, 2) - d(2, 2)*d(3, 1)
      d_inv(3, 2) = d(1, 2)*d(3, 1) - d(1, 1)*d(3, 2)
      d_inv(3, 3) = d(1, 1)*d(2, 2) - d(1, 2)*d(2, 1)
      det = d(1, 1)*d_inv(1, 1) + d(1, 2)*d_inv(2, 1) + d(1, 3)*d_inv(3, 1)
      if (.not. det > 1.0e-14_dp*scale) then
        info = 1
        return
      end if
      d_inv = d_inv/det
    case default
      info = 1
    end select
  end subroutine small_inverse

end module rotorcable_articulated_body
