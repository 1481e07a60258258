"""Many independent snakes on a frictional ground, the workload PyElastica's GPU port
publishes (rod-steps per second of N 20-element snakes with muscle torques, 1,000 steps): N
copies of the snake of cases/snake.toml with 20 elements, side by side 0.1 m apart, in one
cosnet simulation (one MuscleTorque over all lines, one ground plane, gravity, damping) and in
one PyElastica simulation (bench/snake.py's snake, N times; up to N = 100, PyElastica's cost
being linear in N beyond), both at dt = 1e-4 s (PyElastica's step; cosnet's stable step for
this snake is about the same).

rod-steps/s = N x steps / wall time of the steps (compilation and set-up excluded; best of
rounds, each code timed in turn). cosnet runs with 1 and 2 threads in one process, and as 2
processes of one thread each, N/2 snakes apiece, started together (what a user does with
independent rods on a 2-core machine; rate = N x steps / the slower process's time).

--profile: where a cosnet step spends its time at the largest N (each stage repeated inside
one compiled loop, as bench/profile_step.py).

Usage: python bench/many_snakes.py [--quick] [--profile] [N ...]   writes bench/many_snakes.json
"""

from __future__ import annotations

import math
import multiprocessing
import os
import sys
import time
import warnings

import numpy as np

import cosnet
from cosnet.scene import load_scene
from harness import table, write_json
from snake import CASE, case_numbers, pe_snake, SnakeSim

warnings.filterwarnings("ignore")
import elastica as ea  # noqa: E402

ELEMENTS = 20
DT = 1e-4
STEPS = 1000


def cn_snakes(count, threads):
    """count snakes of the case (ELEMENTS elements each) in one simulation."""
    scene = load_scene(CASE)
    case_line = scene.net.line("snake")
    effects = {type(e).__name__: e for e in scene.effects}
    muscle, ground = effects["MuscleTorque"], effects["Obstacle"]
    net = cosnet.Net()
    length = float(np.linalg.norm(case_line.end.position - case_line.start.position))
    lines = []
    for k in range(count):
        head = net.add_node((0.1 * k, 0.0, length))
        tail = net.add_node((0.1 * k, 0.0, 0.0))
        lines.append(net.add_line(head, tail, material=case_line.material, section=case_line.section,
                                  elements=ELEMENTS, d1=(0.0, 1.0, 0.0)))
    period = 2 * math.pi / muscle.wave[0]
    crowd = cosnet.MuscleTorque(lines=lines, moment=muscle.values[:, 0].tolist(), points=muscle.points.tolist(),
                                direction=muscle.direction, period=period, wavelength=2 * math.pi / muscle.wave[1],
                                ramp_time=muscle.wave[3])
    m_v = case_line.material.density * case_line.section.A * length / ELEMENTS
    floor = cosnet.Obstacle("plane", point=ground.origin, normal=ground.axis, k=ground.k,
                            gamma=2 * math.sqrt(ground.k * m_v), mu_s=ground.mu_s, mu_k=ground.mu_k)
    others = [e for e in scene.effects if not isinstance(e, (cosnet.MuscleTorque, cosnet.Obstacle))]
    return cosnet.Simulation(net, others + [crowd, floor], dt=DT, threads=threads)


def pe_snakes(count):
    c = case_numbers()
    sim = SnakeSim()
    rods = [pe_snake(c, ELEMENTS, sim, x0=0.1 * k)[1] for k in range(count)]
    sim.finalize()
    return sim, rods


def _half(count, rounds, start, out):
    """One of two processes: time count snakes on one thread, each round started with the
    other process's."""
    sim = cn_snakes(count, 1)
    sim.run(steps=STEPS)
    times = []
    for _ in range(rounds):
        start.wait()
        t0 = time.perf_counter()
        sim.run(steps=STEPS)
        times.append(time.perf_counter() - t0)
    out.put(times)


