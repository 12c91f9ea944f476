!> Hand-written iso_c_binding interface to the part of GSL's gsl_odeiv2 that the
!> ODE-form integrators use (GSL 2.7, gsl/gsl_odeiv2.h).  GSL ships no Fortran
!> interface; FGSL would be a further dependency for a dozen calls.
!>
!> GSL's default error handler calls abort(), which would kill the Python interpreter;
!> callers switch it off (gsl_set_error_handler_off) and check every return code.
module rotorcable_gsl_ode_binding
  use, intrinsic :: iso_c_binding, only: c_int, c_double, c_size_t, c_long, c_ptr, c_funptr
  implicit none
  private
  public :: gsl_odeiv2_system, gsl_odeiv2_driver, gsl_odeiv2_evolve, gsl_step_rk8pd, gsl_step_msbdf, &
            gsl_step_rkf45, gsl_step_bsimp, gsl_odeiv2_driver_alloc_y_new, gsl_odeiv2_driver_apply, &
            gsl_odeiv2_driver_set_nmax, gsl_odeiv2_driver_set_hmax, gsl_odeiv2_driver_reset, &
            gsl_odeiv2_driver_free, gsl_set_error_handler_off, GSL_SUCCESS

  integer(c_int), parameter :: GSL_SUCCESS = 0

  !> gsl_odeiv2_system: right-hand side, Jacobian, dimension, user data.
  type, bind(C) :: gsl_odeiv2_system
    type(c_funptr) :: function
    type(c_funptr) :: jacobian
    integer(c_size_t) :: dimension
    type(c_ptr) :: params
  end type gsl_odeiv2_system

  !> struct gsl_odeiv2_driver_struct (read for the step statistics only).
  type, bind(C) :: gsl_odeiv2_driver
    type(c_ptr) :: sys, s, c, e
    real(c_double) :: h, hmin, hmax
    integer(c_long) :: n, nmax
  end type gsl_odeiv2_driver

  !> struct gsl_odeiv2_evolve_struct: accepted and failed step counters.
  type, bind(C) :: gsl_odeiv2_evolve
    integer(c_size_t) :: dimension
    type(c_ptr) :: y0, yerr, dydt_in, dydt_out
    real(c_double) :: last_step
    integer(c_long) :: count, failed_steps
    type(c_ptr) :: driver
  end type gsl_odeiv2_evolve

  ! Step types are global pointer variables of libgsl.
  type(c_ptr), bind(C, name='gsl_odeiv2_step_rk8pd') :: gsl_step_rk8pd
  type(c_ptr), bind(C, name='gsl_odeiv2_step_msbdf') :: gsl_step_msbdf
  type(c_ptr), bind(C, name='gsl_odeiv2_step_rkf45') :: gsl_step_rkf45
  type(c_ptr), bind(C, name='gsl_odeiv2_step_bsimp') :: gsl_step_bsimp

  interface
    type(c_ptr) function gsl_odeiv2_driver_alloc_y_new(sys, step_type, hstart, epsabs, epsrel) &
        bind(C, name='gsl_odeiv2_driver_alloc_y_new')
      import :: c_ptr, c_double
      type(c_ptr), value :: sys, step_type
      real(c_double), value :: hstart, epsabs, epsrel
    end function gsl_odeiv2_driver_alloc_y_new

    integer(c_int) function gsl_odeiv2_driver_apply(d, t, t1, y) bind(C, name='gsl_odeiv2_driver_apply')
      import :: c_ptr, c_int, c_double
      type(c_ptr), value :: d
      real(c_double), intent(inout) :: t
      real(c_double), value :: t1
      real(c_double), intent(inout) :: y(*)
    end function gsl_odeiv2_driver_apply

    integer(c_int) function gsl_odeiv2_driver_set_nmax(d, nmax) bind(C, name='gsl_odeiv2_driver_set_nmax')
      import :: c_ptr, c_int, c_long
      type(c_ptr), value :: d
      integer(c_long), value :: nmax
    end function gsl_odeiv2_driver_set_nmax

    integer(c_int) function gsl_odeiv2_driver_set_hmax(d, hmax) bind(C, name='gsl_odeiv2_driver_set_hmax')
      import :: c_ptr, c_int, c_double
      type(c_ptr), value :: d
      real(c_double), value :: hmax
    end function gsl_odeiv2_driver_set_hmax

    integer(c_int) function gsl_odeiv2_driver_reset(d) bind(C, name='gsl_odeiv2_driver_reset')
      import :: c_ptr, c_int
      type(c_ptr), value :: d
    end function gsl_odeiv2_driver_reset

    subroutine gsl_odeiv2_driver_free(d) bind(C, name='gsl_odeiv2_driver_free')
      import :: c_ptr
      type(c_ptr), value :: d
    end subroutine gsl_odeiv2_driver_free

    type(c_ptr) function gsl_set_error_handler_off() bind(C, name='gsl_set_error_handler_off')
      import :: c_ptr
    end function gsl_set_error_handler_off
  end interface

end module rotorcable_gsl_ode_binding
