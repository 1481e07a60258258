"""Symplectic splitting steppers: position Verlet (order 2) and PEFRL (order 4).

A step alternates drifts (free flight, ``drift_state``) with kicks (loads, ``kick_loads``).
External loads are evaluated afresh at every kick, at the stage's own time, so a multi-stage
scheme never applies them twice (free fall is exact for both schemes).
Consecutive steps share their outer drift (first-same-as-last), so n steps cost n kicks.
Kinematic effects (driven nodes) follow every drift and every kick (compose.py): a driven
component is set from its prescription at the stage's end time, never integrated.
"""

from numba import njit

from .backend import ENTRY, STEP
from .compose import apply_drift_constraints, apply_flows, apply_kick_constraints, apply_loads
from .elastic import internal_loads_on
from .motion import drift_state, gather_node_loads_on, kick_state

# Omelyan, Mryglod & Folk (2002), position-extended Forest-Ruth-like coefficients
PEFRL_XI = 0.1786178958448091
PEFRL_LAMBDA = -0.2123418310626054
PEFRL_CHI = -0.06626458266981849


@njit(**ENTRY, inline="always")  # one caller: kick_loads (tests call it from Python)
def evaluate_loads(model, state, loads, load_effects, backend):
    """Update loads given the state: internal loads (3.2)/(3.3), the declared effects, then
    the node balances (4.3)/(4.4)."""
    loads.node_f[:] = 0.0
    loads.node_tau[:] = 0.0
    internal_loads_on(backend, model, state, loads)
    apply_loads(load_effects, model, state, loads)
    gather_node_loads_on(backend, model.node_mass.shape[0], model, state, loads, 0.0)


@njit(**STEP)
def kick_loads(model, state, loads, effects, h, backend):
    """Update velocities by a kick of length h, wrapped in half flows of the velocity effects,
    then restore the prescribed ones. effects = (load, flow, constraint) effect tuples."""
    load_effects, flow_effects, constraint_effects = effects
    apply_flows(flow_effects, model, state, 0.5 * h)
    evaluate_loads(model, state, loads, load_effects, backend)
    kick_state(model, state, loads, h, backend)
    apply_flows(flow_effects, model, state, 0.5 * h)
    apply_kick_constraints(constraint_effects, model, state, (loads, h))


@njit(**STEP, inline="always")
def drift(model, state, effects, h, order, backend):
    """Update state by the free flight of time h, then set the prescribed poses at its end."""
    drift_state(model, state, h, order, backend)
    apply_drift_constraints(effects[2], model, state, h)


@njit(**ENTRY)
def advance_verlet(model, state, loads, effects, h, steps, backend):
    """Update state by ``steps`` position-Verlet steps D(h/2) K(h) D(h/2) of size h;
    effects = (load, flow, constraint) tuples of effect parameter records."""
    drift(model, state, effects, 0.5 * h, 2, backend)
    for s in range(steps):
        kick_loads(model, state, loads, effects, h, backend)
        drift(model, state, effects, h if s < steps - 1 else 0.5 * h, 2, backend)


@njit(**ENTRY)
def advance_pefrl(model, state, loads, effects, h, steps, backend):
    """Update state by ``steps`` PEFRL steps (fourth order):
    D(xi) K((1-2 lam)/2) D(chi) K(lam) D(1-2(chi+xi)) K(lam) D(chi) K((1-2 lam)/2) D(xi)."""
    xi, lam, chi = PEFRL_XI * h, PEFRL_LAMBDA * h, PEFRL_CHI * h
    drift(model, state, effects, xi, 4, backend)
    for s in range(steps):
        kick_loads(model, state, loads, effects, 0.5 * h - lam, backend)
        drift(model, state, effects, chi, 4, backend)
        kick_loads(model, state, loads, effects, lam, backend)
        drift(model, state, effects, h - 2.0 * (chi + xi), 4, backend)
        kick_loads(model, state, loads, effects, lam, backend)
        drift(model, state, effects, chi, 4, backend)
        kick_loads(model, state, loads, effects, 0.5 * h - lam, backend)
        drift(model, state, effects, 2.0 * xi if s < steps - 1 else xi, 4, backend)
