"""Composition of effect kernels into a step.

An effect is a ``NamedTuple`` of parameters (its declaration) registered with one ``@njit``
kernel per hook of the step it acts at. A simulation's step calls, at each hook, the kernel of
every declared effect that has one, in order, and nothing for an absent effect: no flags. The
calls go through addresses (the slots of the step's table, ``bind_slots``, kernels/slots.py),
each with a pointer to its effect's record (``Pins``): each kernel is compiled once in a
library of its own, and the step, which never sees the records, once for every combination:
a new combination compiles the kernels of its new kinds alone.

Load kernels:  kernel(effect, model, state, loads)  -> add to loads (forces/torques)
Flow kernels:  kernel(effect, model, state, h)      -> exact velocity flows (e.g. damping)
Account kernels (optional, beside a load kernel): kernel(effect, model, state, h / 2), run
  just before and just after every kick: the work the effect's load does in the kick, h times
  its load dotted with the mean of the velocities before and after (what the kick gives the
  kinetic energy, exactly)
Inertia kernels (optional, beside a flow kernel): kernel(effect, model, state, (loads, h)),
  run after the loads of a kick of h are evaluated and their work accounted, just before the
  kick divides them by the masses: an effect that adds mass (a fluid's added mass) turns f
  into m M^-1 f (and adds the forces of that mass turning); a velocity flow may run there
  between the kick's halves, v -> F(v + h/2 a) - h/2 a, a = f / m (a fluid's drag at the
  lines' vertices: one flow a kick where halves on its sides take two)
Constraint kernels, a pair (kinematic effects: prescribed motion), run after every stage:
  after a drift of h:  kernel(effect, model, state, h)          -> set the prescribed pose
                       at the stage's end time state.clock[0], and its velocity
  after a kick of h:   kernel(effect, model, state, (loads, h)) -> undo the kick on the
                       prescribed components, given the loads that made it
"""

import inspect
import io
import os
import pickle
import types as _pytypes
from collections import deque

import numba
import numpy as np
from numba import njit
from numba.core import caching, cgutils, types
from numba.extending import intrinsic

from .backend import ENTRY, STEP, inline_twin
from .linking import addressed
from .compiler import (compiling_elsewhere, extend_cache_key, keyed_twin, reaches_compiling_elsewhere,
                       stable_cache_key)
from .slots import (SLOT_ADDRESS, SLOT_COLUMNS, SLOT_HOOK, SLOT_PROCESS, SLOT_RECORD, call_effect, call_slot,
                    core_type, deref, load_table, pin_record, pinned, record_size, slot_argtypes, slot_key,
                    slots_bound_here, step_pointers)

LOAD_KERNELS: dict = {}
FLOW_KERNELS: dict = {}
KERNELS: dict = {}   # declaration -> the kernel as decorated (callable from Python), either stage
DRIFT_CONSTRAINTS: dict = {}
KICK_CONSTRAINTS: dict = {}
ACCOUNTS: dict = {}
INERTIAS: dict = {}
_TWINS: dict = {}   # a kernel -> its twin without entry wrapper (_inner)


def _inner(kernel):
    """The kernel as the step calls it: without numba's Python entry wrapper (a function
    receiving the model and state records compiles several times slower with it). A kernel
    declared that way already is used as it is; others get a wrapper-less twin, and stay
    callable from Python. The twin is cached as its kernel is, under a key of its own: the two
    share one index file (one function, one source line), and numba's key (the argument types)
    would let either load the other's code, the twin's lacking the entry Python calls."""
    if kernel.targetoptions.get("no_cpython_wrapper"):
        return kernel
    held = _TWINS.get(kernel)   # (a kernel shared by several variants' records is registered for each)
    if held is None:
        held = _TWINS[kernel] = keyed_twin(kernel, kernel.py_func, "without entry wrapper", no_cpython_wrapper=True,
                                           no_cfunc_wrapper=True)
    return held


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


