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
!>
!> Stability.  In its textbook form the recursion loses its digits along a chain of
!> multi-axis joints: round-off in the articulated inertia is amplified from joint to joint
!> (by 3 to 16 per joint on 40-body chains of two-axis joints, in double and in 60-digit
!> arithmetic alike), and the solves of a 40-body chain were wrong by 35 %, of an 88-body chain
!> with xyz joints by 1e4 %, wherever the armature A is small (large cj).  Three changes make
!> it accurate to cond(M) eps (tests/test_chain_solver.py, up to n = 200, cond 2e8):
!>  1. The inertia handed to the parent, I^A - U (D + A)^-1 U^T, is formed in the joint's own
!>     basis W = diag(W_r, 1), W_r = [a_1 .. a_nd, complement]: with I~ = W^T I^A W and
!>     D = I~_11, C_11 = D (D + A)^-1 A and C_12 = -C_11 g vanish with A exactly, where the
!>     textbook difference leaves O(eps D) (pass_inertia).
!>  2. Its block on the transmitted directions is the free joint's Z^-1 (the inverse of the
!>     articulated compliance, Featherstone 2008, section 7.3) plus a positive correction,
!>     C_22 = Z^-1 + g^T C_11 g, not I~_22 - I~_21 (D + A)^-1 I~_12, in which a floppy
!>     chain's small effective mass is a difference of large inertias.
!>  3. The move to the parent's joint point is grouped as the product X^T (I X); the expanded
!>     a - b[r] - (b[r])^T - [r] c [r] is the same sum but breaks the exact cancellation
!>     along the child's free directions.
!> Leaving out 2 or 3 brings the error back (1e-4 to 4e-2 at n = 40 without armature, measured
!> in numpy on the same chains).  The bias force is passed the same way as 1: its joint part
!> becomes tau - A (D + A)^-1 u.
module rotorcable_articulated_body
  use rotorcable_kinds, only: dp
  use rotorcable_chain, only: chain_type
  use rotorcable_kinematics, only: chain_state
  use rotorcable_rotations, only: cross, skew
  implicit none
  private
  public :: articulated_factors, articulated_factorise, articulated_solve

  !> Right-hand sides a solve carries through the passes together.
  integer, parameter :: RHS_BLOCK = 12

  !> The factors one articulated-body pass leaves for the solves.
  type :: articulated_factors
    integer :: n = 0                          !< bodies
    real(dp), allocatable :: u(:, :, :)       !< (6,3,n) U_j = I^A_j S_j at P_j
    real(dp), allocatable :: d_inv(:, :, :)   !< (3,3,n) (S_j^T U_j + A_j)^-1, zero-padded
    real(dp), allocatable :: armature(:, :)   !< (3,n) A_j, the joint's diagonal
    real(dp), allocatable :: basis_inv(:, :, :)  !< (3,3,n) rows 1..nd of W_r^-1 (the axes' duals), zero below
    real(dp), allocatable :: axes(:, :, :)    !< (3,3,n) joint axes a_k (angular part of S_j)
    real(dp), allocatable :: arm(:, :)        !< (3,n) r_j = P_{j+1} - P_j [m]
  end type articulated_factors

contains

  !> Factorise M(q) + diag(armature) at the frames in st (positions current), O(n).
  !> info = j > 0 if joint j's D_j is singular (zero mass, or a negative armature) or its axes
  !> are dependent.  Spatial inertias are kept as their 3 x 3 blocks [a, b; b^T, c] (moment
  !> about P from (w, v_P), ...), so every product is a fixed-size 3 x 3 one.
  pure subroutine articulated_factorise(chain, st, armature, f, info)
    type(chain_type), intent(in) :: chain     !< chain description
    type(chain_state), intent(in) :: st       !< frames, joint points, axes at q
    real(dp), intent(in) :: armature(:)       !< (nq) diagonal added to M [kg m^2]
    type(articulated_factors), intent(inout) :: f  !< factors
    integer, intent(out) :: info              !< 0, or the joint with a singular D_j
    real(dp) :: a(3, 3), b(3, 3), c(3, 3), ap(3, 3), bp(3, 3), cp(3, 3), br(3, 3), cr(3, 3), sr(3, 3), sc(3, 3)
    real(dp) :: cm(3), rot(3, 3), w_r(3, 3), it(6, 6), d(3, 3), m
    integer :: j, nd, i0, k, l, n
    n = chain%n_bodies
    info = 0
    if (f%n /= n) then
      if (allocated(f%u)) deallocate (f%u, f%d_inv, f%axes, f%arm, f%armature, f%basis_inv)
      allocate (f%u(6, 3, n), f%d_inv(3, 3, n), f%axes(3, 3, n), f%arm(3, n), f%armature(3, n), &
                f%basis_inv(3, 3, n))
      f%n = n
    end if
    f%u = 0.0_dp; f%d_inv = 0.0_dp; f%axes = 0.0_dp; f%armature = 0.0_dp; f%basis_inv = 0.0_dp
    ap = 0.0_dp; bp = 0.0_dp; cp = 0.0_dp
    do j = n, 1, -1
      f%arm(:, j) = st%joint_point(:, j + 1) - st%joint_point(:, j)
      ! The child's articulated inertia moved from P_{j+1} to P_j, X^T I X with X the motion
      ! transform of the module header: a - b[r] - (b[r])^T - [r] c [r], b + [r] c, c.
      ! Grouped as the product X^T (I X): first I X = [a - b[r], b; b^T - c[r], c], then X^T of it.
      ! The expanded a - b[r] - (b[r])^T - [r] c [r] is the same sum, but it loses the exact
      ! cancellation along the child's free joint directions, and that error grows along the
      ! chain (measured with the rest unchanged: 4e-2 at n = 40 against 4e-11 grouped).
      sr = skew(f%arm(:, j))
      br = ap - matmul(bp, sr)                ! a - b[r]
      cr = transpose(bp) - matmul(cp, sr)     ! b^T - c[r]
      a = br + matmul(sr, cr)
      b = bp + matmul(sr, cp)
      c = cp
      ! Body j's own spatial inertia at P_j: [Ic + m [c][c]^T, m [c]; m [c]^T, m 1], c = C_j - P_j.
      m = chain%mass(j)
      sc = skew(st%cm(:, j) - st%joint_point(:, j))
      rot = st%rot(:, :, j)
      ap = m*matmul(sc, transpose(sc))
      do k = 1, 3                             ! R diag(theta) R^T, one outer product per axis
        cm = rot(:, k)*chain%inertia(k, j)
        do l = 1, 3
          ap(:, l) = ap(:, l) + cm*rot(l, k)
        end do
      end do
      a = a + ap
      b = b + m*sc
      do k = 1, 3
        c(k, k) = c(k, k) + m
      end do
      nd = chain%n_joint_coords(j)
      ap = a; bp = b; cp = c
      if (nd == 0) cycle
      i0 = chain%first_coord(j) - 1
      f%axes(:, 1:nd, j) = st%axes(:, 1:nd, j)
      f%armature(1:nd, j) = armature(i0 + 1:i0 + nd)
      ! U = I^A S, S = [a_k; 0].
      f%u(1:3, 1:nd, j) = matmul(a, st%axes(:, 1:nd, j))
      f%u(4:6, 1:nd, j) = matmul(transpose(b), st%axes(:, 1:nd, j))
      w_r = joint_basis(nd, st%axes(:, 1:nd, j))
      call invert3(w_r, f%basis_inv(:, :, j), info)
      if (info == 0) then
        ! I~ = W^T I^A W; its joint block is D = S^T U.
        it(1:3, 1:3) = matmul(transpose(w_r), matmul(a, w_r))
        it(1:3, 4:6) = matmul(transpose(w_r), b)
        it(4:6, 1:3) = transpose(it(1:3, 4:6))
        it(4:6, 4:6) = c
        d = 0.0_dp
        d(1:nd, 1:nd) = it(1:nd, 1:nd)
        do k = 1, nd
          d(k, k) = d(k, k) + armature(i0 + k)
        end do
        call small_inverse(nd, d, f%d_inv(:, :, j), info)
      end if
      if (info /= 0) then
        info = j
        return
      end if
      call pass_inertia(nd, f%armature(:, j), f%d_inv(:, :, j), it, f%basis_inv(:, :, j), ap, bp, cp, info)
      if (info /= 0) then
        info = j
        return
      end if
      f%basis_inv(nd + 1:3, :, j) = 0.0_dp    ! only the axes' duals are used in the solves
    end do
  end subroutine articulated_factorise

  !> The articulated inertia handed to the parent, I^A - U (D + A)^-1 U^T, in the stable form of
  !> the module header, from I~ = W^T I^A W; returned as its blocks at P_j.  With the Cholesky
  !> factor I~ = L L^T (joint block first: L_SS L_SS^T = D) and the free joint's transmitted
  !> inertia Z^-1 = L_TT L_TT^T (the inverse of the articulated compliance's T block,
  !> Featherstone 2008, section 7.3), g = -D^-1 I~_12 = -L_SS^-T L_TS^T:
  !>   C_11 = D (D + A)^-1 A,   C_12 = -C_11 g,   C_22 = Z^-1 + g^T C_11 g.
  !> The same matrix as I~_22 - I~_21 (D + A)^-1 I~_12, without its cancellation: a long floppy
  !> chain's effective mass behind a free joint is a small difference of large inertias there
  !> (measured: solves wrong by 1e-4 at n = 40 with the difference, 3e-11 this way).  The small
  !> dense algebra is written out: these are 6 x 6 and smaller, once per joint, where LAPACK's
  !> call overhead would exceed the ~150 flops.  info = 1 if I~ is not positive definite.
  pure subroutine pass_inertia(nd, arm_diag, d_a_inv, it, basis_inv, ap, bp, cp, info)
    integer, intent(in) :: nd                 !< joint coordinates
    real(dp), intent(in) :: arm_diag(3)       !< armature A (first nd)
    real(dp), intent(in) :: d_a_inv(3, 3)     !< (D + A)^-1 (leading nd x nd)
    real(dp), intent(in) :: it(6, 6)          !< I~ = W^T I^A W
    real(dp), intent(in) :: basis_inv(3, 3)   !< W_r^-1
    real(dp), intent(out) :: ap(3, 3), bp(3, 3), cp(3, 3)  !< blocks of the inertia passed on
    integer, intent(out) :: info              !< 0, or 1: not positive definite
    real(dp) :: l(6, 6), cb(6, 6), c11(3, 3), g(3, 6), cg(3, 6), s, r3(3, 3)
    integer :: i, j, k
    ap = 0.0_dp; bp = 0.0_dp; cp = 0.0_dp
    info = 0
    ! Cholesky I~ = L L^T, lower.
    l = 0.0_dp
    do j = 1, 6
      s = it(j, j)
      do k = 1, j - 1
        s = s - l(j, k)**2
      end do
      if (.not. s > 1.0e-15_dp*abs(it(j, j))) then
        info = 1
        return
      end if
      l(j, j) = sqrt(s)
      do i = j + 1, 6
        s = it(i, j)
        do k = 1, j - 1
          s = s - l(i, k)*l(j, k)
        end do
        l(i, j) = s/l(j, j)
      end do
    end do
    ! g = -L_SS^-T L_TS^T (nd x (6 - nd)), by back substitution on the columns of L_TS^T.
    do j = nd + 1, 6
      do i = nd, 1, -1
        s = -l(j, i)
        do k = i + 1, nd
          s = s - l(k, i)*g(k, j)
        end do
        g(i, j) = s/l(i, i)
      end do
    end do
    ! C_11 = D (D + A)^-1 A, symmetrised.
    do j = 1, nd
      do i = 1, nd
        s = 0.0_dp
        do k = 1, nd
          s = s + it(i, k)*d_a_inv(k, j)
        end do
        c11(i, j) = s*arm_diag(j)
      end do
    end do
    do j = 1, nd
      do i = 1, nd
        cb(i, j) = 0.5_dp*(c11(i, j) + c11(j, i))
      end do
    end do
    ! C_12 = -C_11 g; C_22 = Z^-1 + g^T C_11 g, Z^-1 = L_TT L_TT^T.
    do j = nd + 1, 6
      do i = 1, nd
        s = 0.0_dp
        do k = 1, nd
          s = s + cb(i, k)*g(k, j)
        end do
        cg(i, j) = s
        cb(i, j) = -s
        cb(j, i) = -s
      end do
    end do
    do j = nd + 1, 6
      do i = nd + 1, j
        s = 0.0_dp
        do k = nd + 1, i
          s = s + l(i, k)*l(j, k)
        end do
        do k = 1, nd
          s = s + g(k, i)*cg(k, j)
        end do
        cb(i, j) = s
        cb(j, i) = s
      end do
    end do
    ! Back from the joint basis: I = W^-T C W^-1, W = diag(W_r, 1).
    r3 = cb(1:3, 1:3)
    ap = matmul(transpose(basis_inv), matmul(r3, basis_inv))
    r3 = cb(1:3, 4:6)
    bp = matmul(transpose(basis_inv), r3)
    cp = cb(4:6, 4:6)
  end subroutine pass_inertia

  !> W_r: the joint axes, completed to a basis of R^3 by unit vectors orthogonal to them.
  pure function joint_basis(nd, axes) result(w)
    integer, intent(in) :: nd
    real(dp), intent(in) :: axes(3, nd)
    real(dp) :: w(3, 3), e(3)
    integer :: k
    w = 0.0_dp
    w(:, 1:nd) = axes
    if (nd == 2) w(:, 3) = cross(axes(:, 1), axes(:, 2))/norm2(cross(axes(:, 1), axes(:, 2)))
    if (nd == 1) then
      ! Any unit vector not along the axis, made orthogonal to it, then the third by a cross product.
      k = minloc(abs(axes(:, 1)), 1)
      e = 0.0_dp
      e(k) = 1.0_dp
      e = e - dot_product(e, axes(:, 1))*axes(:, 1)/dot_product(axes(:, 1), axes(:, 1))
      w(:, 2) = e/norm2(e)
      w(:, 3) = cross(axes(:, 1), w(:, 2))/norm2(axes(:, 1))
    end if
  end function joint_basis

  !> Inverse of a general 3 x 3 matrix by the adjugate; info = 1 if its determinant is tiny
  !> against the product of its column norms (dependent joint axes: a Cardan joint at 90 deg).
  pure subroutine invert3(a, a_inv, info)
    real(dp), intent(in) :: a(3, 3)
    real(dp), intent(out) :: a_inv(3, 3)
    integer, intent(out) :: info
    real(dp) :: det
    a_inv(1, :) = cross(a(:, 2), a(:, 3))
    a_inv(2, :) = cross(a(:, 3), a(:, 1))
    a_inv(3, :) = cross(a(:, 1), a(:, 2))
    det = dot_product(a(:, 1), a_inv(1, :))
    info = 0
    if (.not. abs(det) > 1.0e-12_dp*norm2(a(:, 1))*norm2(a(:, 2))*norm2(a(:, 3))) then
      info = 1
      a_inv = 0.0_dp
      return
    end if
    a_inv = a_inv/det
  end subroutine invert3

  !> Solve (M + A) x = tau for the columns of tau with the factors: a backward pass of the bias
  !> forces and a forward pass of the accelerations (Featherstone 2008, table 7.1, with zero
  !> velocity terms), O(n) per column.  The columns go through the passes together, in blocks of
  !> RHS_BLOCK (the clamp's Schur columns are 12 at once: the factors are read once per block),
  !> with the joint forces u parked in x between the passes; explicit loops over the 1 to 3
  !> joint axes, where library matmul calls and array temporaries would cost more than the
  !> arithmetic.
  pure subroutine articulated_solve(chain, f, tau, x)
    type(chain_type), intent(in) :: chain     !< chain description
    type(articulated_factors), intent(in) :: f  !< factors of articulated_factorise
    real(dp), intent(in) :: tau(:, :)         !< (nq, m) joint forces
    real(dp), intent(out) :: x(:, :)          !< (nq, m) solutions
    ! Every joint block is padded to 3 axes with zeros (axes, U, (D + A)^-1, the dual rows), so
    ! the products below run over 3 whatever the joint; written out, since copies of the blocks
    ! or library matmul calls on their sections cost more than the arithmetic.
    real(dp) :: p(6, RHS_BLOCK), a(6, RHS_BLOCK), t(3), u(3), du(3), r(3)
    integer :: j, nd, i0, k, l, c, col, nb, c0
    do c0 = 0, size(tau, 2) - 1, RHS_BLOCK
      nb = min(RHS_BLOCK, size(tau, 2) - c0)
      p(:, 1:nb) = 0.0_dp
      do j = f%n, 1, -1
        r = f%arm(:, j)
        nd = chain%n_joint_coords(j)
        i0 = chain%first_coord(j) - 1
        do c = 1, nb
          col = c0 + c
          ! p holds the child's force passed through its joint, still at P_{j+1}: move it to P_j.
          p(1:3, c) = p(1:3, c) + cross(r, p(4:6, c))
          if (nd == 0) cycle
          ! u = tau - S^T p (kept in x), du = (D + A)^-1 u, p + U du; then the joint part S^T p
          ! set to the exact tau - A du of the module header (the plain sum cancels): the moment
          ! changes by W_r^-T (new - old), row k of W_r^-1 being the dual of axis k.
          t = 0.0_dp
          t(1:nd) = tau(i0 + 1:i0 + nd, col)
          do k = 1, 3
            u(k) = t(k) - (f%axes(1, k, j)*p(1, c) + f%axes(2, k, j)*p(2, c) + f%axes(3, k, j)*p(3, c))
          end do
          x(i0 + 1:i0 + nd, col) = u(1:nd)
          do k = 1, 3
            du(k) = f%d_inv(k, 1, j)*u(1) + f%d_inv(k, 2, j)*u(2) + f%d_inv(k, 3, j)*u(3)
          end do
          do l = 1, 6
            p(l, c) = p(l, c) + f%u(l, 1, j)*du(1) + f%u(l, 2, j)*du(2) + f%u(l, 3, j)*du(3)
          end do
          do k = 1, 3
            u(k) = t(k) - f%armature(k, j)*du(k) &
                   - (f%axes(1, k, j)*p(1, c) + f%axes(2, k, j)*p(2, c) + f%axes(3, k, j)*p(3, c))
          end do
          do l = 1, 3
            p(l, c) = p(l, c) + u(1)*f%basis_inv(1, l, j) + u(2)*f%basis_inv(2, l, j) + u(3)*f%basis_inv(3, l, j)
          end do
        end do
      end do
      a(:, 1:nb) = 0.0_dp                     ! the base does not accelerate in this system
      do j = 1, f%n
        nd = chain%n_joint_coords(j)
        i0 = chain%first_coord(j) - 1
        if (j > 1) r = f%arm(:, j - 1)
        do c = 1, nb
          col = c0 + c
          if (j > 1) a(4:6, c) = a(4:6, c) + cross(a(1:3, c), r)   ! P_{j-1} -> P_j
          if (nd == 0) cycle
          ! x = (D + A)^-1 (u - U^T a), then a + S x.
          u = 0.0_dp
          u(1:nd) = x(i0 + 1:i0 + nd, col)
          do k = 1, 3
            u(k) = u(k) - dot_product(f%u(:, k, j), a(:, c))
          end do
          do k = 1, 3
            du(k) = f%d_inv(k, 1, j)*u(1) + f%d_inv(k, 2, j)*u(2) + f%d_inv(k, 3, j)*u(3)
          end do
          x(i0 + 1:i0 + nd, col) = du(1:nd)
          do l = 1, 3
            a(l, c) = a(l, c) + f%axes(l, 1, j)*du(1) + f%axes(l, 2, j)*du(2) + f%axes(l, 3, j)*du(3)
          end do
        end do
      end do
    end do
  end subroutine articulated_solve

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
