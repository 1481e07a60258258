"""Driven nodes: prescribed motion of a node's position, rotation or both (docs/drives.md).

A ``Path`` is a function of time given as data: rate * t + amplitude sin(omega t + phase) plus a
clamped cubic spline through (times, values). A ``Drive`` makes a node follow paths from
where it was built: its position by a displacement path, its rotation by an angle path about a
fixed lab axis or by an orientation path (a rotation vector, tabulated directly or as
quaternions). The node is then kinematic (cosnet.kernels.drives): the step sets it, the
loads do not move it, and the force and torque its driver supplies are reported.
"""

from __future__ import annotations

import numpy as np

from ..core import samples
from ..core import checks
from ..engine.registry import Binding, Effect, Key
from ..core.units import ANGULAR_VELOCITY, LENGTH, RATE, TIME, VELOCITY, BadValue, shown, boolean, direction, number
from ..kernels.drives import ACROSS_AXIS, FREE, ORIENTED, PRESCRIBED, VARIANTS, DriveParams, drive_record, eval_path
from ..kernels.layout import typed_call, typed_entry
from ..core.net import Node

# the keys of a path (a scene's inline table) and their units by the path they belong to:
# (length, mass, time) exponents, cosnet.scene.loader converts them from a [scale]
PATH_KEYS = ("rate", "amplitude", "omega", "phase", "times", "values", "quaternions")
PATH_UNITS = {"position": {"rate": VELOCITY, "amplitude": LENGTH, "values": LENGTH, "times": TIME, "omega": RATE},
              "rotation": {"rate": ANGULAR_VELOCITY, "times": TIME, "omega": RATE},
              "orientation": {"rate": ANGULAR_VELOCITY, "times": TIME, "omega": RATE},
              "factor": {"rate": RATE, "times": TIME, "omega": RATE}}
# quaternions further than this from unit norm are refused rather than normalised
QUAT_NORM_TOL = 1e-3


def path_table(v):
    """Scene converter: an inline table of Path keywords, numbers or (nested) lists of numbers."""
    if not isinstance(v, dict):
        raise BadValue(f"must be an inline table of {', '.join(PATH_KEYS)}, got {shown(v)}")
    out = {}
    for k, x in v.items():
        if k not in PATH_KEYS:
            raise BadValue(f"unknown key {k!r} in the path; a path has {', '.join(PATH_KEYS)}")
        if isinstance(x, list):
            try:
                out[k] = np.array(x, dtype=float)
            except (ValueError, TypeError):
                raise BadValue(f"{k} must be numbers or lists of numbers, got {shown(x)}") from None
            if not np.all(np.isfinite(out[k])):
                raise BadValue(f"{k} must be finite, got {shown(x)}")
        else:
            try:
                out[k] = number(x)
            except BadValue as e:
                raise BadValue(f"{k} {e}") from None
    return out
def rotation_vectors(quaternions, who):
    """(m, 3) rotation vectors of (m, 4) quaternions (w, x, y, z), each the one nearest the
    previous (adding whole turns about its axis, or flipping it), so that a spline through them
    turns the short way between neighbours; quaternions off unit norm by more than
    QUAT_NORM_TOL are refused, the others normalised."""
    q = np.array(quaternions, dtype=float)
    if q.ndim != 2 or q.shape[1] != 4 or not np.all(np.isfinite(q)):
        raise ValueError(f"{who}: quaternions must be rows of 4 finite numbers (w, x, y, z), got shape {q.shape}")
    norm = np.linalg.norm(q, axis=1)
    bad = np.flatnonzero(np.abs(norm - 1.0) > QUAT_NORM_TOL)
    if bad.size:
        raise ValueError(f"{who}: quaternions must be unit, quaternions[{bad[0]}] has norm {norm[bad[0]]:.6g}")
    from ..core.rotations import rotvec_from_quat
    out = np.zeros((q.shape[0], 3))
    prev = np.zeros(3)
    for i, qi in enumerate(q / norm[:, None]):
        r = rotvec_from_quat(qi)
        angle = np.linalg.norm(r)
        axis = r / angle if angle > 1e-12 else (prev / np.linalg.norm(prev) if np.linalg.norm(prev) else r)
        # every rotation vector of the same rotation: (angle + 2 pi j) axis for whole j
        j = np.round((axis @ prev - angle) / (2 * np.pi))
        cands = [(angle + 2 * np.pi * (j + d)) * axis for d in (-1, 0, 1)]
        out[i] = prev = min(cands, key=lambda c: np.linalg.norm(c - prev))
    return out


# relative mismatch above which a driven node's state contradicts its drive
MISMATCH = 1e-9


