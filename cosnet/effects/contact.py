"""Rod-rod contact as a declared effect: the lines' elements are capsules that push each other
apart with a damped penalty force, with Coulomb friction between them when asked (kernel and
method: cosnet.kernels.contact)."""

from __future__ import annotations

import math

import numpy as np

from .friction import Frictional, friction_keys
from ..core import samples
from ..engine.bounds import index_error
from ..core import checks
from ..kernels.contact import SLIDE, ContactParams, contact_energy
from ..kernels.layout import typed_call
from ..core.net import Line
from ..engine.registry import Binding, Key
from ..core.units import boolean, integer, nonnegative

PAIRS_PER_ELEMENT = 4  # default friction-table capacity: touching pairs per element taking part
MAX_NODE_GAP = 1e6  # exclusion factor at a node where two lines leave in the same direction


def chosen_parts(sim, items, kind: str, who: str) -> list:
    """The lines or nodes (``kind`` "line" or "node") of sim an effect names (the objects or
    their names), each refused in one line unless it is the net's; None: all of them."""
    parts = sim.net.lines if kind == "line" else sim.net.nodes
    if items is None:
        return list(parts)
    find, check = (sim.net.line, sim.check_line) if kind == "line" else (sim.net.node, sim.check_node)
    out = []
    for x in items:
        if isinstance(x, str):
            try:
                x = find(x)
            except KeyError:
                raise ValueError(f"{who}: unknown {kind} {x!r}; {kind}s are {[p.name for p in parts]}") from None
        check(x, who)
        out.append(x)
    return out


def chosen_lines(sim, lines, who: str) -> list[Line]:
    """The lines of sim an effect names (Line objects or names); None: all of them."""
    return chosen_parts(sim, lines, "line", who)


def pushed_masses(sim, lines) -> tuple[np.ndarray, np.ndarray]:
    """(vertices, masses): the vertices of these lines a contact force can push and the free
    mass each pushes: an interior vertex its own, a line end its node's composite mass (where
    the node is neither fixed nor massless)."""
    m = sim.model
    verts, masses = [], []
    for line in lines:
        lo, hi = int(m.line_vertex_offsets[line.index]), int(m.line_vertex_offsets[line.index + 1])
        inner = np.arange(lo + 1, hi - 1)
        inner = inner[m.vertex_inv_mass[inner] > 0]
        verts.append(inner)
        masses.append(m.vertex_mass[inner])
        for nd, i in ((line.start, lo), (line.end, hi - 1)):
            if 0 < m.node_mass[nd.index] < math.inf:
                verts.append(np.array([i]))
                masses.append(np.array([m.node_mass[nd.index]]))
    if not verts:
        return np.zeros(0, np.int64), np.zeros(0)
    return np.concatenate(verts).astype(np.int64), np.concatenate(masses).astype(float)


def smallest_mass(sim, lines) -> float:
    """The smallest free mass a contact force on these lines can push (pushed_masses; 0 when
    there is none)."""
    masses = pushed_masses(sim, lines)[1]
    return float(masses.min()) if masses.size else 0.0


