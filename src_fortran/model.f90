!> The assembled multibody model: chain, supports, loads, rotor and frame, and the quantities
!> of the equations of motion  M(q) qdd = k(q,qd,t) + G(q,t)^T lambda,  g(q,t) = 0
!> (eq. 3.50-3.51; with a moving clamp the constraints are rheonomic).
!>
!> Every evaluation at a time t first prepares the model for t (model_prepare): rotor state,
!> frame motion, base pose and the seed of the forward recursion, the far support's pose.
!> Then one kinematic pass, the loads and one Newton-Euler backward pass give the residual.
!>
!> The workspace (frames, motion and joint wrenches in model%st, the applied forces) is shared
!> by every evaluation, and model%ws records which state it holds (issue 23 item 2: no routine
!> relies on a caller having evaluated "the same state" before it).  A routine that reads the
!> workspace names the state it needs, (t, q), (t, q, v) or (t, q, v, vdot, lambda), and
!> evaluates it only when the record says the workspace holds another: eom_residual skips the
!> positions of a q whose frames are there, eom_residual_tangent starts from its own base
!> point, and the constraint rows, energies, joint loads and shapes each ask for theirs.  The
!> record costs a copy of the state per evaluation and a comparison where it is read.
module rotorcable_model
  use, intrinsic :: iso_fortran_env, only: int64
  use rotorcable_kinds, only: dp
  use rotorcable_chain, only: chain_type
  use rotorcable_kinematics, only: chain_state, state_allocate, chain_positions, chain_motion, motion_seed
  use rotorcable_inverse_dynamics, only: inverse_dynamics, world_inertia_times
  use rotorcable_kinematics_tangent, only: chain_tangent, tangent_allocate, positions_tangent, motion_tangent
  use rotorcable_inverse_dynamics_tangent, only: inverse_dynamics_tangent, inertia_linearisation, linearise_inertia
  use rotorcable_chain_tangent_columns, only: tangent_columns
  use rotorcable_inverse_dynamics_derivatives, only: derivatives_work
  use rotorcable_mass_matrix, only: mass_matrix_crba
  use rotorcable_linalg, only: solve_dense
  use rotorcable_rotations, only: cross
  use rotorcable_frame, only: frame_type, frame_state, frame_at, relative_velocity
  use rotorcable_motion_rotor, only: rotor_type, rotor_state, rotor_at, rotor_free
  use rotorcable_supports_base, only: base_support, base_pose, base_free
  use rotorcable_supports_type, only: support_type
  use rotorcable_loads_type, only: load_slot
  implicit none
  private
  public :: support_b_key
  public :: model_type, model_init, model_prepare, model_free, eom_residual, eom_residual_tangent, &
            generalized_forces, mass_matrix, &
            constraint_residual, constraint_jacobian, constraint_bias, constraint_velocity, &
            solve_accelerations, positions_at, total_energy, &
            switch_times, joint_diagonal, all_conservative, model_stale, state_motion, state_energies, &
            workspace_holds, tangent_base_point, HOLDS_FRAMES, HOLDS_MOTION, HOLDS_EOM, add_load_forces, &
            applied_generalized_forces, &
            other_bodies_residual

  !> What the workspace holds, in increasing order: nothing; the frames (positions) of (t, q);
  !> also the velocities of v (accelerations of some vdot); also the forces, accelerations and
  !> joint wrenches of eom_residual at (t, q, v, vdot, lambda).
  integer, parameter :: HOLDS_NOTHING = 0, HOLDS_FRAMES = 1, HOLDS_MOTION = 2, HOLDS_EOM = 3

  !> The state the workspace was last filled for (written by every routine that fills it).
  type :: workspace_record
    integer :: holds = HOLDS_NOTHING
    logical :: solved = .false.               !< vdot, lambda are eq. 3.55's at (t, q, v) (sampling)
    logical :: linearised = .false.           !< the loads have linearised at the state (tangents)
    real(dp) :: t = 0.0_dp
    real(dp), allocatable :: q(:), v(:), vdot(:), lambda(:)
  end type workspace_record

  !> Everything a run needs to evaluate the equations of motion; the state is workspace.
  type :: model_type
    type(chain_type) :: chain                 !< bodies and joints
    type(base_support) :: base                !< support A (locked base, may move)
    class(support_type), allocatable :: support_b  !< support B (none: a free end, no rows)
    type(load_slot), allocatable :: loads(:)  !< applied loads
    type(rotor_type) :: rotor                 !< rotor speed and centre
    type(frame_type) :: frame                 !< inertial or hub frame
    integer :: nq = 0                         !< number of coordinates
    integer :: nc = 0                         !< number of constraint rows
    ! The time the model was last prepared for, and what was prepared:
    logical :: prepared = .false.
    real(dp) :: t_prepared = 0.0_dp
    type(rotor_state) :: rs                   !< rotor angle, speed, acceleration
    type(frame_state) :: fs                   !< frame motion
    real(dp) :: base_rot(3, 3) = 0.0_dp       !< R_0(t)
    real(dp) :: base_pos(3) = 0.0_dp          !< P_1(t) [m]
    type(motion_seed) :: seed                 !< absolute motion of the base
    real(dp) :: base_vel(3) = 0.0_dp          !< velocity of P_1 relative to the frame [m/s]
    real(dp) :: base_omega(3) = 0.0_dp        !< angular velocity of the base relative to the frame
    ! Workspace:
    type(chain_state) :: st                   !< kinematic state
    type(workspace_record) :: ws              !< which state st and the forces hold
    real(dp), allocatable :: force(:, :)      !< (3,n) applied forces at the CMs
    real(dp), allocatable :: moment(:, :)     !< (3,n) applied moments
    real(dp), allocatable :: tau(:)           !< (nq) applied generalized forces
    real(dp), allocatable :: zero_q(:)        !< (nq) zeros
    real(dp), allocatable :: zero_c(:)        !< (max(nc,1)) zeros
    type(chain_tangent) :: dst                !< first-order change of st (analytic Jacobian)
    real(dp), allocatable :: dforce(:, :)     !< (3,n) change of the applied forces
    real(dp), allocatable :: dmoment(:, :)    !< (3,n) change of the applied moments
    real(dp), allocatable :: dtau(:)          !< (nq) change of the applied generalized forces
    type(inertia_linearisation) :: lin_inertia  !< the tangent pass's state-only factors
    type(tangent_columns) :: dst_columns      !< a block of columns' changes (ggl_residual_tangent_columns)
    type(derivatives_work) :: derivs          !< the whole-matrix derivatives' arrays (rotorcable_model_derivatives)
  end type model_type