class Path:
    """A prescribed function of time: rate * t + amplitude * sin(omega t + phase) + spline(t),
    each term optional. The spline is the clamped cubic spline through (times, values), zero
    slope at both ends and held beyond them (C2 inside, C1 at the ends), so a tabulated motion
    starts and stops at rest. For a position path rate, amplitude and each value are 3-vectors
    (m/s, m, m); for an angle path numbers (rad/s, rad, rad); for an orientation path
    3-vectors of a lab rotation vector (rad/s, rad, rad), whose table may be given as unit
    quaternions (w, x, y, z) instead of values: each becomes the rotation vector nearest the
    previous one. A Python function of time cannot drive a compiled step: tabulate it
    (times, values) instead."""

    def __init__(self, rate=None, amplitude=None, omega=0.0, phase=0.0, times=None, values=None,
                 quaternions=None):
        self.rate, self.amplitude, self.omega, self.phase = rate, amplitude, omega, phase
        self.times, self.values, self.quaternions = times, values, quaternions

    @classmethod
    def of(cls, value, who):
        """A Path from a Path or a mapping of its keywords (a scene's inline table)."""
        if isinstance(value, Path):
            return value
        if isinstance(value, dict):
            unknown = sorted(set(value) - set(PATH_KEYS))
            if unknown:
                raise ValueError(f"{who}: unknown key {unknown[0]!r}; a path has {', '.join(PATH_KEYS)}")
            return cls(**value)
        raise ValueError(f"{who}: must be a cosnet Path or a table of {', '.join(PATH_KEYS)}, got {value!r}")

    def arrays(self, k, who, turns=False):
        """Return (rate, amplitude, (omega, phase), times, coefficients) for k components,
        refusing what is not a valid path in one line naming ``who``; ``turns``: an
        orientation path, which may tabulate quaternions."""
        shape = (k,) if k > 1 else ()

        def vec(name, x):
            a = np.zeros(k) if x is None else np.array(x, dtype=float)
            if a.shape not in (shape, (k,)) or not np.all(np.isfinite(a)):
                what = f"{k} finite numbers" if k > 1 else "a finite number"
                raise ValueError(f"{who}: {name} must be {what}, got {x!r}")
            return a.reshape(k)
        rate, amp = vec("rate", self.rate), vec("amplitude", self.amplitude)
        wave = np.array([self.omega, self.phase], dtype=float)
        if not np.all(np.isfinite(wave)):
            raise ValueError(f"{who}: omega and phase must be finite, got {self.omega!r}, {self.phase!r}")
        values = self.values
        if self.quaternions is not None:
            if not turns:
                raise ValueError(f"{who}: quaternions tabulate an orientation path only")
            if values is not None:
                raise ValueError(f"{who}: give values (rotation vectors) or quaternions, not both")
            values = rotation_vectors(self.quaternions, who)
        if (self.times is None) != (values is None):
            raise ValueError(f"{who}: give both times and {'values or quaternions' if turns else 'values'} "
                             f"for a tabulated path")
        if self.times is None:
            return rate, amp, wave, np.zeros(0), np.zeros((0, 4, k))
        t = np.array(self.times, dtype=float)
        v = np.array(values, dtype=float)
        if t.ndim != 1 or t.size < 2 or not np.all(np.isfinite(t)):
            raise ValueError(f"{who}: times must be at least 2 finite numbers, got {self.times!r}")
        if np.any(np.diff(t) <= 0):
            i = int(np.argmax(np.diff(t) <= 0))
            raise ValueError(f"{who}: times must increase strictly (times[{i + 1}] = {t[i + 1]:g} "
                             f"after {t[i]:g})")
        if v.shape != (t.size,) + shape or not np.all(np.isfinite(v)):
            want = f"{t.size} x {k}" if k > 1 else f"{t.size}"
            raise ValueError(f"{who}: values must be {want} finite numbers (one per time), got shape "
                             f"{v.shape}")
        from scipy.interpolate import CubicSpline   # (here: importing it costs every start of cosnet 0.2 s)
        spline = CubicSpline(t, v.reshape(t.size, k), bc_type="clamped", axis=0)
        return rate, amp, wave, t, np.ascontiguousarray(np.transpose(spline.c, (1, 0, 2)))

    def __repr__(self):
        given = {n: getattr(self, n) for n in PATH_KEYS}
        parts = [f"{n}={np.asarray(v).tolist()!r}" for n, v in given.items()
                 if v is not None and not (n in ("omega", "phase") and v == 0.0)]
        return f"Path({', '.join(parts)})"


