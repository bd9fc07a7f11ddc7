# SPDX-License-Identifier: Apache-2.0
"""Start the demo's executables as separate processes and stop every one of them cleanly."""

from __future__ import annotations

import contextlib
import os
import select
import shutil
import signal
import subprocess
import sys
import threading
import time
from dataclasses import dataclass, field
from pathlib import Path

from swir_tracker_ros.errors import DemoError


def find_executable(name: str) -> str:
    """Path of an installed console script: next to this interpreter first (a venv), then on PATH."""
    local = Path(sys.executable).parent / name
    if local.exists():
        return str(local)
    found = shutil.which(name)
    if found is None:
        raise DemoError(f"executable {name!r} is not installed next to {sys.executable} nor on PATH")
    return found


def ros_environment(domain_id: int, base: dict[str, str] | None = None) -> dict[str, str]:
    """Environment of one demo run: its own DDS domain, discovery kept on this host, unbuffered output."""
    if not 0 <= domain_id <= 232:
        raise DemoError(f"ROS_DOMAIN_ID {domain_id} is outside 0..232")
    env = dict(os.environ if base is None else base)
    env["ROS_DOMAIN_ID"] = str(domain_id)
    env["ROS_AUTOMATIC_DISCOVERY_RANGE"] = "LOCALHOST"
    env.pop("ROS_LOCALHOST_ONLY", None)  # deprecated in Jazzy; the range above replaces it
    env["PYTHONUNBUFFERED"] = "1"
    return env


@dataclass
class Managed:
    """One started process, its log file and how it ended."""

    name: str
    proc: subprocess.Popen
    log: Path
    returncode: int | None = None
    how: str = "running"  # "exited" (by itself), "sigint", "sigterm", "sigkill"
    cpu_s: float = float("nan")  # user + system CPU seconds, read just before the stop signal


def cpu_seconds(pid: int) -> float:
    """User + system CPU time of a live process (Linux /proc), NaN when unavailable."""
    try:
        fields = Path(f"/proc/{pid}/stat").read_text().rsplit(")", 1)[1].split()
        return (int(fields[11]) + int(fields[12])) / os.sysconf("SC_CLK_TCK")
    except (OSError, ValueError, IndexError):
        return float("nan")


@dataclass
class ProcessGroup:
    """Processes of one demo run, started in order and stopped in reverse order.

    Each process gets its own session (so a terminal's Ctrl-C reaches only the demo, which then stops the
    others in order) and its stdout/stderr in `log_dir/<name>.log`.
    """

    log_dir: Path
    env: dict[str, str]
    started: list[Managed] = field(default_factory=list)

    def start(self, name: str, argv: list[str], *, capture_first_line: bool = False, nice: int = 0
              ) -> Managed:
        """Start argv; with capture_first_line, stdout is a pipe so `first_line` can read it; `nice` is
        added to the process's niceness (lower CPU priority)."""
        self.log_dir.mkdir(parents=True, exist_ok=True)
        log = self.log_dir / f"{name}.log"
        log.write_bytes(b"")
        fh = log.open("ab")  # O_APPEND: stderr and the first-line copy never overwrite each other
        stdout = subprocess.PIPE if capture_first_line else fh
        try:
            proc = subprocess.Popen(
                argv, stdout=stdout, stderr=fh, env=self.env, start_new_session=True,
                preexec_fn=(lambda: os.nice(nice)) if nice > 0 else None,
            )
        except OSError as exc:
            fh.close()
            raise DemoError(f"cannot start {name} ({argv[0]}): {exc}") from exc
        finally:
            if not capture_first_line:
                fh.close()
        if nice > 0:
            _nice_session(proc.pid, nice)
        managed = Managed(name, proc, log)
        self.started.append(managed)
        return managed

    def first_line(self, managed: Managed, timeout: float) -> str:
        """First stdout line of a process started with capture_first_line; the rest goes to its log."""
        assert managed.proc.stdout is not None
        fd = managed.proc.stdout.fileno()
        buf = b""
        end = time.monotonic() + timeout
        while b"\n" not in buf:
            left = end - time.monotonic()
            if left <= 0 or managed.proc.poll() is not None:
                raise DemoError(
                    f"{managed.name} printed no first line within {timeout:.0f} s "
                    f"(exit code {managed.proc.poll()}); see {managed.log}"
                )
            ready, _, _ = select.select([fd], [], [], min(left, 0.2))
            if ready:
                chunk = os.read(fd, 4096)
                if not chunk:
                    continue
                buf += chunk
        line, rest = buf.split(b"\n", 1)
        with managed.log.open("ab") as fh:
            fh.write(line + b"\n" + rest)
        _drain_to_log(managed)
        return line.decode(errors="replace").strip()

    def stop(self, managed: Managed, timeout: float = 8.0) -> int:
        """SIGINT, wait; SIGTERM, wait; SIGKILL as the last resort. Returns the exit code."""
        proc = managed.proc
        if proc.poll() is None:
            managed.cpu_s = cpu_seconds(proc.pid)
        if proc.poll() is not None:
            if managed.how == "running":
                managed.how = "exited"
            managed.returncode = proc.returncode
            return proc.returncode
        for sig, how, wait in ((signal.SIGINT, "sigint", timeout), (signal.SIGTERM, "sigterm", 3.0),
                               (signal.SIGKILL, "sigkill", 3.0)):
            try:
                proc.send_signal(sig)
            except ProcessLookupError:
                break
            try:
                proc.wait(wait)
                managed.how = how
                break
            except subprocess.TimeoutExpired:
                continue
        managed.returncode = proc.poll()
        return -9 if managed.returncode is None else managed.returncode

    def stop_all(self) -> dict[str, dict[str, object]]:
        """Stop in reverse start order; returns {name: {"returncode", "how"}} for the report."""
        report: dict[str, dict[str, object]] = {}
        for managed in reversed(self.started):
            code = self.stop(managed)
            report[managed.name] = {"returncode": code, "how": managed.how, "cpu_s": round(managed.cpu_s, 2)}
        return report

    def dead(self) -> list[Managed]:
        """Processes that ended by themselves while they should still be running."""
        return [m for m in self.started if m.how == "running" and m.proc.poll() is not None]


def _nice_session(pid: int, nice: int) -> None:
    """Lower the CPU weight of a process that leads its own session.

    With the kernel's autogroup scheduling (/proc/sys/kernel/sched_autogroup_enabled), each session is
    one scheduling group whose weight comes from the group's nice value, not the process's: the process
    nice set by `os.nice` then only ranks it inside its own session. Best effort (no autogroup: no file).
    """
    with contextlib.suppress(OSError):
        Path(f"/proc/{pid}/autogroup").write_text(str(nice))


def _drain_to_log(managed: Managed) -> None:
    """Copy a piped stdout to the log in a daemon thread so the child never blocks on a full pipe."""

    def pump() -> None:
        assert managed.proc.stdout is not None
        with managed.log.open("ab") as fh:
            for chunk in iter(lambda: managed.proc.stdout.read1(4096), b""):  # type: ignore[union-attr]
                fh.write(chunk)
                fh.flush()

    threading.Thread(target=pump, name=f"log-{managed.name}", daemon=True).start()


def tail(path: Path, lines: int = 15) -> str:
    """Last lines of a log file for an error message."""
    try:
        return "\n".join(path.read_text(errors="replace").splitlines()[-lines:])
    except OSError:
        return ""
