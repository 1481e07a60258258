"""Shared benchmark harness: timing in one process, tables on stdout, JSON next to the script.

Figures are throughputs (element-steps per second) and ratios measured side by side in the
same run, since absolute times on a shared machine are noisy."""

from __future__ import annotations

import json
import os
import platform
import statistics
import time
from pathlib import Path

import numba

import cosnet

STEEL = cosnet.Material(E=2.1e11, G=8.1e10, density=7850.0, name="steel")


def rod(n, radius=0.01):
    """A 1 m steel rod of n elements clamped at one end (free at the other)."""
    net = cosnet.Net()
    a = net.add_node((0, 0, 0), fixed=True)
    b = net.add_node((1, 0, 0))
    net.add_line(a, b, material=STEEL, section=cosnet.Circle(radius), elements=n)
    return net


def chain(lines, per_line=10):
    """A straight chain of 0.1 m steel lines (r = 2 mm) joined at point junctions, clamped
    at its first node."""
    net = cosnet.Net()
    prev = net.add_node((0, 0, 0), fixed=True)
    for k in range(lines):
        node = net.add_node((0.1 * (k + 1), 0, 0))
        net.add_line(prev, node, material=STEEL, section=cosnet.Circle(0.002), elements=per_line)
        prev = node
    return net


def best_of(fn, repeat=3):
    """Smallest wall time of ``repeat`` calls of fn() (after one warm-up call)."""
    return best_interleaved([fn], repeat)[0]


def best_interleaved(fns, rounds=9):
    """Smallest wall time of each of fns over ``rounds`` rounds that call every fn once in
    turn (after one warm-up call each). On a shared machine whose speed drifts from minute to
    minute, alternating keeps a slow spell from landing on one contender only: ratios of the
    results compare the contenders at the machine's best."""
    for fn in fns:
        fn()
    best = [float("inf")] * len(fns)
    for _ in range(rounds):
        for k, fn in enumerate(fns):
            t0 = time.perf_counter()
            fn()
            best[k] = min(best[k], time.perf_counter() - t0)
    return best


def median_of_copies(builds, copies=3, rounds=5):
    """For each of ``builds`` (callables returning a contender: a callable to time, built anew
    each call, a simulation and its run), the median over ``copies`` instances of the
    smallest wall time each takes over ``rounds`` rounds, every instance of every contender
    timed in turn (best_interleaved). A simulation's step time depends on where its arrays
    lie in memory: copies of one scene in water, built in one process, differed by a fifth of
    the dry line's step, each copy keeping its own figure from round to round, and a table of
    one copy each moved by tens of points between runs in rows whose code had not changed.
    The best of rounds takes the machine at its best; the median of copies, the contender at
    a usual placement (what a shared machine does from one run to the next remains: two runs
    of the fluid's table on one commit still differed by tens of points in some rows)."""
    fns, owner = [], []
    for k, build in enumerate(builds):
        for _ in range(copies):
            fns.append(build())
            owner.append(k)
    times = best_interleaved(fns, rounds)
    return [statistics.median(t for t, o in zip(times, owner) if o == k) for k in range(len(builds))]


def cpu_times():
    """Return (steal, total, busy) CPU jiffies of all cores from /proc/stat, or zeros where it
    is unavailable. On a virtual machine, steal is time the hypervisor gave to other guests;
    busy is all but idle and iowait."""
    try:
        with open("/proc/stat") as f:
            fields = [int(v) for v in f.readline().split()[1:]]
    except OSError:
        return 0, 0, 0
    total = sum(fields[:8])
    return (fields[7] if len(fields) > 7 else 0), total, total - fields[3] - fields[4]


def stolen_since(start) -> float:
    """Fraction of CPU time stolen by the hypervisor since cpu_times() returned start."""
    steal, total, _ = cpu_times()
    return (steal - start[0]) / max(total - start[1], 1)


def cpu_model() -> str:
    """The processor's model name (/proc/cpuinfo), else what platform knows."""
    try:
        with open("/proc/cpuinfo") as f:
            for line in f:
                if line.startswith("model name"):
                    return line.split(":", 1)[1].strip()
    except OSError:
        pass
    return platform.processor() or platform.machine()


def commit() -> str:
    """The checkout's commit (with "+changes" when its code differs from it), or "unknown".
    Changed outputs (the bench JSON and figures, the pages rendered from them) do not count:
    bench/run_all.py --full rewrites them script by script, all on one commit."""
    import subprocess
    here = Path(__file__).resolve().parent
    try:
        head = subprocess.run(["git", "rev-parse", "--short", "HEAD"], cwd=here, capture_output=True,
                              text=True, timeout=10).stdout.strip()
        changed = subprocess.run(["git", "status", "--porcelain", "--untracked-files=no"], cwd=here,
                                 capture_output=True, text=True, timeout=10).stdout.splitlines()
    except (OSError, subprocess.SubprocessError):
        return "unknown"
    dirty = [line for line in changed if not line.rstrip().endswith((".json", ".png", ".gif", ".md"))]
    return (head + ("+changes" if dirty else "")) or "unknown"


def machine() -> dict:
    return {"python": platform.python_version(), "numba": numba.__version__,
            "cpu": platform.processor() or platform.machine(), "cpu_model": cpu_model(),
            "cores": os.cpu_count(), "threads": numba.get_num_threads(), "commit": commit(),
            "load_average_1min": os.getloadavg()[0]}


def table(title: str, header: list[str], rows: list[list]) -> str:
    cells = [[f"{c:.4g}" if isinstance(c, float) else str(c) for c in row] for row in rows]
    widths = [max(len(h), *(len(r[i]) for r in cells)) for i, h in enumerate(header)]
    line = lambda r: "| " + " | ".join(c.rjust(w) for c, w in zip(r, widths)) + " |"
    out = [f"\n{title}", line(header), "|" + "|".join("-" * (w + 2) for w in widths) + "|"]
    out += [line(r) for r in cells]
    text = "\n".join(out)
    print(text)
    return text


def python_env(**extra) -> dict:
    """The environment for a timed Python process, with ``extra`` set: a user's Python, which
    writes the modules' bytecode on their first import and reads it after (a shell with
    PYTHONDONTWRITEBYTECODE set would compile cosnet's source at every start)."""
    env = dict(os.environ, **extra)
    env.pop("PYTHONDONTWRITEBYTECODE", None)
    return env


def write_json(script: str, payload: dict):
    """Write payload (with the machine) to SCRIPT.json next to the script, or into the folder
    named by the environment variable COSNET_BENCH_OUT if set (bench/run_all.py sets it for
    quick runs, so they leave the full-size figures in bench/ alone)."""
    path = Path(script).with_suffix(".json")
    if os.environ.get("COSNET_BENCH_OUT"):
        Path(os.environ["COSNET_BENCH_OUT"]).mkdir(parents=True, exist_ok=True)
        path = Path(os.environ["COSNET_BENCH_OUT"]) / path.name
    payload = {"machine": machine(), **payload}
    path.write_text(json.dumps(payload, indent=2))
    print(f"\nwrote {path}")