class Contact(Frictional):
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
    mu_s, mu_k: static and kinetic Coulomb coefficients between lines (the one not given
    equals the other; neither: frictionless), mu_k <= mu_s; k_t: the stiffness (N/m) of the
    tangential spring that holds a sticking pair (default k); the pair sticks elastically
    within mu_s N / k_t and slides at mu_k N (cosnet.kernels.friction).
    pairs_per_element: the friction table's capacity, in touching pairs per element taking
    part (a run with more stops with an error saying so).
    """

    kind = "contact"
    keys = (*friction_keys(static="static friction coefficient between lines (default: frictionless)",
                           normal="penalty stiffness", damping="damping of the normal approach"),
            Key("self_contact", boolean, doc="whether a line touches itself"),
            Key("lines", "lines", doc="names of the lines taking part (default: all)"),
            Key("self_gap", nonnegative, doc="rest-arc exclusion of a line's own segments, in r_i + r_j"),
            Key("pairs_per_element", integer, doc="friction table capacity: touching pairs per element"))
    record = ContactParams

    @property
    def internal(self) -> bool:
        return True

    # the segment grid is rebuilt by every call before it is read; the rest are counters
    free_integers = ("bucket_start", "cursor", "slot_bucket", "slot_cell", "sorted_elem", "sorted_cell",
                     "narrow_tests", "active")

    @property
    def conservative(self) -> bool:
        return self.gamma == 0 and self.mu_s == 0

    @classmethod
    def example(cls):
        return samples.crossing()[0], [cls(k=1e4)]

    @staticmethod
    def table_error(p, model):
        """What is wrong with the index tables of record ``p`` for ``model``, or None."""
        ne, nn = model.element_rest_length.shape[0], model.node_mass.shape[0]
        nl = model.line_vertex_offsets.shape[0] - 1
        m, size = p.elements.shape[0], p.cursor.shape[0]
        if size < 1 or size & (size - 1) or p.bucket_start.shape != (size + 1,):
            return "contact: bucket tables must hold a power of two of buckets (and one offset more)"
        for name in ("slot_bucket", "slot_mid", "slot_reach", "slot_cell", "sorted_elem", "sorted_cell",
                     "sorted_mid", "sorted_reach"):
            if getattr(p, name).shape[0] != m:
                return f"contact.{name} has {getattr(p, name).shape[0]} rows for {m} segments"
        if p.elem_index.shape != (ne, 2) or p.elem_geom.shape != (ne, 4) or p.node_gap.shape != (nn,):
            return "contact: elem_index, elem_geom or node_gap do not match the net"
        pairs = p.pair_key.shape[1] if p.pair_key.ndim == 3 else -1
        if (p.pair_key.shape != (2, pairs, 3) or p.pair_data.shape != (2, pairs, 8)
                or p.pair_used.shape != (2, pairs) or pairs & (pairs - 1) or p.pair_state.shape != (3,)
                or p.mu_s.shape != (3,) or p.mu_k.shape != (3,) or p.dissipated.shape != (1,)):
            return "contact: the friction pair tables do not have the shapes bind gives them"
        if (p.pair_state[0] not in (0, 1) or np.any(p.pair_state[1:] < 0)
                or np.any(2 * p.pair_state[1:] > pairs)):
            return "contact.pair_state: side must be 0 or 1 and each side hold at most half the table"
        if pairs and any(index_error("contact.pair_used", p.pair_used[side, :p.pair_state[1 + side]], pairs)
                         for side in (0, 1)):
            return "contact.pair_used names a slot outside the pair table"
        if p.damp.shape != ((model.vertex_mass.shape[0] if p.gamma > 0 else 0), 3):
            return "contact.damp needs one row of 3 per vertex when gamma > 0"
        first = np.repeat(model.line_vertex_offsets[:-1] - model.line_element_offsets[:-1],
                          np.diff(model.line_element_offsets)) + np.arange(ne)
        if np.any(p.elem_index[:, 0] != first):
            return "contact.elem_index does not name the elements' first vertices"
        return (index_error("contact.elements", p.elements, ne)
                or index_error("contact.elem_index (line)", p.elem_index[:, 1], nl))

    def __init__(self, k: float, gamma: float = 0.0, self_contact: bool = True, lines=None,
                 self_gap: float = 0.5 * math.pi, mu_s=None, mu_k=None, k_t=None,
                 pairs_per_element: int = PAIRS_PER_ELEMENT):
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
        if mu_s is None:   # only a kinetic coefficient: the contact holds up to the same
            mu_s = 0.0 if mu_k is None else mu_k
        self.mu_s = checks.nonnegative("Contact", "mu_s", mu_s)
        self.mu_k = self.mu_s if mu_k is None else checks.nonnegative("Contact", "mu_k", mu_k)
        if self.mu_k > self.mu_s:
            raise ValueError(f"Contact: mu_k must not exceed the static coefficient, got {self.mu_k:g} > {self.mu_s:g}")
        friction = self.mu_s > 0
        self.k_t = (k if friction else 0.0) if k_t is None else float(k_t)
        if not math.isfinite(self.k_t) or self.k_t < 0 or (friction and self.k_t == 0):
            raise ValueError(f"Contact: k_t must be a finite number > 0 (>= 0 without friction), got {k_t!r}")
        if not friction:
            self.k_t = 0.0   # no table, no springs: the frictionless kernel as it was
        if (isinstance(pairs_per_element, (bool, np.bool_)) or not isinstance(pairs_per_element, (int, np.integer))
                or pairs_per_element < 1):
            raise ValueError(f"Contact: pairs_per_element must be a whole number >= 1, got {pairs_per_element!r}")
        self.pairs_per_element = int(pairs_per_element)
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
        # the pair table: open addressing at most half full
        pairs = 0
        if self.k_t > 0:
            pairs = 16
            while pairs < 2 * self.pairs_per_element * count:
                pairs *= 2
        p = ContactParams(
            self.k, self.gamma, self.self_contact, self.self_gap, elements, index, geom,
            self._node_gaps(m, x, nn), np.zeros(1, np.int64), np.zeros(1, np.int64),
            np.zeros(size + 1, np.int64), np.zeros(size, np.int64), np.zeros(count, np.int64),
            np.zeros((count, 3)), np.zeros(count), np.zeros((count, 3), np.int64),
            np.zeros(count, np.int64), np.zeros((count, 3), np.int64), np.zeros((count, 3)), np.zeros(count),
            self.k_t, np.full(3, self.mu_s), np.full(3, self.mu_k), np.full((2, pairs, 3), -1, np.int64),
            np.zeros((2, pairs, 8)), np.zeros((2, pairs), np.int64), np.zeros(3, np.int64), np.zeros(1),
            np.zeros((m.vertex_mass.shape[0] if self.gamma > 0 else 0, 3)))
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

    def sliding_flags(self, p) -> tuple:
        side = int(p.pair_state[0])    # the pairs with friction kept by the last evaluation
        slots = p.pair_used[side, :p.pair_state[1 + side]]
        return (p.pair_key[side, slots, 2] == SLIDE,)

    # ------------------------------------------------------------------ effect interface
    def potential(self, p, on: Binding) -> float:
        return float(typed_call(contact_energy, p, on.model, on.state))

    def state_arrays(self, sim) -> dict:
        p = self.params(sim)
        if self.k_t == 0:       # no friction: no pairs kept, the dampers' account all the same
            return {"dissipated": p.dissipated}
        return {"pair_key": p.pair_key, "pair_data": p.pair_data, "pair_used": p.pair_used,
                "pair_state": p.pair_state, "dissipated": p.dissipated}

    def omega2(self, p, on: Binding) -> float:
        """2 max(k, k_t) / m_min: two of the smallest free masses (interior vertices, or the
        composite node of a line end) of the record's lines bouncing on the stiffer of the
        normal and the tangential spring (they act along orthogonal directions)."""
        lines = [on.net.lines[l] for l in np.unique(p.elem_index[p.elements, 1])]
        m_min = smallest_mass(on, lines)
        return 2.0 * max(p.k, p.k_t) / m_min if m_min else 0.0

    def describe(self) -> str:
        lines = "all" if self.lines is None else [getattr(x, "name", x) for x in self.lines]
        friction = (f", mu_s={self.mu_s:g}, mu_k={self.mu_k:g}, k_t={self.k_t:g} N/m"
                    if self.k_t > 0 else "")
        return (f"Contact(k={self.k:g} N/m, gamma={self.gamma:g} N s/m, "
                f"self_contact={self.self_contact}, lines={lines}{friction})")

