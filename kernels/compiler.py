"""How cosnet's kernels are compiled and cached: the options every kernel starts from, and the
adjustments to numba that make its on-disk cache safe to share (between processes compiling at
once, between a cold and a warm start, between builds with other options)."""

import contextlib
import hashlib
import os
import pickle
import time

import numba
from llvmlite import binding as llvm
from numba.core import codegen

from . import typing_memo  # noqa: F401  (numba's typing remembers what it found)
from . import by_reference  # noqa: F401  (large records passed as one pointer, not hundreds of arguments)
from . import linking  # noqa: F401  (no machine code for kernels only ever linked into others)
from . import parfor_loads  # noqa: F401  (a threaded loop's call reads each record once)


def _use_own_copies():
    """Make every compiled library call its own copies of the functions it links in.

    Numba links a callee into each caller's module as a ``linkonce_odr`` copy, and the copy is
    optimised again with its caller (inlined, or re-vectorised with fast-math: other
    instructions, other rounding). The JIT then resolves such a weak symbol to the first
    definition it has seen: in a process that compiled the callee first, that is the callee's
    own library; in one that loads the caller from the cache, the caller's copy. The same step
    thus ran different code cold and warm (and in a run resumed after a kill mid-compilation),
    and its results differed in the last bits. Internal copies are never shared, so a
    library's code is the same whether it was compiled here or loaded. (Numba's runtime
    helpers NRT_* keep their linkage: its reference-count pruning finds them by name.)"""
    cls = getattr(codegen, "CPUCodeLibrary", None)
    optimize = getattr(cls, "_optimize_final_module", None)
    if optimize is None or getattr(optimize, "own_copies", False):
        return   # already done, or a numba built otherwise: results stay correct, only not
                 # bit-identical between a cold and a warm cache (tests/test_reproducible.py)

    def optimize_own_copies(self):
        for fn in self._final_module.functions:
            if (not fn.is_declaration and fn.linkage == llvm.Linkage.linkonce_odr
                    and not fn.name.startswith("NRT_")):
                fn.linkage = llvm.Linkage.internal
        optimize(self)
    optimize_own_copies.own_copies = True
    cls._optimize_final_module = optimize_own_copies


_use_own_copies()


def _vectorise_remainders():
    """Have LLVM run a vectorised loop's remainder in vectors of 4 as well (epilogue
    vectorisation, which it does by default only behind a main loop of 16 lanes or more). A
    loop that LLVM vectorises by 8 without interleaving otherwise runs up to 7 iterations one
    at a time, and a line of a few elements (a net's twine, a chain's links) is all remainder:
    there the scalar square roots and divisions wait on each other (the fluid's drag over a
    line of 4 interior vertices took 41 ns so, 16 with it). An option of LLVM's, so
    process-wide: whatever numba compiles in a process that imports cosnet is vectorised so."""
    llvm.set_option("", "-epilogue-vectorization-force-VF=4")


_vectorise_remainders()


def _lock_cache_saves():
    """Make numba's on-disk cache safe for processes saving into one directory at once
    (the test workers, a sweep's workers, two runs started together).

    Numba saves an overload by reading the function's index, picking the first data-file
    name that index does not use, and writing both back. Two processes doing so at once
    each start from their own copy of the index: one's entry is dropped, or both pick one
    file name for different overloads, and the index can then send one signature to the
    other's code. Each save here holds an exclusive lock on a file beside the index from
    reading it to writing the data, so saves follow one another; loads need no lock (the
    index and data files are replaced atomically, and an index naming data not yet written
    reads as a cache miss). Where fcntl is missing (Windows) saves stay as numba makes them:
    give parallel processes separate NUMBA_CACHE_DIRs there."""
    try:
        import fcntl
    except ImportError:
        return
    from numba.core import caching
    cls = getattr(caching, "IndexDataCacheFile", None)
    save = getattr(cls, "save", None)
    if save is None or getattr(save, "locked", False):
        return

    def locked_save(self, key, data):
        with open(self._index_path + ".lock", "ab") as lock:
            fcntl.flock(lock, fcntl.LOCK_EX)   # released as the file closes, or the process dies
            save(self, key, data)
    locked_save.locked = True
    cls.save = locked_save


