"""Calls through addresses: how a step calls kernels compiled apart from it.

Numba links a copy of every function a kernel calls into the kernel's own module, and LLVM
optimises the copy again there: a step compiled for a new combination of effects re-optimised
the internal loads, the updates and every effect kernel in it. A step calls them instead
through addresses held in a table (the slots, an (n, 5) int64 array: address, key, process,
record, hook), each kernel compiled once, in a library of its own, whatever steps call it.

Every such kernel takes the same four arguments, so that a call passes four words rather than
the few hundred numba would flatten the model, state and loads records into:
    kernel(core, record, h, order) -> None
core a pointer to the tuple (model, state, loads, backend), stored once by the step
(``step_pointers``) and read by the kernel (``deref``); record a pointer to one effect's
parameter record pinned in a buffer of its own (``pin_record``, read by ``pinned``), or NULL.
The step never sees the effects' records, nor their types: one step, compiled once, serves
every combination of effects (unboxing a combination's records cost its step seconds of
compilation, more than the rest of it). What it calls is checked where it is called: a core
slot's key names the kernel and the types it was compiled for, and a core call whose slot
holds another key raises instead of calling; an effect's slot says which hook of the step it
serves (the step raises where a row of one hook's range says another), its kernel checks that
the step calls it as that hook (``order``) and that its record carries the tag of the record
type it was compiled for; a step checks, once per call, that its slots were bound in the
process running it (``slots_bound_here``).
"""

import hashlib

from llvmlite import ir
from numba import njit
from numba.core import cgutils, types
from numba.extending import intrinsic

from .backend import ENTRY, STEP
from .by_reference import unaliased

SLOT_ADDRESS, SLOT_KEY, SLOT_PROCESS, SLOT_RECORD, SLOT_HOOK = 0, 1, 2, 3, 4   # the columns of a slot
SLOT_COLUMNS = 5
HEADER = 8   # bytes before a pinned record: the tag of its type
_getpid = types.ExternalFunction("getpid", types.int32())


def slot_key(kernel, argtypes) -> int:
    """A 62-bit key naming ``kernel`` (a njit function, by its ``slot_name`` if it has one,
    else by module and name) compiled for ``argtypes`` (numba types)."""
    f = kernel.py_func
    name = getattr(kernel, "slot_name", None) or f"{f.__module__}.{f.__qualname__}"
    text = f"{name}{tuple(argtypes)}"
    return int.from_bytes(hashlib.sha1(text.encode()).digest()[:8], "little") >> 2


def core_type(model, state, loads, backend):
    """The numba type a slot kernel's ``core`` points to."""
    return types.Tuple((model, state, loads, backend))


def slot_argtypes(core, record=None):
    """The argument types of a slot kernel given its core's type and its record's (None: none)."""
    return (types.CPointer(core), types.voidptr if record is None else types.CPointer(record),
            types.float64, types.int64)


def _store(context, builder, ty, value):
    model = context.data_model_manager[ty]
    ptr = cgutils.alloca_once(builder, model.get_data_type())
    builder.store(model.as_data(builder, value), ptr)
    return ptr


def pointers_type(model, state, loads, effects, backend):
    """The numba type of step_pointers' result."""
    return types.Tuple((types.CPointer(core_type(model, state, loads, backend)), types.CPointer(effects)))


@intrinsic
def step_pointers(typingctx, model, state, loads, effects, backend):
    """Return (pointer to (model, state, loads, backend), pointer to effects), the records
    stored once in the caller's frame (valid while the caller runs)."""
    core = core_type(model, state, loads, backend)
    result = pointers_type(model, state, loads, effects, backend)

    def codegen(context, builder, signature, args):
        m, s, ld, effs, b = args
        value = context.make_tuple(builder, core, (m, s, ld, b))
        pointers = (_store(context, builder, core, value), _store(context, builder, effects, effs))
        return context.make_tuple(builder, result, pointers)
    return result(model, state, loads, effects, backend), codegen


@intrinsic
def deref(typingctx, pointer):
    """Return the value ``pointer`` (a CPointer from step_pointers) points to."""
    if not isinstance(pointer, types.CPointer):
        raise TypeError(f"deref: a pointer expected, got {pointer}")

    def codegen(context, builder, signature, args):
        unaliased(builder, args[0])
        return context.data_model_manager[pointer.dtype].load_from_data_pointer(builder, args[0])
    return pointer.dtype(pointer), codegen


def load_table(context, builder, effects, pointer, rows_needed):
    """The slots array of the step table ``pointer`` points to (of type ``effects``: slots,
    hook rows), checked to have ``rows_needed`` rows (else the caller raises)."""
    slots_t = effects.types[0]
    data = cgutils.gep_inbounds(builder, pointer, 0, 0)
    table = context.make_array(slots_t)(
        context, builder, context.data_model_manager[slots_t].load_from_data_pointer(builder, data))
    rows = cgutils.unpack_tuple(builder, table.shape)[0]
    with cgutils.if_unlikely(builder, builder.icmp_signed("<", rows, rows.type(rows_needed))):
        context.call_conv.return_user_exc(builder, RuntimeError, ("kernel slots missing: compose.bind_slots",))
    return table


