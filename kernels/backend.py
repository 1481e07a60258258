"""Serial or parallel loops, chosen at compile time by the type of a marker argument.

A parallel region costs about a microsecond to launch, which would dominate small nets; so
each hot loop exists as a plain loop and as a ``prange`` loop over the same per-item body,
and ``dispatch`` picks one by the marker's type when the step is compiled.

Per-item bodies called inside a ``prange`` loop must not be ``inline="always"``: with numba
0.68 such an inlined body loses its writes through NamedTuple arguments (a plain call, which
LLVM inlines anyway, is correct; tests/test_conservation.py checks 1 vs 2 threads).
"""

from typing import NamedTuple

from numba.extending import overload

from .rotations import KERNEL

# Options of the serial step kernels. They allocate nothing, so they run without numba's
# reference counting: a call passing the Model/State/Loads records would otherwise cost an
# atomic increment and decrement per array (~45 arrays: about a microsecond per call), and
# any allocation slipping into a step is refused at compile time.
STEP = dict(KERNEL, _nrt=False)


class Serial(NamedTuple):
    """Run every loop on one thread."""
    threads: int = 1


class Parallel(NamedTuple):
    """Run the hot loops on numba's thread pool."""
    threads: int = 2


def _pick(backend, serial, parallel):
    return parallel if backend.instance_class is Parallel else serial


def dispatch3(serial, parallel):
    """Return f(backend, a, b, c) calling serial(a, b, c) or parallel(a, b, c) by the type of
    backend (resolved at compile time; njit only). Fixed arity: star-args cost a copy."""
    def call(backend, a, b, c):
        raise TypeError("dispatch targets are callable from njit code only")

    @overload(call)
    def typer(backend, a, b, c):
        fn = _pick(backend, serial, parallel)

        def impl(backend, a, b, c):
            fn(a, b, c)
        return impl
    return call


def dispatch4(serial, parallel):
    """As dispatch3, for functions of four arguments."""
    def call(backend, a, b, c, d):
        raise TypeError("dispatch targets are callable from njit code only")

    @overload(call)
    def typer(backend, a, b, c, d):
        fn = _pick(backend, serial, parallel)

        def impl(backend, a, b, c, d):
            fn(a, b, c, d)
        return impl
    return call
