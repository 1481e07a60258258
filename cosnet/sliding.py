"""Mobile nodes (§8): rings that slide on a line, eyelets a line slides through.

    ring = net.add_ring(line, s=..., mass=..., inertia=None, mu_s=0, mu_k=0, damping=0)
    eyelet = net.add_eyelet(line, s=..., at=None, mu=0, damping=0)

s is the material coordinate: metres of unstretched length from the line's start, where the
node sits as built. A ring is a new node of its own mass (its rotation locked unless an
inertia is given: a line hung from it turns freely only on a joint, cosnet.Ball); an eyelet is
a fixed node made at the line's point (``at=None``), at a given point, or an existing node
(fixed, driven or free) that the line passes through there. Either returns its node, whose
position and velocity read like any node's. The node then stays on the line's centreline to
round-off while the line's material slides past it: the line's mass, stiffness and elements
stay material. mu_s, mu_k: Coulomb friction coefficients against the normal force (sticks,
then slides), damping: a damper on the sliding velocity (N s/m). A slider stops at the line's
ends. The constraint and its kernels: kernels/sliding.py; the effect that holds a net's
sliders, which a Simulation adds: cosnet.mobile.
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from typing import Any

import numpy as np

from . import checks


@dataclass(eq=False)
class Slider:
    """A node held on a line's centreline at a moving material coordinate."""

    kind: str        # "ring" or "eyelet"
    line: Any        # cosnet.net.Line
    s: float         # material coordinate as built (m of unstretched length)
    node: Any        # cosnet.net.Node
    mu_s: float
    mu_k: float
    damping: float


def point_at(line, s: float) -> np.ndarray:
    """The point of the line as built at unstretched arc length s from its start."""
    seg = np.linalg.norm(np.diff(line.points, axis=0), axis=1)
    arc = np.concatenate([[0.0], np.cumsum(seg)])
    i = min(int(np.searchsorted(arc, s, side="right")) - 1, len(seg) - 1)
    t = (s - arc[i]) / seg[i]
    return line.points[i] + t * (line.points[i + 1] - line.points[i])


def _common(net, line, s, mu_s, mu_k, damping, who):
    lines = net.lines
    if getattr(line, "index", None) is None or line.index >= len(lines) or lines[line.index] is not line:
        raise ValueError(f"{who}: {line!r} is not a line of this net")
    s = checks.number(who, "s", s)
    if not 0.0 <= s <= line.length:
        raise ValueError(f"{who}: s must be in [0, {line.length:.6g}] m (the unstretched length of "
                         f"{line.name!r}), got {s:g}")
    mu_s, mu_k = checks.nonnegative(who, "mu_s", mu_s), checks.nonnegative(who, "mu_k", mu_k)
    if mu_k > mu_s:
        raise ValueError(f"{who}: mu_k must not exceed mu_s, got mu_s = {mu_s:g}, mu_k = {mu_k:g}")
    return s, mu_s, mu_k, checks.nonnegative(who, "damping", damping)


def add_ring(net, line, s, mass, inertia=None, mu_s=0.0, mu_k=0.0, damping=0.0, name=None):
    """Net.add_ring (module docstring): the ring's new node."""
    who = f"ring on {line!r}"
    s, mu_s, mu_k, damping = _common(net, line, s, mu_s, mu_k, damping, who)
    m = checks.positive(who, "mass", mass)
    node = net.add_node(point_at(line, s), mass=m, inertia=[math.inf] * 3 if inertia is None else inertia,
                        name=name)
    net.sliders.append(Slider("ring", line, s, node, mu_s, mu_k, damping))
    return node


def add_eyelet(net, line, s, at=None, mu=0.0, damping=0.0, name=None):
    """Net.add_eyelet (module docstring): the eyelet's node."""
    who = f"eyelet on {line!r}"
    s, mu, _, damping = _common(net, line, s, mu, mu, damping, who)
    here = point_at(line, s)
    given_node = isinstance(getattr(at, "index", None), (int, np.integer))
    if given_node:
        if at.index >= len(net.nodes) or net.nodes[at.index] is not at:
            raise ValueError(f"{who}: {at!r} is not a node of this net")
        point = at.position
    else:
        point = here if at is None else checks.vec3(who, "at", at)
    gap = float(np.linalg.norm(point - here))
    if gap > 1e-9 * max(1.0, line.length):
        raise ValueError(f"{who}: the line does not pass through the eyelet: its point at s = {s:g} m is "
                         f"{here.tolist()}, {gap:.3g} m from {point.tolist()}")
    node = at if given_node else net.add_node(point, fixed=True, name=name)
    net.sliders.append(Slider("eyelet", line, s, node, mu, mu, damping))
    return node
