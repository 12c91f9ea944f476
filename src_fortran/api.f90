!> The f2py boundary: one flat module of scalars and explicit-shape arrays, every routine
!> with an integer status (0 = ok) and a message; no derived types cross it (STYLE.md 5).
!> Python (pydriver) raises the status as an exception naming the deck, group and key.
module rotorcable_api
  use, intrinsic :: iso_c_binding, only: c_double, c_int
  use rotorcable_kinds, only: dp
  use rotorcable_errors, only: error_type, fatal_error
  use rotorcable_deck_scan, only: scan_failure
  use rotorcable_deck, only: deck_type, load_deck, ANALYSIS_STATIC, ANALYSIS_DYNAMIC, ANALYSIS_MODAL
  use rotorcable_modal, only: modal_analysis
  use rotorcable_model, only: eom_residual, generalized_forces, mass_matrix, constraint_residual, &
                              constraint_jacobian, constraint_bias, constraint_velocity, &
                              solve_accelerations, reaction_wrenches, total_energy, sample_state
  use rotorcable_mass_matrix, only: mass_matrix_jourdain
  use rotorcable_kinematics, only: chain_positions, joint_angles
  use rotorcable_joint, only: thesis_angles
  use rotorcable_statics, only: static_result, solve_static
  use rotorcable_dae_integrator, only: solver_stats, integrate, consistent_start, ggl_residual_dense, &
                                       ggl_jacobian_dense
  use rotorcable_ggl_linear_solver, only: ggl_block_solver, block_factorise, block_solve
  use rotorcable_linalg, only: dgetrf, dgetrs
  use rotorcable_ode_integrator, only: ode_settings, integrate_ode, ODE_RK8PD, ODE_MSBDF
  implicit none
  private
  public :: rc_deck_info, rc_joint_kinds, rc_start_state, rc_scene, rc_integrate_end, rc_time_kernels, &
            rc_iteration_matrix, rc_ggl_residual, &
            rc_run_static, rc_run_dynamic, rc_evaluate, rc_shape, rc_run_modal

  real(dp), parameter :: RAD2DEG = 180.0_dp/acos(-1.0_dp)

