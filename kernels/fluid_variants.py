"""The variants of the fluid's kernels: each fluid's record is of the variant its data needs,
whose kernels are compiled without the parts that cannot act (kernels/specialise.py; the
options are kernels.fluid.OPTIONS). A variant's record class is a FluidParams named by its
options' bits (FluidParams_01), found by that name wherever a record is unpickled."""

from typing import NamedTuple

from . import added_mass, fluid
from .compose import flow_kernel, inertia_kernel
from .fluid import OPTIONS, FluidParams
from .specialise import specialise


def options_of(p) -> str:
    """The variant record ``p``'s data needs: a bit per entry of OPTIONS, "1" where that part
    of the medium may act (by the kernels' own tests, run in Python)."""
    moving = not fluid.still_medium.py_func(p)
    carries = fluid.has_added_mass.py_func(p) or p.buoy_node.shape[0] > 0
    return "".join("1" if b else "0" for b in (moving, carries))


class FluidVariant(NamedTuple):
    record: type    # the record class (a subclass of FluidParams) the step is typed by
    family: dict    # its kernels by name, where they differ from kernels.fluid's

    def kernel(self, name: str):
        """Its kernel ``name`` (one callable from Python: sample_fluid, fluid_entrained_energy)."""
        return self.family.get(name) or getattr(fluid, name)


_VARIANTS: dict = {}


def fluid_variant(bits: str) -> FluidVariant:
    """The variant of the fluid's kernels with the parts of ``bits`` (options_of), built once
    per process: its record class, named by its bits, with its flow and inertia kernels
    registered."""
    held = _VARIANTS.get(bits)
    if held is not None:
        return held
    if len(bits) != len(OPTIONS) or set(bits) - {"0", "1"}:
        raise ValueError(f"fluid variant {bits!r}: expected {len(OPTIONS)} bits, one per option {OPTIONS}")
    kernels = specialise((fluid, added_mass), {name: b == "1" for name, b in zip(OPTIONS, bits)}, bits)
    cls = type(f"FluidParams_{bits}", (FluidParams,), {"__slots__": (), "__module__": __name__})
    flow_kernel(cls)(kernels["flow_fluid"])
    inertia_kernel(cls)(kernels["add_fluid_mass"])
    held = _VARIANTS[bits] = FluidVariant(cls, kernels)
    return held


def fluid_record(p):
    """``p`` (a FluidParams) as the record of the variant its data needs, sharing its arrays."""
    return fluid_variant(options_of(p)).record(*p)


def fluid_kernels(p) -> FluidVariant:
    """The variant whose record ``p`` is (FluidParams itself: every part)."""
    if type(p) is FluidParams:
        return FluidVariant(FluidParams, {})
    return fluid_variant(type(p).__name__[len("FluidParams_"):])


def __getattr__(name):
    # a variant's record class by its name, as pickle looks for it (a sweep's worker; a step's
    # cache index naming the records it was compiled for)
    if name.startswith("FluidParams_"):
        try:
            return fluid_variant(name[len("FluidParams_"):]).record
        except ValueError:
            pass
    raise AttributeError(f"module {__name__!r} has no attribute {name!r}")