def two_processes(count, rounds):
    """rod-steps/s of count snakes split over two single-threaded processes run at once
    (best round; a round lasts as long as its slower process)."""
    ctx = multiprocessing.get_context("spawn")
    start, out = ctx.Barrier(2), ctx.Queue()
    procs = [ctx.Process(target=_half, args=(n, rounds, start, out)) for n in (count // 2, count - count // 2)]
    for p in procs:
        p.start()
    times = [out.get() for _ in procs]
    for p in procs:
        p.join()
    return count * STEPS / min(max(pair) for pair in zip(*times))


def rate(count, pe_too, rounds):
    """rod-steps/s of cosnet (1 and 2 threads) and PyElastica for count snakes."""
    sims = {f"cosnet {t} thread{'s' if t > 1 else ''}": cn_snakes(count, t) for t in (1, 2)}
    runs = {name: (lambda s=s: s.run(steps=STEPS)) for name, s in sims.items()}
    if pe_too:
        pe, rods = pe_snakes(count)
        stepper, clock = ea.PositionVerlet(), [np.float64(0.0)]

        def pe_run():
            t = clock[0]
            for _ in range(STEPS):
                t = stepper.step(pe, t, np.float64(DT))
            clock[0] = t
        runs["PyElastica"] = pe_run
    best = {name: math.inf for name in runs}
    for fn in runs.values():
        fn()                     # compilation, caches, PyElastica's own warm-up
    for _ in range(rounds):
        for name, fn in runs.items():
            t0 = time.perf_counter()
            fn()
            best[name] = min(best[name], time.perf_counter() - t0)
    finite = all(np.isfinite(s.state.x).all() for s in sims.values())
    rates = {f"rod_steps_per_s[{name}]": count * STEPS / b for name, b in best.items()}
    if count >= 2:
        rates["rod_steps_per_s[cosnet 2 processes]"] = two_processes(count, rounds)
    return {"snakes": count, "steps": STEPS, "dt": DT, "finite": bool(finite), **rates}


def profile(count):
    from numba import njit
    from cosnet.kernels.compose import apply_loads, apply_flows
    from profile_step import best, loop_drift_state, loop_evaluate, loop_internal, loop_kick_state

    @njit
    def loop_one(model, state, loads, eff, k):
        for _ in range(k):
            apply_loads(eff, model, state, loads)

    @njit
    def loop_flows(model, state, eff, h, k):
        for _ in range(k):
            apply_flows(eff, model, state, h)

    sim = cn_snakes(count, 1)
    sim.run(steps=10)
    m, s, l, eff, be = sim.model, sim.state, sim.loads, sim._load_params, sim._backend
    k = max(20, int(2e6 / (count * ELEMENTS)))
    stages = {"evaluate_loads (all loads)": lambda: loop_evaluate(m, s, l, eff, be, k),
              "  internal loads": lambda: loop_internal(m, s, l, k),
              "kick_state": lambda: loop_kick_state(m, s, l, 0.0, be, k),
              "drift_state": lambda: loop_drift_state(m, s, 0.0, be, k)}
    for e, p in zip(sim.effects, sim._params):
        if type(e).stage == "load":
            stages[f"  {type(e).__name__}"] = lambda p=p: loop_one(m, s, l, (p,), k)
        elif type(e).stage == "flow":
            stages[f"flow {type(e).__name__}"] = lambda p=p: loop_flows(m, s, (p,), 0.0, k)
    t_step = best(lambda: sim.run(steps=k), 3) / k
    out = {name: 1e9 * best(fn, 3) / k for name, fn in stages.items()}
    out["whole step (sim.run)"] = 1e9 * t_step
    return out


def main():
    quick = "--quick" in sys.argv
    counts = [int(a) for a in sys.argv[1:] if a.isdigit()] or ([1, 10, 100] if quick else [1, 10, 100, 1000, 3000])
    load0 = os.getloadavg()[0]
    rows = []
    for n in counts:
        rows.append(rate(n, pe_too=n <= 100, rounds=2 if n >= 1000 else 3))
        print(rows[-1], flush=True)
    names = list(dict.fromkeys(k for r in rows for k in r if k.startswith("rod_steps")))
    table(f"{ELEMENTS}-element snakes on frictional ground, {STEPS} steps of {DT} s: rod-steps per second "
          "(best of rounds)", ["snakes"] + [k[len("rod_steps_per_s["):-1] for k in names],
          [[r["snakes"]] + [r.get(k, float("nan")) for k in names] for r in rows])
    payload = {"elements": ELEMENTS, "rows": rows, "quick": quick, "load_average_1min": [load0, os.getloadavg()[0]]}
    if "--profile" in sys.argv:
        prof = profile(counts[-1])
        table(f"ns per step by stage, {counts[-1]} snakes, 1 thread", ["stage", "ns/step", "ns/rod-step"],
              [[k, v, v / counts[-1]] for k, v in prof.items()])
        payload["profile_ns_per_step"] = {"snakes": counts[-1], **prof}
    write_json(__file__, payload)


if __name__ == "__main__":
    main()
