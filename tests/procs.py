"""Processes the tests start, tied to the test process: none outlives it.

A test that fails or is killed (a timeout, Ctrl-C, SIGKILL of the whole run) must leave no
process behind: a ``dask worker`` that outlived its test kept a core busy for the rest of the
suite and after it. ``spawn`` asks the kernel to SIGKILL the child when the process that
started it dies (Linux ``PR_SET_PDEATHSIG``; elsewhere only ``started``'s clean-up holds), and
``started`` kills it when the block is left, however it is left.
"""

import contextlib
import os
import signal
import subprocess
import time

from cosnet.compiling import die_with_parent


def spawn(args, then=None, **kw) -> subprocess.Popen:
    """subprocess.Popen(args, **kw) whose child is killed with the test process; ``then``
    runs in the child after that (e.g. to ignore SIGINT)."""
    def pre():
        die_with_parent()
        if then is not None:
            then()
    return subprocess.Popen([str(a) for a in args], preexec_fn=pre, **kw)


@contextlib.contextmanager
def started(args, **kw):
    """``spawn`` for the duration of a block: the process (and, when it leads a session of
    its own, every process of that session) is killed when the block is left."""
    proc = spawn(args, **kw)
    try:
        yield proc
    finally:
        if kw.get("start_new_session"):
            kill_session(proc.pid)
        if proc.poll() is None:
            proc.kill()
        proc.wait()


def session(sid: int) -> list[int]:
    """The live processes of session ``sid`` (zombies left out)."""
    out = []
    for name in os.listdir("/proc"):
        if not name.isdigit():
            continue
        try:
            with open(f"/proc/{name}/stat") as f:
                fields = f.read().rpartition(")")[2].split()
        except OSError:
            continue
        if fields[0] != "Z" and int(fields[3]) == sid:   # state, ppid, pgrp, session
            out.append(int(name))
    return out


def kill_session(sid: int):
    for pid in session(sid):
        with contextlib.suppress(OSError):
            os.kill(pid, signal.SIGKILL)


def wait_until(predicate, timeout: float, every: float = 0.05) -> bool:
    """Whether ``predicate()`` became true within ``timeout`` seconds."""
    end = time.monotonic() + timeout
    while time.monotonic() < end:
        if predicate():
            return True
        time.sleep(every)
    return bool(predicate())


def served_page(args, timeout=60.0) -> tuple[str, str]:
    """(address, text) of the page that ``cosnet view ARGS --no-browser`` serves; the server
    is stopped before this returns."""
    import sys
    import urllib.request
    with started([sys.executable, "-m", "cosnet", "view", *args, "--no-browser"],
                 stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True) as proc:
        line = proc.stdout.readline()
        if not line.startswith("serving http://127.0.0.1:"):
            proc.kill()
            raise AssertionError(f"cosnet view {' '.join(map(str, args))}: {line!r} {proc.stderr.read()!r}")
        url = line.split()[1]
        with urllib.request.urlopen(url, timeout=timeout) as r:
            return url, r.read().decode()
