"""Mobile nodes (§8): rings that slide on a line, eyelets a line slides through.

    ring = net.add_ring(line, s=..., mass=..., inertia=None, mu_s=0, mu_k=0, damping=0)
    eyelet = net.add_eyelet(line, s=..., at=None, mu=0, damping=0, radius=0)

``line`` is a line, or a path of lines (a list, each ending at the node where the next starts,
with no offsets there): the slider then passes from one to the next through their junctions.
s is the material coordinate: metres of unstretched length from the path's start, where the
node sits as built. A ring is a new node of its own mass (its rotation locked unless an
inertia is given: a line hung from it turns freely only on a joint, cosnet.Ball); an eyelet is
a fixed node made at the line's point (``at=None``), at a given point, or an existing node
(fixed, driven or free) that the line passes through there. Either returns its node, whose
position and velocity read like any node's. The node then stays on the line's centreline to
round-off while the line's material slides past it: the line's mass, stiffness and elements
stay material. mu_s, mu_k: Coulomb friction coefficients against the normal force (sticks,
then slides), damping: a damper on the sliding velocity (N s/m). A slider stops at the line's
ends. The constraint and its kernels: kernels/sliding.py; the effect that holds a net's
sliders, which a Simulation adds: cosnet.effects.sliders.

An eyelet with a radius is a sheave: a wheel on free bearings about ``at`` (its centre: a
point, or a node whose rotation is locked) whose rim the line's centreline wraps, turning as
sharply as the wrap asks. The line (one line, laid over the rim as built) passes the rim at
s; the sheave's plane is the one its tangent there and the radius span. With mu (or damping)
the wheel does not turn: a drum the line slides over against Coulomb friction (mu_s = mu_k =
mu: the capstan law over its wrap) and a damper on the sliding velocity. Its kernels:
kernels/sheaves.py; its effect: cosnet.effects.sheaves.
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
    lines: tuple     # its path: cosnet.core.net.Line objects, each ending where the next starts
    s: float         # material coordinate as built (m of unstretched length from the path's start)
    node: Any        # cosnet.core.net.Node
    mu_s: float
    mu_k: float
    damping: float


@dataclass(eq=False)
class Sheave:
    """A wheel a line wraps and slides over (an eyelet with a radius)."""

    line: Any        # cosnet.core.net.Line
    s: float         # material coordinate at the rim as built
    node: Any        # the node it moves with (its centre, or offset from it)
    centre: np.ndarray  # (3,) as built
    axis: np.ndarray    # (3,) unit normal of its plane
    radius: float
    mu: float = 0.0
    damping: float = 0.0


def point_at(line, s: float) -> np.ndarray:
    """The point of the line as built at unstretched arc length s from its start."""
    return point_and_tangent(line, s)[0]


def point_and_tangent(line, s: float) -> tuple[np.ndarray, np.ndarray]:
    """The point of the line as built at unstretched arc length s from its start, and the unit
    tangent of its segment there."""
    seg = np.linalg.norm(np.diff(line.points, axis=0), axis=1)
    arc = np.concatenate([[0.0], np.cumsum(seg)])
    i = min(int(np.searchsorted(arc, s, side="right")) - 1, len(seg) - 1)
    chord = line.points[i + 1] - line.points[i]
    return line.points[i] + (s - arc[i]) / seg[i] * chord, chord / seg[i]


def path_point(path, s: float) -> np.ndarray:
    """The point of a path of lines as built at unstretched arc length s from its start."""
    for line in path[:-1]:
        if s <= line.length:
            return point_at(line, s)
        s -= line.length
    return point_at(path[-1], min(s, path[-1].length))


def _owner(kind: str, line) -> str:
    """How messages name a slider: 'ring on line 'wire'' or 'ring on lines 'a' + 'b''."""
    path = line if isinstance(line, (list, tuple)) else [line]
    names = [repr(getattr(l, "name", l)) for l in path]
    return f"{kind} on line {names[0]}" if len(names) == 1 else f"{kind} on lines {' + '.join(names)}"


def _path(net, line, who) -> tuple:
    path = tuple(line) if isinstance(line, (list, tuple)) else (line,)
    if not path:
        raise ValueError(f"{who}: give a line or a path of lines")
    for l in path:
        if getattr(l, "index", None) is None or l.index >= len(net.lines) or net.lines[l.index] is not l:
            raise ValueError(f"{who}: {l!r} is not a line of this net")
    for a, b in zip(path, path[1:]):
        if a.end is not b.start or np.any(a.end_offset) or np.any(b.start_offset):
            raise ValueError(f"{who}: a path's line must end at the node where the next starts, with no "
                             f"offsets there; {a.name!r} ends at {a.end.name!r}, {b.name!r} starts at "
                             f"{b.start.name!r}")
    return path


def _common(net, line, s, mu_s, mu_k, damping, who):
    path = _path(net, line, who)
    total = sum(l.length for l in path)
    s = checks.number(who, "s", s)
    if not 0.0 <= s <= total:
        names = " + ".join(repr(l.name) for l in path)
        raise ValueError(f"{who}: s must be in [0, {total:.6g}] m (the unstretched length of {names}), got {s:g}")
    mu_s, mu_k = checks.nonnegative(who, "mu_s", mu_s), checks.nonnegative(who, "mu_k", mu_k)
    if mu_k > mu_s:
        raise ValueError(f"{who}: mu_k must not exceed mu_s, got mu_s = {mu_s:g}, mu_k = {mu_k:g}")
    return path, s, mu_s, mu_k, checks.nonnegative(who, "damping", damping)


def add_ring(net, line, s, mass, inertia=None, mu_s=0.0, mu_k=0.0, damping=0.0, name=None):
    """Net.add_ring (module docstring): the ring's new node."""
    who = _owner("ring", line)
    path, s, mu_s, mu_k, damping = _common(net, line, s, mu_s, mu_k, damping, who)
    m = checks.positive(who, "mass", mass)
    node = net.add_node(path_point(path, s), mass=m, inertia=[math.inf] * 3 if inertia is None else inertia,
                        name=name)
    net.sliders.append(Slider("ring", path, s, node, mu_s, mu_k, damping))
    return node


