"""The output directory of a run: locked while the run writes it, and never silently mixed
with an earlier run's files.

A run (or a sweep, for its whole length) holds an exclusive ``flock`` on ``DIR/.cosnet.lock``
from before its first write to its end, with its process id, host and kind written in the
file; the kernel drops the lock when the process ends however it ends (even by SIGKILL), so
a lock is never left stale. A second run or sweep into the same directory is refused while
the first holds it, in one line naming the holder. A directory that already holds a run is
refused unless the new run continues it (``--resume``) or replaces it (``--overwrite``: the
old frames, series, probes and checkpoint are removed first).
"""

from __future__ import annotations

import contextlib
import fcntl
import os
import socket
from pathlib import Path

LOCK = ".cosnet.lock"
# what a run writes (with the .tmp of its atomic rewrites)
RUN_FILES = ("series.pvd", "meta.json", "probes.csv", "energy.csv", "checkpoint.npz")
FRAME_GLOBS = ("lines_*.vtu", "nodes_*.vtu")


def run_files(out: Path) -> list[Path]:
    """The files of an earlier run in ``out`` (frames, series, probes, energy, checkpoint)."""
    found = [out / n for n in RUN_FILES if (out / n).exists()]
    found += [p for n in RUN_FILES if (p := out / f"{n}.tmp").exists()]
    for g in FRAME_GLOBS:
        found += sorted(out.glob(g))
    return found


@contextlib.contextmanager
def locked(out: Path, kind: str = "run"):
    """Create ``out`` if needed and hold its lock for the duration of the block (``kind``,
    "run" or "sweep", is written beside the pid and host for whoever is refused); a
    directory another process holds is refused with a ValueError naming the holder."""
    if out.exists() and not out.is_dir():
        raise ValueError(f"{out}: exists and is not a directory")
    try:
        out.mkdir(parents=True, exist_ok=True)
        fd = os.open(out / LOCK, os.O_RDWR | os.O_CREAT, 0o644)
    except OSError as e:
        raise ValueError(f"{out}: cannot use it as the output directory ({e.strerror})") from None
    try:
        try:
            fcntl.flock(fd, fcntl.LOCK_EX | fcntl.LOCK_NB)
        except BlockingIOError:
            raise ValueError(f"{out}: {holder(fd)} is writing into it; wait for it to end or "
                             f"choose another --out") from None
        try:
            os.ftruncate(fd, 0)
            os.pwrite(fd, f"{os.getpid()} {socket.gethostname()} {kind}\n".encode(), 0)
        except OSError:   # a full disk: the lock holds all the same, its holder goes unnamed
            pass
        yield out
    finally:
        os.close(fd)   # releases the lock


def holder(fd: int) -> str:
    """Who holds the lock open as ``fd``: "another sweep (process 12 on host h)"; the file
    is written just after the lock is taken, so it may still be empty."""
    words = os.pread(fd, 256, 0).decode(errors="replace").split()
    if not words or not words[0].isdigit():
        return "another run"
    kind = words[2] if len(words) > 2 else "run"
    host = f" on {words[1]}" if len(words) > 1 else ""
    return f"another {kind} (process {words[0]}{host})"


def prepare(out: Path, resume: bool, overwrite: bool):
    """Refuse to write a new run over an earlier one unless ``overwrite`` (which removes its
    files) or ``resume`` (which continues it). Call while holding the lock."""
    old = run_files(out)
    if not old or resume:
        return
    if not overwrite:
        names = ", ".join(sorted({p.name if not p.name.endswith(".vtu") else "*.vtu" for p in old}))
        raise ValueError(f"{out}: holds a run already ({names}); pass --overwrite to replace it "
                         f"or --resume to continue it")
    for p in old:
        try:
            p.unlink()
        except FileNotFoundError:
            pass
        except OSError as e:
            raise ValueError(f"{p}: cannot remove the earlier run's file ({e.strerror})") from None
