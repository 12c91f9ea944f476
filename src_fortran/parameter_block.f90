!> A component's parameters by name: what a load or support factory reads its values from, so
!> that a flat layout is never written twice by position (issue 23).  Python declares each
!> component's parameters once (pydriver/components.py) and sends them as named arrays; a
!> constructor asks for each by name and size, and a name it does not find, or a size that does
!> not fit, comes back through the error channel naming the component and the parameter.
!>
!> Across f2py the block travels flat (api.f90): the real arrays' names in one blank-separated
!> string, their sizes, and their values one after the other; the same for the integer arrays.
!> pydriver/core.py (`_parameter_arrays`) is the one place that builds that layout.  A word (a
!> choice such as the linear solver 'chain') travels as the integer array of its character
!> codes, so a block needs no character arrays across f2py; `get_word` reads it back.
module rotorcable_parameter_block
  use rotorcable_kinds, only: dp
  use rotorcable_errors, only: error_type, fatal_error
  implicit none
  private
  public :: parameter_block, block_from_flat, has_parameter, parameter_size, get_real, get_reals, get_int, get_ints, &
            get_word

  integer, parameter :: NAME_LEN = 32

  !> Named real arrays and named integer arrays of one component.
  type :: parameter_block
    character(len=:), allocatable :: owner        !< the component, for messages ('drag', 'clamp')
    character(len=NAME_LEN), allocatable :: real_names(:)  !< name of each real array
    integer, allocatable :: real_first(:)         !< (nr+1) where each starts in reals; last = end + 1
    real(dp), allocatable :: reals(:)             !< the real values, array after array
    character(len=NAME_LEN), allocatable :: int_names(:)   !< name of each integer array
    integer, allocatable :: int_first(:)          !< (ni+1) where each starts in ints
    integer, allocatable :: ints(:)               !< the integer values
  end type parameter_block

