"""The output directory of a run: locked while the run writes it, and never silently mixed
with an earlier run's files.

A run holds an exclusive ``flock`` on ``DIR/.cosnet.lock`` from before its first write to its
end; the kernel drops the lock when the process ends however it ends (even by SIGKILL), so
a lock is never left stale. A second run into the same directory is refused while the first
holds it. A directory that already holds a run is refused unless the new run continues it
(``--resume``) or replaces it (``--overwrite``: the old frames, series, probes and
checkpoint are removed first).
"""

from __future__ import annotations

import contextlib
import fcntl
import os
from pathlib import Path

LOCK = ".cosnet.lock"
# what a run writes (with the .tmp of its atomic rewrites)
RUN_FILES = ("series.pvd", "meta.json", "probes.csv", "checkpoint.npz")
FRAME_GLOBS = ("lines_*.vtu", "nodes_*.vtu")


def run_files(out: Path) -> list[Path]:
    """The files of an earlier run in ``out`` (frames, series, probes, checkpoint)."""
    found = [out / n for n in RUN_FILES if (out / n).exists()]
    found += [p for n in RUN_FILES if (p := out / f"{n}.tmp").exists()]
    for g in FRAME_GLOBS:
        found += sorted(out.glob(g))
    return found


@contextlib.contextmanager
def locked(out: Path):
    """Create ``out`` if needed and hold its lock for the duration of the block; a directory
    another process holds is refused with a ValueError naming it."""
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
            holder = os.pread(fd, 32, 0).decode(errors="replace").strip()
            who = f" (process {holder})" if holder.isdigit() else ""
            raise ValueError(f"{out}: another run is writing into it{who}; wait for it to end or "
                             f"choose another --out") from None
        os.ftruncate(fd, 0)
        os.pwrite(fd, f"{os.getpid()}\n".encode(), 0)
        yield out
    finally:
        os.close(fd)   # releases the lock


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
