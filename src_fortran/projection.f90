!> Projection of a start state onto the constraints g(q, t) = 0, G v + g_t = 0, and the rank
!> test of G that tells a closable chain from a taut or straight one.
module rotorcable_projection
  use rotorcable_kinds, only: dp
  use rotorcable_model, only: model_type, positions_at, constraint_residual, constraint_jacobian, &
                              constraint_velocity
  use rotorcable_linalg, only: solve_least_norm, singular_values, thin_svd
  implicit none
  private
  public :: project_positions, project_velocities, constraint_rank_margin, rank_loss_message, clamp_reach

  !> constraint_rank_margin below which the constraints count as dependent (a regular closed
  !> chain has 1e-3 to 1e-1; exactly taut or straight chains 1e-16 to 1e-9).  The one value the
  !> statics and the integrator's consistent start both refuse a chain by.
  real(dp), parameter, public :: RANK_TOL = 1.0e-7_dp

contains

  !> Project q onto g(q, t) = 0: the smallest change of the deck's shape that closes the chain.
  !> Levenberg-Marquardt on the support's closure residual (for the clamp: tip - p_B and
  !> (E - I) l_s, which has no spurious half-turn roots), with minimum-norm steps (the thin SVD of J,
  !> close_chain).  If the direct closure stalls (a far start), the support's target is
  !> approached by continuation from the start shape's own tip pose in 8, 32 or 128 steps
  !> (position linearly, orientation along the geodesic) and every step is closed from the
  !> previous one.  Returns the final max |g|.
  function project_positions(model, t, q) result(gmax)
    type(model_type), intent(inout) :: model  !< model
    real(dp), intent(in) :: t                 !< time [s]
    real(dp), intent(inout) :: q(:)           !< coordinates, projected in place
    real(dp) :: gmax
    real(dp) :: q_start(model%nq), p_0(3), r_0(3, 3), g(max(model%nc, 1)), s, gm
    integer :: n_steps(3), i, k, n
    gmax = 0.0_dp
    if (model%nc == 0) return
    n = model%chain%n_bodies
    q_start = q
    gmax = close_chain(model, t, q)
    if (gmax <= 1.0e-10_dp) return
    call positions_at(model, t, q_start)
    p_0 = model%st%joint_point(:, n + 1)
    r_0 = model%st%rot(:, :, n)
    n_steps = [8, 32, 128]
    do i = 1, size(n_steps)
      q = q_start
      do k = 1, n_steps(i)
        s = real(k, dp)/n_steps(i)
        call model%support_b%blend_target(s, p_0, r_0)
        gm = close_chain(model, t, q)
        if (gm > 1.0e-8_dp) exit
      end do
      call model%support_b%blend_target(1.0_dp, p_0, r_0)
      if (k > n_steps(i)) then
        gmax = close_chain(model, t, q)
        if (gmax <= 1.0e-10_dp) return
      end if
    end do
    call constraint_residual(model, t, q, g)
    gmax = max(maxval(abs(g)), 1.0_dp)
  end function project_positions

  !> Levenberg-Marquardt closure onto the support's current target (see project_positions).
  !> The damped step, the minimum-norm solution of [J; sqrt(mu) I] dq = [-r; 0], is
  !> dq = -V diag(s / (s^2 + mu)) U^T r from the thin SVD J = U diag(s) V^T of the m x nq
  !> closure Jacobian (m = 12 rows), singular values below eps s_max dropped (as dgelsd's
  !> rcond): O(m^2 nq) once per iteration and O(m nq) per trial mu, where a least-squares solve
  !> of the stacked (m + nq) x nq system was O(nq^3) (57 % of the 200-body equilibrium).
  function close_chain(model, t, q) result(gmax)
    type(model_type), intent(inout) :: model
    real(dp), intent(in) :: t
    real(dp), intent(inout) :: q(:)
    real(dp) :: gmax
    real(dp), allocatable :: r(:), r_try(:), r_jac(:, :), w(:), u(:, :), s(:), vt(:, :), c(:)
    real(dp) :: dq(model%nq), q_try(model%nq), mu, g(max(model%nc, 1)), l_s
    integer :: it, info, i, nq, m, k
    nq = model%nq
    m = model%support_b%closure_rows()
    k = min(m, nq)
    allocate (r(m), r_try(m), r_jac(m, nq), w(m), u(m, k), s(k), vt(k, nq), c(k))
    ! Orientation rows weighted by a length so that metres and radians balance.
    l_s = 0.25_dp*sum(model%chain%length)
    w = l_s
    w(1:min(3, m)) = 1.0_dp
    mu = 0.0_dp
    info = 0
    call closure(q, r)
    do it = 1, 300
      if (maxval(abs(r)) < 1.0e-14_dp) exit
      call positions_at(model, t, q)
      call model%support_b%closure(model%chain, model%st, r, r_jac)
      r = w*r
      do i = 1, nq
        r_jac(:, i) = w*r_jac(:, i)
      end do
      call thin_svd(r_jac, u, s, vt, info)
      if (info /= 0) exit
      do
        c = matmul(r, u)
        do i = 1, k
          if (s(i) > epsilon(1.0_dp)*s(1)) then
            c(i) = -c(i)*s(i)/(s(i)**2 + mu)
          else
            c(i) = 0.0_dp
          end if
        end do
        dq = matmul(c, vt)
        q_try = q + dq
        call closure(q_try, r_try)
        if (norm2(r_try) < norm2(r) .or. mu > 1.0e8_dp) exit
        mu = max(10.0_dp*mu, 1.0e-6_dp)
      end do
      if (info /= 0 .or. mu > 1.0e8_dp) exit
      q = q_try
      r = r_try
      mu = 0.1_dp*mu
    end do
    call constraint_residual(model, t, q, g)
    ! A flipped end orientation would also zero g: require the closure residual to vanish too.
    gmax = max(maxval(abs(g)), maxval(abs(r)/w))
  contains
    subroutine closure(qq, rr)
      real(dp), intent(in) :: qq(:)
      real(dp), intent(out) :: rr(:)
      real(dp) :: jj(m, nq)
      call positions_at(model, t, qq)
      call model%support_b%closure(model%chain, model%st, rr, jj)
      rr = w*rr
    end subroutine closure
  end function close_chain

  !> Project v onto G(q,t) v + g_t = 0 (minimum-norm change).
  subroutine project_velocities(model, t, q, v)
    type(model_type), intent(inout) :: model  !< model
    real(dp), intent(in) :: t                 !< time [s]
    real(dp), intent(in) :: q(:)              !< coordinates
    real(dp), intent(inout) :: v(:)           !< rates, projected in place
    real(dp) :: gv(model%nc), g_jac(model%nc, model%nq), dv(model%nq)
    integer :: info
    if (model%nc == 0) return
    call constraint_velocity(model, t, q, v, gv)
    call constraint_jacobian(model, t, q, g_jac)
    call solve_least_norm(g_jac, gv, dv, info)
    v = v - dv
  end subroutine project_velocities

  !> sigma_min / sigma_max of G(q, t) with its position and orientation rows balanced by a
  !> length (1 for a free end).  A value near zero means the constraints are dependent: the
  !> chain is taut (its end at full reach) or straight where it must bend, and the support's
  !> reaction is not determined by the equations.
  function constraint_rank_margin(model, t, q) result(ratio)
    type(model_type), intent(inout) :: model  !< model
    real(dp), intent(in) :: t                 !< time [s]
    real(dp), intent(in) :: q(:)              !< coordinates
    real(dp) :: ratio
    real(dp) :: g_jac(model%nc, model%nq), s(min(model%nc, model%nq)), l_s
    integer :: info
    ratio = 1.0_dp
    if (model%nc == 0) return
    call constraint_jacobian(model, t, q, g_jac)
    l_s = 0.25_dp*sum(model%chain%length)
    g_jac(4:, :) = l_s*g_jac(4:, :)
    call singular_values(g_jac, s, info)
    if (info /= 0 .or. s(1) <= 0.0_dp) then
      ratio = 0.0_dp
      return
    end if
    ratio = s(size(s))/s(1)
  end function constraint_rank_margin

  !> Why the constraints are dependent, for the error message: clamp B's distance from the start
  !> of the free part against the free part's length (the reach).
  function rank_loss_message(model, t, q, margin) result(msg)
    type(model_type), intent(inout) :: model  !< model
    real(dp), intent(in) :: t                 !< time [s]
    real(dp), intent(in) :: q(:)              !< coordinates where the rank was lost
    real(dp), intent(in) :: margin            !< sigma_min/sigma_max of G
    character(len=:), allocatable :: msg
    character(len=240) :: buf
    real(dp) :: reach, span
    write (buf, '(a, es9.2, a)') 'clamp B: the constraint Jacobian has lost rank (sigma_min/sigma_max = ', margin, ')'
    msg = trim(buf)
    if (clamp_reach(model, t, q, reach, span)) then
      write (buf, '(a, f10.6, a, f10.6, a, f8.4, a)') ': the free part of the chain spans ', span, &
        ' m of its ', reach, ' m reach (', 100.0_dp*span/max(reach, tiny(1.0_dp)), ' %)'
      msg = msg//trim(buf)
      if (span < reach*(1.0_dp - 1.0e-6_dp)) then
        msg = msg//'; the cable has slack, but this shape is straight (or kinked straight) between the '// &
              'clamps, where no small joint motion moves its end towards clamp B: start from a shape '// &
              'bent towards the clamp'
        return
      end if
    end if
    msg = msg//'; the chain is straight or taut between the clamps, so its shape and the clamp '// &
          'reactions are not determined: move clamp B within reach or give the cable slack'
  end function rank_loss_message

  !> The free part of the chain runs from the end of a clamped first body (or from A) to the
  !> point support B must be reached at (support_type%reach_target: for clamp B the start of
  !> the body it holds): its length (the reach) and the distance it must span at (t, q).
  !> False when there is no support B or it has no reach check.
  logical function clamp_reach(model, t, q, reach, span, held) result(has_clamp)
    type(model_type), intent(inout) :: model  !< model
    real(dp), intent(in) :: t                 !< time [s]
    real(dp), intent(in) :: q(:)              !< coordinates
    real(dp), intent(out) :: reach            !< length of the free part [m]
    real(dp), intent(out) :: span             !< distance it must span [m]
    integer, intent(out), optional :: held    !< bodies support B holds rigidly
    real(dp) :: start(3), target(3)
    integer :: n, n_held
    has_clamp = .false.
    reach = 0.0_dp; span = 0.0_dp
    if (present(held)) held = 0
    if (.not. allocated(model%support_b)) return
    n = model%chain%n_bodies
    call positions_at(model, t, q)
    call model%support_b%reach_target(model%chain, target, n_held, has_clamp)
    if (.not. has_clamp) return
    if (present(held)) held = n_held
    start = model%st%joint_point(:, 1)
    reach = sum(model%chain%length(1:n - n_held))
    if (model%chain%locked(1)) then
      start = model%st%joint_point(:, 2)
      reach = reach - model%chain%length(1)
    end if
    span = norm2(target - start)
  end function clamp_reach

end module rotorcable_projection
