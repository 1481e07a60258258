"""The sliders of a net in motion: the effect a Simulation adds when a net has rings or
eyelets (cosnet.core.sliding); its kernels keep each node on its line (kernels/sliding.py)."""

from __future__ import annotations

import math

import numpy as np

from .carried import carried_rows, node_tensor, table_error as carried_error, vertex_tensor
from .drives import driven_nodes
from .sheaves import Sheaves
from ..core import samples
from ..engine.bounds import index_error, offsets_error
from ..kernels.motion import place_line_ends
from ..kernels.sliding import PASSES, SlidingParams, sliding_record
from ..engine.registry import Binding, Effect


class Sliders(Effect):
    """The rings and eyelets of a net (cosnet.core.sliding.Slider each)."""

    record = SlidingParams
    reads_added_mass = True    # its impulses move wet lines by the fluid's sampled masses
    none_if_negative = ("corner",)   # no passage pending

    @property
    def internal(self) -> bool:
        return True

    @classmethod
    def implied(cls, net, grids):
        return sliders(net, grids)

    @classmethod
    def example(cls):
        net, line = samples.rod(fixed=True)
        net.add_ring(line, s=0.4 * samples.LENGTH, mass=0.05)
        return net, []

    @staticmethod
    def table_error(p, model):
        """What is wrong with the index tables of record ``p`` for ``model``, or None."""
        k, nv, nn = p.node.shape[0], model.vertex_mass.shape[0], model.node_mass.shape[0]
        vo = model.line_vertex_offsets
        rows = (p.link, p.mu_s, p.mu_k, p.damping, p.at, p.s, p.push, p.sliding, p.corner, p.pending)
        if any(a.shape[0] != k for a in rows):
            return "sliders: every table needs one row per ring or eyelet"
        if p.arc.shape != (nv,) or p.node_weight.shape != (nn,) or p.dissipated.shape != (1,):
            return "sliders: arc needs one entry per vertex, node_weight one per node"
        m = p.path_lines.shape[0]
        if p.path_arc.shape != (m,) or p.path_offsets.shape != (k + 1,):
            return "sliders: path_arc needs one entry per path line, path_offsets one per slider and one"
        problem = (index_error("sliders.node", p.node, nn) or offsets_error("sliders.path_offsets", p.path_offsets, m)
                   or index_error("sliders.path_lines", p.path_lines, vo.shape[0] - 1))
        if problem:
            return problem
        out = (p.link < p.path_offsets[:-1]) | (p.link >= p.path_offsets[1:])
        if np.any(out):
            return f"sliders.link holds {p.link[out][0]}, outside its slider's path"
        line = p.path_lines[p.link]
        bad = (p.at < vo[line]) | (p.at > vo[line + 1] - 2)
        if np.any(bad):
            return f"sliders.at holds {p.at[bad][0]}, outside the elements of its line"
        problem = index_error("sliders.corner", p.corner[p.corner != -1], nv)
        if problem:
            return problem
        return carried_error(p, model, "sliders")

    def __init__(self, sliders):
        self.sliders = list(sliders)

    def bind(self, on: Binding):
        m = on.model
        k = len(self.sliders)
        arc = vertex_arcs(m)
        weight = np.where(driven_nodes(on.effects, m.node_inv_mass.shape[0]), 0.0, m.node_inv_mass)
        offsets = np.concatenate([[0], np.cumsum([len(sl.lines) for sl in self.sliders])]).astype(np.int64)
        path_lines = np.array([l.index for sl in self.sliders for l in sl.lines], dtype=np.int64)
        path_arc = np.concatenate([path_starts(sl) for sl in self.sliders])
        at, link = np.zeros(k, dtype=np.int64), np.zeros(k, dtype=np.int64)
        for j, sl in enumerate(self.sliders):
            here, at[j], _ = where_on_path(m, arc, sl)
            link[j] = offsets[j] + here
        return sliding_record(SlidingParams(
            node=np.array([sl.node.index for sl in self.sliders], dtype=np.int64), path_offsets=offsets,
            path_lines=path_lines, path_arc=path_arc.reshape(-1), link=link, node_weight=weight, arc=arc,
            mu_s=np.array([sl.mu_s for sl in self.sliders], dtype=float),
            mu_k=np.array([sl.mu_k for sl in self.sliders], dtype=float),
            damping=np.array([sl.damping for sl in self.sliders], dtype=float), at=at,
            s=np.array([sl.s for sl in self.sliders], dtype=float), push=np.zeros((k, 3)), sliding=np.zeros(k),
            corner=np.full(k, -1, dtype=np.int64), pending=np.zeros(k),
            dissipated=np.zeros(1),
            **carried_rows(on, "rings and eyelets", [l for sl in self.sliders for l in sl.lines],
                           [sl.node for sl in self.sliders], weight)))

    def start(self, sim):
        """Catch every slider: its node and line take one velocity across the line at the
        slider (a plastic impact, by the same equal and opposite impulse as the kick's
        constraint, kernels/sliding.py), the kinetic energy it takes counted as dissipated.
        A state set by hand (a line swinging, a ring at rest on it) is then one the
        constraint holds; RATTLE keeps it so, and the energy balance closes from step 0."""
        p, m, st = self.params(sim), sim.model, sim.state
        vo = m.line_vertex_offsets
        first = None
        for _ in range(PASSES):   # sliders sharing a vertex: a few sweeps leave round-off
            lost = sum(self._catch(p, m, st, vo, j) for j in range(p.node.shape[0]))
            p.dissipated[0] += lost
            place_line_ends(m, st)
            first = lost if first is None else first
            if lost <= 1e-12 * first:
                break

    @staticmethod
    def _catch(p, m, st, vo, j) -> float:
        """Remove the relative velocity across the line at slider j; return the energy taken."""
        nd, i, l = p.node[j], p.at[j], p.path_lines[p.link[j]]
        span = p.arc[i + 1] - p.arc[i]
        t = min(max((p.s[j] - p.path_arc[p.link[j]] - p.arc[i]) / span, 0.0), 1.0) if span > 0 else 0.0
        ends = {int(vo[l]): m.attach_node[2 * l], int(vo[l + 1]) - 1: m.attach_node[2 * l + 1]}

        def velocity(v):   # a line end moves with its node (the kick's inverse_mass)
            return st.node_v[ends[v]] if v in ends else st.v[v]

        def weight(v):   # the inverse mass tensor that moves vertex v (kernels/sliding.vertex_tensor)
            return node_tensor(p, ends[v]) if v in ends else vertex_tensor(p, m, v)

        tangent = st.x[i + 1] - st.x[i]
        tangent = tangent / np.linalg.norm(tangent)
        u = st.node_v[nd] - ((1.0 - t) * velocity(i) + t * velocity(i + 1))
        across = u - (u @ tangent) * tangent
        k = node_tensor(p, nd) + (1.0 - t) ** 2 * weight(i) + t * t * weight(i + 1)
        if not np.trace(k) > 0.0:
            return 0.0
        # the impulse across the line that stops the motion across it (kernels/sliding.across)
        across_k = k - np.outer(tangent, k @ tangent) - np.outer(k @ tangent, tangent)
        across_k += (np.trace(k) + tangent @ k @ tangent) * np.outer(tangent, tangent)
        impulse = -np.linalg.solve(across_k, across)
        st.node_v[nd] += node_tensor(p, nd) @ impulse
        for v, share in ((i, 1.0 - t), (i + 1, t)):
            velocity(v)[:] -= share * (weight(v) @ impulse)
        return -0.5 * float(across @ impulse)

    def dissipated(self, sim) -> float:
        """Energy the sliders' friction and dampers have taken so far (J)."""
        return float(self.params(sim).dissipated[0])

    def state_arrays(self, sim) -> dict:
        p = self.params(sim)
        return {"link": p.link, "at": p.at, "s": p.s, "push": p.push, "sliding": p.sliding,
                "corner": p.corner, "pending": p.pending, "dissipated": p.dissipated}

    def describe(self) -> str:
        return f"Sliders({len(self.sliders)} rings and eyelets)"


