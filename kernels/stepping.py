"""Symplectic splitting steppers: position Verlet (order 2) and PEFRL (order 4).

A step alternates drifts (free flight, ``drift_state``) with kicks (loads, ``kick_loads``).
External loads are evaluated afresh at every kick, at the stage's own time, so a multi-stage
scheme never applies them twice (free fall is exact for both schemes).
Consecutive steps share their outer drift (first-same-as-last), so n steps cost n kicks.
Each scheme's stage coefficients are in SCHEMES; the kernels below spell them out (a loop
over a table would cost a kick's worth of bookkeeping per stage), and the stability
interval (cosnet) and the convergence tests read the table.
Kinematic effects (driven nodes) follow every drift and every kick (compose.py): a driven
component is set from its prescription at the stage's end time, never integrated.
"""

import math
from functools import cache
from typing import NamedTuple

import numpy as np
from numba import njit

from .backend import ENTRY, STEP
from .compiler import code_weight
from .compose import (CORE, apply_accounts, apply_drift_constraints, apply_flows, apply_inertias,
                      apply_kick_constraints, apply_loads, core_kernel)
from .elastic import internal_loads_on
from .motion import drift_state, gather_node_loads_on, kick_state
from .slots import deref, slots_bound_here, step_pointers

# Omelyan, Mryglod & Folk (2002), position-extended Forest-Ruth-like coefficients
PEFRL_XI = 0.1786178958448091
PEFRL_LAMBDA = -0.2123418310626054
PEFRL_CHI = -0.06626458266981849


class Scheme(NamedTuple):
    """A symmetric splitting step D(drifts[0]) K(kicks[0]) D(drifts[1]) ... K(kicks[-1])
    D(drifts[-1]), coefficients in units of the step h (each row sums to 1)."""
    order: int
    drifts: tuple
    kicks: tuple


SCHEMES = {
    "verlet": Scheme(2, (0.5, 0.5), (1.0,)),
    "pefrl": Scheme(4, (PEFRL_XI, PEFRL_CHI, 1.0 - 2.0 * (PEFRL_CHI + PEFRL_XI), PEFRL_CHI, PEFRL_XI),
                    (0.5 - PEFRL_LAMBDA, PEFRL_LAMBDA, PEFRL_LAMBDA, 0.5 - PEFRL_LAMBDA)),
}
CHUNK_STEPS = 2000  # steps per compiled call: a chunk boundary splits the shared outer drift
                    # into two, so a resumed run is bit-identical only with the same chunks


def steps_to(t: float, dt: float) -> int:
    """The number of steps of dt that reach t (a remainder within 1e-9 dt of a whole step
    is round-off, not one more step)."""
    return int(math.ceil(t / dt - 1e-9))


@cache
def stability_interval(name: str) -> float:
    """Largest omega*h for which scheme ``name`` is stable on the harmonic oscillator: where
    the trace of its step's 2 x 2 transfer matrix first leaves [-2, 2]."""
    scheme = SCHEMES[name]

    def step_matrix(wh):
        m = np.array([[1.0, scheme.drifts[0]], [0.0, 1.0]])
        for kick, drift in zip(scheme.kicks, scheme.drifts[1:]):
            m = np.array([[1.0, 0.0], [-wh * wh * kick, 1.0]]) @ m
            m = np.array([[1.0, drift], [0.0, 1.0]]) @ m
        return m
    grid = np.linspace(1e-3, 8.0, 8000)
    for wh in grid:
        if abs(np.trace(step_matrix(wh))) > 2.0:
            return float(wh)
    return float(grid[-1])


# The step's own kernels: slot kernels (kernels/slots.py), each compiled once in a library of
# its own and called through its slot. The step, compiled once for every combination of
# effects, holds the loop and the calls alone, and LLVM optimises none of these again for it.
@njit(**STEP)
def start_loads_at(core, record, h, order):
    """Update loads given the state: the node balances zeroed, the internal loads (3.2)/(3.3)."""
    model, state, loads, backend = deref(core)
    loads.node_f[:] = 0.0
    loads.node_tau[:] = 0.0
    internal_loads_on(backend, model, state, loads)


@njit(**STEP)
def gather_loads_at(core, record, h, order):
    """Update loads.node_f, node_tau given the loads on the line ends: (4.3)/(4.4)."""
    model, state, loads, backend = deref(core)
    gather_node_loads_on(backend, model.node_mass.shape[0], model, state, loads, 0.0)


@njit(**STEP)
def kick_velocities_at(core, record, h, order):
    """Update velocities and body angular momenta given the loads over time h (motion.kick_state)."""
    model, state, loads, backend = deref(core)
    kick_state(model, state, loads, h, backend)


@njit(**STEP)
def drift_positions_at(core, record, h, order):
    """Update state by the free flight of time h, at the scheme's order (motion.drift_state)."""
    model, state, _, backend = deref(core)
    drift_state(model, state, h, order, backend)


