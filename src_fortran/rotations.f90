!> Elementary rotations and small 3-vector helpers.
!>
!> All matrices here are *active* rotations (world <- body).  The thesis writes the
!> passive transforms A (eq. 4.5-4.8), which are the transposes of these: A(gamma) =
!> rot_z(gamma)^T (the joints' products Rz Ry, Rx Ry are written out in joint_rotation).
module rotorcable_rotations
  use rotorcable_kinds, only: dp
  implicit none
  private
  public :: rot_z, cross, skew, vee, identity3, rotation_log, rotation_exp, transposed_times

contains

  !> Active rotation about z by angle a (transpose of thesis eq. 4.5).
  pure function rot_z(a) result(r)
    real(dp), intent(in) :: a          !< angle [rad]
    real(dp) :: r(3, 3)
    real(dp) :: c, s
    c = cos(a); s = sin(a)
    r(:, 1) = [c, s, 0.0_dp]
    r(:, 2) = [-s, c, 0.0_dp]
    r(:, 3) = [0.0_dp, 0.0_dp, 1.0_dp]
  end function rot_z

  !> Cross product a x b.
  pure function cross(a, b) result(c)
    real(dp), intent(in) :: a(3)       !< first factor
    real(dp), intent(in) :: b(3)       !< second factor
    real(dp) :: c(3)
    c(1) = a(2)*b(3) - a(3)*b(2)
    c(2) = a(3)*b(1) - a(1)*b(3)
    c(3) = a(1)*b(2) - a(2)*b(1)
  end function cross

  !> Tilde (cross-product) matrix of w, eq. 4.4: skew(w) v = w x v.
  pure function skew(w) result(m)
    real(dp), intent(in) :: w(3)       !< vector
    real(dp) :: m(3, 3)
    m(:, 1) = [0.0_dp, w(3), -w(2)]
    m(:, 2) = [-w(3), 0.0_dp, w(1)]
    m(:, 3) = [w(2), -w(1), 0.0_dp]
  end function skew

  !> Inverse of skew: the axial vector (m32, m13, m21) of a matrix.
  pure function vee(m) result(w)
    real(dp), intent(in) :: m(3, 3)    !< matrix (only its skew part matters)
    real(dp) :: w(3)
    w = [m(3, 2), m(1, 3), m(2, 1)]
  end function vee

  !> a^T x for a 3x3 matrix, written out: gfortran calls the library for matmul(transpose(a), x)
  !> even at fixed size (callgrind: ~280 instructions a call against ~15 of arithmetic).
  pure function transposed_times(a, x) result(y)
    real(dp), intent(in) :: a(3, 3)    !< matrix
    real(dp), intent(in) :: x(3)       !< vector
    real(dp) :: y(3)
    y(1) = a(1, 1)*x(1) + a(2, 1)*x(2) + a(3, 1)*x(3)
    y(2) = a(1, 2)*x(1) + a(2, 2)*x(2) + a(3, 2)*x(3)
    y(3) = a(1, 3)*x(1) + a(2, 3)*x(2) + a(3, 3)*x(3)
  end function transposed_times

  !> 3x3 identity.
  pure function identity3() result(m)
    real(dp) :: m(3, 3)
    m = 0.0_dp
    m(1, 1) = 1.0_dp; m(2, 2) = 1.0_dp; m(3, 3) = 1.0_dp
  end function identity3

  !> Rotation vector (axis x angle) of a rotation matrix, angle in [0, pi] (inverse Rodrigues).
  pure function rotation_log(r) result(w)
    real(dp), intent(in) :: r(3, 3)    !< rotation matrix
    real(dp) :: w(3)
    real(dp) :: c, angle, s, b(3, 3)
    integer :: k
    c = max(-1.0_dp, min(1.0_dp, 0.5_dp*(r(1, 1) + r(2, 2) + r(3, 3) - 1.0_dp)))
    angle = acos(c)
    s = sin(angle)
    if (angle < 1.0e-8_dp) then
      w = 0.5_dp*vee(r - transpose(r))
    else if (s > 1.0e-6_dp) then
      w = angle/(2.0_dp*s)*vee(r - transpose(r))
    else
      ! Near a half turn: axis from the symmetric part, R + I = 2 u u^T.
      b = 0.5_dp*(r + identity3())
      k = maxloc([b(1, 1), b(2, 2), b(3, 3)], dim=1)
      w = b(:, k)/sqrt(max(b(k, k), tiny(1.0_dp)))*angle
    end if
  end function rotation_log

  !> Rotation matrix of a rotation vector (Rodrigues' formula).
  pure function rotation_exp(w) result(r)
    real(dp), intent(in) :: w(3)       !< rotation vector [rad]
    real(dp) :: r(3, 3)
    real(dp) :: angle, k(3, 3)
    angle = norm2(w)
    if (angle < 1.0e-12_dp) then
      r = identity3() + skew(w)
      return
    end if
    k = skew(w/angle)
    r = identity3() + sin(angle)*k + (1.0_dp - cos(angle))*matmul(k, k)
  end function rotation_exp

end module rotorcable_rotations
