"""A throw-away single-node SLURM cluster on 127.0.0.1 for tests (Debian's slurm-wlm and munge).

    ok, why = can_run()            # root, Linux, and either the daemons or apt-get are present
    seconds = install()            # apt-get install slurm-wlm munge if missing (0.0 if present)
    with LocalSlurm() as cluster:  # munged, slurmctld, slurmd started here, node idle on return
        subprocess.run([...], env=cluster.env())
    # on exit: our jobs cancelled, the three daemons and any leftover job process stopped by pid

Everything lives in one short temporary directory: munge key and socket, slurm.conf, state and
spool directories, logs and the pid files. The daemons run in the foreground (-F / -D) as
children of this process, each in a new session, so they are stopped by the pids recorded at
start and nothing outside that directory is written. Every wait is bounded by a timeout.
"""

from __future__ import annotations

import os
import shutil
import signal
import socket
import subprocess
import tempfile
import time
from pathlib import Path

APT_PACKAGES = ("slurm-wlm", "munge")
DAEMONS = ("munged", "slurmctld", "slurmd")
CLIENTS = ("sbatch", "srun", "squeue", "sinfo", "scancel", "scontrol", "munge")
SBIN = ("/usr/sbin", "/sbin")
MARKER = "BEAMSIM_LOCAL_SLURM"  # set in the daemons' environment: slurmstepd and job processes inherit it


def _which(name: str) -> str | None:
    return shutil.which(name) or shutil.which(name, path=os.pathsep.join(SBIN))


def missing_binaries() -> list[str]:
    return [b for b in DAEMONS + CLIENTS if _which(b) is None]


def can_run() -> tuple[bool, str]:
    """Whether this machine can host the test cluster, and if not, why (the skip reason)."""
    if not hasattr(os, "geteuid") or not Path("/proc").is_dir():
        return False, "the local SLURM test cluster needs Linux"
    if os.geteuid() != 0:
        return False, "the local SLURM test cluster needs root (apt-get install, SlurmUser=root)"
    if missing_binaries() and shutil.which("apt-get") is None:
        return False, f"slurm-wlm/munge not installed ({', '.join(missing_binaries())}) and no apt-get"
    return True, ""


def install(timeout: float = 900) -> float:
    """apt-get install Debian's slurm-wlm and munge unless their binaries are all there.

    Returns the seconds spent (0.0 when nothing was missing). Package scripts are kept from
    starting the system's own munge/slurm services (policy-rc.d) so the only daemons that
    run are the ones LocalSlurm starts. If another apt or dpkg holds its lock (an unattended
    upgrade, a second test run), apt waits for it instead of failing at once: dpkg's lock through
    ``DPkg::Lock::Timeout`` (the time left), the package lists' lock (which apt-get update does
    not wait for) by retrying every 2 s.
    """
    if not missing_binaries():
        return 0.0
    t0 = time.monotonic()
    env = os.environ | {"DEBIAN_FRONTEND": "noninteractive"}
    policy = Path("/usr/sbin/policy-rc.d")
    made_policy = False
    if not policy.exists():
        policy.write_text("#!/bin/sh\n# written by tests/support/slurm_cluster.py during apt-get install\n"
                          "exit 101\n")
        policy.chmod(0o755)
        made_policy = True
    try:
        for args in (["update", "-q"], ["install", "-y", "-q", "--no-install-recommends", *APT_PACKAGES]):
            left = timeout - (time.monotonic() - t0)
            cmd = ["apt-get", "-o", f"DPkg::Lock::Timeout={max(int(left) - 5, 1)}", *args]
            res = subprocess.run(cmd, env=env, capture_output=True, text=True, timeout=max(left, 1))
            while (res.returncode != 0 and "Could not get lock" in res.stderr
                   and timeout - (time.monotonic() - t0) > 5):
                time.sleep(2)
                left = timeout - (time.monotonic() - t0)
                res = subprocess.run(cmd, env=env, capture_output=True, text=True, timeout=max(left, 1))
            if res.returncode != 0:
                raise RuntimeError(f"{' '.join(cmd)} failed ({res.returncode}):\n"
                                   f"{res.stdout[-2000:]}{res.stderr[-2000:]}")
    finally:
        if made_policy:
            policy.unlink(missing_ok=True)
    if missing_binaries():
        raise RuntimeError(f"still missing after apt-get install: {missing_binaries()}")
    return time.monotonic() - t0


def _free_port() -> int:
    with socket.socket(socket.AF_INET, socket.SOCK_STREAM) as s:
        s.bind(("127.0.0.1", 0))
        return s.getsockname()[1]


def _real_memory_mb() -> int:
    """RealMemory as slurmd itself measures it (slurmd -C), else /proc/meminfo."""
    try:
        out = subprocess.run([_which("slurmd") or "slurmd", "-C"], capture_output=True, text=True,
                             timeout=30).stdout
        for tok in out.split():
            if tok.startswith("RealMemory="):
                return int(tok.split("=", 1)[1])
    except (OSError, subprocess.SubprocessError, ValueError):
        pass
    for line in Path("/proc/meminfo").read_text().splitlines():
        if line.startswith("MemTotal:"):
            return int(line.split()[1]) // 1024
    raise RuntimeError("cannot determine the machine's memory")


