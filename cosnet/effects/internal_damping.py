"""Internal damping of the lines' stretching, declared (its kernel: cosnet.kernels.strain_damping)."""

from __future__ import annotations

import numpy as np

from ..core import checks, samples
from ..core.units import STRAIN_DAMPING, nonnegative
from ..engine.bounds import index_error
from ..engine.registry import Binding, Effect, Key
from ..kernels.strain_damping import InternalDampingParams, damping_record
from .carried import carried_rows, table_error as carried_error
from .contact import chosen_lines
from .drives import driven_nodes


def pair_weights(m) -> np.ndarray:
    """(ne,) w = w_a + w_b of each element of model m: the inverse masses of its two ends (a line
    end: its node's translation; the kernel finds an end element's own as the node turns)."""
    vo, eo = m.line_vertex_offsets, m.line_element_offsets
    inverse = m.vertex_inv_mass.copy()   # an end moves with its node
    inverse[vo[:-1]] = m.node_inv_mass[m.attach_node[0::2]]
    inverse[vo[1:] - 1] = m.node_inv_mass[m.attach_node[1::2]]
    v = np.arange(eo[-1]) + np.repeat(np.arange(eo.shape[0] - 1), np.diff(eo))   # first vertex of each
    return inverse[v] + inverse[v + 1]


class InternalDamping(Effect):
    """Internal damping of the lines' stretching: a dashpot beside each element's axial spring,
    axial force c d(epsilon)/dt with epsilon the element's axial strain (Kelvin-Voigt). It takes
    the energy of the fast axial waves of a stiff line and leaves its slow motion nearly
    alone. Give ``axial`` = c (N s, the force per unit strain rate), or ``ratio`` = zeta, the
    damping ratio of each element's own axial vibration (c = 2 zeta sqrt(E A l0 mu), mu the
    reduced mass of its two ends: 1 damps the finest wave critically, as MoorDyn's lines).
    Integrated as an exact flow of each element in turn, so stable at any dt; momentum is
    kept, and the kinetic energy taken is ``dissipated(sim)``, part of ``sim.dissipated()`` (at
    a driven node, its drive pays what the dashpot takes there, which neither account holds,
    nor the drive's reaction). On lines that carry a fluid's added mass, the dashpot moves them
    by that mass, as the kick does (it then runs after the fluid, whatever the order declared).
    Bending, twisting and shearing rates are not damped."""

    kind = "internal_damping"
    keys = (Key("axial", nonnegative, STRAIN_DAMPING, doc="axial force per unit strain rate c"),
            Key("ratio", nonnegative, doc="instead of axial: the damping ratio of each element's axial vibration"),
            Key("lines", "lines", doc="the damped lines (default: all)"))
    record = InternalDampingParams
    free_integers = ("turn",)   # which half of the kick is next, compared
    reads_added_mass = True     # its impulses move wet lines by the fluid's sampled masses

    @classmethod
    def example(cls):
        net, line = samples.rod(elements=6, fixed=True)
        return net, [cls(ratio=0.3)]

    @staticmethod
    def table_error(p, model):
        ne, nn = model.element_rest_length.shape[0], model.node_mass.shape[0]
        if (any(a.shape != (ne,) for a in (p.rate, p.weight, p.gain, p.loss)) or p.node_weight.shape != (nn,)
                or p.node_turn.shape != (nn, 3) or p.is_driven.shape != (nn,) or p.held.shape != (nn, 6)
                or p.turn.shape != (1,)):
            return ("internal_damping: rate, weight, gain and loss need one entry per element, node_weight, "
                    "node_turn, is_driven and held one row per node")
        if p.carried_vertex.any() and p.carried_decay.shape != (ne,):
            return "internal_damping: carried_decay needs one entry per element where a line carries added mass"
        return carried_error(p, model, "internal_damping") or index_error("internal_damping.driven", p.driven, nn)

    def __init__(self, axial: float | None = None, *, ratio: float | None = None, lines=None):
        if (axial is None) == (ratio is None):
            raise ValueError("InternalDamping: give axial (N s) or ratio, one of them")
        name, value = ("axial", axial) if ratio is None else ("ratio", ratio)
        checks.nonnegative("InternalDamping", name, value)
        self.axial = None if axial is None else float(axial)
        self.ratio = None if ratio is None else float(ratio)
        self.lines = None if lines is None else list(lines)

    def element_rates(self, on: Binding, pair: np.ndarray) -> np.ndarray:
        """(ne,) the coefficient c of each element (N s), 0 on lines not damped, given the inverse
        masses of their pairs of ends (pair_weights)."""
        m = on.model
        rate = np.zeros(m.element_rest_length.shape[0])
        for line in chosen_lines(on, self.lines, "InternalDamping"):
            l = line.index
            e = np.arange(m.line_element_offsets[l], m.line_element_offsets[l + 1])
            if self.ratio is None:
                rate[e] = self.axial
                continue
            w = pair[e]
            mu = np.divide(1.0, w, out=np.zeros_like(w), where=w > 0.0)   # between two fixed ends: none
            rate[e] = 2.0 * self.ratio * np.sqrt(m.element_stiffness[e, 2] * m.element_rest_length[e] * mu)
        return rate

    def bind(self, on: Binding):
        m = on.model
        driven = driven_nodes(on.effects, m.node_mass.shape[0])
        weight = np.where(driven, 0.0, m.node_inv_mass)
        inertia = m.node_inertia
        free = ~driven[:, None] & (m.node_locked == 0.0) & (inertia > 0.0) & np.isfinite(inertia)
        turn = np.divide(1.0, inertia, out=np.zeros_like(inertia), where=free)   # a point junction: no arm to turn
        ne, nn = m.element_rest_length.shape[0], m.node_mass.shape[0]
        pair = pair_weights(m)
        lines = chosen_lines(on, self.lines, "InternalDamping")
        carried = carried_rows(on, "InternalDamping", lines, [n for ln in lines for n in (ln.start, ln.end)], weight)
        return damping_record(InternalDampingParams(
            self.element_rates(on, pair), weight, turn, np.flatnonzero(driven).astype(np.int64),
            driven.astype(float), np.zeros((nn, 6)), pair, np.zeros(ne), np.zeros(ne), np.full(1, np.nan),
            np.zeros(1, dtype=np.int64), np.zeros(1), **carried,
            carried_decay=np.zeros(ne if carried["carried_vertex"].any() else 0)))

    def dissipated(self, sim) -> float:
        """Kinetic energy the dashpots have taken so far (J)."""
        return float(self.params(sim).dissipated[0])

    def state_arrays(self, sim) -> dict:
        p = self.params(sim)
        return {"turn": p.turn, "dissipated": p.dissipated}

    def describe(self):
        how = f"axial={self.axial:g} N s" if self.ratio is None else f"ratio={self.ratio:g}"
        return f"InternalDamping({how})"
