"""Serial or parallel loops, chosen at compile time by the type of a marker argument.

A parallel region costs about a microsecond to launch, which would dominate small nets; so
each hot loop exists as a plain loop and as a ``prange`` loop over the same per-item body,
and ``dispatch`` picks one by the marker's type when the step is compiled.

Per-item bodies called inside a ``prange`` loop must not be ``inline="always"``: with numba
0.68 such an inlined body loses its writes through NamedTuple arguments (a plain call, which
LLVM inlines anyway, is correct; tests/test_conservation.py checks 1 vs 2 threads).
"""

import os
from typing import NamedTuple

import numpy as np
from numba import njit, prange
from numba.core import cgutils, types
from numba.extending import intrinsic

from .compiler import INNER, KERNEL, noalias, stable_cache_key

# Threads waiting for work sleep instead of spinning. GNU OpenMP, numba's usual threading
# layer, spins between parallel loops by default; a thread spinning on a core shared with
# another busy process uses up its share of that core, so the scheduler runs it late when
# the next loop's work arrives, and every loop of the step waits for it: a 30,000-element
# rod stepped 10-17 times slower on two threads than on one (docs/threads.md). The pool
# reads this when it starts, at the first parallel loop; a value the user set is kept.
os.environ.setdefault("OMP_WAIT_POLICY", "PASSIVE")

# Options of the serial step kernels. They allocate nothing, so they run without numba's
# reference counting: a call passing the Model/State/Loads records would otherwise cost an
# atomic increment and decrement per array (~45 arrays: about a microsecond per call), and
# any allocation slipping into a step is refused at compile time. STEP kernels are called
# from other kernels only (see rotations.INNER); ENTRY kernels also from Python.
STEP = dict(INNER, _nrt=False)
ENTRY = dict(KERNEL, _nrt=False)

# nodes per task of the threaded node loops
NODE_BLOCK = 256

# SOLO: a threaded loop with a single task runs it in the calling thread, the serial way.
# Waking a sleeping pool (OMP_WAIT_POLICY=PASSIVE, above) costs tens of microseconds per
# loop, more than a small net's whole step: one 20-element snake stepped 20 times slower on
# two threads than on one. A single task gains nothing from the pool.


# Options of the vectorised passes: their array arguments (column views) never overlap, so
# LLVM vectorises them without run-time overlap tests (a few hundred instructions per loop,
# which would dominate lines of ten elements). Never pass one array twice to such a kernel.
PASS = dict(STEP, **noalias())


class Serial(NamedTuple):
    """Run every loop on one thread."""
    threads: int = 1


class Parallel(NamedTuple):
    """Run the hot loops on numba's thread pool."""
    threads: int = 2


class ParallelSplit(NamedTuple):
    """Parallel, for a net with lines so long that each is split across the threads
    (kernels/elastic.py): a type of its own, so that the threaded loops over a line's parts,
    seconds of compilation each, are compiled only for the nets that have such lines."""
    threads: int = 2


def inline_twin(kernel):
    """``kernel`` as numba inlines it where called: typed and compiled once, inside its
    caller, rather than once alone and again there (each compiled function optimises again,
    and compiles to machine code again, the code of every function it calls). A kernel that
    sets fast-math, the error model or reference counting otherwise than the step keeps its
    own compilation (inlined, its code would take the caller's)."""
    options = dict(kernel.targetoptions)
    if any(k in options and options[k] != v for k, v in STEP.items()
           if k in ("fastmath", "error_model", "_nrt")):
        return kernel
    for k in ("nopython", "no_cpython_wrapper", "no_cfunc_wrapper", "inline"):
        options.pop(k, None)
    return njit(**options, inline="always", no_cpython_wrapper=True, no_cfunc_wrapper=True)(kernel.py_func)


def _pick(backend, serial, parallel, split=None):
    cls = backend.instance_class
    if cls is ParallelSplit:
        return parallel if split is None else split
    return parallel if cls is Parallel else serial


def dispatch(serial, parallel, split=None):
    """Return f(backend, *args) calling serial(*args), parallel(*args) or (for ParallelSplit,
    when given) split(*args) by the type of backend, resolved when the caller is compiled
    (njit only). An intrinsic: the chosen call is emitted straight into the caller, with no
    function in between to compile (each compiled function re-optimises the code of
    everything it calls)."""
    @intrinsic
    def call(typingctx, backend, *args):
        fnty = typingctx.resolve_value_type(_pick(backend, serial, parallel, split))
        sig = typingctx.resolve_function_type(fnty, args, {})

        def codegen(context, builder, signature, llargs):
            # the star-args arrive packed in one tuple (the signature says so)
            context.get_function(fnty, sig)(builder, cgutils.unpack_tuple(builder, llargs[1]))
            return context.get_dummy_value()
        return types.none(backend, types.StarArgTuple(args)), codegen
    return call


def each_node(body):
    """Return (serial, parallel) kernels f(n, a, b, c, d) running body(i, a, b, c, d) for i
    in range(n): the serial one with body inlined (a call per node would pass the whole
    model and state records as arguments), the parallel one in blocks of NODE_BLOCK nodes
    (one call per block). body must not be decorated: it is compiled here."""
    inline = njit(**dict(KERNEL, inline="always"))(body)

    @stable_cache_key
    @njit(**STEP)
    def serial(n, a, b, c, d):
        for i in range(n):
            inline(i, a, b, c, d)

    @stable_cache_key
    @njit(**STEP)  # not inline="always": called inside prange (see above)
    def block(i0, i1, a, b, c, d):
        for i in range(i0, i1):
            inline(i, a, b, c, d)

    @stable_cache_key
    @njit(**INNER, parallel=True)
    def parallel(n, a, b, c, d):
        # one task: run it here (see SOLO); its first node an int64 as the tasks' are (numba
        # compiles a callee once more for a literal 0)
        if n <= NODE_BLOCK:
            block(np.int64(0), n, a, b, c, d)
            return
        for k in prange((n + NODE_BLOCK - 1) // NODE_BLOCK):
            block(k * NODE_BLOCK, min((k + 1) * NODE_BLOCK, n), a, b, c, d)
    return serial, parallel
