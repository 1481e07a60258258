"""Numba's typing made to remember, within a process, what it has already worked out: the
options in force, the signature of a builtin operation for given argument types, the IR of a
function inlined at many call sites (copied once per site, not twice). Numba's own Python
(typing, lowering) is about half of a cold start's compiling (bench/startup.py's "numba +
LLVM"), and numba redoes these at every call site of every kernel. Each adjustment leaves the
compiled code as numba makes it (a test compares runs bit for bit) and falls back to numba's
own where numba is built otherwise. COSNET_TYPING_MEMO=0 in the environment leaves numba's
typing as it is (a test compares the two).
"""

import copy
import os
import types

from numba.core import targetconfig


def _quick_option_values():
    """Make numba's compile options (TargetConfig) cheap to compare and hash. Typing looks up
    every overload in a cache keyed by the options in force; each lookup built a dict of all
    ~40 options through their properties, twice (hash, then equality), tens of thousands of
    times per step compiled: about a twentieth of a cold start. The same dict is now the
    class's defaults updated with the options set; equal values, equal hashes."""
    cls = getattr(targetconfig, "TargetConfig", None)
    values = getattr(cls, "values", None)
    if values is None or getattr(values, "quick", False):
        return

    def quick_values(self):
        kind = type(self)
        defaults = kind.__dict__.get("_defaults")
        if defaults is None:
            defaults = {k: o.default for k, o in kind.options.items()}
            kind._defaults = defaults
        out = dict(defaults)
        out.update(self._values)
        return out
    quick_values.quick = True
    cls.values = quick_values


def _remember_builtin_signatures():
    """Make the typing of a builtin function (an operator, a math or numpy function) for given
    argument types happen once per process. Numba tries the function's templates in turn at
    every call site, recording why each that does not match fails: ``a * b`` on two floats
    walks dozens of them, and a step's kernels hold thousands of such sites (the bridge's
    cold start: 7,200 lookups for 375 distinct signatures, a tenth of its compilation). The
    key holds the options in force (a copy: numba's inliner changes them in place), as
    numba's own cache of overload implementations does, so a kernel compiled without
    fast-math never takes an implementation compiled with it. Failures are not remembered:
    they raise, and numba tries again as before."""
    from numba.core.types import functions
    cls = getattr(functions, "Function", None)
    resolve = getattr(getattr(functions, "BaseFunction", None), "get_call_type", None)
    if cls is None or resolve is None or getattr(resolve, "remembers", False):
        return
    found: dict = {}

    def get_call_type(self, context, args, kws):
        if type(self) is not cls:   # a bound method, a dispatcher: numba's own path
            return resolve(self, context, args, kws)
        flags = targetconfig.ConfigStack.top_or_none()
        try:
            key = (self, context, args, tuple(sorted(kws.items())), flags)
            sig = found.get(key)
        except TypeError:   # an unhashable argument type
            return resolve(self, context, args, kws)
        if sig is None:
            sig = resolve(self, context, args, kws)
            if sig is not None:
                found[key[:-1] + (None if flags is None else flags.copy(),)] = sig
        return sig
    get_call_type.remembers = True
    functions.BaseFunction.get_call_type = get_call_type


def _reuse_inlined_bodies():
    """Make the IR of a function inlined by numba (``inline="always"``: the loop bodies and
    small helpers of the kernels) built once per process and options, not once per call
    site. Numba runs the untyped half of its pipeline on the inlined function at every site
    (``uint`` alone is inlined 78 times into the mooring case's kernels: 3.5 of its 45 s of
    compilation went to these passes). The inliner copies the IR before changing it, so one
    copy serves every site; each site's copy takes a fresh identity, as numba's gives it, so
    the inlined variables' names stay distinct."""
    from numba.core import inline_closurecall
    cls = getattr(inline_closurecall, "InlineWorker", None)
    inline = getattr(cls, "inline_function", None)
    if inline is None or not hasattr(cls, "inline_ir") or getattr(inline, "reused", False):
        return
    bodies: dict = {}

    def inline_function(self, caller_ir, block, i, function, arg_typs=None):
        if self.flags is None:
            return inline(self, caller_ir, block, i, function, arg_typs=arg_typs)
        self.flags.enable_ssa = False   # as numba's run of the passes leaves the caller's options
        try:
            key = (function, tuple(sorted((self.locals or {}).items())), self.flags)
            body = bodies.get(key)
        except TypeError:
            return inline(self, caller_ir, block, i, function, arg_typs=arg_typs)
        if body is None:
            body = self.run_untyped_passes(function)
            bodies[key[:-1] + (self.flags.copy(),)] = body
        site = copy.copy(body)
        site.func_id = body.func_id.derive()
        return self.inline_ir(caller_ir, block, i, site, function.__code__.co_freevars, arg_typs=arg_typs)
    inline_function.reused = True
    cls.inline_function = inline_function


