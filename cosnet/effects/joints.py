"""Penalty joints between two line ends (spherical, hinge, fixed), after the Elastica joints.

A joint is an alternative to a shared node: two line ends, each on its own node, are held
together by stiff springs (kernels: cosnet.kernels.joints). The constraint is met only to
O(load / k), but any two line ends can be joined, and the stable step shrinks as
1 / sqrt(k) (``max_omega2``). With zero damping the springs conserve energy; their potential
is part of ``Simulation.energy()``.

    SphericalJoint(line_a, end_a, line_b, end_b, k=..., nu=0.0, rest_offset=(0, 0, 0))
    HingeJoint(..., normal=(0, 0, 1), kt=..., nut=0.0)
    FixedJoint(..., kt=..., nut=0.0, angle=None, axis=(0, 0, 1))

end_a / end_b are "start" or "end". rest_offset is x_b - x_a at rest (lab). Torques act on
the line-end frames D X (1.3), i.e. on the nodes the ends are attached to, so a stiff fixed
joint tends to the exact junction of the two ends at one node.
"""

from __future__ import annotations

import math

import numpy as np

from ..core import samples
from ..engine.bounds import index_error
from ..core import checks
from ..core.rotations import matrix_from_quat, matrix_from_rotvec, quat_from_matrix
from ..kernels import joints as _joint_kernels
from ..kernels.joints import FixedJointParams, HingeJointParams, SphericalJointParams
from ..kernels.layout import typed_call
from ..core.net import Line
from ..engine.registry import Binding, Effect, Key
from ..core.units import (DAMPING, LENGTH, ROTARY_DAMPING, ROTARY_STIFFNESS, STIFFNESS, choice, nonnegative,
                          number, positive, vec3)

ENDS = {"start": 0, "end": 1}
JOINT_KEYS = (Key("line_a", "line", required=True, doc="the line of end a"),
              Key("end_a", choice(*ENDS), required=True, doc="which end of line_a"),
              Key("line_b", "line", required=True, doc="the line of end b"),
              Key("end_b", choice(*ENDS), required=True, doc="which end of line_b"),
              Key("k", positive, STIFFNESS, required=True, doc="spring stiffness"),
              Key("nu", nonnegative, DAMPING, doc="damping of the relative velocity"),
              Key("rest_offset", vec3, LENGTH, doc="x_b - x_a at rest, lab frame"))
TORQUE_KEYS = (Key("kt", positive, ROTARY_STIFFNESS, required=True, doc="torque spring stiffness"),
               Key("nut", nonnegative, ROTARY_DAMPING, doc="damping of the relative angular velocity"))


def _unit(owner, name, value):
    v = checks.vec3(owner, name, value)
    size = float(np.linalg.norm(v))
    if size == 0:
        raise ValueError(f"{owner}: {name} must be a non-zero vector")
    return v / size


