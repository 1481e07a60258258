"""Fast modes: what each ``fast_modes`` setting gains in step and costs in accuracy, side by
side in one process (docs/fast_modes.md quotes bench/fast_modes.json).

Cases:
  cable   steel cable L = 10 m, r = 1 mm, 100 elements, pinned at both ends 9 m apart,
          released at rest in a plane turned 40 degrees sideways from the vertical: wall time
          per simulated second of each setting against "resolve" (measured in alternation),
          the midpoint path over three swing periods against "resolve" at the same mesh
          (largest distance over the swing amplitude), and the lowest five bending
          frequencies of the same line straight and pinned against Euler-Bernoulli
  rod     steel rod L = 1 m, r = 1 mm, 100 elements, clamped-free: stable step (steps per
          simulated second) and the lowest five bending frequencies (discrete modes of the
          treated mass and stiffness, Verlet's frequency error at that step included) against
          Euler-Bernoulli
  stubby  the same rod with r = 10 mm (l = r): the step must not shrink

The midpoint is sampled every 1/30.8 s (240 samples over 7.8 s); the swing period is taken
from the zero crossings of the reference ("resolve") path, and the path error is the largest
over the samples within three periods.

    python bench/fast_modes.py [--quick] [--save-reference FILE.npy | --reference FILE.npy]

--quick: one swing period, fewer rounds. The "resolve" path takes about half an hour (35
million steps); --save-reference keeps it, --reference reuses one saved by an earlier run of
this script with the same --quick setting (it is deterministic: the same code gives the same
path), which bench/fast_modes.json then records.
"""

from __future__ import annotations

import math
import sys
import time
from pathlib import Path

import numpy as np

sys.path.insert(0, str(Path(__file__).resolve().parent))
import cosnet  # noqa: E402
from cosnet.studies.modes import bending_omegas  # noqa: E402
from harness import STEEL, table, write_json  # noqa: E402

SETTINGS = ("resolve", "rotary", "soften", "auto")
CLAMPED_FREE = (1.8751040687, 4.6940911330, 7.8547574382, 10.9955407349, 14.1371683910)


TILT = math.radians(40.0)


def cable_points(L=10.0, span=9.0, tilt=TILT, samples=4001):
    """A sine-shaped sag of arc length L over the span, in the plane turned by tilt."""
    x = np.linspace(0.0, span, samples)
    lo, hi = 0.0, span
    for _ in range(80):
        d = 0.5 * (lo + hi)
        z = d * np.sin(np.pi * x / span)
        lo, hi = (d, hi) if np.sum(np.hypot(np.diff(x), np.diff(z))) < L else (lo, d)
    z = d * np.sin(np.pi * x / span)
    return np.column_stack([x, z * math.sin(tilt), -z * math.cos(tilt)])


def cable(n=100):
    net = cosnet.Net()
    a = net.add_node((0, 0, 0), mass=math.inf, name="a")
    b = net.add_node((9, 0, 0), mass=math.inf, name="b")
    net.add_line(a, b, material=STEEL, section=cosnet.Circle(1e-3), elements=n,
                 points=cable_points(), rest_curvature=(0, 0, 0), name="cable")
    return net


def straight(L, r, n, clamped):
    net = cosnet.Net()
    a = net.add_node((0, 0, 0), fixed=True) if clamped else net.add_node((0, 0, 0), mass=math.inf)
    b = net.add_node((L, 0, 0)) if clamped else net.add_node((L, 0, 0), mass=math.inf)
    net.add_line(a, b, material=STEEL, section=cosnet.Circle(r), elements=n, name="line")
    return net


def bending_errors(net, fm, exact, dt=None):
    """Largest relative error of the lowest bending frequencies (pairs of equal frequencies of
    the round section counted once; torsion and stretch modes skipped) against exact, with
    Verlet's frequency 2 asin(omega dt / 2) / dt at step dt."""
    bend = bending_omegas(cosnet.Simulation(net, fast_modes=fm), len(exact))
    if dt is not None:
        bend = 2.0 * np.arcsin(np.minimum(1.0, 0.5 * bend * dt)) / dt
    return float(np.max(np.abs(bend / exact - 1.0))), (bend / exact - 1.0).tolist()


def eb(betas, L, r):
    c = math.sqrt(STEEL.E * r * r / 4.0 / STEEL.density)
    return np.array([(b / L) ** 2 * c for b in betas])


def midpoint_path(fm, until, samples):
    sim = cosnet.Simulation(cable(), effects=[cosnet.Gravity()], fast_modes=fm)
    mid = cable().lines[0].elements // 2
    out = np.zeros((samples + 1, 3))
    out[0] = sim.line_positions(sim.net.lines[0])[mid]
    t0 = time.perf_counter()
    for k in range(1, samples + 1):
        sim.run(until=until * k / samples)
        out[k] = sim.line_positions(sim.net.lines[0])[mid]
    return out, time.perf_counter() - t0, sim


SAMPLE_DT = 7.8 / 240.0
PERIOD_WINDOW = 2.6           # s simulated per swing period asked for (the period is ~2.57 s)


def swing_period(path) -> float:
    """Twice the mean interval between the sideways (y) zero crossings of a midpoint path
    sampled every SAMPLE_DT."""
    y = path[:, 1]
    t = SAMPLE_DT * np.arange(len(y))
    cross = [t[k] - y[k] * (t[k + 1] - t[k]) / (y[k + 1] - y[k])
             for k in range(len(y) - 1) if y[k] > 0 >= y[k + 1] or y[k] < 0 <= y[k + 1]]
    return 2.0 * float(np.mean(np.diff(cross))) if len(cross) > 2 else 2.0 * cross[0]


