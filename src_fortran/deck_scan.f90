!> Pre-scan of a namelist deck that names the offending group and key.
!>
!> gfortran's own namelist errors are terse and sometimes misleading (a non-numeric
!> value "length = abc" is reported as "Cannot match namelist object name abc"), so
!> before the real namelist read every group is tokenised here: unknown groups, unknown
!> keys and values that do not parse as the key's type are reported with the group, the
!> key and the reason.  Hand-written because no library parses Fortran namelists from
!> Fortran; it only checks, the values themselves come from the namelist read.
module rotorcable_deck_scan
  use rotorcable_kinds, only: dp
  implicit none
  private
  public :: key_spec, scan_deck, scan_failure

  !> One allowed key: name and type ('r' real, 'i' integer, 'l' logical, 'c' character).
  type :: key_spec
    character(len=32) :: group = ''
    character(len=32) :: name = ''
    character(len=1) :: kind = 'r'
  end type key_spec

  !> Where a scan failed.
  type :: scan_failure
    logical :: failed = .false.
    character(len=64) :: group = ''
    character(len=64) :: key = ''
    character(len=:), allocatable :: reason
  end type scan_failure

contains

  pure function lower(s) result(t)
    character(len=*), intent(in) :: s
    character(len=len(s)) :: t
    integer :: i
    t = s
    do i = 1, len(s)
      if (s(i:i) >= 'A' .and. s(i:i) <= 'Z') t(i:i) = achar(iachar(s(i:i)) + 32)
    end do
  end function lower

  pure logical function is_name_char(c)
    character, intent(in) :: c
    is_name_char = (c >= 'a' .and. c <= 'z') .or. (c >= '0' .and. c <= '9') .or. c == '_' .or. &
                   (c >= 'A' .and. c <= 'Z')
  end function is_name_char

  !> Read the whole deck into one string, comments ('!' outside quotes) removed.
  subroutine read_text(path, text, ios, iomsg)
    character(len=*), intent(in) :: path
    character(len=:), allocatable, intent(out) :: text
    integer, intent(out) :: ios
    character(len=*), intent(inout) :: iomsg
    character(len=4096) :: line
    integer :: u, i
    character :: quote
    text = ''
    open (newunit=u, file=path, status='old', action='read', iostat=ios, iomsg=iomsg)
    if (ios /= 0) return
    do
      read (u, '(a)', iostat=ios) line
      if (ios /= 0) exit
      quote = ' '
      do i = 1, len_trim(line)
        if (quote /= ' ') then
          if (line(i:i) == quote) quote = ' '
        else if (line(i:i) == '"' .or. line(i:i) == "'") then
          quote = line(i:i)
        else if (line(i:i) == '!') then
          line(i:) = ' '
          exit
        end if
      end do
      text = text//' '//trim(line)
    end do
    close (u)
    ios = 0
  end subroutine read_text

  !> Scan all groups of the deck against the allowed keys.
  subroutine scan_deck(path, specs, fail)
    character(len=*), intent(in) :: path          !< deck file
    type(key_spec), intent(in) :: specs(:)        !< allowed groups and keys
    type(scan_failure), intent(out) :: fail       !< first problem found
    character(len=:), allocatable :: text
    character(len=256) :: iomsg
    integer :: ios, i, n, start, gend
    character(len=64) :: group
    character :: quote

    iomsg = ''
    call read_text(path, text, ios, iomsg)
    if (ios /= 0) then
      fail%failed = .true.
      fail%reason = 'cannot open deck: '//trim(iomsg)
      return
    end if
    n = len(text)
    i = 1
    do while (i <= n)
      if (text(i:i) /= '&' .and. text(i:i) /= '$') then
        i = i + 1
        cycle
      end if
      start = i + 1
      i = start
      do while (i <= n)
        if (.not. is_name_char(text(i:i))) exit
        i = i + 1
      end do
      group = lower(text(start:i - 1))
      if (group == 'end') cycle
      if (.not. any(specs%group == group)) then
        fail%failed = .true.
        fail%group = group
        fail%reason = 'unknown group &'//trim(group)
        return
      end if
      ! The group ends at the first '/' (or '&end') outside quotes.
      quote = ' '
      gend = i
      do while (gend <= n)
        if (quote /= ' ') then
          if (text(gend:gend) == quote) quote = ' '
        else if (text(gend:gend) == '"' .or. text(gend:gend) == "'") then
          quote = text(gend:gend)
        else if (text(gend:gend) == '/' .or. text(gend:gend) == '&' .or. text(gend:gend) == '$') then
          exit
        end if
        gend = gend + 1
      end do
      call scan_group(text(i:gend - 1), group, specs, fail)
      if (fail%failed) return
      i = gend + 1
    end do
  end subroutine scan_deck

  !> Split "key = value, key(2) = value ..." and check every key and value.
  subroutine scan_group(body, group, specs, fail)
    character(len=*), intent(in) :: body
    character(len=*), intent(in) :: group
    type(key_spec), intent(in) :: specs(:)
    type(scan_failure), intent(inout) :: fail
    integer :: i, n, eq_pos(200), key_start(200), n_keys, k, j, p, value_end
    character :: quote
    character(len=64) :: key

    n = len(body)
    n_keys = 0
    quote = ' '
    do i = 1, n
      if (quote /= ' ') then
        if (body(i:i) == quote) quote = ' '
        cycle
      end if
      if (body(i:i) == '"' .or. body(i:i) == "'") then
        quote = body(i:i)
      else if (body(i:i) == '=') then
        ! Walk back over an optional "(index)" and the name.
        p = i - 1
        do while (p >= 1)
          if (body(p:p) /= ' ') exit
          p = p - 1
        end do
        if (p >= 1) then
          if (body(p:p) == ')') then
            do while (p >= 1)
              if (body(p:p) == '(') exit
              p = p - 1
            end do
            p = p - 1
          end if
        end if
        j = p
        do while (j >= 1)
          if (.not. is_name_char(body(j:j))) exit
          j = j - 1
        end do
        if (n_keys < size(eq_pos)) then
          n_keys = n_keys + 1
          eq_pos(n_keys) = i
          key_start(n_keys) = j + 1
        end if
      end if
    end do
    do k = 1, n_keys
      key = lower(body(key_start(k):eq_pos(k) - 1))
      p = index(key, '(')
      if (p > 0) key = key(1:p - 1)
      key = adjustl(key)
      if (k < n_keys) then
        value_end = key_start(k + 1) - 1
      else
        value_end = n
      end if
      do j = 1, size(specs)
        if (specs(j)%group == group .and. specs(j)%name == key) exit
      end do
      if (j > size(specs)) then
        fail%failed = .true.
        fail%group = group
        fail%key = key
        fail%reason = 'unknown key '''//trim(key)//''' in group &'//trim(group)//' (allowed: '// &
                      allowed_keys(specs, group)//')'
        return
      end if
      call check_value(body(eq_pos(k) + 1:value_end), specs(j)%kind, fail)
      if (fail%failed) then
        fail%group = group
        fail%key = key
        return
      end if
    end do
  end subroutine scan_group

  function allowed_keys(specs, group) result(list)
    type(key_spec), intent(in) :: specs(:)
    character(len=*), intent(in) :: group
    character(len=:), allocatable :: list
    integer :: j
    list = ''
    do j = 1, size(specs)
      if (specs(j)%group /= group) cycle
      if (len(list) > 0) list = list//', '
      list = list//trim(specs(j)%name)
    end do
  end function allowed_keys

  !> Check the items of one value list against the key's type.
  subroutine check_value(value, kind, fail)
    character(len=*), intent(in) :: value
    character(len=1), intent(in) :: kind
    type(scan_failure), intent(inout) :: fail
    character(len=:), allocatable :: item
    integer :: i, n, start, ios, star
    real(dp) :: x
    integer :: ix
    character(len=16) :: lv

    n = len_trim(value)
    if (kind == 'c') then
      if (index(value, "'") == 0 .and. index(value, '"') == 0) then
        fail%failed = .true.
        fail%reason = 'expected a quoted string, got "'//trim(adjustl(value))//'"'
      end if
      return
    end if
    start = 1
    do i = 1, n + 1
      if (i <= n) then
        if (value(i:i) /= ',' .and. value(i:i) /= ' ') cycle
      end if
      item = trim(adjustl(value(start:i - 1)))
      start = i + 1
      if (len(item) == 0) cycle
      star = index(item, '*')
      if (star > 0) then
        read (item(1:star - 1), *, iostat=ios) ix
        if (ios /= 0) then
          fail%failed = .true.
          fail%reason = 'bad repeat count in "'//item//'"'
          return
        end if
        item = item(star + 1:)
        if (len(item) == 0) cycle
      end if
      select case (kind)
      case ('r')
        read (item, *, iostat=ios) x
        if (ios == 0) ios = merge(1, 0, verify(item, '0123456789.+-eEdD') /= 0)
        if (ios /= 0) then
          fail%failed = .true.
          fail%reason = 'value "'//item//'" is not a number'
          return
        end if
      case ('i')
        ios = merge(1, 0, verify(item, '0123456789+-') /= 0)
        if (ios == 0) read (item, *, iostat=ios) ix
        if (ios /= 0) then
          fail%failed = .true.
          fail%reason = 'value "'//item//'" is not an integer'
          return
        end if
      case ('l')
        lv = lower(item)
        if (.not. any(lv == [character(len=16) :: '.true.', '.false.', 't', 'f', '.t.', '.f.', 'true', 'false'])) then
          fail%failed = .true.
          fail%reason = 'value "'//item//'" is not a logical (.true./.false.)'
          return
        end if
      end select
    end do
  end subroutine check_value

end module rotorcable_deck_scan
