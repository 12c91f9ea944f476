!> Tangent (forward-mode derivative) of the recursive Newton-Euler pass of
!> rotorcable_inverse_dynamics: the first-order change of the joint torques for a change of the
!> kinematic state (rotorcable_kinematics_tangent), of the applied forces and of the wrench of
!> clamp B, O(n) per direction (Carpentier and Mansard, RSS 2018, section IV: the RNEA
!> derivatives; here by the product rule on this code's world-frame pass).
!>
!> World-frame inertia R diag(theta) R^T turns with the body: d(I x) = dtheta x (I x)
!> - I (dtheta x x) + I dx = dtheta x (I x) + I (dx - dtheta x x).  Bodies before dst%first do
!> not move: there only the transported wrench changes, which costs a few flops per body.
!>
!> The state-only factors, each body's world inertia I and I w, I alpha (relative to a turning
!> frame where the pass leaves its couples out), are formed once per state by
!> linearise_inertia and shared by all the columns taken there (8 parameters x 2 corrector
!> iterations, or a Jacobian's 44 columns): each column then costs two 3 x 3 products a body
!> instead of six rotations R diag(theta) R^T x.
module rotorcable_inverse_dynamics_tangent
  use rotorcable_kinds, only: dp
  use rotorcable_chain, only: chain_type
  use rotorcable_kinematics, only: chain_state
  use rotorcable_kinematics_tangent, only: chain_tangent
  use rotorcable_rotations, only: cross
  use rotorcable_joint, only: MAX_JOINT_DOF
  implicit none
  private
  public :: inverse_dynamics_tangent, inertia_linearisation, linearise_inertia, frame_arguments

  !> The pass's state-only factors at one state (linearise_inertia).
  type :: inertia_linearisation
    real(dp), allocatable :: inertia(:, :, :)  !< (3,3,n) R diag(theta) R^T [kg m^2]
    real(dp), allocatable :: iw(:, :)          !< (3,n) I w (w relative where the pass says so)
    real(dp), allocatable :: ia(:, :)          !< (3,n) I alpha (likewise)
  end type inertia_linearisation

contains

  !> Every body's world inertia and I w, I alpha at the state st (its frames and motion), with
  !> w, alpha relative to the frame turning at frame_omega, frame_omega_dot when they are given
  !> (as inverse_dynamics and its tangent take them).
  pure subroutine linearise_inertia(chain, st, lin, frame_omega, frame_omega_dot)
    type(chain_type), intent(in) :: chain     !< chain description
    type(chain_state), intent(in) :: st       !< frames and motion of the state
    type(inertia_linearisation), intent(inout) :: lin  !< factors out
    real(dp), intent(in), optional :: frame_omega(3)      !< as in inverse_dynamics
    real(dp), intent(in), optional :: frame_omega_dot(3)  !< as in inverse_dynamics
    real(dp) :: r(3, 3), w(3), a(3)
    integer :: j, k, l, n
    n = chain%n_bodies
    if (allocated(lin%inertia)) then
      if (size(lin%inertia, 3) /= n) deallocate (lin%inertia, lin%iw, lin%ia)
    end if
    if (.not. allocated(lin%inertia)) allocate (lin%inertia(3, 3, n), lin%iw(3, n), lin%ia(3, n))
    do j = 1, n
      r = st%rot(:, :, j)
      do l = 1, 3
        do k = 1, 3
          lin%inertia(k, l, j) = sum(r(k, :)*chain%inertia(:, j)*r(l, :))
        end do
      end do
      w = st%omega(:, j)
      a = st%alpha(:, j)
      if (present(frame_omega) .and. present(frame_omega_dot)) then
        w = w - frame_omega
        a = a - frame_omega_dot - cross(frame_omega, w)
      end if
      lin%iw(:, j) = times(lin%inertia(:, :, j), w)
      lin%ia(:, j) = times(lin%inertia(:, :, j), a)
    end do
  end subroutine linearise_inertia

  !> m x for a 3 x 3 m, written out (inlined; no temporaries).
  pure function times(m, x) result(y)
    real(dp), intent(in) :: m(3, 3), x(3)
    real(dp) :: y(3)
    y = m(:, 1)*x(1) + m(:, 2)*x(2) + m(:, 3)*x(3)
  end function times

  !> d(tau) of inverse_dynamics for the change dst of the state, dforce, dmoment of the applied
  !> loads and dtip_force, dtip_moment of clamp B.  The wrenches of the state (st%joint_force,
  !> st%joint_moment) must be those of the pass being differentiated, with the same loads.
  pure subroutine inverse_dynamics_tangent(chain, st, lin, dst, force, dforce, dmoment, tip_force, dtip_force, &
                                           dtip_moment, dtau, frame_omega, frame_omega_dot)
    type(chain_type), intent(in) :: chain     !< chain description
    type(chain_state), intent(in) :: st       !< state and wrenches of the pass
    type(inertia_linearisation), intent(in) :: lin  !< linearise_inertia at st, same frame arguments
    type(chain_tangent), intent(in) :: dst    !< change of the state
    real(dp), intent(in) :: force(:, :)       !< (3,n) applied forces at the CMs [N]
    real(dp), intent(in) :: dforce(:, :)      !< (3,n) their change
    real(dp), intent(in) :: dmoment(:, :)     !< (3,n) change of the applied moments
    real(dp), intent(in) :: tip_force(3)      !< force of support B on the tip [N]
    real(dp), intent(in) :: dtip_force(3)     !< its change
    real(dp), intent(in) :: dtip_moment(3)    !< change of support B's moment
    real(dp), intent(out) :: dtau(:)          !< (nq) change of the joint torques
    real(dp), intent(in), optional :: frame_omega(3)      !< as in inverse_dynamics
    real(dp), intent(in), optional :: frame_omega_dot(3)  !< as in inverse_dynamics
    real(dp) :: fo(3), fod(3)
    logical :: relative
    call frame_arguments(relative, fo, fod, frame_omega, frame_omega_dot)
    call tangent_pass(chain%n_bodies, size(dtau), dst%first, chain%n_joint_coords, chain%first_coord, chain%mass, &
                      st%joint_point, st%cm, st%axes, st%omega, st%alpha, st%acc_cm, st%joint_force, st%joint_moment, &
                      lin%inertia, lin%iw, lin%ia, dst%dtheta, dst%djoint_point, dst%dcm, dst%daxes, dst%domega, &
                      dst%dalpha, dst%dacc_cm, force, dforce, dmoment, tip_force, dtip_force, dtip_moment, relative, &
                      fo, fod, dtau)
  end subroutine inverse_dynamics_tangent

  !> The optional frame arguments of inverse_dynamics as values for a pass: relative when both
  !> are given, else zeros that the pass does not read.
  pure subroutine frame_arguments(relative, fo, fod, frame_omega, frame_omega_dot)
    logical, intent(out) :: relative          !< both given
    real(dp), intent(out) :: fo(3), fod(3)    !< their values, or zero
    real(dp), intent(in), optional :: frame_omega(3)      !< as in inverse_dynamics
    real(dp), intent(in), optional :: frame_omega_dot(3)  !< as in inverse_dynamics
    relative = present(frame_omega) .and. present(frame_omega_dot)
    fo = 0.0_dp; fod = 0.0_dp
    if (relative) then
      fo = frame_omega; fod = frame_omega_dot
    end if
  end subroutine frame_arguments

  !> inverse_dynamics_tangent's pass on explicit-shape arrays.  Why a second routine: it runs
  !> once per body and column, and through the derived types' allocatable components every
  !> access re-derives its address from a descriptor (measured on motion_tangent, whose pass
  !> took a third fewer instructions so).  The arithmetic is the same, in the same order.
  pure subroutine tangent_pass(n, nq, first, n_joint_coords, first_coord, mass, joint_point, cm, axes, omega, &
                               alpha, acc_cm, joint_force, joint_moment, inertia, lin_iw, lin_ia, dtheta, &
                               djoint_point, dcm, daxes, domega, dalpha, dacc_cm, force, dforce, dmoment, tip_force, &
                               dtip_force, dtip_moment, relative, frame_omega, frame_omega_dot, dtau)
    integer, intent(in) :: n, nq, first
    integer, intent(in) :: n_joint_coords(n), first_coord(n)
    real(dp), intent(in) :: mass(n), joint_point(3, n + 1), cm(3, n), axes(3, MAX_JOINT_DOF, n)
    real(dp), intent(in) :: omega(3, n), alpha(3, n), acc_cm(3, n), joint_force(3, n), joint_moment(3, n)
    real(dp), intent(in) :: inertia(3, 3, n), lin_iw(3, n), lin_ia(3, n)
    real(dp), intent(in) :: dtheta(3, n), djoint_point(3, n + 1), dcm(3, n), daxes(3, MAX_JOINT_DOF, n)
    real(dp), intent(in) :: domega(3, n), dalpha(3, n), dacc_cm(3, n)
    real(dp), intent(in) :: force(3, n), dforce(3, n), dmoment(3, n)
    real(dp), intent(in) :: tip_force(3), dtip_force(3), dtip_moment(3)
    logical, intent(in) :: relative
    real(dp), intent(in) :: frame_omega(3), frame_omega_dot(3)
    real(dp), intent(out) :: dtau(nq)
    real(dp) :: f_child(3), df_child(3), dn_child(3), f_net(3), df_net(3), df(3), dn(3), dn_cm(3)
    real(dp) :: w(3), a(3), dw(3), da(3), th(3), iw(3), diw(3), arm_cm(3), arm_link(3), darm_cm(3), darm_link(3)
    integer :: j, k, i0, nd

    df_child = -dtip_force
    dn_child = -dtip_moment
    do j = n, 1, -1
      ! The wrench this body's child exerted on it in the pass: -(wrench of j on j+1).
      if (j < n) then
        f_child = joint_force(:, j + 1)
      else
        f_child = -tip_force
      end if
      arm_link = joint_point(:, j + 1) - joint_point(:, j)
      arm_cm = cm(:, j) - joint_point(:, j)
      if (j >= first) then
        f_net = mass(j)*acc_cm(:, j) - force(:, j)
        df_net = mass(j)*dacc_cm(:, j) - dforce(:, j)
        w = omega(:, j)
        a = alpha(:, j)
        dw = domega(:, j)
        da = dalpha(:, j)
        if (relative) then
          w = w - frame_omega
          a = a - frame_omega_dot - cross(frame_omega, w)
          da = da - cross(frame_omega, dw)
        end if
        th = dtheta(:, j)
        iw = lin_iw(:, j)
        diw = cross(th, iw) + times(inertia(:, :, j), dw - cross(th, w))
        dn_cm = cross(th, lin_ia(:, j)) + times(inertia(:, :, j), da - cross(th, a)) + cross(dw, iw) &
                + cross(w, diw) - dmoment(:, j)
        darm_cm = dcm(:, j) - djoint_point(:, j)
        darm_link = djoint_point(:, j + 1) - djoint_point(:, j)
        df = df_net + df_child
        dn = dn_cm + cross(darm_cm, f_net) + cross(arm_cm, df_net) + dn_child + cross(darm_link, f_child) &
             + cross(arm_link, df_child)
      else
        ! Body j does not move: only the applied loads' changes (zero for the body-local loads)
        ! and the wrench passed on from outboard.
        df_net = -dforce(:, j)
        df = df_net + df_child
        dn = -dmoment(:, j) + cross(arm_cm, df_net) + dn_child + cross(arm_link, df_child)
      end if
      nd = n_joint_coords(j)
      if (nd > 0) then
        i0 = first_coord(j) - 1
        do k = 1, nd
          dtau(i0 + k) = dot_product(daxes(:, k, j), joint_moment(:, j)) + dot_product(axes(:, k, j), dn)
        end do
      end if
      df_child = df
      dn_child = dn
    end do
  end subroutine tangent_pass

end module rotorcable_inverse_dynamics_tangent
