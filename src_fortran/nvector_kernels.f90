!> Compiled replacements for the serial N_Vector kernels that IDA calls at every step.
!>
!> Why this exists: Debian's libsundials 6.4.1 is built without optimisation (its
!> N_VLinearSum_Serial, N_VWSqrSumMaskLocal_Serial, ... keep loop counters on the stack; see
!> `objdump -d libsundials_ida.so.6`), and on the UH-60 decay case these vector loops took a
!> quarter of the integration time.  SUNDIALS lets a program supply its own vector operations
!> (the N_Vector ops table, sundials_nvector.h): use_fast_kernels overwrites the table of a
!> serial vector, and every vector IDA clones from it copies the table.  Each kernel is the
!> one-line loop of nvector_serial.c; the data layout (_N_VectorContent_Serial) is unchanged.
!> Element-wise loops read every operand before writing the result, so a result vector may
!> alias an operand, as SUNDIALS allows.
module rotorcable_nvector_kernels
  use, intrinsic :: iso_c_binding, only: c_int, c_int64_t, c_double, c_ptr, c_funptr, c_funloc, &
                                         c_f_pointer
  implicit none
  private
  public :: use_fast_kernels

  !> struct _generic_N_Vector.
  type, bind(C) :: n_vector_struct
    type(c_ptr) :: content
    type(c_ptr) :: ops
    type(c_ptr) :: sunctx
  end type n_vector_struct

  !> struct _N_VectorContent_Serial.
  type, bind(C) :: serial_content
    integer(c_int64_t) :: length
    integer(c_int) :: own_data
    type(c_ptr) :: data
  end type serial_content

  !> struct _generic_N_Vector_Ops of SUNDIALS 6.4, members in the header's order.
  type, bind(C) :: n_vector_ops
    type(c_funptr) :: getvectorid, clone, cloneempty, destroy, space, getarraypointer, &
                      getdevicearraypointer, setarraypointer, getcommunicator, getlength, &
                      linearsum, const, prod, div, scale, abs, inv, addconst, dotprod, maxnorm, &
                      wrmsnorm, wrmsnormmask, min, wl2norm, l1norm, compare, invtest, constrmask, &
                      minquotient, linearcombination, scaleaddmulti, dotprodmulti, &
                      linearsumvectorarray, scalevectorarray, constvectorarray, &
                      wrmsnormvectorarray, wrmsnormmaskvectorarray, scaleaddmultivectorarray, &
                      linearcombinationvectorarray, dotprodlocal, maxnormlocal, minlocal, &
                      l1normlocal, invtestlocal, constrmasklocal, minquotientlocal, wsqrsumlocal, &
                      wsqrsummasklocal, dotprodmultilocal, dotprodmultiallreduce, bufsize, &
                      bufpack, bufunpack, print, printfile, getlocallength
  end type n_vector_ops

