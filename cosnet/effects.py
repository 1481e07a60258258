"""Declared effects. Each is a small validated object that binds, once, to the parameter
record of its @njit kernel (cosnet.kernels.effects); the step is assembled from exactly the
effects a simulation declares (see cosnet.kernels.compose).

To add an effect: write a NamedTuple of parameters and a kernel registered with
``@load_kernel(Params)`` (adds to forces/torques) or ``@flow_kernel(Params)`` (an exact
velocity flow), or a pair ``constraint_kernels(Params, after_drift, after_kick)`` (kinematic:
a prescribed motion, stage "constraint"), then a subclass of ``Effect`` whose ``bind`` returns the parameters.
"""

from __future__ import annotations

import math

import numpy as np

from .kernels.effects import DampingParams, GravityParams, LineLoadParams, NodeLoadParams
from .net import Line, Node


class Effect:
    """Base of all declared effects. ``stage`` is "load" or "flow"; ``adds_energy`` says
    whether it can feed energy in (the instability watch then skips its energy test)."""

    stage = "load"
    adds_energy = False

    def bind(self, sim):
        """Return the kernel's parameter record for this simulation."""
        raise NotImplementedError

    def params(self, sim):
        """The parameter record this effect is bound to in ``sim`` (live: what its kernel
        reads and writes)."""
        return sim.effect_params(self)

    def check_state(self, sim):
        """Raise ValueError (one line) if the state contradicts this effect; run() asks
        before it steps."""

    def potential_energy(self, sim) -> float:
        """Potential energy of a conservative effect (0 for others)."""
        return 0.0

    def energy_scale(self, sim) -> float:
        """Energy this effect can exchange with the motion of the net as built (J); the
        instability watch tolerates Verlet's error on it. 0 for effects that store none."""
        return 0.0

    def max_omega2(self, sim) -> float:
        """Upper bound on the squared frequency this effect's stiffness adds to any mass of
        the net (k / m for a penalty spring); the stable step shrinks accordingly. 0 when the
        effect adds no stiffness."""
        return 0.0

    def describe(self) -> str:
        return type(self).__name__


def _vec3(owner, name, value):
    a = np.array(value, dtype=float)
    if a.shape != (3,) or not np.all(np.isfinite(a)):
        raise ValueError(f"{owner}: {name} must be 3 finite numbers, got {value!r}")
    return a


def _amplitude(owner, times, values, omega, phase):
    if (times is None) != (values is None):
        raise ValueError(f"{owner}: give both times and values for a tabulated amplitude")
    t = np.zeros(0) if times is None else np.array(times, dtype=float)
    v = np.zeros(0) if values is None else np.array(values, dtype=float)
    if t.ndim != 1 or t.shape != v.shape or not np.all(np.isfinite(t)) or not np.all(np.isfinite(v)):
        raise ValueError(f"{owner}: times and values must be 1-D finite arrays of equal length")
    if t.size and np.any(np.diff(t) <= 0):
        raise ValueError(f"{owner}: times must increase strictly")
    for name, x in (("omega", omega), ("phase", phase)):
        if not math.isfinite(float(x)):
            raise ValueError(f"{owner}: {name} must be finite, got {x}")
    return t, v, float(omega), float(phase)


class Gravity(Effect):
    """Uniform gravity g (lab frame) on every mass of the net."""

    def __init__(self, g=(0.0, 0.0, -9.81)):
        self.g = _vec3("Gravity", "g", g)

    def bind(self, sim):
        return GravityParams(self.g.copy())

    def potential_energy(self, sim) -> float:
        from .flatten import matrix_from_quat
        m, s = sim.model, sim.state
        # einsum, not BLAS: a threaded BLAS call here leaves its threads spinning on the
        # cores the step's thread pool is about to use
        e = -float(np.einsum("i,ij,j->", m.vertex_mass, s.x, self.g))
        own = np.flatnonzero(m.node_own_mass > 0)       # the nodes' own masses sit at their reference points
        if own.size:
            ref = s.node_x[own] - np.einsum("nij,nj->ni", matrix_from_quat(s.node_q[own]), m.node_com_offset[own])
            e -= float(np.einsum("i,ij,j->", m.node_own_mass[own], ref, self.g))
        return e

    def energy_scale(self, sim) -> float:
        """Weight of the net times the diagonal of its bounding box."""
        x = np.concatenate([sim.state.x, sim.state.node_x])
        size = float(np.linalg.norm(x.max(axis=0) - x.min(axis=0)))
        return sim.net.total_mass() * float(np.linalg.norm(self.g)) * size

    def describe(self):
        return f"Gravity(g={self.g.tolist()})"


class NodeLoad(Effect):
    """External force F (at the node's reference point) and torque L on a node, lab frame
    (1.5)/(1.7), scaled by amplitude(t) = interp(t, times, values) * sin(omega t + phase)
    (each factor 1 when not given)."""

    adds_energy = True

    def __init__(self, node: Node, force=(0.0, 0.0, 0.0), torque=(0.0, 0.0, 0.0), *,
                 times=None, values=None, omega=0.0, phase=0.0):
        who = f"NodeLoad on {node!r}"
        if not isinstance(node, Node):
            raise ValueError(f"NodeLoad: node must be a cosnet Node, got {node!r}")
        self.node = node
        self.force = _vec3(who, "force", force)
        self.torque = _vec3(who, "torque", torque)
        self.amp = _amplitude(who, times, values, omega, phase)

    def bind(self, sim):
        sim.check_node(self.node, "NodeLoad")
        return NodeLoadParams(np.array([self.node.index], dtype=np.int64), self.force[None].copy(),
                              self.torque[None].copy(), *self.amp)


class LineLoad(Effect):
    """Distributed force f and torque l per unit rest length on a line, lab frame (1.4)."""

    adds_energy = True

    def __init__(self, line: Line, force_per_length=(0.0, 0.0, 0.0), torque_per_length=(0.0, 0.0, 0.0),
                 *, times=None, values=None, omega=0.0, phase=0.0):
        if not isinstance(line, Line):
            raise ValueError(f"LineLoad: line must be a cosnet Line, got {line!r}")
        who = f"LineLoad on {line!r}"
        self.line = line
        self.force = _vec3(who, "force_per_length", force_per_length)
        self.torque = _vec3(who, "torque_per_length", torque_per_length)
        self.amp = _amplitude(who, times, values, omega, phase)

    def bind(self, sim):
        sim.check_line(self.line, "LineLoad")
        return LineLoadParams(np.array([self.line.index], dtype=np.int64), self.force[None].copy(),
                              self.torque[None].copy(), *self.amp)


class Damping(Effect):
    """Linear, mass-proportional viscous damping: every velocity decays as exp(-nu t), every
    angular velocity as exp(-nu_r t). Integrated exactly, so stable at any dt."""

    stage = "flow"

    def __init__(self, translational: float = 0.0, rotational: float | None = None):
        nu = float(translational)
        nr = nu if rotational is None else float(rotational)
        for name, x in (("translational", nu), ("rotational", nr)):
            if not math.isfinite(x) or x < 0:
                raise ValueError(f"Damping: {name} rate must be a finite number >= 0, got {x}")
        self.translational, self.rotational = nu, nr

    def bind(self, sim):
        return DampingParams(self.translational, self.rotational)

    def describe(self):
        return f"Damping(translational={self.translational:g}/s, rotational={self.rotational:g}/s)"
