!> Generalized mass matrix M(q), two ways.
!>
!> * mass_matrix_crba: composite-rigid-body algorithm, O(n^2) (Featherstone 2008, ch. 6).
!>   Used where a Jacobian, a static or a modal analysis needs M explicitly; the
!>   residual of the DAE never forms M (see rotorcable_inverse_dynamics).
!> * mass_matrix_jourdain: the thesis's Jourdain form, eq. 4.87,
!>   M = sum_b J_Tb^T m_b J_Tb + J_Rb^T Theta_b J_Rb, O(n^3); kept as the check of CRBA.
!> Both use the world-frame joint axes a_k through the joint points p_k: the column k of
!> J_Rb is a_k and of J_Tb is a_k x (C_b - p_k) for every body b at or after k's joint
!> (eq. 4.31-4.45 and 4.60-4.77 written with axes instead of matrix derivatives).
module rotorcable_mass_matrix
  use rotorcable_kinds, only: dp
  use rotorcable_chain, only: chain_type
  use rotorcable_kinematics, only: chain_state
  use rotorcable_inverse_dynamics, only: world_inertia_times
  use rotorcable_rotations, only: cross
  implicit none
  private
  public :: mass_matrix_crba, mass_matrix_jourdain, coordinate_joints

contains

  !> Joint index of every coordinate.
  pure function coordinate_joints(chain) result(jk)
    type(chain_type), intent(in) :: chain     !< chain description
    integer :: jk(chain%n_coords)
    integer :: j, k
    do j = 1, chain%n_bodies
      do k = 1, chain%n_joint_coords(j)
        jk(chain%first_coord(j) + k - 1) = j
      end do
    end do
  end function coordinate_joints

  !> Composite-rigid-body mass matrix.  The composite of bodies j..n is held as mass m,
  !> first moment h = sum m c and inertia about the world origin; a unit rate of
  !> coordinate k moves it with (w, v_O) = (a_k, p_k x a_k), giving momentum
  !> P = m v_O + w x h, L_O = I_O w + h x v_O and M_lk = v_Ol . P + a_l . L_O.
  pure subroutine mass_matrix_crba(chain, st, mass)
    type(chain_type), intent(in) :: chain     !< chain description
    type(chain_state), intent(in) :: st       !< state with current positions
    real(dp), intent(out) :: mass(:, :)       !< (nq,nq) mass matrix
    real(dp) :: m_c, h_c(3), i_o(3, 3), c(3), ib(3, 3), e(3, 3)
    real(dp) :: w(3), v_o(3), p_mom(3), l_mom(3), a_l(3), p_l(3)
    integer :: j, k, kk, l, i, jk(chain%n_coords)

    jk = coordinate_joints(chain)
    m_c = 0.0_dp
    h_c = 0.0_dp
    i_o = 0.0_dp
    e = 0.0_dp
    do i = 1, 3
      e(i, i) = 1.0_dp
    end do
    do j = chain%n_bodies, 1, -1
      c = st%cm(:, j)
      do i = 1, 3
        ib(:, i) = world_inertia_times(chain, st, j, e(:, i))
      end do
      ! Parallel-axis (Steiner) shift of body j's inertia to the world origin.
      do i = 1, 3
        ib(:, i) = ib(:, i) + chain%mass(j)*(dot_product(c, c)*e(:, i) - c*c(i))
      end do
      m_c = m_c + chain%mass(j)
      h_c = h_c + chain%mass(j)*c
      i_o = i_o + ib
      do kk = 1, chain%n_joint_coords(j)
        k = chain%first_coord(j) + kk - 1
        w = st%axes(:, kk, j)
        v_o = cross(st%joint_point(:, j), w)
        p_mom = m_c*v_o + cross(w, h_c)
        l_mom = matmul(i_o, w) + cross(h_c, v_o)
        do l = 1, k
          a_l = st%axes(:, l - chain%first_coord(jk(l)) + 1, jk(l))
          p_l = st%joint_point(:, jk(l))
          mass(l, k) = dot_product(cross(p_l, a_l), p_mom) + dot_product(a_l, l_mom)
          mass(k, l) = mass(l, k)
        end do
      end do
    end do
  end subroutine mass_matrix_crba

  !> Thesis Jourdain form, eq. 4.87: explicit translational and rotational Jacobians.
  pure subroutine mass_matrix_jourdain(chain, st, mass)
    type(chain_type), intent(in) :: chain     !< chain description
    type(chain_state), intent(in) :: st       !< state with current positions
    real(dp), intent(out) :: mass(:, :)       !< (nq,nq) mass matrix
    real(dp) :: jt(3, chain%n_coords), jr(3, chain%n_coords), ijr(3, chain%n_coords)
    integer :: b, k, nq, jk(chain%n_coords)

    nq = chain%n_coords
    jk = coordinate_joints(chain)
    mass = 0.0_dp
    do b = 1, chain%n_bodies
      jt = 0.0_dp
      jr = 0.0_dp
      do k = 1, nq
        if (jk(k) > b) cycle
        jr(:, k) = st%axes(:, k - chain%first_coord(jk(k)) + 1, jk(k))
        jt(:, k) = cross(jr(:, k), st%cm(:, b) - st%joint_point(:, jk(k)))
        ijr(:, k) = world_inertia_times(chain, st, b, jr(:, k))
      end do
      do k = 1, nq
        if (jk(k) > b) ijr(:, k) = 0.0_dp
      end do
      mass = mass + chain%mass(b)*matmul(transpose(jt), jt) + matmul(transpose(jr), ijr)
    end do
  end subroutine mass_matrix_jourdain

end module rotorcable_mass_matrix
