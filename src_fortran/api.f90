!> The f2py boundary: one flat module of scalars and explicit-shape arrays, each argument with
!> its intent, and no derived type (f2py cannot wrap one); everything else stays behind it.
!> Python hands the validated description of a deck to the core once (rc_model_*), gets a
!> handle back, and runs every analysis on that handle; nothing here reads a file, so what
!> crosses is the model, never a path the core would parse again.
!> Every routine that can fail returns stat (0 = ok, 1 = bad input, 2 = run failed), the input
!> at fault as 'group.key' (bad input only) and a message (rc_model_free and rc_dynamic_free
!> cannot fail and return nothing); pydriver/core.py is the only Python module that calls
!> these routines and unpacks their results.
module rotorcable_api
  use, intrinsic :: iso_c_binding, only: c_double, c_int
  use rotorcable_kinds, only: dp
  use rotorcable_errors, only: error_type, fatal_error
  use rotorcable_model, only: model_type, constraint_residual
  use rotorcable_model_registry, only: register_model, lookup_model, release_model, register_session, &
                                       lookup_session, release_session, open_sessions
  use rotorcable_model_update, only: update_parameter, parameter_value
  use rotorcable_parameter_block, only: parameter_block, block_from_flat
  use rotorcable_model_builder, only: build_chain, build_load, build_base, build_support, build_rotor, &
                                      build_finish, thesis_to_coordinates
  use rotorcable_statics, only: static_settings, static_result, solve_static, static_system
  use rotorcable_modal, only: reduced_matrices
  use rotorcable_dae_integrator, only: integrator_settings, settings_from_flat, dae_session, session_start, &
                                       session_advance, consistent_start
  use rotorcable_monodromy, only: monodromy_run, monodromy_columns_run
  use rotorcable_parameter_sensitivity, only: difference_points, parameter_sensitivity_run
  use rotorcable_dae_integrator, only: solver_stats
  use rotorcable_sampling, only: sample_state, joint_loads, shape_of, support_motion
  implicit none
  private
  public :: rc_model_new, rc_model_free, rc_model_add_load, rc_model_set_base, rc_model_add_support, &
            rc_model_set_rotor, rc_model_finish, rc_thesis_coordinates, rc_shape, rc_static, &
            rc_static_system, rc_modal_matrices, rc_dynamic_start, rc_dynamic_advance, rc_dynamic_free, rc_sample, &
            rc_monodromy, rc_model_update, rc_model_parameter, rc_constraint_residual, rc_consistent_start, &
            rc_parameter_sensitivity, rc_monodromy_columns

