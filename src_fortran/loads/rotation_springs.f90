!> Joint springs and dampers on the rotation vector of a Cardan bending + twist joint (xyz): the
!> discrete elastic energy of a geometrically exact rod (J. C. Simo, L. Vu-Quoc, "A
!> three-dimensional finite-strain rod model. Part II", CMAME 58, 1986; the discrete rods of
!> M. Bergou et al., "Discrete elastic rods", SIGGRAPH 2008, use the same curvature measure):
!>
!>   V_j = 1/2 phi_j^T K_j phi_j,   phi_j = log(R_rel,j),   K_j = diag(EI, EI, GJ)/l_j
!>
!> phi_j is the same vector in the parent's and the child's frame (R phi = phi).  Springs on the
!> Cardan coordinates instead (rotorcable_loads_joint_springs) differ from this at second order
!> in the joint angles (theta_3 = phi_3 - phi_1 phi_2 / 2 + ...), which summed over the L/l
!> joints of a twisted, doubly bent cable is an O(l) error: the chain would converge at first
!> order in 1/n (docs/model.md, "Converged numbers").
!>
!> Generalized forces, with w = R_c^T (omega_c - omega_p) = A qdot the relative angular velocity
!> in the child's axes (A = R_c^T [joint axes in the world]) and phi' = J_r^-1(phi) w (the right
!> Jacobian of SO(3); e.g. G. S. Chirikjian, Stochastic Models, Information Theory and Lie
!> Groups II, 2012, eq. 10.86):
!>
!>   tau_j = -A^T J_r^-T(phi) K phi - A^T D A qdot,    D = damping_time K (dissipation w^T D w).
!>
!> Parameters: stiffness K(3, j) and damping D(3, j) of every free joint j, in joint order.
!> Updatable: 'springs.stiffness' (K(3, j) for every free joint j, in joint order: one value per
!> coordinate, as the joint springs take them) and 'springs.damping' (D likewise), through
!> rotorcable_loads_spring_constants.
module rotorcable_loads_rotation_springs
  use rotorcable_kinds, only: dp
  use rotorcable_errors, only: error_type, fatal_error
  use rotorcable_chain, only: chain_type
  use rotorcable_joint, only: JOINT_XYZ, MAX_JOINT_DOF, joint_rotation
  use rotorcable_kinematics, only: chain_state
  use rotorcable_kinematics_tangent, only: chain_tangent
  use rotorcable_frame, only: frame_state
  use rotorcable_rotations, only: cross, transposed_times
  use rotorcable_loads_type, only: load_term, load_slot
  use rotorcable_parameter_block, only: parameter_block, get_reals
  use rotorcable_loads_spring_constants, only: set_spring_constants, get_spring_constants
  implicit none
  private
  public :: rotation_springs_load, new_rotation_springs, joint_rotation_vector

  !> Stiffness and damping per free joint, about its child's axes (bending x, y; twist z).
  type, extends(load_term) :: rotation_springs_load
    real(dp), allocatable :: stiffness(:, :)  !< (3, n) K diagonal [Nm/rad]; 0 for a locked joint
    real(dp), allocatable :: damping(:, :)    !< (3, n) D diagonal [Nms/rad]
    logical, allocatable :: free(:)           !< (n) joint j has coordinates
    ! At the state of the last linearise, which the tangents there read: a joint's torque
    ! change is linear in the joint's own (dq, dv), so the columns of one state (8 parameters
    ! x 2 corrector iterations, 44 Jacobian columns) share this 3 x 6 matrix per joint, formed
    ! once, instead of repeating its ~570 instructions of trigonometry-free algebra each.
    real(dp), allocatable :: torque_tangent(:, :, :)  !< (3, 6, n) d(tau_j)/d(dq_j, dv_j)
  contains
    procedure :: add_forces
    procedure :: linearise
    procedure :: add_force_tangent
    procedure :: add_force_jacobians
    procedure :: potential
    procedure :: joint_diagonal
    procedure :: set_parameter
    procedure :: get_parameter
  end type rotation_springs_load

