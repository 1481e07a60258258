"""Where a Verlet step of a clamped rod spends its time: each stage of the step repeated
inside one compiled loop (no Python in the timing), for a few element counts, and the fit
cost = fixed + per_element * n of the whole step.

Usage: python bench/profile_step.py [n1 n2 ...]        (default 1 10 100 1000)
"""

from __future__ import annotations

import sys
import time

import numpy as np
from numba import njit

import cosnet
from cosnet.kernels.compose import apply_loads
from cosnet.kernels.elastic import compute_internal_loads
from cosnet.kernels.layout import typed_call
from cosnet.kernels.motion import (drift_bodies, drift_state, gather_node_loads_on, kick_bodies,
                                   kick_state, place_line_ends)
from cosnet.kernels.slots import step_pointers
from cosnet.kernels.stepping import advance_verlet
from harness import table

STEEL = cosnet.Material(E=2.1e11, G=8.1e10, density=7850.0)


@njit
def loop_internal(model, state, loads, k):
    for _ in range(k):
        compute_internal_loads(model, state, loads)


@njit
def loop_effects(model, state, loads, table, backend, k):
    ptrs = step_pointers(model, state, loads, table, backend)
    for _ in range(k):   # every load effect's kernel, through its slot (the step's load hook)
        apply_loads(ptrs, 0.0)


@njit
def loop_gather(model, state, loads, backend, k):
    for _ in range(k):
        loads.node_f[:] = 0.0
        loads.node_tau[:] = 0.0
        gather_node_loads_on(backend, model.node_mass.shape[0], model, state, loads, 0.0)


@njit
def loop_evaluate(model, state, loads, eff, backend, k):
    for _ in range(k):   # (no steps: the loads at the state, Simulation.evaluate_loads)
        advance_verlet(model, state, loads, eff, 0.0, 0, backend)


@njit
def loop_drift_bodies(model, state, h, k):
    for _ in range(k):
        drift_bodies(model, state, h, 2)


@njit
def loop_drift_state(model, state, h, backend, k):
    for _ in range(k):
        drift_state(model, state, h, 2, backend)


@njit
def loop_place(model, state, k):
    for _ in range(k):
        place_line_ends(model, state)


@njit
def loop_kick_bodies(model, state, loads, h, k):
    for _ in range(k):
        kick_bodies(model, state, loads, h)


@njit
def loop_kick_state(model, state, loads, h, backend, k):
    for _ in range(k):
        kick_state(model, state, loads, h, backend)


def best(fn, repeat=7):
    fn()
    b = np.inf
    for _ in range(repeat):
        t0 = time.perf_counter()
        fn()
        b = min(b, time.perf_counter() - t0)
    return b


def profile(n):
    net = cosnet.Net()
    a = net.add_node((0, 0, 0), fixed=True)
    b = net.add_node((1, 0, 0))
    net.add_line(a, b, material=STEEL, section=cosnet.Circle(0.01), elements=n)
    sim = cosnet.Simulation(net, effects=[cosnet.Gravity()], threads=1)
    sim.run(steps=100)
    m, s, l, eff, be = sim.model, sim.state, sim.loads, sim.step_table, sim.backend
    step = sim._stepper()   # the compiled step, its kernels bound and its records pinned
    h = 0.0   # zero-length drifts/kicks: the same work, the state stays put
    k = max(200, int(2e6 / n))
    # each loop typed as the step types the records (typed_call): through numba's own dispatch
    # a one-row array would type otherwise, and the step's slots refuse kernels of other types
    stages = {
        "whole step (advance_verlet)": lambda: step(m, s, l, eff, sim.dt, k, be),
        "evaluate_loads (all loads)": lambda: typed_call(loop_evaluate, m, s, l, eff, be, k),
        "  internal loads": lambda: typed_call(loop_internal, m, s, l, k),
        "  effects (gravity)": lambda: typed_call(loop_effects, m, s, l, eff, be, k),
        "  gather node loads": lambda: typed_call(loop_gather, m, s, l, be, k),
        "kick_state": lambda: typed_call(loop_kick_state, m, s, l, h, be, k),
        "  kick bodies": lambda: typed_call(loop_kick_bodies, m, s, l, h, k),
        "drift_state": lambda: typed_call(loop_drift_state, m, s, h, be, k),
        "  drift bodies": lambda: typed_call(loop_drift_bodies, m, s, h, k),
        "  place line ends": lambda: typed_call(loop_place, m, s, k),
    }
    call = best(lambda: sim.run(steps=1), 50)
    out = {name: 1e9 * best(fn) / k for name, fn in stages.items()}
    out["sim.run(steps=1) from Python"] = 1e9 * call
    return out


def main():
    sizes = [int(a) for a in sys.argv[1:]] or [1, 10, 100, 1000]
    res = {n: profile(n) for n in sizes}
    names = list(res[sizes[0]])
    table("ns per step by stage (clamped rod, Verlet + gravity, 1 thread, best of 7)",
          ["stage"] + [f"n = {n}" for n in sizes] + [f"ns/element (n={sizes[-1]})"],
          [[name] + [res[n][name] for n in sizes] + [res[sizes[-1]][name] / sizes[-1]] for name in names])
    w = np.array([res[n]["whole step (advance_verlet)"] for n in sizes])
    A = np.column_stack([np.ones(len(sizes)), sizes])
    (fixed, per), *_ = np.linalg.lstsq(A, w, rcond=None)
    print(f"\nwhole step ~ {fixed:.0f} ns + {per:.1f} ns x elements")


if __name__ == "__main__":
    main()