def _inliner_callers_discard_the_copy() -> bool:
    """Whether every call of numba's inliner (its typed and untyped passes) keeps only the new
    blocks of its result, not the unchanged copy of the inlined IR it hands back first."""
    import re
    try:
        from numba.core import typed_passes, untyped_passes
        texts = []
        for module in (typed_passes, untyped_passes):
            with open(module.__file__, encoding="utf-8") as f:
                texts.append(f.read())
    except (ImportError, OSError, TypeError):
        return False
    for text in texts:
        for call in re.finditer(r"\.inline_(?:ir|function)\(", text):
            # "_, _, _, new_blocks = inline_worker.inline_ir(", the call maybe on a line of its own
            before = text[max(0, call.start() - 160):call.start()]
            if not before.endswith("inline_worker") \
                    or not before[:-len("inline_worker")].rstrip(" \n\\").endswith("_, _, _, new_blocks ="):
                return False
    return True


def _copy_inlined_ir_once():
    """Make numba's inliner deep-copy an inlined function's IR once per site, not twice. Its
    ``inline_ir`` copies the IR it is given, changes the copy and splices it in, and copies
    that copy again to hand back unchanged, a copy both of its callers discard (numba 0.68:
    half of the inliner's copying, a few percent of a cold start). Within the inliner, a block
    that is not one of the given IR's own is handed back as it is: the first copy, made from
    the given IR's blocks, is made as before; only the second, made from the first's, is
    left out. And the first is one copy of the function, not one per block: numba copies each
    block apart, and with each the scope all the function's blocks share, every variable of
    the function once per block (the blocks' copies then held equal scopes, which the
    inliner compared in full to find there was one). With one memo for the call, the copied
    blocks share one copied scope and variable, as the given ones do (towed_cable's
    compilation in one process: the inliner's copying 2.3 -> 0.7 s)."""
    from numba.core import inline_closurecall
    cls = getattr(inline_closurecall, "InlineWorker", None)
    inline_ir = getattr(cls, "inline_ir", None)
    module_copy = getattr(inline_closurecall, "copy", None)
    if inline_ir is None or module_copy is not copy or getattr(inline_ir, "copies_once", False) \
            or not _inliner_callers_discard_the_copy():
        return
    given: set = set()   # ids of the blocks of the IR being inlined (inline_ir is not re-entered)
    shared: dict = {}    # the deep copy's memo while it copies them

    def deepcopy(x, memo=None):
        if given and id(x) not in given:
            return x
        return copy.deepcopy(x, shared if memo is None and given else memo)

    def copies_once(self, caller_ir, block, i, callee_ir, callee_freevars, arg_typs=None):
        given.update(id(b) for b in callee_ir.blocks.values())
        try:
            return inline_ir(self, caller_ir, block, i, callee_ir, callee_freevars, arg_typs=arg_typs)
        finally:
            given.clear()
            shared.clear()
    copies_once.copies_once = True
    cls.inline_ir = copies_once
    inline_closurecall.copy = types.SimpleNamespace(deepcopy=deepcopy, copy=copy.copy)


_quick_option_values()
if os.environ.get("COSNET_TYPING_MEMO", "1") != "0":
    _remember_builtin_signatures()
    _reuse_inlined_bodies()
    _copy_inlined_ir_once()
