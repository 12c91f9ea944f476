"""Pool processes die with the sweep process, however it dies.

A sweep killed hard (SIGKILL, the OOM killer, a lost session) cannot shut its pool down.  Its
workers would wait on the task queue forever (they hold its write end themselves, so no EOF
comes), and the forkserver they are forked from stays up while any of them holds its "alive"
pipe.  Two mechanisms end them:

1. Every worker watches ``multiprocessing.parent_process().sentinel``: a pipe to the sweep
   process whose write end only that process holds (multiprocessing keeps it for each child),
   so the worker reads EOF the moment the sweep process is gone, whoever its parent is, and a
   daemon thread then ends it.  The thread needs the GIL, so a worker inside one long call
   into the compiled core notices when that call returns.
2. On Linux, the kernel ends them at once through ``PR_SET_PDEATHSIG`` (SIGKILL when the
   parent dies), where that is sound.  The signal follows the *thread* that forked, so the
   forkserver asks for it only when the sweep's main thread started it (the main thread lives
   as long as the process; the sweep process marks this in ``ROTORCABLE_SWEEP_PID``), and its
   workers ask for it towards the forkserver, a single-threaded process.  Killing the sweep
   then kills the forkserver, which kills every worker, even in the middle of a core call.

The resource tracker of multiprocessing exits by itself once none of them is left.
"""

from __future__ import annotations

import contextlib
import ctypes
import multiprocessing
import multiprocessing.connection
import os
import signal
import sys
import threading

#: Set by the sweep process (its pid) while its pool starts, if in the main thread.
SWEEP_PID_VAR = "ROTORCABLE_SWEEP_PID"
#: Set by a forkserver that dies with the sweep process (its own pid), for its workers.
FORKSERVER_VAR = "ROTORCABLE_SWEEP_FORKSERVER"

_PR_SET_PDEATHSIG = 1          # <linux/prctl.h>


def _die_with_parent() -> bool:
    """Ask the kernel for SIGKILL when the parent (thread) dies; False where unsupported."""
    if not sys.platform.startswith("linux"):
        return False
    try:
        prctl = ctypes.CDLL(None, use_errno=True).prctl
    except (OSError, AttributeError):
        return False
    return prctl(_PR_SET_PDEATHSIG, int(signal.SIGKILL), 0, 0, 0) == 0


@contextlib.contextmanager
def sweep_process_mark():
    """Environment for starting a pool: tells a new forkserver it may tie itself to us."""
    if threading.current_thread() is not threading.main_thread():
        yield                   # the forkserver would follow this thread, not the process
        return
    saved = os.environ.get(SWEEP_PID_VAR)
    os.environ[SWEEP_PID_VAR] = str(os.getpid())
    try:
        yield
    finally:
        if saved is None:
            os.environ.pop(SWEEP_PID_VAR, None)
        else:
            os.environ[SWEEP_PID_VAR] = saved


def guard_forkserver() -> None:
    """In a forkserver (imported as its preload): die with the sweep process that marked it."""
    parent = os.getppid()
    if os.environ.get(SWEEP_PID_VAR) != str(parent) or not _die_with_parent():
        return
    if os.getppid() != parent:
        os._exit(1)             # the sweep died before the request took effect
    os.environ[FORKSERVER_VAR] = str(os.getpid())


def _exit_when_closed(sentinel) -> None:
    multiprocessing.connection.wait([sentinel])
    os._exit(1)


def worker_init() -> None:
    """Pool worker set-up: ignore Ctrl-C, and die with the sweep process (module docstring).

    Ctrl-C reaches the whole process group; the sweep process handles it (cancels the decks
    not started) and the workers finish the deck in hand, so its record is not lost.
    """
    signal.signal(signal.SIGINT, signal.SIG_IGN)
    parent = os.getppid()
    if os.environ.get(FORKSERVER_VAR) == str(parent) and _die_with_parent() \
            and os.getppid() != parent:
        os._exit(1)             # the forkserver died before the request took effect
    sweep = multiprocessing.parent_process()
    if sweep is not None:
        threading.Thread(target=_exit_when_closed, args=(sweep.sentinel,), daemon=True,
                         name="rotorcable-sweep-lifeline").start()
