"""Scaling of rod-rod contact with the number of segments N: a woodpile lattice (layers of
parallel rods, alternately along x and y, each layer resting on the one below with a slight
overlap, so every crossing is a live contact) of 10^3, 10^4 and 10^5 segments.

Times the contact kernel alone (the grid broad phase and the narrow phase, called from
compiled code) and the whole step with and without contact; prints the time per segment and
the growth exponent d log t / d log N of each (1 for linear cost). Writes contact_scaling.json.

With --friction, the same for a pile with friction instead (its rows go under "friction" in
contact_scaling.json, the rest kept): woodpiles of 1,000 to 5,000 segments resting on a
plane obstacle, with Coulomb friction between the rods (Contact's pair springs) and on the
ground; the kernels' cost per segment and per active contact, the frictionless kernel on the
same state beside them, and the whole step.

    python bench/contact_scaling.py [--quick] [--friction]
"""

from __future__ import annotations

import json
import sys
from pathlib import Path

import numpy as np
from numba import njit

import cosnet
from cosnet.kernels.contact import add_contact
from cosnet.kernels.obstacles import add_obstacle
from harness import best_of, machine, table, write_json

MAT = cosnet.Material(E=1e7, G=4e6, density=1000.0, name="rubber")
RADIUS, SPACING, LAYERS = 0.01, 0.05, 10


def woodpile(rods: int, layers: int = LAYERS) -> cosnet.Net:
    """``layers`` layers of ``rods`` rods, each of ``rods`` elements of length SPACING."""
    net = cosnet.Net()
    span = rods * SPACING
    for k in range(layers):
        z = 1.95 * RADIUS * k
        for i in range(rods):
            c = (i + 0.5) * SPACING
            a, b = ((0.0, c, z), (span, c, z)) if k % 2 == 0 else ((c, 0.0, z), (c, span, z))
            net.add_line(net.add_node(a), net.add_node(b), material=MAT, section=cosnet.Circle(RADIUS),
                         elements=rods)
    return net


@njit(cache=True)
def repeat_contact(p, model, state, loads, n):
    for _ in range(n):
        add_contact(p, model, state, loads)


@njit(cache=True)
def repeat_obstacle(p, model, state, loads, n):
    for _ in range(n):
        add_obstacle(p, model, state, loads)


