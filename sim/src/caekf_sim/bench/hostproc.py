"""caekf-host (the firmware app on SocketCAN) as a child process of the bench, for one run or one test session.

`running_host(binary, iface, log_path, profile=..., extra=...)` starts it on the interface, fails with its log
when it exits at start-up, and stops it (SIGTERM, then SIGKILL after 10 s) when the block ends, the block's
error included. `caekf-sim hil run --start-host` and the HIL suite's fixtures use it; `counters(log)` picks the
non-zero counters caekf-host prints when it stops.
"""
from __future__ import annotations

import contextlib
import signal
import subprocess
import time
from pathlib import Path
from typing import Iterator, Sequence, Union

PathLike = Union[str, Path]


class HostError(RuntimeError):
    pass


def host_command(binary: PathLike, iface: str, profile: str = "diagnostics", id_offset: int = 0,
                 extra: Sequence[str] = ()) -> list:
    cmd = [str(binary), "--iface", iface, "--status-period-ms", "0", "--profile", profile]
    if id_offset:
        cmd += ["--id-offset", hex(id_offset) if id_offset > 0 else str(id_offset)]
    return cmd + list(extra)


@contextlib.contextmanager
def running_host(binary: PathLike, iface: str, log_path: PathLike, profile: str = "diagnostics", id_offset: int = 0,
                 extra: Sequence[str] = (), settle: float = 0.3, append: bool = False) -> Iterator[subprocess.Popen]:
    """caekf-host on `iface` while the block runs; its stdout and stderr go to log_path."""
    if not Path(binary).is_file():
        raise HostError(f"caekf-host not built: {binary} (cmake --preset host-double && cmake --build --preset "
                        "host-double)")
    log_path = Path(log_path)
    with open(log_path, "a" if append else "w") as log:
        proc = subprocess.Popen(host_command(binary, iface, profile, id_offset, extra), stdout=log,
                                stderr=subprocess.STDOUT)
        time.sleep(settle)
        if proc.poll() is not None:
            log.flush()
            tail = log_path.read_text(errors="replace").strip().splitlines()[-3:]
            raise HostError(f"caekf-host exited at start-up ({proc.returncode}): {' / '.join(tail)}")
        try:
            yield proc
        finally:
            proc.send_signal(signal.SIGTERM)
            try:
                proc.wait(10)
            except subprocess.TimeoutExpired:
                proc.kill()
                proc.wait()


def counters(log_path: PathLike) -> str:
    """The non-zero counters caekf-host printed when it stopped (from its 'counters' line on)."""
    lines = Path(log_path).read_text(errors="replace").splitlines()
    start = next((i for i, s in enumerate(lines) if "counters" in s), len(lines))
    return "\n".join(s for s in lines[start:] if not s.rstrip().endswith(" 0"))
