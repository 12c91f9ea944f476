!> Floating-point exception halting switched off around LAPACK calls.
!>
!> The debug test suite runs the core with traps on invalid operations, division by zero and
!> overflow (.ci/tests), and LAPACK computes infinities and NaNs on purpose (IEEECK probes the
!> arithmetic from DGESVD, DSYGV, ...).  fpe_pause/fpe_resume hold the halting modes off for
!> such a call and restore them after, with the standard IEEE module (Fortran 2003).  In a
!> release run no halting is on and the pair only reads the modes.
module rotorcable_fpe_guard
  use, intrinsic :: ieee_exceptions, only: ieee_get_halting_mode, ieee_set_halting_mode, ieee_usual, &
                                           ieee_set_flag
  implicit none
  private
  public :: fpe_pause, fpe_resume

contains

  !> Remember the halting modes and switch them off.
  subroutine fpe_pause(saved)
    logical, intent(out) :: saved(3)          !< halting of invalid, divide-by-zero, overflow
    call ieee_get_halting_mode(ieee_usual, saved)
    if (any(saved)) call ieee_set_halting_mode(ieee_usual, .false.)
  end subroutine fpe_pause

  !> Clear the flags LAPACK raised on purpose and restore the halting modes.
  subroutine fpe_resume(saved)
    logical, intent(in) :: saved(3)           !< as returned by fpe_pause
    if (.not. any(saved)) return
    call ieee_set_flag(ieee_usual, .false.)
    call ieee_set_halting_mode(ieee_usual, saved)
  end subroutine fpe_resume

end module rotorcable_fpe_guard