def call_slot(context, builder, table, row, key, sig, args, what):
    """Emit a call of the slot kernel of signature ``sig`` whose address slot ``row`` holds,
    after checking that its key is ``key``; an error status from it propagates."""
    address = builder.load(cgutils.gep(builder, table.data, SLOT_COLUMNS * row + SLOT_ADDRESS))
    held = builder.load(cgutils.gep(builder, table.data, SLOT_COLUMNS * row + SLOT_KEY))
    with cgutils.if_unlikely(builder, builder.icmp_signed("!=", held, held.type(key))):
        context.call_conv.return_user_exc(builder, RuntimeError,
                                          (f"kernel slot {row} not bound to the {what} kernel of this step",))
    fnty = context.call_conv.get_function_type(sig.return_type, sig.args)
    callee = builder.inttoptr(address, fnty.as_pointer())
    status, _ = context.call_conv.call_function(builder, callee, sig.return_type, sig.args, args)
    with cgutils.if_unlikely(builder, status.is_error):
        context.call_conv.return_status_propagate(builder, status)


@njit(**STEP, inline="always")
def slots_bound_here(effects):
    """Whether every slot of the step records was bound in this process (an address taken in
    another process, which a copied simulation would carry, means nothing here)."""
    slots = effects[0]
    pid = _getpid()
    for k in range(slots.shape[0]):
        if slots[k, SLOT_PROCESS] != pid:
            return False
    return True


def record_tag(record) -> int:
    """A 62-bit tag naming the numba type ``record`` (an effect's parameter record)."""
    return int.from_bytes(hashlib.sha1(str(record).encode()).digest()[:8], "little") >> 2


def record_size(record) -> int:
    """The bytes a record of numba type ``record`` takes pinned: its tag, then its data."""
    from numba.core.registry import cpu_target
    context = cpu_target.target_context
    return HEADER + context.get_abi_sizeof(context.data_model_manager[record].get_data_type())


_I64 = ir.IntType(64)


def _at_data(builder, base):
    return builder.gep(base, [cgutils.intp_t(HEADER)])


@intrinsic
def pin(typingctx, record, out):
    """Store ``record`` into ``out`` (a uint8 array of record_size bytes): its type's tag, then
    its data as a slot kernel reads it (``pinned``)."""
    tag = record_tag(record)

    def codegen(context, builder, signature, args):
        model = context.data_model_manager[record]
        size = record_size(record)
        array = context.make_array(out)(context, builder, args[1])
        with cgutils.if_unlikely(builder, builder.icmp_signed("<", array.nitems, array.nitems.type(size))):
            context.call_conv.return_user_exc(builder, RuntimeError, ("pin: buffer smaller than the record",))
        base = builder.bitcast(array.data, cgutils.voidptr_t)
        builder.store(_I64(tag), builder.bitcast(base, _I64.as_pointer()))
        data = builder.bitcast(_at_data(builder, base), model.get_data_type().as_pointer())
        builder.store(model.as_data(builder, args[0]), data)
        return context.get_dummy_value()
    return types.none(record, out), codegen


@njit(**ENTRY)
def pin_record(record, out):
    """Update out (uint8, record_size bytes) given an effect's record: its tag and its data,
    where the slot kernels of its effect read it."""
    pin(record, out)


@intrinsic
def pinned(typingctx, pointer):
    """Return the record a pinned buffer holds (``pointer``: a CPointer to the record's type),
    raising if the buffer carries another type's tag."""
    if not isinstance(pointer, types.CPointer):
        raise TypeError(f"pinned: a pointer expected, got {pointer}")
    record = pointer.dtype
    tag = record_tag(record)

    def codegen(context, builder, signature, args):
        unaliased(builder, args[0])
        base = builder.bitcast(args[0], cgutils.voidptr_t)
        held = builder.load(builder.bitcast(base, _I64.as_pointer()))
        with cgutils.if_unlikely(builder, builder.icmp_signed("!=", held, _I64(tag))):
            context.call_conv.return_user_exc(builder, RuntimeError,
                                              (f"kernel slot given a record other than its {record}",))
        model = context.data_model_manager[record]
        data = builder.bitcast(_at_data(builder, base), model.get_data_type().as_pointer())
        return model.load_from_data_pointer(builder, data)
    return record(pointer), codegen


@intrinsic
def call_effect(typingctx, core, address, record, h, hook):
    """Call the effect's slot kernel at ``address`` (int64) with (core, the pinned record at
    ``record`` (int64), h, hook); an error status from it propagates."""
    args = (core, types.voidptr, types.float64, types.int64)
    sig = types.none(*args)

    def codegen(context, builder, signature, llargs):
        p_core, addr, rec, step, k = llargs
        fnty = context.call_conv.get_function_type(sig.return_type, sig.args)
        callee = builder.inttoptr(addr, fnty.as_pointer())
        values = (p_core, builder.inttoptr(rec, cgutils.voidptr_t), context.cast(builder, step, h, types.float64),
                  context.cast(builder, k, hook, types.int64))
        status, _ = context.call_conv.call_function(builder, callee, sig.return_type, sig.args, values)
        with cgutils.if_unlikely(builder, status.is_error):
            context.call_conv.return_status_propagate(builder, status)
        return context.get_dummy_value()
    return types.none(core, address, record, h, hook), codegen
