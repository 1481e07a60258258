"""The many snakes of bench/many_snakes.py on two cores, and a long rod on one, this
checkout against an earlier commit's code, in alternation.

    python bench/snakes_against.py REV [N ...] [--no-fastmath KERNEL ...]
        (default N: 100 1000 snakes; KERNEL: module.name under REV's kernels folder)

Snakes: for each N and each code (this checkout, REV), one measurement is a pair of
single-threaded processes started together, N/2 snakes apiece (bench/many_snakes.py's
two-process setting, at PyElastica's step): each builds its snakes with its own code's
bench/many_snakes.cn_snakes, steps them once (compilation, caches), waits until both are
ready, then times ROUNDS runs of STEPS steps and reports its best; the pair's rate is N x
STEPS / the slower process's best. Long rod: one process on one thread, a clamped steel rod
of ROD elements (bench/harness.rod), under gravity, timed the same way (element-steps/s).
The codes alternate, measurement after measurement (this, REV, this, REV, ...), so that a
slow spell of the machine falls on both. REV's code comes from `git worktree` in a temporary
folder, run with a numba cache of its own. Reported: each code's rates (median, spread), the
ratio of medians, and the largest difference between the two codes' vertex positions after
the same steps (0 when they compute bit for bit the same trajectory). Kernels of REV's that
took their fast-math from whichever caller compiled them first (a step: fast-math; a script:
none) are named by --no-fastmath; REV then runs once more with them compiled without it
(numpy's error model, as this code pins its ground contact, kernels/compiler.CACHED_LANES),
and that trajectory is compared too.
Writes bench/snakes_against.json.
"""

from __future__ import annotations

import json
import os
import shutil
import statistics
import subprocess
import sys
import tempfile
from pathlib import Path

from harness import table, write_json

ROOT = Path(__file__).resolve().parents[1]
PAIRS = 5
ROUNDS = 3
STEPS = 1000

ROD = 10_000

# argv: bench folder, workload ("snakes" or "rod"), its size, rounds, steps. Prints "ready"
# once warm, reads a line, times.
CHILD = r"""
import sys, time, json
sys.path.insert(0, sys.argv[1])
kind, size, rounds, steps = sys.argv[2], *(int(a) for a in sys.argv[3:6])
if len(sys.argv) > 6:
    import importlib
    for name in sys.argv[6].split(","):
        module, kernel = name.rsplit(".", 1)
        dispatcher = getattr(importlib.import_module("cosnet.kernels." + module), kernel)
        dispatcher.targetoptions.update(fastmath=False, error_model="numpy")
if kind == "snakes":
    from many_snakes import cn_snakes
    sim = cn_snakes(size, 1)
else:
    import cosnet
    from harness import rod
    sim = cosnet.Simulation(rod(size), effects=[cosnet.Gravity()], threads=1)
sim.run(steps=steps)
print("ready", flush=True)
sys.stdin.readline()
best = float("inf")
for _ in range(rounds):
    t = time.perf_counter()
    sim.run(steps=steps)
    best = min(best, time.perf_counter() - t)
print(json.dumps({"best": best, "x": sim.state.x.tolist()}), flush=True)
"""


def code_tree(rev: str, into: Path) -> dict:
    """A checkout of ``rev`` in ``into`` and the environment that imports its cosnet (the
    package with its kernels folder, as the install maps it) with a numba cache of its own."""
    subprocess.run(["git", "worktree", "add", "--detach", str(into / "tree"), rev], cwd=ROOT, check=True,
                   capture_output=True)
    pkg = into / "pkg"
    pkg.mkdir()
    shutil.copytree(into / "tree" / "cosnet", pkg / "cosnet")
    (pkg / "cosnet" / "kernels").symlink_to(into / "tree" / "kernels")
    return {"bench": str(into / "tree" / "bench"),
            "env": dict(os.environ, PYTHONPATH=str(pkg), NUMBA_CACHE_DIR=str(into / "cache"))}