contains

  !> Copy an error into the boundary's (stat, key, msg): stat 1 when it names an input.
  subroutine report(error, stat, key, msg)
    type(error_type), intent(in) :: error
    integer(c_int), intent(out) :: stat
    character(len=64), intent(out) :: key
    character(len=1024), intent(out) :: msg
    stat = 0; key = ''; msg = ''
    if (error%code == 0) return
    stat = 2
    msg = error%message
    if (allocated(error%key)) then
      if (len_trim(error%key) > 0) then
        stat = 1
        key = error%key
      end if
    end if
  end subroutine report

  !> The model of a handle, or an error.
  function model_of(handle, error) result(model)
    integer(c_int), intent(in) :: handle
    type(error_type), intent(inout) :: error
    type(model_type), pointer :: model
    model => lookup_model(handle)
    if (.not. associated(model)) call fatal_error(error, 'no model with this handle (freed?)')
  end function model_of

  !> A new model: the chain of nb cylinders and its joints.
  subroutine rc_model_new(nb, lengths, radii, masses, joint_kind, locked, locked_angles, handle, stat, key, msg)
    integer(c_int), intent(in) :: nb              !< bodies
    real(c_double), intent(in) :: lengths(nb)     !< body lengths [m]
    real(c_double), intent(in) :: radii(nb)       !< body radii [m]
    real(c_double), intent(in) :: masses(nb)      !< body masses [kg]
    integer(c_int), intent(in) :: joint_kind      !< 1 thesis zy, 2 Cardan xy, 3 Cardan xyz
    integer(c_int), intent(in) :: locked(nb)      !< 1 = joint locked (clamped first body)
    real(c_double), intent(in) :: locked_angles(2, nb)  !< thesis gamma, beta of every joint [rad]
    integer(c_int), intent(out) :: handle         !< model handle
    integer(c_int), intent(out) :: stat           !< 0 ok, 1 bad input, 2 failed
    character(len=64), intent(out) :: key         !< 'group.key' at fault
    character(len=1024), intent(out) :: msg       !< why
    type(model_type), pointer :: model
    type(error_type) :: error
    integer :: h
    call register_model(model, h)
    handle = h
    call build_chain(model, lengths, radii, masses, joint_kind, locked /= 0, locked_angles, error)
    call report(error, stat, key, msg)
  end subroutine rc_model_new

  !> Free a model (and its sessions).
  subroutine rc_model_free(handle)
    integer(c_int), intent(in) :: handle          !< model handle
    call release_model(handle)
  end subroutine rc_model_free

  !> Add a load of the given kind (rotorcable_loads_factory) with its parameter block, sent flat
  !> (rotorcable_parameter_block): named real arrays and named integer arrays.
  subroutine rc_model_add_load(handle, kind, real_names, nrn, real_sizes, nr, reals, int_names, nin, int_sizes, &
                               ni, ints, stat, key, msg)
    integer(c_int), intent(in) :: handle          !< model handle
    character(len=*), intent(in) :: kind          !< load kind
    include 'flat_block_arguments.inc'
    integer(c_int), intent(out) :: stat           !< status
    character(len=64), intent(out) :: key         !< input at fault
    character(len=1024), intent(out) :: msg       !< why
    type(model_type), pointer :: model
    type(parameter_block) :: params
    type(error_type) :: error
    model => model_of(handle, error)
    if (error%code == 0) call block_from_flat(trim(kind), real_names, real_sizes, reals, int_names, int_sizes, ints, &
                                              params, error)
    if (error%code == 0) call build_load(model, trim(kind), params, error)
    call report(error, stat, key, msg)
  end subroutine rc_model_add_load

  !> Support A: reference pose and prescribed motion, a parameter block sent flat as for
  !> rc_model_add_load (rotorcable_model_builder, build_base).
  subroutine rc_model_set_base(handle, real_names, nrn, real_sizes, nr, reals, int_names, nin, int_sizes, ni, ints, stat, key, msg)
    integer(c_int), intent(in) :: handle          !< model handle
    include 'flat_block_arguments.inc'
    integer(c_int), intent(out) :: stat           !< status
    character(len=64), intent(out) :: key         !< input at fault
    character(len=1024), intent(out) :: msg       !< why
    type(model_type), pointer :: model
    type(parameter_block) :: params
    type(error_type) :: error
    model => model_of(handle, error)
    if (error%code == 0) call block_from_flat('clamp A', real_names, real_sizes, reals, int_names, int_sizes, ints, &
                                              params, error)
    if (error%code == 0) call build_base(model, params, error)
    call report(error, stat, key, msg)
  end subroutine rc_model_set_base

  !> Support B of the given kind (rotorcable_supports_factory) with its parameter block, sent
  !> flat as for rc_model_add_load.
  subroutine rc_model_add_support(handle, kind, real_names, nrn, real_sizes, nr, reals, int_names, nin, int_sizes, &
                                  ni, ints, stat, key, msg)
    integer(c_int), intent(in) :: handle          !< model handle
    character(len=*), intent(in) :: kind          !< support kind
    include 'flat_block_arguments.inc'
    integer(c_int), intent(out) :: stat           !< status
    character(len=64), intent(out) :: key         !< input at fault
    character(len=1024), intent(out) :: msg       !< why
    type(model_type), pointer :: model
    type(parameter_block) :: params
    type(error_type) :: error
    model => model_of(handle, error)
    if (error%code == 0) call block_from_flat(trim(kind), real_names, real_sizes, reals, int_names, int_sizes, ints, &
                                              params, error)
    if (error%code == 0) call build_support(model, trim(kind), params, error)
    call report(error, stat, key, msg)
  end subroutine rc_model_add_support

  !> The rotor and the frame of the equations, a parameter block sent flat as for
  !> rc_model_add_load (rotorcable_model_builder, build_rotor).
  subroutine rc_model_set_rotor(handle, real_names, nrn, real_sizes, nr, reals, int_names, nin, int_sizes, ni, ints, stat, key, msg)
    integer(c_int), intent(in) :: handle          !< model handle
    include 'flat_block_arguments.inc'
    integer(c_int), intent(out) :: stat           !< status
    character(len=64), intent(out) :: key         !< input at fault
    character(len=1024), intent(out) :: msg       !< why
    type(model_type), pointer :: model
    type(parameter_block) :: params
    type(error_type) :: error
    model => model_of(handle, error)
    if (error%code == 0) call block_from_flat('rotor', real_names, real_sizes, reals, int_names, int_sizes, ints, &
                                              params, error)
    if (error%code == 0) call build_rotor(model, params, error)
    call report(error, stat, key, msg)
  end subroutine rc_model_set_rotor

  !> Finish the model (workspace, geometric checks); returns its sizes.
  subroutine rc_model_finish(handle, nq, nc, stat, key, msg)
    integer(c_int), intent(in) :: handle          !< model handle
    integer(c_int), intent(out) :: nq, nc         !< coordinates, constraint rows
    integer(c_int), intent(out) :: stat           !< status
    character(len=64), intent(out) :: key         !< input at fault
    character(len=1024), intent(out) :: msg       !< why
    type(model_type), pointer :: model
    type(error_type) :: error
    nq = 0; nc = 0
    model => model_of(handle, error)
    if (error%code == 0) then
      call build_finish(model, error)
      nq = model%nq; nc = model%nc
    end if
    call report(error, stat, key, msg)
  end subroutine rc_model_finish

  !> Change a named parameter of a built model in place (rotorcable_model_update: rotor.omega,
  !> loads.pulse, springs.stiffness, springs.damping).  Refused while a session integrates the
  !> model.  An unknown name, or one the model has no component for, is a failed call (stat 2)
  !> whose message names the parameter: the name comes from the program, not from a deck.
  subroutine rc_model_update(handle, name, n, values, stat, key, msg)
    integer(c_int), intent(in) :: handle          !< model handle
    character(len=*), intent(in) :: name          !< parameter name
    integer(c_int), intent(in) :: n               !< number of values
    real(c_double), intent(in) :: values(n)       !< new value(s) [SI]
    integer(c_int), intent(out) :: stat           !< status
    character(len=64), intent(out) :: key         !< input at fault
    character(len=1024), intent(out) :: msg       !< why
    type(model_type), pointer :: model
    type(error_type) :: error
    character(len=160) :: buf
    model => model_of(handle, error)
    if (error%code == 0 .and. open_sessions(handle) > 0) then
      write (buf, '(3a, i0, a)') 'model parameter ''', trim(name), ''': ', open_sessions(handle), &
        ' integration(s) of this model are open; close them before updating it'
      call fatal_error(error, trim(buf))
    end if
    if (error%code == 0) call update_parameter(model, trim(name), values, error)
    call report(error, stat, key, msg)
  end subroutine rc_model_update

  !> The current value of a named parameter (values(1:count); nmax large enough: max(nq, 1)).
  subroutine rc_model_parameter(handle, name, nmax, values, count, stat, key, msg)
    integer(c_int), intent(in) :: handle          !< model handle
    character(len=*), intent(in) :: name          !< parameter name
    integer(c_int), intent(in) :: nmax            !< room in values
    real(c_double), intent(out) :: values(nmax)   !< the value(s) [SI]
    integer(c_int), intent(out) :: count          !< how many
    integer(c_int), intent(out) :: stat           !< status
    character(len=64), intent(out) :: key         !< input at fault
    character(len=1024), intent(out) :: msg       !< why
    type(model_type), pointer :: model
    type(error_type) :: error
    real(dp), allocatable :: found(:)
    values = 0.0_dp; count = 0
    model => model_of(handle, error)
    if (error%code == 0) call parameter_value(model, trim(name), found, error)
    if (error%code == 0) then
      if (size(found) > nmax) then
        call fatal_error(error, 'rc_model_parameter: too little room for '''//trim(name)//'''')
      else
        count = size(found)
        values(1:count) = found
      end if
    end if
    call report(error, stat, key, msg)
  end subroutine rc_model_parameter

  !> An error unless the caller's sizes are the model's (explicit-shape arrays of another size
  !> would be read or written out of bounds).
  subroutine check_sizes(model, nq, nb, routine, error)
    type(model_type), intent(in) :: model
    integer(c_int), intent(in) :: nq, nb          !< coordinates, bodies as the caller has them
    character(len=*), intent(in) :: routine       !< for the message
    type(error_type), intent(inout) :: error
    character(len=160) :: buf
    if (nq == model%nq .and. nb == model%chain%n_bodies) return
    write (buf, '(a, 4(a, i0), a)') routine, ': wrong sizes (nq = ', nq, ', nb = ', nb, &
      '; the model has nq = ', model%nq, ', nb = ', model%chain%n_bodies, ')'
    call fatal_error(error, trim(buf))
  end subroutine check_sizes

  !> Coordinates and rates of a shape in the thesis's angles.
  subroutine rc_thesis_coordinates(handle, nb, gamma, beta, gamma_rate, beta_rate, nq, q, v, stat, key, msg)
    integer(c_int), intent(in) :: handle          !< model handle
    integer(c_int), intent(in) :: nb              !< bodies
    real(c_double), intent(in) :: gamma(nb), beta(nb)  !< thesis angles [rad]
    real(c_double), intent(in) :: gamma_rate(nb), beta_rate(nb)  !< their rates [rad/s]
    integer(c_int), intent(in) :: nq              !< coordinates
    real(c_double), intent(out) :: q(nq), v(nq)   !< coordinates [rad], rates [rad/s]
    integer(c_int), intent(out) :: stat           !< status
    character(len=64), intent(out) :: key         !< input at fault
    character(len=1024), intent(out) :: msg       !< why
    type(model_type), pointer :: model
    type(error_type) :: error
    q = 0.0_dp; v = 0.0_dp
    model => model_of(handle, error)
    if (error%code == 0) call check_sizes(model, nq, nb, 'rc_thesis_coordinates', error)
    if (error%code == 0) call thesis_to_coordinates(model, gamma, beta, gamma_rate, beta_rate, q, v)
    call report(error, stat, key, msg)
  end subroutine rc_thesis_coordinates

  !> Shape at (q, t): thesis angles, CMs, joint points, and the last body's rotation.
  subroutine rc_shape(handle, t, nq, q, nb, angles, cm, joints, rotations, stat, key, msg)
    integer(c_int), intent(in) :: handle          !< model handle
    real(c_double), intent(in) :: t               !< time [s]
    integer(c_int), intent(in) :: nq, nb          !< coordinates, bodies
    real(c_double), intent(in) :: q(nq)           !< coordinates [rad]
    real(c_double), intent(out) :: angles(2, nb)  !< thesis gamma, beta [rad]
    real(c_double), intent(out) :: cm(3, nb)      !< centres of mass [m]
    real(c_double), intent(out) :: joints(3, nb + 1)  !< joint points, last = tip [m]
    real(c_double), intent(out) :: rotations(3, 3, nb)  !< R_j: model frame <- body j (R_n: the last body)
    integer(c_int), intent(out) :: stat           !< status
    character(len=64), intent(out) :: key         !< input at fault
    character(len=1024), intent(out) :: msg       !< why
    type(model_type), pointer :: model
    type(error_type) :: error
    angles = 0.0_dp; cm = 0.0_dp; joints = 0.0_dp; rotations = 0.0_dp
    model => model_of(handle, error)
    if (error%code == 0) call check_sizes(model, nq, nb, 'rc_shape', error)
    if (error%code == 0) then
      call shape_of(model, t, q, angles, cm, joints, rotations=rotations)
    end if
    call report(error, stat, key, msg)
  end subroutine rc_shape

  !> Static equilibrium (relative to the model frame) at time t from a start shape.
  subroutine rc_static(handle, t, nq, q_start, ncd, tol_force, max_iter, q, lambda, stats, stat, key, msg)
    integer(c_int), intent(in) :: handle          !< model handle
    real(c_double), intent(in) :: t               !< time [s]
    integer(c_int), intent(in) :: nq, ncd         !< coordinates, max(1, nc)
    real(c_double), intent(in) :: q_start(nq)     !< start shape [rad]
    real(c_double), intent(in) :: tol_force       !< Newton tolerance [Nm]
    integer(c_int), intent(in) :: max_iter        !< Newton iterations
    real(c_double), intent(out) :: q(nq)          !< equilibrium [rad]
    real(c_double), intent(out) :: lambda(ncd)    !< multipliers
    integer(c_int), intent(out) :: stats(4)       !< iterations, residual evals, Jacobians, step cuts
    integer(c_int), intent(out) :: stat           !< status
    character(len=64), intent(out) :: key         !< input at fault
    character(len=1024), intent(out) :: msg       !< why
    type(model_type), pointer :: model
    type(error_type) :: error
    type(static_settings) :: settings
    type(static_result) :: res
    q = q_start; lambda = 0.0_dp; stats = 0
    model => model_of(handle, error)
    if (error%code == 0) then
      settings%t = t
      settings%tol_force = tol_force
      settings%max_iterations = max_iter
      call solve_static(model, settings, q, lambda(1:model%nc), res, error)
      stats = [res%iterations, res%residual_evals, res%jacobian_evals, res%line_search_cuts]
    end if
    call report(error, stat, key, msg)
  end subroutine rc_static

  !> The static equilibrium equations at a given state (q, lambda) at time t and, with
  !> with_jacobian = 1, their Jacobian in (q, lambda): rotorcable_statics, static_system.  For the
  !> design sensitivities (implicit function theorem at a converged equilibrium); nothing is solved.
  subroutine rc_static_system(handle, t, nq, q, ncd, lambda, with_jacobian, res, g, k_tan, g_jac, stat, key, msg)
    integer(c_int), intent(in) :: handle          !< model handle
    real(c_double), intent(in) :: t               !< time [s]
    integer(c_int), intent(in) :: nq, ncd         !< coordinates, max(1, nc)
    real(c_double), intent(in) :: q(nq)           !< coordinates [rad]
    real(c_double), intent(in) :: lambda(ncd)     !< multipliers
    integer(c_int), intent(in) :: with_jacobian   !< 1: also K and G
    real(c_double), intent(out) :: res(nq)        !< force residual -k(q,0) - G^T lambda [Nm]
    real(c_double), intent(out) :: g(ncd)         !< constraint residual
    real(c_double), intent(out) :: k_tan(nq, nq)  !< d res / dq at fixed lambda [Nm/rad]
    real(c_double), intent(out) :: g_jac(ncd, nq) !< constraint Jacobian G
    integer(c_int), intent(out) :: stat           !< status
    character(len=64), intent(out) :: key         !< input at fault
    character(len=1024), intent(out) :: msg       !< why
    type(model_type), pointer :: model
    type(error_type) :: error
    res = 0.0_dp; g = 0.0_dp; k_tan = 0.0_dp; g_jac = 0.0_dp
    model => model_of(handle, error)
    if (error%code == 0) then
      if (nq /= model%nq .or. ncd /= max(1, model%nc)) call fatal_error(error, 'rc_static_system: wrong sizes')
    end if
    if (error%code == 0) call static_system(model, t, q, lambda(1:model%nc), with_jacobian == 1, res, &
                                            g(1:model%nc), k_tan, g_jac(1:model%nc, :))
    call report(error, stat, key, msg)
  end subroutine rc_static_system

  !> The linearised equations about an equilibrium (q, lambda) at time t on the constraint
  !> manifold: null-space basis N, full M, and the reduced M_r, K_r, D_r (D_r with its
  !> gyroscopic part); their modes are solved in Python (pydriver/analyses/linear_modes.py: the
  !> modal analysis and the Campbell diagram).
  subroutine rc_modal_matrices(handle, t, nq, q, ncd, lambda, nf, basis, m_full, m_r, k_r, d_r, stat, key, msg)
    integer(c_int), intent(in) :: handle          !< model handle
    real(c_double), intent(in) :: t               !< time [s]
    integer(c_int), intent(in) :: nq, ncd, nf     !< coordinates, max(1, nc), nq - nc
    real(c_double), intent(in) :: q(nq)           !< equilibrium [rad]
    real(c_double), intent(in) :: lambda(ncd)     !< multipliers
    real(c_double), intent(out) :: basis(nq, nf)  !< N
    real(c_double), intent(out) :: m_full(nq, nq) !< M
    real(c_double), intent(out) :: m_r(nf, nf), k_r(nf, nf), d_r(nf, nf)  !< reduced matrices
    integer(c_int), intent(out) :: stat           !< status
    character(len=64), intent(out) :: key         !< input at fault
    character(len=1024), intent(out) :: msg       !< why
    type(model_type), pointer :: model
    type(error_type) :: error
    basis = 0.0_dp; m_full = 0.0_dp; m_r = 0.0_dp; k_r = 0.0_dp; d_r = 0.0_dp
    model => model_of(handle, error)
    if (error%code == 0) call reduced_matrices(model, t, q, lambda(1:model%nc), basis, m_full, m_r, k_r, d_r, error)
    call report(error, stat, key, msg)
  end subroutine rc_modal_matrices

  !> Start a time integration from (q0, v0) at t0 (made consistent: returned in q, v), with the
  !> integrator settings as a parameter block sent flat (pydriver/components.py SOLVER; so for
  !> rc_monodromy and rc_parameter_sensitivity).
  subroutine rc_dynamic_start(handle, real_names, nrn, real_sizes, nr, reals, int_names, nin, int_sizes, ni, ints, &
                              t0, nq, q0, v0, session, q, v, stat, key, msg)
    integer(c_int), intent(in) :: handle          !< model handle
    include 'flat_block_arguments.inc'
    real(c_double), intent(in) :: t0              !< start time [s]
    integer(c_int), intent(in) :: nq              !< coordinates
    real(c_double), intent(in) :: q0(nq), v0(nq)  !< start state
    integer(c_int), intent(out) :: session        !< session handle
    real(c_double), intent(out) :: q(nq), v(nq)   !< consistent start
    integer(c_int), intent(out) :: stat           !< status
    character(len=64), intent(out) :: key         !< input at fault
    character(len=1024), intent(out) :: msg       !< why
    type(model_type), pointer :: model
    type(dae_session), pointer :: s
    type(integrator_settings) :: settings
    type(error_type) :: error
    integer :: h
    session = 0
    q = q0; v = v0
    model => model_of(handle, error)
    if (error%code == 0) call settings_from_flat(real_names, real_sizes, reals, int_names, int_sizes, ints, settings, error)
    if (error%code == 0) then
      call register_session(handle, s, h)
      session = h
      call session_start(s, model, settings, t0, q, v, error)
    end if
    call report(error, stat, key, msg)
  end subroutine rc_dynamic_start

  !> Advance a session to the output times t(1:nt); returns the states and the statistics.
  subroutine rc_dynamic_advance(session, nt, t, nq, q, v, stats, stat, key, msg)
    integer(c_int), intent(in) :: session         !< session handle
    integer(c_int), intent(in) :: nt, nq          !< output times, coordinates
    real(c_double), intent(in) :: t(nt)           !< increasing output times [s]
    real(c_double), intent(out) :: q(nq, nt), v(nq, nt)  !< states at t
    integer(c_int), intent(out) :: stats(5)       !< steps, residual evals, Jacobians, error-test and convergence failures
    integer(c_int), intent(out) :: stat           !< status
    character(len=64), intent(out) :: key         !< input at fault
    character(len=1024), intent(out) :: msg       !< why
    type(dae_session), pointer :: s
    type(error_type) :: error
    q = 0.0_dp; v = 0.0_dp; stats = 0
    s => lookup_session(session)
    if (.not. associated(s)) then
      call fatal_error(error, 'no integration with this handle')
    else
      call session_advance(s, t, q, v, error)
      stats = [s%stats%steps, s%stats%residual_evals, s%stats%jacobian_evals, s%stats%error_test_failures, &
               s%stats%convergence_failures]
    end if
    call report(error, stat, key, msg)
  end subroutine rc_dynamic_advance

  !> End a session.
  subroutine rc_dynamic_free(session)
    integer(c_int), intent(in) :: session         !< session handle
    call release_session(session)
  end subroutine rc_dynamic_free

  !> Outputs at states (q, v) and times t: reactions, energies, constraint violation, shape,
  !> joint loads, rotor angle.
  subroutine rc_sample(handle, nt, t, nq, q, v, nb, ncd, wrenches, kinetic, potential, g_max, angles, cm, joints, &
                       axial, shear, bending, torsion, bend_angle, moment_xy, bend_xy, psi, multipliers, supports, &
                       stat, key, msg)
    integer(c_int), intent(in) :: handle          !< model handle
    integer(c_int), intent(in) :: nt, nq, nb      !< samples, coordinates, bodies
    integer(c_int), intent(in) :: ncd             !< max(1, nc)
    real(c_double), intent(in) :: t(nt)           !< times [s]
    real(c_double), intent(in) :: q(nq, nt), v(nq, nt)  !< states
    real(c_double), intent(out) :: wrenches(12, nt)     !< F_A, M_A, F_B, M_B [N, Nm]
    real(c_double), intent(out) :: kinetic(nt), potential(nt)  !< energies [J]
    real(c_double), intent(out) :: g_max(nt)      !< max |g| position rows [m]
    real(c_double), intent(out) :: angles(2, nb, nt)    !< thesis gamma, beta [rad]
    real(c_double), intent(out) :: cm(3, nb, nt)        !< centres of mass [m]
    real(c_double), intent(out) :: joints(3, nb + 1, nt)  !< joint points [m]
    real(c_double), intent(out) :: axial(nb, nt), shear(nb, nt)      !< joint forces [N]
    real(c_double), intent(out) :: bending(nb, nt), torsion(nb, nt)  !< joint moments [Nm]
    real(c_double), intent(out) :: bend_angle(nb, nt)   !< joint bending angles [rad]
    real(c_double), intent(out) :: moment_xy(2, nb, nt) !< bending moment in the child's axes [Nm]
    real(c_double), intent(out) :: bend_xy(2, nb, nt)   !< bend vector in the child's axes [rad]
    real(c_double), intent(out) :: psi(nt)        !< rotor angle [rad]
    real(c_double), intent(out) :: multipliers(ncd, nt)  !< lambda of eq. 3.55
    real(c_double), intent(out) :: supports(12, nt)      !< v_A, w_A, v_B, w_B relative to the frame
    integer(c_int), intent(out) :: stat           !< status
    character(len=64), intent(out) :: key         !< input at fault
    character(len=1024), intent(out) :: msg       !< why
    type(model_type), pointer :: model
    type(error_type) :: error
    integer :: k, info
    wrenches = 0.0_dp; kinetic = 0.0_dp; potential = 0.0_dp; g_max = 0.0_dp; angles = 0.0_dp; cm = 0.0_dp
    joints = 0.0_dp; axial = 0.0_dp; shear = 0.0_dp; bending = 0.0_dp; torsion = 0.0_dp; bend_angle = 0.0_dp
    moment_xy = 0.0_dp; bend_xy = 0.0_dp; psi = 0.0_dp; multipliers = 0.0_dp; supports = 0.0_dp
    model => model_of(handle, error)
    if (error%code == 0) then
      do k = 1, nt
        call sample_state(model, t(k), q(:, k), v(:, k), wrenches(:, k), kinetic(k), potential(k), g_max(k), info, &
                          multipliers(1:model%nc, k))
        if (info /= 0) then
          call fatal_error(error, 'singular acceleration system at an output sample (dependent constraints '// &
                           'or a non-finite state)')
          exit
        end if
        call joint_loads(model, t(k), q(:, k), v(:, k), axial(:, k), shear(:, k), bending(:, k), torsion(:, k), &
                         bend_angle(:, k), moment_xy(:, :, k), bend_xy(:, :, k))
        call shape_of(model, t(k), q(:, k), angles(:, :, k), cm(:, :, k), joints(:, :, k))
        call support_motion(model, t(k), supports(:, k))
        psi(k) = model%rs%psi
      end do
    end if
    call report(error, stat, key, msg)
  end subroutine rc_sample

  !> One period from (q0, v0) at t0 with the forward sensitivities of the independent
  !> coordinates x = (a, b) (rotorcable_monodromy): states at the output times t (the last one
  !> ends the period), the consistent start, the null-space basis N and the monodromy matrix.
  subroutine rc_monodromy(handle, real_names, nrn, real_sizes, nr, reals, int_names, nin, int_sizes, ni, ints, &
                          t0, nq, q0, v0, nt, t, nf, q, v, &
                          q_start, v_start, basis, phi, stats, stat, key, msg)
    integer(c_int), intent(in) :: handle          !< model handle
    include 'flat_block_arguments.inc'
    real(c_double), intent(in) :: t0              !< start time [s]
    integer(c_int), intent(in) :: nq, nt, nf      !< coordinates, output times, nq - nc
    real(c_double), intent(in) :: q0(nq), v0(nq)  !< start state
    real(c_double), intent(in) :: t(nt)           !< increasing output times > t0 [s]
    real(c_double), intent(out) :: q(nq, nt), v(nq, nt)  !< states at t
    real(c_double), intent(out) :: q_start(nq), v_start(nq)  !< consistent start
    real(c_double), intent(out) :: basis(nq, nf)  !< N
    real(c_double), intent(out) :: phi(2*nf, 2*nf)  !< monodromy matrix in x = (a, b)
    integer(c_int), intent(out) :: stats(6)       !< steps, residual evals, Jacobians, error-test and
                                                  !< convergence failures, sensitivity residual evals
    integer(c_int), intent(out) :: stat           !< status
    character(len=64), intent(out) :: key         !< input at fault
    character(len=1024), intent(out) :: msg       !< why
    type(model_type), pointer :: model
    type(error_type) :: error
    type(solver_stats) :: st
    type(integrator_settings) :: settings
    integer :: n_sens
    q = 0.0_dp; v = 0.0_dp; basis = 0.0_dp; phi = 0.0_dp; stats = 0
    q_start = q0; v_start = v0
    model => model_of(handle, error)
    if (error%code == 0) then
      if (nf /= model%nq - model%nc .or. nq /= model%nq) call fatal_error(error, 'rc_monodromy: wrong sizes')
    end if
    if (error%code == 0) call settings_from_flat(real_names, real_sizes, reals, int_names, int_sizes, ints, settings, error)
    if (error%code == 0) then
      call monodromy_run(model, settings, t0, q_start, v_start, t, q, v, basis, phi, st, n_sens, error)
      stats = [st%steps, st%residual_evals, st%jacobian_evals, st%error_test_failures, st%convergence_failures, &
               n_sens]
    end if
    call report(error, stat, key, msg)
  end subroutine rc_monodromy

  !> The monodromy applied to k start perturbations (dq, dv) (rotorcable_monodromy's
  !> monodromy_columns_run): states at the output times t (the last one ends the period), the
  !> consistent start, the null-space basis N and the images Phi x_j of the directions
  !> x_j = (N^T dq_j, N^T dv_j), the columns held to the absolute tolerance column_atol.
  subroutine rc_monodromy_columns(handle, real_names, nrn, real_sizes, nr, reals, int_names, nin, int_sizes, ni, &
                                  ints, column_atol, t0, nq, q0, v0, nt, t, nf, k, dq, dv, q, v, &
                                  q_start, v_start, basis, images, stats, stat, key, msg)
    integer(c_int), intent(in) :: handle          !< model handle
    include 'flat_block_arguments.inc'
    real(c_double), intent(in) :: column_atol     !< absolute tolerance of the columns (> 0)
    real(c_double), intent(in) :: t0              !< start time [s]
    integer(c_int), intent(in) :: nq, nt, nf, k   !< coordinates, output times, nq - nc, columns
    real(c_double), intent(in) :: q0(nq), v0(nq)  !< start state
    real(c_double), intent(in) :: t(nt)           !< increasing output times > t0 [s]
    real(c_double), intent(in) :: dq(nq, k), dv(nq, k)  !< start perturbations of q and v
    real(c_double), intent(out) :: q(nq, nt), v(nq, nt)  !< states at t
    real(c_double), intent(out) :: q_start(nq), v_start(nq)  !< consistent start
    real(c_double), intent(out) :: basis(nq, nf)  !< N
    real(c_double), intent(out) :: images(2*nf, k)  !< Phi x_j in x = (a, b)
    integer(c_int), intent(out) :: stats(6)       !< as rc_monodromy
    integer(c_int), intent(out) :: stat           !< status
    character(len=64), intent(out) :: key         !< input at fault
    character(len=1024), intent(out) :: msg       !< why
    type(model_type), pointer :: model
    type(error_type) :: error
    type(solver_stats) :: st
    type(integrator_settings) :: settings
    integer :: n_sens
    q = 0.0_dp; v = 0.0_dp; basis = 0.0_dp; images = 0.0_dp; stats = 0
    q_start = q0; v_start = v0
    model => model_of(handle, error)
    if (error%code == 0) then
      if (nf /= model%nq - model%nc .or. nq /= model%nq .or. k < 1) &
        call fatal_error(error, 'rc_monodromy_columns: wrong sizes')
      if (.not. column_atol > 0.0_dp) call fatal_error(error, 'rc_monodromy_columns: column_atol must be > 0')
    end if
    if (error%code == 0) call settings_from_flat(real_names, real_sizes, reals, int_names, int_sizes, ints, settings, error)
    if (error%code == 0) then
      call monodromy_columns_run(model, settings, column_atol, t0, q_start, v_start, t, dq, dv, q, v, basis, images, &
                                 st, n_sens, error)
      stats = [st%steps, st%residual_evals, st%jacobian_evals, st%error_test_failures, st%convergence_failures, &
               n_sens]
    end if
    call report(error, stat, key, msg)
  end subroutine rc_monodromy_columns

  !> The constraint residual g(q, t) of the supports (clamp B: position, then rotation rows;
  !> src_fortran/supports/clamp.f90).  For clamp B's pose at any time (pydriver/analyses/clamp_reach.py).
  subroutine rc_constraint_residual(handle, t, nq, q, ncd, g, stat, key, msg)
    integer(c_int), intent(in) :: handle          !< model handle
    real(c_double), intent(in) :: t               !< time [s]
    integer(c_int), intent(in) :: nq, ncd         !< coordinates, max(1, nc)
    real(c_double), intent(in) :: q(nq)           !< coordinates [rad]
    real(c_double), intent(out) :: g(ncd)         !< g(q, t) (the first nc entries)
    integer(c_int), intent(out) :: stat           !< status
    character(len=64), intent(out) :: key         !< input at fault
    character(len=1024), intent(out) :: msg       !< why
    type(model_type), pointer :: model
    type(error_type) :: error
    g = 0.0_dp
    model => model_of(handle, error)
    if (error%code == 0) then
      if (nq /= model%nq .or. ncd /= max(1, model%nc)) call fatal_error(error, 'rc_constraint_residual: wrong sizes')
    end if
    if (error%code == 0) call constraint_residual(model, t, q, g(1:model%nc))
    call report(error, stat, key, msg)
  end subroutine rc_constraint_residual

  !> The consistent start from (q0, v0) at t, as the integrator makes it (positions projected
  !> onto g = 0, velocities onto G v + g_t = 0, then eq. 3.55 for the accelerations and
  !> multipliers), without starting an integration.  For the scene (pydriver/scene.py).
  subroutine rc_consistent_start(handle, t, nq, q0, v0, ncd, q, v, vdot, lambda, stat, key, msg)
    integer(c_int), intent(in) :: handle          !< model handle
    real(c_double), intent(in) :: t               !< time [s]
    integer(c_int), intent(in) :: nq, ncd         !< coordinates, max(1, nc)
    real(c_double), intent(in) :: q0(nq), v0(nq)  !< start state [rad], [rad/s]
    real(c_double), intent(out) :: q(nq), v(nq)   !< consistent start state
    real(c_double), intent(out) :: vdot(nq)       !< consistent accelerations [rad/s^2]
    real(c_double), intent(out) :: lambda(ncd)    !< consistent multipliers (the first nc entries)
    integer(c_int), intent(out) :: stat           !< status
    character(len=64), intent(out) :: key         !< input at fault
    character(len=1024), intent(out) :: msg       !< why
    type(model_type), pointer :: model
    type(error_type) :: error
    q = q0; v = v0; vdot = 0.0_dp; lambda = 0.0_dp
    model => model_of(handle, error)
    if (error%code == 0) then
      if (nq /= model%nq .or. ncd /= max(1, model%nc)) call fatal_error(error, 'rc_consistent_start: wrong sizes')
    end if
    if (error%code == 0) call consistent_start(model, t, q, v, vdot, lambda(1:model%nc), error)
    call report(error, stat, key, msg)
  end subroutine rc_consistent_start

  !> An integration from (q0, v0) at t0 through the output times t with the forward
  !> sensitivities of np design parameters (rotorcable_parameter_sensitivity), starting from the
  !> state sensitivities (sq0, sv0).  The explicit partial dF/dp_k is sum_i weights(i, k)
  !> F(model handles(i, k)) / h(k) (handle 0: this model).
  subroutine rc_parameter_sensitivity(handle, real_names, nrn, real_sizes, nr, reals, int_names, nin, int_sizes, &
                                      ni, ints, t0, nq, q0, v0, &
                                      np, npts, handles, offsets, weights, h, pbar, loads_only, nl, changed_loads, &
                                      tolerance_scale, sq0, sv0, nt, t, q, v, &
                                      q_start, v_start, sq, sv, sq_start, sv_start, stats, stat, key, msg)
    integer(c_int), intent(in) :: handle          !< model handle
    include 'flat_block_arguments.inc'
    real(c_double), intent(in) :: t0              !< start time [s]
    integer(c_int), intent(in) :: nq, np, npts, nt  !< coordinates, parameters, difference points, output times
    real(c_double), intent(in) :: q0(nq), v0(nq)  !< start state
    integer(c_int), intent(in) :: handles(npts, np)  !< rebuilt models (0: this model)
    real(c_double), intent(in) :: offsets(npts, np)  !< their offsets in steps
    real(c_double), intent(in) :: weights(npts, np)  !< difference weights (0: unused point)
    real(c_double), intent(in) :: h(np)           !< steps [unit of p]
    real(c_double), intent(in) :: pbar(np)        !< scales of the parameters (> 0)
    !> 1: the rebuilt models differ in their loads only; 2: in their bodies' masses and inertias
    !> and their loads (the run's kinematics); 0: otherwise
    integer(c_int), intent(in) :: loads_only(np)
    integer(c_int), intent(in) :: nl              !< load slots described by changed_loads
    !> with loads_only 1 or 2: 1 where the rebuilt models' load in that slot differs from the
    !> run's (the others cancel in the difference and are not evaluated)
    integer(c_int), intent(in) :: changed_loads(nl, np)
    !> the sensitivities' tolerances are the state's times this (>= 1: products whose weight in
    !> the result is small, the inexact Krylov blocks of pydriver's periodic start)
    real(c_double), intent(in) :: tolerance_scale
    real(c_double), intent(in) :: sq0(nq, np), sv0(nq, np)  !< start sensitivities
    real(c_double), intent(in) :: t(nt)           !< increasing output times > t0 [s]
    real(c_double), intent(out) :: q(nq, nt), v(nq, nt)  !< states at t
    real(c_double), intent(out) :: q_start(nq), v_start(nq)  !< consistent start
    real(c_double), intent(out) :: sq(nq, nt, np), sv(nq, nt, np)  !< sensitivities at t
    real(c_double), intent(out) :: sq_start(nq, np), sv_start(nq, np)  !< consistent start sensitivities
    integer(c_int), intent(out) :: stats(6)       !< as rc_monodromy
    integer(c_int), intent(out) :: stat           !< status
    character(len=64), intent(out) :: key         !< input at fault
    character(len=1024), intent(out) :: msg       !< why
    type(model_type), pointer :: model
    type(difference_points), target :: points
    type(error_type) :: error
    type(solver_stats) :: st
    type(integrator_settings) :: settings
    integer :: n_sens, i, k
    q = 0.0_dp; v = 0.0_dp; sq = 0.0_dp; sv = 0.0_dp; stats = 0
    q_start = q0; v_start = v0; sq_start = sq0; sv_start = sv0
    model => model_of(handle, error)
    if (error%code == 0) then
      if (nq /= model%nq) call fatal_error(error, 'rc_parameter_sensitivity: wrong sizes')
      if (any(pbar <= 0.0_dp) .or. any(h <= 0.0_dp) .or. .not. tolerance_scale >= 1.0_dp) &
        call fatal_error(error, 'rc_parameter_sensitivity: steps and parameter scales must be > 0, the '// &
                         'tolerance scale >= 1')
    end if
    if (error%code == 0) then
      allocate (points%model(npts, np))
      points%offset = offsets; points%weight = weights; points%h = h
      points%loads_only = loads_only == 1
      points%bodies_and_loads = loads_only == 2
      points%changed_load = changed_loads /= 0
      do k = 1, np
        do i = 1, npts
          if (handles(i, k) == 0) cycle
          points%model(i, k)%m => model_of(handles(i, k), error)
          if (error%code /= 0) exit
          if (points%model(i, k)%m%nq /= model%nq .or. points%model(i, k)%m%nc /= model%nc) &
            call fatal_error(error, 'rc_parameter_sensitivity: a rebuilt model has other sizes than the run''s')
          if (error%code /= 0) exit
        end do
        if (error%code /= 0) exit
      end do
    end if
    if (error%code == 0) call settings_from_flat(real_names, real_sizes, reals, int_names, int_sizes, ints, settings, error)
    if (error%code == 0) then
      call parameter_sensitivity_run(model, points, pbar, settings, t0, &
                                     q_start, v_start, sq0, sv0, t, q, v, sq, sv, st, n_sens, error, sq_start, sv_start, &
                                     tolerance_scale)
      stats = [st%steps, st%residual_evals, st%jacobian_evals, st%error_test_failures, st%convergence_failures, &
               n_sens]
    end if
    call report(error, stat, key, msg)
  end subroutine rc_parameter_sensitivity

end module rotorcable_api
