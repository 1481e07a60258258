"""cosnet: nonlinear dynamics of Cosserat nets (Gratus & Tucker), accelerated with Numba."""

import os as _os

# Installed, the Numba kernels are the subpackage cosnet.kernels. In a source checkout they sit
# beside this folder, in the top-level kernels/; let `python -m cosnet ...` run from the checkout
# find them there too.
if not _os.path.isdir(_os.path.join(__path__[0], "kernels")):
    _root = _os.path.dirname(_os.path.abspath(__path__[0]))
    if _os.path.isfile(_os.path.join(_root, "kernels", "__init__.py")):
        __path__.append(_root)

from .effects import Damping, Effect, Gravity, LineLoad, NodeLoad
from .drives import Drive, Path
from .active import ActiveCurvature, MuscleTorque
from .joints import FixedJoint, HingeJoint, SphericalJoint
from .materials import Circle, Ellipse, Material, Rectangle, Section, Tube
from .net import Line, Net, Node
from .scaling import Scale
from .simulation import InstabilityError, Simulation
from .contract import contract
from .io import Output, SeriesWriter, read_output
from .lincos import Mode, Modes, analytic_modes
from .modes import DiscreteModes, main_modes, modes
from .scene import RunSettings, Scene, build_scene, load_scene
from .contact import Contact
from .sweep import sweep

__all__ = [
    "Circle", "Ellipse", "Material", "Rectangle", "Section", "Tube",
    "Line", "Net", "Node",
    "Damping", "Effect", "Gravity", "LineLoad", "NodeLoad", "Drive", "Path", "MuscleTorque", "ActiveCurvature",
    "SphericalJoint", "HingeJoint", "FixedJoint",
    "InstabilityError", "Simulation", "Scale",
    "contract", "Output", "SeriesWriter", "read_output", "Mode", "Modes", "analytic_modes",
    "DiscreteModes", "main_modes", "modes", "RunSettings", "Scene", "build_scene", "load_scene",
    "Contact", "sweep",
]
