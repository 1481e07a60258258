"""The built-in effects: gravity, node and line loads, damping. Each is one declaration
(cosnet.engine.registry.Effect): scene kind and keys, the parameter record of its @njit kernel
(cosnet.kernels.effects) and the binding of the record; the step is assembled from exactly
the effects a simulation declares (see cosnet.kernels.compose).

To add an effect: write a NamedTuple of parameters and a kernel registered with
``@load_kernel(Params)`` (adds to forces/torques) or ``@flow_kernel(Params)`` (an exact
velocity flow), then a subclass of ``Effect`` stating ``kind``, ``keys`` and
``record = Params`` whose ``bind`` returns the parameters (docs/effects.md).
"""

from __future__ import annotations

import math

import numpy as np

from ..core import samples
from ..engine.bounds import index_error
from ..core import checks
from ..kernels.effects import DampingParams, GravityParams, LineLoadParams, NodeLoadParams
from ..core.net import Line, Node
from ..engine.registry import Binding, Effect, Key
from ..core.units import (ACCELERATION, FORCE, FORCE_PER_LENGTH, RATE, TIME, TORQUE, TORQUE_PER_LENGTH,
                          floats, nonnegative, number, vec3)

AMPLITUDE = (Key("times", floats, TIME, doc="abscissae of the amplitude table (increasing)"),
             Key("values", floats, doc="amplitude table (interpolated linearly, held at its ends)"),
             Key("omega", number, RATE, doc="angular frequency of the factor sin(omega t + phase)"),
             Key("phase", number, doc="phase of the harmonic factor (rad)"))


def checked_table(owner, x, y, names=("times", "values")):
    """(x, y) as float arrays of a table interpolated linearly over x (both empty when neither
    is given), refused in one line naming ``owner`` unless both or neither are given, both
    are 1-D, finite and of one length, and x increases strictly."""
    xn, yn = names
    if (x is None) != (y is None):
        raise ValueError(f"{owner}: give both {xn} and {yn}")
    a = np.zeros(0) if x is None else np.array(x, dtype=float)
    b = np.zeros(0) if y is None else np.array(y, dtype=float)
    if a.ndim != 1 or a.shape != b.shape or not np.all(np.isfinite(a)) or not np.all(np.isfinite(b)):
        raise ValueError(f"{owner}: {xn} and {yn} must be 1-D finite arrays of equal length")
    if a.size and np.any(np.diff(a) <= 0):
        raise ValueError(f"{owner}: {xn} must increase strictly")
    return a, b


def _amplitude(owner, times, values, omega, phase):
    t, v = checked_table(owner, times, values)
    for name, x in (("omega", omega), ("phase", phase)):
        if not math.isfinite(float(x)):
            raise ValueError(f"{owner}: {name} must be finite, got {x}")
    # one row: its table is the whole of times/values
    return t, v, np.array([0, t.size], dtype=np.int64), np.array([float(omega)]), np.array([float(phase)])


POOLED = ("times", "values")   # the load records' arrays shared by their rows through ``table``


def join_loads(records):
    """Return (joined, views) for load records of one type (NodeLoadParams, LineLoadParams):
    one record holding every row of ``records`` in order, its amplitude tables pooled (row
    offsets shifted), and for each given record one made of views into the joined arrays, so
    that what is read or changed through a declared effect's own record is what the kernel
    reads."""
    cls = type(records[0])
    rows = [f for f in cls._fields if f not in POOLED and f != "table"]
    joined = {f: np.concatenate([getattr(r, f) for r in records]) for f in rows + list(POOLED)}
    table, start = [0], 0
    for r in records:
        table.extend(start + r.table[1:] - r.table[0])
        start = table[-1]
    joined["table"] = np.array(table, dtype=np.int64)
    out = cls(**joined)
    views, k = [], 0
    for r in records:
        n = r.table.shape[0] - 1
        views.append(cls(**{f: getattr(out, f)[k:k + n] for f in rows},
                         **{f: getattr(out, f) for f in POOLED}, table=out.table[k:k + n + 1]))
        k += n
    return out, views


def _peak(amp) -> float:
    """The largest |value| of an amplitude's table (1 without one)."""
    values = amp[1]
    return float(np.max(np.abs(values))) if values is not None and np.size(values) else 1.0


