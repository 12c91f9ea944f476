!> Hand-written iso_c_binding interface to GSL's cubic splines (gsl/gsl_spline.h, GSL 2.7):
!> the C2 interpolation of time tables (rotor speed, blade angles), with the derivatives and
!> the integral that the equations of motion need.  GSL ships no Fortran interface.
module rotorcable_gsl_spline_binding
  use, intrinsic :: iso_c_binding, only: c_int, c_double, c_size_t, c_ptr
  implicit none
  private
  public :: gsl_interp_cspline, gsl_interp_cspline_periodic, gsl_spline_alloc, gsl_spline_init, &
            gsl_spline_free, gsl_spline_eval_e, gsl_spline_eval_deriv_e, gsl_spline_eval_deriv2_e, &
            gsl_spline_eval_integ_e, gsl_interp_accel_alloc, gsl_interp_accel_free

  ! Interpolation types are global pointer variables of libgsl.
  type(c_ptr), bind(C, name='gsl_interp_cspline') :: gsl_interp_cspline
  type(c_ptr), bind(C, name='gsl_interp_cspline_periodic') :: gsl_interp_cspline_periodic

  interface
    type(c_ptr) function gsl_spline_alloc(interp_type, size) bind(C, name='gsl_spline_alloc')
      import :: c_ptr, c_size_t
      type(c_ptr), value :: interp_type
      integer(c_size_t), value :: size
    end function gsl_spline_alloc

    integer(c_int) function gsl_spline_init(spline, xa, ya, size) bind(C, name='gsl_spline_init')
      import :: c_ptr, c_int, c_double, c_size_t
      type(c_ptr), value :: spline
      real(c_double), intent(in) :: xa(*), ya(*)
      integer(c_size_t), value :: size
    end function gsl_spline_init

    subroutine gsl_spline_free(spline) bind(C, name='gsl_spline_free')
      import :: c_ptr
      type(c_ptr), value :: spline
    end subroutine gsl_spline_free

    integer(c_int) function gsl_spline_eval_e(spline, x, acc, y) bind(C, name='gsl_spline_eval_e')
      import :: c_ptr, c_int, c_double
      type(c_ptr), value :: spline, acc
      real(c_double), value :: x
      real(c_double), intent(out) :: y
    end function gsl_spline_eval_e

    integer(c_int) function gsl_spline_eval_deriv_e(spline, x, acc, y) bind(C, name='gsl_spline_eval_deriv_e')
      import :: c_ptr, c_int, c_double
      type(c_ptr), value :: spline, acc
      real(c_double), value :: x
      real(c_double), intent(out) :: y
    end function gsl_spline_eval_deriv_e

    integer(c_int) function gsl_spline_eval_deriv2_e(spline, x, acc, y) bind(C, name='gsl_spline_eval_deriv2_e')
      import :: c_ptr, c_int, c_double
      type(c_ptr), value :: spline, acc
      real(c_double), value :: x
      real(c_double), intent(out) :: y
    end function gsl_spline_eval_deriv2_e

    integer(c_int) function gsl_spline_eval_integ_e(spline, a, b, acc, y) bind(C, name='gsl_spline_eval_integ_e')
      import :: c_ptr, c_int, c_double
      type(c_ptr), value :: spline, acc
      real(c_double), value :: a, b
      real(c_double), intent(out) :: y
    end function gsl_spline_eval_integ_e

    type(c_ptr) function gsl_interp_accel_alloc() bind(C, name='gsl_interp_accel_alloc')
      import :: c_ptr
    end function gsl_interp_accel_alloc

    subroutine gsl_interp_accel_free(acc) bind(C, name='gsl_interp_accel_free')
      import :: c_ptr
      type(c_ptr), value :: acc
    end subroutine gsl_interp_accel_free
  end interface

end module rotorcable_gsl_spline_binding
