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

Longer steps: the snake's stable step is set by its sections' rotation against the shear
stiffness, a motion the crawl does not depend on. With the rotary inertia x ROTARY (the
damping's rotational rate divided by it, so that the damping torque, mass-proportional, stays
PyElastica's) cosnet's stable step is 3.2 times longer and the crawl the same to the accuracy
accuracy() measures: the mean velocity of a snake's centre of mass (4 s to 10 s) against a
resolved run at dt / 4. Those runs ("x16 rotary") are timed beside the others, and every
rate is also given as simulated rod-seconds per wall second (rod-steps/s times the step):
the GPU's 7e5 rod-steps/s at 1e-4 s are 70 rod-s/s.

--profile: where a cosnet step spends its time at 100 snakes, or at the largest N when 100
is not among them (each stage repeated inside one compiled loop, as bench/profile_step.py).

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
from cosnet.scene.loader import load_scene
from harness import table, write_json
from snake import CASE, case_numbers, pe_snake, SnakeSim

warnings.filterwarnings("ignore")
import elastica as ea  # noqa: E402

ELEMENTS = 20
DT = 1e-4
STEPS = 1000
ROTARY = 16.0
GPU_ROD_S_PER_S = 7e5 * DT


def cn_snakes(count, threads, rotary=1.0, dt=None):
    """count snakes of the case (ELEMENTS elements each) in one simulation, their rotary
    inertia scaled by rotary (and the damping's rotational rate divided by it), at dt (DT for
    the resolved snakes, the stable step for scaled ones, unless given)."""
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
                                  elements=ELEMENTS, d1=(0.0, 1.0, 0.0), rotary_inertia_scale=rotary))
    period = 2 * math.pi / muscle.wave[0]
    crowd = cosnet.MuscleTorque(lines=lines, moment=muscle.values[:, 0].tolist(), points=muscle.points.tolist(),
                                direction=muscle.direction, period=period, wavelength=2 * math.pi / muscle.wave[1],
                                ramp_time=muscle.wave[3])
    m_v = case_line.material.density * case_line.section.A * length / ELEMENTS
    floor = cosnet.Obstacle("plane", point=ground.origin, normal=ground.axis, k=ground.k,
                            gamma=2 * math.sqrt(ground.k * m_v), mu_s=ground.mu_s, mu_k=ground.mu_k)
    damping = effects["Damping"]
    others = [e for e in scene.effects if not isinstance(e, (cosnet.MuscleTorque, cosnet.Obstacle, cosnet.Damping))]
    others.append(cosnet.Damping(damping.translational, damping.rotational / rotary))
    if dt is None and rotary == 1.0:
        dt = DT
    return cosnet.Simulation(net, others + [crowd, floor], dt=dt, threads=threads)


def pe_snakes(count):
    c = case_numbers()
    sim = SnakeSim()
    rods = [pe_snake(c, ELEMENTS, sim, x0=0.1 * k)[1] for k in range(count)]
    sim.finalize()
    return sim, rods


def _half(count, rotaries, rounds, start, out):
    """One of two processes: time count snakes on one thread for each rotary inertia scale in
    turn, round after round, each timing started with the other process's (alternation: a
    slow spell of the machine falls on both variants, not on one)."""
    sims = [cn_snakes(count, 1, r) for r in rotaries]
    for sim in sims:
        sim.run(steps=STEPS)
    times = [[] for _ in sims]
    for _ in range(rounds):
        for sim, t in zip(sims, times):
            start.wait()
            t0 = time.perf_counter()
            sim.run(steps=STEPS)
            t.append(time.perf_counter() - t0)
    out.put(times)


