"""A record read once, not once per field, where a threaded loop (numba's prange) is called.

Numba hands a prange loop's body (a "gufunc" of its own) each tuple it reads as its elements,
one argument each, and builds the call by loading the tuple's whole value from its variable
once per element and taking that element out. For a record of n arrays that is n loads of n
arrays: LLVM's optimisation of the calling function grows as n squared. The fluid's threaded
kick reads its record, the model and the state (about 90 arrays) in each of three loops, and
LLVM spent 20 of the 30 s its compiling took on those loads (a record of 30 arrays: 0.1 s; of
90: 5 s). Here the loads of each tuple at one such call are the first one's value: the same
value, since nothing is stored into the variable between them, so the optimised code is
numba's own (a test compares it). COSNET_PARFOR_LOADS=0 in the environment leaves numba's
lowering as it is."""

import inspect
import os

from numba.parfors import parfor_lowering

ACTIVE = os.environ.get("COSNET_PARFOR_LOADS", "1") != "0"   # read at each call: a test turns it off


def _load_tuples_once():
    """Make parfor_lowering.call_parallel_gufunc load each tuple it passes once (see above),
    where numba's function has the form this knows: its last parameter the map of the
    elements' names to (tuple, index)."""
    call = getattr(parfor_lowering, "call_parallel_gufunc", None)
    if call is None or getattr(call, "loads_once", False):
        return
    if list(inspect.signature(call).parameters)[-1:] != ["exp_name_to_tuple_var"]:
        return   # another numba: its own lowering, slower to compile, same code

    def call_parallel_gufunc(lowerer, *args):
        tuples = {name for name, _ in args[-1].values()}
        if not ACTIVE or not tuples:
            return call(lowerer, *args)
        load, held = lowerer.loadvar, {}

        def loadvar(name):
            # (a tuple is loaded only where the arguments are gathered, in one block before
            # the call: the first load dominates every use)
            if name not in tuples:
                return load(name)
            if name not in held:
                held[name] = load(name)
            return held[name]

        lowerer.loadvar = loadvar
        try:
            return call(lowerer, *args)
        finally:
            del lowerer.loadvar
    call_parallel_gufunc.loads_once = True
    parfor_lowering.call_parallel_gufunc = call_parallel_gufunc


_load_tuples_once()