def _load_error(what, p, field, table, size):
    k = table.shape[0]
    if p.force.shape != (k, 3) or p.torque.shape != (k, 3):
        return f"{what}: force and torque need one row of 3 per entry"
    if p.omega.shape != (k,) or p.phase.shape != (k,) or p.work.shape != (k,):
        return f"{what}: omega, phase and work need one entry per row"
    if p.values.shape != p.times.shape:
        return f"{what}: the amplitude table's times and values differ in length"
    o, m = p.table, p.times.shape[0]
    if o.shape != (k + 1,) or o[0] < 0 or o[-1] > m or np.any(np.diff(o) < 0):
        return f"{what}.table is not an offset table of {k} rows into {m} table entries"
    return index_error(f"{what}.{field}", table, size)


class Gravity(Effect):
    """Uniform gravity g (lab frame) on every mass of the net."""

    kind = "gravity"
    keys = (Key("g", vec3, ACCELERATION, doc="acceleration of gravity, lab frame"),)
    record = GravityParams

    @property
    def conservative(self) -> bool:
        return True

    @classmethod
    def example(cls):
        net, line = samples.rod()
        net.add_node((0.0, 0.0, 0.1), mass=0.2, inertia=(1e-4, 1e-4, 1e-4))
        return net, [cls()]

    @staticmethod
    def table_error(p, model):
        return "gravity: g needs 3 components" if p.g.shape != (3,) else None

    def __init__(self, g=(0.0, 0.0, -9.81)):
        self.g = checks.vec3("Gravity", "g", g)

    def bind(self, on: Binding):
        return GravityParams(self.g.copy())

    def potential(self, p, on: Binding) -> float:
        from ..core.rotations import matrix_from_quat
        m, s = on.model, on.state
        # einsum, not BLAS: a threaded BLAS call here leaves its threads spinning on the
        # cores the step's thread pool is about to use
        e = -float(np.einsum("i,ij,j->", m.vertex_mass, s.x, p.g))
        own = np.flatnonzero(m.node_own_mass > 0)       # the nodes' own masses sit at their reference points
        if own.size:
            ref = s.node_x[own] - np.einsum("nij,nj->ni", matrix_from_quat(s.node_q[own]), m.node_com_offset[own])
            e -= float(np.einsum("i,ij,j->", m.node_own_mass[own], ref, p.g))
        return e

    def load_scale(self, net) -> float:
        return net.total_mass() * float(np.linalg.norm(self.g))

    def exchange(self, p, on: Binding) -> float:
        """Weight of the net times the diagonal of its bounding box."""
        x = np.concatenate([on.state.x, on.state.node_x])
        size = float(np.linalg.norm(x.max(axis=0) - x.min(axis=0)))
        return on.net.total_mass() * float(np.linalg.norm(p.g)) * size

    def describe(self):
        return f"Gravity(g={self.g.tolist()})"


class _RowLoad(Effect):
    """A declared load of rows (node or line loads, joined when declared one after another):
    the work each row has done is its account, part of sim.load_work(), and the checkpoint's."""

    work_kind = "load"

    def work(self, sim) -> float:
        """Work this load has done on the net so far (J), part of sim.load_work()."""
        return float(np.sum(self.params(sim).work))

    def state_arrays(self, sim) -> dict:
        return {"work": self.params(sim).work}


class NodeLoad(_RowLoad):
    """External force F (at the node's reference point) and torque L on a node, lab frame
    (1.5)/(1.7), scaled by amplitude(t) = interp(t, times, values) * sin(omega t + phase)
    (each factor 1 when not given)."""

    kind = "node_load"
    keys = (Key("node", "node", required=True, doc="the loaded node"),
            Key("force", vec3, FORCE, doc="force at the node's reference point, lab frame"),
            Key("torque", vec3, TORQUE, doc="torque, lab frame"), *AMPLITUDE)
    record = NodeLoadParams
    adds_energy = True
    join = staticmethod(join_loads)

    @classmethod
    def example(cls):
        net, line = samples.rod()
        return net, [cls(line.end, force=(0.0, 0.0, 1.0), torque=(0.1, 0.0, 0.0))]

    @staticmethod
    def table_error(p, model):
        return _load_error("node load", p, "nodes", p.nodes, model.node_mass.shape[0])


    def __init__(self, node: Node, force=(0.0, 0.0, 0.0), torque=(0.0, 0.0, 0.0), *,
                 times=None, values=None, omega=0.0, phase=0.0):
        who = f"NodeLoad on {node!r}"
        if not isinstance(node, Node):
            raise ValueError(f"NodeLoad: node must be a cosnet Node, got {node!r}")
        self.node = node
        self.force = checks.vec3(who, "force", force)
        self.torque = checks.vec3(who, "torque", torque)
        self.amp = _amplitude(who, times, values, omega, phase)

    def load_scale(self, net) -> float:
        return float(np.linalg.norm(self.force)) * _peak(self.amp)

    def bind(self, on: Binding):
        on.check_node(self.node, "NodeLoad")
        return NodeLoadParams(np.array([self.node.index], dtype=np.int64), self.force[None].copy(),
                              self.torque[None].copy(), *(a.copy() for a in self.amp), np.zeros(1))


