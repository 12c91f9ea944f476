!> Applied loads: body forces at the centres of mass and joint spring/damper torques.
!>
!> Only what a scene needs is evaluated: the centrifugal field only when the rotor
!> turns, the pulse only inside its time window.
module rotorcable_loads
  use rotorcable_kinds, only: dp
  use rotorcable_chain, only: chain_type
  implicit none
  private
  public :: load_type, body_forces, spring_damper_forces, potential_energy

  !> Load case of a run.
  type :: load_type
    real(dp) :: gravity(3) = [0.0_dp, 0.0_dp, -9.81_dp]  !< gravitational acceleration [m/s^2]
    real(dp) :: rotor_omega = 0.0_dp          !< rotor speed about world z [rad/s] (0 = rotor at rest)
    real(dp) :: rotor_offset(3) = 0.0_dp      !< world origin (clamp A) relative to the rotor centre [m]
    integer :: pulse_body = 0                 !< body loaded by the force pulse (0 = no pulse)
    real(dp) :: pulse_force(3) = 0.0_dp       !< pulse force at the body's CM [N]
    real(dp) :: pulse_start = 0.0_dp          !< pulse start time [s]
    real(dp) :: pulse_end = 0.0_dp            !< pulse end time [s]
    real(dp) :: tip_force(3) = 0.0_dp         !< constant force at the free tip P_{n+1} [N] (open chains)
  end type load_type

contains

  !> External force on every body at its CM at time t: weight (eq. 4.46), centrifugal
  !> force m w^2 (r_x, r_y, 0) with r from the rotor centre (section 5.5, eq. 5.7) and a
  !> rectangular force pulse (section 5.4).
  pure subroutine body_forces(chain, loads, cm, t, force)
    type(chain_type), intent(in) :: chain     !< chain description
    type(load_type), intent(in) :: loads      !< load case
    real(dp), intent(in) :: cm(:, :)          !< (3,n) centres of mass [m]
    real(dp), intent(in) :: t                 !< time [s]
    real(dp), intent(out) :: force(:, :)      !< (3,n) force on each body [N]
    integer :: j
    real(dp) :: w2

    do j = 1, chain%n_bodies
      force(:, j) = chain%mass(j)*loads%gravity
    end do
    if (loads%rotor_omega /= 0.0_dp) then
      w2 = loads%rotor_omega**2
      do j = 1, chain%n_bodies
        force(1:2, j) = force(1:2, j) + chain%mass(j)*w2*(cm(1:2, j) + loads%rotor_offset(1:2))
      end do
    end if
    if (loads%pulse_body > 0) then
      if (t >= loads%pulse_start .and. t < loads%pulse_end) then
        force(:, loads%pulse_body) = force(:, loads%pulse_body) + loads%pulse_force
      end if
    end if
  end subroutine body_forces

  !> Generalized spring and damper forces, eq. 4.79-4.85.  A torque pair along a joint
  !> axis does power only on that axis's own rate (a_gamma . a_beta = 0), so the
  !> spring moments of eq. 4.78 project to the diagonal  -c (q - q_rest) - d qdot.
  pure function spring_damper_forces(chain, q, qd) result(qs)
    type(chain_type), intent(in) :: chain     !< chain description
    real(dp), intent(in) :: q(:)              !< coordinates [rad]
    real(dp), intent(in) :: qd(:)             !< rates [rad/s]
    real(dp) :: qs(size(q))
    qs = -chain%stiffness*(q - chain%rest) - chain%damping*qd
  end function spring_damper_forces

  !> Potential energy: gravity, centrifugal field (potential -m w^2 r^2/2) and springs.
  pure function potential_energy(chain, loads, q, cm) result(v)
    type(chain_type), intent(in) :: chain     !< chain description
    type(load_type), intent(in) :: loads      !< load case
    real(dp), intent(in) :: q(:)              !< coordinates [rad]
    real(dp), intent(in) :: cm(:, :)          !< (3,n) centres of mass [m]
    real(dp) :: v
    integer :: j
    v = 0.5_dp*sum(chain%stiffness*(q - chain%rest)**2)
    do j = 1, chain%n_bodies
      v = v - chain%mass(j)*dot_product(loads%gravity, cm(:, j))
      if (loads%rotor_omega /= 0.0_dp) v = v - 0.5_dp*chain%mass(j)*loads%rotor_omega**2 &
                                               *sum((cm(1:2, j) + loads%rotor_offset(1:2))**2)
    end do
  end function potential_energy

end module rotorcable_loads
