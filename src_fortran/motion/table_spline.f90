!> A time table interpolated by a natural cubic spline (GSL), C2 inside the table, so that
!> a prescribed angle has the second derivative the acceleration-level constraint (g_tt)
!> needs.  Outside the table the last value is held (first and second derivative zero; the
!> integral grows linearly), which is the natural reading of "the table ends here".
module rotorcable_motion_table_spline
  use, intrinsic :: iso_c_binding, only: c_ptr, c_null_ptr, c_associated, c_size_t, c_double, c_int
  use rotorcable_kinds, only: dp
  use rotorcable_errors, only: error_type, fatal_error
  use rotorcable_gsl_spline_binding, only: gsl_interp_cspline, gsl_spline_alloc, gsl_spline_init, &
                                           gsl_spline_free, gsl_spline_eval_e, gsl_spline_eval_deriv_e, &
                                           gsl_spline_eval_deriv2_e, gsl_spline_eval_integ_e, &
                                           gsl_interp_accel_alloc, gsl_interp_accel_free
  implicit none
  private
  public :: table_spline, spline_init, spline_eval, spline_integral, spline_free

  !> GSL spline of a table (x_k, y_k); the C objects are freed by spline_free.
  type :: table_spline
    type(c_ptr) :: spline = c_null_ptr        !< gsl_spline
    type(c_ptr) :: accel = c_null_ptr         !< gsl_interp_accel (last-interval cache)
    real(dp) :: x_first = 0.0_dp, x_last = 0.0_dp
    real(dp) :: y_first = 0.0_dp, y_last = 0.0_dp
  end type table_spline

contains

  !> Build the spline of a table; x strictly increasing, at least 3 points (GSL's cspline).
  subroutine spline_init(s, x, y, error)
    type(table_spline), intent(inout) :: s    !< spline to build
    real(dp), intent(in) :: x(:), y(:)        !< table abscissae and values
    type(error_type), intent(inout) :: error  !< status
    integer(c_int) :: flag
    if (size(x) < 3 .or. size(x) /= size(y)) then
      call fatal_error(error, 'a table needs at least 3 points and as many values as times')
      return
    end if
    if (any(x(2:) <= x(:size(x) - 1))) then
      call fatal_error(error, 'table times must increase strictly')
      return
    end if
    s%spline = gsl_spline_alloc(gsl_interp_cspline, int(size(x), c_size_t))
    s%accel = gsl_interp_accel_alloc()
    flag = gsl_spline_init(s%spline, real(x, c_double), real(y, c_double), int(size(x), c_size_t))
    if (flag /= 0) call fatal_error(error, 'GSL could not build the table spline')
    s%x_first = x(1); s%x_last = x(size(x))
    s%y_first = y(1); s%y_last = y(size(y))
  end subroutine spline_init

  !> Value and first two derivatives at x (held constant outside the table).  With
  !> ``ends_on_spline`` the table's first and last times belong to the spline (its slope there),
  !> without it to the held values (rate 0).  A blade angle table needs the former: a dynamic run
  !> starts at the first time, and clamp B's velocity there must be the one the spline takes just
  !> after it, or the start is inconsistent and IDA fails at t = 0.
  subroutine spline_eval(s, x, f, df, ddf, ends_on_spline)
    type(table_spline), intent(in) :: s       !< spline
    real(dp), intent(in) :: x                 !< abscissa
    real(dp), intent(out) :: f, df, ddf       !< value, first and second derivative
    logical, intent(in), optional :: ends_on_spline  !< the ends take the spline's rates
    real(c_double) :: y
    integer(c_int) :: flag
    logical :: held
    held = x <= s%x_first .or. x >= s%x_last
    if (present(ends_on_spline)) then
      if (ends_on_spline) held = x < s%x_first .or. x > s%x_last
    end if
    if (held) then
      f = merge(s%y_first, s%y_last, x <= s%x_first)
      df = 0.0_dp; ddf = 0.0_dp
      return
    end if
    flag = gsl_spline_eval_e(s%spline, real(x, c_double), s%accel, y); f = y
    flag = gsl_spline_eval_deriv_e(s%spline, real(x, c_double), s%accel, y); df = y
    flag = gsl_spline_eval_deriv2_e(s%spline, real(x, c_double), s%accel, y); ddf = y
  end subroutine spline_eval

  !> Integral of the held spline from the table start to x (x >= x_first).
  function spline_integral(s, x) result(area)
    type(table_spline), intent(in) :: s       !< spline
    real(dp), intent(in) :: x                 !< upper limit
    real(dp) :: area
    real(c_double) :: y
    integer(c_int) :: flag
    if (x <= s%x_first) then
      area = s%y_first*(x - s%x_first)
      return
    end if
    flag = gsl_spline_eval_integ_e(s%spline, real(s%x_first, c_double), real(min(x, s%x_last), c_double), &
                                   s%accel, y)
    area = y
    if (x > s%x_last) area = area + s%y_last*(x - s%x_last)
  end function spline_integral

  !> Release the GSL objects.
  subroutine spline_free(s)
    type(table_spline), intent(inout) :: s    !< spline
    if (c_associated(s%spline)) call gsl_spline_free(s%spline)
    if (c_associated(s%accel)) call gsl_interp_accel_free(s%accel)
    s%spline = c_null_ptr
    s%accel = c_null_ptr
  end subroutine spline_free

end module rotorcable_motion_table_spline
