!> The chain's tangent for many directions at once: rotorcable_kinematics_tangent's positions
!> and motion passes and rotorcable_inverse_dynamics_tangent's Newton-Euler pass, for m columns
!> (dq, dv, dvdot) about one state, every column from body 1 on.
!>
!> Why a second form of the same recursions: a flight's design sensitivities take 8 columns at
!> every corrector iteration of every step (rotorcable_parameter_sensitivity), and one column
!> at a time reads each body's state-only factors (axes, rates, arms, inertia) again for every
!> column, in scalar arithmetic.  Here each body's factors are read once and every operation
!> runs over the column index, innermost and contiguous (arrays (BLK, 3, n)), which the compiler
!> turns into vector instructions.  Each column's arithmetic is the single-column passes', term
!> for term and in the same order, so the results are the same bit for bit (checked by the
!> sensitivities of the main job, tests/test_flight_sensitivities.py, and a direct comparison
!> in tests/test_analytic_jacobian.py).  Cross products are written out per component as
!> rotorcable_rotations' cross: c1 = a2 b3 - a3 b2, c2 = a3 b1 - a1 b3, c3 = a1 b2 - a2 b1.
module rotorcable_chain_tangent_columns
  use rotorcable_kinds, only: dp
  use rotorcable_chain, only: chain_type
  use rotorcable_kinematics, only: chain_state, motion_seed
  use rotorcable_kinematics_tangent, only: chain_tangent
  use rotorcable_joint, only: MAX_JOINT_DOF, JOINT_ZY, JOINT_XY, JOINT_XYZ
  use rotorcable_inverse_dynamics_tangent, only: inertia_linearisation, frame_arguments
  implicit none
  private
  public :: tangent_columns, columns_allocate, positions_tangent_columns, motion_tangent_columns, &
            inverse_dynamics_tangent_columns, column_of, put

  !> Columns taken together: a compile-time width, so that every operation over them is a
  !> fixed-length loop the compiler unrolls into vector instructions (2 SSE2 lanes, the x86-64
  !> baseline) with no loop set-up, and every scratch array has a fixed size (no allocation in
  !> the passes).  More columns run in blocks of this width, the last block padded with zero
  !> columns.
  integer, parameter, public :: COLUMN_BLOCK = 4
  integer, parameter :: BLK = COLUMN_BLOCK  !< (its short name in the declarations)

  !> First-order changes of a chain_state for a block of columns (chain_tangent's fields,
  !> column first), and the block's inputs and load changes (rotorcable_ggl_residual).
  type :: tangent_columns
    real(dp), allocatable :: dtheta(:, :, :)        !< (COLUMN_BLOCK,3,n)
    real(dp), allocatable :: djoint_point(:, :, :)  !< (COLUMN_BLOCK,3,n+1)
    real(dp), allocatable :: dcm(:, :, :)           !< (COLUMN_BLOCK,3,n)
    real(dp), allocatable :: daxes(:, :, :, :)      !< (COLUMN_BLOCK,3,MAX_JOINT_DOF,n)
    real(dp), allocatable :: domega(:, :, :)        !< (COLUMN_BLOCK,3,n)
    real(dp), allocatable :: dalpha(:, :, :)        !< (COLUMN_BLOCK,3,n)
    real(dp), allocatable :: dvel_joint(:, :, :)    !< (COLUMN_BLOCK,3,n+1)
    real(dp), allocatable :: dacc_joint(:, :, :)    !< (COLUMN_BLOCK,3,n+1)
    real(dp), allocatable :: dvel_cm(:, :, :)       !< (COLUMN_BLOCK,3,n)
    real(dp), allocatable :: dacc_cm(:, :, :)       !< (COLUMN_BLOCK,3,n)
    real(dp), allocatable :: dq(:, :), dv(:, :), dvdot(:, :)  !< (COLUMN_BLOCK,nq) the block's directions
    real(dp), allocatable :: dforce(:, :, :), dmoment(:, :, :)  !< (COLUMN_BLOCK,3,n) its loads' changes
    real(dp), allocatable :: dtau(:, :), dres(:, :) !< (COLUMN_BLOCK,nq) its generalized forces, residuals
    real(dp), allocatable :: dtip_force(:, :), dtip_moment(:, :)  !< (COLUMN_BLOCK,3) support B's
  end type tangent_columns