_lock_cache_saves()


def _defer_blas_check():
    """Have numba find scipy's BLAS without importing scipy.linalg until something uses it.

    The first kernel a process compiles or loads from the cache makes numba load its numpy
    support, whose module numba.np.arraymath checks at import that BLAS is there by importing
    scipy.linalg (and all it imports), a part of every start, warm ones included, for
    routines no cosnet kernel calls. The check at that import now only finds
    scipy.linalg's module; numba's own checks where BLAS is used (numba.np.linalg's
    ensure_blas, called when a dot or solve is compiled: scipy.linalg imported, its integer
    width checked) are left as they are."""
    import importlib.util
    import sys
    if "numba.np.arraymath" in sys.modules:
        return
    from numba.np import linalg
    check = getattr(linalg, "ensure_blas", None)
    if check is None:
        return

    def find_blas():
        if importlib.util.find_spec("scipy.linalg") is None:
            raise ImportError("scipy 0.16+ is required for linear algebra")
    linalg.ensure_blas = find_blas
    try:
        from numba.np import arraymath
    finally:
        linalg.ensure_blas = check
    arraymath.ensure_blas = check


_defer_blas_check()


class _PlainWrapperLibrary:
    """A code library whose added modules' functions LLVM leaves unoptimised (optnone)."""

    def __init__(self, library):
        self.library = library

    def add_ir_module(self, module):
        for fn in module.functions:
            if not fn.is_declaration:
                fn.attributes.add("noinline")   # (optnone requires it)
                fn.attributes.add("optnone")
        self.library.add_ir_module(module)

    def __getattr__(self, name):
        return getattr(self.library, name)


def _plain_python_wrappers():
    """Have LLVM compile the wrapper through which Python calls a kernel as it is written, not
    optimised. The wrapper unboxes each argument from its Python object: for a kernel taking
    an effect's record, the model and the state, a hundred arrays, a long straight run of
    checks that LLVM took most of a second to optimise and compile (the kernel itself, which
    the wrapper calls, is optimised as before). Unoptimised it compiles in half the time and
    costs a microsecond or two more per call from Python, which the kernels called so (the
    step once per chunk of steps, the energies once per frame) do not notice. Numba's, so
    process-wide: every function numba compiles in a process that imports cosnet has such a
    wrapper."""
    from numba.core import cpu
    cls = getattr(cpu, "CPUContext", None)
    create = getattr(cls, "create_cpython_wrapper", None)
    if create is None or getattr(create, "plain", False):
        return

    def create_plain(self, library, *args, **kwargs):
        return create(self, _PlainWrapperLibrary(library), *args, **kwargs)
    create_plain.plain = True
    cls.create_cpython_wrapper = create_plain


_plain_python_wrappers()


# how long a compilation waits for another process compiling the same kernel before it
# compiles the kernel itself (the other may be stopped, not dead: a dead one frees the lock)
COMPILE_WAIT = 600.0
_held: dict = {}   # lock path -> [open lock file, depth] of the compilations in this process
# the event fired around a wait for another process's compilation (data: the kernel's
# qualified name, module.function), for a progress display to say why nothing seems to happen
WAIT_EVENT = "cosnet:compile-wait"


def compile_lock_path(dispatcher, sig):
    """Return the lock file that stands for compiling ``dispatcher`` for ``sig`` (a tuple of
    numba types) into the on-disk cache, or None when nothing is to be waited for: the
    function is not cached, or the signature is compiled in this process or saved already."""
    from numba.core import caching, sigutils
    cache = getattr(dispatcher, "_cache", None)
    if not isinstance(cache, caching.Cache):
        return None
    args, _ = sigutils.normalize_signature(sig)
    if tuple(args) in dispatcher.overloads:
        return None
    try:
        key = cache._index_key(sig, dispatcher.targetctx.codegen())
        if key in cache._cache_file._load_index():
            return None
        index = cache._cache_file._index_path
    except Exception:   # another numba's internals: compile as numba would
        return None
    return f"{index}.{hashlib.sha256(repr(key).encode()).hexdigest()[:16]}.compiling"


