"""Soak: long runs that write frames and checkpoints, watched for leaks and growth.

    python bench/soak.py [--steps N] [--every M] [CASE ...]     (default: 10^7 steps, a frame
                                                                 and a checkpoint every 10^5,
                                                                 the cases bridge and contact)

Each case runs in a process of its own (one thread each, side by side on two cores) through
``Simulation.run(until, out=..., every=...)``, the path of ``cosnet run``: a VTK frame, a
probes row and a checkpoint at every output. After every frame it records the process's
resident memory (VmRSS), its open file descriptors and the net's total energy. A run that
leaks shows memory or descriptors climbing with the frames; one that goes wrong shows the
energy growing (the watch would stop it). The figures go to soak.json and the table of
docs/faults.md (bench/tables.py).
"""

from __future__ import annotations

import argparse
import os
import sys
import tempfile
import time
from concurrent.futures import ProcessPoolExecutor
from pathlib import Path

sys.path.insert(0, str(Path(__file__).resolve().parent))


def resident_mb() -> float:
    with open("/proc/self/status") as f:
        for line in f:
            if line.startswith("VmRSS:"):
                return int(line.split()[1]) / 1024
    return float("nan")


def open_files() -> int:
    return len(os.listdir("/proc/self/fd"))


def soak(case: str, steps: int, every: int) -> dict:
    """One case run for ``steps`` steps with output every ``every`` steps; per frame (step,
    simulated time, wall s, resident MB, open descriptors, energy J) and a summary."""
    from cosnet import load_scene
    from cosnet.scene.cases import scene_path
    scene = load_scene(scene_path(case))
    sim = scene.simulation(threads=1)
    rows = []
    t0 = time.perf_counter()

    def watch(s):
        rows.append([s.steps, s.time,
                     time.perf_counter() - t0, resident_mb(), open_files(), s.energy()])
    with tempfile.TemporaryDirectory() as out:
        sim.run(until=sim.time + steps * sim.dt, out=Path(out) / "run", every=every * sim.dt, callback=watch)
    wall = time.perf_counter() - t0
    settled = rows[min(10, len(rows) - 1):]            # after the first frames' allocations
    half = rows[len(rows) // 2:]
    energies = [r[5] for r in rows]
    return dict(case=case, steps=steps, every=every, dt=sim.dt, frames=len(rows), wall_s=wall,
                steps_per_s=steps / wall,
                rss_mb_at_frame_10=settled[0][3], rss_mb_last=rows[-1][3],
                rss_mb_max=max(r[3] for r in rows), rss_growth_mb=rows[-1][3] - settled[0][3],
                open_files_min=min(r[4] for r in rows), open_files_max=max(r[4] for r in rows),
                energy_first=energies[0], energy_max=max(energies), energy_last=energies[-1],
                energy_max_second_half=max(r[5] for r in half),
                rows=rows)


def main(argv=None) -> int:
    from harness import write_json
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("cases", nargs="*", default=["bridge", "contact"])
    ap.add_argument("--steps", type=int, default=10_000_000)
    ap.add_argument("--every", type=int, default=100_000)
    args = ap.parse_args(argv)
    load0 = os.getloadavg()[0]
    t0 = time.time()
    with ProcessPoolExecutor(max_workers=min(2, len(args.cases))) as pool:
        runs = list(pool.map(soak, args.cases, [args.steps] * len(args.cases), [args.every] * len(args.cases)))
    for r in runs:
        print(f"{r['case']}: {r['steps']:,} steps, {r['frames']} frames in {r['wall_s']:.0f} s; resident "
              f"{r['rss_mb_at_frame_10']:.0f} -> {r['rss_mb_last']:.0f} MB; open files "
              f"{r['open_files_min']}-{r['open_files_max']}; energy {r['energy_first']:.4g} -> "
              f"{r['energy_last']:.4g} J (max {r['energy_max']:.4g}, second half {r['energy_max_second_half']:.4g})")
    write_json(__file__, dict(runs=runs, started=time.strftime("%Y-%m-%d %H:%M", time.gmtime(t0)),
                              load_before=load0, load_after=os.getloadavg()[0],
                              command="python bench/soak.py " + " ".join(argv or sys.argv[1:])))
    return 0


if __name__ == "__main__":
    sys.exit(main())