def vertex_arcs(model) -> np.ndarray:
    """(nv,) unstretched arc length of each vertex from its line's start."""
    vo, eo = model.line_vertex_offsets, model.line_element_offsets
    arc = np.zeros(model.vertex_mass.shape[0])
    for l in range(vo.shape[0] - 1):
        arc[vo[l] + 1:vo[l + 1]] = np.cumsum(model.element_rest_length[eo[l]:eo[l + 1]])
    return arc


def path_starts(sl) -> np.ndarray:
    """Unstretched arc length of slider sl's path before each of its lines."""
    return np.concatenate([[0.0], np.cumsum([line.length for line in sl.lines])[:-1]])


def where_on_path(model, arc, sl) -> tuple[int, int, float]:
    """(here, i, t): slider sl's line (its index in sl.lines), the first vertex (global) of
    the element it is on at its material coordinate, and its fraction of that element."""
    vo = model.line_vertex_offsets
    before = path_starts(sl)
    here = int(np.searchsorted(before, sl.s, side="right")) - 1
    l = sl.lines[here].index
    local = int(np.searchsorted(arc[vo[l]:vo[l + 1]], sl.s - before[here], side="right")) - 1
    i = vo[l] + min(max(local, 0), vo[l + 1] - vo[l] - 2)
    span = arc[i + 1] - arc[i]
    return here, i, min(max((sl.s - before[here] - arc[i]) / span, 0.0), 1.0) if span > 0 else 0.0