@contextlib.contextmanager
def compiling(path, kernel: str = ""):
    """Hold the lock ``path`` (from compile_lock_path) while compiling ``kernel`` (its name, for
    WAIT_EVENT): another process asking for the same kernel waits (at most COMPILE_WAIT s) and
    then loads what this one saved. A compilation nested in one of the same path in this
    process does not wait for itself."""
    entry = _held.get(path)
    if entry is None:
        try:
            f = open(path, "ab")
        except OSError:   # a cache folder we cannot write: compile unlocked, as numba would
            yield
            return
        if not _take(f):
            _wait_for(f, kernel)
        entry = _held[path] = [f, 0]
    entry[1] += 1
    try:
        yield
    finally:
        entry[1] -= 1
        if entry[1] == 0:
            del _held[path]
            entry[0].close()   # frees the lock


def compiling_elsewhere(dispatcher, sig) -> bool:
    """Whether another process is compiling ``dispatcher`` for ``sig`` into the cache right
    now (holds its lock, compiling): a caller with other work may do that first, then load
    this one rather than wait for it."""
    path = compile_lock_path(dispatcher, sig)
    return path is not None and _held_elsewhere(path)


def _held_elsewhere(path) -> bool:
    """Whether another process holds the compile lock ``path`` (one this process holds is not
    another's)."""
    if path in _held:
        return False
    try:
        f = open(path, "ab")
    except OSError:   # a cache folder we cannot write: nobody compiles into it
        return False
    with f:   # a free lock taken here is released as the file closes
        return not _take(f)


def _take(f) -> bool:
    """Whether this process got the exclusive lock on the open file ``f`` (without waiting);
    where fcntl is missing (Windows) there are no locks, and nothing to wait for."""
    try:
        import fcntl
    except ImportError:
        return True
    try:
        fcntl.flock(f, fcntl.LOCK_EX | fcntl.LOCK_NB)
    except OSError:
        return False
    return True


def _wait_for(f, kernel):
    from numba.core import event
    deadline = time.monotonic() + COMPILE_WAIT
    with event.trigger_event(WAIT_EVENT, data=kernel):
        while time.monotonic() < deadline:
            time.sleep(0.02)
            if _take(f):
                return


def _lock_compilations():
    """Make a process that needs a kernel another process is compiling into the same cache
    wait for it and load the result, instead of compiling it a second time (two test workers,
    a sweep's workers, a run started beside another). Numba looks in its cache, and on a miss
    compiles: two processes starting together thus both paid the whole compilation. Now a
    miss takes a lock per kernel and signature (compiling) and looks again once it holds it.
    Locks are taken callers before callees, along the call graph, so two processes never wait
    for each other; a process that dies frees its locks. Where fcntl is missing (Windows)
    compilations stay as numba makes them."""
    try:
        import fcntl  # noqa: F401
    except ImportError:
        return
    from numba.core import dispatcher
    cls = dispatcher.Dispatcher
    compile_ = cls.compile
    if getattr(compile_, "locked", False):
        return

    def locked_compile(self, sig):
        path = compile_lock_path(self, sig)
        if path is None:
            return compile_(self, sig)
        py = self.py_func
        with compiling(path, f"{py.__module__}.{py.__qualname__}"):
            return compile_(self, sig)   # which loads what another process saved meanwhile
    locked_compile.locked = True
    cls.compile = locked_compile


_lock_compilations()


def noalias() -> dict:
    """Return the option that marks a kernel's array arguments as not overlapping (numba's
    ``noalias`` compiler flag, which its parallel gufuncs use; exposed here as a decorator
    option), or nothing where this numba lacks the flag: the loops stay correct, but LLVM
    then vectorises them only where a few run-time overlap tests suffice."""
    from numba.core import compiler, cpu, options
    if not hasattr(compiler.Flags, "noalias"):
        return {}
    if not hasattr(cpu.CPUTargetOptions, "noalias"):
        cpu.CPUTargetOptions.noalias = options.TargetOptions.Mapping("noalias")
    return {"noalias": True}


