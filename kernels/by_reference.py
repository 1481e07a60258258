"""Large records passed to a compiled function by reference, not flattened into its arguments.

Numba passes a tuple to a function it calls as its leaves, one argument each: the fluid's
record of 47 arrays is 320 arguments, and a kernel taking it with the model and the state
takes 650. Every call unpacked them and every function packed them again, an instruction
each, and each instruction's text names the whole record's type: towed_cable's libraries
held 50 MB of LLVM IR, which numba built in Python and printed and LLVM parsed. Here a record
of cosnet's (a NamedTuple class of its modules) of BIG leaves or more is passed as one
pointer to its value, and the function called loads it. A pointer to a copy made at the call
costs LLVM as much as the unpacking spared (the copy's stores, hundreds at every call site,
before inlining removes them), so a call passes, where it can, the memory its value was
loaded from: the caller's own argument, a pinned record, the step's core tuple
(kernels/slots.py), or a record within one of those. A record is a value nothing writes once
stored, so that memory holds it while the call runs. The value is traced to such a load
through the variable slots numba keeps (only a variable assigned once in the function:
numba's definitions) and through the tuples it builds and takes apart; any other value is
copied. Smaller records (the state, the loads, a body's shape, which a contact loop builds
for each target) stay flattened: a copy in a loop cost more than their arguments; so does a
record whose class says ``by_value`` (a rigid body's contacts: its loop read the record
again after each contact's writes).

After each function is lowered, every call passing memory is checked (the variable it came
through stored once, the pointer defined where the call is reached only through it): a call
that is not raises at compile time. A function taking records so is given LLVM's inlining
threshold raised by what their flattened arguments counted for (LLVM counts each argument a
call passes as a saving of inlining it), so that LLVM inlines what it inlined before; the
record pointers of the slot kernels are noalias (unaliased), so that what is loaded through
them may be kept across the stores into arrays.

The arithmetic is the same, but LLVM may inline and combine it otherwise than before, so a
step's results may differ from before in their last bits (they are the same cold and warm:
tests/test_reproducible.py); the calling convention changes, and the kernels' cache directory
is keyed by this file as by every kernel's source (compiler._cache_options)."""

from llvmlite import ir
from numba.core import cgutils, lowering, types
from numba.core.datamodel import default_manager, models

BIG = 100            # leaves (arguments numba would flatten a record into) of a record passed by reference
INLINE_BASE = 750    # LLVM's inlining threshold at -O3 with its largest bonuses (one block, vector code)
ARGUMENT_COST = 5    # what LLVM counts a call's argument as (InlineConstants::InstrCost)


def leaves(fe_type) -> int:
    """How many arguments numba flattens a value of ``fe_type`` into."""
    if isinstance(fe_type, types.BaseTuple):
        return sum(leaves(t) for t in fe_type)
    if isinstance(fe_type, types.Array):
        return 5 + 2 * fe_type.ndim   # meminfo, parent, size, itemsize, data, shape, strides
    return 1


def by_reference(fe_type) -> bool:
    """Whether ``fe_type`` is one of cosnet's records passed by reference: of BIG leaves or
    more, and not declared ``by_value`` by its class."""
    cls = getattr(fe_type, "instance_class", None)
    return (cls is not None and getattr(cls, "__module__", "").startswith("cosnet.")
            and not getattr(cls, "by_value", False) and leaves(fe_type) >= BIG)


def _notes(function) -> dict:
    """What lowering ``function`` found: "loaded" {id: (value, pointer)}, "slots" {id: (slot,
    value)} of variables assigned once, "passed" [(slots, pointer, block)]."""
    notes = getattr(function, "_cosnet_records", None)
    if notes is None:
        notes = function._cosnet_records = {"loaded": {}, "slots": {}, "passed": []}
    return notes


def _held_by(notes, value, slots, depth=0):
    """(pointer, path) such that the memory at pointer, indexed by path, holds ``value``
    unchanged, or None; ``slots`` collects the variable slots the trace went through."""
    if depth > 16:
        return None
    hit = notes["loaded"].get(id(value))
    if hit is not None and hit[0] is value:
        return hit[1], []
    if isinstance(value, ir.LoadInstr):
        held = notes["slots"].get(id(value.operands[0]))
        if held is None or held[0] is not value.operands[0]:
            return None
        slots.append(held[0])
        return _held_by(notes, held[1], slots, depth + 1)
    if isinstance(value, ir.ExtractValue) and len(value.indices) == 1:
        agg = value.aggregate
        while isinstance(agg, ir.InsertValue):   # a tuple numba built: the member at that index
            if list(agg.indices) == list(value.indices):
                return _held_by(notes, agg.value, slots, depth + 1)
            agg = agg.aggregate
        whole = _held_by(notes, agg, slots, depth + 1)   # a member of a record held in memory
        if whole is not None:
            return whole[0], whole[1] + list(value.indices)
    return None


def _stored(function) -> dict:
    """{id(pointer): [values]} of what ``function`` stores through each pointer, numba's
    zero-filling of a variable's slot (a constant) left out."""
    stores: dict = {}
    for block in function.blocks:
        for ins in block.instructions:
            if isinstance(ins, ir.StoreInstr) and not isinstance(ins.operands[0], ir.Constant):
                stores.setdefault(id(ins.operands[1]), []).append(ins.operands[0])
    return stores


