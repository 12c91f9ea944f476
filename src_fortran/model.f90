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
                                    clamp_bias, clamp_velocity, clamp_wrench, clamp_closure
  use rotorcable_linalg, only: solve_dense, solve_least_norm
  use rotorcable_rotations, only: rotation_log, rotation_exp
  implicit none
  private
  public :: model_type, model_init, eom_residual, generalized_forces, mass_matrix, &
            constraint_residual, constraint_jacobian, constraint_bias, constraint_velocity, &
            solve_accelerations, reactions, total_energy, reaction_wrenches, project_positions, &
            sample_state, &
            project_velocities

  !> Everything a run needs to evaluate the equations of motion; the state is workspace.
  type :: model_type
    type(chain_type) :: chain                 !< bodies and joints
    type(load_type) :: loads                  !< load case
    type(clamp_type) :: clamp                 !< far clamp B
    integer :: nq = 0                         !< number of coordinates
    integer :: nc = 0                         !< number of constraint rows
    type(chain_state) :: st                   !< kinematic workspace
    real(dp), allocatable :: force(:, :)      !< (3,n) body force workspace
    real(dp), allocatable :: g_jac(:, :)      !< (nc,nq) constraint Jacobian workspace
    real(dp), allocatable :: zero_q(:)        !< (nq) zeros: vdot = 0 without a temporary
    real(dp), allocatable :: zero_c(:)        !< (max(nc,1)) zeros: lambda = 0
  end type model_type