def _describe(value):
    """Return a description of a closure cell that every process gives alike: a jitted
    function by its module, name, bytecode and own cells; anything else as it is."""
    py = getattr(value, "py_func", value)
    code = getattr(py, "__code__", None)
    if code is None:
        return value
    cells = tuple(_describe(c.cell_contents) for c in (py.__closure__ or ()))
    return (py.__module__, py.__qualname__, hashlib.sha256(code.co_code).hexdigest(), cells,
            getattr(py, "cosnet_options", None))   # (kernels/specialise.py: its compile-time options)


def _reach(kernel) -> tuple:
    """(bytes of Python bytecode, cached dispatchers) of ``kernel`` (a njit function) and of
    every function it reaches, each counted once: through its names, its closure cells and
    the typers of the intrinsics it calls, into cosnet's modules and the kernel's own. Read
    from the code, before anything is compiled; remembered per kernel."""
    import types as pytypes

    from numba.core import caching
    from numba.core.extending import _Intrinsic
    held = _REACHED.get(kernel)
    if held is not None:
        return held
    root = kernel.py_func.__module__ if isinstance(kernel, numba.core.dispatcher.Dispatcher) else None
    seen: set = set()
    total, dispatchers, stack = 0, [], [kernel]
    while stack:
        obj = stack.pop()
        if isinstance(obj, numba.core.dispatcher.Dispatcher):
            if id(obj) not in seen and isinstance(getattr(obj, "_cache", None), caching.Cache):
                seen.add(id(obj))
                dispatchers.append(obj)
            obj = obj.py_func
        elif isinstance(obj, _Intrinsic):
            obj = obj._defn
        elif isinstance(obj, (tuple, list)):
            stack.extend(obj)
            continue
        if (not isinstance(obj, pytypes.FunctionType) or id(obj) in seen
                or not (obj.__module__.startswith("cosnet") or obj.__module__ == root)):
            continue
        seen.add(id(obj))
        for cell in obj.__closure__ or ():
            try:
                stack.append(cell.cell_contents)
            except ValueError:   # a cell not yet filled
                pass
        codes = [obj.__code__]
        while codes:
            code = codes.pop()
            size, names = _live_code(code, obj.__globals__)
            total += size
            codes.extend(c for c in code.co_consts if isinstance(c, pytypes.CodeType))
            stack.extend(obj.__globals__[n] for n in names if n in obj.__globals__)
    held = _REACHED[kernel] = (total, dispatchers)
    return held


def _live_code(code, space) -> tuple:
    """(bytes, global names) of ``code`` outside the branches numba prunes before typing:
    those a module's boolean constant (space: its globals; a variant's options,
    kernels/specialise.py) never enters, ``if OPTION:`` with OPTION false or ``if not
    OPTION:`` with it true. (The fluid's flow reaches the waves' passes, which a still
    medium's variant never compiles: counted, they made it weigh more than the kick, which
    takes longer.)"""
    import dis
    found = list(dis.get_instructions(code))
    live, names, until = 0, [], -1
    for k, ins in enumerate(found):
        if ins.offset < until:
            continue
        live += 1
        if ins.opname in ("LOAD_GLOBAL", "LOAD_NAME", "LOAD_ATTR", "LOAD_METHOD"):
            names.append(ins.argval)
        following = found[k + 1] if k + 1 < len(found) else None
        if (ins.opname == "LOAD_GLOBAL" and isinstance(space.get(ins.argval), bool) and following is not None
                and "JUMP" in following.opname and "IF_" in following.opname
                and isinstance(following.argval, int) and following.argval > following.offset):
            # the branch jumped over is pruned where the test takes the jump never
            if following.opname.endswith("IF_FALSE") and not space[ins.argval]:
                until = following.argval
            elif following.opname.endswith("IF_TRUE") and space[ins.argval]:
                until = following.argval
    return len(code.co_code) * live // max(len(found), 1), names


_REACHED: dict = {}


def code_weight(kernel) -> int:
    """The bytes of Python bytecode in ``kernel`` (a njit function) and in every function it
    reaches (_reach): known before compiling anything, and in the order of their compile
    times (an obstacle's line contact against gravity: seventy times the bytecode, twenty
    times the seconds), so that two processes sharing a queue take the long ones first."""
    return _reach(kernel)[0]


