!> Working precision of rotorcable, defined once (STYLE.md rule 1).
module rotorcable_kinds
  use, intrinsic :: iso_fortran_env, only: dp => real64
  implicit none
  private
  public :: dp

end module rotorcable_kinds