class SphericalJoint(Effect):
    """Hold end ``end_a`` of ``line_a`` and end ``end_b`` of ``line_b`` together with a spring
    k (N/m) and a damper nu (N s/m) on their relative velocity: f = k (eps - eps0) + nu dot
    eps on end a, -f on end b, eps = x_b - x_a (lab); the lines turn freely about the joint."""

    kind = "spherical_joint"
    keys: tuple[Key, ...] = JOINT_KEYS
    record = SphericalJointParams
    energy_kernel = staticmethod(_joint_kernels.spherical_energy)

    @property
    def internal(self) -> bool:
        return True

    @property
    def conservative(self) -> bool:
        return self.nu == 0 and getattr(self, "nut", 0.0) == 0

    @classmethod
    def example(cls):
        net, a, b = samples.chain()
        extra = {} if cls is SphericalJoint else {"kt": 1.0}
        if cls.kind == "hinge_joint":
            extra["normal"] = (0.0, 0.0, 1.0)
        return net, [cls(a, "end", b, "start", k=1e4, **extra)]

    @staticmethod
    def table_error(p, model):
        """What is wrong with the index tables of record ``p`` for ``model``, or None."""
        what = type(p).__name__
        k = p.k.shape[0]
        for name, a in zip(p._fields, p):
            if a.shape[0] != k:
                return f"{what}.{name} has {a.shape[0]} rows for {k} joints"
        na = model.attach_node.shape[0]
        return index_error(f"{what}.attach_a", p.attach_a, na) or index_error(f"{what}.attach_b", p.attach_b, na)

    def __init__(self, line_a: Line, end_a: str, line_b: Line, end_b: str, *, k: float,
                 nu: float = 0.0, rest_offset=(0.0, 0.0, 0.0)):
        name = type(self).__name__
        for which, line, end in (("line_a", line_a, end_a), ("line_b", line_b, end_b)):
            if not isinstance(line, Line):
                raise ValueError(f"{name}: {which} must be a cosnet Line, got {line!r}")
            if not isinstance(end, str) or end not in ENDS:
                raise ValueError(f"{name}: end of {which} must be 'start' or 'end', got {end!r}")
        if line_a is line_b and end_a == end_b:
            raise ValueError(f"{name}: joins the {end_a} of {line_a!r} to itself; give two different line ends")
        self.line_a, self.end_a, self.line_b, self.end_b = line_a, end_a, line_b, end_b
        self.who = f"{name}({line_a.name!r} {end_a}, {line_b.name!r} {end_b})"
        self.k = checks.positive(self.who, "k", k)
        self.nu = checks.nonnegative(self.who, "nu", nu)
        self.rest_offset = checks.vec3(self.who, "rest_offset", rest_offset)

    # -------------------------------------------------------------- binding
    def _attachments(self, on: Binding):
        for line in (self.line_a, self.line_b):
            on.check_line(line, self.who)
        return (2 * self.line_a.index + ENDS[self.end_a], 2 * self.line_b.index + ENDS[self.end_b])

    def _end_frame(self, on: Binding, a) -> np.ndarray:
        """(3, 3) line-end frame E = D X of attachment a (columns d1 d2 d3, lab)."""
        m = on.model
        nd = m.attach_node[a]
        return matrix_from_quat(on.state.node_q[nd]) @ matrix_from_quat(m.attach_frame[a])

    def _torque_fields(self, on: Binding, a, b) -> tuple:
        """The kind's own fields after the spherical ones (none for a spherical joint)."""
        return ()

    def bind(self, on: Binding):
        a, b = self._attachments(on)
        return self.record(np.array([a], dtype=np.int64), np.array([b], dtype=np.int64),
                           np.array([self.k]), np.array([self.nu]), self.rest_offset[None].copy(),
                           *self._torque_fields(on, a, b))

    # -------------------------------------------------------------- energy and stability
    def potential(self, p, on: Binding) -> float:
        return float(typed_call(self.energy_kernel, p, on.model, on.state))

    @staticmethod
    def _end_inverse_inertia(m, a):
        """(inverse mass of end a seen by a force at it, largest inverse rotary inertia)."""
        nd = m.attach_node[a]
        inv_j = float(np.max(m.node_inv_inertia[nd]))
        lever = float(np.dot(m.attach_offset[a], m.attach_offset[a]))
        return float(m.node_inv_mass[nd]) + lever * inv_j, inv_j

    def omega2(self, p, on: Binding) -> float:
        """k (1/m_a + 1/m_b) + (nu (1/m_a + 1/m_b))^2, and the same with kt, nut and the ends'
        rotary inertias: an upper bound of the joint's frequencies (a damper's rate enters the
        explicit kick like a frequency); the largest over the record's joints."""
        kt, nut = (p.kt, p.nut) if hasattr(p, "kt") else (np.zeros_like(p.k), np.zeros_like(p.nu))
        w2 = 0.0
        for j in range(p.k.shape[0]):
            (ma, ja) = self._end_inverse_inertia(on.model, int(p.attach_a[j]))
            (mb, jb) = self._end_inverse_inertia(on.model, int(p.attach_b[j]))
            im, ij = ma + mb, ja + jb
            w2 = max(w2, float(p.k[j] * im + (p.nu[j] * im) ** 2 + kt[j] * ij + (nut[j] * ij) ** 2))
        return w2

    def describe(self):
        return f"{self.who}, k = {self.k:g} N/m"


