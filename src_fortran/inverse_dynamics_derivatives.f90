!> Analytic derivatives of the chain's inverse dynamics as whole matrices: d(tau)/dq, d(tau)/dv and
!> d(tau)/d(vdot) = M of rotorcable_inverse_dynamics's pass, in one forward and one backward sweep
!> over the bodies and O(1) work per matrix entry, in the structure of Carpentier and Mansard's
!> recursions ("Analytical derivatives of rigid body dynamics algorithms", RSS 2018, section IV
!> and Algorithm 1; Pinocchio's computeRNEADerivatives), written for this chain: its joints (zy,
!> xy, xyz: each coordinate a revolute joint whose axis turns with the coordinates before it in
!> the same joint), its base and tip, its rotating hub frame, and loads that act on the bodies.
!> The column-by-column tangent sweeps (rotorcable_kinematics_tangent and
!> rotorcable_inverse_dynamics_tangent, O(n) per column) stay as the independent check
!> (tests/test_analytic_derivatives.py).
!>
!> Spatial vectors about one fixed point O (rotorcable_spatial_algebra; O = P_1, the base joint
!> point at this time, so that lever arms stay of the cable's size).  Coordinate k, of joint b(k),
!> turns about S_k = (P_b x a_k, a_k); the bodies outboard of it all turn with it.  With nu^(k),
!> a^(k) the spatial velocity and acceleration of the frame after coordinate k,
!>   c_k = nu^(k-1) x S_k,   d_k = a^(k-1) x S_k + nu^(k-1) x c_k,
!> a change dq_k turns every outboard body i rigidly by S_k dq_k and changes its velocity and
!> acceleration by (S_k x nu_i + c_k) dq_k and (S_k x a_i + d_k - nu_i x c_k) dq_k, and a change
!> dv_k by S_k dv_k and (2 c_k - nu_i x S_k) dv_k.  Every body's net force f_i (inertia less
!> loads, about O) changes linearly in these: df_i = Q_i xi + V_i dnu + A_i da for a rigid turn
!> xi, with A_i the spatial inertia.  Grouped as they enter,
!>   B_i = V_i - A_i [nu_i x],    Qhat_i = Q_i - V_i [nu_i x] - A_i [a_i x] - (. x* f_i),
!> Qhat_i is what does not turn with the body (zero for the inertia of a body in an inertial
!> or hub frame; a world-fixed gravity, a stream, the clamp's pose or a frame rate left out of
!> the couples make it nonzero).  With the composites over the bodies outboard of joint b,
!> Ac_b, Bc_b, Qc_b = sum_{i >= b} A_i, B_i, Qhat_i, and F_b the spatial wrench at joint b,
!>   dtau_k/dq_m  = S_k . (S_m x* F_b + Qc_b S_m + Bc_b c_m + Ac_b d_m),  b = b(m),  k <= m,
!>                = (Qc_b^T S_k) . S_m + (Bc_b^T S_k) . c_m + (Ac_b S_k) . d_m,  b = b(k),  k > m,
!>   dtau_k/dv_m  = S_k . (Bc_b S_m + 2 Ac_b c_m),  b = b(max(k, m)),
!>   dtau_k/dvdot_m = S_k . Ac_b S_m,                b = b(max(k, m)):
!> the first line (k inboard of m) is the derivative of the wrench outboard of m, the second adds
!> the turn of axis S_k with coordinate m, (S_m x S_k) . F_b, which cancels the part of the
!> wrench's change that turns with the body (Carpentier and Mansard's eq. 13-15, with the
!> non-turning part kept apart so that it is never formed as a difference).
!>
!> The loads and support B's wrench come in as each body's own linearisation about its centre of
!> mass (force at C_j, moment): d(F, M)/d(dC_j, dtheta_j) and d(F, M)/d(dv_Cj, domega_j), with
!> their values (the parts that do not turn); the caller fills them into the work arrays
!> (rotorcable_model_derivatives).
module rotorcable_inverse_dynamics_derivatives
  use rotorcable_kinds, only: dp
  use rotorcable_chain, only: chain_type
  use rotorcable_kinematics, only: chain_state, motion_seed
  use rotorcable_joint, only: MAX_JOINT_DOF
  use rotorcable_rotations, only: cross, skew
  use rotorcable_spatial_algebra, only: motion_cross, force_cross, to_origin, wrench_about_origin, skew_product
  implicit none
  private
  public :: derivatives_work, derivatives_allocate, inverse_dynamics_derivatives

  !> Arrays of one evaluation, kept between evaluations (allocated once per chain).
  type :: derivatives_work
    real(dp) :: origin(3) = 0.0_dp               !< O, the point the spatial vectors are about [m]
    integer, allocatable :: body_of(:)           !< (nq) joint (body) of each coordinate
    real(dp), allocatable :: axis(:, :)          !< (6,nq) S_k about O
    real(dp), allocatable :: axis_rows(:, :)     !< (nq,6) S_k^T (row k contiguous over k)
    real(dp), allocatable :: vel_axis(:, :)      !< (6,nq) c_k
    real(dp), allocatable :: acc_axis(:, :)      !< (6,nq) d_k
    real(dp), allocatable :: inertia_c(:, :, :)  !< (6,6,n) Ac_b
    real(dp), allocatable :: velocity_c(:, :, :) !< (6,6,n) Bc_b
    real(dp), allocatable :: pose_c(:, :, :)     !< (6,6,n) Qc_b
    real(dp), allocatable :: joint_wrench(:, :)  !< (6,n) F_b about O
    real(dp), allocatable :: rows(:, :)          !< (nq,18) per row k: Qc^T S_k, Bc^T S_k, Ac S_k
    real(dp), allocatable :: cols(:, :)          !< (6,3nq) per column m: the q, v and vdot vectors
    !> Inputs of the external terms (loads, support B), filled by the caller: per body j, the
    !> force at C_j and moment, as they enter the residual's net force (inertia + these), and
    !> their derivatives d(F, M)/d(dC_j, dtheta_j) and d(F, M)/d(dv_Cj, domega_j).
    real(dp), allocatable :: ext_force(:, :)     !< (3,n) [N]
    real(dp), allocatable :: ext_moment(:, :)    !< (3,n) [Nm]
    real(dp), allocatable :: ext_pose(:, :, :)   !< (6,6,n)
    real(dp), allocatable :: ext_motion(:, :, :) !< (6,6,n)
    !> Generalized forces on the coordinates that depend on the joint's own coordinates and rates
    !> (springs, dampers): d(tau of joint j)/d(q, v of joint j), filled by the caller.
    real(dp), allocatable :: joint_q(:, :, :)    !< (MAX_JOINT_DOF,MAX_JOINT_DOF,n)
    real(dp), allocatable :: joint_v(:, :, :)    !< (MAX_JOINT_DOF,MAX_JOINT_DOF,n)
  end type derivatives_work

