"""Compile-time composition of effect kernels.

An effect is a ``NamedTuple`` of parameters (its declaration) registered with one ``@njit``
kernel. A simulation passes the tuple of its declared effects to the step; ``apply_loads`` and
``apply_flows`` unroll that tuple at compile time into a straight sequence of kernel calls, so
the step that runs contains exactly the declared effects: no flags, no loops over absent ones.

Load kernels:  kernel(effect, model, state, loads)  -> add to loads (forces/torques)
Flow kernels:  kernel(effect, model, state, h)      -> exact velocity flows (e.g. damping)
Account kernels (optional, beside a load kernel): kernel(effect, model, state, h / 2), run
  just before and just after every kick: the work the effect's load does in the kick, h times
  its load dotted with the mean of the velocities before and after (what the kick gives the
  kinetic energy, exactly)
Inertia kernels (optional, beside a flow kernel): kernel(effect, model, state, (loads, h)),
  run after the loads of a kick of h are evaluated and their work accounted, just before the
  kick divides them by the masses: an effect that adds mass (a fluid's added mass) turns f
  into m M^-1 f (and adds the forces of that mass turning)
Constraint kernels, a pair (kinematic effects: prescribed motion), run after every stage:
  after a drift of h:  kernel(effect, model, state, h)          -> set the prescribed pose
                       at the stage's end time state.clock[0], and its velocity
  after a kick of h:   kernel(effect, model, state, (loads, h)) -> undo the kick on the
                       prescribed components, given the loads that made it
"""

import io
import pickle
import types as _pytypes

from numba import njit
from numba.core import caching, types
from numba.extending import intrinsic

LOAD_KERNELS: dict = {}
FLOW_KERNELS: dict = {}
KERNELS: dict = {}   # declaration -> the kernel as decorated (callable from Python), either stage
DRIFT_CONSTRAINTS: dict = {}
KICK_CONSTRAINTS: dict = {}
ACCOUNTS: dict = {}
INERTIAS: dict = {}


def _inner(kernel):
    """The kernel as the step calls it: without numba's Python entry wrapper (a function
    receiving the model and state records compiles several times slower with it). A kernel
    declared that way already is used as it is; others get a wrapper-less twin, and stay
    callable from Python."""
    options = dict(kernel.targetoptions)
    if options.get("no_cpython_wrapper"):
        return kernel
    options.pop("nopython", None)
    return njit(**options, no_cpython_wrapper=True, no_cfunc_wrapper=True)(kernel.py_func)


def load_kernel(declaration):
    """Register the decorated njit function as the load kernel of ``declaration``."""
    def register(kernel):
        LOAD_KERNELS[declaration] = _inner(kernel)
        KERNELS[declaration] = kernel
        return kernel
    return register


def flow_kernel(declaration):
    """Register the decorated njit function as the velocity-flow kernel of ``declaration``."""
    def register(kernel):
        FLOW_KERNELS[declaration] = _inner(kernel)
        KERNELS[declaration] = kernel
        return kernel
    return register


def account_kernel(declaration):
    """Register the decorated njit function as the account kernel of ``declaration`` (a
    declaration that has a load kernel)."""
    def register(kernel):
        ACCOUNTS[declaration] = _inner(kernel)
        return kernel
    return register


def inertia_kernel(declaration):
    """Register the decorated njit function as the inertia kernel of ``declaration`` (a
    declaration that has a flow kernel)."""
    def register(kernel):
        INERTIAS[declaration] = _inner(kernel)
        return kernel
    return register


def constraint_kernels(declaration, after_drift, after_kick):
    """Register the njit pair run after every drift and every kick for ``declaration``."""
    DRIFT_CONSTRAINTS[declaration] = _inner(after_drift)
    KICK_CONSTRAINTS[declaration] = _inner(after_kick)
    KERNELS[declaration] = after_drift


def _chain(registry, what, optional=False):
    """Return an intrinsic f(effects, model, state, arg) emitting, into its caller, one call
    kernel(effects[i], model, state, arg) per effect in order (the kernel of each effect's
    type, looked up in registry when the caller is compiled); ``optional``: effects without
    one are skipped."""
    @intrinsic
    def apply(typingctx, effects, model, state, arg):
        try:
            kernels = [registry.get(t.instance_class) if optional else registry[t.instance_class]
                       for t in effects.types]
        except (AttributeError, KeyError):
            raise TypeError(f"no {what} kernel registered for effect types {effects}") from None
        calls = []
        for kernel, t in zip(kernels, effects.types):
            if kernel is None:
                calls.append(None)
                continue
            fnty = typingctx.resolve_value_type(kernel)
            calls.append((fnty, typingctx.resolve_function_type(fnty, (t, model, state, arg), {})))

        def codegen(context, builder, signature, args):
            effs, m, s, a = args
            for i, call in enumerate(calls):
                if call is None:
                    continue
                fnty, sig = call
                context.get_function(fnty, sig)(builder, (builder.extract_value(effs, i), m, s, a))
            return context.get_dummy_value()
        return types.none(effects, model, state, arg), codegen
    return apply


# apply_loads(effects, model, state, loads): add the loads of every effect of the tuple
apply_loads = _chain(LOAD_KERNELS, "load")
# apply_flows(effects, model, state, h): the velocity flow of every effect for time h
apply_flows = _chain(FLOW_KERNELS, "flow")
# apply_accounts(effects, model, state, h / 2): the work of every load effect that keeps one
apply_accounts = _chain(ACCOUNTS, "account", optional=True)
# apply_inertias(effects, model, state, (loads, h)): the loads as the masses of the effects that add some see them
apply_inertias = _chain(INERTIAS, "inertia", optional=True)


class UnresolvedRecord:
    """Stands, in a step's cache index read back, for an effect record whose module this
    process cannot import (a package since uninstalled, a script's own class)."""


class _IndexUnpickler(pickle.Unpickler):
    def find_class(self, module, name):
        try:
            return super().find_class(module, name)
        except (ImportError, AttributeError):
            return UnresolvedRecord


def _tolerant_loads(data, **kw):
    return _IndexUnpickler(io.BytesIO(data), **kw).load()


def _tolerate_unresolved_records():
    """Let numba read a cache index that names records it cannot import. The step's index
    holds one signature per combination of effects, each naming its records' classes: one
    unimportable class made every later compilation of the step fail on loading the index.
    Such an entry now names UnresolvedRecord instead, matches no signature and is skipped."""
    if getattr(caching.pickle, "tolerant", False):
        return
    shim = _pytypes.ModuleType("pickle")
    shim.__dict__.update(pickle.__dict__)
    shim.loads, shim.tolerant = _tolerant_loads, True
    caching.pickle = shim


_tolerate_unresolved_records()
# apply_drift_constraints(effects, model, state, h): every prescribed pose after a drift
apply_drift_constraints = _chain(DRIFT_CONSTRAINTS, "drift constraint")
# apply_kick_constraints(effects, model, state, (loads, h)): every prescribed velocity after a kick
apply_kick_constraints = _chain(KICK_CONSTRAINTS, "kick constraint")