def two_processes(count, rounds, rotaries=(1.0, ROTARY)):
    """For each rotary scale: (rod-steps/s, spread) of count snakes split over two
    single-threaded processes run at once, the scales timed in alternation; the rate is the
    best round's (a round lasts as long as its slower process), the spread (worst - best) /
    best over the rounds."""
    ctx = multiprocessing.get_context("spawn")
    start, out = ctx.Barrier(2), ctx.Queue()
    procs = [ctx.Process(target=_half, args=(n, rotaries, rounds, start, out))
             for n in (count // 2, count - count // 2)]
    for p in procs:
        p.start()
    times = [out.get() for _ in procs]
    for p in procs:
        p.join()
    result = []
    for k in range(len(rotaries)):
        rounds_wall = [max(pair) for pair in zip(times[0][k], times[1][k])]
        result.append((count * STEPS / min(rounds_wall), (max(rounds_wall) - min(rounds_wall)) / min(rounds_wall)))
    return result


def rate(count, pe_too, rounds):
    """rod-steps/s of cosnet (1 and 2 threads; 1 thread with the rotary inertia x ROTARY) and
    PyElastica for count snakes; and each as rod-seconds simulated per wall second."""
    sims = {f"cosnet {t} thread{'s' if t > 1 else ''}": cn_snakes(count, t) for t in (1, 2)}
    sims[f"cosnet 1 thread x{ROTARY:g} rotary"] = cn_snakes(count, 1, ROTARY)
    runs = {name: (lambda s=s: s.run(steps=STEPS)) for name, s in sims.items()}
    step = {name: s.dt for name, s in sims.items()}
    if pe_too:
        pe, rods = pe_snakes(count)
        stepper, clock = ea.PositionVerlet(), [np.float64(0.0)]

        def pe_run():
            t = clock[0]
            for _ in range(STEPS):
                t = stepper.step(pe, t, np.float64(DT))
            clock[0] = t
        runs["PyElastica"], step["PyElastica"] = pe_run, DT
    walls: dict = {name: [] for name in runs}
    for fn in runs.values():
        fn()                     # compilation, caches, PyElastica's own warm-up
    for _ in range(rounds):      # in alternation
        for name, fn in runs.items():
            t0 = time.perf_counter()
            fn()
            walls[name].append(time.perf_counter() - t0)
    finite = all(np.isfinite(s.state.x).all() for s in sims.values())
    rates = {name: count * STEPS / min(w) for name, w in walls.items()}
    spread = {name: (max(w) - min(w)) / min(w) for name, w in walls.items()}
    if count >= 2:
        (plain, spread["cosnet 2 processes"]), (scaled, spread[f"cosnet 2 processes x{ROTARY:g} rotary"]) = \
            two_processes(count, rounds)
        rates["cosnet 2 processes"], rates[f"cosnet 2 processes x{ROTARY:g} rotary"] = plain, scaled
        step["cosnet 2 processes"] = DT
        step[f"cosnet 2 processes x{ROTARY:g} rotary"] = step[f"cosnet 1 thread x{ROTARY:g} rotary"]
    return {"snakes": count, "steps": STEPS, "dt": step, "finite": bool(finite),
            **{f"rod_steps_per_s[{name}]": r for name, r in rates.items()},
            **{f"rod_s_per_s[{name}]": r * step[name] for name, r in rates.items()},
            **{f"spread[{name}]": v for name, v in spread.items()}}


def accuracy(rotary=ROTARY, until=10.0, settle=4.0):
    """The mean velocity of one snake's centre of mass from settle to until: resolved at DT,
    with the rotary inertia x rotary at its stable step, and the reference (resolved, DT / 4);
    each run's difference from the reference as a fraction of the reference's forward speed."""
    runs = {"resolved, dt = 1e-4": cn_snakes(1, 1), f"x{rotary:g} rotary, stable step": cn_snakes(1, 1, rotary),
            "reference: resolved, dt = 2.5e-5": cn_snakes(1, 1, dt=DT / 4)}
    out = {}
    for name, sim in runs.items():
        w = sim.model.vertex_mass / sim.model.vertex_mass.sum()
        sim.run(until=settle)
        start = w @ sim.state.x
        sim.run(until=until)
        out[name] = {"dt": sim.dt, "velocity": ((w @ sim.state.x - start) / (sim.time - settle)).tolist()}
    ref = np.array(out["reference: resolved, dt = 2.5e-5"]["velocity"])
    for row in out.values():
        row["error_of_forward_speed"] = float(np.linalg.norm(np.array(row["velocity"]) - ref) / ref[2])
    return out


def profile(count):
    from numba import njit
    from cosnet.kernels.compose import KERNELS
    from cosnet.kernels.layout import typed_call
    from profile_step import best, loop_drift_state, loop_evaluate, loop_internal, loop_kick_state

    @njit
    def loop_one(kernel, model, state, last, eff, k):
        for _ in range(k):
            kernel(eff, model, state, last)

    sim = cn_snakes(count, 1)
    sim.run(steps=10)
    m, s, l, eff, be = sim.model, sim.state, sim.loads, sim.step_table, sim.backend
    k = max(20, int(2e6 / (count * ELEMENTS)))
    # typed as the step types the records (typed_call): through numba's own dispatch the loads
    # would call the step's slot kernels with other types, which their keys refuse
    stages = {"evaluate_loads (all loads)": lambda: typed_call(loop_evaluate, m, s, l, eff, be, k),
              "  internal loads": lambda: typed_call(loop_internal, m, s, l, k),
              "kick_state": lambda: typed_call(loop_kick_state, m, s, l, 0.0, be, k),
              "drift_state": lambda: typed_call(loop_drift_state, m, s, 0.0, be, k)}
    for e, p in zip(sim.effects, sim.records):
        if type(e).stage == "load":
            stages[f"  {type(e).__name__}"] = lambda p=p: loop_one(KERNELS[type(p)], m, s, l, p, k)
        elif type(e).stage == "flow":
            stages[f"flow {type(e).__name__}"] = lambda p=p: loop_one(KERNELS[type(p)], m, s, 0.0, p, k)
    t_step = best(lambda: sim.run(steps=k), 3) / k
    out = {name: 1e9 * best(fn, 3) / k for name, fn in stages.items()}
    out["whole step (sim.run)"] = 1e9 * t_step
    return out


def main():
    quick = "--quick" in sys.argv
    counts = [int(a) for a in sys.argv[1:] if a.isdigit()] or ([1, 10, 100] if quick else [1, 10, 100, 1000, 3000])
    load0 = os.getloadavg()[0]
    acc = accuracy()
    table("One snake's crawl, mean velocity of the centre of mass from 4 s to 10 s",
          ["run", "dt (s)", "forward (m/s)", "sideways (m/s)", "error / forward speed"],
          [[name, r["dt"], r["velocity"][2], r["velocity"][0], r["error_of_forward_speed"]] for name, r in acc.items()])
    rows = []
    for n in counts:
        rows.append(rate(n, pe_too=n <= 100, rounds=2 if n >= 1000 else 3))
        print(rows[-1], flush=True)
    for unit, title in (("rod_steps_per_s", "rod-steps per second"),
                        ("rod_s_per_s", f"rod-seconds simulated per second (the GPU: {GPU_ROD_S_PER_S:g})")):
        names = list(dict.fromkeys(k for r in rows for k in r if k.startswith(unit + "[")))
        table(f"{ELEMENTS}-element snakes on frictional ground, {STEPS} steps: {title} (best of rounds)",
              ["snakes"] + [k[len(unit) + 1:-1] for k in names],
              [[r["snakes"]] + [r.get(k, float("nan")) for k in names] for r in rows])
    payload = {"elements": ELEMENTS, "accuracy": acc, "rows": rows, "quick": quick,
               "load_average_1min": [load0, os.getloadavg()[0]]}
    if "--profile" in sys.argv:
        at = 100 if 100 in counts else counts[-1]
        prof = profile(at)
        table(f"ns per step by stage, {at} snakes, 1 thread", ["stage", "ns/step", "ns/rod-step"],
              [[k, v, v / at] for k, v in prof.items()])
        payload["profile_ns_per_step"] = {"snakes": at, **prof}
    write_json(__file__, payload)


if __name__ == "__main__":
    main()