contains

  !> Point the vector's operations table at the compiled kernels below.  Call it on the
  !> N_VNew_Serial vectors before they reach IDA (IDAInit clones its work vectors from them).
  subroutine use_fast_kernels(v)
    type(c_ptr), intent(in) :: v              !< serial N_Vector
    type(n_vector_struct), pointer :: nv
    type(n_vector_ops), pointer :: ops
    call c_f_pointer(v, nv)
    call c_f_pointer(nv%ops, ops)
    ops%linearsum = c_funloc(nv_linear_sum)
    ops%const = c_funloc(nv_const)
    ops%prod = c_funloc(nv_prod)
    ops%div = c_funloc(nv_div)
    ops%scale = c_funloc(nv_scale)
    ops%abs = c_funloc(nv_abs)
    ops%inv = c_funloc(nv_inv)
    ops%addconst = c_funloc(nv_add_const)
    ops%dotprod = c_funloc(nv_dot_prod)
    ops%dotprodlocal = c_funloc(nv_dot_prod)
    ops%maxnorm = c_funloc(nv_max_norm)
    ops%maxnormlocal = c_funloc(nv_max_norm)
    ops%wrmsnorm = c_funloc(nv_wrms_norm)
    ops%wrmsnormmask = c_funloc(nv_wrms_norm_mask)
    ops%wsqrsumlocal = c_funloc(nv_wsqr_sum)
    ops%wsqrsummasklocal = c_funloc(nv_wsqr_sum_mask)
    ops%min = c_funloc(nv_min)
    ops%minlocal = c_funloc(nv_min)
    ops%linearcombination = c_funloc(nv_linear_combination)
    ops%scaleaddmulti = c_funloc(nv_scale_add_multi)
    ops%linearsumvectorarray = c_funloc(nv_linear_sum_array)
    ops%scalevectorarray = c_funloc(nv_scale_array)
  end subroutine use_fast_kernels

  !> The data array of a serial vector.
  function values(v) result(a)
    type(c_ptr), intent(in) :: v
    real(c_double), pointer :: a(:)
    type(n_vector_struct), pointer :: nv
    type(serial_content), pointer :: content
    call c_f_pointer(v, nv)
    call c_f_pointer(nv%content, content)
    call c_f_pointer(content%data, a, [content%length])
  end function values

  !> z = a x + b y
  subroutine nv_linear_sum(a, x, b, y, z) bind(C)
    real(c_double), value :: a, b
    type(c_ptr), value :: x, y, z
    real(c_double), pointer :: xa(:), ya(:), za(:)
    integer :: i
    xa => values(x); ya => values(y); za => values(z)
    do i = 1, size(za)
      za(i) = a*xa(i) + b*ya(i)
    end do
  end subroutine nv_linear_sum

  !> z = c
  subroutine nv_const(c, z) bind(C)
    real(c_double), value :: c
    type(c_ptr), value :: z
    real(c_double), pointer :: za(:)
    integer :: i
    za => values(z)
    do i = 1, size(za)
      za(i) = c
    end do
  end subroutine nv_const

  !> z = x .* y
  subroutine nv_prod(x, y, z) bind(C)
    type(c_ptr), value :: x, y, z
    real(c_double), pointer :: xa(:), ya(:), za(:)
    integer :: i
    xa => values(x); ya => values(y); za => values(z)
    do i = 1, size(za)
      za(i) = xa(i)*ya(i)
    end do
  end subroutine nv_prod

  !> z = x ./ y
  subroutine nv_div(x, y, z) bind(C)
    type(c_ptr), value :: x, y, z
    real(c_double), pointer :: xa(:), ya(:), za(:)
    integer :: i
    xa => values(x); ya => values(y); za => values(z)
    do i = 1, size(za)
      za(i) = xa(i)/ya(i)
    end do
  end subroutine nv_div

  !> z = c x
  subroutine nv_scale(c, x, z) bind(C)
    real(c_double), value :: c
    type(c_ptr), value :: x, z
    real(c_double), pointer :: xa(:), za(:)
    integer :: i
    xa => values(x); za => values(z)
    do i = 1, size(za)
      za(i) = c*xa(i)
    end do
  end subroutine nv_scale

  !> z = |x|
  subroutine nv_abs(x, z) bind(C)
    type(c_ptr), value :: x, z
    real(c_double), pointer :: xa(:), za(:)
    integer :: i
    xa => values(x); za => values(z)
    do i = 1, size(za)
      za(i) = abs(xa(i))
    end do
  end subroutine nv_abs

  !> z = 1 ./ x
  subroutine nv_inv(x, z) bind(C)
    type(c_ptr), value :: x, z
    real(c_double), pointer :: xa(:), za(:)
    integer :: i
    xa => values(x); za => values(z)
    do i = 1, size(za)
      za(i) = 1.0_c_double/xa(i)
    end do
  end subroutine nv_inv

  !> z = x + b
  subroutine nv_add_const(x, b, z) bind(C)
    type(c_ptr), value :: x, z
    real(c_double), value :: b
    real(c_double), pointer :: xa(:), za(:)
    integer :: i
    xa => values(x); za => values(z)
    do i = 1, size(za)
      za(i) = xa(i) + b
    end do
  end subroutine nv_add_const

  !> x . y
  real(c_double) function nv_dot_prod(x, y) bind(C)
    type(c_ptr), value :: x, y
    nv_dot_prod = dot_product(values(x), values(y))
  end function nv_dot_prod

  !> max |x|
  real(c_double) function nv_max_norm(x) bind(C)
    type(c_ptr), value :: x
    nv_max_norm = maxval(abs(values(x)))
  end function nv_max_norm

  !> min x
  real(c_double) function nv_min(x) bind(C)
    type(c_ptr), value :: x
    nv_min = minval(values(x))
  end function nv_min

  !> sum (x w)^2
  real(c_double) function nv_wsqr_sum(x, w) bind(C)
    type(c_ptr), value :: x, w
    real(c_double), pointer :: xa(:), wa(:)
    xa => values(x); wa => values(w)
    nv_wsqr_sum = sum((xa*wa)**2)
  end function nv_wsqr_sum

  !> sum over id > 0 of (x w)^2
  real(c_double) function nv_wsqr_sum_mask(x, w, id) bind(C)
    type(c_ptr), value :: x, w, id
    real(c_double), pointer :: xa(:), wa(:), ida(:)
    xa => values(x); wa => values(w); ida => values(id)
    nv_wsqr_sum_mask = sum((xa*wa)**2, mask=ida > 0.0_c_double)
  end function nv_wsqr_sum_mask

  !> sqrt(sum (x w)^2 / n)
  real(c_double) function nv_wrms_norm(x, w) bind(C)
    type(c_ptr), value :: x, w
    nv_wrms_norm = sqrt(nv_wsqr_sum(x, w)/size(values(x)))
  end function nv_wrms_norm

  !> sqrt(sum over id > 0 of (x w)^2 / n), n counting every entry as nvector_serial does
  real(c_double) function nv_wrms_norm_mask(x, w, id) bind(C)
    type(c_ptr), value :: x, w, id
    nv_wrms_norm_mask = sqrt(nv_wsqr_sum_mask(x, w, id)/size(values(x)))
  end function nv_wrms_norm_mask

  !> z = sum_i c(i) X(i); z may be X(1) (not a later X(i)), as in nvector_serial.c.
  integer(c_int) function nv_linear_combination(nvec, c, xs, z) bind(C)
    integer(c_int), value :: nvec
    real(c_double), intent(in) :: c(nvec)
    type(c_ptr), intent(in) :: xs(nvec)
    type(c_ptr), value :: z
    real(c_double), pointer :: za(:), xa(:)
    integer :: i, j
    za => values(z)
    xa => values(xs(1))
    do j = 1, size(za)
      za(j) = c(1)*xa(j)
    end do
    do i = 2, nvec
      xa => values(xs(i))
      do j = 1, size(za)
        za(j) = za(j) + c(i)*xa(j)
      end do
    end do
    nv_linear_combination = 0
  end function nv_linear_combination

  !> Z(i) = a(i) x + Y(i), i = 1..nvec
  integer(c_int) function nv_scale_add_multi(nvec, a, x, ys, zs) bind(C)
    integer(c_int), value :: nvec
    real(c_double), intent(in) :: a(nvec)
    type(c_ptr), value :: x
    type(c_ptr), intent(in) :: ys(nvec), zs(nvec)
    real(c_double), pointer :: xa(:), ya(:), za(:)
    integer :: i, j
    xa => values(x)
    do i = 1, nvec
      ya => values(ys(i)); za => values(zs(i))
      do j = 1, size(za)
        za(j) = a(i)*xa(j) + ya(j)
      end do
    end do
    nv_scale_add_multi = 0
  end function nv_scale_add_multi

  !> Z(i) = a X(i) + b Y(i), i = 1..nvec
  integer(c_int) function nv_linear_sum_array(nvec, a, xs, b, ys, zs) bind(C)
    integer(c_int), value :: nvec
    real(c_double), value :: a, b
    type(c_ptr), intent(in) :: xs(nvec), ys(nvec), zs(nvec)
    integer :: i
    do i = 1, nvec
      call nv_linear_sum(a, xs(i), b, ys(i), zs(i))
    end do
    nv_linear_sum_array = 0
  end function nv_linear_sum_array

  !> Z(i) = c(i) X(i), i = 1..nvec
  integer(c_int) function nv_scale_array(nvec, c, xs, zs) bind(C)
    integer(c_int), value :: nvec
    real(c_double), intent(in) :: c(nvec)
    type(c_ptr), intent(in) :: xs(nvec), zs(nvec)
    integer :: i
    do i = 1, nvec
      call nv_scale(c(i), xs(i), zs(i))
    end do
    nv_scale_array = 0
  end function nv_scale_array

end module rotorcable_nvector_kernels