def wall_ratio(fm, rounds, steps):
    """Wall time per simulated second of "resolve" over that of fm, per round (alternating),
    and the median wall time per simulated second of each."""
    sims = {s: cosnet.Simulation(cable(), effects=[cosnet.Gravity()], fast_modes=s) for s in ("resolve", fm)}
    for s in sims.values():
        s.run(steps=100)
    ratios, each = [], {name: [] for name in sims}
    for _ in range(rounds):
        per = {}
        for name, s in sims.items():
            t0 = time.perf_counter()
            s.run(steps=steps)
            per[name] = (time.perf_counter() - t0) / (steps * s.dt)
            each[name].append(per[name])
        ratios.append(per["resolve"] / per[fm])
    return ratios, {name: float(np.median(v)) for name, v in each.items()}


def option(argv, name):
    return argv[argv.index(name) + 1] if name in argv else None


def main(argv):
    quick = "--quick" in argv
    periods = 1 if quick else 3
    rounds, steps = (2, 2000) if quick else (5, 5000)
    result = {"periods": periods, "under_load": True}

    # cable: steps, wall time, midpoint path
    samples = int(round(periods * PERIOD_WINDOW / SAMPLE_DT))
    window = samples * SAMPLE_DT
    ref_sim = cosnet.Simulation(cable(), effects=[cosnet.Gravity()], fast_modes="resolve")
    loaded = option(argv, "--reference")
    if loaded:
        ref, ref_wall = np.load(loaded), None
        if ref.shape != (samples + 1, 3):
            raise SystemExit(f"{loaded}: a path of {ref.shape[0]} samples, not {samples + 1} "
                             f"(saved with another --quick setting?)")
    else:
        ref, ref_wall, ref_sim = midpoint_path("resolve", window, samples)
        if option(argv, "--save-reference"):
            np.save(option(argv, "--save-reference"), ref)
    T = swing_period(ref)
    until = periods * T
    within = SAMPLE_DT * np.arange(samples + 1) <= until + 1e-9
    amp = float(np.max(np.abs(ref[within, 1])))
    rows, cab = [], {"swing_period_s": T, "simulated_s": until, "swing_amplitude_m": amp,
                     "sample_interval_s": SAMPLE_DT,
                     "reference": f"loaded from {Path(loaded).name}, saved by an earlier run of this "
                                  f"script" if loaded else "computed in this run"}
    exact_pp = eb([math.pi * k for k in range(1, 6)], 10.0, 1e-3)
    for fm in SETTINGS:
        path, wall, sim = (ref, ref_wall, ref_sim) if fm == "resolve" else midpoint_path(fm, window, samples)
        dev = float(np.max(np.linalg.norm(path - ref, axis=1)[within])) / amp
        if fm == "resolve":
            ratios, per = [1.0], {}
        else:
            ratios, per = wall_ratio(fm, rounds, steps)
            cab["resolve"].setdefault("wall_per_sim_s_rounds", []).append(per["resolve"])
        freq, _ = bending_errors(straight(10.0, 1e-3, 100, clamped=False), fm, exact_pp, sim.dt)
        f = sim.line_factors[0]
        cab[fm] = {"dt": sim.dt, "dt_gain": sim.dt / ref_sim.dt, "wall_ratio_rounds": ratios,
                   "wall_ratio": float(np.median(ratios)), "path_error_over_amplitude": dev,
                   "bending_freq_error": freq, "factors": vars(f) if hasattr(f, "__dict__") else str(f),
                   "wall_s": wall, **({"wall_per_sim_s": per[fm]} if per else {})}
        rows.append([fm, sim.dt, sim.dt / ref_sim.dt, float(np.median(ratios)), dev, freq])
    cab["resolve"]["wall_per_sim_s"] = float(np.median(cab["resolve"]["wall_per_sim_s_rounds"]))
    table(f"cable L = 10 m, r = 1 mm, 100 elements, {periods} swing period(s) of {T:.3g} s (under load)",
          ["setting", "dt (s)", "dt gain", "wall ratio", "path err / amp", "freq err (5 modes)"], rows)
    result["cable"] = cab

    # rods: steps per simulated second at the accuracy of the five lowest bending frequencies
    for name, r in (("rod", 1e-3), ("stubby", 1e-2)):
        exact = eb(CLAMPED_FREE, 1.0, r)
        rows, out = [], {}
        base = None
        for fm in SETTINGS:
            sim = cosnet.Simulation(straight(1.0, r, 100, clamped=True), fast_modes=fm)
            base = base or sim.dt
            err, each = bending_errors(straight(1.0, r, 100, clamped=True), fm, exact, sim.dt)
            out[fm] = {"dt": sim.dt, "steps_per_s": 1.0 / sim.dt, "fewer_steps": sim.dt / base,
                       "bending_freq_error": err, "errors": each}
            rows.append([fm, sim.dt, sim.dt / base, err])
        table(f"{name}: L = 1 m, r = {r * 1e3:g} mm, 100 elements, clamped-free",
              ["setting", "dt (s)", "fewer steps", "freq err (5 modes)"], rows)
        result[name] = out
    write_json(__file__, result)


if __name__ == "__main__":
    main(sys.argv[1:])