def reaches_compiling_elsewhere(kernel) -> bool:
    """Whether another process is compiling into the cache, right now, a function ``kernel``
    calls (or it, for any argument types): compiling ``kernel`` would then wait for it (a
    callee's lock is taken as it is reached), so a caller with other work does that first.
    (A second process started beside a run asked first for the fluid's flow, which calls the
    sample the run was compiling for its frame 0, and idled for seconds.)"""
    indexes = {}
    for d in _reach(kernel)[1]:
        path = d._cache._cache_file._index_path
        indexes.setdefault(os.path.dirname(path), set()).add(os.path.basename(path))
    for folder, names in indexes.items():
        try:
            entries = os.listdir(folder)
        except OSError:   # nothing cached there yet: nothing compiled into it either
            continue
        for entry in entries:
            # a lock is the index's name, a key's hash, .compiling (compile_lock_path)
            if not entry.endswith(".compiling") or entry.rsplit(".", 2)[0] not in names:
                continue
            if _held_elsewhere(os.path.join(folder, entry)):
                return True
    return False


def in_cache(dispatcher, sig) -> bool:
    """Whether numba's cache on disk holds ``dispatcher`` compiled for the argument types
    ``sig`` (read from its index, which numba keeps private: an index absent or stale reads
    as empty)."""
    index = dispatcher._cache._cache_file._load_index()
    return any(key[0] == sig for key in index)


def stable_cache_key(dispatcher):
    """Give a closure compiled by ``njit(cache=True)`` a cache key that is the same in every
    process, and return it. Numba keys a closure by the pickle of its cells; a cell holding
    a jitted function pickles with a random id drawn per process, so such a closure never
    found itself in the cache: every process compiled it again and its index grew by one
    entry per process. The cells are described by what they compute instead (_describe)."""
    cache = dispatcher._cache
    if not hasattr(cache, "_index_key"):  # caching off (no cache directory)
        return dispatcher
    py = dispatcher.py_func
    cells = pickle.dumps(tuple(_describe(c.cell_contents) for c in (py.__closure__ or ())))
    code = hashlib.sha256(py.__code__.co_code).hexdigest()

    def index_key(sig, codegen):
        return (sig, codegen.magic_tuple(), (code, hashlib.sha256(cells).hexdigest()))
    cache._index_key = index_key
    return dispatcher


def extend_cache_key(dispatcher, extra, key=None):
    """Key ``dispatcher``'s cached code by ``extra`` after ``key`` (a cache's index key; its
    own by default), and return it: functions that share a source line share an index file,
    and numba's key (code and argument types) would let one load another's code."""
    key = key or dispatcher._cache._index_key
    dispatcher._cache._index_key = lambda sig, codegen: key(sig, codegen) + (extra,)
    return dispatcher


def keyed_twin(kernel, py_func, extra, **options):
    """A dispatcher of ``py_func`` with ``kernel``'s options updated by ``options``, cached as
    ``kernel`` is, under its key plus ``extra`` (extend_cache_key)."""
    from numba.core import caching
    options = {**{k: v for k, v in kernel.targetoptions.items() if k != "nopython"}, **options}
    twin = numba.njit(**options)(py_func)
    if isinstance(kernel._cache, caching.Cache):
        twin.enable_caching()
        extend_cache_key(twin, extra, kernel._cache._index_key)   # (stable_cache_key's, for a closure)
    return twin