contains

  !> Size the work arrays for a chain (nothing when they are its size already).
  pure subroutine derivatives_allocate(chain, work)
    type(chain_type), intent(in) :: chain      !< chain description
    type(derivatives_work), intent(inout) :: work  !< arrays to size
    integer :: n, nq
    n = chain%n_bodies
    nq = chain%n_coords
    if (allocated(work%axis)) then
      if (size(work%axis, 2) == nq .and. size(work%inertia_c, 3) == n) return
      deallocate (work%body_of, work%axis, work%axis_rows, work%vel_axis, work%acc_axis, work%inertia_c, &
                  work%velocity_c, work%pose_c, work%joint_wrench, work%rows, work%cols, work%ext_force, &
                  work%ext_moment, work%ext_pose, work%ext_motion, work%joint_q, work%joint_v)
    end if
    allocate (work%body_of(nq), work%axis(6, nq), work%axis_rows(nq, 6), work%vel_axis(6, nq), work%acc_axis(6, nq))
    allocate (work%inertia_c(6, 6, n), work%velocity_c(6, 6, n), work%pose_c(6, 6, n), work%joint_wrench(6, n))
    allocate (work%rows(nq, 18), work%cols(6, 3*nq), work%ext_force(3, n), work%ext_moment(3, n))
    allocate (work%ext_pose(6, 6, n), work%ext_motion(6, 6, n))
    allocate (work%joint_q(MAX_JOINT_DOF, MAX_JOINT_DOF, n), work%joint_v(MAX_JOINT_DOF, MAX_JOINT_DOF, n))
  end subroutine derivatives_allocate

  !> d(tau)/dq, d(tau)/dv and (when asked) M = d(tau)/d(vdot) of inverse_dynamics's torques
  !> tau = (inertia - work's external terms) at the state st, less the joint terms work%joint_q,
  !> work%joint_v (so, with the loads and support B's wrench as the external terms and the
  !> springs as the joint terms: the derivatives of the equation-of-motion residual).  st holds
  !> the pass being differentiated (frames, motion at (qd, qdd), joint wrenches); inertia the
  !> bodies' world inertias; the frame arguments as inverse_dynamics takes them.
  pure subroutine inverse_dynamics_derivatives(chain, st, seed, qd, qdd, inertia, work, dtau_dq, dtau_dv, mass, &
                                               frame_omega, frame_omega_dot)
    type(chain_type), intent(in) :: chain     !< chain description
    type(chain_state), intent(in) :: st       !< frames, motion and joint wrenches of the pass
    type(motion_seed), intent(in) :: seed     !< absolute motion of the base
    real(dp), intent(in) :: qd(:), qdd(:)     !< rates and accelerations of the pass
    real(dp), intent(in) :: inertia(:, :, :)  !< (3,3,n) world inertia about each CM [kg m^2]
    type(derivatives_work), intent(inout) :: work  !< external terms in; work arrays
    real(dp), intent(inout) :: dtau_dq(:, :)  !< (nq,nq) d(tau)/dq
    real(dp), intent(inout) :: dtau_dv(:, :)  !< (nq,nq) d(tau)/dv
    real(dp), intent(inout), optional :: mass(:, :)  !< (nq,nq) M
    real(dp), intent(in), optional :: frame_omega(3)      !< as in inverse_dynamics
    real(dp), intent(in), optional :: frame_omega_dot(3)  !< as in inverse_dynamics
    logical :: relative
    relative = present(frame_omega) .and. present(frame_omega_dot)
    work%origin = st%joint_point(:, 1)
    call axes_pass(chain, st, seed, qd, qdd, work)
    if (relative) then
      call composites_pass(chain, st, inertia, work, frame_omega, frame_omega_dot)
    else
      call composites_pass(chain, st, inertia, work)
    end if
    call assemble(chain, work, dtau_dq, dtau_dv, mass)
  end subroutine inverse_dynamics_derivatives

  !> The forward sweep: S_k, c_k, d_k of every coordinate from the frames and motion of the pass.
  !> Joint j's parent frame moves with nu = (v_P + x x w_p, w_p) and a = (a_P - alpha_p x x
  !> - w_p x v_P, alpha_p) about O (x = P_j - O, P_j a point of the parent: its velocity and
  !> acceleration are the pass's), and each of the joint's coordinates adds its turn.
  pure subroutine axes_pass(chain, st, seed, qd, qdd, work)
    type(chain_type), intent(in) :: chain
    type(chain_state), intent(in) :: st
    type(motion_seed), intent(in) :: seed
    real(dp), intent(in) :: qd(:), qdd(:)
    type(derivatives_work), intent(inout) :: work
    real(dp) :: nu(6), acc(6), s(6), c(6), x(3), w_p(3), al_p(3), v_p(3), a_p(3)
    integer :: j, l, k
    do j = 1, chain%n_bodies
      if (chain%n_joint_coords(j) == 0) cycle
      if (j == 1) then
        w_p = seed%omega
        al_p = seed%alpha
      else
        w_p = st%omega(:, j - 1)
        al_p = st%alpha(:, j - 1)
      end if
      x = st%joint_point(:, j) - work%origin
      v_p = st%vel_joint(:, j)
      a_p = st%acc_joint(:, j)
      nu(1:3) = v_p + cross(x, w_p)
      nu(4:6) = w_p
      acc(1:3) = a_p - cross(al_p, x) - cross(w_p, v_p)
      acc(4:6) = al_p
      do l = 1, chain%n_joint_coords(j)
        k = chain%first_coord(j) + l - 1
        s(4:6) = st%axes(:, l, j)
        s(1:3) = cross(x, s(4:6))
        c = motion_cross(nu, s)
        work%body_of(k) = j
        work%axis(:, k) = s
        work%axis_rows(k, :) = s
        work%vel_axis(:, k) = c
        work%acc_axis(:, k) = motion_cross(acc, s) + motion_cross(nu, c)
        nu = nu + s*qd(k)
        acc = acc + s*qdd(k) + c*qd(k)
      end do
    end do
  end subroutine axes_pass

  !> The backward sweep: each body's A_i, B_i, Qhat_i, formed about its CM and moved to O, summed
  !> from the tip (the composites), and the joint wrenches about O.
  !>
  !> About the CM (motion (dv_C, dw), force (F, N)), the body's inertia is diag(m, I) and, for
  !> Newton's F = m a_C and Euler's N = I alpha + w x I w at a fixed spatial acceleration,
  !>   B_C = [0, -2 m [v_C]; 0, [w] I - I [w] - [I w]],  Qhat_C = 0
  !> (Newton: da_C = dw x v_C + w x dv_C against A [nu x]'s m [w], m [v_C]).  The external terms
  !> (L_p, L_m their derivatives, (F_e, N_e) their values) add L_m to B_C and
  !>   Qhat_C += L_p + L_m [0, -[v_C]; 0, -[w]] + [0, [F_e]; 0, [N_e]]:
  !> under a rigid turn xi of the body (its velocity turned with it: dv_C = xi_w x v_C,
  !> dw = xi_w x w) less the change of (F_e, N_e) turned with the body.  With frame_omega the
  !> pass leaves the frame rate out of the couples (rotorcable_inverse_dynamics): Euler's moment
  !> then is I alpha' + w' x I w', w' = w - Omega, alpha' = alpha - Omega-dot - Omega x w',
  !> which adds dN = I alpha' - I alpha + w' x I w' - w x I w, an external moment of the body's
  !> pose and rate (relative_couples).
  pure subroutine composites_pass(chain, st, inertia, work, frame_omega, frame_omega_dot)
    type(chain_type), intent(in) :: chain
    type(chain_state), intent(in) :: st
    real(dp), intent(in) :: inertia(:, :, :)
    type(derivatives_work), intent(inout) :: work
    real(dp), intent(in), optional :: frame_omega(3), frame_omega_dot(3)
    real(dp) :: a_c(6, 6), b_c(6, 6), q_c(6, 6), lm(6, 6), lp(6, 6), ib(3, 3), wi(3, 3), cm(3), v(3), w(3), f_e(3)
    real(dp) :: n_e(3), dn(3), lp_dn(3, 3), lm_dn(3, 3), x(3), r_row(3), s_row(3)
    integer :: j, i, n
    n = chain%n_bodies
    do j = n, 1, -1
      cm = st%cm(:, j) - work%origin
      v = st%vel_cm(:, j)
      w = st%omega(:, j)
      ib = inertia(:, :, j)
      ! Inertia about the CM.
      a_c = 0.0_dp
      do i = 1, 3
        a_c(i, i) = chain%mass(j)
      end do
      a_c(4:6, 4:6) = ib
      wi = skew_product(w, ib)
      b_c = 0.0_dp
      b_c(1:3, 4:6) = -2.0_dp*chain%mass(j)*skew(v)
      b_c(4:6, 4:6) = wi + transpose(wi) - skew(matmul(ib, w))   ! I [w] = -([w] I)^T (I symmetric)
      ! External terms, and the couples' frame correction as one more.
      lp = work%ext_pose(:, :, j)
      lm = work%ext_motion(:, :, j)
      f_e = work%ext_force(:, j)
      n_e = work%ext_moment(:, j)
      if (present(frame_omega) .and. present(frame_omega_dot)) then
        call relative_couples(ib, w, frame_omega, frame_omega_dot, dn, lp_dn, lm_dn)
        n_e = n_e + dn
        lp(4:6, 4:6) = lp(4:6, 4:6) + lp_dn
        lm(4:6, 4:6) = lm(4:6, 4:6) + lm_dn
      end if
      b_c = b_c + lm
      q_c = lp
      do i = 1, 6
        ! Row i of L_m(:, 1:3) [v] + L_m(:, 4:6) [w]: r x v + s x w for its rows r, s.
        r_row = lm(i, 1:3)      ! rows copied: a row section is strided, cross() would take a temporary
        s_row = lm(i, 4:6)
        x = cross(r_row, v) + cross(s_row, w)
        q_c(i, 4:6) = q_c(i, 4:6) - x
      end do
      q_c(1:3, 4:6) = q_c(1:3, 4:6) + skew(f_e)
      q_c(4:6, 4:6) = q_c(4:6, 4:6) + skew(n_e)
      a_c = to_origin(a_c, cm)
      b_c = to_origin(b_c, cm)
      q_c = to_origin(q_c, cm)
      if (j < n) then
        a_c = a_c + work%inertia_c(:, :, j + 1)
        b_c = b_c + work%velocity_c(:, :, j + 1)
        q_c = q_c + work%pose_c(:, :, j + 1)
      end if
      work%inertia_c(:, :, j) = a_c
      work%velocity_c(:, :, j) = b_c
      work%pose_c(:, :, j) = q_c
      work%joint_wrench(:, j) = wrench_about_origin(st%joint_force(:, j), st%joint_moment(:, j), &
                                                    st%joint_point(:, j) - work%origin)
    end do
  end subroutine composites_pass

  !> The change of Euler's moment when the couples leave the frame rate out, dN = I x1 + w' x I w'
  !> - w x I w (x1 = -Omega-dot - Omega x w', w' = w - Omega), and its derivatives: by the body's
  !> rate, -I [Omega] + [I Omega] - [Omega] I; by its turn dtheta (d(I y) = (I [y] - [I y]) dtheta),
  !> J(x1) + [w'] J(w') - [w] J(w) with J(y) = I [y] - [I y].
  pure subroutine relative_couples(ib, w, omega, omega_dot, dn, lp, lm)
    real(dp), intent(in) :: ib(3, 3), w(3), omega(3), omega_dot(3)
    real(dp), intent(out) :: dn(3), lp(3, 3), lm(3, 3)
    real(dp) :: wr(3), x1(3), oi(3, 3)
    wr = w - omega
    x1 = -omega_dot - cross(omega, wr)
    dn = matmul(ib, x1) + cross(wr, matmul(ib, wr)) - cross(w, matmul(ib, w))
    oi = skew_product(omega, ib)
    lm = transpose(oi) - oi + skew(matmul(ib, omega))
    lp = turn(x1) + skew_product(wr, turn(wr)) - skew_product(w, turn(w))
  contains
    !> J(y) = I [y] - [I y], with I [y] = -([y] I)^T.
    pure function turn(y) result(jy)
      real(dp), intent(in) :: y(3)
      real(dp) :: jy(3, 3)
      jy = -transpose(skew_product(y, ib)) - skew(matmul(ib, y))
    end function turn
  end subroutine relative_couples

  !> The matrices from the axes and the composites: each column's and each row's vectors (the
  !> module's formulas), then every entry as one dot product of them.  Inner loops run down a
  !> column (k), over contiguous rows of work%axis_rows and work%rows.
  pure subroutine assemble(chain, work, dtau_dq, dtau_dv, mass)
    type(chain_type), intent(in) :: chain
    type(derivatives_work), intent(inout) :: work
    real(dp), intent(inout) :: dtau_dq(:, :), dtau_dv(:, :)
    real(dp), intent(inout), optional :: mass(:, :)
    real(dp) :: s(6), c(6), d(6), gq(6), gv(6), ga(6), sq(6), sv(6), sa(6)
    integer :: nq, k, m, b, i, j, l, i0, nd
    nq = chain%n_coords
    do m = 1, nq
      b = work%body_of(m)
      s = work%axis(:, m)
      c = work%vel_axis(:, m)
      d = work%acc_axis(:, m)
      associate (ac => work%inertia_c(:, :, b), bc => work%velocity_c(:, :, b), qc => work%pose_c(:, :, b))
        ga = matmul(ac, s)
        gv = matmul(bc, s) + 2.0_dp*matmul(ac, c)
        gq = force_cross(s, work%joint_wrench(:, b)) + matmul(qc, s) + matmul(bc, c) + matmul(ac, d)
        ! Row m's vectors (composites of its own joint; A symmetric).
        sq = matmul(s, qc)
        sv = matmul(s, bc)
        sa = ga
      end associate
      work%cols(:, m) = gq
      work%cols(:, nq + m) = gv
      work%cols(:, 2*nq + m) = ga
      work%rows(m, 1:6) = sq
      work%rows(m, 7:12) = sv
      work%rows(m, 13:18) = sa
    end do
    do m = 1, nq
      gq = work%cols(:, m)
      gv = work%cols(:, nq + m)
      ga = work%cols(:, 2*nq + m)
      s = work%axis(:, m)
      c = work%vel_axis(:, m)
      d = work%acc_axis(:, m)
      do k = 1, m
        dtau_dq(k, m) = work%axis_rows(k, 1)*gq(1) + work%axis_rows(k, 2)*gq(2) + work%axis_rows(k, 3)*gq(3) &
                        + work%axis_rows(k, 4)*gq(4) + work%axis_rows(k, 5)*gq(5) + work%axis_rows(k, 6)*gq(6)
        dtau_dv(k, m) = work%axis_rows(k, 1)*gv(1) + work%axis_rows(k, 2)*gv(2) + work%axis_rows(k, 3)*gv(3) &
                        + work%axis_rows(k, 4)*gv(4) + work%axis_rows(k, 5)*gv(5) + work%axis_rows(k, 6)*gv(6)
      end do
      do k = m + 1, nq
        dtau_dq(k, m) = work%rows(k, 1)*s(1) + work%rows(k, 2)*s(2) + work%rows(k, 3)*s(3) &
                        + work%rows(k, 4)*s(4) + work%rows(k, 5)*s(5) + work%rows(k, 6)*s(6) &
                        + work%rows(k, 7)*c(1) + work%rows(k, 8)*c(2) + work%rows(k, 9)*c(3) &
                        + work%rows(k, 10)*c(4) + work%rows(k, 11)*c(5) + work%rows(k, 12)*c(6) &
                        + work%rows(k, 13)*d(1) + work%rows(k, 14)*d(2) + work%rows(k, 15)*d(3) &
                        + work%rows(k, 16)*d(4) + work%rows(k, 17)*d(5) + work%rows(k, 18)*d(6)
        dtau_dv(k, m) = work%rows(k, 7)*s(1) + work%rows(k, 8)*s(2) + work%rows(k, 9)*s(3) &
                        + work%rows(k, 10)*s(4) + work%rows(k, 11)*s(5) + work%rows(k, 12)*s(6) &
                        + 2.0_dp*(work%rows(k, 13)*c(1) + work%rows(k, 14)*c(2) + work%rows(k, 15)*c(3) &
                                  + work%rows(k, 16)*c(4) + work%rows(k, 17)*c(5) + work%rows(k, 18)*c(6))
      end do
      if (present(mass)) then
        do k = 1, m
          mass(k, m) = work%axis_rows(k, 1)*ga(1) + work%axis_rows(k, 2)*ga(2) + work%axis_rows(k, 3)*ga(3) &
                       + work%axis_rows(k, 4)*ga(4) + work%axis_rows(k, 5)*ga(5) + work%axis_rows(k, 6)*ga(6)
        end do
        do k = m + 1, nq
          mass(k, m) = work%rows(k, 13)*s(1) + work%rows(k, 14)*s(2) + work%rows(k, 15)*s(3) &
                       + work%rows(k, 16)*s(4) + work%rows(k, 17)*s(5) + work%rows(k, 18)*s(6)
        end do
      end if
    end do
    ! Generalized forces of the joints' own coordinates (springs, dampers): on the diagonal blocks.
    do j = 1, chain%n_bodies
      nd = chain%n_joint_coords(j)
      if (nd == 0) cycle
      i0 = chain%first_coord(j) - 1
      do l = 1, nd
        do i = 1, nd
          dtau_dq(i0 + i, i0 + l) = dtau_dq(i0 + i, i0 + l) - work%joint_q(i, l, j)
          dtau_dv(i0 + i, i0 + l) = dtau_dv(i0 + i, i0 + l) - work%joint_v(i, l, j)
        end do
      end do
    end do
  end subroutine assemble

end module rotorcable_inverse_dynamics_derivatives
