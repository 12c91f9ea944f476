!> Building a model from its description in flat arrays and parameter blocks (what Python's
!> schema-validated deck becomes): the chain, then loads and supports through their factories, the rotor, and the
!> checks that need the assembled geometry (reach of clamp B, enough coordinates).
module rotorcable_model_builder
  use rotorcable_kinds, only: dp
  use rotorcable_errors, only: error_type, fatal_error
  use rotorcable_chain, only: chain_allocate
  use rotorcable_joint, only: angles_from_thesis, MAX_JOINT_DOF
  use rotorcable_model, only: model_type, model_init
  use rotorcable_loads_type, only: load_slot
  use rotorcable_loads_factory, only: new_load
  use rotorcable_parameter_block, only: parameter_block, get_int, get_reals
  use rotorcable_supports_factory, only: new_support
  use rotorcable_projection, only: clamp_reach
  use rotorcable_motion_builder, only: motion_from_block
  use rotorcable_motion_rotor, only: rotor_from_block
  implicit none
  private
  public :: build_chain, build_load, build_base, build_support, build_rotor, build_finish, thesis_to_coordinates

contains

  !> The chain: per-body cylinders, joint parametrisation, locked joints and their angles.
  subroutine build_chain(model, lengths, radii, masses, joint_kind, locked, locked_angles, error)
    type(model_type), intent(inout) :: model  !< model (fresh)
    real(dp), intent(in) :: lengths(:), radii(:), masses(:)  !< per body [m, m, kg]
    integer, intent(in) :: joint_kind         !< parametrisation of the free joints
    logical, intent(in) :: locked(:)          !< locked joints
    real(dp), intent(in) :: locked_angles(:, :)  !< (2,n) thesis gamma, beta of every joint [rad]
    type(error_type), intent(inout) :: error  !< status
    integer :: n
    n = size(lengths)
    if (n < 1 .or. size(radii) /= n .or. size(masses) /= n .or. size(locked) /= n) then
      call fatal_error(error, 'chain description: inconsistent sizes')
      return
    end if
    if (.not. (all(lengths > 0.0_dp) .and. all(radii > 0.0_dp) .and. all(masses > 0.0_dp))) then
      call fatal_error(error, 'every body needs a positive length, radius and mass', key='chain.n_bodies')
      return
    end if
    call chain_allocate(model%chain, n, lengths, radii, masses, locked, joint_kind)
    model%chain%locked_angles = locked_angles
    allocate (model%loads(0))
  end subroutine build_chain

  !> Append a load built by the load factory.
  subroutine build_load(model, kind, params, error)
    type(model_type), intent(inout) :: model  !< model with its chain
    character(len=*), intent(in) :: kind      !< load kind
    type(parameter_block), intent(in) :: params  !< its parameters by name
    type(error_type), intent(inout) :: error  !< status
    type(load_slot), allocatable :: grown(:)
    integer :: n
    n = size(model%loads)
    allocate (grown(n + 1))
    call new_load(kind, grown(n + 1), model%chain, params, error)
    if (error%code /= 0) return
    grown(1:n) = model%loads
    call move_alloc(grown, model%loads)
  end subroutine build_load

  !> Support A: its reference pose (position(3) of P_1 [m], rotation(9): R_0 column by column)
  !> and its prescribed motion under 'motion.' (rotorcable_motion_builder; 0 hinges: fixed).
  subroutine build_base(model, params, error)
    type(model_type), intent(inout) :: model  !< model
    type(parameter_block), intent(in) :: params  !< its parameters
    type(error_type), intent(inout) :: error  !< status
    real(dp) :: rotation(9)
    call get_reals(params, 'position', model%base%position, error)
    call get_reals(params, 'rotation', rotation, error)
    model%base%rotation = reshape(rotation, [3, 3])
    call motion_from_block(params, 'motion.', model%base%motion, error)
    model%base%moving = size(model%base%motion%hinges) > 0
  end subroutine build_base

  !> Support B at the chain's far end, built by the support factory.
  subroutine build_support(model, kind, params, error)
    type(model_type), intent(inout) :: model  !< model with its chain
    character(len=*), intent(in) :: kind      !< support kind
    type(parameter_block), intent(in) :: params  !< its parameters by name
    type(error_type), intent(inout) :: error  !< status
    if (allocated(model%support_b)) then
      call fatal_error(error, 'the chain''s end has a support already')
      return
    end if
    call new_support(kind, model%support_b, model%chain, params, error)
  end subroutine build_support

  !> The rotor (speed profile, centre: rotorcable_motion_rotor, rotor_from_block) and the frame
  !> of the equations: hub (1: equations in the hub frame), body_couples (1: rotational inertia
  !> in the frame terms).
  subroutine build_rotor(model, params, error)
    type(model_type), intent(inout) :: model  !< model
    type(parameter_block), intent(in) :: params  !< its parameters
    type(error_type), intent(inout) :: error  !< status
    integer :: hub, body_couples
    call get_int(params, 'hub', hub, error)
    call get_int(params, 'body_couples', body_couples, error)
    if (error%code /= 0) return
    call rotor_from_block(model%rotor, params, error)
    model%frame%hub = hub /= 0
    model%frame%body_couples = body_couples /= 0
    model%frame%centre = model%rotor%centre
  end subroutine build_rotor

  !> Size the workspace and check what needs the assembled model.
  subroutine build_finish(model, error)
    type(model_type), intent(inout) :: model  !< model
    type(error_type), intent(inout) :: error  !< status
    real(dp) :: span, reach, zero(model%chain%n_coords)
    integer :: n, held
    character(len=200) :: buf
    call model_init(model)
    if (model%nc == 0) return
    n = model%chain%n_bodies
    if (model%nc > model%nq) then
      write (buf, '(a, i0, a, i0, a)') 'too few free coordinates (', model%nq, ') for the ', model%nc, &
        ' clamp constraints; use more bodies'
      call fatal_error(error, trim(buf), key='chain.n_bodies')
      return
    end if
    ! The free part cannot span more than its length.
    zero = 0.0_dp
    if (clamp_reach(model, 0.0_dp, zero, reach, span, held)) then
      if (n - held < 1 .or. span > reach*(1.0_dp + 1.0e-12_dp)) then
        write (buf, '(a, g0.6, a, g0.6, a)') ' is out of reach: the free part of the chain is ', &
          reach, ' m long but must span ', span, ' m'
        call fatal_error(error, trim(model%support_b%label)//trim(buf), key=trim(model%support_b%position_key))
      else if (span > reach*(1.0_dp - 1.0e-9_dp)) then
        ! At full reach the chain is a straight bar between the clamps: its axial force is not
        ! determined (the constraint Jacobian loses rank), whatever the solver would return.
        write (buf, '(a, g0.10, a, g0.10, a)') ' is at full reach (taut): the free part of the chain is ', &
          reach, ' m long and must span ', span, ' m; give it slack'
        call fatal_error(error, trim(model%support_b%label)//trim(buf), key=trim(model%support_b%position_key))
      end if
    end if
  end subroutine build_finish

  !> Coordinates and rates of a shape given in the thesis's (gamma, beta) per body [rad];
  !> rates are the thesis angles' rates (thesis joint only; others start at rest).
  subroutine thesis_to_coordinates(model, gamma, beta, gamma_rate, beta_rate, q, v)
    type(model_type), intent(in) :: model     !< model
    real(dp), intent(in) :: gamma(:), beta(:) !< thesis angles per body [rad]
    real(dp), intent(in) :: gamma_rate(:), beta_rate(:)  !< their rates [rad/s]
    real(dp), intent(out) :: q(:), v(:)       !< coordinates, rates
    real(dp) :: joint_q(MAX_JOINT_DOF)
    integer :: j, i0, nd
    q = 0.0_dp; v = 0.0_dp
    do j = 1, model%chain%n_bodies
      i0 = model%chain%first_coord(j)
      if (i0 == 0) cycle
      nd = model%chain%n_joint_coords(j)
      joint_q = angles_from_thesis(model%chain%joint_kind(j), [gamma(j), beta(j)])
      q(i0:i0 + nd - 1) = joint_q(1:nd)
      v(i0:i0 + 1) = [gamma_rate(j), beta_rate(j)]
    end do
  end subroutine thesis_to_coordinates

end module rotorcable_model_builder