def _cache_options() -> dict:
    """Return the options every kernel starts from, and point numba's on-disk cache at a
    directory of this exact kernel source: "cosnet-<digest of kernels/*.py>" under
    NUMBA_CACHE_DIR, else under numba's user cache. Numba checks a cached function against
    its own file only, so a step kernel cached before a kernel it calls (in another file)
    changed would go on running the old code; a new source digest starts a fresh directory.

    Debug mode: with COSNET_BOUNDSCHECK=1 in the environment every kernel checks its indices
    (numba's boundscheck: an IndexError instead of a read or write out of bounds). Numba's
    cache keys ignore such options, so the checked builds get a directory of their own
    ("...-boundscheck"): a normal run never loads a checked kernel, nor a debug run an
    unchecked one. Likewise a build at another LLVM optimisation level (NUMBA_OPT) than
    numba's default 3 ("...-opt1"): a run at full speed never loads a less optimised kernel.
    And a build linking as numba does (COSNET_LINK_ONLY=0, kernels/linking.py), whose steps
    differ in their last bits ("...-numba-linking")."""
    from numba.misc.appdirs import AppDirs
    here = os.path.dirname(os.path.abspath(__file__))
    digest = hashlib.sha256()
    for name in sorted(os.listdir(here)):
        if name.endswith(".py"):
            with open(os.path.join(here, name), "rb") as f:
                digest.update(name.encode() + b"\0" + f.read())
    check = os.environ.get("COSNET_BOUNDSCHECK", "0") not in ("", "0")
    base = numba.config.CACHE_DIR or AppDirs("numba", appauthor=False).user_cache_dir
    level = getattr(numba.config.OPT, "_raw_value", numba.config.OPT)   # 0..3 or "max"
    opt = "" if level == 3 else f"-opt{level}"
    own = "-numba-linking" if os.environ.get("COSNET_LINK_ONLY", "1") == "0" else ""
    numba.config.CACHE_DIR = os.path.join(base, f"cosnet-{digest.hexdigest()[:16]}"
                                          + ("-boundscheck" if check else "") + opt + own)
    return dict(cache=True, boundscheck=True) if check else dict(cache=True)


# fast-math without nnan/ninf: contraction and reassociation, while NaN and infinity still
# propagate so that a blow-up stays visible to the instability watch
FAST = {"contract", "arcp", "reassoc", "nsz"}
# Options every kernel starts from: fast-math, numpy's error model and no reference counts,
# all three set. Under numpy's model a division by zero gives inf/NaN (the watch sees it);
# python's raises, and the zero test it puts before every division is an early exit, which
# stops vectorisation. Numba compiles a kernel whose options leave one unset with its first
# caller's, and neither its in-memory overloads nor its cache key tell the variants apart: a
# contact kernel first called from Python took python's error model (a division by zero
# raises) and kept it for every step of that process, and a step compiled there went into the
# cache with it linked in. A cache filled by test workers in one order then made a rope pile's
# step raise ZeroDivisionError that a cache filled in another order did not. Set, a kernel's
# code is the same whoever calls it first. No kernel allocates; any that did would be refused
# at compile time (no reference counts), as the steps refuse it. No C-callable wrapper: numba
# builds one for every function unless told not to, taking the records' arrays as a few hundred
# scalar arguments, and nothing here calls a kernel through it (the slots call the kernels
# themselves, kernels/slots.py).
CACHED = dict(_cache_options(), fastmath=FAST, error_model="numpy", _nrt=False, no_cfunc_wrapper=True)
# the same, inlined by numba where called (the joints' helpers)
CACHED_INLINE = dict(CACHED, inline="always")
# the same, for helpers called only from other kernels: without the Python entry wrapper,
# whose compilation (unboxing a record of dozens of arrays) costs more than a small body's
CACHED_INNER = dict(CACHED, no_cpython_wrapper=True)
# Without fast-math: the vertex-obstacle contact (other rounding than the step's fused
# multiply-adds). For kernels whose divisions are all guarded, whose loops run in vector lanes.
CACHED_LANES = dict(CACHED, fastmath=False)
# the step kernels' options (the same)
KERNEL = CACHED
# Kernels called only from other kernels: no Python entry wrapper. Numba otherwise builds and
# compiles, for every function, a wrapper unboxing its arguments from Python objects; for a
# function taking the model, state and loads records (47 arrays) that alone is most of a
# second of compilation, even for a body of one line.
INNER = dict(KERNEL, no_cpython_wrapper=True)
# Inlined by numba where called: for the bodies of vectorised loops whose arguments are
# tuples of arrays (left to LLVM, such calls, passing dozens of array fields, slowed the
# vectorised passes by half). Numba types an inlined body afresh at every call site, so the
# scalar helpers below are plain functions instead: compiled once, inlined by LLVM.
INLINE = dict(INNER, inline="always")