contains

  !> Build from its parameter block: stiffness, damping, 3 per free joint; every free joint must
  !> be an xyz joint.
  subroutine new_rotation_springs(slot, chain, params, error)
    include 'constructor_arguments.inc'
    type(rotation_springs_load) :: load
    real(dp), allocatable :: stiffness(:), damping(:)
    integer :: j, k, n_free
    n_free = count(.not. chain%locked)
    if (any(chain%joint_kind /= JOINT_XYZ .and. .not. chain%locked)) then
      call fatal_error(error, 'rotation-vector springs need xyz joints')
      return
    end if
    allocate (stiffness(3*n_free), damping(3*n_free))
    call get_reals(params, 'stiffness', stiffness, error)
    call get_reals(params, 'damping', damping, error)
    if (error%code /= 0) return
    load%label = 'rotation-vector springs'
    allocate (load%stiffness(3, chain%n_bodies), load%damping(3, chain%n_bodies))
    load%stiffness = 0.0_dp
    load%damping = 0.0_dp
    load%free = .not. chain%locked
    allocate (load%torque_tangent(3, 6, chain%n_bodies))
    load%torque_tangent = 0.0_dp
    k = 0
    do j = 1, chain%n_bodies
      if (chain%locked(j)) cycle
      k = k + 1
      load%stiffness(:, j) = stiffness(3*k - 2:3*k)
      load%damping(:, j) = damping(3*k - 2:3*k)
    end do
    load%conservative = .true.
    load%depends_on_bodies = .false.   ! the joints' angles and rates and its own constants only
    allocate (slot%term, source=load)
  end subroutine new_rotation_springs

  !> phi = log(R_rel) of joint j at the coordinates q.  The angle from atan2 of the skew and
  !> the trace parts keeps full relative precision at small angles (acos of the trace does not).
  pure function joint_rotation_vector(chain, j, q) result(phi)
    type(chain_type), intent(in) :: chain     !< chain description
    integer, intent(in) :: j                  !< joint
    real(dp), intent(in) :: q(:)              !< coordinates [rad]
    real(dp) :: phi(3)
    phi = rotation_vector(relative_rotation(chain, j, q))
  end function joint_rotation_vector

  !> R_rel = Rx(q1) Ry(q2) Rz(q3) of the xyz joint j.
  pure function relative_rotation(chain, j, q) result(r)
    type(chain_type), intent(in) :: chain     !< chain description
    integer, intent(in) :: j                  !< joint
    real(dp), intent(in) :: q(:)              !< coordinates [rad]
    real(dp) :: r(3, 3)
    real(dp) :: angles(MAX_JOINT_DOF)
    angles = 0.0_dp
    angles(1:3) = q(chain%first_coord(j):chain%first_coord(j) + 2)
    r = joint_rotation(JOINT_XYZ, angles)
  end function relative_rotation

  !> log(R) by atan2 of the skew and the trace parts (module comment of joint_rotation_vector).
  pure function rotation_vector(r) result(phi)
    real(dp), intent(in) :: r(3, 3)           !< rotation matrix
    real(dp) :: phi(3)
    real(dp) :: axis_sin(3), s, c
    axis_sin = 0.5_dp*[r(3, 2) - r(2, 3), r(1, 3) - r(3, 1), r(2, 1) - r(1, 2)]   ! sin(angle) * axis
    s = norm2(axis_sin)
    c = 0.5_dp*(r(1, 1) + r(2, 2) + r(3, 3) - 1.0_dp)
    if (s > 1.0e-300_dp) then
      phi = atan2(s, c)/s*axis_sin
    else
      phi = 0.0_dp
    end if
  end function rotation_vector

  !> What joint j's springs need at its angles: phi = log(R_rel), the coefficient c(|phi|) of
  !> J_r^-1 with dc/da, and A, the joint axes in the child's frame (w = A qdot is the relative
  !> angular velocity in the child's axes).  For the xyz joint A = [R_rel^T e_x, (sin q3,
  !> cos q3, 0), e_z] (joint_axes: x of the parent, y after the first turn, z of the child), a
  !> function of the joint's own angles, so the frames are not needed: the library matmul on
  !> their array sections cost more than the arithmetic (callgrind, 2026-11-26).
  pure subroutine joint_terms(chain, j, q, phi, a, c, dc_da)
    type(chain_type), intent(in) :: chain     !< chain description
    integer, intent(in) :: j                  !< joint
    real(dp), intent(in) :: q(:)              !< coordinates [rad]
    real(dp), intent(out) :: phi(3)           !< rotation vector [rad]
    real(dp), intent(out) :: a(3, 3)          !< joint axes in the child's frame
    real(dp), intent(out) :: c, dc_da         !< J_r^-1's coefficient and its derivative
    real(dp) :: r(3, 3), psi
    r = relative_rotation(chain, j, q)
    phi = rotation_vector(r)
    psi = q(chain%first_coord(j) + 2)
    a(:, 1) = r(1, :)
    a(:, 2) = [sin(psi), cos(psi), 0.0_dp]
    a(:, 3) = [0.0_dp, 0.0_dp, 1.0_dp]
    call jacobian_coefficient(norm2(phi), c, dc_da)
  end subroutine joint_terms

  !> J_r^-T(phi) K phi = K phi - phi x K phi / 2 + c phi x (phi x K phi), written with cross
  !> products (skew(phi)^T = -skew(phi)).
  pure function spring_moment(phi, kphi, c) result(g)
    real(dp), intent(in) :: phi(3), kphi(3)   !< rotation vector, K phi
    real(dp), intent(in) :: c                 !< J_r^-1's coefficient
    real(dp) :: g(3)
    real(dp) :: pk(3)
    pk = cross(phi, kphi)
    g = kphi - 0.5_dp*pk + c*cross(phi, pk)
  end function spring_moment

  pure subroutine add_forces(self, chain, st, fs, t, q, v, force, moment, tau)
    class(rotation_springs_load), intent(in) :: self
    include 'force_arguments.inc'
    real(dp) :: phi(3), a(3, 3), rates(3), w(3), torque(3), c, dc_da
    integer :: j, i0
    do j = 1, chain%n_bodies
      if (chain%locked(j)) cycle
      i0 = chain%first_coord(j)
      call joint_terms(chain, j, q, phi, a, c, dc_da)
      rates = v(i0:i0 + 2)                    ! a fixed-size copy: matmul is inlined, not a library call
      w = matmul(a, rates)
      torque = spring_moment(phi, self%stiffness(:, j)*phi, c) + self%damping(:, j)*w
      tau(i0:i0 + 2) = tau(i0:i0 + 2) - transposed_times(a, torque)
    end do
  end subroutine add_forces

  !> The coefficient c(a) of J_r^-1 = I + [phi]/2 + c [phi]^2 and its derivative dc/da, a = |phi|:
  !> c = 1/a^2 - cot(a/2)/(2 a), dc/da = -2/a^3 + (a/sin^2(a/2) + 2 cot(a/2))/(4 a^2); below
  !> a = 1e-3 the series 1/12 + a^2/720 and a/360 (cancellation).
  pure subroutine jacobian_coefficient(a, c, dc_da)
    real(dp), intent(in) :: a
    real(dp), intent(out) :: c, dc_da
    real(dp) :: cot_half, sin_half
    if (a < 1.0e-3_dp) then
      c = 1.0_dp/12.0_dp + a**2/720.0_dp
      dc_da = a/360.0_dp
    else
      sin_half = sin(0.5_dp*a)
      cot_half = cos(0.5_dp*a)/sin_half
      c = 1.0_dp/a**2 - cot_half/(2.0_dp*a)
      dc_da = -2.0_dp/a**3 + (a/sin_half**2 + 2.0_dp*cot_half)/(4.0_dp*a**2)
    end if
  end subroutine jacobian_coefficient

  !> The tangents' matrix of every free joint at (q, v).  Its angle columns are
  !> joint_torque_tangent of the joint's three unit angle directions (the map is linear in
  !> them), the same formula as one direction at a time summed in another order; its rate
  !> columns are that formula's rate part in closed form, d(tau)/d(qdot) = -A^T D A.
  subroutine linearise(self, chain, st, fs, q, v)
    class(rotation_springs_load), intent(inout) :: self
    type(chain_type), intent(in) :: chain     !< chain description
    type(chain_state), intent(in) :: st       !< frames, velocities at the state (not needed)
    type(frame_state), intent(in) :: fs       !< the model frame's motion (not needed)
    real(dp), intent(in) :: q(:), v(:)        !< coordinates [rad] and rates [rad/s]
    real(dp) :: phi(3), a(3, 3), c, dc_da, unit(3), zero(3)
    integer :: j, i0, k, l
    zero = 0.0_dp
    do j = 1, chain%n_bodies
      if (chain%locked(j)) cycle
      i0 = chain%first_coord(j)
      call joint_terms(chain, j, q, phi, a, c, dc_da)
      do k = 1, 3
        unit = 0.0_dp
        unit(k) = 1.0_dp
        self%torque_tangent(:, k, j) = joint_torque_tangent(phi, a, c, dc_da, self%stiffness(:, j), &
                                                            self%damping(:, j), v(i0:i0 + 2), unit, zero)
        do l = 1, 3
          self%torque_tangent(l, k + 3, j) = -sum(a(:, l)*self%damping(:, j)*a(:, k))
        end do
      end do
    end do
  end subroutine linearise

  !> Tangent of tau_j = -A^T (g(phi) + D A qdot_j), g = J_r^-T K phi = K phi - phi x K phi / 2
  !> + c phi x (phi x K phi), for the joint's own (dq, dv), from linearise's matrix.
  pure subroutine add_force_tangent(self, chain, st, dst, fs, t, q, v, dq, dv, dforce, dmoment, dtau)
    class(rotation_springs_load), intent(in) :: self
    include 'force_tangent_arguments.inc'
    real(dp) :: s
    integer :: j, i0, i, k
    do j = dst%first, chain%n_bodies
      if (chain%locked(j)) cycle
      i0 = chain%first_coord(j) - 1
      do i = 1, 3
        s = 0.0_dp
        do k = 1, 3
          s = s + self%torque_tangent(i, k, j)*dq(i0 + k) + self%torque_tangent(i, k + 3, j)*dv(i0 + k)
        end do
        dtau(i0 + i) = dtau(i0 + i) + s
      end do
    end do
  end subroutine add_force_tangent

  !> linearise's matrix of every free joint, which is this very derivative.
  pure subroutine add_force_jacobians(self, chain, st, fs, t, q, v, pose, motion, joint_q, joint_v)
    class(rotation_springs_load), intent(in) :: self
    include 'force_jacobians_arguments.inc'
    integer :: j
    do j = 1, chain%n_bodies
      if (chain%locked(j)) cycle
      joint_q(1:3, 1:3, j) = joint_q(1:3, 1:3, j) + self%torque_tangent(:, 1:3, j)
      joint_v(1:3, 1:3, j) = joint_v(1:3, 1:3, j) + self%torque_tangent(:, 4:6, j)
    end do
  end subroutine add_force_jacobians

  !> d(tau_j) for the joint's own change (d_angles, d_rates) at its joint_terms (phi, A, c,
  !> dc/da), stiffness k, damping d and rates.  With delta = A dq the relative rotation's change
  !> in the child's axes (dR_rel = R_rel [delta]x): dphi = J_r^-1(phi) delta, and A
  !> (joint_terms) changes by dA = [A_1 x delta, (A_2 x e_z) dq_3, 0] (d(R^T e) = R^T e x
  !> delta for the first column; the second is R_yz^T e_y, which turns by A_2 dq_2 + e_z dq_3).
  pure function joint_torque_tangent(phi, a, c, dc_da, k, d, rates, d_angles, d_rates) result(dtau)
    real(dp), intent(in) :: phi(3), a(3, 3), c, dc_da  !< joint_terms at the state
    real(dp), intent(in) :: k(3), d(3)        !< stiffness [Nm/rad], damping [Nms/rad]
    real(dp), intent(in) :: rates(3)          !< the joint's rates [rad/s]
    real(dp), intent(in) :: d_angles(3), d_rates(3)  !< their change
    real(dp) :: dtau(3)
    real(dp) :: dphi(3), da(3, 3), kphi(3), dkphi(3), pk(3), delta(3), w(3), dw(3)
    real(dp) :: g(3), dg(3), torque(3), dtorque(3), dc, size_phi
    delta = matmul(a, d_angles)
    da(:, 1) = cross(a(:, 1), delta)
    da(:, 2) = [a(2, 2), -a(1, 2), 0.0_dp]*d_angles(3)
    da(:, 3) = 0.0_dp
    pk = cross(phi, delta)
    dphi = delta + 0.5_dp*pk + c*cross(phi, pk)
    size_phi = norm2(phi)
    dc = 0.0_dp
    if (size_phi > 0.0_dp) dc = dc_da*dot_product(phi, dphi)/size_phi
    kphi = k*phi
    dkphi = k*dphi
    pk = cross(phi, kphi)
    g = kphi - 0.5_dp*pk + c*cross(phi, pk)
    dg = dkphi - 0.5_dp*(cross(dphi, kphi) + cross(phi, dkphi)) + dc*cross(phi, pk) &
         + c*(cross(dphi, pk) + cross(phi, cross(dphi, kphi) + cross(phi, dkphi)))
    w = matmul(a, rates)
    dw = matmul(da, rates) + matmul(a, d_rates)
    torque = g + d*w
    dtorque = dg + d*dw
    dtau = -transposed_times(da, torque) - transposed_times(a, dtorque)
  end function joint_torque_tangent

  pure real(dp) function potential(self, chain, st, q) result(e)
    class(rotation_springs_load), intent(in) :: self
    include 'potential_arguments.inc'
    real(dp) :: phi(3)
    integer :: j
    e = 0.0_dp
    do j = 1, chain%n_bodies
      if (chain%locked(j)) cycle
      phi = joint_rotation_vector(chain, j, q)
      e = e + 0.5_dp*sum(self%stiffness(:, j)*phi**2)
    end do
  end function potential

  !> The diagonal at q = 0 (A = I, J_r = I there): what a chain factorisation may use.
  pure subroutine joint_diagonal(self, stiffness, damping)
    class(rotation_springs_load), intent(in) :: self
    real(dp), intent(inout) :: stiffness(:), damping(:)
    integer :: j, k
    k = 0
    do j = 1, size(self%stiffness, 2)
      if (.not. self%free(j)) cycle
      stiffness(k + 1:k + 3) = stiffness(k + 1:k + 3) + self%stiffness(:, j)
      damping(k + 1:k + 3) = damping(k + 1:k + 3) + self%damping(:, j)
      k = k + 3
    end do
  end subroutine joint_diagonal

  !> 'springs.stiffness' or 'springs.damping': 3 values per free joint, in joint order (the
  !> entries of the free joints' columns).
  subroutine set_parameter(self, name, values, found, error)
    class(rotation_springs_load), intent(inout) :: self
    include 'set_parameter_arguments.inc'
    call set_spring_constants(name, values, [spread(self%free, 1, 3)], self%stiffness, self%damping, found, error)
  end subroutine set_parameter

  subroutine get_parameter(self, name, values, found)
    class(rotation_springs_load), intent(in) :: self
    include 'get_parameter_arguments.inc'
    call get_spring_constants(name, [spread(self%free, 1, 3)], self%stiffness, self%damping, values, found)
  end subroutine get_parameter

end module rotorcable_loads_rotation_springs
