"""Long undamped run of a free net (1e6 steps at the automatic step): the envelope of the
relative energy error over time (Verlet: a bounded band, no drift) and the momentum errors.

Usage: python bench/long_run.py [steps]   (default 1,000,000). Writes bench/long_run.json."""

from __future__ import annotations

import sys
import time
from pathlib import Path

import numpy as np

HERE = Path(__file__).resolve().parent
sys.path[:0] = [str(HERE), str(HERE.parent / "tests"), str(HERE.parent / "tests" / "hard")]

from harness import table, write_json  # noqa: E402
from test_long_run import energy_envelope, start_long_run  # noqa: E402


def main(steps: int = 1_000_000, windows: int = 100):
    sim = start_long_run()
    p0, l0 = sim.momentum(), sim.angular_momentum()
    scale_p = np.abs(sim.state.v).sum(axis=1) @ sim.model.vertex_mass + np.abs(p0).sum()
    t0 = time.perf_counter()
    env = energy_envelope(sim, steps, windows)
    wall = time.perf_counter() - t0
    dp = float(np.abs(sim.momentum() - p0).max() / scale_p)
    dl = float(np.abs(sim.angular_momentum() - l0).max() / np.abs(l0).max())
    unit = float(np.abs(np.linalg.norm(sim.state.q, axis=1) - 1).max())
    per = steps // windows
    rows, records = [], []
    for k in range(0, windows, max(1, windows // 10)):
        block = env[k:k + max(1, windows // 10)]
        lo, hi = float(block[:, 0].min()), float(block[:, 1].max())
        start, end = k * per, (k + len(block)) * per
        rows.append([f"{start:,}-{end:,}", f"{start * sim.dt:.4g}-{end * sim.dt:.4g}", lo, hi, hi - lo])
        records.append({"steps": [start, end], "time": [start * sim.dt, end * sim.dt],
                        "error_min": lo, "error_max": hi})
    table(f"Energy error envelope, {sim.net.element_count} elements, dt = {sim.dt:.4g} s, "
          f"{steps:,} steps ({wall:.1f} s wall)",
          ["steps", "time (s)", "min rel. error", "max rel. error", "band"], rows)
    print(f"\nmomentum error {dp:.3g} (of its scale), angular momentum error {dl:.3g} (relative), "
          f"max ||q| - 1| {unit:.3g}")
    write_json(__file__, {"steps": steps, "dt": sim.dt, "elements": sim.net.element_count,
                          "wall_s": wall, "envelope": records, "momentum_error": dp,
                          "angular_momentum_error": dl, "quaternion_unit_error": unit,
                          "max_abs_energy_error": float(np.abs(env).max())})


if __name__ == "__main__":
    main(int(sys.argv[1]) if len(sys.argv) > 1 else 1_000_000)