contains

  !> Size the model's workspace once the chain, loads and clamp are set.
  subroutine model_init(model)
    type(model_type), intent(inout) :: model  !< model to finish
    model%nq = model%chain%n_coords
    model%nc = clamp_rows(model%clamp)
    call state_allocate(model%chain, model%st)
    allocate (model%force(3, model%chain%n_bodies), model%g_jac(model%nc, model%nq))
    allocate (model%zero_q(model%nq), model%zero_c(max(model%nc, 1)))
    model%zero_q = 0.0_dp
    model%zero_c = 0.0_dp
  end subroutine model_init

  !> Equation-of-motion residual  M vdot - k - G^T lambda  by one inverse-dynamics pass,
  !> O(n), M never formed.  Optionally returns the reaction wrenches at A and B.
  subroutine eom_residual(model, t, q, v, vdot, lambda, res, wrenches, frames_current)
    type(model_type), intent(inout) :: model  !< model
    real(dp), intent(in) :: t                 !< time [s]
    real(dp), intent(in) :: q(:), v(:), vdot(:)  !< coordinates, rates, accelerations
    real(dp), intent(in) :: lambda(:)         !< multipliers (size nc)
    real(dp), intent(out) :: res(:)           !< residual (size nq) [Nm]
    real(dp), intent(out), optional :: wrenches(12)  !< F_A, M_A, F_B, M_B (support on chain)
    logical, intent(in), optional :: frames_current  !< model%st already holds the frames of q
    real(dp) :: f_b(3), m_b(3), f_a(3), m_a(3)
    logical :: skip_positions

    skip_positions = .false.
    if (present(frames_current)) skip_positions = frames_current
    if (.not. skip_positions) call chain_positions(model%chain, q, model%st)
    call chain_motion(model%chain, v, vdot, model%st)
    call body_forces(model%chain, model%loads, model%st%cm, t, model%force)
    ! The tip carries the clamp wrench (closed chain) or an applied tip force (open chain).
    f_b = model%loads%tip_force
    m_b = 0.0_dp
    if (model%nc > 0) call clamp_wrench(model%clamp, model%st, lambda(1:6), f_b, m_b)
    call inverse_dynamics(model%chain, model%st, model%force, f_b, m_b, res, f_a, m_a)
    ! Springs and dampers, eq. 4.79-4.85 (spring_damper_forces), added without a temporary.
    res = res + model%chain%stiffness*(q - model%chain%rest) + model%chain%damping*v
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
  !> With baumgarte_omega = w the constraint rows become Baumgarte's stabilised
  !> gdd + 2 w gd + w^2 g = 0 (the ODE route, ode_integrator).
  subroutine solve_accelerations(model, t, q, v, vdot, lambda, info, baumgarte_omega)
    type(model_type), intent(inout) :: model  !< model
    real(dp), intent(in) :: t                 !< time [s]
    real(dp), intent(in) :: q(:), v(:)        !< coordinates and rates
    real(dp), intent(out) :: vdot(:)          !< accelerations
    real(dp), intent(out) :: lambda(:)        !< multipliers (size nc)
    integer, intent(out) :: info              !< LAPACK status
    real(dp), intent(in), optional :: baumgarte_omega  !< Baumgarte constant w [1/s]
    real(dp) :: a(model%nq + model%nc, model%nq + model%nc), rhs(model%nq + model%nc)
    integer :: nq, nc, k
    nq = model%nq; nc = model%nc
    ! One kinematic pass for everything: frames (M, G, g), then the motion at vdot = 0
    ! (k by inverse dynamics, and Gdot v).
    call chain_positions(model%chain, q, model%st)
    a = 0.0_dp
    call mass_matrix_crba(model%chain, model%st, a(1:nq, 1:nq))
    if (nc > 0) then
      call clamp_jacobian(model%chain, model%clamp, model%st, a(nq + 1:, 1:nq))
      a(1:nq, nq + 1:) = transpose(a(nq + 1:, 1:nq))
    end if
    call eom_residual(model, t, q, v, model%zero_q, model%zero_c, rhs(1:nq), frames_current=.true.)
    rhs(1:nq) = -rhs(1:nq)                    ! k(q, v, t)
    if (nc > 0) then
      rhs(nq + 1:) = -clamp_bias(model%clamp, model%st)
      if (present(baumgarte_omega)) then
        rhs(nq + 1:) = rhs(nq + 1:) - baumgarte_omega**2*clamp_residual(model%clamp, model%st)
        do k = 1, nq
          rhs(nq + 1:) = rhs(nq + 1:) - 2.0_dp*baumgarte_omega*a(nq + 1:, k)*v(k)
        end do
      end if
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

  !> Everything an output sample needs at a state (q, v), in two kinematic passes:
  !> accelerations and multipliers from eq. 3.55, the support wrenches from the
  !> Newton-Euler pass with them, the total energy and max |g| of the position rows.
  !> On return model%st holds the frames of q (CMs for the output tables).
  subroutine sample_state(model, t, q, v, wrenches, energy, g_max, info)
    type(model_type), intent(inout) :: model  !< model
    real(dp), intent(in) :: t                 !< time [s]
    real(dp), intent(in) :: q(:), v(:)        !< coordinates and rates
    real(dp), intent(out) :: wrenches(12)     !< F_A, M_A, F_B, M_B
    real(dp), intent(out) :: energy           !< total mechanical energy [J]
    real(dp), intent(out) :: g_max            !< max |g| of the position rows [m]
    integer, intent(out) :: info              !< LAPACK status of eq. 3.55
    real(dp) :: vdot(model%nq), lambda(max(model%nc, 1)), res(model%nq), g(6)
    lambda = 0.0_dp
    call solve_accelerations(model, t, q, v, vdot, lambda(1:model%nc), info)
    call eom_residual(model, t, q, v, vdot, lambda, res, wrenches, frames_current=.true.)
    energy = kinetic_energy(model) + stored_energy(model, q)
    g_max = 0.0_dp
    if (model%nc > 0) then
      g = clamp_residual(model%clamp, model%st)
      g_max = maxval(abs(g(1:3)))
    end if
  end subroutine sample_state

  !> Kinetic energy sum of m v_C^2/2 + w.Theta w/2 from the velocities in model%st.
  function kinetic_energy(model) result(e)
    type(model_type), intent(in) :: model     !< model with current velocities
    real(dp) :: e
    integer :: j
    e = 0.0_dp
    do j = 1, model%chain%n_bodies
      e = e + 0.5_dp*model%chain%mass(j)*dot_product(model%st%vel_cm(:, j), model%st%vel_cm(:, j)) &
          + 0.5_dp*dot_product(model%st%omega(:, j), world_inertia_times(model%chain, model%st, j, model%st%omega(:, j)))
    end do
  end function kinetic_energy

  !> Total mechanical energy: kinetic + gravitational/centrifugal potential + springs.
  function total_energy(model, q, v) result(e)
    type(model_type), intent(inout) :: model  !< model
    real(dp), intent(in) :: q(:), v(:)        !< coordinates and rates
    real(dp) :: e
    call chain_positions(model%chain, q, model%st)
    call chain_motion(model%chain, v, model%zero_q, model%st)
    e = kinetic_energy(model) + stored_energy(model, q)
  end function total_energy

  !> Potential of the springs, gravity and centrifugal field and of a tip force, at the
  !> frames in model%st.
  function stored_energy(model, q) result(e)
    type(model_type), intent(in) :: model     !< model with current frames
    real(dp), intent(in) :: q(:)              !< coordinates
    real(dp) :: e
    e = potential_energy(model%chain, model%loads, q, model%st%cm) &
        - dot_product(model%loads%tip_force, model%st%joint_point(:, model%chain%n_bodies + 1))
  end function stored_energy

  !> Project q onto g(q) = 0: the smallest change of the deck's shape that closes the chain.
  !> Levenberg-Marquardt on the closure residual (tip - p_B, (E - I) l_s), which has no
  !> spurious half-turn roots, with minimum-norm steps (LAPACK dgelsd on [J; sqrt(mu) I]).
  !> If the direct closure stalls (a far start), the clamp pose is approached by
  !> continuation: the target moves from the start shape's tip pose to p_B, R_B in 8, 32 or
  !> 128 steps (position linearly, orientation along the geodesic R_0 exp(s log(R_0^T R_B)))
  !> and every step is closed from the previous one.  Returns the final max |g|.
  function project_positions(model, q) result(gmax)
    type(model_type), intent(inout) :: model  !< model
    real(dp), intent(inout) :: q(:)           !< coordinates, projected in place
    real(dp) :: gmax
    real(dp) :: q_start(model%nq), p_b(3), r_b(3, 3), p_0(3), r_0(3, 3), w(3), g(max(model%nc, 1)), s, gm
    integer :: n_steps(3), i, k, n
    gmax = 0.0_dp
    if (model%nc == 0) return
    n = model%chain%n_bodies
    q_start = q
    gmax = close_chain(model, q)
    if (gmax <= 1.0e-10_dp) return
    p_b = model%clamp%position
    r_b = model%clamp%rotation
    call chain_positions(model%chain, q_start, model%st)
    p_0 = model%st%joint_point(:, n + 1)
    r_0 = model%st%rot(:, :, n)
    w = rotation_log(matmul(transpose(r_0), r_b))
    n_steps = [8, 32, 128]
    do i = 1, size(n_steps)
      q = q_start
      do k = 1, n_steps(i)
        s = real(k, dp)/n_steps(i)
        model%clamp%position = p_0 + s*(p_b - p_0)
        model%clamp%rotation = matmul(r_0, rotation_exp(s*w))
        gm = close_chain(model, q)
        if (gm > 1.0e-8_dp) exit
      end do
      model%clamp%position = p_b
      model%clamp%rotation = r_b
      if (k > n_steps(i)) then
        gmax = close_chain(model, q)
        if (gmax <= 1.0e-10_dp) return
      end if
    end do
    call constraint_residual(model, q, g)
    gmax = max(maxval(abs(g)), 1.0_dp)
  end function project_positions

  !> Levenberg-Marquardt closure onto the current clamp pose (see project_positions).
  function close_chain(model, q) result(gmax)
    type(model_type), intent(inout) :: model
    real(dp), intent(inout) :: q(:)
    real(dp) :: gmax
    real(dp) :: r(12), r_try(12), r_jac(12, model%nq), a(12 + model%nq, model%nq), b(12 + model%nq)
    real(dp) :: dq(model%nq), q_try(model%nq), mu, g(max(model%nc, 1)), l_s
    integer :: it, info, i, nq
    nq = model%nq
    ! Orientation rows weighted by a length so that metres and radians balance.
    l_s = 0.25_dp*sum(model%chain%length)
    mu = 0.0_dp
    info = 0
    call closure(q, r)
    do it = 1, 300
      if (maxval(abs(r)) < 1.0e-14_dp) exit
      call chain_positions(model%chain, q, model%st)
      call clamp_closure(model%chain, model%clamp, model%st, r, r_jac)
      r(4:12) = l_s*r(4:12)
      r_jac(4:12, :) = l_s*r_jac(4:12, :)
      do
        a = 0.0_dp
        a(1:12, :) = r_jac
        do i = 1, nq
          a(12 + i, i) = sqrt(mu)
        end do
        b = 0.0_dp
        b(1:12) = -r
        call solve_least_norm(a, b, dq, info)
        q_try = q + dq
        call closure(q_try, r_try)
        if (norm2(r_try) < norm2(r) .or. mu > 1.0e8_dp) exit
        mu = max(10.0_dp*mu, 1.0e-6_dp)
      end do
      if (info /= 0 .or. mu > 1.0e8_dp) exit
      q = q_try
      r = r_try
      mu = 0.1_dp*mu
    end do
    call constraint_residual(model, q, g)
    ! A flipped end orientation would also zero g: require E = I as well.
    gmax = max(maxval(abs(g)), maxval(abs(r(4:12)))/l_s)
  contains
    subroutine closure(qq, rr)
      real(dp), intent(in) :: qq(:)
      real(dp), intent(out) :: rr(12)
      real(dp) :: jj(12, model%nq)
      call chain_positions(model%chain, qq, model%st)
      call clamp_closure(model%chain, model%clamp, model%st, rr, jj)
      rr(4:12) = l_s*rr(4:12)
    end subroutine closure
  end function close_chain

  !> Project v onto G(q) v = 0 (minimum-norm change).
  subroutine project_velocities(model, q, v)
    type(model_type), intent(inout) :: model  !< model
    real(dp), intent(in) :: q(:)              !< coordinates
    real(dp), intent(inout) :: v(:)           !< rates, projected in place
    real(dp) :: gv(model%nc), g_jac(model%nc, model%nq), dv(model%nq)
    integer :: info
    if (model%nc == 0) return
    call constraint_velocity(model, q, v, gv)
    call constraint_jacobian(model, q, g_jac)
    call solve_least_norm(g_jac, gv, dv, info)
    v = v - dv
  end subroutine project_velocities

end module rotorcable_model
