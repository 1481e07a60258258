"""cosnet: nonlinear dynamics of Cosserat nets (Gratus & Tucker), accelerated with Numba."""

from .effects import Damping, Effect, Gravity, LineLoad, NodeLoad
from .materials import Circle, Ellipse, Material, Rectangle, Section, Tube
from .net import Line, Net, Node
from .scaling import Scale
from .simulation import InstabilityError, Simulation

__all__ = [
    "Circle", "Ellipse", "Material", "Rectangle", "Section", "Tube",
    "Line", "Net", "Node",
    "Damping", "Effect", "Gravity", "LineLoad", "NodeLoad",
    "InstabilityError", "Simulation", "Scale",
]
