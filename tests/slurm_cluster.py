"""A private single-node Slurm for the tests: started for the session, stopped at its end.

The sweep's Slurm path (``sweep --slurm``, ``sweep-task``, ``sweep-collect``) and its Dask path
on dask-jobqueue are only kept working if something runs them against a real Slurm.  This
module starts one on the test machine, Debian's Slurm 22.05 (``slurm-wlm``, ``munge``; ``bash
.ci/setup`` installs them), with nothing shared with any other Slurm or munge on the machine:

* its own ``munged`` (a fresh key, its socket, pid and seed files in the cluster's
  directory), which ``slurm.conf`` names in ``AuthInfo=socket=...``;
* its own ``slurm.conf`` in that directory (state, spool, pid and log files there too, ports
  chosen free), passed to the daemons and to every ``sbatch``/``squeue``/``scancel`` through
  the ``SLURM_CONF`` environment variable (:attr:`LocalSlurm.env`);
* one node, the machine itself as ``slurmd -C`` describes it (so that slurmd never finds its
  hardware short of the configuration and drains the node), one partition.

All three daemons run in the foreground as children of the test process and are stopped by
their process ids at the end, never by name: other Slurm or munge daemons may run on the
machine.  Should the test process die first, the kernel stops them (``setpriv --pdeathsig``).  Accounting is off, so a job is waited for until ``squeue`` no longer lists it.

The daemons run as root (slurmd starts every job as its user); the tests need root, as CI
has.  Nothing is skipped when Slurm is missing: the session fails, saying how to install it.
"""

from __future__ import annotations

import contextlib
import os
import shutil
import signal
import socket
import subprocess
import tempfile
import time
from dataclasses import dataclass, field
from pathlib import Path

INSTALL_HINT = "bash .ci/setup installs them (Debian packages slurm-wlm and munge)"
PROGRAMS = ("munged", "slurmctld", "slurmd", "sbatch", "squeue", "scancel",
            "scontrol", "sinfo")
PARTITION = "tests"
# Seconds.  The daemons answer within ~3 s on a 2-core VM; a minute turns a hang into a failure
# on a slow or busy machine without making anyone wait for a working one.
START_TIMEOUT = 60
STOP_TIMEOUT = 30
COMMAND_TIMEOUT = 60


class SlurmUnavailable(RuntimeError):
    """The private cluster cannot be started; the message says why, with the daemons' logs."""


def _program(name: str) -> str:
    # The daemons live in /usr/sbin, which a non-login shell may leave out of PATH.
    found = shutil.which(name) or shutil.which(name, path="/usr/sbin:/sbin")
    if found is None:
        raise SlurmUnavailable(f"{name} not found: the Slurm tests start a private single-node "
                               f"Slurm; {INSTALL_HINT}")
    return found


def _free_ports(count: int) -> list[int]:
    """Ports free on the loopback now (bound together, so they differ)."""
    with contextlib.ExitStack() as stack:
        socks = [stack.enter_context(socket.socket()) for _ in range(count)]
        for s in socks:
            s.bind(("127.0.0.1", 0))
        return [s.getsockname()[1] for s in socks]


def _node_line(slurmd: str, node: str) -> str:
    """``NodeName=...`` as ``slurmd -C`` sees this machine (CPUs, sockets, cores, threads,
    memory), with our node name and address."""
    proc = subprocess.run([slurmd, "-C"], capture_output=True, text=True, timeout=COMMAND_TIMEOUT)
    line = next((ln for ln in proc.stdout.splitlines() if ln.startswith("NodeName=")), None)
    if proc.returncode != 0 or line is None:
        raise SlurmUnavailable(f"slurmd -C did not describe this machine (status {proc.returncode}): "
                               f"{proc.stdout}{proc.stderr}")
    hardware = line.split(None, 1)[1]
    return f"NodeName={node} NodeAddr=127.0.0.1 {hardware} State=UNKNOWN"


def slurm_conf(root: Path, node: str, node_line: str, ports: list[int], munge_socket: Path) -> str:
    """The text of the private cluster's ``slurm.conf``: every file in ``root``.

    Parameters
    ----------
    root : Path
        The cluster's directory (state, spool, pid and log files).
    node : str
        Short host name of this machine: the controller's and the node's name.
    node_line : str
        The ``NodeName=`` line (:func:`_node_line`).
    ports : list of int
        slurmctld's and slurmd's ports.
    munge_socket : Path
        The private munged's socket.

    Returns
    -------
    str
    """
    return f"""\
# A private single-node Slurm of the rotorcable tests (tests/slurm_cluster.py).
ClusterName=rotorcable-tests
SlurmctldHost={node}(127.0.0.1)
SlurmctldPort={ports[0]}
SlurmdPort={ports[1]}
SlurmUser=root
SlurmdUser=root
AuthType=auth/munge
CredType=cred/munge
AuthInfo=socket={munge_socket}
StateSaveLocation={root}/state
SlurmdSpoolDir={root}/spool
SlurmctldPidFile={root}/slurmctld.pid
SlurmdPidFile={root}/slurmd.pid
SlurmctldLogFile={root}/slurmctld.log
SlurmdLogFile={root}/slurmd.log
SlurmctldDebug=info
SlurmdDebug=info
# No cgroups: processes are tracked through /proc, and tasks are not bound to cores.
ProctrackType=proctrack/linuxproc
TaskPlugin=task/none
SchedulerType=sched/backfill
SelectType=select/cons_tres
SelectTypeParameters=CR_Core
ReturnToService=2
# A cancelled task gets SIGKILL 2 s after SIGTERM (default 30 s).
KillWait=2
MailProg=/bin/true
{node_line}
PartitionName={PARTITION} Nodes={node} Default=YES MaxTime=INFINITE State=UP
"""


