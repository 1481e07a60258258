"""Compile-time composition of effect kernels.

An effect is a ``NamedTuple`` of parameters (its declaration) registered with one ``@njit``
kernel. A simulation passes the tuple of its declared effects to the step; ``apply_loads`` and
``apply_flows`` unroll that tuple at compile time into a straight sequence of kernel calls, so
the step that runs contains exactly the declared effects: no flags, no loops over absent ones.

Load kernels:  kernel(effect, model, state, loads)  -> add to loads (forces/torques)
Flow kernels:  kernel(effect, model, state, h)      -> exact velocity flows (e.g. damping)
"""

from numba import njit
from numba.extending import overload

LOAD_KERNELS: dict = {}
FLOW_KERNELS: dict = {}


def _inlined(kernel):
    """The kernel's body, inlined where the step calls it (with the kernel's own options): one
    compilation pipeline fewer per effect, and no call. The registered dispatcher itself stays
    callable from Python and other kernels."""
    options = {k: v for k, v in kernel.targetoptions.items() if k != "nopython"}
    return njit(**options, inline="always")(kernel.py_func)


def load_kernel(declaration):
    """Register the decorated njit function as the load kernel of ``declaration``."""
    def register(kernel):
        LOAD_KERNELS[declaration] = _inlined(kernel)
        return kernel
    return register


def flow_kernel(declaration):
    """Register the decorated njit function as the velocity-flow kernel of ``declaration``."""
    def register(kernel):
        FLOW_KERNELS[declaration] = _inlined(kernel)
        return kernel
    return register


def _chain(kernels, i):
    """Return an njit function calling kernels[i:] on effects[i:] in order."""
    if i == len(kernels):
        @njit(inline="always")
        def done(effects, model, state, arg):
            return None
        return done
    kernel = kernels[i]
    rest = _chain(kernels, i + 1)

    @njit(inline="always")
    def call(effects, model, state, arg):
        kernel(effects[i], model, state, arg)
        rest(effects, model, state, arg)
    return call


def apply_loads(effects, model, state, loads):
    """Add the loads of every effect in the tuple ``effects`` (njit only)."""


def apply_flows(effects, model, state, h):
    """Apply the velocity flow of every effect in the tuple ``effects`` for time h (njit only)."""


def _overload_chain(registry, what):
    def typer(effects, model, state, arg):
        try:
            kernels = [registry[t.instance_class] for t in effects.types]
        except (AttributeError, KeyError):
            raise TypeError(f"no {what} kernel registered for effect types {effects}")
        call = _chain(kernels, 0)

        def impl(effects, model, state, arg):
            call(effects, model, state, arg)
        return impl
    return typer


overload(apply_loads)(_overload_chain(LOAD_KERNELS, "load"))
overload(apply_flows)(_overload_chain(FLOW_KERNELS, "flow"))