contains

  subroutine open_deck(path, deck, stat, group, key, msg)
    character(len=*), intent(in) :: path
    type(deck_type), intent(out) :: deck
    integer(c_int), intent(out) :: stat
    character(len=64), intent(out) :: group, key
    character(len=1024), intent(out) :: msg
    type(scan_failure) :: fail
    call load_deck(path, deck, fail)
    stat = 0; group = ''; key = ''; msg = ''
    if (fail%failed) then
      stat = 1
      group = fail%group
      key = fail%key
      msg = fail%reason
    end if
  end subroutine open_deck

  !> Sizes and analysis type of a deck.
  subroutine rc_deck_info(path, n_bodies, nq, nc, n_out, analysis, c_beta, case_name, pulse_body, pulse_end, &
                          stat, group, key, msg)
    character(len=*), intent(in) :: path          !< deck file
    integer(c_int), intent(out) :: n_bodies              !< bodies
    integer(c_int), intent(out) :: nq                    !< coordinates
    integer(c_int), intent(out) :: nc                    !< constraint rows
    integer(c_int), intent(out) :: n_out                 !< output samples of a dynamic run
    integer(c_int), intent(out) :: analysis              !< 1 static, 2 dynamic, 3 modal
    real(c_double), intent(out) :: c_beta               !< bending spring per joint [Nm/rad]
    character(len=64), intent(out) :: case_name   !< &case name
    integer(c_int), intent(out) :: pulse_body     !< body loaded by a force pulse (0 = none)
    real(c_double), intent(out) :: pulse_end      !< end of the pulse [s]
    integer(c_int), intent(out) :: stat                  !< 0 = ok
    character(len=64), intent(out) :: group, key  !< where the deck is wrong
    character(len=1024), intent(out) :: msg       !< why
    type(deck_type) :: deck
    n_bodies = 0; nq = 0; nc = 0; n_out = 0; analysis = 0; c_beta = 0.0_dp; case_name = ''
    pulse_body = 0; pulse_end = 0.0_dp
    call open_deck(path, deck, stat, group, key, msg)
    if (stat /= 0) return
    n_bodies = deck%model%chain%n_bodies
    nq = deck%model%nq
    nc = deck%model%nc
    n_out = nint(deck%integrator%t_end/deck%integrator%dt_out) + 1
    analysis = deck%analysis
    c_beta = deck%c_beta
    case_name = deck%case_name
    pulse_body = deck%model%loads%pulse_body
    pulse_end = deck%model%loads%pulse_end
  end subroutine rc_deck_info

  !> Parametrisation of every joint (1 = thesis zy, 2 = Cardan xy) and whether it is free.
  subroutine rc_joint_kinds(path, nb, kinds, is_free, stat, msg)
    character(len=*), intent(in) :: path          !< deck file
    integer(c_int), intent(in) :: nb              !< bodies
    integer(c_int), intent(out) :: kinds(nb)      !< joint parametrisation per joint
    integer(c_int), intent(out) :: is_free(nb)    !< 1 = the joint has coordinates (not "free": f2py C name clash)
    integer(c_int), intent(out) :: stat           !< 0 = ok
    character(len=1024), intent(out) :: msg       !< why not
    type(deck_type) :: deck
    character(len=64) :: group, key
    kinds = 0; is_free = 0
    call open_deck(path, deck, stat, group, key, msg)
    if (stat /= 0) return
    kinds = deck%model%chain%joint_kind
    is_free = merge(0, 1, deck%model%chain%locked)
  end subroutine rc_joint_kinds

  !> Start coordinates and rates of a deck (as written, not projected).
  subroutine rc_start_state(path, nq, q, v, stat, msg)
    character(len=*), intent(in) :: path          !< deck file
    integer(c_int), intent(in) :: nq                     !< coordinates
    real(c_double), intent(out) :: q(nq), v(nq)         !< start coordinates [rad] and rates [rad/s]
    integer(c_int), intent(out) :: stat                  !< 0 = ok
    character(len=1024), intent(out) :: msg       !< why not
    type(deck_type) :: deck
    character(len=64) :: group, key
    q = 0.0_dp; v = 0.0_dp
    call open_deck(path, deck, stat, group, key, msg)
    if (stat /= 0) return
    q = deck%q0
    v = deck%v0
  end subroutine rc_start_state

  !> The scene of a deck as plain numbers, for independent implementations of the same
  !> model (benchmark peers, tests): bodies, springs, supports, loads and the consistent
  !> start state the integrators begin from (the static equilibrium when the deck starts
  !> there, otherwise the deck's shape projected onto g = 0 and G v = 0).
  subroutine rc_scene(path, nb, nq, lengths, radii, masses, inertia, locked, locked_angles, first_coord, &
                      stiffness, damping, rest, base_position, base_rotation, clamp_active, clamp_position, &
                      clamp_rotation, gravity, rotor_omega, rotor_offset, pulse_body, pulse_force, pulse_window, &
                      tip_force, t_end, q0, v0, stat, msg)
    character(len=*), intent(in) :: path          !< deck file
    integer(c_int), intent(in) :: nb, nq          !< bodies, coordinates
    real(c_double), intent(out) :: lengths(nb)    !< body lengths [m]
    real(c_double), intent(out) :: radii(nb)      !< body radii [m]
    real(c_double), intent(out) :: masses(nb)     !< body masses [kg]
    real(c_double), intent(out) :: inertia(nb, 3) !< principal inertia about the CM, body axes [kg m^2]
    integer(c_int), intent(out) :: locked(nb)     !< 1 = joint locked (clamped first body)
    real(c_double), intent(out) :: locked_angles(nb, 2) !< (gamma, beta) of locked joints [rad]
    integer(c_int), intent(out) :: first_coord(nb) !< 1-based index of joint j's gamma in q (0 = locked)
    real(c_double), intent(out) :: stiffness(nq)  !< spring per coordinate [Nm/rad]
    real(c_double), intent(out) :: damping(nq)    !< damper per coordinate [Nms/rad]
    real(c_double), intent(out) :: rest(nq)       !< spring rest angle per coordinate [rad]
    real(c_double), intent(out) :: base_position(3)     !< clamp A point [m]
    real(c_double), intent(out) :: base_rotation(3, 3)  !< world <- base frame
    integer(c_int), intent(out) :: clamp_active   !< 1 = clamp B holds the tip
    real(c_double), intent(out) :: clamp_position(3)    !< clamp B point [m]
    real(c_double), intent(out) :: clamp_rotation(3, 3) !< world <- clamped last body
    real(c_double), intent(out) :: gravity(3)     !< gravitational acceleration [m/s^2]
    real(c_double), intent(out) :: rotor_omega    !< rotor speed about world z [rad/s]
    real(c_double), intent(out) :: rotor_offset(3) !< clamp A relative to the rotor centre [m]
    integer(c_int), intent(out) :: pulse_body     !< body loaded by the pulse (0 = none)
    real(c_double), intent(out) :: pulse_force(3) !< pulse force at that CM [N]
    real(c_double), intent(out) :: pulse_window(2) !< pulse start, end [s]
    real(c_double), intent(out) :: tip_force(3)   !< constant force at a free tip [N]
    real(c_double), intent(out) :: t_end          !< end time of a dynamic run [s]
    real(c_double), intent(out) :: q0(nq), v0(nq) !< consistent start coordinates and rates
    integer(c_int), intent(out) :: stat           !< 0 = ok, 1 = deck error, 2 = start failed
    character(len=1024), intent(out) :: msg       !< why not
    type(deck_type) :: deck
    type(error_type) :: error
    character(len=64) :: group, key
    real(dp) :: vdot(nq), lam(6)
    integer :: stats(5)

    lengths = 0; radii = 0; masses = 0; inertia = 0; locked = 0; locked_angles = 0; first_coord = 0
    stiffness = 0; damping = 0; rest = 0; base_position = 0; base_rotation = 0; clamp_active = 0
    clamp_position = 0; clamp_rotation = 0; gravity = 0; rotor_omega = 0; rotor_offset = 0
    pulse_body = 0; pulse_force = 0; pulse_window = 0; tip_force = 0; t_end = 0; q0 = 0; v0 = 0
    call open_deck(path, deck, stat, group, key, msg)
    if (stat /= 0) return
    associate (ch => deck%model%chain, ld => deck%model%loads, cl => deck%model%clamp)
      lengths = ch%length; radii = ch%radius; masses = ch%mass
      inertia = transpose(ch%inertia)
      locked = merge(1, 0, ch%locked)
      locked_angles = transpose(ch%locked_angles)
      first_coord = ch%first_coord
      stiffness = ch%stiffness; damping = ch%damping; rest = ch%rest
      base_position = ch%base_position; base_rotation = ch%base_rotation
      clamp_active = merge(1, 0, cl%active)
      clamp_position = cl%position; clamp_rotation = cl%rotation
      gravity = ld%gravity; rotor_omega = ld%rotor_omega; rotor_offset = ld%rotor_offset
      pulse_body = ld%pulse_body; pulse_force = ld%pulse_force
      pulse_window = [ld%pulse_start, ld%pulse_end]
      tip_force = ld%tip_force
    end associate
    t_end = deck%integrator%t_end
    q0 = deck%q0; v0 = deck%v0
    if (deck%start_at_equilibrium) then
      call equilibrium(deck, q0, lam, stats, error)
      v0 = 0.0_dp
    end if
    if (error%code == 0) call consistent_start(deck%model, 0.0_dp, q0, v0, vdot, lam(1:deck%model%nc), error)
    if (error%code /= 0) then
      stat = 2
      msg = error%message
    end if
  end subroutine rc_scene

  !> One timed integration of a dynamic deck from its consistent start to t_end, for the
  !> work-precision comparison: method 1 = IDA on the GGL index-2 DAE (the default route),
  !> 2 = GSL rk8pd and 3 = GSL msbdf on the Baumgarte-stabilised index-1 ODE (thesis route).
  !> Only the integration is timed (not the deck, the start equilibrium or the outputs).
  subroutine rc_integrate_end(path, method, rtol, atol, h_max, baumgarte_omega, nb, nq, ns, cm_end, tip_end, &
                              wrenches_end, gmax, cm_samples, stats, cpu_s, wall_s, stat, msg)
    character(len=*), intent(in) :: path          !< deck file
    integer(c_int), intent(in) :: method          !< 1 IDA-GGL, 2 GSL rk8pd, 3 GSL msbdf
    real(c_double), intent(in) :: rtol, atol      !< tolerances (atol on q [rad] and v [rad/s])
    real(c_double), intent(in) :: h_max           !< maximum step [s]; < 0 = the deck's, 0 = none
    real(c_double), intent(in) :: baumgarte_omega !< Baumgarte constant of the ODE route [1/s]
    integer(c_int), intent(in) :: nb, nq          !< bodies, coordinates
    integer(c_int), intent(in) :: ns              !< samples t_k = t_end (k - 1)/(ns - 1), ns >= 2
    real(c_double), intent(out) :: cm_end(nb, 3)  !< centres of mass at t_end [m]
    real(c_double), intent(out) :: tip_end(3)     !< chain tip P_{n+1} at t_end [m]
    real(c_double), intent(out) :: wrenches_end(12) !< F_A, M_A, F_B, M_B at t_end [N, Nm]
    real(c_double), intent(out) :: gmax           !< max |g| position rows at t_end [m]
    real(c_double), intent(out) :: cm_samples(ns, 3*nb) !< x1, y1, z1, x2, ... at the samples [m]
    integer(c_int), intent(out) :: stats(5)       !< steps, rhs/residual evals, Jacobians, error-test fails, conv fails
    real(c_double), intent(out) :: cpu_s, wall_s  !< CPU and wall time of the integration [s]
    integer(c_int), intent(out) :: stat           !< 0 = ok, 1 = deck error, 2 = run error
    character(len=1024), intent(out) :: msg       !< why not
    type(deck_type) :: deck
    type(error_type) :: error
    type(solver_stats) :: ss
    type(ode_settings) :: ode
    character(len=64) :: group, key
    real(dp) :: t(max(ns, 2)), q_out(nq, max(ns, 2)), v_out(nq, max(ns, 2)), vdot(nq), lam(6), ang(nb, 2)
    real(dp) :: joints(nb + 1, 3), g(6), c(nb, 3)
    real(dp) :: c0, c1
    integer(kind=8) :: k0, k1, rate
    integer :: info, nc, k, m

    cm_end = 0.0_dp; tip_end = 0.0_dp; wrenches_end = 0.0_dp; gmax = 0.0_dp; stats = 0; cm_samples = 0.0_dp
    cpu_s = 0.0_dp; wall_s = 0.0_dp
    call open_deck(path, deck, stat, group, key, msg)
    if (stat /= 0) return
    nc = deck%model%nc
    if (deck%start_at_equilibrium) then
      call equilibrium(deck, vdot, lam, stats, error)
      deck%q0 = vdot
      deck%v0 = 0.0_dp
    end if
    if (error%code == 0) then
      m = max(ns, 2)
      do k = 1, m
        t(k) = deck%integrator%t_end*real(k - 1, dp)/real(m - 1, dp)
      end do
      if (h_max >= 0.0_dp) deck%integrator%h_max = h_max
      deck%integrator%rtol = rtol
      deck%integrator%atol = atol
      call system_clock(k0, rate)
      call cpu_time(c0)
      select case (method)
      case (1)
        call integrate(deck%model, deck%integrator, deck%q0, deck%v0, t, q_out, v_out, ss, error)
      case (2, 3)
        ode%method = merge(ODE_RK8PD, ODE_MSBDF, method == 2)
        ode%rtol = rtol
        ode%atol = atol
        ode%baumgarte_omega = baumgarte_omega
        ode%h_max = deck%integrator%h_max
        call integrate_ode(deck%model, ode, deck%q0, deck%v0, t, q_out, v_out, ss, error)
      case default
        call fatal_error(error, 'unknown integration method')
      end select
      call cpu_time(c1)
      call system_clock(k1)
      cpu_s = c1 - c0
      wall_s = real(k1 - k0, dp)/real(rate, dp)
      stats = [ss%steps, ss%residual_evals, ss%jacobian_evals, ss%error_test_failures, ss%convergence_failures]
    end if
    if (error%code /= 0) then
      stat = 2
      msg = error%message
      return
    end if
    do k = 1, min(ns, m)
      call fill_shape(deck, q_out(:, k), ang, c, joints)
      cm_samples(k, 1::3) = c(:, 1)
      cm_samples(k, 2::3) = c(:, 2)
      cm_samples(k, 3::3) = c(:, 3)
    end do
    call fill_shape(deck, q_out(:, m), ang, cm_end, joints)
    tip_end = joints(nb + 1, :)
    lam = 0.0_dp
    call solve_accelerations(deck%model, t(m), q_out(:, m), v_out(:, m), vdot, lam(1:nc), info)
    call reaction_wrenches(deck%model, t(m), q_out(:, m), v_out(:, m), vdot, lam, wrenches_end)
    if (nc > 0) then
      call constraint_residual(deck%model, q_out(:, m), g)
      gmax = maxval(abs(g(1:3)))
    end if
  end subroutine rc_integrate_end

  !> The GGL residual F(t, y, y') of the integrator at any (y, y'), y = (q, v, lambda, mu),
  !> for the tests (its constraint rows against the explicitly formed G).
  subroutine rc_ggl_residual(path, t, n, y, yd, r, stat, msg)
    character(len=*), intent(in) :: path          !< deck file
    real(c_double), intent(in) :: t               !< time [s]
    integer(c_int), intent(in) :: n               !< 2 nq + 2 nc
    real(c_double), intent(in) :: y(n), yd(n)     !< unknowns and their derivatives
    real(c_double), intent(out) :: r(n)           !< residual
    integer(c_int), intent(out) :: stat           !< 0 = ok
    character(len=1024), intent(out) :: msg       !< why not
    type(deck_type) :: deck
    character(len=64) :: group, key
    r = 0.0_dp
    call open_deck(path, deck, stat, group, key, msg)
    if (stat /= 0) return
    if (n /= 2*deck%model%nq + 2*deck%model%nc) then
      stat = 2
      msg = 'n must be 2 nq + 2 nc'
      return
    end if
    call ggl_residual_dense(deck%model, t, y, yd, r)
  end subroutine rc_ggl_residual

  !> The GGL iteration matrix J = dF/dy + cj dF/dy' at the deck's consistent start (mu = 0)
  !> and the block (Schur-complement) solution of J x = b for given right-hand sides, for
  !> the tests (against a dense solve) and the benchmarks: wall time per factorisation and
  !> per solve, block against LAPACK's dense LU (dgetrf/dgetrs) of the whole matrix.
  subroutine rc_iteration_matrix(path, cj, n, n_rhs, b, n_rep, jac, x_block, ns_block_factor, &
                                 ns_block_solve, ns_dense_factor, ns_dense_solve, stat, msg)
    character(len=*), intent(in) :: path          !< deck file
    real(c_double), intent(in) :: cj              !< IDA's cj = alpha/h [1/s]
    integer(c_int), intent(in) :: n, n_rhs        !< GGL unknowns 2 nq + 2 nc, right-hand sides
    real(c_double), intent(in) :: b(n, n_rhs)     !< right-hand sides
    integer(c_int), intent(in) :: n_rep           !< repetitions of each timed operation
    real(c_double), intent(out) :: jac(n, n)      !< iteration matrix
    real(c_double), intent(out) :: x_block(n, n_rhs) !< block solutions
    real(c_double), intent(out) :: ns_block_factor, ns_block_solve   !< block: ns per factorisation, per solve
    real(c_double), intent(out) :: ns_dense_factor, ns_dense_solve   !< dense LU: the same
    integer(c_int), intent(out) :: stat           !< 0 = ok
    character(len=1024), intent(out) :: msg       !< why not
    type(deck_type) :: deck
    type(error_type) :: error
    type(ggl_block_solver) :: block
    character(len=64) :: group, key
    real(dp), allocatable :: y(:), yd(:), vdot(:), lam(:), lu(:, :), x(:)
    integer, allocatable :: pivots(:)
    integer(kind=8) :: k0, k1, rate
    integer :: nq, nc, i, k, info

    jac = 0.0_dp; x_block = 0.0_dp
    ns_block_factor = 0.0_dp; ns_block_solve = 0.0_dp; ns_dense_factor = 0.0_dp; ns_dense_solve = 0.0_dp
    call open_deck(path, deck, stat, group, key, msg)
    if (stat /= 0) return
    nq = deck%model%nq; nc = deck%model%nc
    if (n /= 2*nq + 2*nc) then
      stat = 2
      msg = 'n must be 2 nq + 2 nc'
      return
    end if
    allocate (y(n), yd(n), vdot(nq), lam(max(nc, 1)), lu(n, n), x(n), pivots(n))
    call consistent_start(deck%model, 0.0_dp, deck%q0, deck%v0, vdot, lam(1:nc), error)
    if (error%code /= 0) then
      stat = 2
      msg = error%message
      return
    end if
    y = 0.0_dp; yd = 0.0_dp
    y(1:nq) = deck%q0; y(nq + 1:2*nq) = deck%v0; y(2*nq + 1:2*nq + nc) = lam(1:nc)
    yd(1:nq) = deck%v0; yd(nq + 1:2*nq) = vdot
    call ggl_jacobian_dense(deck%model, 0.0_dp, cj, y, yd, jac)
    block%nq = nq; block%nc = nc; block%cj = cj
    allocate (block%k(nq, nq), block%k_pivots(nq), block%kq(nq, nq), block%b1_rows(nq + 2*nc, nq), block%g_t(nq, nc), &
              block%cq(nc, nq), block%c_rows(2*nc, nq), block%kinv_b(nq, 2*nc), &
              block%s(2*nc, 2*nc), block%s_pivots(2*nc))
    call system_clock(k0, rate)
    do i = 1, max(n_rep, 1)
      call block_factorise(block, jac, info)
    end do
    call system_clock(k1)
    ns_block_factor = 1.0e9_dp*real(k1 - k0, dp)/real(rate, dp)/max(n_rep, 1)
    if (info /= 0) then
      stat = 3
      msg = 'block factorisation: singular K or S'
      return
    end if
    call system_clock(k0)
    do i = 1, max(n_rep, 1)
      do k = 1, n_rhs
        call block_solve(block, b(:, k), x_block(:, k))
      end do
    end do
    call system_clock(k1)
    ns_block_solve = 1.0e9_dp*real(k1 - k0, dp)/real(rate, dp)/max(n_rep, 1)/max(n_rhs, 1)
    call system_clock(k0)
    do i = 1, max(n_rep, 1)
      lu = jac
      call dgetrf(n, n, lu, n, pivots, info)
    end do
    call system_clock(k1)
    ns_dense_factor = 1.0e9_dp*real(k1 - k0, dp)/real(rate, dp)/max(n_rep, 1)
    call system_clock(k0)
    do i = 1, max(n_rep, 1)
      do k = 1, n_rhs
        x = b(:, k)
        call dgetrs('N', n, 1, lu, n, pivots, x, n, info)
      end do
    end do
    call system_clock(k1)
    ns_dense_solve = 1.0e9_dp*real(k1 - k0, dp)/real(rate, dp)/max(n_rep, 1)/max(n_rhs, 1)
  end subroutine rc_iteration_matrix

  !> Cost of the integrator's kernels at the deck's consistent start, timed in a loop
  !> here (no Python call overhead): one GGL residual (inverse dynamics, g, G, G v), one
  !> structured Jacobian and one mass matrix.  Also returns the residual itself.
  subroutine rc_time_kernels(path, n_rep, n, residual, ns_residual, ns_jacobian, ns_mass, stat, msg)
    character(len=*), intent(in) :: path          !< deck file
    integer(c_int), intent(in) :: n_rep          !< repetitions of the residual (Jacobian: n_rep/100 + 1)
    integer(c_int), intent(in) :: n               !< GGL unknowns 2 nq + 2 nc
    real(c_double), intent(out) :: residual(n)    !< residual at the start (should be ~0)
    real(c_double), intent(out) :: ns_residual    !< wall time per residual [ns]
    real(c_double), intent(out) :: ns_jacobian    !< wall time per Jacobian [ns]
    real(c_double), intent(out) :: ns_mass        !< wall time per mass matrix [ns]
    integer(c_int), intent(out) :: stat           !< 0 = ok
    character(len=1024), intent(out) :: msg       !< why not
    type(deck_type) :: deck
    type(error_type) :: error
    character(len=64) :: group, key
    real(dp), allocatable :: y(:), yd(:), jac(:, :), m(:, :), vdot(:), lam(:)
    integer(kind=8) :: k0, k1, rate
    integer :: nq, nc, i, n_jac
    real(dp) :: sink

    residual = 0.0_dp; ns_residual = 0.0_dp; ns_jacobian = 0.0_dp; ns_mass = 0.0_dp
    call open_deck(path, deck, stat, group, key, msg)
    if (stat /= 0) return
    nq = deck%model%nq; nc = deck%model%nc
    allocate (y(n), yd(n), jac(n, n), m(nq, nq), vdot(nq), lam(max(nc, 1)))
    call consistent_start(deck%model, 0.0_dp, deck%q0, deck%v0, vdot, lam(1:nc), error)
    if (error%code /= 0) then
      stat = 2
      msg = error%message
      return
    end if
    y = 0.0_dp; yd = 0.0_dp
    y(1:nq) = deck%q0; y(nq + 1:2*nq) = deck%v0; y(2*nq + 1:2*nq + nc) = lam(1:nc)
    yd(1:nq) = deck%v0; yd(nq + 1:2*nq) = vdot
    sink = 0.0_dp
    call system_clock(k0, rate)
    do i = 1, n_rep
      ! Vary t slightly so that the loop cannot be hoisted.
      call ggl_residual_dense(deck%model, 1.0e-9_dp*i, y, yd, residual)
      sink = sink + residual(1)
    end do
    call system_clock(k1)
    ns_residual = 1.0e9_dp*real(k1 - k0, dp)/real(rate, dp)/n_rep
    n_jac = n_rep/100 + 1
    call system_clock(k0)
    do i = 1, n_jac
      call ggl_jacobian_dense(deck%model, 0.0_dp, 1.0e3_dp, y, yd, jac)
      sink = sink + jac(1, 1)
    end do
    call system_clock(k1)
    ns_jacobian = 1.0e9_dp*real(k1 - k0, dp)/real(rate, dp)/n_jac
    call system_clock(k0)
    do i = 1, n_rep
      call mass_matrix(deck%model, y(1:nq), m)
      sink = sink + m(1, 1)
    end do
    call system_clock(k1)
    ns_mass = 1.0e9_dp*real(k1 - k0, dp)/real(rate, dp)/n_rep
    call ggl_residual_dense(deck%model, 0.0_dp, y, yd, residual)
    if (sink /= sink) msg = 'NaN'   ! keeps sink alive
  end subroutine rc_time_kernels

  !> Joint angles [deg] and CM / joint-point coordinates [m] of every body for q.
  subroutine rc_shape(path, nb, nq, q, angles_deg, cm, joints, stat, msg)
    character(len=*), intent(in) :: path          !< deck file
    integer(c_int), intent(in) :: nb, nq                 !< bodies, coordinates
    real(c_double), intent(in) :: q(nq)                 !< coordinates [rad]
    real(c_double), intent(out) :: angles_deg(nb, 2)    !< (gamma, beta) per joint [deg]
    real(c_double), intent(out) :: cm(nb, 3)            !< centres of mass [m]
    real(c_double), intent(out) :: joints(nb + 1, 3)    !< joint points, last = tip [m]
    integer(c_int), intent(out) :: stat                  !< 0 = ok
    character(len=1024), intent(out) :: msg       !< why not
    type(deck_type) :: deck
    character(len=64) :: group, key
    angles_deg = 0.0_dp; cm = 0.0_dp; joints = 0.0_dp
    call open_deck(path, deck, stat, group, key, msg)
    if (stat /= 0) return
    call fill_shape(deck, q, angles_deg, cm, joints)
  end subroutine rc_shape

  subroutine fill_shape(deck, q, angles_deg, cm, joints)
    type(deck_type), intent(inout) :: deck
    real(c_double), intent(in) :: q(:)
    real(c_double), intent(out) :: angles_deg(:, :), cm(:, :), joints(:, :)
    integer :: j
    call chain_positions(deck%model%chain, q, deck%model%st)
    do j = 1, deck%model%chain%n_bodies
      angles_deg(j, :) = thesis_angles(deck%model%chain%joint_kind(j), joint_angles(deck%model%chain, q, j))*RAD2DEG
    end do
    cm = transpose(deck%model%st%cm)
    joints = transpose(deck%model%st%joint_point)
  end subroutine fill_shape

  !> Equilibrium of a deck: Newton on the constraint manifold, or damped dynamic settling
  !> (the thesis's route, section 5.3) when the deck asks for static_method = 'settle'.
  subroutine equilibrium(deck, q, lambda, stats, error)
    type(deck_type), intent(inout) :: deck
    real(dp), intent(out) :: q(:), lambda(:)
    integer, intent(out) :: stats(5)
    type(error_type), intent(inout) :: error
    type(static_result) :: res
    type(solver_stats) :: ss
    real(dp), allocatable :: t(:), q_out(:, :), v_out(:, :), vdot(:)
    integer :: nt, k, info, pulse_body
    character(len=32) :: buf
    q = deck%q0
    lambda = 0.0_dp
    ! The equilibrium is that of the steady loads: a force pulse is a dynamic excitation.
    pulse_body = deck%model%loads%pulse_body
    deck%model%loads%pulse_body = 0
    if (.not. deck%settle) then
      call solve_static(deck%model, deck%statics, q, lambda, res, error)
      stats = [res%iterations, res%residual_evals, res%jacobian_evals, res%line_search_cuts, 0]
      deck%model%loads%pulse_body = pulse_body
      return
    end if
    nt = nint(deck%integrator%t_end/deck%integrator%dt_out) + 1
    allocate (t(nt), q_out(deck%model%nq, nt), v_out(deck%model%nq, nt), vdot(deck%model%nq))
    do k = 1, nt
      t(k) = min((k - 1)*deck%integrator%dt_out, deck%integrator%t_end)
    end do
    call integrate(deck%model, deck%integrator, deck%q0, 0.0_dp*deck%q0, t, q_out, v_out, ss, error)
    stats = [ss%steps, ss%residual_evals, ss%jacobian_evals, ss%error_test_failures, ss%convergence_failures]
    if (error%code /= 0) return
    q = q_out(:, nt)
    if (maxval(abs(v_out(:, nt))) > deck%settle_tol) then
      write (buf, '(es10.3)') maxval(abs(v_out(:, nt)))
      call fatal_error(error, 'dynamic settling: not at rest at t_end (max |qdot| = '//trim(buf)// &
                       ' rad/s > settle_tol); increase t_end')
      return
    end if
    call solve_accelerations(deck%model, t(nt), q, 0.0_dp*q, vdot, lambda(1:deck%model%nc), info)
    deck%model%loads%pulse_body = pulse_body
  end subroutine equilibrium

  !> Static equilibrium from the deck's start shape.
  subroutine rc_run_static(path, nb, nq, ncd, q, lambda, angles_deg, cm, wrenches, stats, gmax, stat, group, key, msg)
    character(len=*), intent(in) :: path          !< deck file
    integer(c_int), intent(in) :: nb, nq, ncd            !< bodies, coordinates, max(1, constraint rows)
    real(c_double), intent(out) :: q(nq)                !< equilibrium coordinates [rad]
    real(c_double), intent(out) :: lambda(ncd)          !< multipliers
    real(c_double), intent(out) :: angles_deg(nb, 2)    !< joint angles [deg]
    real(c_double), intent(out) :: cm(nb, 3)            !< centres of mass [m]
    real(c_double), intent(out) :: wrenches(12)         !< F_A, M_A, F_B, M_B (support on chain) [N, Nm]
    integer(c_int), intent(out) :: stats(5)              !< Newton: iterations, residual evals, Jacobians, step cuts; settling: IDA stats
    real(c_double), intent(out) :: gmax                 !< max |g| position rows [m]
    integer(c_int), intent(out) :: stat                  !< 0 = ok
    character(len=64), intent(out) :: group, key  !< where a deck error is
    character(len=1024), intent(out) :: msg       !< why
    type(deck_type) :: deck
    type(error_type) :: error

    q = 0.0_dp; lambda = 0.0_dp; angles_deg = 0.0_dp; cm = 0.0_dp; wrenches = 0.0_dp; stats = 0; gmax = 0.0_dp
    call open_deck(path, deck, stat, group, key, msg)
    if (stat /= 0) return
    call equilibrium(deck, q, lambda, stats, error)
    if (error%code /= 0) then
      stat = 2
      msg = error%message
      return
    end if
    call describe_equilibrium(deck, q, lambda, angles_deg, cm, wrenches, gmax)
  end subroutine rc_run_static

  subroutine describe_equilibrium(deck, q, lambda, angles_deg, cm, wrenches, gmax)
    type(deck_type), intent(inout) :: deck
    real(dp), intent(in) :: q(:), lambda(:)
    real(dp), intent(out) :: angles_deg(:, :), cm(:, :), wrenches(12), gmax
    real(dp) :: joints(deck%model%chain%n_bodies + 1, 3), g(6), zero(size(q))
    zero = 0.0_dp
    gmax = 0.0_dp
    call reaction_wrenches(deck%model, 0.0_dp, q, zero, zero, lambda, wrenches)
    if (deck%model%nc > 0) then
      call constraint_residual(deck%model, q, g)
      gmax = maxval(abs(g(1:3)))
    end if
    call fill_shape(deck, q, angles_deg, cm, joints)
  end subroutine describe_equilibrium

  !> Modal analysis about the deck's equilibrium: frequencies, damping, mode shapes.
  subroutine rc_run_modal(path, nb, nq, ncd, nf, q, lambda, angles_deg, cm, wrenches, f_undamped, f_damped, &
                          zeta, shapes, cm_shapes, stats, gmax, stat, group, key, msg)
    character(len=*), intent(in) :: path          !< deck file
    integer(c_int), intent(in) :: nb, nq, ncd, nf !< bodies, coordinates, max(1, nc), free coordinates nq - nc
    real(c_double), intent(out) :: q(nq)          !< equilibrium coordinates [rad]
    real(c_double), intent(out) :: lambda(ncd)    !< multipliers
    real(c_double), intent(out) :: angles_deg(nb, 2) !< joint angles [deg]
    real(c_double), intent(out) :: cm(nb, 3)      !< centres of mass [m]
    real(c_double), intent(out) :: wrenches(12)   !< support wrenches at equilibrium
    real(c_double), intent(out) :: f_undamped(nf) !< natural frequencies [Hz]
    real(c_double), intent(out) :: f_damped(nf)   !< damped frequencies [Hz] (0 = overdamped)
    real(c_double), intent(out) :: zeta(nf)       !< damping ratios
    real(c_double), intent(out) :: shapes(nq, nf) !< mode shapes in q (mass-normalised)
    real(c_double), intent(out) :: cm_shapes(3*nb, nf) !< mode shapes as CM displacements (x1,y1,z1,...)
    integer(c_int), intent(out) :: stats(5)       !< equilibrium solver statistics
    real(c_double), intent(out) :: gmax           !< max |g| position rows [m]
    integer(c_int), intent(out) :: stat           !< 0 = ok
    character(len=64), intent(out) :: group, key  !< where a deck error is
    character(len=1024), intent(out) :: msg       !< why
    type(deck_type) :: deck
    type(error_type) :: error
    real(dp) :: cp(nb, 3), cmm(nb, 3), ang(nb, 2), joints(nb + 1, 3), h
    integer :: i

    q = 0.0_dp; lambda = 0.0_dp; angles_deg = 0.0_dp; cm = 0.0_dp; wrenches = 0.0_dp; stats = 0; gmax = 0.0_dp
    f_undamped = 0.0_dp; f_damped = 0.0_dp; zeta = 0.0_dp; shapes = 0.0_dp; cm_shapes = 0.0_dp
    call open_deck(path, deck, stat, group, key, msg)
    if (stat /= 0) return
    call equilibrium(deck, q, lambda, stats, error)
    if (error%code == 0) call modal_analysis(deck%model, q, lambda(1:deck%model%nc), f_undamped, f_damped, &
                                             zeta, shapes, error)
    if (error%code /= 0) then
      stat = 2
      msg = error%message
      return
    end if
    call describe_equilibrium(deck, q, lambda, angles_deg, cm, wrenches, gmax)
    ! CM displacement per unit modal coordinate, by central differences of the kinematics.
    h = 1.0e-6_dp
    do i = 1, nf
      call fill_shape(deck, q + h*shapes(:, i), ang, cp, joints)
      call fill_shape(deck, q - h*shapes(:, i), ang, cmm, joints)
      cm_shapes(1::3, i) = (cp(:, 1) - cmm(:, 1))/(2.0_dp*h)
      cm_shapes(2::3, i) = (cp(:, 2) - cmm(:, 2))/(2.0_dp*h)
      cm_shapes(3::3, i) = (cp(:, 3) - cmm(:, 3))/(2.0_dp*h)
    end do
  end subroutine rc_run_modal

  !> Dynamic run with IDA; outputs at t = 0, dt_out, ..., t_end.
  subroutine rc_run_dynamic(path, nb, nq, nt, t, q, angles_deg, cm, wrenches, energy, gviol, stats, &
                            stat, group, key, msg)
    character(len=*), intent(in) :: path          !< deck file
    integer(c_int), intent(in) :: nb, nq, nt             !< bodies, coordinates, output samples
    real(c_double), intent(out) :: t(nt)                !< output times [s]
    real(c_double), intent(out) :: q(nt, nq)            !< coordinates [rad]
    real(c_double), intent(out) :: angles_deg(nt, 2*nb) !< gamma1, beta1, gamma2, ... [deg]
    real(c_double), intent(out) :: cm(nt, 3*nb)         !< x1, y1, z1, x2, ... [m]
    real(c_double), intent(out) :: wrenches(nt, 12)     !< F_A, M_A, F_B, M_B [N, Nm]
    real(c_double), intent(out) :: energy(nt)           !< total mechanical energy [J]
    real(c_double), intent(out) :: gviol(nt)            !< max |g| of the position rows [m]
    integer(c_int), intent(out) :: stats(5)              !< steps, residual evals, Jacobian evals, error-test fails, conv fails
    integer(c_int), intent(out) :: stat                  !< 0 = ok
    character(len=64), intent(out) :: group, key  !< where a deck error is
    character(len=1024), intent(out) :: msg       !< why
    type(deck_type) :: deck
    type(error_type) :: error
    type(solver_stats) :: ss
    real(dp), allocatable :: q_out(:, :), v_out(:, :), vdot(:), lam(:)
    real(dp) :: ang(nb, 2), wr(12)
    integer :: k, j, nc, info

    t = 0.0_dp; q = 0.0_dp; angles_deg = 0.0_dp; cm = 0.0_dp; wrenches = 0.0_dp
    energy = 0.0_dp; gviol = 0.0_dp; stats = 0
    call open_deck(path, deck, stat, group, key, msg)
    if (stat /= 0) return
    nc = deck%model%nc
    do k = 1, nt
      t(k) = min((k - 1)*deck%integrator%dt_out, deck%integrator%t_end)
    end do
    allocate (q_out(nq, nt), v_out(nq, nt), vdot(nq), lam(max(nc, 1)))
    if (deck%start_at_equilibrium) then
      ! Start at rest in the static equilibrium (e.g. the decay test of section 5.4).
      call equilibrium(deck, vdot, lam, stats, error)
      deck%q0 = vdot          ! vdot is free workspace here
      deck%v0 = 0.0_dp
      if (error%code /= 0) then
        stat = 2
        msg = 'start equilibrium: '//error%message
        return
      end if
    end if
    call integrate(deck%model, deck%integrator, deck%q0, deck%v0, t, q_out, v_out, ss, error)
    stats = [ss%steps, ss%residual_evals, ss%jacobian_evals, ss%error_test_failures, ss%convergence_failures]
    if (error%code /= 0) then
      stat = 2
      msg = error%message
      return
    end if
    do k = 1, nt
      q(k, :) = q_out(:, k)
      ! Reactions from the multipliers of eq. 3.55/3.57 at the integrated state (IDA's own
      ! lambda is only Newton-accurate), energy, |g|; model%st then holds the frames of q.
      call sample_state(deck%model, t(k), q_out(:, k), v_out(:, k), wr, energy(k), gviol(k), info)
      wrenches(k, :) = wr
      do j = 1, nb
        ang(j, :) = thesis_angles(deck%model%chain%joint_kind(j), joint_angles(deck%model%chain, q_out(:, k), j))
        cm(k, 3*j - 2:3*j) = deck%model%st%cm(:, j)
      end do
      angles_deg(k, 1::2) = ang(:, 1)*RAD2DEG
      angles_deg(k, 2::2) = ang(:, 2)*RAD2DEG
    end do
  end subroutine rc_run_dynamic

  !> Every model quantity at one state, for the tests (checks against independent
  !> formulations and finite differences).
  subroutine rc_evaluate(path, nq, ncd, t, q, v, vdot, lambda, mass_crba, mass_jourdain, k_gen, res, &
                         g, g_jac, g_bias, g_vel, vdot_acc, lambda_acc, wrenches, energy, stat, msg)
    character(len=*), intent(in) :: path          !< deck file
    integer(c_int), intent(in) :: nq, ncd                !< coordinates, max(1, constraint rows)
    real(c_double), intent(in) :: t                     !< time [s]
    real(c_double), intent(in) :: q(nq), v(nq), vdot(nq) !< state and accelerations
    real(c_double), intent(in) :: lambda(ncd)           !< multipliers
    real(c_double), intent(out) :: mass_crba(nq, nq)    !< M by composite rigid bodies
    real(c_double), intent(out) :: mass_jourdain(nq, nq) !< M by the thesis's Jourdain form
    real(c_double), intent(out) :: k_gen(nq)            !< k(q, v, t)
    real(c_double), intent(out) :: res(nq)              !< M vdot - k - G^T lambda by inverse dynamics
    real(c_double), intent(out) :: g(ncd)               !< g(q)
    real(c_double), intent(out) :: g_jac(ncd, nq)       !< G(q)
    real(c_double), intent(out) :: g_bias(ncd)          !< Gdot v
    real(c_double), intent(out) :: g_vel(ncd)           !< G v
    real(c_double), intent(out) :: vdot_acc(nq)         !< accelerations from eq. 3.55
    real(c_double), intent(out) :: lambda_acc(ncd)      !< multipliers from eq. 3.55
    real(c_double), intent(out) :: wrenches(12)         !< support wrenches for (vdot_acc, lambda_acc)
    real(c_double), intent(out) :: energy               !< total energy [J]
    integer(c_int), intent(out) :: stat                  !< 0 = ok
    character(len=1024), intent(out) :: msg       !< why not
    type(deck_type) :: deck
    character(len=64) :: group, key
    integer :: nc, info

    mass_crba = 0.0_dp; mass_jourdain = 0.0_dp; k_gen = 0.0_dp; res = 0.0_dp; g = 0.0_dp; g_jac = 0.0_dp
    g_bias = 0.0_dp; g_vel = 0.0_dp; vdot_acc = 0.0_dp; lambda_acc = 0.0_dp; wrenches = 0.0_dp; energy = 0.0_dp
    call open_deck(path, deck, stat, group, key, msg)
    if (stat /= 0) return
    nc = deck%model%nc
    call mass_matrix(deck%model, q, mass_crba)
    call mass_matrix_jourdain(deck%model%chain, deck%model%st, mass_jourdain)
    call generalized_forces(deck%model, t, q, v, k_gen)
    call eom_residual(deck%model, t, q, v, vdot, lambda, res)
    if (nc > 0) then
      call constraint_residual(deck%model, q, g(1:nc))
      call constraint_jacobian(deck%model, q, g_jac(1:nc, :))
      call constraint_bias(deck%model, q, v, g_bias(1:nc))
      call constraint_velocity(deck%model, q, v, g_vel(1:nc))
    end if
    call solve_accelerations(deck%model, t, q, v, vdot_acc, lambda_acc(1:nc), info)
    if (info /= 0) then
      stat = 3
      msg = 'singular acceleration system'
    end if
    call reaction_wrenches(deck%model, t, q, v, vdot_acc, lambda_acc, wrenches)
    energy = total_energy(deck%model, q, v)
  end subroutine rc_evaluate

end module rotorcable_api