@dataclass
class LocalSlurm:
    """A running private single-node Slurm (made by :func:`local_slurm`).

    Attributes
    ----------
    root : Path
        Its directory: ``slurm.conf``, the daemons' state, spool, pid and log files.
    conf : Path
        ``root/slurm.conf``.
    env : dict
        The environment of every Slurm command: ``os.environ`` without Slurm's own variables,
        with ``SLURM_CONF`` naming ``conf``.
    partition : str
        Its one partition (the default).
    """

    root: Path
    conf: Path
    env: dict
    partition: str = PARTITION
    _daemons: dict = field(default_factory=dict)

    def command(self, *args, check: bool = True, timeout: float = COMMAND_TIMEOUT, **kw):
        """Run a Slurm command (``sbatch``, ``squeue``, ...) on this cluster.

        Parameters
        ----------
        *args : str or Path
            The command line, program first.
        check : bool
            Raise :class:`AssertionError` (with the output and the daemons' logs) when the
            command fails.
        timeout : float
            Seconds before the command counts as hung.
        **kw
            Further arguments of :func:`subprocess.run` (``cwd``).

        Returns
        -------
        subprocess.CompletedProcess
            With text ``stdout`` and ``stderr``.
        """
        args = [str(a) for a in args]
        proc = subprocess.run(args, env=self.env, capture_output=True, text=True, timeout=timeout, **kw)
        if check and proc.returncode != 0:
            raise AssertionError(f"{' '.join(args)}: status {proc.returncode}\n{proc.stdout}{proc.stderr}"
                                 f"\n{self.logs()}")
        return proc

    def sbatch(self, script, *options, cwd=None) -> str:
        """Submit ``script`` as a user would (``sbatch [options] script``); return the job id.

        ``cwd`` is sbatch's working directory, the job's too (default: the script's directory,
        so that no job writes into the directory the tests run from).
        """
        script = Path(script)
        proc = self.command("sbatch", "--parsable", *options, script, cwd=cwd or script.parent)
        return proc.stdout.strip().split(";")[0]

    def jobs(self, job_id: str) -> list[str]:
        """The pending or running jobs (array tasks) of ``job_id`` as ``<job>_<task> <state>``."""
        proc = self.command("squeue", "-h", "-r", "-j", job_id, "-o", "%i %T", check=False)
        if proc.returncode != 0:
            # Once slurmctld forgets a finished job (MinJobAge), squeue calls its id invalid.
            if "Invalid job id" in proc.stderr:
                return []
            raise AssertionError(f"squeue -j {job_id}: status {proc.returncode}: {proc.stderr}\n{self.logs()}")
        return proc.stdout.split("\n")[:-1]

    def wait(self, job_id: str, timeout: float) -> None:
        """Wait until no task of ``job_id`` is pending or running (accounting is off: squeue).

        Raises
        ------
        AssertionError
            Still listed after ``timeout`` seconds (the message has the daemons' logs).
        """
        deadline = time.monotonic() + timeout
        while (left := self.jobs(job_id)):
            if time.monotonic() > deadline:
                raise AssertionError(f"job {job_id} not done after {timeout} s: {left}\n{self.logs()}")
            time.sleep(0.5)

    def wait_until(self, job_id: str, states: set[str], timeout: float) -> list[str]:
        """Wait until every listed task of ``job_id`` is in one of ``states``; return them."""
        deadline = time.monotonic() + timeout
        while True:
            listed = self.jobs(job_id)
            if listed and all(line.split()[1] in states for line in listed):
                return listed
            if time.monotonic() > deadline:
                raise AssertionError(f"job {job_id} not in {states} after {timeout} s: {listed}\n{self.logs()}")
            time.sleep(0.2)

    def logs(self) -> str:
        """The daemons' log files (the tail of each), for failure messages."""
        parts = []
        for name in ("munged", "slurmctld", "slurmd"):
            # A daemon's log file once it has opened it, its output (stderr) before that;
            # munged in the foreground logs to stderr only.
            path = self.root / f"{name}.log"
            if not path.is_file():
                path = self.root / f"{name}.out"
            text = path.read_text(errors="replace") if path.is_file() else "(none)\n"
            parts.append(f"--- {path} (last 40 lines)\n" + "".join(text.splitlines(True)[-40:]))
        return "".join(parts)

    def _start(self, name: str, args: list[str]) -> None:
        # A test session killed hard (a CI time-out) cannot stop its daemons: setpriv (Debian's
        # util-linux) has the kernel send them SIGTERM when the session process dies.
        setpriv = shutil.which("setpriv")
        if setpriv is not None:
            args = [setpriv, "--pdeathsig", "TERM", "--", *args]
        with open(self.root / f"{name}.out", "wb") as out:
            self._daemons[name] = subprocess.Popen(args, env=self.env, stdout=out, stderr=subprocess.STDOUT,
                                                   stdin=subprocess.DEVNULL)

    def _check_running(self) -> None:
        for name, proc in self._daemons.items():
            if proc.poll() is not None:
                raise SlurmUnavailable(f"{name} exited with status {proc.returncode}\n{self.logs()}")

    def stop(self) -> None:
        """Cancel every job of this cluster, then stop the daemons (by process id, last started
        first: SIGTERM, SIGKILL after :data:`STOP_TIMEOUT`)."""
        if self._daemons.get("slurmctld") is not None and self._daemons["slurmctld"].poll() is None:
            # Every job of this private cluster is a test's: none may outlive the session.
            listed = self.command("squeue", "-h", "-o", "%A", check=False, timeout=10).stdout.split()
            if listed:
                self.command("scancel", *listed, check=False, timeout=10)
                deadline = time.monotonic() + STOP_TIMEOUT
                while (self.command("squeue", "-h", "-o", "%A", check=False, timeout=10).stdout.split()
                       and time.monotonic() < deadline):
                    time.sleep(0.5)
        for name in reversed(list(self._daemons)):
            proc = self._daemons.pop(name)
            if proc.poll() is None:
                proc.send_signal(signal.SIGTERM)
                try:
                    proc.wait(STOP_TIMEOUT)
                except subprocess.TimeoutExpired:
                    proc.kill()
                    proc.wait()


