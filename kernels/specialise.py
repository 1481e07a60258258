"""Kernels compiled per variant: the options of an effect that a scene fixes once (which parts
of a fluid act) as compile-time constants, so that a scene compiles only the parts it uses.

A module writes such options as globals (``MOVING = True``) and tests them in plain ``if``
statements. Numba prunes a branch on a global constant before it types the function, so the
calls in a pruned branch are never typed, compiled or linked; an option tested at run time
would compile every part for every scene. ``specialise`` clones the jitted functions of some
modules that read an option, directly or through another such function, with the options
set: the modules' own functions stay the variant with every option on. A clone depends on
the options it reads alone, and variants that agree on those share it: a record of any
variant has its base's numba type, so a shared clone is compiled once for all of them.
"""

import types as _pytypes
from typing import NamedTuple

from numba.core import types as numba_types
from numba.core.registry import CPUDispatcher
from numba.core.typing.typeof import typeof_impl

from .compiler import keyed_twin


def _jitted(module) -> dict:
    return {name: f for name, f in vars(module).items()
            if isinstance(f, CPUDispatcher) and f.py_func.__module__ == module.__name__}


_CLONES: dict = {}   # (module, name, the options it reads and their values) -> its clone


def specialise(modules, options: dict, tag: str) -> dict:
    """Return {name: dispatcher}: the functions of ``modules`` that read any global of
    ``options`` or call such a function, compiled with those globals set to ``options``
    (calling each other's clones). A clone is made once per process for the values of the
    options it reads, itself or through its callees, and shared by every variant that agrees
    on those: variants that differ elsewhere compile it once. ``tag`` (the effect) and those
    values are part of each clone's cache key, since the same source with the same argument
    types would otherwise share its cached code between variants."""
    found = {}
    for m in modules:
        for name, f in _jitted(m).items():
            if name in found:
                raise ValueError(f"variants: {name} is defined in {found[name][0].__name__} and {m.__name__}")
            found[name] = (m, f)

    def callees(name):
        m, f = found[name]
        space = vars(m)
        return {n for n in f.py_func.__code__.co_names if n in found and space.get(n) is found[n][1]}

    calls = {n: callees(n) for n in found}
    reads = {n: set(found[n][1].py_func.__code__.co_names) & set(options) for n in found}
    while True:   # what a function reads through its callees, to a fixed point
        grown = {n: reads[n].union(*(reads[c] for c in calls[n])) for n in found}
        if grown == reads:
            break
        reads = grown
    members = [n for n in found if reads[n]]
    spaces = {m: dict(vars(m), **options) for m in modules}
    clones = {}
    for n in members:
        m = found[n][0]
        values = tuple(sorted((o, options[o]) for o in reads[n]))
        key = (m.__name__, n, values)
        if key not in _CLONES:
            _CLONES[key] = _clone(found[n][1], spaces[m], f"{tag}:" + ",".join(f"{o}={int(v)}" for o, v in values))
        clones[n] = _CLONES[key]
    originals = {id(found[n][1]): clones[n] for n in members}
    for space in spaces.values():   # names bound to a member, its own module's or imported
        for name, value in space.items():
            if id(value) in originals:
                space[name] = originals[id(value)]
    return clones


def _clone(f, space: dict, tag: str):
    py = f.py_func
    clone = _pytypes.FunctionType(py.__code__, space, py.__name__, py.__defaults__, py.__closure__)
    clone.__qualname__, clone.__doc__, clone.__kwdefaults__ = py.__qualname__, py.__doc__, py.__kwdefaults__
    clone.cosnet_options = tag   # (compiler._describe: a closure calling it is keyed by it too)
    return keyed_twin(f, clone, ("variant", tag))


class Variant(NamedTuple):
    record: type    # the record class (a subclass of the effect's) the step is typed by
    family: dict    # its kernels by name, where they differ from the modules' own
    modules: tuple  # the effect's kernel modules

    def kernel(self, name: str):
        """Its kernel ``name`` (one called from Python: a sample, an energy)."""
        held = self.family.get(name)
        if held is not None:
            return held
        for m in self.modules:
            if name in vars(m):
                return vars(m)[name]
        raise AttributeError(f"no kernel {name!r} in {[m.__name__ for m in self.modules]}")


class Variants:
    """The variants of one effect's kernels: a record class per combination of ``options``
    (module globals, each True or False), a subclass of ``base`` named by their bits
    (``base.__name__`` + "_01"), whose hook kernels are the clones compiled with those options
    (``register(record class, clones)`` registers them with kernels.compose). ``home``, the
    module the record classes say they belong to, finds them by name with its module
    ``__getattr__ = VARIANTS.module_getattr``.
    ``modules`` is called at the first variant: the effect's kernel modules."""

    def __init__(self, base: type, modules, options: tuple, register, home: str):
        self.base, self.modules, self.options, self.register, self.home = base, modules, options, register, home
        self._held: dict = {}

    def variant(self, bits: str) -> Variant:
        """The variant with the options whose bits are "1", built once per process."""
        held = self._held.get(bits)
        if held is not None:
            return held
        if len(bits) != len(self.options) or set(bits) - {"0", "1"}:
            raise ValueError(f"{self.base.__name__} variant {bits!r}: expected {len(self.options)} bits, "
                             f"one per option {self.options}")
        modules = tuple(self.modules())
        clones = specialise(modules, {name: b == "1" for name, b in zip(self.options, bits)}, self.base.__name__)
        cls = type(f"{self.base.__name__}_{bits}", (self.base,), {"__slots__": (), "__module__": self.home})
        typeof_impl.register(cls)(self._typeof)
        self.register(cls, clones)
        held = self._held[bits] = Variant(cls, clones, modules)
        return held

    def _typeof(self, record, context):
        # numba types a variant's record as its base's (the same fields, the same layout), so
        # that a clone compiled for one variant is the clone of every variant that shares it;
        # which kernels a step calls is chosen by the record's class (kernels.compose)
        fields = [typeof_impl(v, context) for v in record]
        return None if any(t is None for t in fields) else numba_types.BaseTuple.from_types(fields, self.base)

    def with_options(self, options) -> Variant:
        """The variant with ``options`` (a bool per option)."""
        return self.variant("".join("1" if b else "0" for b in options))

    def record(self, p, options) -> tuple:
        """``p`` (a base record) as the record of the variant with ``options`` (a bool per
        option), sharing its arrays."""
        return self.with_options(options).record(*p)

    def of(self, p) -> Variant:
        """The variant whose record ``p`` is (the base record itself: every option on, the
        modules' own kernels)."""
        if type(p) is self.base:
            return Variant(self.base, {}, tuple(self.modules()))
        return self.variant(type(p).__name__[len(self.base.__name__) + 1:])

    def module_getattr(self, name: str):
        """``home``'s module ``__getattr__``: the record class named ``name``, as pickle looks
        for it (a sweep's worker; a step's cache index naming the records it was compiled for)."""
        prefix = self.base.__name__ + "_"
        if name.startswith(prefix):
            try:
                return self.variant(name[len(prefix):]).record
            except ValueError:
                pass
        raise AttributeError(f"module {self.home!r} has no attribute {name!r}")