# The step's hooks in slot order: (what, registry, group of the step records it serves,
# whether every effect of that group must have a kernel there).
HOOKS = (("load", LOAD_KERNELS, 0, True), ("flow", FLOW_KERNELS, 1, True),
         ("account", ACCOUNTS, 0, False), ("inertia", INERTIAS, 1, False),
         ("drift constraint", DRIFT_CONSTRAINTS, 2, True), ("kick constraint", KICK_CONSTRAINTS, 2, True))
N_HOOKS = len(HOOKS)
LOAD_HOOK = 0   # the index of the load kernels' hook
# The slot kernels every step calls (internal loads, the velocity and position updates), in
# the slots of their registration, before the effects' (kernels/slots.py).
CORE: list = []
_WRAPPERS: dict = {}   # (effect kernel, hook) -> the slot kernel calling it


def slot_layout(groups):
    """Return [(hook index, group index, effect index, kernel)] in the order of the effect
    slots (after the CORE ones), given the three tuples (load, flow, constraint) of effect
    record classes of a step (the records' own: a variant's numba type names its base)."""
    layout = []
    for k, (what, registry, g, required) in enumerate(HOOKS):
        for i, cls in enumerate(groups[g]):
            kernel = registry.get(cls)
            if kernel is None and required:
                raise TypeError(f"no {what} kernel registered for effect record {cls.__name__}")
            if kernel is not None:
                layout.append((k, g, i, kernel))
    return layout


def slot_wrapper(kernel, hook):
    """The slot kernel (kernels/slots.py) calling the effect kernel ``kernel`` as hook ``hook``
    (an index of HOOKS) calls it: compiled once per kernel and types, LLVM inlining the kernel
    into it, so that the step passes it four words and no records."""
    held = _WRAPPERS.get((kernel, hook))
    if held is not None:
        return held
    what, f = HOOKS[hook][0], kernel.py_func
    name = f"{what}:{f.__module__}.{f.__qualname__}"
    registered, kernel = kernel, inline_twin(kernel)
    # the step calls it with order = the hook it runs (run_hook): a kernel found in another
    # hook's rows raises instead of running there; pinned checks the record's type
    if what == "load":
        def call(core, record, h, order):
            if order != hook:
                raise RuntimeError("kernel slot not bound to the kernel of its hook")
            model, state, loads, _ = deref(core)
            kernel(pinned(record), model, state, loads)
    elif what in ("inertia", "kick constraint"):
        def call(core, record, h, order):
            if order != hook:
                raise RuntimeError("kernel slot not bound to the kernel of its hook")
            model, state, loads, _ = deref(core)
            kernel(pinned(record), model, state, (loads, h))
    else:
        def call(core, record, h, order):
            if order != hook:
                raise RuntimeError("kernel slot not bound to the kernel of its hook")
            model, state, _, _ = deref(core)
            kernel(pinned(record), model, state, h)
    held = _WRAPPERS[(registered, hook)] = stable_cache_key(njit(**STEP)(addressed(call)))
    held.slot_name = name   # the wrappers share one function name: their keys name their kernel
    stamp = _source_stamp(kernel)
    if stamp is None:
        held._cache = caching.NullCache()
    else:
        extend_cache_key(held, stamp)
    return held


def _source_stamp(kernel):
    """The modification time and size of the file defining ``kernel`` (None: no file). A
    wrapper's cached code holds its kernel's: it is keyed by the kernel's file as well, which
    numba's key for the wrapper, by its own file, would not see change."""
    try:
        st = os.stat(inspect.getsourcefile(kernel.py_func))
    except (TypeError, OSError):
        return None
    return (st.st_mtime, st.st_size)


def records_layout(records):
    """slot_layout of a step's effect records (three tuples of records)."""
    return slot_layout([tuple(type(r) for r in group) for group in records])


def step_kernels(records) -> list:
    """The slot kernels of a step of ``records`` (three tuples of effect records), a njit
    function each, in slot order: CORE's, then a wrapper per effect hook (slot_wrapper)."""
    layout = records_layout(records)
    return list(CORE) + [slot_wrapper(kernel, k) for k, _, _, kernel in layout]