contains

  !> Allocate (zeroed) the block's arrays for a chain, unless they are already its size.
  pure subroutine columns_allocate(chain, tc)
    type(chain_type), intent(in) :: chain      !< chain description
    type(tangent_columns), intent(inout) :: tc !< arrays to allocate
    integer :: n, nq, w
    n = chain%n_bodies
    nq = chain%n_coords
    w = COLUMN_BLOCK
    if (allocated(tc%dtheta)) then
      if (size(tc%dtheta, 3) == n .and. size(tc%dq, 2) == nq) return
      deallocate (tc%dtheta, tc%djoint_point, tc%dcm, tc%daxes, tc%domega, tc%dalpha, tc%dvel_joint, tc%dacc_joint, &
                  tc%dvel_cm, tc%dacc_cm, tc%dq, tc%dv, tc%dvdot, tc%dforce, tc%dmoment, tc%dtau, tc%dres, &
                  tc%dtip_force, tc%dtip_moment)
    end if
    allocate (tc%dtheta(w, 3, n), tc%djoint_point(w, 3, n + 1), tc%dcm(w, 3, n), tc%daxes(w, 3, MAX_JOINT_DOF, n))
    allocate (tc%domega(w, 3, n), tc%dalpha(w, 3, n), tc%dvel_joint(w, 3, n + 1), tc%dacc_joint(w, 3, n + 1))
    allocate (tc%dvel_cm(w, 3, n), tc%dacc_cm(w, 3, n), tc%dq(w, nq), tc%dv(w, nq), tc%dvdot(w, nq))
    allocate (tc%dforce(w, 3, n), tc%dmoment(w, 3, n), tc%dtau(w, nq), tc%dres(w, nq), tc%dtip_force(w, 3), &
              tc%dtip_moment(w, 3))
    tc%dtheta = 0.0_dp; tc%djoint_point = 0.0_dp; tc%dcm = 0.0_dp; tc%daxes = 0.0_dp
    tc%domega = 0.0_dp; tc%dalpha = 0.0_dp; tc%dvel_joint = 0.0_dp; tc%dacc_joint = 0.0_dp
    tc%dvel_cm = 0.0_dp; tc%dacc_cm = 0.0_dp; tc%dq = 0.0_dp; tc%dv = 0.0_dp; tc%dvdot = 0.0_dp
    tc%dforce = 0.0_dp; tc%dmoment = 0.0_dp; tc%dtau = 0.0_dp; tc%dres = 0.0_dp
    tc%dtip_force = 0.0_dp; tc%dtip_moment = 0.0_dp
  end subroutine columns_allocate

  !> Column c as a single chain_tangent, the fields the loads' and the supports' tangents read
  !> (frames, points, axes, CM and joint velocities, angular velocities; not the accelerations,
  !> which only the Newton-Euler pass reads).
  pure subroutine column_of(tc, c, dst)
    type(tangent_columns), intent(in) :: tc    !< the columns
    integer, intent(in) :: c                   !< which
    type(chain_tangent), intent(inout) :: dst  !< allocated for the chain (tangent_allocate)
    integer :: n
    n = size(tc%dtheta, 3)
    dst%first = 1
    call pick(tc%dtheta, c, 3*n, dst%dtheta)
    call pick(tc%djoint_point, c, 3*(n + 1), dst%djoint_point)
    call pick(tc%dcm, c, 3*n, dst%dcm)
    call pick(tc%daxes, c, 3*MAX_JOINT_DOF*n, dst%daxes)
    call pick(tc%domega, c, 3*n, dst%domega)
    call pick(tc%dvel_joint, c, 3*(n + 1), dst%dvel_joint)
    call pick(tc%dvel_cm, c, 3*n, dst%dvel_cm)
  end subroutine column_of

  !> to(i) = from(c, i): one column of a block's array, by sequence association of the
  !> contiguous arrays (no descriptors, no temporaries).
  pure subroutine pick(from, c, count, to)
    integer, intent(in) :: c, count
    real(dp), intent(in) :: from(BLK, count)
    real(dp), intent(inout) :: to(count)
    to = from(c, :)
  end subroutine pick

  !> to(c, i) = from(i): the reverse of pick.
  pure subroutine put(from, c, count, to)
    integer, intent(in) :: c, count
    real(dp), intent(in) :: from(count)
    real(dp), intent(inout) :: to(BLK, count)
    to(c, :) = from
  end subroutine put

  !> positions_tangent for the block's columns tc%dq, from body 1 on.
  pure subroutine positions_tangent_columns(chain, st, tc)
    type(chain_type), intent(in) :: chain      !< chain description
    type(chain_state), intent(in) :: st        !< positions at q
    type(tangent_columns), intent(inout) :: tc !< columns (positions filled)
    call positions_pass(chain%n_bodies, chain%n_coords, chain%n_joint_coords, chain%first_coord, st%joint_point, &
                        st%axes, tc%dq, tc%dtheta, tc%djoint_point, tc%dcm, tc%daxes)
  end subroutine positions_tangent_columns

  pure subroutine positions_pass(n, nq, n_joint_coords, first_coord, joint_point, axes, dq, dtheta, djoint_point, &
                                 dcm, daxes)
    integer, intent(in) :: n, nq
    integer, intent(in) :: n_joint_coords(n), first_coord(n)
    real(dp), intent(in) :: joint_point(3, n + 1), axes(3, MAX_JOINT_DOF, n), dq(BLK, nq)
    real(dp), intent(inout) :: dtheta(BLK, 3, n), djoint_point(BLK, 3, n + 1), dcm(BLK, 3, n), daxes(BLK, 3, MAX_JOINT_DOF, n)
    real(dp) :: w(BLK, 3), rr(BLK, 3), a(3), r(3)
    integer :: j, k, i0
    w = 0.0_dp
    djoint_point(:, :, 1) = 0.0_dp
    do j = 1, n
      i0 = first_coord(j) - 1
      do k = 1, n_joint_coords(j)
        a = axes(:, k, j)
        daxes(:, 1, k, j) = w(:, 2)*a(3) - w(:, 3)*a(2)
        daxes(:, 2, k, j) = w(:, 3)*a(1) - w(:, 1)*a(3)
        daxes(:, 3, k, j) = w(:, 1)*a(2) - w(:, 2)*a(1)
        w(:, 1) = w(:, 1) + a(1)*dq(:, i0 + k)
        w(:, 2) = w(:, 2) + a(2)*dq(:, i0 + k)
        w(:, 3) = w(:, 3) + a(3)*dq(:, i0 + k)
      end do
      dtheta(:, :, j) = w
      r = joint_point(:, j + 1) - joint_point(:, j)
      rr(:, 1) = w(:, 2)*r(3) - w(:, 3)*r(2)
      rr(:, 2) = w(:, 3)*r(1) - w(:, 1)*r(3)
      rr(:, 3) = w(:, 1)*r(2) - w(:, 2)*r(1)
      dcm(:, :, j) = djoint_point(:, :, j) + 0.5_dp*rr
      djoint_point(:, :, j + 1) = djoint_point(:, :, j) + rr
    end do
  end subroutine positions_pass

  !> motion_tangent for the block's columns (tc%dv, tc%dvdot), positions filled
  !> (positions_tangent_columns); chain_motion current in st.
  pure subroutine motion_tangent_columns(chain, seed, st, qd, qdd, tc)
    type(chain_type), intent(in) :: chain      !< chain description
    type(motion_seed), intent(in) :: seed      !< absolute motion of the base (no tangent)
    type(chain_state), intent(in) :: st        !< positions and motion at (q, qd, qdd)
    real(dp), intent(in) :: qd(:), qdd(:)      !< rates and accelerations
    type(tangent_columns), intent(inout) :: tc !< columns (motion filled)
    call motion_pass(chain%n_bodies, size(qd), chain%n_joint_coords, chain%first_coord, chain%joint_kind, &
                     seed%omega, st%omega, st%alpha, st%joint_point, st%axes, qd, qdd, tc%dv, tc%dvdot, tc%dtheta, &
                     tc%daxes, tc%domega, tc%dalpha, tc%dvel_joint, tc%dacc_joint, tc%dvel_cm, tc%dacc_cm)
  end subroutine motion_tangent_columns

  pure subroutine motion_pass(n, nq, n_joint_coords, first_coord, joint_kind, seed_omega, omega, alpha, &
                              joint_point, axes, qd, qdd, dqd, dqdd, dtheta, daxes, domega, dalpha, dvel_joint, &
                              dacc_joint, dvel_cm, dacc_cm)
    integer, intent(in) :: n, nq
    integer, intent(in) :: n_joint_coords(n), first_coord(n), joint_kind(n)
    real(dp), intent(in) :: seed_omega(3), omega(3, n), alpha(3, n), joint_point(3, n + 1)
    real(dp), intent(in) :: axes(3, MAX_JOINT_DOF, n), qd(nq), qdd(nq), dqd(BLK, nq), dqdd(BLK, nq)
    real(dp), intent(in) :: dtheta(BLK, 3, n), daxes(BLK, 3, MAX_JOINT_DOF, n)
    real(dp), intent(inout) :: domega(BLK, 3, n), dalpha(BLK, 3, n), dvel_joint(BLK, 3, n + 1), dacc_joint(BLK, 3, n + 1)
    real(dp), intent(inout) :: dvel_cm(BLK, 3, n), dacc_cm(BLK, 3, n)
    real(dp) :: dw_parent(BLK, 3), da_parent(BLK, 3), dw_rel(BLK, 3), dw(BLK, 3), dal(BLK, 3), dr(BLK, 3), ddvr(BLK, 3), dda(BLK, 3)
    real(dp) :: dbias(BLK, 3), x(BLK, 3), y(BLK, 3), dw12(BLK, 3), s12(BLK)
    real(dp) :: w_parent(3), w_rel(3), a(3), r(3), dvr(3), om(3), al(3), a1(3), a2(3), a3(3), w12(3), c12(3), c3(3)
    real(dp) :: rt(MAX_JOINT_DOF)
    integer :: j, k, i0, nd, i
    dw_parent = 0.0_dp
    da_parent = 0.0_dp
    dvel_joint(:, :, 1) = 0.0_dp
    dacc_joint(:, :, 1) = 0.0_dp
    do j = 1, n
      w_parent = seed_omega
      if (j > 1) then
        w_parent = omega(:, j - 1)
        dw_parent = domega(:, :, j - 1)
        da_parent = dalpha(:, :, j - 1)
      end if
      nd = n_joint_coords(j)
      dw = dw_parent
      dal = da_parent
      if (nd > 0) then
        i0 = first_coord(j) - 1
        w_rel = 0.0_dp
        dw_rel = 0.0_dp
        rt = 0.0_dp
        do k = 1, nd
          a = axes(:, k, j)
          rt(k) = qd(i0 + k)
          w_rel = w_rel + a*qd(i0 + k)
          do i = 1, 3
            dw_rel(:, i) = dw_rel(:, i) + daxes(:, i, k, j)*qd(i0 + k) + a(i)*dqd(:, i0 + k)
            dal(:, i) = dal(:, i) + daxes(:, i, k, j)*qdd(i0 + k) + a(i)*dqdd(:, i0 + k)
          end do
        end do
        dw = dw + dw_rel
        ! dal + cross(dw_parent, w_rel) + cross(w_parent, dw_rel) + joint_bias_tangent
        x(:, 1) = dw_parent(:, 2)*w_rel(3) - dw_parent(:, 3)*w_rel(2)
        x(:, 2) = dw_parent(:, 3)*w_rel(1) - dw_parent(:, 1)*w_rel(3)
        x(:, 3) = dw_parent(:, 1)*w_rel(2) - dw_parent(:, 2)*w_rel(1)
        y(:, 1) = w_parent(2)*dw_rel(:, 3) - w_parent(3)*dw_rel(:, 2)
        y(:, 2) = w_parent(3)*dw_rel(:, 1) - w_parent(1)*dw_rel(:, 3)
        y(:, 3) = w_parent(1)*dw_rel(:, 2) - w_parent(2)*dw_rel(:, 1)
        ! joint_bias_tangent (rotorcable_joint) of the columns: the same terms in the same order.
        dbias = 0.0_dp
        select case (joint_kind(j))
        case (JOINT_ZY, JOINT_XY, JOINT_XYZ)
          a1 = axes(:, 1, j); a2 = axes(:, 2, j)
          c12 = [a1(2)*a2(3) - a1(3)*a2(2), a1(3)*a2(1) - a1(1)*a2(3), a1(1)*a2(2) - a1(2)*a2(1)]
          s12 = dqd(:, i0 + 1)*rt(2) + rt(1)*dqd(:, i0 + 2)
          ! cross(d1, a2) + cross(a1, d2)
          dw12(:, 1) = (daxes(:, 2, 1, j)*a2(3) - daxes(:, 3, 1, j)*a2(2)) &
                       + (a1(2)*daxes(:, 3, 2, j) - a1(3)*daxes(:, 2, 2, j))
          dw12(:, 2) = (daxes(:, 3, 1, j)*a2(1) - daxes(:, 1, 1, j)*a2(3)) &
                       + (a1(3)*daxes(:, 1, 2, j) - a1(1)*daxes(:, 3, 2, j))
          dw12(:, 3) = (daxes(:, 1, 1, j)*a2(2) - daxes(:, 2, 1, j)*a2(1)) &
                       + (a1(1)*daxes(:, 2, 2, j) - a1(2)*daxes(:, 1, 2, j))
          do i = 1, 3
            dbias(:, i) = s12*c12(i) + rt(1)*rt(2)*dw12(:, i)
          end do
          if (joint_kind(j) == JOINT_XYZ) then
            a3 = axes(:, 3, j)
            w12 = rt(1)*a1 + rt(2)*a2
            c3 = [w12(2)*a3(3) - w12(3)*a3(2), w12(3)*a3(1) - w12(1)*a3(3), w12(1)*a3(2) - w12(2)*a3(1)]
            do i = 1, 3
              dw12(:, i) = dqd(:, i0 + 1)*a1(i) + rt(1)*daxes(:, i, 1, j) + dqd(:, i0 + 2)*a2(i) &
                           + rt(2)*daxes(:, i, 2, j)
            end do
            ! + drates(3) cross(w12, a3) + rates(3) (cross(dw12, a3) + cross(w12, d3))
            dbias(:, 1) = dbias(:, 1) + dqd(:, i0 + 3)*c3(1) + rt(3)*((dw12(:, 2)*a3(3) - dw12(:, 3)*a3(2)) &
                          + (w12(2)*daxes(:, 3, 3, j) - w12(3)*daxes(:, 2, 3, j)))
            dbias(:, 2) = dbias(:, 2) + dqd(:, i0 + 3)*c3(2) + rt(3)*((dw12(:, 3)*a3(1) - dw12(:, 1)*a3(3)) &
                          + (w12(3)*daxes(:, 1, 3, j) - w12(1)*daxes(:, 3, 3, j)))
            dbias(:, 3) = dbias(:, 3) + dqd(:, i0 + 3)*c3(3) + rt(3)*((dw12(:, 1)*a3(2) - dw12(:, 2)*a3(1)) &
                          + (w12(1)*daxes(:, 2, 3, j) - w12(2)*daxes(:, 1, 3, j)))
          end if
        end select
        dal = dal + x + y + dbias
      end if
      domega(:, :, j) = dw
      dalpha(:, :, j) = dal
      ! Rigid-body transport along the body (eq. 3.14, 3.21) and its product rule.
      r = joint_point(:, j + 1) - joint_point(:, j)
      om = omega(:, j)
      al = alpha(:, j)
      dr(:, 1) = dtheta(:, 2, j)*r(3) - dtheta(:, 3, j)*r(2)
      dr(:, 2) = dtheta(:, 3, j)*r(1) - dtheta(:, 1, j)*r(3)
      dr(:, 3) = dtheta(:, 1, j)*r(2) - dtheta(:, 2, j)*r(1)
      dvr = [om(2)*r(3) - om(3)*r(2), om(3)*r(1) - om(1)*r(3), om(1)*r(2) - om(2)*r(1)]
      ! ddvr = cross(dw, r) + cross(om, dr)
      ddvr(:, 1) = (dw(:, 2)*r(3) - dw(:, 3)*r(2)) + (om(2)*dr(:, 3) - om(3)*dr(:, 2))
      ddvr(:, 2) = (dw(:, 3)*r(1) - dw(:, 1)*r(3)) + (om(3)*dr(:, 1) - om(1)*dr(:, 3))
      ddvr(:, 3) = (dw(:, 1)*r(2) - dw(:, 2)*r(1)) + (om(1)*dr(:, 2) - om(2)*dr(:, 1))
      ! dda = cross(dal, r) + cross(al, dr) + cross(dw, dvr) + cross(om, ddvr)
      dda(:, 1) = (dal(:, 2)*r(3) - dal(:, 3)*r(2)) + (al(2)*dr(:, 3) - al(3)*dr(:, 2)) &
                  + (dw(:, 2)*dvr(3) - dw(:, 3)*dvr(2)) + (om(2)*ddvr(:, 3) - om(3)*ddvr(:, 2))
      dda(:, 2) = (dal(:, 3)*r(1) - dal(:, 1)*r(3)) + (al(3)*dr(:, 1) - al(1)*dr(:, 3)) &
                  + (dw(:, 3)*dvr(1) - dw(:, 1)*dvr(3)) + (om(3)*ddvr(:, 1) - om(1)*ddvr(:, 3))
      dda(:, 3) = (dal(:, 1)*r(2) - dal(:, 2)*r(1)) + (al(1)*dr(:, 2) - al(2)*dr(:, 1)) &
                  + (dw(:, 1)*dvr(2) - dw(:, 2)*dvr(1)) + (om(1)*ddvr(:, 2) - om(2)*ddvr(:, 1))
      dvel_cm(:, :, j) = dvel_joint(:, :, j) + 0.5_dp*ddvr
      dacc_cm(:, :, j) = dacc_joint(:, :, j) + 0.5_dp*dda
      dvel_joint(:, :, j + 1) = dvel_joint(:, :, j) + ddvr
      dacc_joint(:, :, j + 1) = dacc_joint(:, :, j) + dda
    end do
  end subroutine motion_pass

  !> inverse_dynamics_tangent for the block's columns: the loads' changes tc%dforce, tc%dmoment
  !> and support B's tc%dtip_force, tc%dtip_moment in, the joint torques' tc%dres out.
  pure subroutine inverse_dynamics_tangent_columns(chain, st, lin, force, tip_force, tc, frame_omega, frame_omega_dot)
    type(chain_type), intent(in) :: chain     !< chain description
    type(chain_state), intent(in) :: st       !< state and wrenches of the pass
    type(inertia_linearisation), intent(in) :: lin  !< linearise_inertia at st, same frame arguments
    real(dp), intent(in) :: force(:, :)       !< (3,n) applied forces at the CMs [N]
    real(dp), intent(in) :: tip_force(3)      !< force of support B on the tip [N]
    type(tangent_columns), intent(inout) :: tc  !< the block (state's change and loads' in, dres out)
    real(dp), intent(in), optional :: frame_omega(3)      !< as in inverse_dynamics
    real(dp), intent(in), optional :: frame_omega_dot(3)  !< as in inverse_dynamics
    real(dp) :: fo(3), fod(3)
    logical :: relative
    call frame_arguments(relative, fo, fod, frame_omega, frame_omega_dot)
    call newton_euler_pass(chain%n_bodies, chain%n_coords, chain%n_joint_coords, chain%first_coord, chain%mass, &
                           st%joint_point, st%cm, st%axes, st%omega, st%alpha, st%acc_cm, st%joint_force, &
                           st%joint_moment, lin%inertia, lin%iw, lin%ia, tc%dtheta, tc%djoint_point, tc%dcm, tc%daxes, &
                           tc%domega, tc%dalpha, tc%dacc_cm, force, tc%dforce, tc%dmoment, tip_force, tc%dtip_force, &
                           tc%dtip_moment, relative, fo, fod, tc%dres)
  end subroutine inverse_dynamics_tangent_columns

  pure subroutine newton_euler_pass(n, nq, n_joint_coords, first_coord, mass, joint_point, cm, axes, omega, &
                                    alpha, acc_cm, joint_force, joint_moment, inertia, lin_iw, lin_ia, dtheta, &
                                    djoint_point, dcm, daxes, domega, dalpha, dacc_cm, force, dforce, dmoment, &
                                    tip_force, dtip_force, dtip_moment, relative, fo, fod, dtau)
    integer, intent(in) :: n, nq
    integer, intent(in) :: n_joint_coords(n), first_coord(n)
    real(dp), intent(in) :: mass(n), joint_point(3, n + 1), cm(3, n), axes(3, MAX_JOINT_DOF, n)
    real(dp), intent(in) :: omega(3, n), alpha(3, n), acc_cm(3, n), joint_force(3, n), joint_moment(3, n)
    real(dp), intent(in) :: inertia(3, 3, n), lin_iw(3, n), lin_ia(3, n)
    real(dp), intent(in) :: dtheta(BLK, 3, n), djoint_point(BLK, 3, n + 1), dcm(BLK, 3, n), daxes(BLK, 3, MAX_JOINT_DOF, n)
    real(dp), intent(in) :: domega(BLK, 3, n), dalpha(BLK, 3, n), dacc_cm(BLK, 3, n)
    real(dp), intent(in) :: force(3, n), dforce(BLK, 3, n), dmoment(BLK, 3, n)
    real(dp), intent(in) :: tip_force(3), dtip_force(BLK, 3), dtip_moment(BLK, 3)
    logical, intent(in) :: relative
    real(dp), intent(in) :: fo(3), fod(3)
    real(dp), intent(out) :: dtau(BLK, nq)
    real(dp) :: df_child(BLK, 3), dn_child(BLK, 3), df_net(BLK, 3), df(BLK, 3), dn(BLK, 3), dn_cm(BLK, 3), da(BLK, 3), th(BLK, 3)
    real(dp) :: x(BLK, 3), diw(BLK, 3), darm_cm(BLK, 3), darm_link(BLK, 3), dw(BLK, 3)
    real(dp) :: f_child(3), f_net(3), w(3), a(3), iw(3), ia(3), arm_cm(3), arm_link(3), im(3, 3), jm(3), ax(3)
    integer :: j, k, i0
    df_child = -dtip_force
    dn_child = -dtip_moment
    do j = n, 1, -1
      if (j < n) then
        f_child = joint_force(:, j + 1)
      else
        f_child = -tip_force
      end if
      arm_link = joint_point(:, j + 1) - joint_point(:, j)
      arm_cm = cm(:, j) - joint_point(:, j)
      f_net = mass(j)*acc_cm(:, j) - force(:, j)
      df_net = mass(j)*dacc_cm(:, :, j) - dforce(:, :, j)
      w = omega(:, j)
      a = alpha(:, j)
      dw = domega(:, :, j)
      da = dalpha(:, :, j)
      if (relative) then
        w = w - fo
        a = a - fod - [fo(2)*w(3) - fo(3)*w(2), fo(3)*w(1) - fo(1)*w(3), fo(1)*w(2) - fo(2)*w(1)]
        da(:, 1) = da(:, 1) - (fo(2)*dw(:, 3) - fo(3)*dw(:, 2))
        da(:, 2) = da(:, 2) - (fo(3)*dw(:, 1) - fo(1)*dw(:, 3))
        da(:, 3) = da(:, 3) - (fo(1)*dw(:, 2) - fo(2)*dw(:, 1))
      end if
      th = dtheta(:, :, j)
      iw = lin_iw(:, j)
      ia = lin_ia(:, j)
      im = inertia(:, :, j)
      ! diw = cross(th, iw) + times(I, dw - cross(th, w))
      x(:, 1) = dw(:, 1) - (th(:, 2)*w(3) - th(:, 3)*w(2))
      x(:, 2) = dw(:, 2) - (th(:, 3)*w(1) - th(:, 1)*w(3))
      x(:, 3) = dw(:, 3) - (th(:, 1)*w(2) - th(:, 2)*w(1))
      diw(:, 1) = (th(:, 2)*iw(3) - th(:, 3)*iw(2)) + (im(1, 1)*x(:, 1) + im(1, 2)*x(:, 2) + im(1, 3)*x(:, 3))
      diw(:, 2) = (th(:, 3)*iw(1) - th(:, 1)*iw(3)) + (im(2, 1)*x(:, 1) + im(2, 2)*x(:, 2) + im(2, 3)*x(:, 3))
      diw(:, 3) = (th(:, 1)*iw(2) - th(:, 2)*iw(1)) + (im(3, 1)*x(:, 1) + im(3, 2)*x(:, 2) + im(3, 3)*x(:, 3))
      ! dn_cm = cross(th, ia) + times(I, da - cross(th, a)) + cross(dw, iw) + cross(w, diw) - dmoment
      x(:, 1) = da(:, 1) - (th(:, 2)*a(3) - th(:, 3)*a(2))
      x(:, 2) = da(:, 2) - (th(:, 3)*a(1) - th(:, 1)*a(3))
      x(:, 3) = da(:, 3) - (th(:, 1)*a(2) - th(:, 2)*a(1))
      dn_cm(:, 1) = (th(:, 2)*ia(3) - th(:, 3)*ia(2)) + (im(1, 1)*x(:, 1) + im(1, 2)*x(:, 2) + im(1, 3)*x(:, 3)) &
                    + (dw(:, 2)*iw(3) - dw(:, 3)*iw(2)) + (w(2)*diw(:, 3) - w(3)*diw(:, 2)) - dmoment(:, 1, j)
      dn_cm(:, 2) = (th(:, 3)*ia(1) - th(:, 1)*ia(3)) + (im(2, 1)*x(:, 1) + im(2, 2)*x(:, 2) + im(2, 3)*x(:, 3)) &
                    + (dw(:, 3)*iw(1) - dw(:, 1)*iw(3)) + (w(3)*diw(:, 1) - w(1)*diw(:, 3)) - dmoment(:, 2, j)
      dn_cm(:, 3) = (th(:, 1)*ia(2) - th(:, 2)*ia(1)) + (im(3, 1)*x(:, 1) + im(3, 2)*x(:, 2) + im(3, 3)*x(:, 3)) &
                    + (dw(:, 1)*iw(2) - dw(:, 2)*iw(1)) + (w(1)*diw(:, 2) - w(2)*diw(:, 1)) - dmoment(:, 3, j)
      darm_cm = dcm(:, :, j) - djoint_point(:, :, j)
      darm_link = djoint_point(:, :, j + 1) - djoint_point(:, :, j)
      df = df_net + df_child
      ! dn = dn_cm + cross(darm_cm, f_net) + cross(arm_cm, df_net) + dn_child + cross(darm_link, f_child)
      !      + cross(arm_link, df_child)
      dn(:, 1) = dn_cm(:, 1) + (darm_cm(:, 2)*f_net(3) - darm_cm(:, 3)*f_net(2)) &
                 + (arm_cm(2)*df_net(:, 3) - arm_cm(3)*df_net(:, 2)) + dn_child(:, 1) &
                 + (darm_link(:, 2)*f_child(3) - darm_link(:, 3)*f_child(2)) &
                 + (arm_link(2)*df_child(:, 3) - arm_link(3)*df_child(:, 2))
      dn(:, 2) = dn_cm(:, 2) + (darm_cm(:, 3)*f_net(1) - darm_cm(:, 1)*f_net(3)) &
                 + (arm_cm(3)*df_net(:, 1) - arm_cm(1)*df_net(:, 3)) + dn_child(:, 2) &
                 + (darm_link(:, 3)*f_child(1) - darm_link(:, 1)*f_child(3)) &
                 + (arm_link(3)*df_child(:, 1) - arm_link(1)*df_child(:, 3))
      dn(:, 3) = dn_cm(:, 3) + (darm_cm(:, 1)*f_net(2) - darm_cm(:, 2)*f_net(1)) &
                 + (arm_cm(1)*df_net(:, 2) - arm_cm(2)*df_net(:, 1)) + dn_child(:, 3) &
                 + (darm_link(:, 1)*f_child(2) - darm_link(:, 2)*f_child(1)) &
                 + (arm_link(1)*df_child(:, 2) - arm_link(2)*df_child(:, 1))
      i0 = first_coord(j) - 1
      jm = joint_moment(:, j)
      do k = 1, n_joint_coords(j)
        ax = axes(:, k, j)
        ! dot_product(daxes_k, joint_moment) + dot_product(axes_k, dn), summed as gfortran's
        ! dot_product does (from zero, in index order)
        dtau(:, i0 + k) = (0.0_dp + daxes(:, 1, k, j)*jm(1) + daxes(:, 2, k, j)*jm(2) + daxes(:, 3, k, j)*jm(3)) &
                          + (0.0_dp + ax(1)*dn(:, 1) + ax(2)*dn(:, 2) + ax(3)*dn(:, 3))
      end do
      df_child = df
      dn_child = dn
    end do
  end subroutine newton_euler_pass

end module rotorcable_chain_tangent_columns