def _given_node(net, at, who) -> bool:
    given = isinstance(getattr(at, "index", None), (int, np.integer))
    if given and (at.index >= len(net.nodes) or net.nodes[at.index] is not at):
        raise ValueError(f"{who}: {at!r} is not a node of this net")
    return given


def add_eyelet(net, line, s, at=None, mu=0.0, damping=0.0, radius=0.0, name=None):
    """Net.add_eyelet (module docstring): the eyelet's node."""
    radius = checks.nonnegative(_owner("eyelet", line), "radius", radius)
    if radius > 0.0:
        return add_sheave(net, line, s, at, mu, damping, radius, name)
    who = _owner("eyelet", line)
    path, s, mu, _, damping = _common(net, line, s, mu, mu, damping, who)
    here = path_point(path, s)
    given_node = _given_node(net, at, who)
    if given_node:
        point = at.position
    else:
        point = here if at is None else checks.vec3(who, "at", at)
    gap = float(np.linalg.norm(point - here))
    if gap > 1e-9 * max(1.0, sum(l.length for l in path)):
        raise ValueError(f"{who}: the line does not pass through the eyelet: its point at s = {s:g} m is "
                         f"{here.tolist()}, {gap:.3g} m from {point.tolist()}")
    node = at if given_node else net.add_node(point, fixed=True, name=name)
    net.sliders.append(Slider("eyelet", path, s, node, mu, mu, damping))
    return node


def add_sheave(net, line, s, at, mu, damping, radius, name=None):
    """Net.add_eyelet with a radius (module docstring): the sheave's node."""
    who = _owner("sheave", line)
    path, s, mu, _, damping = _common(net, line, s, mu, mu, damping, who)
    if len(path) != 1:
        raise ValueError(f"{who}: a sheave takes one line, not a path of {len(path)}")
    if at is None:
        raise ValueError(f"{who}: give at, the sheave's centre (a node or a point)")
    given_node = _given_node(net, at, who)
    if given_node and not at.fixed_position and not np.all(at.locked_axes):
        raise ValueError(f"{who}: node {at.name!r} may turn; a sheave moves with a node whose rotation is "
                         f"locked (give it no inertia)")
    centre = at.position.copy() if given_node else checks.vec3(who, "at", at)
    (l,) = path
    here, tangent = point_and_tangent(l, s)
    gap = float(np.linalg.norm(here - centre))
    if abs(gap - radius) > 0.05 * radius:
        raise ValueError(f"{who}: the line does not pass over the sheave: its point at s = {s:g} m is "
                         f"{gap:.4g} m from the centre {centre.tolist()}, not the radius {radius:g} m")
    axis = np.cross(here - centre, tangent)
    if not np.linalg.norm(axis) > 0.5 * gap:
        raise ValueError(f"{who}: the line at s = {s:g} m does not run along the rim (it meets it at "
                         f"{math.degrees(math.asin(min(1.0, np.linalg.norm(axis) / gap))):.3g} degrees)")
    node = at if given_node else net.add_node(centre, fixed=True, name=name)
    net.sheaves.append(Sheave(l, s, node, centre, axis / np.linalg.norm(axis), radius, mu, damping))
    return node
