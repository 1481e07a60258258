"""Scaling of cosnet's compiled stepper and the machine's limits.

  1. cost per element-step of a clamped rod from 10^2 to 10^6 elements (one thread; must stay
     flat), measured in one process, best of N;
  2. peak memory per size: a fresh subprocess per size builds the simulation and runs a few
     steps; its peak resident set (VmHWM) minus that of a 100-element rod, per element,
     next to the bytes of the model/state/loads arrays per element;
  3. nets of 100, 1,000 and 10,000 lines x 10 elements, as a chain (point junctions of two
     lines) and as a truss (a Pratt truss, junctions of 3-5 lines), 1 and 2 threads; a
     100,000-element single rod on 1 and 2 threads (full run only);
  4. start-up: `cosnet run cases/bridge.toml --until 1e-4` in a subprocess with an empty
     NUMBA_CACHE_DIR (compiles everything) and again with the cache it left (loads it);
  5. the machine: memory bandwidth (numpy copy, compiled triad on 1 and 2 threads),
     floating-point rate (numpy matmul) and what a second thread gains on arithmetic in cache,
     against which the stepper's rate and thread speed-up are set.

Usage: python bench/scaling.py [--quick]        writes bench/scaling.json
"""

from __future__ import annotations

import copy
import resource
import os
import subprocess
import sys
import tempfile
import time
from pathlib import Path

import numba
import numpy as np

import cosnet
from cosnet.engine.simulation import backend_for
from harness import best_interleaved, best_of, chain, python_env, rod, table, write_json

HERE = Path(__file__).resolve().parent
ROOT = HERE.parent
STEEL = cosnet.Material(E=2.1e11, G=8.1e10, density=7850.0)
# element-steps per timed run, and runs per case (best of; many short runs, since the machine
# is shared and a short run more often finds it quiet)
TARGET = 5e5
REPEAT = {True: 8, False: 15}


