"""Scaling of rod-rod contact with the number of segments N: a woodpile lattice (layers of
parallel rods, alternately along x and y, each layer resting on the one below with a slight
overlap, so every crossing is a live contact) of 10^3, 10^4 and 10^5 segments.

Times the contact kernel alone (the grid broad phase and the narrow phase, called from
compiled code) and the whole step with and without contact; prints the time per segment and
the growth exponent d log t / d log N of each (1 for linear cost). Writes contact_scaling.json.

    python bench/contact_scaling.py [--quick]
"""

from __future__ import annotations

import sys

import numpy as np
from numba import njit

import cosnet
from cosnet.kernels.contact import add_contact
from harness import best_of, table, write_json

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
        write_json(__file__, {"rows": rows, "exponents": slopes})


if __name__ == "__main__":
    main(quick="--quick" in sys.argv)