contains

  !> The deck key of support B's position, for messages about reaching it ('' without support B).
  function support_b_key(model) result(key)
    type(model_type), intent(in) :: model     !< the model
    character(len=:), allocatable :: key
    key = ''
    if (allocated(model%support_b)) key = trim(model%support_b%position_key)
  end function support_b_key

  !> Size the model's workspace once the chain, supports and loads are set (again after a
  !> support was added).
  subroutine model_init(model)
    type(model_type), intent(inout) :: model  !< model to finish
    model%nq = model%chain%n_coords
    model%nc = 0
    if (allocated(model%support_b)) model%nc = model%support_b%rows()
    if (.not. allocated(model%loads)) allocate (model%loads(0))
    call state_allocate(model%chain, model%st)
    call tangent_allocate(model%chain, model%dst)
    if (allocated(model%force)) deallocate (model%force, model%moment, model%tau, model%zero_q, model%zero_c, &
                                            model%dforce, model%dmoment, model%dtau)
    allocate (model%force(3, model%chain%n_bodies), model%moment(3, model%chain%n_bodies), model%tau(model%nq))
    allocate (model%dforce(3, model%chain%n_bodies), model%dmoment(3, model%chain%n_bodies), model%dtau(model%nq))
    allocate (model%zero_q(model%nq), model%zero_c(max(model%nc, 1)))
    model%ws = workspace_record()
    allocate (model%ws%q(model%nq), model%ws%v(model%nq), model%ws%vdot(model%nq), model%ws%lambda(model%nc))
    model%ws%q = 0.0_dp; model%ws%v = 0.0_dp; model%ws%vdot = 0.0_dp; model%ws%lambda = 0.0_dp
    model%zero_q = 0.0_dp
    model%zero_c = 0.0_dp
    model%prepared = .false.
  end subroutine model_init

  !> Release the C memory of the model's table splines.
  subroutine model_free(model)
    type(model_type), intent(inout) :: model  !< model
    call rotor_free(model%rotor)
    call base_free(model%base)
    if (allocated(model%support_b)) call model%support_b%free()
  end subroutine model_free

  !> Evaluate everything that depends on time alone (once per distinct t).
  subroutine model_prepare(model, t)
    type(model_type), intent(inout) :: model  !< model
    real(dp), intent(in) :: t                 !< time [s]
    if (model%prepared .and. t == model%t_prepared) return
    model%rs = rotor_at(model%rotor, t)
    model%fs = frame_at(model%frame, model%rs)
    call base_pose(model%base, t, model%rs, model%fs, model%base_rot, model%base_pos, model%seed, model%base_vel, &
                   model%base_omega)
    if (allocated(model%support_b)) call model%support_b%update(t, model%rs)
    model%prepared = .true.
    model%t_prepared = t
  end subroutine model_prepare

  !> After a parameter changed (rotorcable_model_update): nothing prepared for time t and
  !> nothing in the workspace is current any more.
  subroutine model_stale(model)
    type(model_type), intent(inout) :: model  !< model
    model%prepared = .false.
    model%ws%holds = HOLDS_NOTHING
    model%ws%solved = .false.
    model%ws%linearised = .false.
  end subroutine model_stale

  !> Whether the workspace holds at least `level` of the state given (frames: t, q; motion:
  !> also v; eom: also vdot, lambda).  Equal means the same bits (a -0 is not a +0).
  logical function workspace_holds(model, level, t, q, v, vdot, lambda) result(yes)
    type(model_type), intent(in) :: model     !< model
    integer, intent(in) :: level              !< HOLDS_FRAMES, HOLDS_MOTION or HOLDS_EOM
    real(dp), intent(in) :: t                 !< time [s]
    real(dp), intent(in) :: q(:)              !< coordinates
    real(dp), intent(in), optional :: v(:), vdot(:), lambda(:)  !< rates, accelerations, multipliers (nc)
    yes = model%ws%holds >= level .and. model%prepared .and. same_bits(t, model%ws%t) &
          .and. same_bits(t, model%t_prepared)
    if (yes) yes = same(q, model%ws%q)
    if (yes .and. present(v)) yes = same(v, model%ws%v)
    if (yes .and. present(vdot)) yes = same(vdot, model%ws%vdot)
    if (yes .and. present(lambda)) yes = same(lambda(1:model%nc), model%ws%lambda)
  end function workspace_holds

  !> Frames, joint points and CMs of q at time t (in model%st); nothing is evaluated when the
  !> workspace holds them already.
  subroutine positions_at(model, t, q)
    type(model_type), intent(inout) :: model  !< model
    real(dp), intent(in) :: t                 !< time [s]
    real(dp), intent(in) :: q(:)              !< coordinates [rad]
    call model_prepare(model, t)
    if (workspace_holds(model, HOLDS_FRAMES, t, q)) return
    call chain_positions(model%chain, model%base_rot, model%base_pos, q, model%st)
    call record(model, HOLDS_FRAMES, t, q)
  end subroutine positions_at

  !> Frames of q and velocities of v at time t in model%st (accelerations of vdot = 0 where they
  !> are evaluated here): what the constraint rows and the energies read.
  subroutine state_motion(model, t, q, v)
    type(model_type), intent(inout) :: model  !< model
    real(dp), intent(in) :: t                 !< time [s]
    real(dp), intent(in) :: q(:), v(:)        !< coordinates and rates
    if (workspace_holds(model, HOLDS_MOTION, t, q, v)) return
    call positions_at(model, t, q)
    call chain_motion(model%chain, model%seed, v, model%zero_q, model%st)
    call record(model, HOLDS_MOTION, t, q, v, model%zero_q)
  end subroutine state_motion

  !> Kinetic energy relative to the model frame and potential energy at (q, v, t).
  subroutine state_energies(model, t, q, v, kinetic, potential)
    type(model_type), intent(inout) :: model  !< model
    real(dp), intent(in) :: t                 !< time [s]
    real(dp), intent(in) :: q(:), v(:)        !< coordinates and rates
    real(dp), intent(out) :: kinetic          !< kinetic energy [J]
    real(dp), intent(out) :: potential        !< potential energy [J]
    call state_motion(model, t, q, v)
    kinetic = kinetic_energy(model)
    potential = stored_energy(model, q)
  end subroutine state_energies

  !> Note what the workspace now holds (the state copied; a lower level forgets the rest).
  subroutine record(model, level, t, q, v, vdot, lambda)
    type(model_type), intent(inout) :: model
    integer, intent(in) :: level
    real(dp), intent(in) :: t
    real(dp), intent(in) :: q(:)
    real(dp), intent(in), optional :: v(:), vdot(:), lambda(:)
    model%ws%holds = level
    model%ws%solved = .false.
    model%ws%linearised = .false.
    model%ws%t = t
    model%ws%q(:) = q                       ! (:): no reallocation check, the sizes are the model's
    if (present(v)) model%ws%v(:) = v
    if (present(vdot)) model%ws%vdot(:) = vdot
    if (present(lambda)) model%ws%lambda(:) = lambda(1:model%nc)
  end subroutine record

  !> a and b hold the same bits (NaN never matches; -0 and +0 differ).  Two loops without an
  !> early exit or a short-circuit, so that the compiler vectorises both: the bits' differences
  !> ored, then (equal bits only) the NaNs counted.  The record is read ~10^5 times a run
  !> (every residual and tangent), and equal states, the common case, read it all (one loop
  !> with the NaN test in it compiled to a branch per element: 430 instructions for 33 values).
  pure logical function same(a, b)
    real(dp), intent(in) :: a(:), b(:)
    integer(int64) :: differ
    integer :: i, nans
    same = size(a) == size(b)
    if (.not. same) return
    differ = 0_int64
    do i = 1, size(a)
      differ = ior(differ, ieor(transfer(a(i), 0_int64), transfer(b(i), 0_int64)))
    end do
    same = differ == 0_int64
    if (.not. same) return
    nans = 0
    do i = 1, size(a)
      nans = nans + merge(1, 0, a(i) /= a(i))
    end do
    same = nans == 0
  end function same

  pure logical function same_bits(a, b)
    real(dp), intent(in) :: a, b
    same_bits = a == b .and. sign(1.0_dp, a) == sign(1.0_dp, b)
  end function same_bits

  !> Equation-of-motion residual  M vdot - k - G^T lambda  by one inverse-dynamics pass,
  !> O(n), M never formed.  Optionally returns the support wrenches at A and B; the wrench
  !> of every parent on its child is left in model%st (joint_force, joint_moment), and the
  !> workspace record says so.  The positions are reused when the workspace holds q's frames.
  subroutine eom_residual(model, t, q, v, vdot, lambda, res, wrenches)
    type(model_type), intent(inout) :: model  !< model
    real(dp), intent(in) :: t                 !< time [s]
    real(dp), intent(in) :: q(:), v(:), vdot(:)  !< coordinates, rates, accelerations
    real(dp), intent(in) :: lambda(:)         !< multipliers (size nc)
    real(dp), intent(out) :: res(:)           !< residual (size nq) [Nm]
    real(dp), intent(out), optional :: wrenches(12)  !< F_A, M_A, F_B, M_B (support on chain)
    real(dp) :: f_b(3), m_b(3), f_a(3), m_a(3)
    integer :: i

    call positions_at(model, t, q)
    call chain_motion(model%chain, model%seed, v, vdot, model%st)
    model%force = 0.0_dp
    model%moment = 0.0_dp
    model%tau = 0.0_dp
    do i = 1, size(model%loads)
      call model%loads(i)%term%add_forces(model%chain, model%st, model%fs, t, q, v, model%force, model%moment, &
                                          model%tau)
    end do
    f_b = 0.0_dp
    m_b = 0.0_dp
    if (model%nc > 0) call model%support_b%wrench(model%chain, model%st, lambda(1:model%nc), f_b, m_b)
    call newton_euler(model, model%force, model%moment, f_b, m_b, res, f_a, m_a)
    res = res - model%tau
    if (present(wrenches)) wrenches = [f_a, m_a, f_b, m_b]
    call record(model, HOLDS_EOM, t, q, v, vdot, lambda)
  end subroutine eom_residual

  !> The pass a tangent is taken about: eom_residual at (t, q, v, vdot, lambda), evaluated here
  !> unless the workspace holds it (or `held`: an earlier column of the same point was just
  !> taken; comparing the record costs ~5 % of a column), and the loads', support's and
  !> inertias' state-only factors (linearise), once per state for all the columns taken there.
  subroutine tangent_base_point(model, t, q, v, vdot, lambda, held)
    type(model_type), intent(inout) :: model  !< model
    real(dp), intent(in) :: t                 !< time [s]
    real(dp), intent(in) :: q(:), v(:), vdot(:)  !< coordinates, rates, accelerations
    real(dp), intent(in) :: lambda(:)         !< multipliers (size nc)
    logical, intent(in), optional :: held     !< the workspace holds the point (not compared)
    real(dp) :: scratch(model%nq)
    integer :: i
    logical :: known
    known = .false.
    if (present(held)) known = held
    if (.not. known) known = workspace_holds(model, HOLDS_EOM, t, q, v, vdot, lambda)
    if (.not. known) call eom_residual(model, t, q, v, vdot, lambda, scratch)
    if (.not. model%ws%linearised) then
      do i = 1, size(model%loads)
        call model%loads(i)%term%linearise(model%chain, model%st, model%fs, q, v)
      end do
      if (model%nc > 0) call model%support_b%linearise(model%chain, model%st)
      if (model%fs%rotating .and. .not. model%fs%body_couples) then
        call linearise_inertia(model%chain, model%st, model%lin_inertia, model%fs%omega, model%fs%omega_dot)
      else
        call linearise_inertia(model%chain, model%st, model%lin_inertia)
      end if
      model%ws%linearised = .true.
    end if
  end subroutine tangent_base_point

  !> First-order change of eom_residual's residual for the change (dq, dv, dvdot, dlambda) of its
  !> arguments, O(n): the tangent of the kinematics, of every load, of clamp B's wrench and of
  !> the Newton-Euler pass, about eom_residual's pass at (t, q, v, vdot, lambda): evaluated
  !> here unless the workspace holds it (so a Jacobian's columns share one pass).  model%dst is
  !> left holding the state's change (for the constraint rows).  dq, dv and dvdot must vanish on
  !> the joints before body `first` (a column of the Jacobian starts there; 1 for any direction).
  subroutine eom_residual_tangent(model, t, q, v, vdot, lambda, dq, dv, dvdot, dlambda, first, dres, held)
    type(model_type), intent(inout) :: model  !< model
    real(dp), intent(in) :: t                 !< time [s]
    real(dp), intent(in) :: q(:), v(:), vdot(:)  !< coordinates, rates, accelerations (the base point)
    real(dp), intent(in) :: lambda(:)         !< multipliers (size nc)
    real(dp), intent(in) :: dq(:), dv(:), dvdot(:)  !< their change
    real(dp), intent(in) :: dlambda(:)        !< change of the multipliers
    integer, intent(in) :: first              !< first body whose joint has dq, dv /= 0
    real(dp), intent(out) :: dres(:)          !< (nq) change of the residual
    !> the workspace holds the base point: an earlier column of the same point was just taken
    !> (comparing the record costs ~5 % of a column)
    logical, intent(in), optional :: held
    real(dp) :: f_b(3), m_b(3), df_b(3), dm_b(3)
    integer :: i
    call tangent_base_point(model, t, q, v, vdot, lambda, held)
    call positions_tangent(model%chain, model%st, dq, first, model%dst)
    call motion_tangent(model%chain, model%seed, model%st, v, vdot, dv, dvdot, model%dst)
    model%dforce = 0.0_dp
    model%dmoment = 0.0_dp
    model%dtau = 0.0_dp
    do i = 1, size(model%loads)
      call model%loads(i)%term%add_force_tangent(model%chain, model%st, model%dst, model%fs, t, q, v, dq, dv, &
                                                 model%dforce, model%dmoment, model%dtau)
    end do
    f_b = 0.0_dp; df_b = 0.0_dp; dm_b = 0.0_dp
    if (model%nc > 0) then
      call model%support_b%wrench(model%chain, model%st, lambda(1:model%nc), f_b, m_b)
      call model%support_b%wrench_tangent(model%chain, model%st, model%dst, lambda(1:model%nc), dlambda(1:model%nc), &
                                    df_b, dm_b)
    end if
    if (model%fs%rotating .and. .not. model%fs%body_couples) then
      call inverse_dynamics_tangent(model%chain, model%st, model%lin_inertia, model%dst, model%force, model%dforce, &
                                    model%dmoment, f_b, &
                                    df_b, dm_b, dres, model%fs%omega, model%fs%omega_dot)
    else
      call inverse_dynamics_tangent(model%chain, model%st, model%lin_inertia, model%dst, model%force, model%dforce, &
                                    model%dmoment, f_b, &
                                    df_b, dm_b, dres)
    end if
    dres = dres - model%dtau
  end subroutine eom_residual_tangent

  !> Add weight x the forces of `loads` at this model's state (t, q, v) to (force, moment, tau).
  !> The loads may be another model's built on the same chain, supports and motions (a design
  !> parameter's rebuilt models, rotorcable_parameter_sensitivity): they read this model's
  !> frames and velocities, which is what they would compute themselves.
  subroutine add_load_forces(model, loads, weight, t, q, v, force, moment, tau, only)
    type(model_type), intent(inout) :: model  !< model whose kinematics the loads read
    type(load_slot), intent(in) :: loads(:)   !< the loads
    real(dp), intent(in) :: weight            !< factor of their forces
    real(dp), intent(in) :: t                 !< time [s]
    real(dp), intent(in) :: q(:), v(:)        !< coordinates and rates
    real(dp), intent(inout) :: force(:, :), moment(:, :), tau(:)  !< (3,n), (3,n), (nq) sums
    logical, intent(in), optional :: only(:)  !< the loads to add (slot i where only(i); default all)
    real(dp) :: f(3, model%chain%n_bodies), m(3, model%chain%n_bodies), tq(model%nq)
    integer :: i
    call state_motion(model, t, q, v)
    f = 0.0_dp; m = 0.0_dp; tq = 0.0_dp
    do i = 1, size(loads)
      if (present(only)) then
        if (.not. only(i)) cycle
      end if
      call loads(i)%term%add_forces(model%chain, model%st, model%fs, t, q, v, f, m, tq)
    end do
    force = force + weight*f
    moment = moment + weight*m
    tau = tau + weight*tq
  end subroutine add_load_forces

  !> Generalized forces Q = J^T (force, moment) + tau of forces at the CMs, moments and joint
  !> torques, at this model's state (t, q, v), by one backward pass of the applied loads alone
  !> (the load terms of the Newton-Euler pass, eq. 3.24, 4.52, whose inertia and frame terms
  !> do not depend on them): the outboard force F_j = F_{j+1} + f_j and moment about P_j
  !> N_j = N_{j+1} + (P_{j+1} - P_j) x F_{j+1} + m_j + (C_j - P_j) x f_j, and Q_k = a_k . N_j
  !> for joint j's axes (all joints turn).  The joint wrenches of the workspace are left alone.
  subroutine applied_generalized_forces(model, t, q, v, force, moment, tau, gen)
    type(model_type), intent(inout) :: model  !< model
    real(dp), intent(in) :: t                 !< time [s]
    real(dp), intent(in) :: q(:), v(:)        !< coordinates and rates
    real(dp), intent(in) :: force(:, :), moment(:, :), tau(:)  !< (3,n), (3,n), (nq)
    real(dp), intent(out) :: gen(:)           !< (nq) Q [Nm]
    real(dp) :: f_out(3), n_out(3), link(3), arm(3), f(3)
    integer :: j, k, i0
    call state_motion(model, t, q, v)
    f_out = 0.0_dp
    n_out = 0.0_dp
    do j = model%chain%n_bodies, 1, -1
      ! Fixed-size copies: cross products of array sections make heap temporaries.
      link = model%st%joint_point(:, j + 1) - model%st%joint_point(:, j)
      arm = model%st%cm(:, j) - model%st%joint_point(:, j)
      f = force(:, j)
      n_out = n_out + cross(link, f_out) + moment(:, j) + cross(arm, f)
      f_out = f_out + f
      i0 = model%chain%first_coord(j) - 1
      do k = 1, model%chain%n_joint_coords(j)
        gen(i0 + k) = dot_product(model%st%axes(:, k, j), n_out) + tau(i0 + k)
      end do
    end do
  end subroutine applied_generalized_forces

  !> The equation-of-motion residual of `other`, a model with this one's kinematics (geometry,
  !> joints, supports, rotor) but its own bodies' masses and inertias and its own loads, at this
  !> model's motion (t, q, v, vdot), without support B's wrench and with the load slots `only`
  !> (the terms a difference over such models shares: they cancel).  Other's Newton-Euler pass
  !> runs on this model's frames and motion, which are what it would compute itself; the joint
  !> wrenches it writes are put back, so the workspace holds what it held (the tangents that
  !> follow a parameter partial at the same state reuse its pass and linearisation).
  subroutine other_bodies_residual(model, other, t, q, v, vdot, only, res)
    type(model_type), intent(inout) :: model  !< model whose kinematics are used
    type(model_type), intent(in) :: other     !< model whose bodies and loads are used
    real(dp), intent(in) :: t                 !< time [s]
    real(dp), intent(in) :: q(:), v(:), vdot(:)  !< coordinates, rates, accelerations
    logical, intent(in) :: only(:)            !< other's load slots to add
    real(dp), intent(out) :: res(:)           !< (nq) residual without the support's wrench [Nm]
    real(dp) :: f(3, model%chain%n_bodies), m(3, model%chain%n_bodies), tq(model%nq), zero(3), f_a(3), m_a(3)
    real(dp) :: kept_force(3, model%chain%n_bodies), kept_moment(3, model%chain%n_bodies)
    integer :: i
    if (.not. (workspace_holds(model, HOLDS_MOTION, t, q, v) .and. same(vdot, model%ws%vdot))) then
      call positions_at(model, t, q)
      call chain_motion(model%chain, model%seed, v, vdot, model%st)
      call record(model, HOLDS_MOTION, t, q, v, vdot)
    end if
    f = 0.0_dp; m = 0.0_dp; tq = 0.0_dp; zero = 0.0_dp
    do i = 1, size(other%loads)
      if (.not. only(i)) cycle
      call other%loads(i)%term%add_forces(other%chain, model%st, model%fs, t, q, v, f, m, tq)   ! other's bodies
    end do
    kept_force = model%st%joint_force
    kept_moment = model%st%joint_moment
    if (model%fs%rotating .and. .not. model%fs%body_couples) then
      call inverse_dynamics(other%chain, model%st, f, m, zero, zero, res, f_a, m_a, model%fs%omega, model%fs%omega_dot)
    else
      call inverse_dynamics(other%chain, model%st, f, m, zero, zero, res, f_a, m_a)
    end if
    model%st%joint_force = kept_force
    model%st%joint_moment = kept_moment
    res = res - tq
  end subroutine other_bodies_residual

  !> The Newton-Euler pass of the workspace's motion under the applied forces and support B's
  !> wrench, in the model frame's form (a turning frame's rate left out of the couples unless
  !> the bodies carry them): joint torques and the base's wrench.
  subroutine newton_euler(model, force, moment, f_b, m_b, res, f_a, m_a)
    type(model_type), intent(inout) :: model  !< model
    real(dp), intent(in) :: force(:, :), moment(:, :)  !< (3,n) applied forces and moments
    real(dp), intent(in) :: f_b(3), m_b(3)    !< support B's wrench on the chain
    real(dp), intent(out) :: res(:)           !< (nq) joint torques of the pass
    real(dp), intent(out) :: f_a(3), m_a(3)   !< the base's wrench on body 1
    if (model%fs%rotating .and. .not. model%fs%body_couples) then
      call inverse_dynamics(model%chain, model%st, force, moment, f_b, m_b, res, f_a, m_a, &
                            model%fs%omega, model%fs%omega_dot)
    else
      call inverse_dynamics(model%chain, model%st, force, moment, f_b, m_b, res, f_a, m_a)
    end if
  end subroutine newton_euler

  !> Generalized applied and velocity forces k(q,qd,t) = -(residual at vdot = 0, lambda = 0).
  subroutine generalized_forces(model, t, q, v, k)
    type(model_type), intent(inout) :: model  !< model
    real(dp), intent(in) :: t                 !< time [s]
    real(dp), intent(in) :: q(:), v(:)        !< coordinates and rates
    real(dp), intent(out) :: k(:)             !< generalized forces
    call eom_residual(model, t, q, v, model%zero_q, model%zero_c, k)
    k = -k
  end subroutine generalized_forces

  !> Mass matrix by the composite-rigid-body algorithm.
  subroutine mass_matrix(model, t, q, m)
    type(model_type), intent(inout) :: model  !< model
    real(dp), intent(in) :: t                 !< time [s] (the base may move)
    real(dp), intent(in) :: q(:)              !< coordinates
    real(dp), intent(out) :: m(:, :)          !< (nq,nq)
    call positions_at(model, t, q)
    call mass_matrix_crba(model%chain, model%st, m)
  end subroutine mass_matrix

  !> Constraint residual g(q, t).
  subroutine constraint_residual(model, t, q, g)
    type(model_type), intent(inout) :: model  !< model
    real(dp), intent(in) :: t                 !< time [s]
    real(dp), intent(in) :: q(:)              !< coordinates
    real(dp), intent(out) :: g(:)             !< (nc)
    if (model%nc == 0) return
    call positions_at(model, t, q)
    call model%support_b%residual(model%chain, model%st, g)
  end subroutine constraint_residual

  !> Constraint Jacobian G(q, t).
  subroutine constraint_jacobian(model, t, q, g_jac)
    type(model_type), intent(inout) :: model  !< model
    real(dp), intent(in) :: t                 !< time [s]
    real(dp), intent(in) :: q(:)              !< coordinates
    real(dp), intent(out) :: g_jac(:, :)      !< (nc,nq)
    if (model%nc == 0) return
    call positions_at(model, t, q)
    call model%support_b%jacobian(model%chain, model%st, g_jac)
  end subroutine constraint_jacobian

  !> Velocity rows G(q,t) v + g_t.
  subroutine constraint_velocity(model, t, q, v, gv)
    type(model_type), intent(inout) :: model  !< model
    real(dp), intent(in) :: t                 !< time [s]
    real(dp), intent(in) :: q(:), v(:)        !< coordinates and rates
    real(dp), intent(out) :: gv(:)            !< (nc)
    if (model%nc == 0) return
    call state_motion(model, t, q, v)
    call model%support_b%velocity(model%chain, model%st, model%fs, gv)
  end subroutine constraint_velocity

  !> Acceleration bias d^2 g/dt^2 at qdd = 0 (eq. 3.54, 4.103, plus the rheonomic terms).
  subroutine constraint_bias(model, t, q, v, gb)
    type(model_type), intent(inout) :: model  !< model
    real(dp), intent(in) :: t                 !< time [s]
    real(dp), intent(in) :: q(:), v(:)        !< coordinates and rates
    real(dp), intent(out) :: gb(:)            !< (nc)
    if (model%nc == 0) return
    call positions_at(model, t, q)
    call chain_motion(model%chain, model%seed, v, model%zero_q, model%st)
    call record(model, HOLDS_MOTION, t, q, v, model%zero_q)
    call model%support_b%bias(model%chain, model%st, model%fs, gb)
  end subroutine constraint_bias

  !> Accelerations and multipliers from the acceleration-level system, eq. 3.55:
  !>   [M G^T; G 0] [vdot; -lambda] = [k; -(d/dt)^2 g at qdd = 0]
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
    real(dp) :: g(model%nc), gv(model%nc)
    integer :: nq, nc
    nq = model%nq; nc = model%nc
    ! One kinematic pass for everything: frames (M, G, g), then the motion at vdot = 0
    ! (k by inverse dynamics, and the bias).
    call positions_at(model, t, q)
    a = 0.0_dp
    call mass_matrix_crba(model%chain, model%st, a(1:nq, 1:nq))
    if (nc > 0) then
      call model%support_b%jacobian(model%chain, model%st, a(nq + 1:, 1:nq))
      a(1:nq, nq + 1:) = transpose(a(nq + 1:, 1:nq))
    end if
    call eom_residual(model, t, q, v, model%zero_q, model%zero_c, rhs(1:nq))   ! the frames above reused
    rhs(1:nq) = -rhs(1:nq)                    ! k(q, v, t)
    if (nc > 0) then
      call model%support_b%bias(model%chain, model%st, model%fs, rhs(nq + 1:))
      rhs(nq + 1:) = -rhs(nq + 1:)
      if (present(baumgarte_omega)) then
        call model%support_b%residual(model%chain, model%st, g)
        call model%support_b%velocity(model%chain, model%st, model%fs, gv)
        rhs(nq + 1:) = rhs(nq + 1:) - baumgarte_omega**2*g - 2.0_dp*baumgarte_omega*gv
      end if
    end if
    call solve_dense(a, rhs, info)
    vdot = rhs(1:nq)
    if (nc > 0) lambda = -rhs(nq + 1:)
  end subroutine solve_accelerations

  !> Kinetic energy relative to the model frame, sum of m v_C^2/2 + w.Theta w/2, from the
  !> velocities in model%st.
  function kinetic_energy(model) result(e)
    type(model_type), intent(in) :: model     !< model (private: state_energies fills the workspace first)
    real(dp) :: e
    real(dp) :: v(3), w(3)
    integer :: j
    e = 0.0_dp
    do j = 1, model%chain%n_bodies
      v = relative_velocity(model%fs, model%st%cm(:, j), model%st%vel_cm(:, j))
      w = model%st%omega(:, j) - model%fs%omega
      e = e + 0.5_dp*model%chain%mass(j)*dot_product(v, v) &
          + 0.5_dp*dot_product(w, world_inertia_times(model%chain, model%st, j, w))
    end do
  end function kinetic_energy

  !> Potential energy at the frames in model%st: every conservative load's potential, plus the
  !> centrifugal potential of a turning frame, -sum (m |Omega x r|^2 + Omega.Theta Omega)/2
  !> (its rotational part left out where the frame terms leave out the rotational inertia).
  !> With these, kinetic + potential is the Jacobi integral of a frame turning at constant Omega.
  function stored_energy(model, q) result(e)
    type(model_type), intent(in) :: model     !< model (private: state_energies fills the workspace first)
    real(dp), intent(in) :: q(:)              !< coordinates
    real(dp) :: e
    real(dp) :: w(3), r(3)
    integer :: i, j
    e = 0.0_dp
    do i = 1, size(model%loads)
      if (model%loads(i)%term%has_potential()) e = e + model%loads(i)%term%potential(model%chain, model%st, q)
    end do
    if (.not. model%fs%rotating) return
    w = model%fs%omega
    do j = 1, model%chain%n_bodies
      r = cross(w, model%st%cm(:, j) - model%fs%centre)
      e = e - 0.5_dp*model%chain%mass(j)*dot_product(r, r)
      if (model%fs%body_couples) e = e - 0.5_dp*dot_product(w, world_inertia_times(model%chain, model%st, j, w))
    end do
  end function stored_energy

  !> Kinetic + potential energy at (q, v, t).
  function total_energy(model, t, q, v) result(e)
    type(model_type), intent(inout) :: model  !< model
    real(dp), intent(in) :: t                 !< time [s]
    real(dp), intent(in) :: q(:), v(:)        !< coordinates and rates
    real(dp) :: e, kinetic, potential
    call state_energies(model, t, q, v, kinetic, potential)
    e = kinetic + potential
  end function total_energy

  !> Times at which some load jumps, ascending (the integrator stops and restarts there).
  subroutine switch_times(model, times)
    type(model_type), intent(in) :: model     !< model
    real(dp), allocatable, intent(out) :: times(:)  !< switching times [s]
    real(dp), allocatable :: more(:)
    real(dp) :: x
    integer :: i, j
    allocate (times(0))
    do i = 1, size(model%loads)
      call model%loads(i)%term%switch_times(more)
      times = [times, more]
    end do
    do i = 2, size(times)                     ! insertion sort: a handful of times
      x = times(i)
      j = i - 1
      do while (j >= 1)
        if (times(j) <= x) exit
        times(j + 1) = times(j)
        j = j - 1
      end do
      times(j + 1) = x
    end do
  end subroutine switch_times

  !> Whether every load's forces at rest at time t are those of its potential (statics may then
  !> use the energy as merit function): each load's conservative_at_rest at the frame's and the
  !> base's motion at t.
  logical function all_conservative(model, t)
    type(model_type), intent(inout) :: model  !< model
    real(dp), intent(in) :: t                 !< time of the equilibrium [s]
    integer :: i
    call model_prepare(model, t)
    all_conservative = .true.
    do i = 1, size(model%loads)
      all_conservative = all_conservative .and. model%loads(i)%term%conservative_at_rest(model%fs, model%seed)
    end do
  end function all_conservative

  !> The loads' constant diagonal joint-space stiffness and damping.
  subroutine joint_diagonal(model, stiffness, damping)
    type(model_type), intent(in) :: model     !< model
    real(dp), intent(out) :: stiffness(:)     !< (nq) [Nm/rad]
    real(dp), intent(out) :: damping(:)       !< (nq) [Nms/rad]
    integer :: i
    stiffness = 0.0_dp
    damping = 0.0_dp
    do i = 1, size(model%loads)
      call model%loads(i)%term%joint_diagonal(stiffness, damping)
    end do
  end subroutine joint_diagonal

end module rotorcable_model
