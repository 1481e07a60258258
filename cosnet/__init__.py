"""cosnet: nonlinear dynamics of Cosserat nets (Gratus & Tucker), accelerated with Numba."""

from .effects import Damping, Effect, Gravity, LineLoad, NodeLoad
from .materials import Circle, Ellipse, Material, Rectangle, Section, Tube
from .net import Line, Net, Node
from .scaling import Scale
from .simulation import InstabilityError, Simulation
from .contract import contract
from .io import Output, SeriesWriter, read_output
from .lincos import Mode, Modes, analytic_modes
from .modes import DiscreteModes, main_modes, modes
from .scene import RunSettings, Scene, build_scene, load_scene

__all__ = [
    "Circle", "Ellipse", "Material", "Rectangle", "Section", "Tube",
    "Line", "Net", "Node",
    "Damping", "Effect", "Gravity", "LineLoad", "NodeLoad",
    "InstabilityError", "Simulation", "Scale",
    "contract", "Output", "SeriesWriter", "read_output", "Mode", "Modes", "analytic_modes",
    "DiscreteModes", "main_modes", "modes", "RunSettings", "Scene", "build_scene", "load_scene",
]
