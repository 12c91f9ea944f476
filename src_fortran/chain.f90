!> Chain description: bodies (uniform cylinders, each with its own length, radius and mass)
!> and joints; the springs and dampers are a load (rotorcable_loads_joint_springs), the
!> supports are the model's (rotorcable_supports_*).
!>
!> Body j has its frame origin at its joint point P_j, its axis along local z, its
!> centre of mass at (0,0,L_j/2) (eq. 4.3) and its end (the next joint) at (0,0,L_j).
!> A locked joint keeps its angles and contributes no coordinates: a clamped first
!> body is a locked joint 1.  Free joints contribute joint_ndof coordinates each, in
!> body order, so q = (gamma_j, beta_j, ...) over the free joints.
module rotorcable_chain
  use rotorcable_kinds, only: dp
  use rotorcable_joint, only: JOINT_ZY, joint_ndof
  implicit none
  private
  public :: chain_type, chain_allocate, cylinder_inertia

  !> Geometry, inertia and joint data of the whole chain.
  type :: chain_type
    integer :: n_bodies = 0                       !< number of rigid bodies
    integer :: n_coords = 0                       !< number of generalized coordinates
    real(dp), allocatable :: length(:)            !< body length L_j [m]
    real(dp), allocatable :: radius(:)            !< body radius R_j [m]
    real(dp), allocatable :: mass(:)              !< body mass m_j [kg]
    real(dp), allocatable :: inertia(:, :)        !< (3,n) principal inertia about CM, body frame [kg m^2]
    integer, allocatable :: joint_kind(:)         !< parametrisation of joint j
    logical, allocatable :: locked(:)             !< joint j locked (no coordinates)
    real(dp), allocatable :: locked_angles(:, :)  !< (2,n) angles of a locked joint [rad]
    integer, allocatable :: first_coord(:)        !< index in q of joint j's first coordinate (0 if locked)
    integer, allocatable :: n_joint_coords(:)     !< coordinates of joint j (0 if locked)
  end type chain_type

contains

  !> Principal inertia of a uniform solid cylinder about its CM, eq. 4.50.
  pure function cylinder_inertia(mass, length, radius) result(theta)
    real(dp), intent(in) :: mass       !< body mass [kg]
    real(dp), intent(in) :: length     !< body length [m]
    real(dp), intent(in) :: radius     !< body radius [m]
    real(dp) :: theta(3)
    theta(1) = mass*(length**2 + 3.0_dp*radius**2)/12.0_dp
    theta(2) = theta(1)
    theta(3) = mass*radius**2/2.0_dp
  end function cylinder_inertia

  !> Allocate a chain of n cylinders; `locked` marks locked joints.
  !> Coordinates are numbered here, once, so every kernel shares one map.
  pure subroutine chain_allocate(chain, n, length, radius, mass, locked, joint_kind)
    type(chain_type), intent(out) :: chain    !< chain to build
    integer, intent(in) :: n                  !< number of bodies
    real(dp), intent(in) :: length(n)         !< body lengths [m]
    real(dp), intent(in) :: radius(n)         !< body radii [m]
    real(dp), intent(in) :: mass(n)           !< body masses [kg]
    logical, intent(in) :: locked(n)          !< locked joints
    integer, intent(in), optional :: joint_kind  !< parametrisation of the free joints (JOINT_ZY)
    integer :: j, nq

    chain%n_bodies = n
    chain%length = length
    chain%radius = radius
    chain%mass = mass
    allocate (chain%inertia(3, n))
    do j = 1, n
      chain%inertia(:, j) = cylinder_inertia(mass(j), length(j), radius(j))
    end do
    allocate (chain%joint_kind(n), chain%first_coord(n), chain%n_joint_coords(n))
    ! Locked joints keep the thesis's angles (they have no coordinates to be singular in).
    chain%joint_kind = JOINT_ZY
    if (present(joint_kind)) then
      where (.not. locked) chain%joint_kind = joint_kind
    end if
    chain%locked = locked
    allocate (chain%locked_angles(2, n))
    chain%locked_angles = 0.0_dp
    nq = 0
    do j = 1, n
      if (locked(j)) then
        chain%first_coord(j) = 0
        chain%n_joint_coords(j) = 0
      else
        chain%first_coord(j) = nq + 1
        chain%n_joint_coords(j) = joint_ndof(chain%joint_kind(j))
        nq = nq + chain%n_joint_coords(j)
      end if
    end do
    chain%n_coords = nq
  end subroutine chain_allocate

end module rotorcable_chain