def driven_nodes(effects, nn: int) -> np.ndarray:
    """(nn,) True at the nodes a Drive among ``effects`` moves: they go where their drive says,
    whatever pushes them (an impulse on them moves nothing)."""
    mask = np.zeros(nn, dtype=bool)
    for e in effects:
        if isinstance(e, Drive):
            mask[e.node.index] = True
    return mask


class Drive(Effect):
    """Prescribed motion of ``node`` (a Node), from where it was built.

    position: a Path of the displacement (lab); rotation: a Path of the angle turned about
    ``axis`` (a lab direction); orientation (instead of rotation): a Path of a lab rotation
    vector r(t), the node turned by exp(r(t)) exp(r(t0))^-1 from its frame as built (a rate
    alone: a constant angular velocity about a fixed lab axis). Without rotation or orientation
    the node turns freely (a driven pin); without position it stays in place (a turned clamp).
    slide=True frees the motion along ``axis`` (a motor shaft: the angle prescribed, sliding
    along the axis allowed, the rest held). A
    fixed node (infinite mass or inertia) cannot be driven: give it a finite mass instead, the
    drive then holds it. ``sim.reaction(node)`` gives the driver's force and torque,
    ``sim.driver_work()`` the work it has done."""

    work_kind = "driver"

    kind = "drive"
    record = DriveParams
    keys = (Key("node", "node", required=True, doc="the driven node"),
            Key("position", path_table, PATH_UNITS["position"],
                doc="displacement path {rate, amplitude, omega, phase, times, values} (lab)"),
            Key("rotation", path_table, PATH_UNITS["rotation"],
                doc="angle path about axis {rate, amplitude, omega, phase, times, values} (rad)"),
            Key("orientation", path_table, PATH_UNITS["orientation"],
                doc="rotation vector path {rate, amplitude, omega, phase, times, values or quaternions} (lab)"),
            Key("axis", direction, doc="rotation (and slide) axis, lab"),
            Key("slide", boolean, doc="free along axis (a motor shaft)"))
    adds_energy = True

    @classmethod
    def example(cls):
        net, line = samples.rod()
        return net, [cls(line.start, position=Path(rate=(0.1, 0.0, 0.0)), rotation=Path(rate=1.0),
                         axis=(0.0, 0.0, 1.0))]

    def __init__(self, node: Node, position=None, rotation=None, axis=None, slide=False, orientation=None):
        if not isinstance(node, Node):
            raise ValueError(f"Drive: node must be a cosnet Node, got {node!r}")
        who = f"Drive on {node!r}"
        self.node = node
        if position is None and rotation is None and orientation is None:
            raise ValueError(f"{who}: give a position path, a rotation or orientation path, or both")
        if rotation is not None and orientation is not None:
            raise ValueError(f"{who}: give a rotation (about axis) or an orientation path, not both")
        self.position = None if position is None else Path.of(position, f"{who}: position")
        self.rotation = None if rotation is None else Path.of(rotation, f"{who}: rotation")
        self.orientation = None if orientation is None else Path.of(orientation, f"{who}: orientation")
        self.slide = bool(slide)
        if axis is None:
            if self.rotation is not None or self.slide:
                raise ValueError(f"{who}: axis is needed for a rotation or slide=True")
            self.axis = np.array([0.0, 0.0, 1.0])
        else:
            self.axis = checks.direction(who, "axis", axis)
        if node.fixed_position:
            raise ValueError(f"{who}: the node is fixed (infinite mass); a drive holds it: give it a finite mass")
        if (self.rotation is not None or self.orientation is not None) and np.any(node.locked_axes):
            raise ValueError(f"{who}: the node has infinite inertia; a drive turning it needs a finite one")
        self._pos = (self.position or Path()).arrays(3, f"{who}: position")
        self._ang = (self.rotation or Path()).arrays(1, f"{who}: rotation")
        self._rv = (self.orientation or Path()).arrays(3, f"{who}: orientation", turns=True)

    def bind(self, on: Binding):
        who = f"Drive on {self.node!r}"
        on.check_node(self.node, "Drive")
        for other in on.effects:
            if other is not self and isinstance(other, Drive) and other.node is self.node:
                raise ValueError(f"{who}: the node has another drive; give one drive per node")
        m, s, nd = on.model, on.state, self.node.index
        if m.node_inv_mass[nd] == 0.0:
            raise ValueError(f"{who}: the node is fixed (infinite mass); a drive holds it: give it a finite mass")
        rot = PRESCRIBED if self.rotation is not None else ORIENTED if self.orientation is not None else FREE
        if rot == PRESCRIBED and np.any(m.node_locked[nd] > 0):
            raise ValueError(f"{who}: the node has infinite inertia; a drive turning it needs a finite one")
        from ..core.rotations import conj, matrix_from_quat, quat_from_rotvec
        rho = matrix_from_quat(s.node_q[nd]) @ m.node_com_offset[nd]
        if rot == FREE and np.linalg.norm(rho) > 1e-12 * (1.0 + np.linalg.norm(s.node_x[nd])):
            raise ValueError(f"{who}: a drive leaving the rotation free needs the node's centre of mass "
                             f"at its reference point (it is {np.linalg.norm(rho):.3g} m away)")
        pos = ACROSS_AXIS if self.slide else PRESCRIBED
        # the paths' values at the start are subtracted (the orientation's undone): the motion
        # starts where the node was built
        out = np.zeros(9)
        eval_path(on.time, *self._rv, np.zeros(3), out, 0)
        back = np.array(conj(quat_from_rotvec(out[:3])))
        # of the variant that compiles the turning only where the rotation is prescribed
        p = drive_record(DriveParams(nd, pos, rot, self.axis.copy(), s.node_x[nd].copy(), rho, s.node_q[nd].copy(),
                                     *self._pos, np.zeros(3), *self._ang, np.zeros(1), *self._rv, np.zeros(3), back,
                                     np.zeros(24), np.zeros(6), np.zeros(1)))
        eval_path(on.time, *self._pos, np.zeros(3), out, 0)
        p.pos_start[:] = out[:3]
        eval_path(on.time, *self._ang, np.zeros(1), out, 0)
        p.ang_start[0] = out[0]
        typed_call(VARIANTS.of(p).kernel("place_drive"), p, m, s)
        return p

    def check_state(self, sim):
        """Refuse a state whose driven node is not where, or not moving as, its drive says."""
        p, st, nd = self.params(sim), sim.state, self.node.index
        rows = (st.node_x, st.node_v, st.node_q, st.node_w)
        now = [a[nd].copy() for a in rows]
        typed_call(VARIANTS.of(p).kernel("place_drive"), p, sim.model, st)
        want = [a[nd].copy() for a in rows]
        for a, v in zip(rows, now):
            a[nd] = v
        scale = 1.0 + float(np.linalg.norm(now[0]))
        for name, i, tol in (("position", 0, scale), ("velocity", 1, scale), ("angular velocity", 3, 1.0)):
            if np.linalg.norm(now[i] - want[i]) > MISMATCH * tol * (1.0 + np.linalg.norm(want[i])):
                raise ValueError(f"Drive on {self.node!r}: the node's {name} {np.round(now[i], 9).tolist()} "
                                 f"contradicts its drive's {np.round(want[i], 9).tolist()} at t = {sim.time:.6g} s")

    def reaction(self, sim, evaluate):
        """(force, torque) the driver supplies now (lab; the torque about the node's centre of
        mass), given ``evaluate``, which evaluates sim.loads at the current state and returns
        them."""
        p = self.params(sim)
        # typed as the step types the records: drive_reaction is then the kick's own, not a
        # second compile; and compiled before the loads are evaluated: at a cold start the step
        # that evaluates them compiles its kernels in two processes, and this one, compiled
        # after, kept this process busy alone at the end
        kernel = VARIANTS.of(p).kernel("reaction_now")
        typed_entry(kernel, p, sim.model, sim.state, sim.loads)
        typed_call(kernel, p, sim.model, sim.state, evaluate())
        return p.reaction[:3].copy(), p.reaction[3:].copy()

    def drives(self, node) -> bool:
        return node is self.node

    def state_arrays(self, sim) -> dict:
        p = self.params(sim)
        return {"work": p.work, "reaction": p.reaction}

    def work(self, sim) -> float:
        """Work done by the driver so far (J): the kicks' quadrature of R.v + T.w, plus the
        kinetic energy damping took from the components it holds (it puts that back)."""
        from .loads import Damping
        p = self.params(sim)
        paid = 0.0
        for e in sim.effects:
            if isinstance(e, Damping):
                moved, turned = e.node_dissipated(sim, self.node)
                if p.position == PRESCRIBED:
                    paid += np.trace(moved)
                elif p.position == ACROSS_AXIS:
                    paid += np.trace(moved) - self.axis @ moved @ self.axis
                if p.rotation != FREE:
                    paid += turned
        return float(p.work[0] + paid)

    def describe(self):
        parts = [f"position={self.position!r}" if self.position else None,
                 f"rotation={self.rotation!r} about {self.axis.tolist()}" if self.rotation else None,
                 f"orientation={self.orientation!r}" if self.orientation else None,
                 "slide" if self.slide else None]
        return f"Drive({self.node.name!r}, {', '.join(x for x in parts if x)})"