class LineLoad(_RowLoad):
    """Distributed force f and torque l per unit rest length on a line, lab frame (1.4)."""

    kind = "line_load"
    keys = (Key("line", "line", required=True, doc="the loaded line"),
            Key("force_per_length", vec3, FORCE_PER_LENGTH, doc="force per unit rest length, lab frame"),
            Key("torque_per_length", vec3, TORQUE_PER_LENGTH, doc="torque per unit rest length, lab frame"),
            *AMPLITUDE)
    record = LineLoadParams
    adds_energy = True
    join = staticmethod(join_loads)

    @classmethod
    def example(cls):
        net, line = samples.rod()
        return net, [cls(line, force_per_length=(0.0, 0.0, 1.0), torque_per_length=(0.1, 0.0, 0.0))]

    @staticmethod
    def table_error(p, model):
        return _load_error("line load", p, "lines", p.lines, model.line_vertex_offsets.shape[0] - 1)


    def __init__(self, line: Line, force_per_length=(0.0, 0.0, 0.0), torque_per_length=(0.0, 0.0, 0.0),
                 *, times=None, values=None, omega=0.0, phase=0.0):
        if not isinstance(line, Line):
            raise ValueError(f"LineLoad: line must be a cosnet Line, got {line!r}")
        who = f"LineLoad on {line!r}"
        self.line = line
        self.force = checks.vec3(who, "force_per_length", force_per_length)
        self.torque = checks.vec3(who, "torque_per_length", torque_per_length)
        self.amp = _amplitude(who, times, values, omega, phase)

    def load_scale(self, net) -> float:
        return float(np.linalg.norm(self.force)) * self.line.length * _peak(self.amp)

    def bind(self, on: Binding):
        on.check_line(self.line, "LineLoad")
        return LineLoadParams(np.array([self.line.index], dtype=np.int64), self.force[None].copy(),
                              self.torque[None].copy(), *(a.copy() for a in self.amp), np.zeros(1))


class Damping(Effect):
    """Linear, mass-proportional viscous damping: every velocity decays as exp(-nu t), every
    angular velocity as exp(-nu_r t). Integrated exactly, so stable at any dt; the kinetic
    energy it takes is ``dissipated(sim)``, part of ``sim.dissipated()``."""

    kind = "damping"
    keys = (Key("translational", nonnegative, RATE, required=True, doc="decay rate of velocities"),
            Key("rotational", nonnegative, RATE, doc="decay rate of angular velocities (default: translational)"))
    record = DampingParams

    @classmethod
    def example(cls):
        return samples.rod()[0], [cls(1.0, 2.0)]

    def __init__(self, translational: float = 0.0, rotational: float | None = None):
        nu = float(translational)
        nr = nu if rotational is None else float(rotational)
        for name, x in (("translational", nu), ("rotational", nr)):
            checks.nonnegative("Damping", f"{name} rate", x)
        self.translational, self.rotational = nu, nr

    def bind(self, on: Binding):
        return DampingParams(self.translational, self.rotational, np.zeros(1),
                             np.zeros((on.model.node_mass.shape[0], 10)))

    def dissipated(self, sim) -> float:
        """Kinetic energy taken so far (J), driven nodes' included (their drives put it back,
        part of sim.driver_work())."""
        return float(self.params(sim).dissipated[0])

    def state_arrays(self, sim) -> dict:
        p = self.params(sim)
        return {"dissipated": p.dissipated, "node_dissipated": p.node_dissipated}

    def node_dissipated(self, sim, node: Node) -> tuple[np.ndarray, float]:
        """((3, 3), float): of dissipated(sim), what was taken from ``node``'s translation,
        sum 1/2 m (1 - c^2) v v^T (its trace the energy; a drive pays the components it
        holds), and from its rotation."""
        sim.check_node(node, "Damping")
        row = self.params(sim).node_dissipated[node.index]
        return row[:9].reshape(3, 3).copy(), float(row[9])

    def describe(self):
        return f"Damping(translational={self.translational:g}/s, rotational={self.rotational:g}/s)"
