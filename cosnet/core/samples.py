"""Small nets an effect's example scene is built on (Effect.example): a few short steel rods,
built in milliseconds, on which cosnet.studies.effect_check holds each effect to its contract."""

from __future__ import annotations

from .materials import Circle, Material
from .net import Line, Net

STEEL = Material(E=2.1e11, G=8.1e10, density=7850.0, name="steel")
RADIUS = 0.005   # m: every sample rod's section
LENGTH = 0.3     # m


def rod(net: Net | None = None, start=(0.0, 0.0, 0.0), end=(LENGTH, 0.0, 0.0), *, elements: int = 4,
        fixed: bool = False, **kw) -> tuple[Net, Line]:
    """(net, line): a steel rod from ``start`` to ``end`` added to ``net`` (a new one by
    default), its start node fixed when ``fixed``; ``kw`` go to Net.add_line."""
    net = Net() if net is None else net
    a = net.add_node(start, fixed=fixed)
    b = net.add_node(end)
    return net, net.add_line(a, b, material=STEEL, section=Circle(RADIUS), elements=elements, **kw)


def crossing(gap: float = 1.6 * RADIUS) -> tuple[Net, Line, Line]:
    """(net, a, b): two rods crossing at their middles, their centrelines ``gap`` apart
    (less than two radii: their capsules overlap)."""
    net, a = rod()
    h = 0.5 * LENGTH
    _, b = rod(net, (h, -h, gap), (h, h, gap))
    return net, a, b


def chain() -> tuple[Net, Line, Line]:
    """(net, a, b): two rods end to end, b's start a millimetre past a's end and turned a
    little (a joint between them holds a load)."""
    net, a = rod()
    _, b = rod(net, (LENGTH + 1e-3, 0.0, 0.0), (2 * LENGTH, 0.02, 0.01))
    return net, a, b