# --------------------------------------------------------------------------- nets
def truss(lines, per=10, panel=0.5, height=0.5):
    """A Pratt truss of about ``lines`` lines (4 per panel: bottom and top chords, a post, a
    diagonal; plus the closing post), both bottom ends fixed."""
    panels = max(1, (lines - 1) // 4)
    net = cosnet.Net()
    sec = cosnet.Circle(0.01)
    bot = [net.add_node((panel * k, 0, 0), fixed=k in (0, panels)) for k in range(panels + 1)]
    top = [net.add_node((panel * k, 0, height)) for k in range(panels + 1)]
    add = lambda a, b: net.add_line(a, b, material=STEEL, section=sec, elements=per)
    for k in range(panels):
        add(bot[k], bot[k + 1])
        add(top[k], top[k + 1])
        add(bot[k], top[k])
        add(bot[k], top[k + 1]) if k < panels // 2 else add(top[k], bot[k + 1])
    add(bot[panels], top[panels])
    return net


def array_bytes(sim):
    return sum(a.nbytes for part in (sim.model, sim.state, sim.loads) for a in part)


# --------------------------------------------------------------------------- 1. per element-step
def rod_sizes(quick):
    """Build every size first, then time them round-robin (best of N each), so that a change
    of the machine's load during the run hits all sizes alike."""
    sizes = [100, 1_000, 10_000, 100_000] + ([] if quick else [1_000_000])
    sims, builds = [], []
    for n in sizes:
        t0 = time.perf_counter()
        sims.append(cosnet.Simulation(rod(n), effects=[cosnet.Gravity()], threads=1))
        builds.append(time.perf_counter() - t0)
        sims[-1].run(steps=2)
    steps = [max(3, int(TARGET / n)) for n in sizes]
    best = [np.inf] * len(sizes)
    wall = [np.inf] * len(sizes)
    for _ in range(REPEAT[quick]):
        for k, sim in enumerate(sims):
            c0, t0 = time.thread_time(), time.perf_counter()
            sim.run(steps=steps[k])
            best[k] = min(best[k], time.thread_time() - c0)
            wall[k] = min(wall[k], time.perf_counter() - t0)
    out = []
    for n, sim, s, t, w, b in zip(sizes, sims, steps, best, wall, builds):
        out.append({"case": f"rod {n:,}", "elements": n, "threads": 1, "steps": s,
                    "us_per_step": 1e6 * t / s, "ns_per_element_step": 1e9 * t / (s * n),
                    "element_steps_per_s": s * n / t, "wall_us_per_step": 1e6 * w / s, "build_s": b,
                    "array_bytes_per_element": array_bytes(sim) / n})
    return out


# --------------------------------------------------------------------------- 2. peak memory
CHILD = """
import sys
sys.path.insert(0, {here!r})
import cosnet
from scaling import rod, array_bytes
n = int(sys.argv[1])
sim = cosnet.Simulation(rod(n), effects=[cosnet.Gravity()], threads=1)
sim.run(steps=3)
# peak resident set of this process (VmHWM; ru_maxrss would carry the parent's over fork)
hwm = [l for l in open("/proc/self/status") if l.startswith("VmHWM")][0]
print(int(hwm.split()[1]) * 1024, array_bytes(sim))
"""


def peak_memory(sizes):
    code = CHILD.format(here=str(HERE))
    env = dict(os.environ)
    out = {}
    for n in [100] + list(sizes):
        res = subprocess.run([sys.executable, "-c", code, str(n)], capture_output=True, text=True,
                             env=env, cwd=str(HERE))
        if res.returncode:
            raise RuntimeError(res.stderr[-2000:])
        rss, arr = map(int, res.stdout.split()[-2:])
        out[n] = (rss, arr)
    base = out[100][0]
    return [{"elements": n, "peak_rss_bytes": out[n][0], "rss_over_base_bytes": out[n][0] - base,
             "rss_bytes_per_element": (out[n][0] - base) / n,
             "array_bytes_per_element": out[n][1] / n} for n in sizes]


# --------------------------------------------------------------------------- 3. nets, threads
def with_threads(sim, threads):
    """The same simulation stepped on ``threads`` threads: shares the flattened arrays, so a
    big net is flattened once for both thread counts (Simulation(..., threads=k) would pick
    the same backend)."""
    twin = copy.copy(sim)
    twin.threads = threads
    twin.backend = backend_for(sim.model, threads)
    twin._new_step_table()   # the original's slots hold the kernels of its own backend
    return twin


def steps_per_call(ne):
    """Steps per run() call: enough that the call's own work (it hashes the state at its
    start and scans it for non-finite values at its end: 2-3 ms on 10^5 elements, serial)
    stays a small part of what is timed, as in a long run (printed separately as the cost
    of run(steps=1))."""
    return max(100, int(TARGET / ne))


def nets(quick):
    """Each net built once; its 1- and 2-thread runs are timed alternately (best of N)."""
    out = []
    sizes = [100, 1_000] + ([] if quick else [10_000])
    for kind, build in (("chain", chain), ("truss", truss)):
        for lines in sizes:
            t0 = time.perf_counter()
            sim1 = cosnet.Simulation(build(lines), effects=[cosnet.Gravity()], threads=1)
            build_s = time.perf_counter() - t0
            ne = sim1.net.element_count
            sims = [sim1] + ([with_threads(sim1, 2)] if ne >= 5_000 else [])
            steps = steps_per_call(ne)
            best = [np.inf] * len(sims)
            cpu = [np.inf] * len(sims)
            for s in sims:
                s.run(steps=2)
            for _ in range(REPEAT[quick]):
                for k, s in enumerate(sims):
                    c0, t0 = time.thread_time(), time.perf_counter()
                    s.run(steps=steps)
                    best[k] = min(best[k], time.perf_counter() - t0)
                    cpu[k] = min(cpu[k], time.thread_time() - c0)
            for s, t, c in zip(sims, best, cpu):
                out.append({"case": f"{kind} {len(s.net.lines):,} x 10", "elements": ne,
                            "threads": s.threads, "steps": steps, "us_per_step": 1e6 * t / steps,
                            "ns_per_element_step": 1e9 * t / (steps * ne),
                            "element_steps_per_s": steps * ne / t, "build_s": build_s,
                            "cpu_ns_per_element_step": 1e9 * c / (steps * ne)})
    return out


def big_rod_threads(quick):
    """A single long line: the line loop has one task, only the vertex/element loops split."""
    n = 100_000
    sim1 = cosnet.Simulation(rod(n), effects=[cosnet.Gravity()], threads=1)
    sims = [sim1, with_threads(sim1, 2)]
    steps = steps_per_call(n)
    best = best_interleaved([lambda s=s: s.run(steps=steps) for s in sims], REPEAT[quick])
    return [{"case": f"rod {n:,}", "elements": n, "threads": s.threads, "steps": steps,
             "load_average_1min": os.getloadavg()[0],
             "us_per_step": 1e6 * t / steps, "ns_per_element_step": 1e9 * t / (steps * n),
             "element_steps_per_s": steps * n / t} for s, t in zip(sims, best)]


# --------------------------------------------------------------------------- 4. start-up
def _child_cpu():
    r = resource.getrusage(resource.RUSAGE_CHILDREN)
    return r.ru_utime + r.ru_stime


def startup():
    """Wall and CPU seconds (user + system of the subprocess: on a loaded machine the wall
    time stretches, the CPU time much less) of a short scene run from a cold and a warm cache."""
    scene = ROOT / "cases" / "bridge.toml"
    times = {}
    with tempfile.TemporaryDirectory() as tmp:
        env = python_env(NUMBA_CACHE_DIR=str(Path(tmp) / "cache"))
        runs = [("cold (empty cache)", ["-m", "cosnet.cli", "run", str(scene), "--out",
                                        str(Path(tmp) / "out"), "--until", "1e-4", "--overwrite"])]
        runs += [(label, runs[0][1]) for label in ("warm (cache)", "warm again")]
        runs += [("python + import cosnet", ["-c", "import cosnet"])]
        for label, args in runs:
            c0, t0 = _child_cpu(), time.perf_counter()
            res = subprocess.run([sys.executable, *args], env=env, capture_output=True, text=True, cwd=tmp)
            times[label] = {"wall_s": time.perf_counter() - t0, "cpu_s": _child_cpu() - c0}
            if res.returncode:
                raise RuntimeError(res.stderr[-2000:])
    return times


# --------------------------------------------------------------------------- 5. machine
@numba.njit(cache=True)
def _triad(a, b, c, s):
    for i in range(a.shape[0]):
        a[i] = b[i] + s * c[i]


@numba.njit(cache=True, parallel=True)
def _triad_par(a, b, c, s):
    for i in numba.prange(a.shape[0]):
        a[i] = b[i] + s * c[i]


@numba.njit(cache=True, fastmath=True)
def _arith(a, rounds):
    """Update a in place by rounds of a polynomial per entry: arithmetic only, in L1."""
    for _ in range(rounds):
        for i in range(a.shape[0]):
            x = a[i]
            a[i] = ((0.25 * x - 0.5) * x + 0.75) * x + 0.125


@numba.njit(cache=True, parallel=True)
def _arith_par(a, rounds):
    """As _arith, on two halves of a, one per thread."""
    half = a.shape[0] // 2
    for k in numba.prange(2):
        _arith(a[k * half:(k + 1) * half], rounds)


def machine_limits(quick):
    n = 10_000_000 if quick else 20_000_000
    a, b, c = np.zeros(n), np.random.rand(n), np.random.rand(n)
    t_copy = best_of(lambda: np.copyto(a, b), 5)
    t_tri1 = best_of(lambda: _triad(a, b, c, 3.0), 5)
    numba.set_num_threads(numba.config.NUMBA_NUM_THREADS)
    t_tri2 = best_of(lambda: _triad_par(a, b, c, 3.0), 5)
    # in-cache arithmetic on 1 and 2 threads (2 x 2,048 doubles: 16 KiB per core): the most
    # any loop can gain from a second thread here, memory not involved. Sampled in alternating
    # pairs, since what the second core delivers on this machine varies from moment to moment.
    w, rounds = np.random.rand(4096), 20_000
    pairs = []
    for _ in range(5 if quick else 9):
        pairs.append(best_interleaved([lambda: (_arith(w[:2048], rounds), _arith(w[2048:], rounds)),
                                       lambda: _arith_par(w, rounds)], 3))
    arith_speedup = sorted(t1 / t2 for t1, t2 in pairs)
    m = 1000 if quick else 2000
    x, y = np.random.rand(m, m), np.random.rand(m, m)
    t_mm = best_of(lambda: x @ y, 3)
    return {"copy_GBps": 2 * 8 * n / t_copy / 1e9, "triad_1thread_GBps": 3 * 8 * n / t_tri1 / 1e9,
            "triad_2threads_GBps": 3 * 8 * n / t_tri2 / 1e9, "triad_1thread_Gflops": 2 * n / t_tri1 / 1e9,
            "matmul_Gflops": 2 * m ** 3 / t_mm / 1e9,
            "arith_in_cache_Gflops_1thread": [6 * 4096 * rounds / t1 / 1e9 for t1, _ in pairs],
            "arith_in_cache_2thread_speedup": arith_speedup, "matmul_size": m, "array_doubles": n}


def _span(xs):
    return f"{min(xs):.3g}-{max(xs):.3g}"


def _spread(xs):
    return f"{min(xs):.2f}, {float(np.median(xs)):.2f}, {max(xs):.2f}"


# --------------------------------------------------------------------------- main
def main():
    quick = "--quick" in sys.argv
    load0 = os.getloadavg()[0]
    rods = rod_sizes(quick)
    table("Cost per element-step, clamped rod, Verlet + gravity, 1 thread (one process, best of N; "
          "CPU time of the stepping thread, wall alongside)",
          ["case", "elements", "steps", "us/step (CPU)", "ns/element-step", "element-steps/s",
           "us/step (wall)", "build (s)"],
          [[r["case"], r["elements"], r["steps"], r["us_per_step"], r["ns_per_element_step"],
            r["element_steps_per_s"], r["wall_us_per_step"], r["build_s"]] for r in rods])
    flat = [r["ns_per_element_step"] for r in rods if r["elements"] >= 1000]
    print(f"ns/element-step, 10^3..10^6: min {min(flat):.3g}, max {max(flat):.3g} "
          f"(max/min {max(flat) / min(flat):.2f})")

    mem_sizes = [1_000, 10_000, 100_000] + ([] if quick else [1_000_000])
    mem = peak_memory(mem_sizes)
    table("Peak memory (fresh subprocess per size, VmHWM; minus that of a 100-element rod)",
          ["elements", "peak RSS (MB)", "RSS over base (MB)", "RSS bytes/element", "array bytes/element"],
          [[m["elements"], m["peak_rss_bytes"] / 1e6, m["rss_over_base_bytes"] / 1e6,
            m["rss_bytes_per_element"], m["array_bytes_per_element"]] for m in mem])

    netr = nets(quick) + big_rod_threads(quick)
    table("Nets of lines x 10 elements (and a 10^5-element rod), 1 vs 2 threads (wall; CPU for 1 thread)",
          ["case", "elements", "threads", "us/step", "ns/element-step", "element-steps/s",
           "CPU ns/element-step"],
          [[r["case"], r["elements"], r["threads"], r["us_per_step"], r["ns_per_element_step"],
            r["element_steps_per_s"], r.get("cpu_ns_per_element_step", "")] for r in netr])
    speedups = {}
    for r1 in netr:
        if r1["threads"] == 1:
            r2 = [r for r in netr if r["case"] == r1["case"] and r["threads"] == 2]
            if r2:
                speedups[r1["case"]] = r2[0]["element_steps_per_s"] / r1["element_steps_per_s"]
    table("2 threads vs 1", ["case", "speed-up"], [[k, v] for k, v in speedups.items()])

    start = startup()
    table("Start-up: `cosnet run cases/bridge.toml --until 1e-4` (wall, subprocess)",
          ["run", "wall (s)", "CPU (s)"], [[k, v["wall_s"], v["cpu_s"]] for k, v in start.items()])

    lim = machine_limits(quick)     # last: its 2-thread triad starts the thread pool
    best1 = max(r["element_steps_per_s"] for r in rods)
    bpe = rods[-1]["array_bytes_per_element"]
    implied = best1 * bpe / 1e9
    table("Machine limits", ["quantity", "value"],
          [["numpy copy bandwidth (GB/s)", lim["copy_GBps"]],
           ["compiled triad, 1 thread (GB/s)", lim["triad_1thread_GBps"]],
           ["compiled triad, 2 threads (GB/s)", lim["triad_2threads_GBps"]],
           [f"numpy matmul {lim['matmul_size']}^2 (Gflop/s)", lim["matmul_Gflops"]],
           ["in-cache arithmetic, 1 thread (Gflop/s, range)", _span(lim["arith_in_cache_Gflops_1thread"])],
           ["in-cache arithmetic, 2 threads vs 1 (min, median, max)", _spread(lim["arith_in_cache_2thread_speedup"])],
           ["stepper best element-steps/s, 1 thread", best1],
           ["model+state+loads bytes per element", bpe],
           ["implied traffic if every byte is touched once per step (GB/s)", implied]])
    write_json(__file__, {"quick": quick, "rod_sizes": rods, "memory": mem, "nets": netr,
                          "thread_speedup": speedups, "startup_s": start, "machine_limits": lim,
                          "load_average_1min": [load0, os.getloadavg()[0]]})
    print(f"1-minute load average at start and end: {load0:.2f}, {os.getloadavg()[0]:.2f} "
          f"(cores: {os.cpu_count()})")


if __name__ == "__main__":
    main()
