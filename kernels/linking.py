"""Numba's code generation made to leave out the machine code of the functions that are only
ever linked into others.

Numba compiles every function to machine code as soon as it is compiled, and caches that
code. A kernel called only from other kernels (no Python entry wrapper, no C wrapper:
kernels/compiler.py INNER, kernels/backend.py STEP and PASS) never runs its own: each caller
links its LLVM module in, optimises it with its own and compiles the whole, so the callee's
machine code is made, cached and never executed (towed_cable's cold start in one process:
about 1.5 of its 35 s, for 68 such functions). Here such a function's library is optimised
and kept as LLVM IR only, not handed to the JIT; its cache entry holds that IR (numba's
"bitcode" form) instead of machine code, and is read back the same way, and a caller links
that optimised module. (Numba's callers link the module as the JIT left it: the JIT's code
generation passes change the module they compile, sample_medium's IR grew by a seventh so.
A step's code may thus differ from numba's own, and its results in their last bits; it is the
same whether the callee was compiled in the process or read back from the cache, which a
test compares bit for bit.)

A kernel the step calls through its address (kernels/compose.py: the step's own kernels and
the slot kernels) is declared so (``addressed``) and compiled as numba does; a linked-only
library asked for the address of one of its functions all the same is compiled then
(``promoted`` counts them: a test holds it at zero). Numba's own libraries (its runtime, the
implementations of numpy functions) are left as numba makes them. COSNET_LINK_ONLY=0 in the
environment leaves numba's code generation as it is.
"""

import os

from llvmlite import binding
from numba.core import codegen, typed_passes

_ADDRESSED: set = set()   # the Python functions whose compiled code is called through its address
promoted = [0]            # linked-only libraries compiled after all, in this process


def addressed(func):
    """Declare that the compiled code of the Python function ``func`` is called through its
    address (not only linked into callers): it gets its machine code. Returns ``func``."""
    _ADDRESSED.add(func)
    return func


def _linked_only(library) -> bool:
    return getattr(library, "_cosnet_linked_only", False)


def _defines(module, name) -> bool:
    """Whether LLVM module ``module`` defines a function named ``name``."""
    try:
        return not module.get_function(name).is_declaration
    except NameError:
        return False


def _mark_linked_only_functions():
    """Make numba's lowering create the library of a function compiled without any wrapper
    marked as linked only (numba creates it there when no library is given, as a dispatcher's
    compilation gives none)."""
    lowering = getattr(typed_passes, "BaseNativeLowering", None)
    run = getattr(lowering, "run_pass", None)
    if run is None or getattr(run, "links_only", False):
        return

    def run_pass(self, state):
        flags = state.flags
        if state.library is None and flags.no_cpython_wrapper and flags.no_cfunc_wrapper and not flags.no_compile \
                and state.func_id.func not in _ADDRESSED:
            library = state.targetctx.codegen().create_library(state.func_id.func_qualname)
            library.enable_object_caching()   # (as numba's own creation does)
            library._cosnet_linked_only = isinstance(library, codegen.JITCodeLibrary)
            state.library = library
        return run(self, state)
    run_pass.links_only = True
    lowering.run_pass = run_pass


def _keep_linked_only_libraries_out_of_the_jit():
    """Make a linked-only library's finalisation stop before the JIT: numba's finalisation
    links, optimises and verifies the module (what a caller links), then adds it to the JIT
    and compiles it; the last two are left out. Its cache entry is its optimised module, read
    back as the same kind of library; an environment whose global the JIT does not hold is
    not written (numba would write through a null address: none of these runs)."""
    lib = getattr(codegen, "CPUCodeLibrary", None)
    jit = getattr(codegen, "JITCPUCodegen", None)
    needed = ("_finalize_final_module", "_finalize_dynamic_globals", "_verify_declare_only_symbols",
              "serialize_using_object_code", "serialize_using_bitcode", "_unserialize")
    if lib is None or jit is None or not all(hasattr(lib, n) for n in needed) or not hasattr(jit, "set_env") \
            or getattr(lib._finalize_final_module, "links_only", False):
        return
    finalize_final = lib._finalize_final_module
    serialize = lib.serialize_using_object_code
    unserialize = lib._unserialize.__func__
    set_env = jit.set_env
    pointer_to = codegen.JITCodeLibrary.get_pointer_to_function

    def _finalize_final_module(self):
        if not _linked_only(self):
            return finalize_final(self)
        self._finalize_dynamic_globals()
        self._verify_declare_only_symbols()
        self._finalized = True

    def serialize_using_object_code(self):
        return self.serialize_using_bitcode() if _linked_only(self) else serialize(self)

    def _unserialize(cls, codegen_, state):
        name, kind, data = state
        if kind != "bitcode" or not issubclass(cls, codegen.JITCodeLibrary):
            return unserialize(cls, codegen_, state)
        self = codegen_.create_library(name)
        self._cosnet_linked_only = True
        self._final_module = binding.parse_bitcode(data)
        self._finalize_final_module()
        return self

    def get_pointer_to_function(self, name):
        if _linked_only(self):
            self._ensure_finalized()
            if _defines(self._final_module, name):   # asked for its code after all: compiled as numba does
                self._cosnet_linked_only = False
                promoted[0] += 1
                finalize_final(self)
        return pointer_to(self, name)

    def set_env_where_held(self, env_name, env):
        if self._engine.get_global_value_address(env_name):
            set_env(self, env_name, env)

    _finalize_final_module.links_only = True
    lib._finalize_final_module = _finalize_final_module
    lib.serialize_using_object_code = serialize_using_object_code
    lib._unserialize = classmethod(_unserialize)
    codegen.JITCodeLibrary.get_pointer_to_function = get_pointer_to_function
    jit.set_env = set_env_where_held


if os.environ.get("COSNET_LINK_ONLY", "1") != "0":
    _mark_linked_only_functions()
    _keep_linked_only_libraries_out_of_the_jit()