def _processes_with_env(marker: bytes) -> list[int]:
    """Pids (other than ours) whose environment holds ``marker`` (an exact NAME=value entry)."""
    pids = []
    for d in Path("/proc").iterdir():
        if not d.name.isdigit() or int(d.name) == os.getpid():
            continue
        try:
            env = (d / "environ").read_bytes()
        except OSError:
            continue
        if marker in env.split(b"\0"):
            pids.append(int(d.name))
    return pids


class LocalSlurm:
    """One controller + one node on 127.0.0.1; CPUs and RealMemory are the machine's."""

    def __init__(self, cpus: int | None = None, partition: str = "debug", cluster_name: str = "beamsimtest",
                 min_job_age: int = 300):
        self.cpus = cpus or os.cpu_count() or 1
        self.partition = partition
        self.cluster_name = cluster_name
        self.min_job_age = min_job_age
        self.node = socket.gethostname().split(".")[0]
        self.base: Path | None = None
        self.procs: dict[str, subprocess.Popen] = {}
        self.start_seconds = 0.0

    # -- paths --------------------------------------------------------------------------------
    @property
    def conf(self) -> Path:
        return self.base / "slurm.conf"

    @property
    def munge_socket(self) -> Path:
        return self.base / "munge" / "munge.socket"

    @property
    def bin_dir(self) -> Path:
        return self.base / "bin"

    def env(self, extra_path: list[str] | None = None) -> dict[str, str]:
        """Environment for client commands (sbatch, squeue, snakemake --executor slurm)."""
        path = [str(self.bin_dir), *(extra_path or []), os.environ.get("PATH", ""), *SBIN]
        return os.environ | {"SLURM_CONF": str(self.conf), MARKER: str(self.base),
                             "PATH": os.pathsep.join(p for p in path if p)}

    # -- start --------------------------------------------------------------------------------
    def start(self, timeout: float = 90) -> "LocalSlurm":
        t0 = time.monotonic()
        # short path: the munge socket must stay under the 108-byte sun_path limit
        self.base = Path(tempfile.mkdtemp(prefix="slurm-", dir="/tmp"))
        try:
            self._write_files()
            self._spawn("munged", [_which("munged"), "-F", "-f", f"--socket={self.munge_socket}",
                                   f"--key-file={self.base / 'munge' / 'munge.key'}",
                                   f"--pid-file={self.base / 'munged.pid'}",
                                   f"--log-file={self.base / 'munged.log'}",
                                   f"--seed-file={self.base / 'munge' / 'munged.seed'}"])
            self._wait(lambda: self._ok([_which("munge"), "-n", "-S", str(self.munge_socket)]),
                       t0 + timeout, "munged answering on its socket")
            self._spawn("slurmctld", [_which("slurmctld"), "-D", "-i", "-f", str(self.conf)])
            self._wait(lambda: self._ok([_which("scontrol"), "ping"], want="UP"), t0 + timeout,
                       "slurmctld answering `scontrol ping`")
            self._spawn("slurmd", [_which("slurmd"), "-D", "-N", self.node, "-f", str(self.conf)])
            self._wait(self._node_idle, t0 + timeout, f"node {self.node} idle in `sinfo`")
        except BaseException:
            self.stop()
            raise
        self.start_seconds = time.monotonic() - t0
        return self

    def _write_files(self) -> None:
        b = self.base
        for d in ("munge", "state", "spool", "bin", "pids"):
            (b / d).mkdir()
        (b / "munge").chmod(0o711)
        key = b / "munge" / "munge.key"
        key.write_bytes(os.urandom(1024))
        key.chmod(0o400)
        mem = _real_memory_mb()
        ctld_port, slurmd_port = _free_port(), _free_port()
        self.conf.write_text(f"""\
# single-node test cluster written by tests/support/slurm_cluster.py
ClusterName={self.cluster_name}
SlurmctldHost={self.node}(127.0.0.1)
SlurmctldPort={ctld_port}
SlurmdPort={slurmd_port}
AuthType=auth/munge
CredType=cred/munge
AuthInfo=socket={self.munge_socket}
SlurmUser=root
SlurmdUser=root
StateSaveLocation={b / 'state'}
SlurmdSpoolDir={b / 'spool'}
SlurmctldPidFile={b / 'slurmctld.pid'}
SlurmdPidFile={b / 'slurmd.pid'}
SlurmctldLogFile={b / 'slurmctld.log'}
SlurmdLogFile={b / 'slurmd.log'}
ProctrackType=proctrack/linuxproc
TaskPlugin=task/none
AccountingStorageType=accounting_storage/none
JobAcctGatherType=jobacct_gather/none
JobCompType=jobcomp/none
SelectType=select/cons_tres
SelectTypeParameters=CR_Core_Memory
SchedulerType=sched/backfill
ReturnToService=2
MpiDefault=none
MailProg=/bin/true
MinJobAge={self.min_job_age}
KillWait=5
NodeName={self.node} NodeAddr=127.0.0.1 CPUs={self.cpus} RealMemory={mem} State=UNKNOWN
PartitionName={self.partition} Nodes={self.node} Default=YES MaxTime=INFINITE State=UP
""")
        # snakemake-executor-plugin-slurm-jobstep drops every SLURM_* variable but a few job ids
        # (SLURM_CONF too) before its nested `srun`; on a real cluster srun then finds
        # /etc/slurm/slurm.conf or the configless cache, here this shim points it at our file.
        srun = self.bin_dir / "srun"
        srun.write_text(f'#!/bin/sh\nSLURM_CONF="{self.conf}" exec "{_which("srun")}" "$@"\n')
        srun.chmod(0o755)

    def _spawn(self, name: str, cmd: list) -> None:
        out = open(self.base / f"{name}.out", "wb")
        try:
            self.procs[name] = subprocess.Popen([str(c) for c in cmd], stdout=out, stderr=subprocess.STDOUT,
                                                stdin=subprocess.DEVNULL, cwd=self.base, env=self.env(),
                                                start_new_session=True)
        finally:
            out.close()
        (self.base / "pids" / f"{name}.pid").write_text(f"{self.procs[name].pid}\n")

    def _ok(self, cmd: list, want: str | None = None) -> bool:
        try:
            res = subprocess.run([str(c) for c in cmd], capture_output=True, text=True, env=self.env(),
                                 timeout=10)
        except subprocess.TimeoutExpired:
            return False
        return res.returncode == 0 and (want is None or want in res.stdout)

    def _node_idle(self) -> bool:
        try:
            res = subprocess.run([_which("sinfo"), "-h", "-N", "-n", self.node, "-o", "%T"],
                                 capture_output=True, text=True, env=self.env(), timeout=10)
        except subprocess.TimeoutExpired:
            return False
        return res.stdout.strip() == "idle"

    def _wait(self, ready, deadline: float, what: str) -> None:
        while time.monotonic() < deadline:
            dead = [n for n, p in self.procs.items() if p.poll() is not None]
            if dead:
                raise RuntimeError(f"{', '.join(dead)} exited while waiting for {what}\n{self.logs()}")
            if ready():
                return
            time.sleep(0.5)
        raise TimeoutError(f"timed out waiting for {what}\n{self.logs()}")

    # -- inspect ------------------------------------------------------------------------------
    def logs(self, lines: int = 30) -> str:
        if self.base is None:
            return ""
        parts = []
        for name in ("munged.out", "slurmctld.log", "slurmctld.out", "slurmd.log", "slurmd.out"):
            p = self.base / name
            if p.exists():
                tail = p.read_text(errors="replace").splitlines()[-lines:]
                parts.append(f"--- {name} ---\n" + "\n".join(tail))
        return "\n".join(parts)

    def pids(self) -> dict[str, int]:
        return {n: p.pid for n, p in self.procs.items()}

    # -- stop ---------------------------------------------------------------------------------
    def stop(self, timeout: float = 30) -> None:
        """Cancel our jobs, then stop exactly the daemons started here (by pid), newest first."""
        deadline = time.monotonic() + timeout
        if "slurmctld" in self.procs and self.procs["slurmctld"].poll() is None:
            try:
                subprocess.run([_which("scancel"), "--full", "-p", self.partition], env=self.env(),
                               capture_output=True, timeout=10)
                end = min(deadline, time.monotonic() + 10)
                while time.monotonic() < end:
                    res = subprocess.run([_which("squeue"), "-h", "-t", "PD,R,CG,S"], env=self.env(),
                                         capture_output=True, text=True, timeout=10)
                    if res.returncode != 0 or not res.stdout.strip():
                        break
                    time.sleep(0.5)
            except subprocess.TimeoutExpired:
                pass
        for name in reversed(list(self.procs)):
            proc = self.procs[name]
            if proc.poll() is None:
                proc.send_signal(signal.SIGTERM)
                try:
                    proc.wait(timeout=max(1.0, min(10.0, deadline - time.monotonic())))
                except subprocess.TimeoutExpired:
                    proc.kill()
                    proc.wait(timeout=10)
        # slurmstepd (it double-forks and calls setsid) or job processes left behind: they
        # inherited the marker from our slurmd or from an sbatch run with env()
        if self.base is not None:
            for pid in _processes_with_env(f"{MARKER}={self.base}".encode()):
                try:
                    os.kill(pid, signal.SIGKILL)
                except ProcessLookupError:
                    pass
        if self.base is not None and not os.environ.get("BEAMSIM_KEEP_SLURM_DIR"):
            shutil.rmtree(self.base, ignore_errors=True)

    def running(self) -> list[str]:
        return [n for n, p in self.procs.items() if p.poll() is None]

    def __enter__(self) -> "LocalSlurm":
        return self.start()

    def __exit__(self, *exc) -> None:
        self.stop()