def empty_table(records) -> tuple:
    """The table of a step of ``records`` (three tuples of effect records): (slots, hook rows),
    slots (n, SLOT_COLUMNS) int64 unbound (a step called with them raises rather than calling
    anything) but for each effect row's hook, hook rows (len(HOOKS) + 1,) the first row of
    each hook's effects (they follow CORE's, hook by hook), then the end."""
    layout = records_layout(records)
    slots = np.zeros((len(CORE) + len(layout), SLOT_COLUMNS), np.int64)
    slots[:len(CORE), SLOT_HOOK] = -1
    slots[len(CORE):, SLOT_HOOK] = [k for k, _, _, _ in layout]
    hooks = np.searchsorted(slots[len(CORE):, SLOT_HOOK], np.arange(len(HOOKS) + 1)) + len(CORE)
    return slots, hooks.astype(np.int64)


def step_calls(records, model, state, loads, backend) -> list:
    """[(slot kernel, its argument types)] of a step of ``records`` (three tuples of effect
    records) given the numba types of the model, state, loads and backend, in slot order."""
    core = core_type(model, state, loads, backend)
    groups = numba.typeof(tuple(records)).types
    calls = [(kernel, slot_argtypes(core)) for kernel in CORE]
    calls += [(slot_wrapper(kernel, k), slot_argtypes(core, groups[g].types[i]))
              for k, g, i, kernel in records_layout(records)]   # (by the records' classes: a variant's
    return calls                                                 # numba type is its base's, kernels/specialise.py)


def bind_slots(table, records, model, state, loads, backend, flags_of, rows=None) -> None:
    """Update the slots of ``table`` (empty_table) given the step's effect records and the
    numba types of the model, state, loads and backend: compile (or load from the cache) every
    slot kernel the step calls, under the compiler flags of ``flags_of`` (the step: a kernel
    leaving fast-math, the error model or reference counting unset takes its caller's), and
    write its address here; ``rows``: those slots alone, in that order (a second process
    compiling alongside). The records' own addresses are written where they are pinned
    (Pins)."""
    from numba.core import compiler
    from numba.core.targetconfig import ConfigStack
    flags = compiler.Flags()
    flags_of.targetdescr.options.parse_as_flags(flags, flags_of.targetoptions)
    slots = table[0]
    calls = step_calls(records, model, state, loads, backend)
    if slots.shape != (len(calls), SLOT_COLUMNS):
        raise ValueError(f"slots of shape {slots.shape} for a step of {len(calls)} kernels")
    pending = deque(range(len(calls)) if rows is None else rows)
    put_off = set()
    while pending:
        row = pending.popleft()
        kernel, argtypes = calls[row]
        # a kernel the other process (compiling alongside a run) is compiling right now, or
        # one of its callees, goes to the end of the queue: by then it is cached, where
        # waiting for it would idle a core
        if row not in put_off and pending and (compiling_elsewhere(kernel, argtypes)
                                               or reaches_compiling_elsewhere(kernel)):
            put_off.add(row)
            pending.append(row)
            continue
        with ConfigStack().enter(flags):
            kernel.compile(argtypes)
        cres = kernel.overloads[argtypes]
        if cres.signature.return_type != types.none:   # the step calls it as returning nothing
            raise TypeError(f"slot kernel {kernel.py_func.__qualname__} must return nothing")
        address = cres.library.get_pointer_to_function(cres.fndesc.llvm_func_name)
        slots[row, SLOT_ADDRESS:SLOT_PROCESS + 1] = (address, slot_key(kernel, argtypes), os.getpid())


