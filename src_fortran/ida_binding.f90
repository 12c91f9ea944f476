!> Hand-written iso_c_binding interfaces to the SUNDIALS 6.4 C API used by rotorcable
!> (Debian's libsundials-dev ships no Fortran modules, so SUNDIALS's own fida_mod cannot be used).
!> sunindextype is int64_t, realtype double, booleantype int, "long int" is c_long.
!> The library linked is IDAS 5.4.1 (meson.build), which holds the IDA 6.4.1 API under the same
!> names and prototypes plus the forward-sensitivity functions (IDASens*) used by
!> rotorcable_monodromy.
module rotorcable_ida_binding
  use, intrinsic :: iso_c_binding, only: c_int, c_long, c_int64_t, c_double, c_ptr, c_funptr, c_char, &
                                         c_associated, c_f_pointer
  implicit none
  private
  public :: SUNContext_Create, SUNContext_Free, N_VNew_Serial, N_VDestroy, N_VGetArrayPointer, &
            SUNDenseMatrix, SUNMatDestroy, SUNLinSol_Dense, SUNLinSolFree, SUNLinSolNewEmpty, &
            SUNLinSolFreeEmpty, IDACreate, IDAInit, &
            IDASVtolerances, IDASetUserData, IDASetId, IDASetSuppressAlg, IDASetLinearSolver, &
            IDASetMaxNumSteps, IDASetMaxStep, IDASetStopTime, IDASolve, IDAReInit, IDAFree, &
            IDAGetNumSteps, IDAGetNumResEvals, IDAGetNumJacEvals, IDAGetNumLinResEvals, &
            IDAGetNumErrTestFails, IDAGetNumNonlinSolvConvFails, IDASetErrHandlerFn, IDA_NORMAL, &
            IDASetJacFn, SUNDenseMatrix_Data, IDAGetCurrentCj, IDAGetCurrentY, &
            IDAGetCurrentTime, IDASensInit, IDASensSVtolerances, IDASetSensErrCon, &
            IDAGetSens, IDASensFree, IDASensReInit, IDAGetSensNumResEvals, &
            IDA_STAGGERED, IDASetInitStep, IDASetNonlinearSolverSensStg, SUNNonlinSolNewEmpty, SUNNonlinSolFreeEmpty, &
            N_VClone, N_VScale, N_VLinearSum, N_VConst, &
            SUN_NLS_SUCCESS, SUN_NLS_CONTINUE, SUN_NLS_CONV_RECVR, SUN_NLS_MEM_NULL

  public :: sun_linear_solver, sun_linear_solver_ops, SUNLINEARSOLVER_DIRECT, SUNLINEARSOLVER_MATRIX_EMBEDDED, &
            SUNLS_SUCCESS, SUNLS_LUFACT_FAIL, SUNLS_PACKAGE_FAIL_REC
  public :: copy_solver_message

  !> Return values of a SUNNonlinearSolver and its convergence test (sundials_nonlinearsolver.h, 6.4).
  integer(c_int), parameter :: SUN_NLS_SUCCESS = 0, SUN_NLS_CONTINUE = 901, SUN_NLS_CONV_RECVR = 902, &
                               SUN_NLS_MEM_NULL = -901

  !> struct _generic_SUNLinearSolver (sundials_linearsolver.h, 6.4): a user-supplied linear
  !> solver is an empty solver whose content and operation pointers are filled in.
  type, bind(C) :: sun_linear_solver
    type(c_ptr) :: content
    type(c_ptr) :: ops
    type(c_ptr) :: sunctx
  end type sun_linear_solver

  !> struct _generic_SUNLinearSolver_Ops, members in the header's order.
  type, bind(C) :: sun_linear_solver_ops
    type(c_funptr) :: gettype, getid, setatimes, setpreconditioner, setscalingvectors, &
                      setzeroguess, initialize, setup, solve, numiters, resnorm, lastflag, &
                      space, resid, free
  end type sun_linear_solver_ops

  integer(c_int), parameter :: SUNLINEARSOLVER_DIRECT = 0  !< SUNLinearSolver_Type
  !> A solver that holds its own matrix (IDA passes none and calls no Jacobian function).
  integer(c_int), parameter :: SUNLINEARSOLVER_MATRIX_EMBEDDED = 3
  integer(c_int), parameter :: SUNLS_SUCCESS = 0
  integer(c_int), parameter :: SUNLS_LUFACT_FAIL = 808     !< positive: IDA retries (recoverable)
  integer(c_int), parameter :: SUNLS_PACKAGE_FAIL_REC = 806  !< recoverable failure of the solver's own work
  integer(c_int), parameter :: IDA_NORMAL = 1   !< itask of IDASolve: return at tout
  !> ism of IDASensInit: the sensitivity corrector after the state's (idas.h)
  integer(c_int), parameter :: IDA_STAGGERED = 2

  interface
    integer(c_int) function SUNContext_Create(comm, ctx) bind(C, name='SUNContext_Create')
      import :: c_int, c_ptr
      type(c_ptr), value :: comm
      type(c_ptr) :: ctx
    end function SUNContext_Create
    integer(c_int) function SUNContext_Free(ctx) bind(C, name='SUNContext_Free')
      import :: c_int, c_ptr
      type(c_ptr) :: ctx
    end function SUNContext_Free
    type(c_ptr) function N_VNew_Serial(n, ctx) bind(C, name='N_VNew_Serial')
      import :: c_ptr, c_int64_t
      integer(c_int64_t), value :: n
      type(c_ptr), value :: ctx
    end function N_VNew_Serial
    subroutine N_VDestroy(v) bind(C, name='N_VDestroy')
      import :: c_ptr
      type(c_ptr), value :: v
    end subroutine N_VDestroy
    type(c_ptr) function N_VGetArrayPointer(v) bind(C, name='N_VGetArrayPointer')
      import :: c_ptr
      type(c_ptr), value :: v
    end function N_VGetArrayPointer
    type(c_ptr) function SUNDenseMatrix(m, n, ctx) bind(C, name='SUNDenseMatrix')
      import :: c_ptr, c_int64_t
      integer(c_int64_t), value :: m, n
      type(c_ptr), value :: ctx
    end function SUNDenseMatrix
    subroutine SUNMatDestroy(a) bind(C, name='SUNMatDestroy')
      import :: c_ptr
      type(c_ptr), value :: a
    end subroutine SUNMatDestroy
    type(c_ptr) function SUNLinSol_Dense(y, a, ctx) bind(C, name='SUNLinSol_Dense')
      import :: c_ptr
      type(c_ptr), value :: y, a, ctx
    end function SUNLinSol_Dense
    integer(c_int) function SUNLinSolFree(ls) bind(C, name='SUNLinSolFree')
      import :: c_int, c_ptr
      type(c_ptr), value :: ls
    end function SUNLinSolFree
    type(c_ptr) function SUNLinSolNewEmpty(ctx) bind(C, name='SUNLinSolNewEmpty')
      import :: c_ptr
      type(c_ptr), value :: ctx
    end function SUNLinSolNewEmpty
    subroutine SUNLinSolFreeEmpty(ls) bind(C, name='SUNLinSolFreeEmpty')
      import :: c_ptr
      type(c_ptr), value :: ls
    end subroutine SUNLinSolFreeEmpty
    type(c_ptr) function IDACreate(ctx) bind(C, name='IDACreate')
      import :: c_ptr
      type(c_ptr), value :: ctx
    end function IDACreate
    integer(c_int) function IDAInit(mem, res, t0, yy0, yp0) bind(C, name='IDAInit')
      import :: c_int, c_ptr, c_funptr, c_double
      type(c_ptr), value :: mem
      type(c_funptr), value :: res
      real(c_double), value :: t0
      type(c_ptr), value :: yy0, yp0
    end function IDAInit
    integer(c_int) function IDAReInit(mem, t0, yy0, yp0) bind(C, name='IDAReInit')
      import :: c_int, c_ptr, c_double
      type(c_ptr), value :: mem
      real(c_double), value :: t0
      type(c_ptr), value :: yy0, yp0
    end function IDAReInit
    integer(c_int) function IDASVtolerances(mem, rtol, atol) bind(C, name='IDASVtolerances')
      import :: c_int, c_ptr, c_double
      type(c_ptr), value :: mem
      real(c_double), value :: rtol
      type(c_ptr), value :: atol
    end function IDASVtolerances
    integer(c_int) function IDASetUserData(mem, data) bind(C, name='IDASetUserData')
      import :: c_int, c_ptr
      type(c_ptr), value :: mem, data
    end function IDASetUserData
    integer(c_int) function IDASetId(mem, id) bind(C, name='IDASetId')
      import :: c_int, c_ptr
      type(c_ptr), value :: mem, id
    end function IDASetId
    integer(c_int) function IDASetSuppressAlg(mem, flag) bind(C, name='IDASetSuppressAlg')
      import :: c_int, c_ptr
      type(c_ptr), value :: mem
      integer(c_int), value :: flag
    end function IDASetSuppressAlg
    integer(c_int) function IDASetLinearSolver(mem, ls, a) bind(C, name='IDASetLinearSolver')
      import :: c_int, c_ptr
      type(c_ptr), value :: mem, ls, a
    end function IDASetLinearSolver
    integer(c_int) function IDASetMaxNumSteps(mem, mxsteps) bind(C, name='IDASetMaxNumSteps')
      import :: c_int, c_ptr, c_long
      type(c_ptr), value :: mem
      integer(c_long), value :: mxsteps
    end function IDASetMaxNumSteps
    integer(c_int) function IDASetMaxStep(mem, hmax) bind(C, name='IDASetMaxStep')
      import :: c_int, c_ptr, c_double
      type(c_ptr), value :: mem
      real(c_double), value :: hmax
    end function IDASetMaxStep
    integer(c_int) function IDASetStopTime(mem, tstop) bind(C, name='IDASetStopTime')
      import :: c_int, c_ptr, c_double
      type(c_ptr), value :: mem
      real(c_double), value :: tstop
    end function IDASetStopTime
    integer(c_int) function IDASolve(mem, tout, tret, yret, ypret, itask) bind(C, name='IDASolve')
      import :: c_int, c_ptr, c_double
      type(c_ptr), value :: mem
      real(c_double), value :: tout
      real(c_double) :: tret
      type(c_ptr), value :: yret, ypret
      integer(c_int), value :: itask
    end function IDASolve
    subroutine IDAFree(mem) bind(C, name='IDAFree')
      import :: c_ptr
      type(c_ptr) :: mem
    end subroutine IDAFree
    integer(c_int) function IDAGetNumSteps(mem, n) bind(C, name='IDAGetNumSteps')
      import :: c_int, c_ptr, c_long
      type(c_ptr), value :: mem
      integer(c_long) :: n
    end function IDAGetNumSteps
    integer(c_int) function IDAGetNumResEvals(mem, n) bind(C, name='IDAGetNumResEvals')
      import :: c_int, c_ptr, c_long
      type(c_ptr), value :: mem
      integer(c_long) :: n
    end function IDAGetNumResEvals
    integer(c_int) function IDAGetNumJacEvals(mem, n) bind(C, name='IDAGetNumJacEvals')
      import :: c_int, c_ptr, c_long
      type(c_ptr), value :: mem
      integer(c_long) :: n
    end function IDAGetNumJacEvals
    integer(c_int) function IDAGetNumLinResEvals(mem, n) bind(C, name='IDAGetNumLinResEvals')
      import :: c_int, c_ptr, c_long
      type(c_ptr), value :: mem
      integer(c_long) :: n
    end function IDAGetNumLinResEvals
    integer(c_int) function IDAGetNumErrTestFails(mem, n) bind(C, name='IDAGetNumErrTestFails')
      import :: c_int, c_ptr, c_long
      type(c_ptr), value :: mem
      integer(c_long) :: n
    end function IDAGetNumErrTestFails
    integer(c_int) function IDAGetNumNonlinSolvConvFails(mem, n) bind(C, name='IDAGetNumNonlinSolvConvFails')
      import :: c_int, c_ptr, c_long
      type(c_ptr), value :: mem
      integer(c_long) :: n
    end function IDAGetNumNonlinSolvConvFails
    integer(c_int) function IDASetErrHandlerFn(mem, ehfun, eh_data) bind(C, name='IDASetErrHandlerFn')
      import :: c_int, c_ptr, c_funptr
      type(c_ptr), value :: mem
      type(c_funptr), value :: ehfun
      type(c_ptr), value :: eh_data
    end function IDASetErrHandlerFn
    integer(c_int) function IDASetJacFn(mem, jac) bind(C, name='IDASetJacFn')
      import :: c_int, c_ptr, c_funptr
      type(c_ptr), value :: mem
      type(c_funptr), value :: jac
    end function IDASetJacFn
    type(c_ptr) function SUNDenseMatrix_Data(a) bind(C, name='SUNDenseMatrix_Data')
      import :: c_ptr
      type(c_ptr), value :: a
    end function SUNDenseMatrix_Data
    integer(c_int) function IDAGetCurrentCj(mem, cj) bind(C, name='IDAGetCurrentCj')
      import :: c_int, c_ptr, c_double
      type(c_ptr), value :: mem
      real(c_double) :: cj
    end function IDAGetCurrentCj
    integer(c_int) function IDAGetCurrentY(mem, ycur) bind(C, name='IDAGetCurrentY')
      import :: c_int, c_ptr
      type(c_ptr), value :: mem
      type(c_ptr) :: ycur
    end function IDAGetCurrentY
    integer(c_int) function IDAGetCurrentTime(mem, tcur) bind(C, name='IDAGetCurrentTime')
      import :: c_int, c_ptr, c_double
      type(c_ptr), value :: mem
      real(c_double) :: tcur
    end function IDAGetCurrentTime
    ! IDAS forward sensitivities (idas.h); N_Vector* arguments are c_loc of arrays of c_ptr.
    integer(c_int) function IDASensInit(mem, ns, ism, res_s, ys0, yps0) bind(C, name='IDASensInit')
      import :: c_int, c_ptr, c_funptr
      type(c_ptr), value :: mem
      integer(c_int), value :: ns, ism
      type(c_funptr), value :: res_s
      type(c_ptr), value :: ys0, yps0
    end function IDASensInit
    integer(c_int) function IDASensSVtolerances(mem, rtol, atol_s) bind(C, name='IDASensSVtolerances')
      import :: c_int, c_ptr, c_double
      type(c_ptr), value :: mem
      real(c_double), value :: rtol
      type(c_ptr), value :: atol_s
    end function IDASensSVtolerances
    integer(c_int) function IDASetSensErrCon(mem, errcon) bind(C, name='IDASetSensErrCon')
      import :: c_int, c_ptr
      type(c_ptr), value :: mem
      integer(c_int), value :: errcon
    end function IDASetSensErrCon
    integer(c_int) function IDAGetSens(mem, tret, ys) bind(C, name='IDAGetSens')
      import :: c_int, c_ptr, c_double
      type(c_ptr), value :: mem
      real(c_double) :: tret
      type(c_ptr), value :: ys
    end function IDAGetSens
    subroutine IDASensFree(mem) bind(C, name='IDASensFree')
      import :: c_ptr
      type(c_ptr), value :: mem
    end subroutine IDASensFree
    !> Restart the sensitivities' history (after IDAReInit at a discontinuity of the loads).
    integer(c_int) function IDASensReInit(mem, ism, ys0, yps0) bind(C, name='IDASensReInit')
      import :: c_int, c_ptr
      type(c_ptr), value :: mem
      integer(c_int), value :: ism
      type(c_ptr), value :: ys0, yps0
    end function IDASensReInit
    integer(c_int) function IDAGetSensNumResEvals(mem, n) bind(C, name='IDAGetSensNumResEvals')
      import :: c_int, c_ptr, c_long
      type(c_ptr), value :: mem
      integer(c_long) :: n
    end function IDAGetSensNumResEvals
    !> Replace the staggered sensitivity corrector's nonlinear solver (rotorcable_sensitivity_newton).
    integer(c_int) function IDASetNonlinearSolverSensStg(mem, nls) bind(C, name='IDASetNonlinearSolverSensStg')
      import :: c_int, c_ptr
      type(c_ptr), value :: mem, nls
    end function IDASetNonlinearSolverSensStg
    !> An empty SUNNonlinearSolver (content and operations filled in by the caller), and its free.
    type(c_ptr) function SUNNonlinSolNewEmpty(ctx) bind(C, name='SUNNonlinSolNewEmpty')
      import :: c_ptr
      type(c_ptr), value :: ctx
    end function SUNNonlinSolNewEmpty
    subroutine SUNNonlinSolFreeEmpty(nls) bind(C, name='SUNNonlinSolFreeEmpty')
      import :: c_ptr
      type(c_ptr), value :: nls
    end subroutine SUNNonlinSolFreeEmpty
    !> Generic N_Vector operations (any vector kind: the sensitivity wrappers too).
    type(c_ptr) function N_VClone(v) bind(C, name='N_VClone')
      import :: c_ptr
      type(c_ptr), value :: v
    end function N_VClone
    subroutine N_VScale(c, x, z) bind(C, name='N_VScale')
      import :: c_ptr, c_double
      real(c_double), value :: c
      type(c_ptr), value :: x, z
    end subroutine N_VScale
    subroutine N_VLinearSum(a, x, b, y, z) bind(C, name='N_VLinearSum')
      import :: c_ptr, c_double
      real(c_double), value :: a, b
      type(c_ptr), value :: x, y, z
    end subroutine N_VLinearSum
    subroutine N_VConst(c, z) bind(C, name='N_VConst')
      import :: c_ptr, c_double
      real(c_double), value :: c
      type(c_ptr), value :: z
    end subroutine N_VConst
    integer(c_int) function IDASetInitStep(mem, hin) bind(C, name='IDASetInitStep')
      import :: c_int, c_ptr, c_double
      type(c_ptr), value :: mem
      real(c_double), value :: hin
    end function IDASetInitStep
  end interface

contains

  !> An error handler's C message into a Fortran buffer (up to its NUL, blank-padded, cut at the
  !> buffer's length); code 0 (no error) leaves the buffer blank.  Shared by the error handlers
  !> of every IDA session (dae_integrator.f90, monodromy.f90), which keep the message for the
  !> Python exception instead of printing it.
  subroutine copy_solver_message(code, msg, text)
    integer(c_int), intent(in) :: code          !< the handler's error code
    type(c_ptr), intent(in) :: msg              !< char* message
    character(len=*), intent(out) :: text       !< the message
    character(kind=c_char), pointer :: chars(:)
    integer :: i
    text = ''
    if (code == 0 .or. .not. c_associated(msg)) return
    call c_f_pointer(msg, chars, [len(text)])
    do i = 1, len(text)
      if (chars(i) == achar(0)) exit
      text(i:i) = chars(i)
    end do
  end subroutine copy_solver_message

end module rotorcable_ida_binding