def unaliased(builder, pointer):
    """Mark noalias the argument of the function being built that ``pointer`` (a value of it,
    directly or through a variable slot) is: memory reached through it is only read, and
    nothing else the function reaches writes it (the step's core tuple, a pinned record:
    kernels/slots.py), so LLVM may keep what it loads from there across the function's stores
    into arrays."""
    value = pointer
    if isinstance(value, ir.LoadInstr) and isinstance(value.operands[0], ir.AllocaInstr):
        stored = _stored(builder.function).get(id(value.operands[0]), [])
        value = stored[0] if len(stored) == 1 else None
    if isinstance(value, ir.Argument) and isinstance(value.type, ir.PointerType):
        value.add_attribute("noalias")


class _ByReference:
    def get_argument_type(self):
        return self.get_value_type().as_pointer()

    def as_argument(self, builder, value):
        notes, slots = _notes(builder.function), []
        held = _held_by(notes, value, slots)
        if held is not None:
            base, path = held
            pointer = cgutils.gep_inbounds(builder, base, 0, *path) if path else base
            if pointer.type == self.get_argument_type():
                notes["passed"].append((slots, base, builder.block))
                return pointer
        pointer = cgutils.alloca_once(builder, self.get_value_type())
        builder.store(value, pointer)
        return pointer

    def from_argument(self, builder, value):
        value.add_attribute("noalias")   # (read only, and no other argument reaches it but to read it)
        out = builder.load(value)
        _notes(builder.function)["loaded"][id(out)] = (out, value)
        return out

    def load_from_data_pointer(self, builder, ptr, align=None):
        if self.get_data_type() != self.get_value_type():
            return super().load_from_data_pointer(builder, ptr, align)
        out = builder.load(ptr, align=align)
        _notes(builder.function)["loaded"][id(out)] = (out, ptr)
        return out


class RecordByReference(_ByReference, models.TupleModel):
    pass


class UniRecordByReference(_ByReference, models.UniTupleModel):
    pass


def _successors(block):
    term = block.terminator
    if term is None:
        return []
    targets = [op for op in term.operands if isinstance(op, ir.Block)]
    if isinstance(term, ir.SwitchInstr):   # (its cases are not among its operands)
        targets += [term.default] + [b for _, b in term.cases]
    return targets


def _dominators(function) -> dict:
    """{block: the set of blocks dominating it} of ``function`` (its first block the entry)."""
    blocks = function.blocks
    preds = {b: [] for b in blocks}
    for b in blocks:
        for s in _successors(b):
            preds[s].append(b)
    dom = {b: set(blocks) for b in blocks}
    dom[blocks[0]] = {blocks[0]}
    changed = True
    while changed:
        changed = False
        for b in blocks[1:]:
            new = set.intersection(*(dom[p] for p in preds[b])) if preds[b] else set()
            new.add(b)
            if new != dom[b]:
                dom[b], changed = new, True
    return dom


def check_passed(function):
    """Raise if a call in ``function`` passed a record's memory it may not hold at the call:
    a variable traced through stored more than once, or the pointer not dominating the call."""
    notes = getattr(function, "_cosnet_records", None)
    if not notes or not notes["passed"]:
        return
    stores = _stored(function)
    dom = None
    for slots, pointer, block in notes["passed"]:
        if any(len(stores.get(id(s), [])) != 1 for s in slots):
            raise RuntimeError(f"{function.name}: a record variable passed by reference is stored more than once")
        if isinstance(pointer, ir.Instruction) and pointer.parent is not block:
            dom = dom or _dominators(function)
            if pointer.parent not in dom[block]:
                raise RuntimeError(f"{function.name}: a record passed by reference from where it may be undefined")


class _Attributes(ir.values.FunctionAttributes):
    """A function's attributes with LLVM's inlining threshold for it."""

    threshold = 0

    @classmethod
    def extend(cls, function, threshold):
        attrs = cls()
        for name in function.attributes:
            attrs.add(name)
        attrs.alignstack, attrs.personality = function.attributes.alignstack, function.attributes.personality
        attrs.threshold = threshold
        function.attributes = attrs

    def __bool__(self):   # (llvmlite prints a function's attributes only where the set is not empty)
        return True

    def _to_list(self, ret_type):
        return super()._to_list(ret_type) + [f'"function-inline-threshold"="{self.threshold}"']


def _install():
    storevar, post_lower = lowering.Lower.storevar, lowering.Lower.post_lower

    def storevar_noting(self, value, name, argidx=None):
        storevar(self, value, name, argidx)
        if (by_reference(self.typeof(name)) and name in self.varmap
                and len(self.func_ir._definitions.get(name, ())) == 1):
            slot = self.varmap[name]
            _notes(self.function)["slots"][id(slot)] = (slot, value)

    def post_lower_checking(self):
        post_lower(self)
        check_passed(self.function)
        spared = sum(leaves(t) - 1 for t in self.fndesc.argtypes if by_reference(t))
        if spared:
            _Attributes.extend(self.function, INLINE_BASE + ARGUMENT_COST * spared)

    lowering.Lower.storevar = storevar_noting
    lowering.Lower.post_lower = post_lower_checking

    def chooser(mine, theirs):
        return lambda dmm, fe_type: (mine if by_reference(fe_type) else theirs)(dmm, fe_type)
    default_manager.register(types.NamedTuple, chooser(RecordByReference, default_manager._handlers[types.NamedTuple]))
    default_manager.register(types.NamedUniTuple,
                             chooser(UniRecordByReference, default_manager._handlers[types.NamedUniTuple]))


_install()