class Pins:
    """The effect records of a step pinned where its slot kernels read them (slots.pin_record):
    a buffer per record, its address in the slots of every hook of its effect. Pinned anew at
    every call of the step (``__call__``): a buffer holds the addresses of its record's arrays,
    which a copied simulation does not share."""

    def __init__(self, records):
        rows: dict = {}   # (group, index) of a record -> its slots (a record per declared effect)
        for row, (_, g, i, _) in enumerate(records_layout(records)):
            rows.setdefault((g, i), []).append(len(CORE) + row)
        self.records = [records[g][i] for g, i in rows]
        self.rows = list(rows.values())
        self.types = [numba.typeof(r) for r in self.records]
        self.buffers = [np.zeros(record_size(t), np.uint8) for t in self.types]
        self.entries = None

    def signatures(self) -> list:
        """The argument types pin_record is compiled for, one per record."""
        buffer = numba.typeof(np.zeros(1, np.uint8))
        return [(t, buffer) for t in self.types]

    def __call__(self, table) -> None:
        """Update the buffers given the records, and their addresses in table's slots."""
        if self.entries is None:
            entries = []
            for sig in self.signatures():
                pin_record.compile(sig)
                entries.append(pin_record.overloads[sig].entry_point)
            self.entries = entries
        slots = table[0]
        for entry, record, buffer, rows in zip(self.entries, self.records, self.buffers, self.rows):
            entry(record, buffer)
            slots[rows, SLOT_RECORD] = buffer.ctypes.data


def _slot_signature(args):
    """The signature a step calls a slot kernel by: every slot kernel returns nothing
    (bind_slots refuses one that does not). Written, not typed from the kernel: typing the
    call would compile the kernel inside the step's compilation, so that a step could not be
    compiled while another process compiles its kernels."""
    return types.none(*args)


def _pointed(ptrs, what):
    """(core type, step records type) given the type of step_pointers' result."""
    if not (isinstance(ptrs, types.BaseTuple) and len(ptrs) == 2
            and all(isinstance(t, types.CPointer) for t in ptrs.types)):
        raise TypeError(f"{what}: the step's pointers (slots.step_pointers) expected, got {ptrs}")
    return ptrs.types[0].dtype, ptrs.types[1].dtype


def core_kernel(kernel):
    """Register the slot kernel ``kernel`` (kernel(core, record, h, order), kernels/slots.py)
    as one every step calls, in the next CORE slot. Returns an intrinsic f(ptrs, h, order)
    calling it there (ptrs: slots.step_pointers' result)."""
    row = len(CORE)
    CORE.append(kernel)
    addressed(kernel.py_func)   # (its machine code is what the slot calls: kernels/linking.py)
    what = kernel.py_func.__qualname__

    @intrinsic
    def call(typingctx, ptrs, h, order):
        core, effects = _pointed(ptrs, what)
        argtypes = slot_argtypes(core)
        sig = _slot_signature(argtypes)
        key = slot_key(kernel, argtypes)

        def codegen(context, builder, signature, args):
            p_core, p_effects = cgutils.unpack_tuple(builder, args[0])
            table = load_table(context, builder, effects, p_effects, len(CORE))
            values = (p_core, context.get_constant_null(types.voidptr),
                      context.cast(builder, args[1], h, types.float64),
                      context.cast(builder, args[2], order, types.int64))
            call_slot(context, builder, table, row, key, sig, values, what)
            return context.get_dummy_value()
        return types.none(ptrs, h, order), codegen
    return call


@intrinsic
def core_rows(typingctx):
    """Return the number of CORE slots (a constant of the step)."""
    def codegen(context, builder, signature, args):
        return context.get_constant(types.int64, len(CORE))
    return types.int64(), codegen


