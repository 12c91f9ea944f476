!> The assembled multibody model: chain + loads + far clamp, and the quantities of the
!> equations of motion  M(q) qdd = k(q,qd,t) + G(q)^T lambda,  g(q) = 0  (eq. 3.50-3.51).
module rotorcable_model
  use rotorcable_kinds, only: dp
  use rotorcable_chain, only: chain_type
  use rotorcable_kinematics, only: chain_state, state_allocate, chain_positions, chain_motion
  use rotorcable_loads, only: load_type, body_forces, spring_damper_forces, potential_energy
  use rotorcable_inverse_dynamics, only: inverse_dynamics, world_inertia_times
  use rotorcable_mass_matrix, only: mass_matrix_crba
  use rotorcable_constraints, only: clamp_type, clamp_rows, clamp_residual, clamp_jacobian, &
                                    clamp_bias, clamp_velocity, clamp_wrench
  use rotorcable_linalg, only: solve_dense
  implicit none
  private
  public :: model_type, model_init, eom_residual, generalized_forces, mass_matrix, &
            constraint_residual, constraint_jacobian, constraint_bias, constraint_velocity, &
            solve_accelerations, reactions, total_energy, reaction_wrenches

  !> Everything a run needs to evaluate the equations of motion; the state is workspace.
  type :: model_type
    type(chain_type) :: chain                 !< bodies and joints
    type(load_type) :: loads                  !< load case
    type(clamp_type) :: clamp                 !< far clamp B
    integer :: nq = 0                         !< number of coordinates
    integer :: nc = 0                         !< number of constraint rows
    type(chain_state) :: st                   !< kinematic workspace
    real(dp), allocatable :: force(:, :)      !< (3,n) body force workspace
  end type model_type

