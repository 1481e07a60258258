"""cosnet: nonlinear dynamics of Cosserat nets (Gratus & Tucker), accelerated with Numba."""

import os as _os

# Installed, the Numba kernels are the subpackage cosnet.kernels. In a source checkout they sit
# beside this folder, in the top-level kernels/; let `python -m cosnet ...` run from the checkout
# find them there too.
if not _os.path.isdir(_os.path.join(__path__[0], "kernels")):
    _root = _os.path.dirname(_os.path.abspath(__path__[0]))
    if _os.path.isfile(_os.path.join(_root, "kernels", "__init__.py")):
        __path__.append(_root)

from .engine.registry import Binding, Effect, Key, builtin_effects
from .core.materials import Circle, Ellipse, Material, Rectangle, Section, Tube
from .core.net import Line, Net, Node
from .core.scaling import Scale
from .engine.simulation import InstabilityError, Simulation
from .core.contract import contract
from .output.io import Output, SeriesWriter, read_output
from .studies.lincos import Mode, Modes, analytic_modes
from .studies.modes import DiscreteModes, main_modes, modes
from .scene.loader import RunSettings, Scene, build_scene, load_scene
from .studies.sweep import sweep
from .effects.drives import Path
from .effects.fluid import resistive_coefficients, slender_body_coefficients, wave_number
from .core.articulation import Ball, Hinge, Universal
from .effects.articulations import joint_state
from .effects.sliders import slider_state

# every effect cosnet declares is exported under its class name (cosnet.Gravity, ...)
_EFFECTS = {cls.__name__: cls for cls in builtin_effects().values()}
globals().update(_EFFECTS)

__all__ = [
    "Circle", "Ellipse", "Material", "Rectangle", "Section", "Tube",
    "Line", "Net", "Node",
    "Binding", "Effect", "Key", *_EFFECTS,
    "InstabilityError", "Simulation", "Scale",
    "contract", "Output", "SeriesWriter", "read_output", "Mode", "Modes", "analytic_modes",
    "DiscreteModes", "main_modes", "modes", "RunSettings", "Scene", "build_scene", "load_scene",
    "sweep", "Path", "resistive_coefficients", "slender_body_coefficients", "wave_number",
    "Ball", "Hinge", "Universal", "joint_state", "slider_state",
]
