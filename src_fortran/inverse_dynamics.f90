!> Recursive Newton-Euler inverse dynamics, O(n) (Featherstone, Rigid Body Dynamics
!> Algorithms, 2008, ch. 5), in the world frame.
!>
!> Given the kinematic state (positions, velocities, accelerations), the applied body
!> forces and the wrench that clamp B exerts on the tip, returns the joint torques
!>   tau = M(q) qdd + h(q,qd) - Q_applied - G^T lambda
!> i.e. the Jourdain sum of eq. 3.46 / 4.87 / 4.90 without forming M.  The backward pass
!> also yields the wrench each parent exerts on its child, in particular the base on
!> body 1: the reaction at clamp (or pivot) A.
module rotorcable_inverse_dynamics
  use rotorcable_kinds, only: dp
  use rotorcable_chain, only: chain_type
  use rotorcable_kinematics, only: chain_state
  use rotorcable_rotations, only: cross
  implicit none
  private
  public :: inverse_dynamics, world_inertia_times

contains

  !> World-frame inertia of body j times a vector: R diag(theta) R^T v (eq. 4.48/4.49).
  pure function world_inertia_times(chain, st, j, v) result(iv)
    type(chain_type), intent(in) :: chain     !< chain description
    type(chain_state), intent(in) :: st       !< state with current frames
    integer, intent(in) :: j                  !< body index
    real(dp), intent(in) :: v(3)              !< world vector
    real(dp) :: iv(3)
    real(dp) :: r(3, 3), body(3)
    r = st%rot(:, :, j)
    body = chain%inertia(:, j)*matmul(v, r)
    iv = matmul(r, body)
  end function world_inertia_times

  !> Joint torques and base reaction by the Newton-Euler backward pass.  The wrench every
  !> parent exerts on its child (the cable's internal loads) is kept in st%joint_force and
  !> st%joint_moment (moment about the joint point P_j).
  !>
  !> Euler's equation uses the absolute angular velocity and acceleration of each body (the
  !> gyroscopic and centrifugal couples of a turning frame included).  With frame_omega given,
  !> the rotational inertia sees only the motion relative to a frame turning at frame_omega,
  !> frame_omega_dot (w_rel = w - Omega, alpha_rel = alpha - Omega-dot - Omega x w_rel): the
  !> thesis's point-mass centrifugal field, which leaves those couples out.
  pure subroutine inverse_dynamics(chain, st, force, moment, tip_force, tip_moment, tau, base_force, &
                                   base_moment, frame_omega, frame_omega_dot)
    type(chain_type), intent(in) :: chain     !< chain description
    type(chain_state), intent(inout) :: st    !< positions, velocities, accelerations; joint wrenches out
    real(dp), intent(in) :: force(:, :)       !< (3,n) applied force at each CM [N]
    real(dp), intent(in) :: moment(:, :)      !< (3,n) applied moment on each body [Nm]
    real(dp), intent(in) :: tip_force(3)      !< force of support B on the tip [N]
    real(dp), intent(in) :: tip_moment(3)     !< moment of support B on the last body [Nm]
    real(dp), intent(out) :: tau(:)           !< joint torques per coordinate [Nm]
    real(dp), intent(out) :: base_force(3)    !< force of the base on body 1 at P_1 [N]
    real(dp), intent(out) :: base_moment(3)   !< moment of the base on body 1 about P_1 [Nm]
    real(dp), intent(in), optional :: frame_omega(3)      !< frame rate left out of the couples [rad/s]
    real(dp), intent(in), optional :: frame_omega_dot(3)  !< its derivative [rad/s^2]
    real(dp) :: f_child(3), n_child(3), f(3), n(3), f_net(3), n_cm(3), w(3), iw(3), a(3)
    real(dp) :: arm_cm(3), arm_link(3)
    integer :: j, k, i0
    logical :: relative

    relative = present(frame_omega) .and. present(frame_omega_dot)
    ! The "child" of the last body is support B: it receives -F_B, -M_B from the chain.
    f_child = -tip_force
    n_child = -tip_moment
    do j = chain%n_bodies, 1, -1
      ! Newton (eq. 3.24) and Euler about the CM (eq. 4.52) for body j.
      f_net = chain%mass(j)*st%acc_cm(:, j) - force(:, j)
      w = st%omega(:, j)
      a = st%alpha(:, j)
      if (relative) then
        w = w - frame_omega
        a = a - frame_omega_dot - cross(frame_omega, w)
      end if
      iw = world_inertia_times(chain, st, j, w)
      n_cm = world_inertia_times(chain, st, j, a) + cross(w, iw) - moment(:, j)
      ! Wrench of the parent on body j, moment about the joint point P_j.
      f = f_net + f_child
      ! Lever arms as fixed-size locals: an expression argument of cross would be a heap
      ! temporary (its extent comes from an allocatable component).
      arm_cm = st%cm(:, j) - st%joint_point(:, j)
      arm_link = st%joint_point(:, j + 1) - st%joint_point(:, j)
      n = n_cm + cross(arm_cm, f_net) + n_child + cross(arm_link, f_child)
      if (chain%n_joint_coords(j) > 0) then
        i0 = chain%first_coord(j) - 1
        do k = 1, chain%n_joint_coords(j)
          tau(i0 + k) = dot_product(st%axes(:, k, j), n)
        end do
      end if
      st%joint_force(:, j) = f
      st%joint_moment(:, j) = n
      f_child = f
      n_child = n
    end do
    base_force = f_child
    base_moment = n_child
  end subroutine inverse_dynamics

end module rotorcable_inverse_dynamics
