!> Spatial (6-D) vectors of rigid-body motion and force about one fixed point, the language of the
!> whole-matrix derivatives (rotorcable_inverse_dynamics_derivatives).  Featherstone, Rigid Body
!> Dynamics Algorithms, 2008, ch. 2 (Pluecker coordinates), with the linear part first:
!>   motion m = (v, w): w the angular velocity, v the velocity of the body point at the reference
!>                      point (a twist; a joint axis a through p is (p x a, a) about the origin),
!>   force  f = (F, N): F the force, N its moment about the reference point,
!> and m . f = v . F + w . N the power.  Moving the reference point from the origin to p:
!>   m_p = X_p m = (v + w x p, w),   f = X_p^T f_p = (F, N_p + p x F),   X_p = [I, -[p]; 0, I].
!> A linear map from motion at p to force at p (an inertia, a load's derivative) is M = X_p^T M_p X_p
!> about the origin.  Cross products: m1 x m2 (motion), m x* f (force, the dual: m x* = -(m x)^T).
module rotorcable_spatial_algebra
  use rotorcable_kinds, only: dp
  use rotorcable_rotations, only: skew
  implicit none
  private
  public :: motion_cross, force_cross, to_origin, twist_at, wrench_about_origin, skew_product, point_wrench_to_cm

contains

  !> Motion cross product m1 x m2 = (w1 x v2 + v1 x w2, w1 x w2).
  pure function motion_cross(m1, m2) result(m)
    real(dp), intent(in) :: m1(6), m2(6)      !< motions (v, w)
    real(dp) :: m(6)
    m(1) = m1(5)*m2(3) - m1(6)*m2(2) + m1(2)*m2(6) - m1(3)*m2(5)
    m(2) = m1(6)*m2(1) - m1(4)*m2(3) + m1(3)*m2(4) - m1(1)*m2(6)
    m(3) = m1(4)*m2(2) - m1(5)*m2(1) + m1(1)*m2(5) - m1(2)*m2(4)
    m(4) = m1(5)*m2(6) - m1(6)*m2(5)
    m(5) = m1(6)*m2(4) - m1(4)*m2(6)
    m(6) = m1(4)*m2(5) - m1(5)*m2(4)
  end function motion_cross

  !> Force cross product m x* f = (w x F, w x N + v x F): the change of a force carried along by
  !> the motion m.
  pure function force_cross(m, f) result(g)
    real(dp), intent(in) :: m(6)              !< motion (v, w)
    real(dp), intent(in) :: f(6)              !< force (F, N)
    real(dp) :: g(6)
    g(1) = m(5)*f(3) - m(6)*f(2)
    g(2) = m(6)*f(1) - m(4)*f(3)
    g(3) = m(4)*f(2) - m(5)*f(1)
    g(4) = m(5)*f(6) - m(6)*f(5) + m(2)*f(3) - m(3)*f(2)
    g(5) = m(6)*f(4) - m(4)*f(6) + m(3)*f(1) - m(1)*f(3)
    g(6) = m(4)*f(5) - m(5)*f(4) + m(1)*f(2) - m(2)*f(1)
  end function force_cross

  !> The motion m (about the origin) about the point p: X_p m = (v + w x p, w).
  pure function twist_at(m, p) result(mp)
    real(dp), intent(in) :: m(6)              !< motion about the origin
    real(dp), intent(in) :: p(3)              !< point (relative to the origin) [m]
    real(dp) :: mp(6)
    mp(1) = m(1) + m(5)*p(3) - m(6)*p(2)
    mp(2) = m(2) + m(6)*p(1) - m(4)*p(3)
    mp(3) = m(3) + m(4)*p(2) - m(5)*p(1)
    mp(4:6) = m(4:6)
  end function twist_at

  !> A force F at the point p with a moment N, about the origin: (F, N + p x F).
  pure function wrench_about_origin(force, moment, p) result(f)
    real(dp), intent(in) :: force(3), moment(3)  !< F [N], N [Nm]
    real(dp), intent(in) :: p(3)              !< point of F (relative to the origin) [m]
    real(dp) :: f(6)
    f(1:3) = force
    f(4) = moment(1) + p(2)*force(3) - p(3)*force(2)
    f(5) = moment(2) + p(3)*force(1) - p(1)*force(3)
    f(6) = moment(3) + p(1)*force(2) - p(2)*force(1)
  end function wrench_about_origin

  !> X_p^T M X_p: a map M from motion at p to force at p as the map about the origin.  With
  !> X_p = [I, -[p]; 0, I]: the right factor takes the angular columns to M(:, 4:6) - M(:, 1:3) [p],
  !> the left one the moment rows to M(4:6, :) + [p] M(1:3, :).
  pure function to_origin(m, p) result(mo)
    real(dp), intent(in) :: m(6, 6)           !< map about p
    real(dp), intent(in) :: p(3)              !< the point (relative to the origin) [m]
    real(dp) :: mo(6, 6)
    integer :: i
    mo = m
    do i = 1, 6
      ! Row i of M(:, 1:3) [p] is r x p for the row r = M(i, 1:3) (r^T [p] = (-[p] r)^T).
      mo(i, 4) = mo(i, 4) - (m(i, 2)*p(3) - m(i, 3)*p(2))
      mo(i, 5) = mo(i, 5) - (m(i, 3)*p(1) - m(i, 1)*p(3))
      mo(i, 6) = mo(i, 6) - (m(i, 1)*p(2) - m(i, 2)*p(1))
    end do
    do i = 1, 6
      mo(4, i) = mo(4, i) + p(2)*mo(3, i) - p(3)*mo(2, i)
      mo(5, i) = mo(5, i) + p(3)*mo(1, i) - p(1)*mo(3, i)
      mo(6, i) = mo(6, i) + p(1)*mo(2, i) - p(2)*mo(1, i)
    end do
  end function to_origin

  !> A wrench (F at a body point x, moment M) as the force at the body's CM and the moment
  !> M + r x F (r = x - C), and its derivative by the body's pose about the CM (dC, dtheta), from
  !> d its derivative by the pose about x (dx, dtheta): X_r^T d X_r (dx = dC - [r] dtheta, the
  !> moment of dF about C), plus the turn of the arm, d(r) x F = (dtheta x r) x F = [F] [r] dtheta.
  pure function point_wrench_to_cm(d, force, r) result(dc)
    real(dp), intent(in) :: d(6, 6)           !< d(F, M)/d(dx, dtheta)
    real(dp), intent(in) :: force(3)          !< F [N]
    real(dp), intent(in) :: r(3)              !< x - C [m]
    real(dp) :: dc(6, 6)
    dc = to_origin(d, r)
    dc(4:6, 4:6) = dc(4:6, 4:6) + matmul(skew(force), skew(r))
  end function point_wrench_to_cm

  !> [a] B for a 3-vector a and a 3 x 3 matrix B: the cross product of a with every column.
  pure function skew_product(a, b) result(c)
    real(dp), intent(in) :: a(3)              !< vector
    real(dp), intent(in) :: b(3, 3)           !< matrix
    real(dp) :: c(3, 3)
    integer :: j
    do j = 1, 3
      c(1, j) = a(2)*b(3, j) - a(3)*b(2, j)
      c(2, j) = a(3)*b(1, j) - a(1)*b(3, j)
      c(3, j) = a(1)*b(2, j) - a(2)*b(1, j)
    end do
  end function skew_product

end module rotorcable_spatial_algebra
