!> The interface of a support at the chain's far end: its constraint rows g(q, t) = 0 in the
!> GGL form (residual, Jacobian G, G^T mu, the velocity rows G v + g_t, the acceleration bias
!> (d/dt)^2 g at qdd = 0) and the wrench its multipliers exert on the chain.  A free end has no
!> support and no rows.  Modelled on tblite's container_type (src/tblite/container/type.f90):
!> a new kind of support is one type extending support_type, in a file of its own.
!>
!> A support is evaluated at a time by `update` (its prescribed pose and motion), then its row
!> procedures read the chain state st (frames, absolute velocities and accelerations in the
!> model frame) and the frame state fs (to form velocities relative to the model frame).
module rotorcable_supports_type
  use rotorcable_kinds, only: dp
  use rotorcable_chain, only: chain_type
  use rotorcable_kinematics, only: chain_state
  use rotorcable_kinematics_tangent, only: chain_tangent
  use rotorcable_frame, only: frame_state
  use rotorcable_motion_rotor, only: rotor_state
  implicit none
  private
  public :: support_type

  type, abstract :: support_type
    character(len=32) :: label = ''           !< name in messages ('clamp B')
    character(len=64) :: position_key = ''    !< deck key of its position, for messages
  contains
    !> Number of constraint rows.
    procedure(rows_i), deferred :: rows
    !> Evaluate the prescribed pose and motion at time t.
    procedure(update_i), deferred :: update
    !> g(q, t).
    procedure(residual_i), deferred :: residual
    !> G = dg/dq.
    procedure(jacobian_i), deferred :: jacobian
    !> r = r + G^T mu without forming G.
    procedure(add_jt_i), deferred :: add_jacobian_transpose_times
    !> G v + g_t (needs the velocities in st).
    procedure(rows_vector_i), deferred :: velocity
    !> d^2 g/dt^2 at qdd = 0 (needs velocities and accelerations at qdd = 0 in st).
    procedure(rows_vector_i), deferred :: bias
    !> Force and moment of the support on the chain from the multipliers.
    procedure(wrench_i), deferred :: wrench
    !> First-order changes of g, of G v + g_t, of G^T mu and of the wrench for a change dst of
    !> the chain state (rotorcable_kinematics_tangent) and of the multipliers: the analytic
    !> Jacobian's constraint parts.
    procedure(residual_tangent_i), deferred :: residual_tangent
    procedure(velocity_tangent_i), deferred :: velocity_tangent
    procedure(add_jt_tangent_i), deferred :: add_jacobian_transpose_tangent
    procedure(wrench_tangent_i), deferred :: wrench_tangent
    !> The same derivatives as matrices, for the Jacobian taken whole (rotorcable_model_derivatives):
    !> by the last body's own motion, a shift dP of the tip P_{n+1} and a turn dtheta_n about it
    !> (pose, columns 1:3 and 4:6), or a change dv of the tip's absolute velocity and domega_n of
    !> the body's angular velocity (motion).  wrench_jacobian: d(F, M)/d(pose) (rows 1:3 the
    !> force at the tip, 4:6 the moment) of the wrench of multipliers lambda (or of mu: the
    !> generalized force G^T mu is that of the same wrench).  rows_jacobian: d(g)/d(pose),
    !> d(G v + g_t)/d(pose) and d(G v + g_t)/d(motion), (nc, 6) each.
    procedure(wrench_jacobian_i), deferred :: wrench_jacobian
    procedure(rows_jacobian_i), deferred :: rows_jacobian
    !> A closure residual without spurious roots and its Jacobian (for projecting a start shape).
    procedure(closure_i), deferred :: closure
    !> Size of the closure residual.
    procedure(rows_i), deferred :: closure_rows
    !> Move the target pose part of the way from (p0, R0) towards the true one (continuation).
    procedure(blend_i), deferred :: blend_target
    !> The point the free part of the chain must reach and how many bodies at the chain's end
    !> the support holds rigidly (they are not part of that free part); found = .false.: no
    !> reach check (rotorcable_projection, clamp_reach).
    procedure :: reach_target => no_reach_target
    !> Velocity of the support point and rotation rate of the support, relative to the model
    !> frame, at the last update (with the reactions, the power the support puts in).
    procedure :: motion_twist => at_rest
    !> Release C memory held by a prescribed motion.
    procedure :: free => no_free
    !> Keep what the tangents need at the state of st (the model calls it once per state,
    !> before them, as it calls the loads' linearise): nothing, by default.
    procedure :: linearise => no_linearise
  end type support_type

  abstract interface
    pure integer function rows_i(self)
      import :: support_type
      class(support_type), intent(in) :: self
    end function rows_i

    subroutine update_i(self, t, rs)
      import :: support_type, dp, rotor_state
      class(support_type), intent(inout) :: self
      real(dp), intent(in) :: t
      type(rotor_state), intent(in) :: rs
    end subroutine update_i

    pure subroutine residual_i(self, chain, st, g)
      import :: support_type, chain_type, chain_state, dp
      class(support_type), intent(in) :: self
      type(chain_type), intent(in) :: chain
      type(chain_state), intent(in) :: st
      real(dp), intent(out) :: g(:)
    end subroutine residual_i

    pure subroutine jacobian_i(self, chain, st, g_jac)
      import :: support_type, chain_type, chain_state, dp
      class(support_type), intent(in) :: self
      type(chain_type), intent(in) :: chain
      type(chain_state), intent(in) :: st
      real(dp), intent(out) :: g_jac(:, :)
    end subroutine jacobian_i

    pure subroutine add_jt_i(self, chain, st, mu, r)
      import :: support_type, chain_type, chain_state, dp
      class(support_type), intent(in) :: self
      type(chain_type), intent(in) :: chain
      type(chain_state), intent(in) :: st
      real(dp), intent(in) :: mu(:)
      real(dp), intent(inout) :: r(:)
    end subroutine add_jt_i

    pure subroutine rows_vector_i(self, chain, st, fs, out)
      import :: support_type, chain_type, chain_state, frame_state, dp
      class(support_type), intent(in) :: self
      type(chain_type), intent(in) :: chain
      type(chain_state), intent(in) :: st
      type(frame_state), intent(in) :: fs
      real(dp), intent(out) :: out(:)
    end subroutine rows_vector_i

    pure subroutine wrench_i(self, chain, st, lambda, force, moment)
      import :: support_type, chain_type, chain_state, dp
      class(support_type), intent(in) :: self
      type(chain_type), intent(in) :: chain
      type(chain_state), intent(in) :: st
      real(dp), intent(in) :: lambda(:)
      real(dp), intent(out) :: force(3), moment(3)
    end subroutine wrench_i

    pure subroutine residual_tangent_i(self, chain, st, dst, dg)
      import :: support_type, chain_type, chain_state, chain_tangent, dp
      class(support_type), intent(in) :: self
      type(chain_type), intent(in) :: chain
      type(chain_state), intent(in) :: st
      type(chain_tangent), intent(in) :: dst
      real(dp), intent(out) :: dg(:)
    end subroutine residual_tangent_i

    pure subroutine velocity_tangent_i(self, chain, st, dst, fs, dout)
      import :: support_type, chain_type, chain_state, chain_tangent, frame_state, dp
      class(support_type), intent(in) :: self
      type(chain_type), intent(in) :: chain
      type(chain_state), intent(in) :: st
      type(chain_tangent), intent(in) :: dst
      type(frame_state), intent(in) :: fs
      real(dp), intent(out) :: dout(:)
    end subroutine velocity_tangent_i

    pure subroutine add_jt_tangent_i(self, chain, st, dst, mu, dmu, dr)
      import :: support_type, chain_type, chain_state, chain_tangent, dp
      class(support_type), intent(in) :: self
      type(chain_type), intent(in) :: chain
      type(chain_state), intent(in) :: st
      type(chain_tangent), intent(in) :: dst
      real(dp), intent(in) :: mu(:), dmu(:)
      real(dp), intent(inout) :: dr(:)
    end subroutine add_jt_tangent_i

    pure subroutine wrench_tangent_i(self, chain, st, dst, lambda, dlambda, dforce, dmoment)
      import :: support_type, chain_type, chain_state, chain_tangent, dp
      class(support_type), intent(in) :: self
      type(chain_type), intent(in) :: chain
      type(chain_state), intent(in) :: st
      type(chain_tangent), intent(in) :: dst
      real(dp), intent(in) :: lambda(:), dlambda(:)
      real(dp), intent(out) :: dforce(3), dmoment(3)
    end subroutine wrench_tangent_i

    pure subroutine wrench_jacobian_i(self, chain, st, lambda, d_wrench)
      import :: support_type, chain_type, chain_state, dp
      class(support_type), intent(in) :: self
      type(chain_type), intent(in) :: chain
      type(chain_state), intent(in) :: st
      real(dp), intent(in) :: lambda(:)
      real(dp), intent(out) :: d_wrench(6, 6)
    end subroutine wrench_jacobian_i

    pure subroutine rows_jacobian_i(self, chain, st, fs, dg_pose, dgv_pose, dgv_motion)
      import :: support_type, chain_type, chain_state, frame_state, dp
      class(support_type), intent(in) :: self
      type(chain_type), intent(in) :: chain
      type(chain_state), intent(in) :: st
      type(frame_state), intent(in) :: fs
      real(dp), intent(out) :: dg_pose(:, :), dgv_pose(:, :), dgv_motion(:, :)
    end subroutine rows_jacobian_i

    pure subroutine closure_i(self, chain, st, r, r_jac)
      import :: support_type, chain_type, chain_state, dp
      class(support_type), intent(in) :: self
      type(chain_type), intent(in) :: chain
      type(chain_state), intent(in) :: st
      real(dp), intent(out) :: r(:)
      real(dp), intent(out) :: r_jac(:, :)
    end subroutine closure_i

    subroutine blend_i(self, s, p0, r0)
      import :: support_type, dp
      class(support_type), intent(inout) :: self
      real(dp), intent(in) :: s
      real(dp), intent(in) :: p0(3), r0(3, 3)
    end subroutine blend_i
  end interface

contains

  !> No reach check by default.
  pure subroutine no_reach_target(self, chain, point, held, found)
    class(support_type), intent(in) :: self   !< support
    type(chain_type), intent(in) :: chain     !< chain description
    real(dp), intent(out) :: point(3)         !< point the free part must reach [m]
    integer, intent(out) :: held              !< bodies held rigidly at the end
    logical, intent(out) :: found             !< the support has a reach check
    point = 0.0_dp
    held = 0
    found = .false.
  end subroutine no_reach_target

  !> A support that does not move.
  pure subroutine at_rest(self, velocity, omega)
    class(support_type), intent(in) :: self   !< support
    real(dp), intent(out) :: velocity(3)      !< support point velocity [m/s]
    real(dp), intent(out) :: omega(3)         !< rotation rate [rad/s]
    velocity = 0.0_dp
    omega = 0.0_dp
  end subroutine at_rest

  !> Release C memory (table splines); nothing by default.
  subroutine no_linearise(self, chain, st)
    class(support_type), intent(inout) :: self  !< the support
    type(chain_type), intent(in) :: chain     !< chain description
    type(chain_state), intent(in) :: st       !< frames and motion at the state
  end subroutine no_linearise

  subroutine no_free(self)
    class(support_type), intent(inout) :: self  !< support
  end subroutine no_free

end module rotorcable_supports_type
