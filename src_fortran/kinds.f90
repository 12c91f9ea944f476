!> Working precision of rotorcable, defined once, here: every module takes `dp` from this one and
!> writes its literals as `1.0_dp`; `c_double` and `c_int` appear only at the C and f2py boundaries.
module rotorcable_kinds
  use, intrinsic :: iso_fortran_env, only: dp => real64
  implicit none
  private
  public :: dp

end module rotorcable_kinds
