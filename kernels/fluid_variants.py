"""The variants of the fluid's kernels: each fluid's record is of the variant its data needs,
whose kernels are compiled without the parts that cannot act (kernels/specialise.py; the
options are kernels.fluid.OPTIONS). A variant's record class is a FluidParams named by its
options' bits (FluidParams_0101), found by that name wherever a record is unpickled."""

import numpy as np

from . import added_mass, fluid, fluid_step
from .backend import NODE_BLOCK
from .compose import flow_kernel, inertia_kernel
from .fluid import OPTIONS, FluidParams
from .specialise import Variants


def _register(cls, kernels):
    flow_kernel(cls)(kernels["flow_fluid"])
    inertia_kernel(cls)(kernels["kick_fluid"])


VARIANTS = Variants(FluidParams, lambda: (fluid, fluid_step, added_mass), OPTIONS, _register, __name__)


def options_of(p, model=None, threads=1) -> tuple:
    """The options record ``p``'s data needs, one per entry of OPTIONS, True where that part
    of the medium may act (by the kernels' own tests, run in Python): of each pair (the drag's
    law, a medium at rest or flowing) the one its data has. The nodes' arms are the model's:
    without it (``model`` None), some node may have one. THREADS where the step runs on more
    than one thread (``threads``) and the medium has more lines than a block of them, or the
    net more nodes than a block (its threaded loops would otherwise each run one block, in the
    calling thread, and their compiling buy nothing)."""
    moving = not fluid.still_medium.py_func(p)
    carries = fluid.has_added_mass.py_func(p) or p.buoy_node.shape[0] > 0
    nodes = p.buoy_node.shape[0] > 0 or bool(np.any(p.node_skip == 0.0))   # (fixed nodes are skipped too)
    linear, calm = p.law == fluid.LINEAR, not moving and not np.any(p.current)   # (fluid.calm_medium)
    arms = model is None or bool(np.any(np.any(model.attach_offset != 0.0, axis=1)
                                        & (model.node_inv_mass > 0.0)[model.attach_node]
                                        & (p.node_skip == 0.0)[model.attach_node]))   # (fluid_step.point_junction)
    blocks = p.lines.shape[0] > fluid.LINE_BLOCK or (model is None or model.node_mass.shape[0] > NODE_BLOCK)
    threaded = threads > 1 and blocks
    return moving, carries, p.wave_a.shape[0] > 0, nodes, not linear, linear, calm, not calm, arms, threaded


def fluid_record(p, model=None, threads=1):
    """``p`` (a FluidParams) as the record of the variant its data needs (on ``model``: the
    nodes' arms; on ``threads`` threads), sharing its arrays."""
    return VARIANTS.record(p, options_of(p, model, threads))


__getattr__ = VARIANTS.module_getattr   # a variant's record class by its name, as pickle looks for it