@contextlib.contextmanager
def local_slurm():
    """Start a private single-node Slurm; stop it and remove its directory on exit.

    Yields
    ------
    LocalSlurm
        Its node idle, ready for ``sbatch``.

    Raises
    ------
    SlurmUnavailable
        Slurm or munge not installed (the message says ``bash .ci/setup`` installs them), not
        root, or the cluster did not come up within :data:`START_TIMEOUT` seconds (the message
        holds the daemons' logs).
    """
    programs = {name: _program(name) for name in PROGRAMS}
    if os.geteuid() != 0:
        raise SlurmUnavailable("the Slurm tests start a private single-node Slurm, whose slurmd "
                               "must run as root; run the tests as root (CI does)")
    # Not under pytest's basetemp: munged wants its socket's directory searchable by everyone,
    # and pytest makes its directories 0700.
    root = Path(tempfile.mkdtemp(prefix="rotorcable-slurm-"))
    root.chmod(0o755)
    cluster = None
    try:
        for sub in ("state", "spool"):
            (root / sub).mkdir(mode=0o700)
        key = root / "munge.key"
        with open(os.open(key, os.O_WRONLY | os.O_CREAT | os.O_EXCL, 0o600), "wb") as fh:
            fh.write(os.urandom(128))               # a key is any 32 to 1024 random bytes
        munge_socket = root / "munge.socket"
        node = socket.gethostname().split(".")[0]
        conf = root / "slurm.conf"
        conf.write_text(slurm_conf(root, node, _node_line(programs["slurmd"], node), _free_ports(2),
                                   munge_socket))
        cluster = LocalSlurm(root=root, conf=conf, env=dict(_environment_without_slurm(), SLURM_CONF=str(conf)))
        cluster._start("munged", [programs["munged"], "--foreground", f"--socket={munge_socket}",
                                  f"--key-file={key}", f"--pid-file={root}/munged.pid",
                                  f"--seed-file={root}/munged.seed"])
        _wait(cluster, lambda: munge_socket.exists(), "munged to make its socket")
        cluster._start("slurmctld", [programs["slurmctld"], "-D"])
        cluster._start("slurmd", [programs["slurmd"], "-D"])
        _wait(cluster, lambda: _node_state(cluster) == "idle", "sinfo to show the node idle")
        yield cluster
    finally:
        if cluster is not None:
            cluster.stop()
        shutil.rmtree(root, ignore_errors=True)


def _environment_without_slurm() -> dict:
    """``os.environ`` without the variables Slurm's commands read as input or set in a job:
    tests run inside a job of a real cluster would otherwise submit with its partition or
    account (``SBATCH_PARTITION``, ...) to ours."""
    return {k: v for k, v in os.environ.items() if not k.startswith(("SLURM_", "SBATCH_", "SALLOC_", "SRUN_", "SQUEUE_"))}


def _node_state(cluster: LocalSlurm) -> str | None:
    proc = cluster.command("sinfo", "-h", "-N", "-o", "%T", check=False, timeout=10)
    return proc.stdout.strip() if proc.returncode == 0 else None


def _wait(cluster: LocalSlurm, ready, what: str) -> None:
    deadline = time.monotonic() + START_TIMEOUT
    while not ready():
        cluster._check_running()
        if time.monotonic() > deadline:
            raise SlurmUnavailable(f"waited {START_TIMEOUT} s for {what}\n{cluster.logs()}")
        time.sleep(0.2)
