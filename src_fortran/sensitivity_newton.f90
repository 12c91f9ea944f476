!> The Newton iteration of IDAS's staggered corrector for forward sensitivities, with the linear
!> solves of all the columns at once (docs/model.md, "Design sensitivities of a flight",
!> corrector).
!>
!> IDAS corrects the np sensitivity columns of a step together: one residual of all columns
!> (the caller's sensitivity residual), then the solve with the state's iteration matrix column
!> by column (idas_nls_stg.c, idaNlsLSolveSensStg), then its convergence test on all columns.
!> Column by column, every solve reads all the factors again.  This is SUNDIALS's Newton
!> iteration (sunnonlinsol_newton.c, SUNNonlinSolSolve_Newton, 6.4) step for step, IDAS's
!> residual, setup and test as IDAS hands them over, with one change: the solve takes all the
!> columns at once through the block solver's matrix products (ggl_linear_solver,
!> block_solve_columns), and scales the correction by 2/(1 + cj/cj_matrix) where cj has moved
!> since the matrix, as IDA's matrix-based solves do (idas_ls.c, idaLsSolve).  Only with the
!> block solver; the others keep SUNDIALS's own iteration.
!>
!> Why hand-written: SUNDIALS's iteration calls the linear solve per vector, and a
!> SUNNonlinearSolver is the interface IDAS gives for replacing it (IDASetNonlinearSolverSensStg).
module rotorcable_sensitivity_newton
  use, intrinsic :: iso_c_binding, only: c_int, c_long, c_double, c_ptr, c_funptr, c_funloc, c_loc, &
                                         c_f_pointer, c_f_procpointer, c_associated, c_null_ptr, c_null_funptr
  use rotorcable_kinds, only: dp
  use rotorcable_ggl_linear_solver, only: ggl_block_solver, block_solve_columns
  use rotorcable_ida_binding, only: N_VGetArrayPointer, IDAGetCurrentCj, IDASetNonlinearSolverSensStg, &
                                    SUNNonlinSolNewEmpty, SUNNonlinSolFreeEmpty, N_VClone, N_VDestroy, N_VScale, &
                                    N_VLinearSum, N_VConst, SUN_NLS_SUCCESS, SUN_NLS_CONTINUE, SUN_NLS_CONV_RECVR, &
                                    SUN_NLS_MEM_NULL
  implicit none
  private
  public :: batched_newton, newton_attach, newton_free

  !> SUNDIALS's default iterations of the staggered corrector (IDAS sets them: MAXIT).
  integer, parameter :: DEFAULT_MAX_ITERS = 4
  !> SUNNonlinearSolver_Type SUNNONLINEARSOLVER_ROOTFIND.
  integer(c_int), parameter :: ROOTFIND = 0

  !> struct _generic_SUNNonlinearSolver and its ops (sundials_nonlinearsolver.h, 6.4).
  type, bind(C) :: sun_nonlinear_solver
    type(c_ptr) :: content, ops, sunctx
  end type sun_nonlinear_solver
  type, bind(C) :: sun_nonlinear_solver_ops
    type(c_funptr) :: gettype, initialize, setup, solve, free, setsysfn, setlsetupfn, setlsolvefn, setctestfn, &
                      setmaxiters, getnumiters, getcuriter, getnumconvfails
  end type sun_nonlinear_solver_ops
  !> struct _generic_N_Vector and struct _N_VectorContent_SensWrapper.
  type, bind(C) :: generic_vector
    type(c_ptr) :: content, ops, sunctx
  end type generic_vector
  type, bind(C) :: sens_wrapper_content
    type(c_ptr) :: vecs
    integer(c_int) :: nvecs, own_vecs
  end type sens_wrapper_content

  abstract interface
    integer(c_int) function sys_fn(ycor, f, mem) bind(C)
      import :: c_int, c_ptr
      type(c_ptr), value :: ycor, f, mem
    end function sys_fn
    integer(c_int) function lsetup_fn(jbad, jcur, mem) bind(C)
      import :: c_int, c_ptr
      integer(c_int), value :: jbad
      integer(c_int) :: jcur
      type(c_ptr), value :: mem
    end function lsetup_fn
    integer(c_int) function ctest_fn(nls, ycor, del, tol, ewt, data) bind(C)
      import :: c_int, c_ptr, c_double
      type(c_ptr), value :: nls, ycor, del
      real(c_double), value :: tol
      type(c_ptr), value :: ewt, data
    end function ctest_fn
  end interface

  !> The iteration's state: the SUNNonlinearSolver's content (it must stay in place).
  type :: batched_newton
    type(c_ptr) :: handle = c_null_ptr        !< the SUNNonlinearSolver
    type(c_ptr) :: mem = c_null_ptr           !< IDAS memory
    type(ggl_block_solver), pointer :: solver => null()  !< the iteration matrix's factors
    type(c_funptr) :: sys = c_null_funptr, lsetup = c_null_funptr, ctest = c_null_funptr
    type(c_ptr) :: ctest_data = c_null_ptr
    type(c_ptr) :: delta = c_null_ptr         !< the correction (a clone of IDAS's wrapper)
    integer :: max_iters = DEFAULT_MAX_ITERS
    integer(c_int) :: curiter = 0
    integer(c_long) :: niters = 0, nconvfails = 0
    logical :: jcur = .false.
    integer :: n = 0, np = 0                  !< unknowns, columns
    real(dp), allocatable :: columns(:, :)    !< (n, np) the right-hand sides, then the corrections
  end type batched_newton

contains

  !> Give IDAS's staggered corrector (after IDASensInit) this iteration.  Returns a negative
  !> SUNDIALS flag, or 0.
  integer(c_int) function newton_attach(self, mem, ctx, np, n, solver) result(flag)
    type(batched_newton), intent(inout), target :: self  !< iteration (kept in place)
    type(c_ptr), intent(in) :: mem, ctx       !< IDAS memory, SUNContext
    integer, intent(in) :: np, n              !< columns, unknowns
    type(ggl_block_solver), pointer, intent(in) :: solver  !< the block solver IDA uses
    type(sun_nonlinear_solver), pointer :: nls
    type(sun_nonlinear_solver_ops), pointer :: ops
    self%mem = mem; self%np = np; self%n = n; self%solver => solver
    allocate (self%columns(n, np))
    flag = -1
    self%handle = SUNNonlinSolNewEmpty(ctx)
    if (.not. c_associated(self%handle)) return
    call c_f_pointer(self%handle, nls)
    nls%content = c_loc(self)
    call c_f_pointer(nls%ops, ops)
    ops%gettype = c_funloc(newton_gettype)
    ops%solve = c_funloc(newton_solve)
    ops%setsysfn = c_funloc(newton_setsysfn)
    ops%setlsetupfn = c_funloc(newton_setlsetupfn)
    ops%setlsolvefn = c_funloc(newton_setlsolvefn)
    ops%setctestfn = c_funloc(newton_setctestfn)
    ops%setmaxiters = c_funloc(newton_setmaxiters)
    ops%getnumiters = c_funloc(newton_getnumiters)
    ops%getcuriter = c_funloc(newton_getcuriter)
    ops%getnumconvfails = c_funloc(newton_getnumconvfails)
    flag = IDASetNonlinearSolverSensStg(mem, self%handle)
  end function newton_attach

  !> Free the iteration (after IDAFree: IDAS does not own it).
  subroutine newton_free(self)
    type(batched_newton), intent(inout) :: self  !< iteration
    if (c_associated(self%delta)) call N_VDestroy(self%delta)
    self%delta = c_null_ptr
    if (c_associated(self%handle)) call SUNNonlinSolFreeEmpty(self%handle)
    self%handle = c_null_ptr
  end subroutine newton_free

  !> The iteration of the SUNNonlinearSolver handle.
  function content_of(nls) result(self)
    type(c_ptr), intent(in) :: nls
    type(batched_newton), pointer :: self
    type(sun_nonlinear_solver), pointer :: s
    call c_f_pointer(nls, s)
    call c_f_pointer(s%content, self)
  end function content_of

  !> SUNNonlinSolSolve: SunNonlinSolSolve_Newton's iteration (module doc); ycor starts at 0.
  integer(c_int) function newton_solve(nls, y0, ycor, w, tol, call_lsetup, mem) bind(C) result(flag)
    type(c_ptr), value :: nls, y0, ycor, w, mem   ! y0: the predictor, not needed (ycor is relative)
    real(c_double), value :: tol
    integer(c_int), value :: call_lsetup
    type(batched_newton), pointer :: self
    procedure(sys_fn), pointer :: sys
    procedure(lsetup_fn), pointer :: lsetup
    procedure(ctest_fn), pointer :: ctest
    logical :: setup
    integer(c_int) :: jbad, jcur
    self => content_of(nls)
    flag = SUN_NLS_MEM_NULL
    if (.not. (c_associated(self%sys) .and. c_associated(self%ctest))) return
    call c_f_procpointer(self%sys, sys)
    call c_f_procpointer(self%ctest, ctest)
    lsetup => null()
    if (c_associated(self%lsetup)) call c_f_procpointer(self%lsetup, lsetup)
    setup = call_lsetup /= 0
    if (setup .and. .not. associated(lsetup)) return
    if (.not. c_associated(self%delta)) self%delta = N_VClone(ycor)
    if (.not. c_associated(self%delta)) return
    jbad = 0
    self%niters = 0
    self%nconvfails = 0
    do                                        ! attempts, each with a setup if asked
      flag = sys(ycor, self%delta, mem)
      if (flag /= SUN_NLS_SUCCESS) exit
      if (setup) then
        jcur = 0
        flag = lsetup(jbad, jcur, mem)
        self%jcur = jcur /= 0
        if (flag /= SUN_NLS_SUCCESS) exit
      end if
      self%curiter = 0
      do                                      ! Newton iterations
        self%niters = self%niters + 1
        call N_VScale(-1.0_dp, self%delta, self%delta)
        flag = solve_columns(self)
        if (flag /= SUN_NLS_SUCCESS) exit
        call N_VLinearSum(1.0_dp, ycor, 1.0_dp, self%delta, ycor)
        flag = ctest(nls, ycor, self%delta, tol, w, self%ctest_data)
        if (flag == SUN_NLS_SUCCESS) then
          self%jcur = .false.
          return
        end if
        if (flag /= SUN_NLS_CONTINUE) exit
        self%curiter = self%curiter + 1
        if (self%curiter >= self%max_iters) then
          flag = SUN_NLS_CONV_RECVR
          exit
        end if
        flag = sys(ycor, self%delta, mem)
        if (flag /= SUN_NLS_SUCCESS) exit
      end do
      ! A recoverable failure with a matrix that is not current: again from a zero correction
      ! with a new matrix.
      if (flag > 0 .and. .not. self%jcur .and. associated(lsetup)) then
        self%nconvfails = self%nconvfails + 1
        setup = .true.
        jbad = 1
        call N_VConst(0.0_dp, ycor)
        cycle
      end if
      exit
    end do
    self%nconvfails = self%nconvfails + 1
  end function newton_solve

  !> delta <- M^-1 delta for every column at once, scaled as idaLsSolve does.  0, or
  !> SUN_NLS_CONV_RECVR on a non-finite correction (IDAS then cuts the step).
  integer(c_int) function solve_columns(self) result(flag)
    type(batched_newton), intent(inout) :: self
    real(c_double), pointer :: col(:)
    real(c_double) :: cj
    integer :: k
    flag = SUN_NLS_MEM_NULL
    if (IDAGetCurrentCj(self%mem, cj) /= 0) return
    do k = 1, self%np
      col => column(self%delta, k, self%n)
      self%columns(:, k) = col
    end do
    call block_solve_columns(self%solver, self%columns)
    if (cj /= self%solver%cj) self%columns = self%columns*(2.0_dp/(1.0_dp + cj/self%solver%cj))
    flag = SUN_NLS_CONV_RECVR
    if (.not. all(abs(self%columns) <= huge(1.0_dp))) return
    do k = 1, self%np
      col => column(self%delta, k, self%n)
      col = self%columns(:, k)
    end do
    flag = SUN_NLS_SUCCESS
  end function solve_columns

  !> Column k of a sensitivity wrapper vector.
  function column(wrapper, k, n) result(col)
    type(c_ptr), intent(in) :: wrapper
    integer, intent(in) :: k, n
    real(c_double), pointer :: col(:)
    type(generic_vector), pointer :: v
    type(sens_wrapper_content), pointer :: content
    type(c_ptr), pointer :: vecs(:)
    call c_f_pointer(wrapper, v)
    call c_f_pointer(v%content, content)
    call c_f_pointer(content%vecs, vecs, [k])
    call c_f_pointer(N_VGetArrayPointer(vecs(k)), col, [n])
  end function column

  integer(c_int) function newton_gettype(nls) bind(C)
    type(c_ptr), value :: nls
    newton_gettype = ROOTFIND
  end function newton_gettype

  integer(c_int) function newton_setsysfn(nls, fn) bind(C)
    type(c_ptr), value :: nls
    type(c_funptr), value :: fn
    type(batched_newton), pointer :: self
    self => content_of(nls)
    self%sys = fn
    newton_setsysfn = SUN_NLS_SUCCESS
  end function newton_setsysfn

  integer(c_int) function newton_setlsetupfn(nls, fn) bind(C)
    type(c_ptr), value :: nls
    type(c_funptr), value :: fn
    type(batched_newton), pointer :: self
    self => content_of(nls)
    self%lsetup = fn
    newton_setlsetupfn = SUN_NLS_SUCCESS
  end function newton_setlsetupfn

  !> IDAS's per-column solve is not used (solve_columns instead).
  integer(c_int) function newton_setlsolvefn(nls, fn) bind(C)
    type(c_ptr), value :: nls
    type(c_funptr), value :: fn
    newton_setlsolvefn = SUN_NLS_SUCCESS
  end function newton_setlsolvefn

  integer(c_int) function newton_setctestfn(nls, fn, data) bind(C)
    type(c_ptr), value :: nls
    type(c_funptr), value :: fn
    type(c_ptr), value :: data
    type(batched_newton), pointer :: self
    self => content_of(nls)
    self%ctest = fn
    self%ctest_data = data
    newton_setctestfn = SUN_NLS_SUCCESS
  end function newton_setctestfn

  integer(c_int) function newton_setmaxiters(nls, iters) bind(C)
    type(c_ptr), value :: nls
    integer(c_int), value :: iters
    type(batched_newton), pointer :: self
    self => content_of(nls)
    newton_setmaxiters = SUN_NLS_SUCCESS
    if (iters < 1) then
      newton_setmaxiters = -903              ! SUN_NLS_ILL_INPUT
      return
    end if
    self%max_iters = iters
  end function newton_setmaxiters

  integer(c_int) function newton_getnumiters(nls, iters) bind(C)
    type(c_ptr), value :: nls
    integer(c_long) :: iters
    type(batched_newton), pointer :: self
    self => content_of(nls)
    iters = self%niters
    newton_getnumiters = SUN_NLS_SUCCESS
  end function newton_getnumiters

  integer(c_int) function newton_getcuriter(nls, iter) bind(C)
    type(c_ptr), value :: nls
    integer(c_int) :: iter
    type(batched_newton), pointer :: self
    self => content_of(nls)
    iter = self%curiter
    newton_getcuriter = SUN_NLS_SUCCESS
  end function newton_getcuriter

  integer(c_int) function newton_getnumconvfails(nls, fails) bind(C)
    type(c_ptr), value :: nls
    integer(c_long) :: fails
    type(batched_newton), pointer :: self
    self => content_of(nls)
    fails = self%nconvfails
    newton_getnumconvfails = SUN_NLS_SUCCESS
  end function newton_getnumconvfails

end module rotorcable_sensitivity_newton