@njit(**STEP)
def run_hook(ptrs, h, hook):
    """Call the kernel of hook ``hook`` (an index of HOOKS) of every effect that has one, in
    order, each through its slot with its pinned record, for time h (ptrs:
    slots.step_pointers' result). The rows of each hook are a range of the table (empty_table).
    A function of its own, called, not inlined: a step calls it a dozen times, and a copy at
    each call doubled the step's compilation, for a call per hook a step saves nothing."""
    slots, hooks = deref(ptrs[1])
    if hooks.shape[0] != N_HOOKS + 1:
        raise RuntimeError("kernel slots missing: compose.bind_slots")
    lo, hi = hooks[hook], hooks[hook + 1]
    if lo < core_rows() or hi < lo or hi > slots.shape[0] or slots.shape[1] != SLOT_COLUMNS:
        raise RuntimeError("kernel slots missing: compose.bind_slots")
    for row in range(lo, hi):
        if slots[row, SLOT_HOOK] != hook:
            raise RuntimeError("kernel slot not bound to the kernel of its hook")
        if slots[row, SLOT_RECORD] == 0:
            raise RuntimeError("kernel slot without its record: compose.Pins")
        call_effect(ptrs[0], slots[row, SLOT_ADDRESS], slots[row, SLOT_RECORD], h, hook)


@njit(**ENTRY)
def run_slot(model, state, loads, table, backend, row, h):
    """Call the effect kernel of slot ``row`` of the step table ``table`` (bound in this
    process: bind_slots; its record pinned: Pins) at its hook, for time h, with the model,
    state, loads and backend: one effect's kernel alone, the very code the step calls,
    callable from Python. Called through layout.typed_call, which types the records as the
    step does: the slot kernel reads them as the types it was compiled for."""
    slots = table[0]
    if row < core_rows() or row >= slots.shape[0] or slots.shape[1] != SLOT_COLUMNS:
        raise ValueError("run_slot: no effect slot of that row")
    if not slots_bound_here(table):
        raise RuntimeError("run_slot: the slots are not bound in this process: compose.bind_slots")
    if slots[row, SLOT_RECORD] == 0:
        raise RuntimeError("kernel slot without its record: compose.Pins")
    ptrs = step_pointers(model, state, loads, table, backend)
    call_effect(ptrs[0], slots[row, SLOT_ADDRESS], slots[row, SLOT_RECORD], h, slots[row, SLOT_HOOK])


def effect_rows(records, record, hook) -> list:
    """The slots (rows of the step table) of the kernel of hook ``hook`` (an index of HOOKS)
    that a step of ``records`` (three tuples of effect records) calls with ``record`` (by
    identity): one, or none where that record has no kernel there."""
    return [len(CORE) + r for r, (k, g, i, _) in enumerate(records_layout(records))
            if k == hook and records[g][i] is record]


def _at_hook(hook, doc):
    """The step's call of run_hook at hook ``hook``: f(ptrs, h), inlined where called. The
    hook passed as an int64, not the constant it is here: numba types a constant argument as
    a literal and compiled run_hook once per hook, six functions where one serves."""
    def apply(ptrs, h):
        run_hook(ptrs, h, np.int64(hook))
    apply.__doc__ = doc
    return njit(**STEP, inline="always")(apply)


apply_loads = _at_hook(0, "Add the loads of every load effect.")
apply_flows = _at_hook(1, "The velocity flow of every flow effect for time h.")
apply_accounts = _at_hook(2, "The work of every load effect that keeps one (h: half the kick).")
apply_inertias = _at_hook(3, "The loads as the masses of the effects that add some see them; flows in the kick.")
apply_drift_constraints = _at_hook(4, "Every prescribed pose after a drift of h.")
apply_kick_constraints = _at_hook(5, "Every prescribed velocity after a kick of h.")


class UnresolvedRecord:
    """Stands, in a kernel's cache index read back, for an effect record whose module this
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
    """Let numba read a cache index that names records it cannot import. The index of a
    kernel typed by effect records (slots.pin_record's, a slot wrapper's) holds one signature
    per record type, each naming its class: one unimportable class made every later
    compilation of that kernel fail on loading the index.
    Such an entry now names UnresolvedRecord instead, matches no signature and is skipped."""
    if getattr(caching.pickle, "tolerant", False):
        return
    shim = _pytypes.ModuleType("pickle")
    shim.__dict__.update(pickle.__dict__)
    shim.loads, shim.tolerant = _tolerant_loads, True
    caching.pickle = shim


_tolerate_unresolved_records()
