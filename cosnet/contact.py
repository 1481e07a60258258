"""Rod-rod contact as a declared effect: the lines' elements are capsules that push each other
apart with a damped penalty force (kernel and method: cosnet.kernels.contact)."""

from __future__ import annotations

import math

import numpy as np

from . import checks
from .kernels.contact import ContactParams, contact_energy
from .net import Line
from .registry import Binding, Effect, Key
from .scene_values import DAMPING, STIFFNESS, boolean, nonnegative, positive

MAX_NODE_GAP = 1e6  # exclusion factor at a node where two lines leave in the same direction


def chosen_lines(sim, lines, who: str) -> list[Line]:
    """The lines of sim an effect names (Line objects or names); None: all of them."""
    if lines is None:
        return list(sim.net.lines)
    out = []
    for x in lines:
        if isinstance(x, str):
            try:
                x = sim.net.line(x)
            except KeyError:
                have = [ln.name for ln in sim.net.lines]
                raise ValueError(f"{who}: unknown line {x!r}; lines are {have}") from None
        sim.check_line(x, who)
        out.append(x)
    return out


def smallest_mass(sim, lines) -> float:
    """The smallest free mass a contact force on these lines can push: an interior vertex, or
    the composite node of a line end (0 when there is none)."""
    m = sim.model
    masses = []
    for line in lines:
        v = slice(m.line_vertex_offsets[line.index] + 1, m.line_vertex_offsets[line.index + 1] - 1)
        masses.extend(m.vertex_mass[v][m.vertex_inv_mass[v] > 0])
        masses.extend(m.node_mass[nd.index] for nd in (line.start, line.end)
                      if 0 < m.node_mass[nd.index] < math.inf)
    return float(min(masses)) if masses else 0.0