class _TorqueJoint(SphericalJoint):
    """A spherical joint plus a torque spring kt (N m) and damper nut (N m s) between the two
    line-end frames."""

    def __init__(self, line_a, end_a, line_b, end_b, *, k, kt, nu=0.0, nut=0.0, rest_offset=(0.0, 0.0, 0.0)):
        super().__init__(line_a, end_a, line_b, end_b, k=k, nu=nu, rest_offset=rest_offset)
        self.kt = checks.positive(self.who, "kt", kt)
        self.nut = checks.nonnegative(self.who, "nut", nut)

    def describe(self):
        return f"{self.who}, k = {self.k:g} N/m, kt = {self.kt:g} N m"


class HingeJoint(_TorqueJoint):
    """Spherical joint that also keeps line b's end tangent t_b in the plane through line a's
    end with unit normal n: torque -kt s (t_b x n) on end b and its opposite on end a, with
    s = t_b . n (energy kt s^2 / 2). ``normal`` is given in the lab for the net as built and
    then turns with line a's end frame (choose it normal to line a's tangent for a hinge axis
    along n through that end)."""

    kind = "hinge_joint"
    keys = JOINT_KEYS + TORQUE_KEYS + (Key("normal", vec3, doc="plane normal n, lab frame as built"),)
    record = HingeJointParams
    energy_kernel = staticmethod(_joint_kernels.hinge_energy)

    def __init__(self, line_a, end_a, line_b, end_b, *, k, kt, normal=(0.0, 0.0, 1.0), nu=0.0,
                 nut=0.0, rest_offset=(0.0, 0.0, 0.0)):
        super().__init__(line_a, end_a, line_b, end_b, k=k, kt=kt, nu=nu, nut=nut, rest_offset=rest_offset)
        self.normal = _unit(self.who, "normal", normal)

    def _torque_fields(self, on, a, b):
        n_a = self._end_frame(on, a).T @ self.normal
        return np.array([self.kt]), np.array([self.nut]), n_a[None].copy()


class FixedJoint(_TorqueJoint):
    """Spherical joint that also holds the relative rotation R = E_a^T E_b of the two line-end
    frames at its rest value R0 (PyElastica's FixedJoint): torque -kt E_b theta on end b and
    its opposite on end a, theta the rotation vector of R0^T R (energy kt |theta|^2 / 2).
    angle=None takes R0 from the net as built; otherwise line b's end frame rests at line a's
    turned by ``angle`` (rad) about ``axis`` (lab, as built)."""

    kind = "fixed_joint"
    keys = JOINT_KEYS + TORQUE_KEYS + (
        Key("angle", number, doc="rest rotation of end b's frame from end a's (rad); default: as built"),
        Key("axis", vec3, doc="axis of that rotation, lab frame as built"))
    record = FixedJointParams
    energy_kernel = staticmethod(_joint_kernels.fixed_energy)

    def __init__(self, line_a, end_a, line_b, end_b, *, k, kt, angle=None, axis=(0.0, 0.0, 1.0),
                 nu=0.0, nut=0.0, rest_offset=(0.0, 0.0, 0.0)):
        super().__init__(line_a, end_a, line_b, end_b, k=k, kt=kt, nu=nu, nut=nut, rest_offset=rest_offset)
        if angle is not None:
            angle = float(angle)
            if not math.isfinite(angle):
                raise ValueError(f"{self.who}: angle must be a finite number (rad), got {angle}")
        self.angle, self.axis = angle, _unit(self.who, "axis", axis)

    def _torque_fields(self, on, a, b):
        ea = self._end_frame(on, a)
        if self.angle is None:
            r0 = ea.T @ self._end_frame(on, b)
        else:
            r0 = matrix_from_rotvec(self.angle * (ea.T @ self.axis))  # axis in a's end frame
        return np.array([self.kt]), np.array([self.nut]), quat_from_matrix(r0)[None].copy()