def measure(code: dict, kind: str, size: int) -> tuple[float, list]:
    """(items x steps per second, positions) of one measurement: for snakes, a pair of
    processes of size/2 snakes each (the rate over the slower one's best, the positions of
    the first); for the rod, one process."""
    sizes = (size // 2, size - size // 2) if kind == "snakes" else (size,)
    pin = [",".join(code["no_fastmath"])] if code.get("no_fastmath") else []
    procs = [subprocess.Popen([sys.executable, "-c", CHILD, code["bench"], kind, str(n), str(ROUNDS), str(STEPS),
                               *pin],
                              env=code["env"], stdin=subprocess.PIPE, stdout=subprocess.PIPE, text=True)
             for n in sizes]
    try:
        for p in procs:
            if p.stdout.readline().strip() != "ready":
                raise RuntimeError(f"a {kind} process failed ({code['bench']})")
        for p in procs:
            p.stdin.write("go\n")
            p.stdin.flush()
        out = [json.loads(p.stdout.readline()) for p in procs]
    finally:
        for p in procs:
            p.kill()
            p.wait()
    return size * STEPS / max(o["best"] for o in out), out[0]["x"]


def largest_difference(x: list, y: list) -> float:
    return max(abs(a - b) for u, v in zip(x, y) for a, b in zip(u, v))


def compare(rev: str, counts: list[int], no_fastmath: list[str]) -> dict:
    with tempfile.TemporaryDirectory() as tmp:
        this = {"bench": str(ROOT / "bench"), "env": dict(os.environ)}
        try:
            earlier = code_tree(rev, Path(tmp))
            pinned = {**earlier, "no_fastmath": no_fastmath,
                      "env": dict(earlier["env"], NUMBA_CACHE_DIR=str(Path(tmp) / "cache-pinned"))}
            rows = []
            for kind, n in [("snakes", n) for n in counts] + [("rod", ROD)]:
                rates: dict = {"this": [], rev: []}
                shift = 0.0
                for _ in range(PAIRS):
                    r_this, x_this = measure(this, kind, n)
                    r_rev, x_rev = measure(earlier, kind, n)
                    rates["this"].append(r_this)
                    rates[rev].append(r_rev)
                    shift = largest_difference(x_this, x_rev)
                med = {k: statistics.median(v) for k, v in rates.items()}
                rows.append({"workload": kind, "size": n, "per_s": rates, "median": med,
                             "spread": {k: (max(v) - min(v)) / min(v) for k, v in rates.items()},
                             "ratio_of_medians": med["this"] / med[rev], "largest_position_difference_m": shift})
                if no_fastmath:   # positions only: its rate is not one of the alternation's
                    rows[-1]["largest_position_difference_no_fastmath_m"] = largest_difference(
                        x_this, measure(pinned, kind, n)[1])
                print(rows[-1], flush=True)
        finally:
            subprocess.run(["git", "worktree", "remove", "--force", str(Path(tmp) / "tree")], cwd=ROOT,
                           capture_output=True)
    return {"against": rev, "no_fastmath": no_fastmath, "pairs": PAIRS, "rounds": ROUNDS, "steps": STEPS,
            "rows": rows}


def main():
    if len(sys.argv) < 2 or sys.argv[1].isdigit():
        raise SystemExit("usage: python bench/snakes_against.py REV [N ...]")
    rev = subprocess.run(["git", "rev-parse", "--short", sys.argv[1]], cwd=ROOT, capture_output=True, text=True,
                         check=True).stdout.strip()
    args = sys.argv[2:]
    cut = args.index("--no-fastmath") if "--no-fastmath" in args else len(args)
    counts = [int(a) for a in args[:cut]] or [100, 1000]
    load0 = os.getloadavg()[0]
    result = compare(rev, counts, args[cut + 1:])
    table(f"rod-steps/s of snakes on two cores, element-steps/s of a rod on one (median of {PAIRS} in "
          f"alternation): this checkout against {rev}",
          ["workload", "this", rev, "ratio", "spread this", f"spread {rev}", "largest |dx| (m)",
           "|dx| no fast-math (m)"],
          [[f"{r['size']} {r['workload']}", r["median"]["this"], r["median"][rev], r["ratio_of_medians"],
            r["spread"]["this"], r["spread"][rev], r["largest_position_difference_m"],
            r.get("largest_position_difference_no_fastmath_m", "-")] for r in result["rows"]])
    write_json(__file__, {**result, "load_average_1min": [load0, os.getloadavg()[0]]})


if __name__ == "__main__":
    main()