class Contact(Effect):
    """Contact between the capsules (centre segment, radius r = section.radius) of the lines'
    elements: overlap eps = r_i + r_j - d_min gives the force max(0, k eps - gamma v_n) along
    the normal, equal and opposite at the closest points (Elastica's rod collision).

    k: penalty stiffness (N/m) > 0; gamma: damping (N s/m) >= 0 (0 conserves energy, with the
    potential k eps^2 / 2 counted in sim.energy()).
    self_contact: whether a line touches itself (a loop, a coil); segments closer along the
    rest arc than self_gap (r_i + r_j) never touch (pi/2: any closer pair could only touch
    if the centre line bent tighter than the radius).
    lines: the lines taking part (Line objects or names); None: all of them. Segments of
    lines meeting at a node are excluded near that node (see cosnet.kernels.contact).
    """

    kind = "contact"
    keys = (Key("k", positive, STIFFNESS, required=True, doc="penalty stiffness"),
            Key("gamma", nonnegative, DAMPING, doc="damping of the normal approach"),
            Key("self_contact", boolean, doc="whether a line touches itself"),
            Key("lines", "lines", doc="names of the lines taking part (default: all)"),
            Key("self_gap", nonnegative, doc="rest-arc exclusion of a line's own segments, in r_i + r_j"))
    record = ContactParams

    def __init__(self, k: float, gamma: float = 0.0, self_contact: bool = True, lines=None,
                 self_gap: float = 0.5 * math.pi):
        k = checks.positive("Contact", "stiffness k", float(k))
        gamma = checks.nonnegative("Contact", "damping gamma", float(gamma))
        self_gap = checks.nonnegative("Contact", "self_gap", float(self_gap))
        if not isinstance(self_contact, (bool, np.bool_)):
            raise ValueError(f"Contact: self_contact must be true or false, got {self_contact!r}")
        if lines is not None:
            lines = list(lines)
            for x in lines:
                if not isinstance(x, (Line, str)):
                    raise ValueError(f"Contact: lines must be cosnet Lines or line names, got {x!r}")
        self.k, self.gamma, self.self_gap = k, gamma, self_gap
        self.self_contact = bool(self_contact)
        self.lines = lines

    # ------------------------------------------------------------------ binding
    def _lines(self, on: Binding) -> list[Line]:
        return chosen_lines(on, self.lines, "Contact")

    def bind(self, on: Binding) -> ContactParams:
        m, x = on.model, on.state.x
        ne, nn = m.element_rest_length.shape[0], m.node_mass.shape[0]
        vo, eo = m.line_vertex_offsets, m.line_element_offsets
        index, geom = np.zeros((ne, 2), np.int64), np.zeros((ne, 4))
        for line in on.net.lines:
            l = line.index
            e0, n = eo[l], eo[l + 1] - eo[l]
            cum = np.concatenate([[0.0], np.cumsum(m.element_rest_length[e0:e0 + n])])
            geom[e0:e0 + n, 0] = [line.section_at((i + 0.5) / n).radius for i in range(n)]
            geom[e0:e0 + n, 1], geom[e0:e0 + n, 2], geom[e0:e0 + n, 3] = cum[:-1], cum[1:], cum[-1] - cum[1:]
            index[e0:e0 + n, 0] = vo[l] + np.arange(n)
            index[e0:e0 + n, 1] = l
        chosen = sorted({line.index for line in self._lines(on)})
        elements = np.concatenate([np.arange(eo[l], eo[l + 1]) for l in chosen] or [np.zeros(0)]).astype(np.int64)
        count = elements.shape[0]
        size = 16
        while size < 2 * count:
            size *= 2
        p = ContactParams(
            self.k, self.gamma, self.self_contact, self.self_gap, elements, index, geom,
            self._node_gaps(m, x, nn), np.zeros(1, np.int64), np.zeros(1, np.int64),
            np.zeros(size + 1, np.int64), np.zeros(size, np.int64), np.zeros(count, np.int64),
            np.zeros((count, 3)), np.zeros(count), np.zeros((count, 3), np.int64),
            np.zeros(count, np.int64), np.zeros((count, 3), np.int64), np.zeros((count, 3)), np.zeros(count))
        return p

    def _node_gaps(self, m, x, nn) -> np.ndarray:
        """Junction exclusion factor per node: max(self_gap, 1 / sin(theta / 2)) over the
        smallest angle theta between two lines leaving the node (in the initial shape); two
        straight capsules leaving at theta overlap up to an arc sum of r_sum / sin(theta / 2)."""
        gap = np.full(nn, self.self_gap)
        vo = m.line_vertex_offsets
        for nd in range(nn):
            att = m.node_attach_list[m.node_attach_offsets[nd]:m.node_attach_offsets[nd + 1]]
            dirs = []
            for a in att:
                l, end = divmod(int(a), 2)
                v = vo[l] if end == 0 else vo[l + 1] - 1
                u = x[v + 1] - x[v] if end == 0 else x[v - 1] - x[v]
                nu = np.linalg.norm(u)
                dirs.append(u / nu if nu > 0 else u)
            for i in range(len(dirs)):
                for j in range(i):
                    half = 0.5 * math.acos(float(np.clip(np.dot(dirs[i], dirs[j]), -1.0, 1.0)))
                    factor = MAX_NODE_GAP if math.sin(half) < 1.0 / MAX_NODE_GAP else 1.0 / math.sin(half)
                    gap[nd] = max(gap[nd], factor)
        return gap

    def narrow_tests(self, sim) -> int:
        """Number of narrow-phase pair tests made so far in sim (candidates passing the grid)."""
        return int(self.params(sim).narrow_tests[0])

    def active_contacts(self, sim) -> int:
        """Overlapping pairs found by the last force evaluation."""
        return int(self.params(sim).active[0])

    # ------------------------------------------------------------------ effect interface
    def potential(self, p, on: Binding) -> float:
        return float(contact_energy(p, on.model, on.state))

    def omega2(self, p, on: Binding) -> float:
        """2 k / m_min: two of the smallest free masses (interior vertices, or the composite
        node of a line end) of the record's lines bouncing on one contact spring."""
        lines = [on.net.lines[l] for l in np.unique(p.elem_index[p.elements, 1])]
        m_min = smallest_mass(on, lines)
        return 2.0 * p.k / m_min if m_min else 0.0

    def describe(self) -> str:
        lines = "all" if self.lines is None else [getattr(x, "name", x) for x in self.lines]
        return (f"Contact(k={self.k:g} N/m, gamma={self.gamma:g} N s/m, "
                f"self_contact={self.self_contact}, lines={lines})")

