"""The joints of a net in motion: the effect a Simulation adds when a line declares a joint.

Its energy (the joints' springs and the bending of the articulated ends) is part of
``sim.energy()``, what dampers and friction take part of ``sim.dissipated()``, and
``joint_state(sim, line, end)`` reads a joint's angles, rates and reaction torque (the
kernels: kernels/articulation.py; the joints: cosnet.core.articulation).
"""

from __future__ import annotations

import numpy as np

from ..core import samples
from ..core.articulation import Hinge
from ..engine.bounds import index_error, offsets_error
from ..kernels.articulation import VARIANTS, ArticulationParams, articulation_record
from ..kernels.joint_lanes import LANE_CONSTANTS, LANE_ROWS, lane_count, lane_tables
from ..kernels.layout import typed_call
from ..engine.registry import Binding, Effect
from ..core.rotations import matrix_from_quat

ENDS = ("start", "end")


class Articulations(Effect):
    """The articulated line ends of a net: each joint's coordinates settle where its loads
    balance at every evaluation (kernels/articulation.py). ``ends``: (attachment, Joint,
    bend) per articulated end, bend the (3,) bending and twisting stiffness of its boundary
    Voronoi point, which the model no longer holds (cosnet.engine.flatten)."""

    record = ArticulationParams
    adds_energy = False

    @property
    def internal(self) -> bool:
        return True

    @property
    def conservative(self) -> bool:
        return not any(np.any(j.damping) or np.any(j.static) or np.any(j.kinetic) for _, j, _ in self.ends)

    # the probes of a jointed line end ("LINE@start:joint_angle"): its coordinates in the
    # columns _x, _y, _z (zero past the joint's own), and the torque it passes (lab)
    PROBES = {"joint_angle": "angle", "joint_rate": "rate", "joint_reaction": "reaction"}

    @classmethod
    def end_probe_fields(cls, line, end: str) -> tuple:
        return tuple(cls.PROBES) if getattr(line, f"{end}_joint") is not None else ()

    @classmethod
    def end_probe(cls, sim, line, end: str, field: str):
        value = np.zeros(3)
        got = joint_state(sim, line, end)[cls.PROBES[field]]
        value[:got.shape[0]] = got
        return value

    @classmethod
    def implied(cls, net, grids):
        return articulations(net, grids)

    @classmethod
    def example(cls):
        net, _ = samples.rod(fixed=True, start_joint=Hinge(axis=(0.0, 1.0, 0.0), stiffness=2.0, rest=0.1))
        return net, []

    @staticmethod
    def table_error(p, model):
        """What is wrong with the index tables of record ``p`` for ``model``, or None."""
        k, na = p.attach.shape[0], model.attach_node.shape[0]
        rows = [a for name, a in zip(p._fields, p) if name not in ("attach", "table_offsets", "table_angle",
                                                                      "table_torque", "last", "dissipated", "lanes",
                                                                      "lane_constants", "lane_ends")]
        if any(a.shape[0] != k for a in rows) or p.last.shape != (1,) or p.dissipated.shape != (1,):
            return "joints: every table needs one row per articulated line end"
        if np.any((p.dofs < 1) | (p.dofs > 3)):
            return "joints: dofs must be 1 (hinge), 2 (universal) or 3 (ball)"
        m = p.table_angle.shape[0]
        if p.table_offsets.shape != (3 * k + 1,) or p.table_torque.shape != (m,):
            return "joints: table_offsets needs 3 entries per joint and one, table_torque one per angle"
        problem = offsets_error("joints.table_offsets", p.table_offsets, m)
        if problem:
            return problem
        w = lane_count(k)
        if p.lanes.shape != (LANE_ROWS, w) or p.lane_constants.shape != (LANE_CONSTANTS, w) or \
                p.lane_ends.shape != (2, w):
            return (f"joints: lanes, lane_constants and lane_ends need {LANE_ROWS}, {LANE_CONSTANTS} and 2 rows "
                    f"of {w} entries ({k} joints padded to whole vectors)")
        # (lane_ends in range is what the lanes' gathers need; run() rebuilds them from attach
        # before it checks, check_state)
        return (index_error("joints.attach", p.attach, na) or
                index_error("joints.lane_ends", p.lane_ends[0], model.node_mass.shape[0]) or
                index_error("joints.lane_ends", p.lane_ends[1], model.element_rest_length.shape[0]))

    def __init__(self, ends):
        self.ends = list(ends)

    def bind(self, on: Binding):
        k = len(self.ends)
        z = lambda: np.zeros((k, 3))
        # coordinate (j, i) at 3 j + i: its spring table, or none (the kinds' unused coordinates too)
        per = [(joint.tables + [None] * 3)[i] for _, joint, _ in self.ends for i in range(3)]
        tables = [t for t in per if t is not None]
        sizes = [0 if t is None else t[0].size for t in per]
        p = ArticulationParams(
            attach=np.array([a for a, _, _ in self.ends], dtype=np.int64),
            dofs=np.array([j.dofs for _, j, _ in self.ends], dtype=np.int64),
            axis_a=z(), axis_b=z(), bend=np.array([b for _, _, b in self.ends], dtype=float).reshape(k, 3),
            stiffness=z(), rest=z(), damping=z(), static=z(), kinetic=z(), lower=z(), upper=z(),
            cone=np.array([j.cone for _, j, _ in self.ends], dtype=float),
            table_offsets=np.concatenate([[0], np.cumsum(sizes)]).astype(np.int64),
            table_angle=np.concatenate([t[0] for t in tables] or [np.zeros(0)]),
            table_torque=np.concatenate([t[1] for t in tables] or [np.zeros(0)]),
            phi=z(), rate=z(), sliding=z(), reaction=z(), last=on.state.clock.copy(), dissipated=np.zeros(1),
            lanes=np.zeros((LANE_ROWS, lane_count(k))), lane_constants=np.zeros((LANE_CONSTANTS, lane_count(k))),
            lane_ends=np.zeros((2, lane_count(k)), dtype=np.int64))
        m = on.model
        for i, (a, joint, _) in enumerate(self.ends):
            nd = m.attach_node[a]
            # node body components -> principal -> the line end's frame X
            to_end = matrix_from_quat(m.attach_frame[a]).T @ matrix_from_quat(m.node_principal[nd]).T
            p.axis_a[i], p.axis_b[i] = joint.axes_in(to_end)
            for name in ("stiffness", "rest", "damping", "static", "kinetic", "lower", "upper"):
                getattr(p, name)[i] = getattr(joint, name)
            p.phi[i] = np.clip(0.0, joint.lower, joint.upper)
        lane_tables(p, m)
        return articulation_record(p)   # of the variant that compiles only what its joints have

    def potential(self, p, on: Binding) -> float:
        """The joints' springs and the bending of the articulated ends' boundary points."""
        return float(typed_call(VARIANTS.of(p).kernel("articulation_energy"), p, on.model, on.state))

    def exchange(self, p, on: Binding) -> float:
        return abs(self.potential(p, on))

    def held_stiffness(self, p, on: Binding):
        return on.model.attach_vertex[p.attach], p.bend

    def end_fields(self, p, on: Binding):
        """(vertices, frames, torque, curvature) at the articulated ends' boundary points, in
        place of what the model gives there (it holds no stiffness at them): the joint frame
        (quaternion), the internal torque m (lab) and u - u0 (its frame) (3.22)."""
        k = p.attach.shape[0]
        frames, torque, curvature = np.zeros((k, 4)), np.zeros((k, 3)), np.zeros((k, 3))
        typed_call(VARIANTS.of(p).kernel("articulation_fields"), p, on.model, on.state, frames, torque, curvature)
        return on.model.attach_vertex[p.attach], frames, torque, curvature

    def check_state(self, sim):
        """Refresh the joints' constants as the lane pass holds them (lane_tables) from the
        record and the model, which a user may have changed since the last run (where the
        record's line ends are out of range, the table check that follows says so)."""
        p = self.params(sim)
        if index_error("joints.attach", p.attach, sim.model.attach_node.shape[0]) is None:
            lane_tables(p, sim.model)

    def dissipated(self, sim) -> float:
        """Energy the joints' dampers and friction have taken so far (J)."""
        return float(self.params(sim).dissipated[0])

    def state_arrays(self, sim) -> dict:
        p = self.params(sim)
        return {"phi": p.phi, "rate": p.rate, "sliding": p.sliding, "reaction": p.reaction,
                "last": p.last, "dissipated": p.dissipated}

    def describe(self) -> str:
        return f"Articulations({len(self.ends)} joints)"

    def index(self, attach: int) -> int:
        for i, (a, _, _) in enumerate(self.ends):
            if a == attach:
                return i
        raise ValueError(f"line end {attach} has no joint")


