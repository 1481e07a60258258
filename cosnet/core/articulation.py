"""Articulated line ends (§8): hinges, universal joints and ball joints at a node, exact.

A line end is welded to its node unless it declares a joint:

    net.add_line(a, b, ..., start_joint=cosnet.Hinge(axis=(0, 0, 1)), end_joint=None)

    Hinge(axis, stiffness=0, rest=0, damping=0, friction=(0, 0), limits=None, spring_table=None)
    Universal(axes=(a, b), ...)   a stays with the node, b turns with the line (a Cardan cross)
    Ball(cone=None, stiffness=0, rest=(0, 0, 0), damping=0, friction=(0, 0))

Axes are given in the node's body frame as the net is built (a line's own end turns with the
joint). Per coordinate (one for a hinge, two for a universal joint, three for a ball joint:
its rotation vector in the line end's frame as built): a spring ``stiffness`` (N m/rad) about
``rest`` (rad) or a ``spring_table`` = (angles, torques) of the torque resisting each angle
(piecewise linear, its end segments carried on), a damper ``damping`` (N m s/rad), Coulomb
``friction`` = (static, kinetic) torques (N m) that stick (a ball joint's: one pair, resisting
its rotation as a whole), and ``limits`` = (lower, upper)
(rad) a coordinate cannot leave (a ball joint: ``cone``, the largest angle its line end's axis
may turn from where it was built). A number applies to every coordinate, a list gives one
per coordinate. The joint's relative rotation is restricted exactly (kernels/articulation.py),
so a free axis costs no stiffness in the step. A scene declares the same as
``start_joint = { kind = "hinge", axis = [0, 0, 1] }`` in ``[lines.X]``.

The joints of a net act through one effect (cosnet.effects.articulations), which a Simulation adds
when a line declares a joint.
"""

from __future__ import annotations

import copy
import math

import numpy as np

from . import checks
from ..kernels.joint_math import BALL, HINGE, UNIVERSAL

def _per_axis(who: str, name: str, value, n: int, check) -> np.ndarray:
    """(3,) one value per coordinate (zeros past n): a number for all, or a list of n."""
    if isinstance(value, (list, tuple, np.ndarray)):
        if len(value) != n:
            raise ValueError(f"{who}: {name} must be a number or {n} numbers (one per axis), got {value!r}")
        vals = [check(who, name, v) for v in value]
    else:
        vals = [check(who, name, value)] * n
    return np.array(vals + [0.0] * (3 - n), dtype=float)


def _finite(who: str, name: str, value) -> float:
    x = checks.number(who, name, value)
    if not math.isfinite(x):
        raise ValueError(f"{who}: {name} must be a finite number, got {value!r}")
    return x