contains

  !> Build the block of `owner` from the flat layout (names blank-separated, sizes, values).
  subroutine block_from_flat(owner, real_names, real_sizes, reals, int_names, int_sizes, ints, block, error)
    character(len=*), intent(in) :: owner         !< component kind
    character(len=*), intent(in) :: real_names    !< names of the real arrays, blank-separated
    integer, intent(in) :: real_sizes(:)          !< size of each real array
    real(dp), intent(in) :: reals(:)              !< their values, one after the other
    character(len=*), intent(in) :: int_names     !< names of the integer arrays
    integer, intent(in) :: int_sizes(:)           !< size of each integer array
    integer, intent(in) :: ints(:)                !< their values
    type(parameter_block), intent(out) :: block   !< the block
    type(error_type), intent(inout) :: error      !< status (a layout whose parts disagree)
    block%owner = owner
    call split_names(real_names, block%real_names)
    call split_names(int_names, block%int_names)
    if (size(block%real_names) /= size(real_sizes) .or. size(block%int_names) /= size(int_sizes) &
        .or. sum(real_sizes) /= size(reals) .or. sum(int_sizes) /= size(ints) &
        .or. any(real_sizes < 0) .or. any(int_sizes < 0)) then
      call fatal_error(error, owner//': parameter names, sizes and values do not agree')
      return
    end if
    block%real_first = offsets(real_sizes)
    block%int_first = offsets(int_sizes)
    block%reals = reals
    block%ints = ints
  end subroutine block_from_flat

  !> Whether the block has a real or integer array called `name`.
  pure logical function has_parameter(block, name)
    type(parameter_block), intent(in) :: block    !< the block
    character(len=*), intent(in) :: name          !< parameter name
    has_parameter = findloc_name(block%real_names, name) > 0 .or. findloc_name(block%int_names, name) > 0
  end function has_parameter

  !> The number of values of parameter `name` (real or integer), -1 if the block has none: for
  !> a parameter whose length the constructor cannot know (a motion description).
  pure integer function parameter_size(block, name) result(n)
    type(parameter_block), intent(in) :: block    !< the block
    character(len=*), intent(in) :: name          !< parameter name
    integer :: i
    n = -1
    i = findloc_name(block%real_names, name)
    if (i > 0) n = block%real_first(i + 1) - block%real_first(i)
    i = findloc_name(block%int_names, name)
    if (i > 0) n = block%int_first(i + 1) - block%int_first(i)
  end function parameter_size

  !> The scalar real parameter `name`.
  subroutine get_real(block, name, value, error)
    type(parameter_block), intent(in) :: block    !< the block
    character(len=*), intent(in) :: name          !< parameter name
    real(dp), intent(out) :: value                !< its value
    type(error_type), intent(inout) :: error      !< status: missing, or not one value
    real(dp) :: values(1)
    value = 0.0_dp
    call get_reals(block, name, values, error)
    if (error%code == 0) value = values(1)
  end subroutine get_real

  !> The real array `name`, which must have exactly size(values) elements.
  subroutine get_reals(block, name, values, error)
    type(parameter_block), intent(in) :: block    !< the block
    character(len=*), intent(in) :: name          !< parameter name
    real(dp), intent(out) :: values(:)            !< its values (the size the caller expects)
    type(error_type), intent(inout) :: error      !< status: missing, or of another size
    integer :: first, last
    values = 0.0_dp
    call locate(block, block%real_names, block%real_first, name, first, last, error)
    if (error%code /= 0) return
    if (last - first + 1 /= size(values)) then
      call wrong_size(block, name, last - first + 1, size(values), error)
      return
    end if
    values = block%reals(first:last)
  end subroutine get_reals

  !> The scalar integer parameter `name`.
  subroutine get_int(block, name, value, error)
    type(parameter_block), intent(in) :: block    !< the block
    character(len=*), intent(in) :: name          !< parameter name
    integer, intent(out) :: value                 !< its value
    type(error_type), intent(inout) :: error      !< status
    integer :: values(1)
    value = 0
    call get_ints(block, name, values, error)
    if (error%code == 0) value = values(1)
  end subroutine get_int

  !> The integer array `name`, which must have exactly size(values) elements.
  subroutine get_ints(block, name, values, error)
    type(parameter_block), intent(in) :: block    !< the block
    character(len=*), intent(in) :: name          !< parameter name
    integer, intent(out) :: values(:)             !< its values
    type(error_type), intent(inout) :: error      !< status
    integer :: first, last
    values = 0
    call locate(block, block%int_names, block%int_first, name, first, last, error)
    if (error%code /= 0) return
    if (last - first + 1 /= size(values)) then
      call wrong_size(block, name, last - first + 1, size(values), error)
      return
    end if
    values = block%ints(first:last)
  end subroutine get_ints

  !> The word `name` (sent as its character codes, pydriver/core.py `_parameter_arrays`).
  subroutine get_word(block, name, value, error)
    type(parameter_block), intent(in) :: block    !< the block
    character(len=*), intent(in) :: name          !< parameter name
    character(len=:), allocatable, intent(out) :: value  !< the word ('' if missing)
    type(error_type), intent(inout) :: error      !< status: missing, or not character codes
    integer :: first, last, k
    value = ''
    call locate(block, block%int_names, block%int_first, name, first, last, error)
    if (error%code /= 0) return
    if (any(block%ints(first:last) < 32) .or. any(block%ints(first:last) > 126)) then
      call fatal_error(error, block%owner//': parameter '''//name//''' is not a word (printable character codes)')
      return
    end if
    value = repeat(' ', last - first + 1)
    do k = first, last
      value(k - first + 1:k - first + 1) = achar(block%ints(k))
    end do
  end subroutine get_word

  !> Where the array `name` of one kind (the names and starts of the reals or of the integers)
  !> lies in its values: first, last; a missing name is the error.
  subroutine locate(block, names, starts, name, first, last, error)
    type(parameter_block), intent(in) :: block    !< the block (for the message)
    character(len=NAME_LEN), intent(in) :: names(:)  !< the kind's names
    integer, intent(in) :: starts(:)              !< the kind's starts, last = end + 1
    character(len=*), intent(in) :: name          !< parameter name
    integer, intent(out) :: first, last           !< its range in the kind's values
    type(error_type), intent(inout) :: error      !< status: missing
    integer :: i
    first = 1; last = 0
    i = findloc_name(names, name)
    if (i == 0) then
      call missing(block, name, error)
      return
    end if
    first = starts(i)
    last = starts(i + 1) - 1
  end subroutine locate

  pure integer function findloc_name(names, name) result(i)
    character(len=NAME_LEN), intent(in) :: names(:)
    character(len=*), intent(in) :: name
    do i = 1, size(names)
      if (names(i) == name) return
    end do
    i = 0
  end function findloc_name

  pure function offsets(sizes) result(first)
    integer, intent(in) :: sizes(:)
    integer :: first(size(sizes) + 1), i
    first(1) = 1
    do i = 1, size(sizes)
      first(i + 1) = first(i) + sizes(i)
    end do
  end function offsets

  !> The blank-separated words of `text` (an empty or blank text has none).
  subroutine split_names(text, names)
    character(len=*), intent(in) :: text
    character(len=NAME_LEN), allocatable, intent(out) :: names(:)
    integer :: i, n, start
    character(len=NAME_LEN) :: found(len(text))
    n = 0
    i = 1
    do while (i <= len(text))
      if (text(i:i) == ' ') then
        i = i + 1
        cycle
      end if
      start = i
      do while (i <= len(text))
        if (text(i:i) == ' ') exit
        i = i + 1
      end do
      n = n + 1
      found(n) = text(start:i - 1)
    end do
    names = found(1:n)
  end subroutine split_names

  subroutine missing(block, name, error)
    type(parameter_block), intent(in) :: block
    character(len=*), intent(in) :: name
    type(error_type), intent(inout) :: error
    call fatal_error(error, block%owner//': no parameter '''//name//''' (pydriver/components.py declares it)')
  end subroutine missing

  subroutine wrong_size(block, name, given, expected, error)
    type(parameter_block), intent(in) :: block
    character(len=*), intent(in) :: name
    integer, intent(in) :: given, expected
    type(error_type), intent(inout) :: error
    character(len=160) :: buf
    write (buf, '(a, i0, a, i0)') ''' has ', given, ' values, expected ', expected
    call fatal_error(error, block%owner//': parameter '''//name//trim(buf))
  end subroutine wrong_size

end module rotorcable_parameter_block