def places(net, model, state) -> list:
    """[(node, i, t, dx/ds)] of the net's sliders in ``state`` (engine/linearised.linearise):
    each node's index, the element it is on (first vertex i, fraction t) and the line's
    tangent per unit material coordinate there."""
    arc = vertex_arcs(model)
    out = []
    for sl in net.sliders:
        _, i, t = where_on_path(model, arc, sl)
        out.append((sl.node.index, i, t, (state.x[i + 1] - state.x[i]) / (arc[i + 1] - arc[i])))
    return out


def sliders(net, grids=None) -> Sliders | None:
    """The Sliders effect of the net's rings and eyelets (None when it has none)."""
    return Sliders(net.sliders) if net.sliders else None


def slider_state(sim, node) -> dict:
    """The slider whose node is ``node`` in ``sim``: "s" (its material coordinate, m of
    unstretched length from its line's start) and "sliding" (bool); for a sheave, those of the
    line's wrap and its angle "wrap" (sheave_state)."""
    sim.check_node(node, "slider_state")
    wheel = sheave_state(sim, node)
    if wheel is not None:
        return wheel
    held = next((e for e in sim.effects if isinstance(e, Sliders)), None)
    j = next((i for i, sl in enumerate(held.sliders) if sl.node is node), None) if held else None
    if held is None or j is None:
        raise ValueError(f"slider_state: node {node.name!r} is no ring, eyelet or sheave")
    p = held.params(sim)
    return {"s": float(p.s[j]), "sliding": bool(p.sliding[j] != 0.0)}


def sheave_state(sim, node) -> dict | None:
    """The sheave whose node is ``node`` in ``sim`` (None if none): "s" (the material
    coordinate at the middle of the line's wrap, m of unstretched length from its start),
    "wrap" (the angle the engaged vertices span, rad) and "sliding" (bool: a vertex on the rim
    slides against its friction; True without friction)."""
    held = next((e for e in sim.effects if isinstance(e, Sheaves)), None)
    j = next((i for i, sh in enumerate(held.sheaves) if sh.node is node), None) if held else None
    if held is None or j is None:
        return None
    p = held.params(sim)
    on = np.arange(p.lo[j], p.hi[j] + 1)
    on = on[p.engaged[on] != 0.0]
    if not on.size:
        return {"s": math.nan, "wrap": 0.0, "sliding": False}
    arc = vertex_arcs(sim.model)
    centre = sim.state.node_x[node.index] + p.offset[j]
    a, b = sim.state.x[on[0]] - centre, sim.state.x[on[-1]] - centre
    wrap = math.atan2(float(np.cross(a, b) @ p.axis[j]), float(a @ b)) % (2 * math.pi)
    sliding = bool(np.any(p.sliding[on] != 0.0)) or p.mu_s[j] == 0.0
    return {"s": float(0.5 * (arc[on[0]] + arc[on[-1]])), "wrap": wrap, "sliding": sliding}