def articulations(net, grids) -> Articulations | None:
    """The Articulations effect of the net's jointed line ends (None when every end is
    welded), with each end's boundary stiffness as flatten found it (grid.held_bend)."""
    ends = []
    for line, g in zip(net.lines, grids):
        for side, joint in enumerate((line.start_joint, line.end_joint)):
            if joint is not None:
                ends.append((2 * line.index + side, joint, g.held_bend[side]))
    return Articulations(ends) if ends else None


def condensed_bending(net, model, state, grids) -> list:
    """[(point, S)]: at each articulated end's boundary Voronoi point, the 3x3 bending and
    twisting stiffness (N m/rad, its strain theta's components) left when the joint's free
    coordinates settle, S = B/L - (B/L) C (C^T (B/L) C + k)^-1 C^T (B/L), C the coordinates'
    axes as built, k their springs (the linearisation of kernels/articulation.py about rest).
    A coordinate held by static friction counts as welded (small motions do not slide it)."""
    joints = articulations(net, grids)
    if joints is None:
        return []
    p = joints.bind(Binding(net, model, state))
    out = []
    for j, a in enumerate(p.attach):
        point = int(model.attach_vertex[a])
        bend = np.diag(p.bend[j]) * model.voronoi_inv_rest_length[point]
        n = int(p.dofs[j])
        cols = np.eye(3) if n == 3 else np.column_stack([p.axis_a[j], p.axis_b[j]])[:, :n]
        free = p.static[j, :n] == 0.0
        c, k = cols[:, free], np.diag(p.stiffness[j, :n][free])
        s = bend - bend @ c @ np.linalg.solve(c.T @ bend @ c + k, c.T @ bend) if c.size else bend
        out.append((point, 0.5 * (s + s.T)))
    return out


def joint_state(sim, line, end: str = "start") -> dict:
    """The joint at ``end`` of ``line`` in ``sim`` as of the last evaluation of the loads:
    "angle" and "rate" (per coordinate, rad and rad/s), "reaction" (the torque the line
    exerts on the node through it, lab, N m) and "sliding" (per coordinate, bool)."""
    sim.check_line(line, "joint_state")
    if end not in ENDS:
        raise ValueError(f"joint_state: end must be 'start' or 'end', got {end!r}")
    joint = line.start_joint if end == "start" else line.end_joint
    art = next((e for e in sim.effects if isinstance(e, Articulations)), None)
    if joint is None or art is None:
        raise ValueError(f"joint_state: the {end} of line {line.name!r} is welded (it declares no joint)")
    p = art.params(sim)
    i = art.index(2 * line.index + ENDS.index(end))
    n = joint.dofs
    return {"angle": p.phi[i, :n].copy(), "rate": p.rate[i, :n].copy(), "reaction": p.reaction[i].copy(),
            "sliding": p.sliding[i, :n] != 0.0}