contains

  !> Size the model's workspace once the chain, loads and clamp are set.
  subroutine model_init(model)
    type(model_type), intent(inout) :: model  !< model to finish
    model%nq = model%chain%n_coords
    model%nc = clamp_rows(model%clamp)
    call state_allocate(model%chain, model%st)
    allocate (model%force(3, model%chain%n_bodies))
  end subroutine model_init

  !> Equation-of-motion residual  M vdot - k - G^T lambda  by one inverse-dynamics pass,
  !> O(n), M never formed.  Optionally returns the reaction wrenches at A and B.
  subroutine eom_residual(model, t, q, v, vdot, lambda, res, wrenches)
    type(model_type), intent(inout) :: model  !< model
    real(dp), intent(in) :: t                 !< time [s]
    real(dp), intent(in) :: q(:), v(:), vdot(:)  !< coordinates, rates, accelerations
    real(dp), intent(in) :: lambda(:)         !< multipliers (size nc)
    real(dp), intent(out) :: res(:)           !< residual (size nq) [Nm]
    real(dp), intent(out), optional :: wrenches(12)  !< F_A, M_A, F_B, M_B (support on chain)
    real(dp) :: f_b(3), m_b(3), f_a(3), m_a(3)

    call chain_positions(model%chain, q, model%st)
    call chain_motion(model%chain, v, vdot, model%st)
    call body_forces(model%chain, model%loads, model%st%cm, t, model%force)
    f_b = 0.0_dp
    m_b = 0.0_dp
    if (model%nc > 0) call clamp_wrench(model%clamp, model%st, lambda(1:6), f_b, m_b)
    call inverse_dynamics(model%chain, model%st, model%force, f_b, m_b, res, f_a, m_a)
    res = res - spring_damper_forces(model%chain, q, v)
    if (present(wrenches)) wrenches = [f_a, m_a, f_b, m_b]
  end subroutine eom_residual

  !> Generalized applied and velocity forces k(q,qd,t) = -(residual at vdot = 0, lambda = 0).
  subroutine generalized_forces(model, t, q, v, k)
    type(model_type), intent(inout) :: model  !< model
    real(dp), intent(in) :: t                 !< time [s]
    real(dp), intent(in) :: q(:), v(:)        !< coordinates and rates
    real(dp), intent(out) :: k(:)             !< generalized forces
    real(dp) :: zero_lambda(max(model%nc, 1))
    zero_lambda = 0.0_dp
    call eom_residual(model, t, q, v, 0.0_dp*v, zero_lambda, k)
    k = -k
  end subroutine generalized_forces

  !> Mass matrix by the composite-rigid-body algorithm.
  subroutine mass_matrix(model, q, m)
    type(model_type), intent(inout) :: model  !< model
    real(dp), intent(in) :: q(:)              !< coordinates
    real(dp), intent(out) :: m(:, :)          !< (nq,nq)
    call chain_positions(model%chain, q, model%st)
    call mass_matrix_crba(model%chain, model%st, m)
  end subroutine mass_matrix

  !> Constraint residual g(q).
  subroutine constraint_residual(model, q, g)
    type(model_type), intent(inout) :: model  !< model
    real(dp), intent(in) :: q(:)              !< coordinates
    real(dp), intent(out) :: g(:)             !< (nc)
    if (model%nc == 0) return
    call chain_positions(model%chain, q, model%st)
    g = clamp_residual(model%clamp, model%st)
  end subroutine constraint_residual

  !> Constraint Jacobian G(q).
  subroutine constraint_jacobian(model, q, g_jac)
    type(model_type), intent(inout) :: model  !< model
    real(dp), intent(in) :: q(:)              !< coordinates
    real(dp), intent(out) :: g_jac(:, :)      !< (nc,nq)
    if (model%nc == 0) return
    call chain_positions(model%chain, q, model%st)
    call clamp_jacobian(model%chain, model%clamp, model%st, g_jac)
  end subroutine constraint_jacobian

  !> Constraint velocity G(q) v.
  subroutine constraint_velocity(model, q, v, gv)
    type(model_type), intent(inout) :: model  !< model
    real(dp), intent(in) :: q(:), v(:)        !< coordinates and rates
    real(dp), intent(out) :: gv(:)            !< (nc)
    if (model%nc == 0) return
    call chain_positions(model%chain, q, model%st)
    call chain_motion(model%chain, v, 0.0_dp*v, model%st)
    gv = clamp_velocity(model%clamp, model%st)
  end subroutine constraint_velocity

  !> Bias term Gdot(q,v) v of the acceleration-level constraint (eq. 3.54, 4.103).
  subroutine constraint_bias(model, q, v, gb)
    type(model_type), intent(inout) :: model  !< model
    real(dp), intent(in) :: q(:), v(:)        !< coordinates and rates
    real(dp), intent(out) :: gb(:)            !< (nc)
    if (model%nc == 0) return
    call chain_positions(model%chain, q, model%st)
    call chain_motion(model%chain, v, 0.0_dp*v, model%st)
    gb = clamp_bias(model%clamp, model%st)
  end subroutine constraint_bias

  !> Accelerations and multipliers from the acceleration-level system, eq. 3.55:
  !>   [M G^T; G 0] [vdot; -lambda] = [k; -Gdot v]
  !> (eq. 3.56/3.57 without forming inverses).  info /= 0 if the system is singular.
  subroutine solve_accelerations(model, t, q, v, vdot, lambda, info)
    type(model_type), intent(inout) :: model  !< model
    real(dp), intent(in) :: t                 !< time [s]
    real(dp), intent(in) :: q(:), v(:)        !< coordinates and rates
    real(dp), intent(out) :: vdot(:)          !< accelerations
    real(dp), intent(out) :: lambda(:)        !< multipliers (size nc)
    integer, intent(out) :: info              !< LAPACK status
    real(dp) :: a(model%nq + model%nc, model%nq + model%nc), rhs(model%nq + model%nc)
    integer :: nq, nc
    nq = model%nq; nc = model%nc
    a = 0.0_dp
    call mass_matrix(model, q, a(1:nq, 1:nq))
    call generalized_forces(model, t, q, v, rhs(1:nq))
    if (nc > 0) then
      call constraint_jacobian(model, q, a(nq + 1:, 1:nq))
      a(1:nq, nq + 1:) = transpose(a(nq + 1:, 1:nq))
      call constraint_bias(model, q, v, rhs(nq + 1:))
      rhs(nq + 1:) = -rhs(nq + 1:)
    end if
    call solve_dense(a, rhs, info)
    vdot = rhs(1:nq)
    if (nc > 0) lambda = -rhs(nq + 1:)
  end subroutine solve_accelerations

  !> Support wrenches (F_A, M_A about A, F_B, M_B about B) for a consistent state.
  subroutine reaction_wrenches(model, t, q, v, vdot, lambda, wrenches)
    type(model_type), intent(inout) :: model  !< model
    real(dp), intent(in) :: t                 !< time [s]
    real(dp), intent(in) :: q(:), v(:), vdot(:)  !< state and accelerations
    real(dp), intent(in) :: lambda(:)         !< multipliers
    real(dp), intent(out) :: wrenches(12)     !< F_A, M_A, F_B, M_B
    real(dp) :: res(model%nq)
    call eom_residual(model, t, q, v, vdot, lambda, res, wrenches)
  end subroutine reaction_wrenches

  !> Reactions at a state (q, v): accelerations and multipliers from eq. 3.55, then the
  !> support wrenches from the Newton-Euler backward pass.
  subroutine reactions(model, t, q, v, wrenches, info)
    type(model_type), intent(inout) :: model  !< model
    real(dp), intent(in) :: t                 !< time [s]
    real(dp), intent(in) :: q(:), v(:)        !< coordinates and rates
    real(dp), intent(out) :: wrenches(12)     !< F_A, M_A, F_B, M_B
    integer, intent(out) :: info              !< LAPACK status
    real(dp) :: vdot(model%nq), lambda(max(model%nc, 1))
    lambda = 0.0_dp
    call solve_accelerations(model, t, q, v, vdot, lambda(1:model%nc), info)
    call reaction_wrenches(model, t, q, v, vdot, lambda, wrenches)
  end subroutine reactions

  !> Total mechanical energy: kinetic + gravitational/centrifugal potential + springs.
  function total_energy(model, q, v) result(e)
    type(model_type), intent(inout) :: model  !< model
    real(dp), intent(in) :: q(:), v(:)        !< coordinates and rates
    real(dp) :: e
    integer :: j
    call chain_positions(model%chain, q, model%st)
    call chain_motion(model%chain, v, 0.0_dp*v, model%st)
    e = potential_energy(model%chain, model%loads, q, model%st%cm)
    do j = 1, model%chain%n_bodies
      e = e + 0.5_dp*model%chain%mass(j)*dot_product(model%st%vel_cm(:, j), model%st%vel_cm(:, j)) &
          + 0.5_dp*dot_product(model%st%omega(:, j), world_inertia_times(model%chain, model%st, j, model%st%omega(:, j)))
    end do
  end function total_energy

end module rotorcable_model