def measure(rods: int, repeat: int) -> dict:
    net = woodpile(rods)
    contact = cosnet.Contact(k=1e3)
    sim = cosnet.Simulation(net, effects=[contact], threads=1)
    bare = cosnet.Simulation(net, threads=1, dt=sim.dt)
    p = contact.params(sim)
    n = p.elements.shape[0]
    calls = max(1, 200_000 // n)
    t_kernel = best_of(lambda: repeat_contact(p, sim.model, sim.state, sim.loads, calls), repeat) / calls
    tests0 = contact.narrow_tests(sim)
    repeat_contact(p, sim.model, sim.state, sim.loads, 1)
    tests, contacts = contact.narrow_tests(sim) - tests0, contact.active_contacts(sim)
    steps = max(10, 200_000 // n)  # enough steps to hide the per-run health check
    t_step = best_of(lambda: sim.run(steps=steps), repeat) / steps
    t_bare = best_of(lambda: bare.run(steps=steps), repeat) / steps
    return {"segments": n, "rods": rods * LAYERS, "contacts": contacts,
            "narrow_tests_per_call": tests, "kernel_s": t_kernel, "step_s": t_step,
            "step_without_contact_s": t_bare,
            "kernel_ns_per_segment": 1e9 * t_kernel / n, "step_ns_per_segment": 1e9 * t_step / n}


def exponent(rows, key) -> float:
    """Least-squares slope of log(key) against log(segments)."""
    x = np.log([r["segments"] for r in rows])
    y = np.log([r[key] for r in rows])
    return float(np.polyfit(x, y, 1)[0])


def measure_friction(rods: int, repeat: int) -> dict:
    """The woodpile of ``rods`` rods per layer on a frictional ground, rods rubbing on each
    other: kernel and step times with friction, the frictionless contact kernel beside them."""
    net = woodpile(rods)
    contact = cosnet.Contact(k=1e3, mu_s=0.5, mu_k=0.4)
    ground = cosnet.Obstacle("plane", point=(0, 0, -0.95 * RADIUS), normal=(0, 0, 1), k=1e3,
                             mu_s=0.5, mu_k=0.4)
    sim = cosnet.Simulation(net, effects=[cosnet.Gravity(), contact, ground], threads=1)
    plain = cosnet.Simulation(net, effects=[cosnet.Contact(k=1e3)], threads=1, dt=sim.dt)
    sim.run(steps=20)   # the pair table and the anchors filled, some pairs sliding
    p, q, g = contact.params(sim), plain.effects[0].params(plain), ground.params(sim)
    n = p.elements.shape[0]
    calls = max(1, 200_000 // n)
    t_fric = best_of(lambda: repeat_contact(p, sim.model, sim.state, sim.loads, calls), repeat) / calls
    t_plain = best_of(lambda: repeat_contact(q, plain.model, sim.state, plain.loads, calls), repeat) / calls
    t_ground = best_of(lambda: repeat_obstacle(g, sim.model, sim.state, sim.loads, calls), repeat) / calls
    pairs, touching = contact.active_contacts(sim), ground.active_contacts(sim)
    steps = max(10, 200_000 // n)
    t_step = best_of(lambda: sim.run(steps=steps), repeat) / steps
    return {"segments": n, "rods": rods * LAYERS, "rod_pairs": pairs, "ground_contacts": touching,
            "pair_table_slots": int(p.pair_key.shape[1]),
            "contact_friction_s": t_fric, "contact_frictionless_s": t_plain, "ground_s": t_ground,
            "step_s": t_step,
            "contact_friction_ns_per_segment": 1e9 * t_fric / n,
            "contact_friction_ns_per_pair": 1e9 * t_fric / max(pairs, 1),
            "friction_extra_ns_per_pair": 1e9 * (t_fric - t_plain) / max(pairs, 1),
            "ground_ns_per_contact": 1e9 * t_ground / max(touching, 1),
            "step_ns_per_segment": 1e9 * t_step / n}


def main_friction(quick=False):
    sizes = (10, 16) if quick else (10, 16, 22)  # 1,000, 2,560 and 4,840 segments
    rows = [measure_friction(r, 2 if quick else 3) for r in sizes]
    table("Contact with friction (woodpile on a frictional ground, 1 thread)",
          ["segments", "rod pairs", "ground contacts", "contact (ms)", "frictionless (ms)",
           "ns/segment", "ns/pair", "friction ns/pair", "ground (ms)", "step (ms)"],
          [[r["segments"], r["rod_pairs"], r["ground_contacts"], 1e3 * r["contact_friction_s"],
            1e3 * r["contact_frictionless_s"], r["contact_friction_ns_per_segment"],
            r["contact_friction_ns_per_pair"], r["friction_extra_ns_per_pair"], 1e3 * r["ground_s"],
            1e3 * r["step_s"]] for r in rows])
    slopes = {k: exponent(rows, k) for k in ("contact_friction_s", "ground_s", "step_s")}
    print("\ngrowth exponent d log t / d log N: contact with friction {contact_friction_s:.3f}, "
          "ground {ground_s:.3f}, step {step_s:.3f}".format(**slopes))
    if not quick:
        path = Path(__file__).with_suffix(".json")
        kept = json.loads(path.read_text()) if path.exists() else {}
        # the frictionless rows keep the machine they were measured on
        write_json(__file__, {**kept, "friction": {"machine": machine(), "rows": rows, "exponents": slopes}})


def main(quick=False):
    sizes = (10, 32) if quick else (10, 32, 100)  # rods per layer: N = 10 rods^2 segments
    rows = [measure(r, 2 if quick else 3) for r in sizes]
    table("Contact detection (woodpile lattice, 1 thread)",
          ["segments", "contacts", "narrow tests", "kernel (ms)", "ns/segment", "step (ms)",
           "step w/o contact (ms)", "step ns/segment"],
          [[r["segments"], r["contacts"], r["narrow_tests_per_call"], 1e3 * r["kernel_s"],
            r["kernel_ns_per_segment"], 1e3 * r["step_s"], 1e3 * r["step_without_contact_s"],
            r["step_ns_per_segment"]] for r in rows])
    slopes = {k: exponent(rows, k) for k in ("kernel_s", "step_s", "narrow_tests_per_call")}
    print("\ngrowth exponent d log t / d log N: kernel {kernel_s:.3f}, step {step_s:.3f}, "
          "narrow tests {narrow_tests_per_call:.3f}".format(**slopes))
    if not quick:
        path = Path(__file__).with_suffix(".json")
        kept = json.loads(path.read_text()) if path.exists() else {}
        write_json(__file__, {"rows": rows, "exponents": slopes,
                              **({"friction": kept["friction"]} if "friction" in kept else {})})


if __name__ == "__main__":
    if "--friction" in sys.argv:
        main_friction(quick="--quick" in sys.argv)
    else:
        main(quick="--quick" in sys.argv)