start_loads = core_kernel(start_loads_at)
gather_loads = core_kernel(gather_loads_at)
kick_velocities = core_kernel(kick_velocities_at)
drift_positions = core_kernel(drift_positions_at)


def compile_orders(kernels: list) -> tuple[list, list]:
    """(a run's order, a second process's order) of compiling a step's slot kernels
    (compose.step_kernels): the drift's first for the run (its frame 0 needs it) and last for
    the second process, the others in one order for both, the longest to compile first by
    their bytecode (compiler.code_weight). Each passes over a kernel the other is compiling,
    or one calling a function the other is compiling, and comes back to it at the end
    (bind_slots), so the two share the list as one queue;
    the longest first, so that neither ends waiting while the other compiles a long kernel
    taken last (a line-obstacle contact of 6.6 s, last in slot order, held a run 5.5 s)."""
    drift = CORE.index(drift_positions_at)
    weights = [code_weight(k) for k in kernels]
    rest = sorted((r for r in range(len(kernels)) if r != drift), key=lambda r: -weights[r])
    return [drift] + rest, rest + [drift]


@njit(**STEP, inline="always")
def evaluate_loads_at(ptrs):
    """Update loads given the state: internal loads (3.2)/(3.3), the declared effects, then
    the node balances (4.3)/(4.4). ptrs: slots.step_pointers' result."""
    start_loads(ptrs, 0.0, 0)
    apply_loads(ptrs, 0.0)
    gather_loads(ptrs, 0.0, 0)


@njit(**STEP)
def kick_loads(ptrs, h):
    """Update velocities by a kick of length h, wrapped in half flows of the velocity effects,
    then restore the prescribed ones (ptrs: slots.step_pointers' result). The load effects
    that keep an account of their work see the velocities on both sides of the kick; flow
    effects that add mass (a fluid's) turn the loads into what the kick divides by the
    masses alone."""
    apply_flows(ptrs, 0.5 * h)
    evaluate_loads_at(ptrs)
    apply_accounts(ptrs, 0.5 * h)
    apply_inertias(ptrs, h)
    kick_velocities(ptrs, h, 0)
    apply_accounts(ptrs, 0.5 * h)
    apply_flows(ptrs, 0.5 * h)
    apply_kick_constraints(ptrs, h)


# The kick as advance_verlet calls it, once per step: inlined by numba (one call a step, no
# function of its own to compile). advance_pefrl calls the kick four times and keeps the call.
kick_loads_inline = njit(**STEP, inline="always")(kick_loads.py_func)


@njit(**STEP, inline="always")
def drift(ptrs, h, order):
    """Update state by the free flight of time h, then set the prescribed poses at its end."""
    drift_positions(ptrs, h, order)
    apply_drift_constraints(ptrs, h)


@njit(**ENTRY)
def advance_verlet(model, state, loads, effects, h, steps, backend):
    """Update state by ``steps`` position-Verlet steps D(h/2) K(h) D(h/2) of size h;
    effects = the step's table (compose.empty_table): the slots of its kernels
    (compose.bind_slots) and the effects' records pinned (compose.Pins). For no steps, update
    loads given the state instead (evaluate_loads_at; Simulation.evaluate_loads): the step's
    own entry, where one of its own would compile the unboxing of every record again."""
    if not slots_bound_here(effects):
        raise RuntimeError("advance_verlet: kernels not bound in this process (compose.bind_slots)")
    ptrs = step_pointers(model, state, loads, effects, backend)
    if steps == 0:
        evaluate_loads_at(ptrs)
        return
    drift(ptrs, 0.5 * h, 2)
    for s in range(steps):
        kick_loads_inline(ptrs, h)
        drift(ptrs, h if s < steps - 1 else 0.5 * h, 2)


@njit(**ENTRY)
def advance_pefrl(model, state, loads, effects, h, steps, backend):
    """Update state by ``steps`` PEFRL steps (fourth order):
    D(xi) K((1-2 lam)/2) D(chi) K(lam) D(1-2(chi+xi)) K(lam) D(chi) K((1-2 lam)/2) D(xi).
    For no steps, update loads given the state instead (as advance_verlet)."""
    if not slots_bound_here(effects):
        raise RuntimeError("advance_pefrl: kernels not bound in this process (compose.bind_slots)")
    xi, lam, chi = PEFRL_XI * h, PEFRL_LAMBDA * h, PEFRL_CHI * h
    ptrs = step_pointers(model, state, loads, effects, backend)
    if steps == 0:
        evaluate_loads_at(ptrs)
        return
    drift(ptrs, xi, 4)
    for s in range(steps):
        kick_loads(ptrs, 0.5 * h - lam)
        drift(ptrs, chi, 4)
        kick_loads(ptrs, lam)
        drift(ptrs, h - 2.0 * (chi + xi), 4)
        kick_loads(ptrs, lam)
        drift(ptrs, chi, 4)
        kick_loads(ptrs, 0.5 * h - lam)
        drift(ptrs, 2.0 * xi if s < steps - 1 else xi, 4)
