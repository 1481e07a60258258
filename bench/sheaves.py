"""Sheaves (eyelets with a radius) side by side with the same rope without one, in one process.

Cost: an Atwood machine, 0.3 and 0.2 kg on a laid rope (r = 2 mm) over a fixed sheave of 5 cm,
its strands 0.5 m long, with 5, 10 or 20 elements per radius; each stepped with and without its
sheave at the sheave's stable step (the rope's kernels cost the same whichever way it moves),
interleaved rounds, one thread: the cost per step, over the bare rope, and per vertex the rim
holds.

Accuracy (python bench/accuracy.py --joints runs it, from accuracy here): the same machines run
for 0.3 s against the rigid rope's motion, x(t) = (alpha / beta)(cosh(sqrt(beta) t) - 1)
(tests/test_sheaves.py): the heavier mass's drop against it, the energy the landings took
against the kinetic energy, and the wall time of the run.
Run: python bench/sheaves.py [--quick]; writes bench/sheaves.json (docs/performance.md shows
its tables).
"""

import math
import sys
import time

import numpy as np

import cosnet
from cosnet.effects.sheaves import Sheaves, over_a_sheave
from harness import best_interleaved, table, write_json

G = 9.81
M1, M2, RADIUS, DROP = 0.3, 0.2, 0.05, 0.5


def atwood(per_radius, sheave=True, dt=None):
    net, _ = over_a_sheave(radius=RADIUS, drop=DROP, masses=(M1, M2), elements_per_radius=per_radius)
    if not sheave:
        net.sheaves.clear()
    return cosnet.Simulation(net, [cosnet.Gravity()], threads=1, dt=dt, force_dt=dt is not None)


def cost(per_radius, rounds):
    held = atwood(per_radius)
    bare = atwood(per_radius, sheave=False, dt=held.dt)
    steps = 20_000
    held.run(steps=200)    # the rope on the rim: its vertices engaged
    p = next(e for e in held.effects if isinstance(e, Sheaves)).params(held)
    engaged = int(np.count_nonzero(p.engaged))
    t_bare, t_held = best_interleaved([lambda: bare.run(steps=steps), lambda: held.run(steps=steps)], rounds)
    return {"per_radius": per_radius, "elements": held.net.element_count, "engaged": engaged,
            "window": int(p.hi[0] - p.lo[0] + 1), "us_bare": 1e6 * t_bare / steps,
            "us_sheave": 1e6 * t_held / steps,
            "over_percent": 100.0 * (t_held / t_bare - 1.0),
            "us_per_engaged": 1e6 * (t_held - t_bare) / steps / engaged}


def rigid_drop(net, t):
    rope = net.lines[0]
    lam = rope.material.density * rope.section.A
    mass = M1 + M2 + lam * rope.length
    alpha, beta = G * (M1 - M2) / mass, 2.0 * lam * G / mass
    return alpha / beta * (math.cosh(math.sqrt(beta) * t) - 1.0)


def accuracy(per_radius, until):
    sim = atwood(per_radius)
    sim.run(steps=1)     # compiled before the clock starts
    heavy = sim.net.node("left")
    z0, t0 = sim.node_position(heavy)[2], sim.time
    wall = time.perf_counter()
    sim.run(until=until)
    wall = time.perf_counter() - wall
    went = z0 - sim.node_position(heavy)[2]
    exact = rigid_drop(sim.net, sim.time) - rigid_drop(sim.net, t0)
    speed = np.linalg.norm(sim.state.node_v[heavy.index])
    return {"per_radius": per_radius, "elements": sim.net.element_count, "dt": sim.dt, "steps": sim.steps,
            "drop_error": went / exact - 1.0, "landings_over_kinetic": sim.dissipated() / (0.5 * (M1 + M2) * speed**2),
            "wall_s": wall}


def main():
    quick = "--quick" in sys.argv
    per_radius, rounds = ((5, 10), 3) if quick else ((5, 10, 20), 9)
    runs = [cost(n, rounds) for n in per_radius]
    table("sheaves: cost per step of an Atwood machine's rope, with and without its sheave (one thread)",
          ["elements per radius", "elements", "engaged", "window", "us/step bare", "us/step sheave", "over %",
           "us per engaged vertex"],
          [[r["per_radius"], r["elements"], r["engaged"], r["window"], r["us_bare"], r["us_sheave"],
            r["over_percent"], r["us_per_engaged"]] for r in runs])
    write_json(__file__, {"command": " ".join(["python", "bench/sheaves.py", *sys.argv[1:]]), "cost": runs})


if __name__ == "__main__":
    main()