class Joint:
    """What an articulated line end allows: its kind's coordinates, springs, dampers,
    friction and limits (module docstring). Use Hinge, Universal or Ball."""

    kind = ""
    dofs = 0

    def __init__(self, *, stiffness=0.0, rest=0.0, damping=0.0, friction=(0.0, 0.0), limits=None,
                 spring_table=None):
        who, n = self.who, self.dofs
        self.tables = self._tables(spring_table)
        self.stiffness = _per_axis(who, "stiffness", stiffness, n, checks.nonnegative)
        self.rest = _per_axis(who, "rest", rest, n, _finite)
        self.damping = _per_axis(who, "damping", damping, n, checks.nonnegative)
        if not isinstance(friction, (list, tuple)) or len(friction) != 2:
            raise ValueError(f"{who}: friction must be (static, kinetic) torques, got {friction!r}")
        self.static = _per_axis(who, "friction (static)", friction[0], n, checks.nonnegative)
        self.kinetic = _per_axis(who, "friction (kinetic)", friction[1], n, checks.nonnegative)
        if np.any(self.kinetic > self.static):
            raise ValueError(f"{who}: the kinetic friction torque must not exceed the static one, got "
                             f"friction = {friction!r}")
        self.lower = np.full(3, -math.inf)
        self.upper = np.full(3, math.inf)
        self.cone = math.pi
        if limits is not None:
            self._limits(limits)

    def _tables(self, given) -> list:
        """One (angles, torques) table per coordinate (None: none) from spring_table: a table
        (angles, torques) for every coordinate, or a list of one per coordinate."""
        who, n = self.who, self.dofs
        if given is None:
            return [None] * n
        def one_table(t):   # (angles, torques): two sequences
            return isinstance(t, (list, tuple)) and len(t) == 2 and isinstance(t[0], (list, tuple, np.ndarray))
        per_axis = n > 1 and isinstance(given, (list, tuple)) and len(given) == n and \
            all(t is None or one_table(t) for t in given) and not one_table(given)
        per = list(given) if per_axis else [given] * n
        out: list = []
        for t in per:
            if t is None:
                out.append(None)
                continue
            try:
                a, q = (np.array(x, dtype=float) for x in t)
            except (TypeError, ValueError):
                raise ValueError(f"{who}: spring_table must be (angles, torques), got {given!r}") from None
            if a.ndim != 1 or a.shape != q.shape or a.size < 2 or not np.all(np.isfinite(a)) or \
                    not np.all(np.isfinite(q)):
                raise ValueError(f"{who}: spring_table must be two lists of the same length >= 2 of finite "
                                 f"numbers (angles in rad, torques in N m), got {given!r}")
            if np.any(np.diff(a) <= 0):
                raise ValueError(f"{who}: spring_table's angles must increase, got {a.tolist()}")
            out.append((a, q))
        return out

    @property
    def who(self) -> str:
        return type(self).__name__

    def _limits(self, limits):
        who, n = self.who, self.dofs
        pairs = limits if n > 1 and isinstance(limits, (list, tuple)) and limits \
            and isinstance(limits[0], (list, tuple)) else [limits] * n
        if len(pairs) != n:
            raise ValueError(f"{who}: limits must be (lower, upper) or {n} such pairs, got {limits!r}")
        for i, pair in enumerate(pairs):
            if not isinstance(pair, (list, tuple)) or len(pair) != 2:
                raise ValueError(f"{who}: limits must be (lower, upper) in rad, got {limits!r}")
            lo, hi = (checks.number(who, "limits", v) for v in pair)
            if math.isnan(lo) or math.isnan(hi) or not lo < hi:
                raise ValueError(f"{who}: limits must have lower < upper, got {list(pair)!r}")
            if not lo <= 0.0 <= hi:
                raise ValueError(f"{who}: limits {list(pair)!r} must hold the angle as built, 0")
            self.lower[i], self.upper[i] = lo, hi

    def scaled(self, torque: float, rotary_damping: float) -> Joint:
        """A copy with its torques times ``torque`` and its dampers times ``rotary_damping``
        (units of a [scale]: angles and axes do not change)."""
        out = copy.copy(self)
        out.stiffness, out.static, out.kinetic = self.stiffness * torque, self.static * torque, self.kinetic * torque
        out.tables = [None if t is None else (t[0], t[1] * torque) for t in self.tables]
        out.damping = self.damping * rotary_damping
        return out

    def axes_in(self, to_end: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        """(a, b): the joint's axes in the line end's frame X (3-vectors), given the rotation
        taking the node's body components to X's."""
        return np.zeros(3), np.zeros(3)

    def __repr__(self):
        return f"{self.who}()"


class Hinge(Joint):
    """One relative rotation, about ``axis`` (node's body frame)."""

    kind, dofs = "hinge", HINGE

    def __init__(self, axis=(0.0, 0.0, 1.0), **kw):
        self.axis = checks.direction(self.who, "axis", axis)
        super().__init__(**kw)

    def axes_in(self, to_end):
        return to_end @ self.axis, np.zeros(3)

    def __repr__(self):
        return f"Hinge(axis={self.axis.tolist()})"


class Universal(Joint):
    """Two relative rotations: about the first of ``axes`` (fixed in the node), then about the
    second (fixed in the line's end: the cross of a Cardan joint), both given in the node's
    body frame as built."""

    kind, dofs = "universal", UNIVERSAL

    def __init__(self, axes=((1.0, 0.0, 0.0), (0.0, 1.0, 0.0)), **kw):
        if not isinstance(axes, (list, tuple)) or len(axes) != 2:
            raise ValueError(f"{self.who}: axes must be two axes, got {axes!r}")
        a, b = (checks.direction(self.who, "axes", v) for v in axes)
        if np.linalg.norm(np.cross(a, b)) < 1e-6:
            raise ValueError(f"{self.who}: the two axes must not be parallel, got {axes!r}")
        self.axes = (a, b)
        super().__init__(**kw)

    def axes_in(self, to_end):
        return to_end @ self.axes[0], to_end @ self.axes[1]

    def __repr__(self):
        return f"Universal(axes={[x.tolist() for x in self.axes]})"


class Ball(Joint):
    """Three relative rotations (the rotation vector, line end's frame as built); ``cone``:
    the largest angle (rad) the line end's axis d3 may turn from where it was built."""

    kind, dofs = "ball", BALL

    def __init__(self, cone=None, **kw):
        if kw.get("limits") is not None:
            raise ValueError("Ball: limits are per axis; a ball joint takes a cone (its largest tilt, rad)")
        friction = kw.get("friction", (0.0, 0.0))
        if isinstance(friction, (list, tuple)) and any(isinstance(v, (list, tuple, np.ndarray)) for v in friction):
            raise ValueError(f"Ball: friction acts on the joint's rotation as a whole: give one static and one "
                             f"kinetic torque (N m), got friction = {friction!r}")
        super().__init__(**kw)
        if cone is not None:
            c = checks.number(self.who, "cone", cone)
            if not 0.0 < c <= math.pi:
                raise ValueError(f"Ball: cone must be an angle in (0, pi] rad, got {cone!r}")
            self.cone = c


JOINTS = {cls.kind: cls for cls in (Hinge, Universal, Ball)}


def joint_value(who: str, value) -> Joint | None:
    """value if it is a Joint or None, else a ValueError in one line."""
    if value is None or isinstance(value, Joint):
        return value
    raise ValueError(f"{who}: must be a cosnet joint ({', '.join(c.__name__ for c in JOINTS.values())}) "
                     f"or None (welded), got {value!r}")
