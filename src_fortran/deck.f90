!> Input decks: Fortran namelist groups, read, validated and turned into a model.
!>
!> Groups (see inputs/*.nml for commented examples and docs/model.md for meaning):
!>   &case    name, analysis ('static' | 'dynamic' | 'modal'), start ('shape' | 'equilibrium')
!>   &chain   n_bodies, total_length, diameter, density | total_mass, first_body ('clamped' | 'pivot'),
!>            joint ('zy' thesis two-angle joint, default | 'xy' Cardan bending angles |
!>            'xyz' Cardan bending + twist)
!>   &shape   gamma_deg(:), beta_deg(:) joint angles of the start shape [deg],
!>            gamma_rate_deg(:), beta_rate_deg(:) start rates [deg/s]
!>   &springs c_gamma, c_beta [Nm/rad], d_gamma, d_beta [Nms/rad], rest_gamma_deg(:), rest_beta_deg(:),
!>            c_twist, d_twist (joint = 'xyz' only)
!>   &clamp_b active, from_start, position(3) [m], gamma_deg, beta_deg (orientation of the last body)
!>   &loads   gravity(3), rotor_rpm, rotor_offset(3), pulse_body, pulse_force(3), pulse_start, pulse_end,
!>            tip_force(3) (open chains)
!>   &solver  t_end, dt_out, rtol, atol, atol_multiplier, h_max, max_steps, newton_tol, newton_max_iter,
!>            static_method ('newton' | 'settle'), settle_tol [rad/s], linear_solver ('block' | 'dense'),
!>            jacobian_max_age (steps over which the finite-difference part of the Jacobian is kept),
!>            vector_kernels ('compiled' | 'sundials': IDA's N_Vector operations)
!> Every problem is reported with the deck, the group, the key and the reason.
module rotorcable_deck
  use rotorcable_kinds, only: dp
  use rotorcable_deck_scan, only: key_spec, scan_deck, scan_failure
  use rotorcable_chain, only: chain_allocate
  use rotorcable_joint, only: JOINT_ZY, JOINT_XY, JOINT_XYZ, MAX_JOINT_DOF, angles_from_thesis
  use rotorcable_model, only: model_type, model_init
  use rotorcable_kinematics, only: chain_state, state_allocate, chain_positions
  use rotorcable_rotations, only: rot_y, rot_z
  use rotorcable_dae_integrator, only: integrator_settings, LINEAR_SOLVER_BLOCK, LINEAR_SOLVER_DENSE
  use rotorcable_statics, only: static_settings
  implicit none
  private
  public :: deck_type, load_deck, ANALYSIS_STATIC, ANALYSIS_DYNAMIC, ANALYSIS_MODAL

  integer, parameter :: ANALYSIS_STATIC = 1, ANALYSIS_DYNAMIC = 2, ANALYSIS_MODAL = 3
  integer, parameter :: MAX_BODIES = 2000
  real(dp), parameter :: UNSET = -huge(1.0_dp)
  real(dp), parameter :: PI = acos(-1.0_dp), DEG = PI/180.0_dp

  !> A validated deck, ready to run.
  type :: deck_type
    character(len=:), allocatable :: path         !< deck file
    character(len=:), allocatable :: case_name    !< &case name
    integer :: analysis = ANALYSIS_STATIC         !< analysis type
    type(model_type) :: model                     !< assembled model
    real(dp), allocatable :: q0(:)                !< start coordinates [rad]
    real(dp), allocatable :: v0(:)                !< start rates [rad/s]
    real(dp) :: c_beta = 0.0_dp                   !< bending spring per joint [Nm/rad] (table caption)
    type(integrator_settings) :: integrator       !< IDA settings
    type(static_settings) :: statics              !< Newton settings
    logical :: start_at_equilibrium = .false.     !< dynamic run starts from the static equilibrium
    logical :: settle = .false.                   !< equilibrium by damped dynamic settling (thesis route)
    real(dp) :: settle_tol = 1.0e-8_dp            !< settled when max |qdot| < settle_tol [rad/s]
  end type deck_type

contains

  function specs() result(s)
    type(key_spec), allocatable :: s(:)
    s = [key_spec('case', 'name', 'c'), key_spec('case', 'analysis', 'c'), key_spec('case', 'description', 'c'), &
         key_spec('case', 'start', 'c'), &
         key_spec('chain', 'n_bodies', 'i'), key_spec('chain', 'total_length', 'r'), &
         key_spec('chain', 'diameter', 'r'), key_spec('chain', 'density', 'r'), &
         key_spec('chain', 'total_mass', 'r'), key_spec('chain', 'first_body', 'c'), key_spec('chain', 'joint', 'c'), &
         key_spec('shape', 'gamma_deg', 'r'), key_spec('shape', 'beta_deg', 'r'), &
         key_spec('shape', 'gamma_rate_deg', 'r'), key_spec('shape', 'beta_rate_deg', 'r'), &
         key_spec('springs', 'c_gamma', 'r'), key_spec('springs', 'c_beta', 'r'), &
         key_spec('springs', 'd_gamma', 'r'), key_spec('springs', 'd_beta', 'r'), &
         key_spec('springs', 'rest_gamma_deg', 'r'), key_spec('springs', 'rest_beta_deg', 'r'), &
         key_spec('springs', 'c_twist', 'r'), key_spec('springs', 'd_twist', 'r'), &
         key_spec('clamp_b', 'active', 'l'), key_spec('clamp_b', 'from_start', 'l'), &
         key_spec('clamp_b', 'position', 'r'), key_spec('clamp_b', 'gamma_deg', 'r'), &
         key_spec('clamp_b', 'beta_deg', 'r'), &
         key_spec('loads', 'gravity', 'r'), key_spec('loads', 'rotor_rpm', 'r'), &
         key_spec('loads', 'rotor_offset', 'r'), key_spec('loads', 'pulse_body', 'i'), &
         key_spec('loads', 'pulse_force', 'r'), key_spec('loads', 'pulse_start', 'r'), &
         key_spec('loads', 'pulse_end', 'r'), key_spec('loads', 'tip_force', 'r'), &
         key_spec('solver', 't_end', 'r'), key_spec('solver', 'dt_out', 'r'), key_spec('solver', 'rtol', 'r'), &
         key_spec('solver', 'atol', 'r'), key_spec('solver', 'atol_multiplier', 'r'), &
         key_spec('solver', 'h_max', 'r'), key_spec('solver', 'max_steps', 'i'), &
         key_spec('solver', 'newton_tol', 'r'), key_spec('solver', 'newton_max_iter', 'i'), &
         key_spec('solver', 'static_method', 'c'), key_spec('solver', 'settle_tol', 'r'), &
         key_spec('solver', 'linear_solver', 'c'), key_spec('solver', 'jacobian_max_age', 'i'), &
         key_spec('solver', 'vector_kernels', 'c')]
  end function specs

  !> Read and validate a deck.  On failure fail%failed is set with group, key and reason.
  subroutine load_deck(path, deck, fail)
    character(len=*), intent(in) :: path          !< deck file
    type(deck_type), intent(out) :: deck          !< validated deck
    type(scan_failure), intent(out) :: fail       !< first problem
    ! &case
    character(len=64) :: name, analysis, start
    character(len=256) :: description
    ! &chain
    integer :: n_bodies
    real(dp) :: total_length, diameter, density, total_mass
    character(len=16) :: first_body, joint
    ! &shape
    real(dp) :: gamma_deg(MAX_BODIES), beta_deg(MAX_BODIES), gamma_rate_deg(MAX_BODIES), beta_rate_deg(MAX_BODIES)
    ! &springs
    real(dp) :: c_gamma, c_beta, d_gamma, d_beta, rest_gamma_deg(MAX_BODIES), rest_beta_deg(MAX_BODIES)
    real(dp) :: c_twist, d_twist, joint_q(MAX_JOINT_DOF)
    ! &clamp_b
    logical :: active, from_start
    real(dp) :: position(3), clamp_gamma, clamp_beta
    ! &loads
    real(dp) :: gravity(3), rotor_rpm, rotor_offset(3), pulse_force(3), pulse_start, pulse_end, tip_force(3)
    integer :: pulse_body
    ! &solver
    real(dp) :: t_end, dt_out, rtol, atol, atol_multiplier, h_max, newton_tol
    integer :: max_steps, newton_max_iter, jacobian_max_age
    character(len=16) :: static_method, linear_solver, vector_kernels
    real(dp) :: settle_tol

    namelist /case/ name, analysis, description, start
    namelist /chain/ n_bodies, total_length, diameter, density, total_mass, first_body, joint
    namelist /shape/ gamma_deg, beta_deg, gamma_rate_deg, beta_rate_deg
    namelist /springs/ c_gamma, c_beta, d_gamma, d_beta, rest_gamma_deg, rest_beta_deg, c_twist, d_twist
    namelist /solver/ t_end, dt_out, rtol, atol, atol_multiplier, h_max, max_steps, newton_tol, newton_max_iter, &
                      static_method, settle_tol, linear_solver, jacobian_max_age, vector_kernels

    integer :: u, ios, n, j, nq, i0, joint_kind
    logical :: unit_open
    character(len=512) :: iomsg
    logical, allocatable :: locked(:)
    real(dp) :: lbody, radius, mbody, reach, span
    real(dp), allocatable :: lengths(:), radii(:), masses(:)
    type(chain_state) :: st

    deck%path = path
    unit_open = .false.
    call scan_deck(path, specs(), fail)
    if (fail%failed) return

    open (newunit=u, file=path, status='old', action='read', iostat=ios, iomsg=iomsg)
    unit_open = (ios == 0)
    if (ios /= 0) then
      call set_fail('', '', 'cannot open deck: '//trim(iomsg))
      return
    end if

    name = ''; analysis = ''; description = ''; start = 'shape'
    if (.not. read_group('case')) return
    deck%case_name = trim(name)
    if (start /= 'shape' .and. start /= 'equilibrium') then
      call set_fail('case', 'start', 'must be ''shape'' or ''equilibrium'', got '''//trim(start)//'''')
      return
    end if
    deck%start_at_equilibrium = (start == 'equilibrium')
    select case (trim(analysis))
    case ('static')
      deck%analysis = ANALYSIS_STATIC
    case ('dynamic')
      deck%analysis = ANALYSIS_DYNAMIC
    case ('modal')
      deck%analysis = ANALYSIS_MODAL
    case default
      call set_fail('case', 'analysis', 'must be ''static'', ''dynamic'' or ''modal'', got '''//trim(analysis)//'''')
      return
    end select

    n_bodies = -1; total_length = UNSET; diameter = UNSET; density = UNSET; total_mass = UNSET
    first_body = 'clamped'; joint = 'zy'
    if (.not. read_group('chain')) return
    select case (trim(joint))
    case ('zy')
      joint_kind = JOINT_ZY
    case ('xy')
      joint_kind = JOINT_XY
    case ('xyz')
      joint_kind = JOINT_XYZ
    case default
      call set_fail('chain', 'joint', 'must be ''zy'' (thesis gamma/beta), ''xy'' (Cardan bending) or '// &
                    '''xyz'' (Cardan bending + twist), got '''//trim(joint)//'''')
      return
    end select
    if (n_bodies < 1) then
      call set_fail('chain', 'n_bodies', 'must be at least 1 (number of rigid bodies)')
      return
    end if
    if (n_bodies > MAX_BODIES) then
      call set_fail('chain', 'n_bodies', 'at most 2000 bodies are supported')
      return
    end if
    if (.not. positive('chain', 'total_length', total_length)) return
    if (.not. positive('chain', 'diameter', diameter)) return
    if ((density == UNSET) .eqv. (total_mass == UNSET)) then
      call set_fail('chain', 'density', 'give exactly one of density and total_mass')
      return
    end if
    if (density /= UNSET) then
      if (.not. positive('chain', 'density', density)) return
    else
      if (.not. positive('chain', 'total_mass', total_mass)) return
    end if
    if (first_body /= 'clamped' .and. first_body /= 'pivot') then
      call set_fail('chain', 'first_body', 'must be ''clamped'' or ''pivot'', got '''//trim(first_body)//'''')
      return
    end if
    n = n_bodies
    lbody = total_length/n
    radius = 0.5_dp*diameter
    if (density /= UNSET) then
      mbody = density*PI*radius**2*lbody          ! eq. 4.51
    else
      mbody = total_mass/n
    end if

    gamma_deg = UNSET; beta_deg = UNSET; gamma_rate_deg = 0.0_dp; beta_rate_deg = 0.0_dp
    if (.not. read_group('shape')) return
    if (any(gamma_deg(1:n) == UNSET)) then
      call set_fail('shape', 'gamma_deg', 'needs one angle per body ('//itoa(n)//' values)')
      return
    end if
    if (any(beta_deg(1:n) == UNSET)) then
      call set_fail('shape', 'beta_deg', 'needs one angle per body ('//itoa(n)//' values)')
      return
    end if

    c_gamma = 0.0_dp; c_beta = 0.0_dp; d_gamma = 0.0_dp; d_beta = 0.0_dp; c_twist = UNSET; d_twist = 0.0_dp
    rest_gamma_deg = 0.0_dp; rest_beta_deg = 0.0_dp
    if (.not. read_group('springs', optional_group=.true.)) return
    if (.not. nonnegative('springs', 'c_gamma', c_gamma)) return
    if (.not. nonnegative('springs', 'c_beta', c_beta)) return
    if (.not. nonnegative('springs', 'd_gamma', d_gamma)) return
    if (.not. nonnegative('springs', 'd_beta', d_beta)) return
    deck%c_beta = c_beta
    if (joint_kind == JOINT_XY .or. joint_kind == JOINT_XYZ) then
      ! Both Cardan angles bend the cable: c_beta/d_beta act on both.  The thesis's gamma
      ! spring has no coordinate here, and rest angles or start rates in gamma/beta do not
      ! translate into Cardan angles uniquely: refuse rather than guess.
      if (c_gamma /= 0.0_dp .or. d_gamma /= 0.0_dp) then
        call set_fail('springs', 'c_gamma', 'with joint = '''//trim(joint)//''' both bending angles use '// &
                      'c_beta and d_beta; c_gamma and d_gamma have no coordinate (set them to 0)')
        return
      end if
      if (any(rest_gamma_deg(1:n) /= 0.0_dp) .or. any(rest_beta_deg(1:n) /= 0.0_dp)) then
        call set_fail('springs', 'rest_beta_deg', 'rest angles are not supported with joint = '''// &
                      trim(joint)//''' (straight rest)')
        return
      end if
      if (any(gamma_rate_deg(1:n) /= 0.0_dp) .or. any(beta_rate_deg(1:n) /= 0.0_dp)) then
        call set_fail('shape', 'beta_rate_deg', 'start rates are not supported with joint = '''//trim(joint)//'''')
        return
      end if
    end if
    if (joint_kind == JOINT_XYZ) then
      ! The twist needs its own torsion spring: without one a static shape is undetermined.
      if (.not. positive('springs', 'c_twist', c_twist)) return
      if (.not. nonnegative('springs', 'd_twist', d_twist)) return
    else if (c_twist /= UNSET .or. d_twist /= 0.0_dp) then
      call set_fail('springs', 'c_twist', 'a twist spring needs the twist coordinate of joint = ''xyz''')
      return
    end if

    active = .false.; from_start = .false.; position = UNSET; clamp_gamma = UNSET; clamp_beta = UNSET
    if (.not. read_clamp()) return

    gravity = [0.0_dp, 0.0_dp, -9.81_dp]; rotor_rpm = 0.0_dp; rotor_offset = 0.0_dp
    pulse_body = 0; pulse_force = 0.0_dp; pulse_start = 0.0_dp; pulse_end = 0.0_dp; tip_force = 0.0_dp
    if (.not. read_loads()) return
    if (pulse_body < 0 .or. pulse_body > n) then
      call set_fail('loads', 'pulse_body', 'must be 0 (no pulse) or a body index 1..'//itoa(n))
      return
    end if
    if (pulse_body > 0 .and. pulse_end <= pulse_start) then
      call set_fail('loads', 'pulse_end', 'must be later than pulse_start')
      return
    end if

    t_end = 1.0_dp; dt_out = 1.0e-2_dp; rtol = 1.0e-8_dp; atol = 1.0e-10_dp; atol_multiplier = 1.0e4_dp
    h_max = 0.0_dp; max_steps = 500000; newton_tol = 1.0e-10_dp; newton_max_iter = 200
    static_method = 'newton'; settle_tol = 1.0e-8_dp; linear_solver = 'block'
    jacobian_max_age = deck%integrator%jacobian_max_age; vector_kernels = 'compiled'
    if (.not. read_group('solver', optional_group=.true.)) return
    if (.not. positive('solver', 't_end', t_end)) return
    if (.not. positive('solver', 'dt_out', dt_out)) return
    if (.not. positive('solver', 'rtol', rtol)) return
    if (.not. positive('solver', 'atol', atol)) return
    if (.not. positive('solver', 'atol_multiplier', atol_multiplier)) return
    if (.not. nonnegative('solver', 'h_max', h_max)) return
    if (.not. positive('solver', 'newton_tol', newton_tol)) return
    if (static_method /= 'newton' .and. static_method /= 'settle') then
      call set_fail('solver', 'static_method', 'must be ''newton'' or ''settle'', got '''//trim(static_method)//'''')
      return
    end if
    if (.not. positive('solver', 'settle_tol', settle_tol)) return
    if (linear_solver /= 'block' .and. linear_solver /= 'dense') then
      call set_fail('solver', 'linear_solver', 'must be ''block'' (Schur complement, default) or '// &
                    '''dense'' (SUNDIALS dense LU), got '''//trim(linear_solver)//'''')
      return
    end if
    if (vector_kernels /= 'compiled' .and. vector_kernels /= 'sundials') then
      call set_fail('solver', 'vector_kernels', 'must be ''compiled'' (default) or ''sundials'' '// &
                    '(the library''s own N_Vector kernels), got '''//trim(vector_kernels)//'''')
      return
    end if
    if (jacobian_max_age < 1) then
      call set_fail('solver', 'jacobian_max_age', 'must be at least 1 (steps)')
      return
    end if
    if (max_steps < 1) then
      call set_fail('solver', 'max_steps', 'must be positive')
      return
    end if
    close (u)
    unit_open = .false.

    ! ---- assemble the model -----------------------------------------------------------
    allocate (locked(n), lengths(n), radii(n), masses(n))
    locked = .false.
    locked(1) = (first_body == 'clamped')
    lengths = lbody; radii = radius; masses = mbody
    call chain_allocate(deck%model%chain, n, lengths, radii, masses, locked, joint_kind)
    deck%model%chain%locked_angles(1, :) = gamma_deg(1:n)*DEG
    deck%model%chain%locked_angles(2, :) = beta_deg(1:n)*DEG
    nq = deck%model%chain%n_coords
    allocate (deck%q0(nq), deck%v0(nq))
    do j = 1, n
      i0 = deck%model%chain%first_coord(j)
      if (i0 == 0) cycle
      joint_q = angles_from_thesis(joint_kind, [gamma_deg(j), beta_deg(j)]*DEG)
      deck%q0(i0:i0 + 1) = joint_q(1:2)
      deck%v0(i0:i0 + 1) = [gamma_rate_deg(j), beta_rate_deg(j)]*DEG
      deck%model%chain%stiffness(i0:i0 + 1) = [c_gamma, c_beta]            ! eq. 4.79-4.85
      deck%model%chain%damping(i0:i0 + 1) = [d_gamma, d_beta]
      if (joint_kind == JOINT_XY .or. joint_kind == JOINT_XYZ) then
        deck%model%chain%stiffness(i0:i0 + 1) = c_beta
        deck%model%chain%damping(i0:i0 + 1) = d_beta
      end if
      deck%model%chain%rest(i0:i0 + 1) = [rest_gamma_deg(j), rest_beta_deg(j)]*DEG
      if (joint_kind == JOINT_XYZ) then                                     ! untwisted start
        deck%q0(i0 + 2) = joint_q(3)
        deck%v0(i0 + 2) = 0.0_dp
        deck%model%chain%stiffness(i0 + 2) = c_twist
        deck%model%chain%damping(i0 + 2) = d_twist
        deck%model%chain%rest(i0 + 2) = 0.0_dp
      end if
    end do
    deck%model%loads%gravity = gravity
    deck%model%loads%rotor_omega = rotor_rpm*2.0_dp*PI/60.0_dp
    deck%model%loads%rotor_offset = rotor_offset
    deck%model%loads%pulse_body = pulse_body
    deck%model%loads%pulse_force = pulse_force
    deck%model%loads%pulse_start = pulse_start
    deck%model%loads%pulse_end = pulse_end
    if (active .and. any(tip_force /= 0.0_dp)) then
      call set_fail('loads', 'tip_force', 'a tip force needs a free end (clamp_b active = .false.)')
      return
    end if
    deck%model%loads%tip_force = tip_force
    deck%model%clamp%active = active

    if (active) then
      call state_allocate(deck%model%chain, st)
      call chain_positions(deck%model%chain, deck%q0, st)
      if (from_start) then
        deck%model%clamp%position = st%joint_point(:, n + 1)
        deck%model%clamp%rotation = st%rot(:, :, n)
      else
        if (any(position == UNSET)) then
          call set_fail('clamp_b', 'position', 'needs 3 coordinates (or from_start = .true.)')
          return
        end if
        if (clamp_gamma == UNSET .or. clamp_beta == UNSET) then
          call set_fail('clamp_b', 'gamma_deg', 'gamma_deg and beta_deg of the last body are needed '// &
                        '(or from_start = .true.)')
          return
        end if
        deck%model%clamp%position = position
        deck%model%clamp%rotation = matmul(rot_z(clamp_gamma*DEG), rot_y(clamp_beta*DEG))
      end if
      ! Reach: the free part runs from the end of a clamped first body (or from A) to the
      ! start of the clamped last body; it cannot span more than its length.
      reach = sum(lengths(2:n - 1))
      if (.not. locked(1)) reach = reach + lengths(1)
      span = norm2(deck%model%clamp%position - lengths(n)*deck%model%clamp%rotation(:, 3) &
                   - merge(st%joint_point(:, 2), deck%model%chain%base_position, locked(1)))
      if (n < 2 .or. span > reach*(1.0_dp + 1.0e-12_dp)) then
        call set_fail('clamp_b', 'position', 'the end clamp is out of reach: the free part of the chain is '// &
                      ftoa(reach)//' m long but must span '//ftoa(span)//' m')
        return
      end if
    end if
    call model_init(deck%model)
    if (deck%model%nc > deck%model%nq) then
      call set_fail('chain', 'n_bodies', 'too few free coordinates ('//itoa(deck%model%nq)// &
                    ') for the 6 clamp constraints; use more bodies')
      return
    end if

    deck%integrator%t_end = t_end
    deck%integrator%dt_out = dt_out
    deck%integrator%rtol = rtol
    deck%integrator%atol = atol
    deck%integrator%atol_multiplier = atol_multiplier
    deck%integrator%h_max = h_max
    deck%integrator%max_steps = max_steps
    deck%integrator%linear_solver = LINEAR_SOLVER_BLOCK
    if (linear_solver == 'dense') deck%integrator%linear_solver = LINEAR_SOLVER_DENSE
    deck%integrator%jacobian_max_age = jacobian_max_age
    deck%integrator%compiled_vector_kernels = (vector_kernels == 'compiled')
    deck%statics%tol_force = newton_tol
    deck%statics%max_iterations = newton_max_iter
    deck%settle = (static_method == 'settle')
    deck%settle_tol = settle_tol

  contains

    logical function read_group(group, optional_group) result(ok)
      character(len=*), intent(in) :: group
      logical, intent(in), optional :: optional_group
      rewind (u)
      select case (group)
      case ('case')
        read (u, nml=case, iostat=ios, iomsg=iomsg)
      case ('chain')
        read (u, nml=chain, iostat=ios, iomsg=iomsg)
      case ('shape')
        read (u, nml=shape, iostat=ios, iomsg=iomsg)
      case ('springs')
        read (u, nml=springs, iostat=ios, iomsg=iomsg)
      case ('solver')
        read (u, nml=solver, iostat=ios, iomsg=iomsg)
      end select
      ok = check_read(group, optional_group)
    end function read_group

    logical function read_clamp() result(ok)
      real(dp) :: gamma_deg, beta_deg
      namelist /clamp_b/ active, from_start, position, gamma_deg, beta_deg
      gamma_deg = UNSET; beta_deg = UNSET
      rewind (u)
      read (u, nml=clamp_b, iostat=ios, iomsg=iomsg)
      ok = check_read('clamp_b', .true.)
      clamp_gamma = gamma_deg; clamp_beta = beta_deg
    end function read_clamp

    logical function read_loads() result(ok)
      namelist /loads/ gravity, rotor_rpm, rotor_offset, pulse_body, pulse_force, pulse_start, pulse_end, tip_force
      rewind (u)
      read (u, nml=loads, iostat=ios, iomsg=iomsg)
      ok = check_read('loads', .true.)
    end function read_loads

    logical function check_read(group, optional_group) result(ok)
      character(len=*), intent(in) :: group
      logical, intent(in), optional :: optional_group
      ok = .true.
      if (ios == 0) return
      if (is_iostat_end(ios)) then
        if (present(optional_group)) then
          if (optional_group) then
            ios = 0
            return
          end if
        end if
        call set_fail(group, '', 'group &'//group//' is missing')
      else
        call set_fail(group, '', trim(iomsg))
      end if
      ok = .false.
    end function check_read

    logical function positive(group, key, x) result(ok)
      character(len=*), intent(in) :: group, key
      real(dp), intent(in) :: x
      ok = .true.
      if (x == UNSET) then
        call set_fail(group, key, 'is required')
        ok = .false.
      else if (.not. (x > 0.0_dp)) then
        call set_fail(group, key, 'must be positive, got '//ftoa(x))
        ok = .false.
      end if
    end function positive

    logical function nonnegative(group, key, x) result(ok)
      character(len=*), intent(in) :: group, key
      real(dp), intent(in) :: x
      ok = x >= 0.0_dp
      if (.not. ok) then
        call set_fail(group, key, 'must not be negative, got '//ftoa(x))
      end if
    end function nonnegative

    subroutine set_fail(group, key, reason)
      character(len=*), intent(in) :: group, key, reason
      ! A rejected deck must not keep its unit open: the same file is read again by the
      ! next run.  Every failure path comes here, so the unit is closed in one place.
      if (unit_open) close (u)
      unit_open = .false.
      fail%failed = .true.
      fail%group = group
      fail%key = key
      fail%reason = reason
    end subroutine set_fail

  end subroutine load_deck

  pure function itoa(i) result(s)
    integer, intent(in) :: i
    character(len=:), allocatable :: s
    character(len=24) :: buf
    write (buf, '(i0)') i
    s = trim(buf)
  end function itoa

  pure function ftoa(x) result(s)
    real(dp), intent(in) :: x
    character(len=:), allocatable :: s
    character(len=32) :: buf
    write (buf, '(g0.6)') x
    s = trim(adjustl(buf))
  end function ftoa

end module rotorcable_deck
