"""Kernels compiled per variant: the options of an effect that a scene fixes once (which parts
of a fluid act) as compile-time constants, so that a scene compiles only the parts it uses.

A module writes such options as globals (``MOVING = True``) and tests them in plain ``if``
statements. Numba prunes a branch on a global constant before it types the function, so the
calls in a pruned branch are never typed, compiled or linked; an option tested at run time
would compile every part for every scene. ``specialise`` clones the jitted functions of some
modules that read an option, directly or through another such function, with the options
set: the modules' own functions stay the variant with every option on.
"""

import types as _pytypes

from numba.core.registry import CPUDispatcher

from .compiler import keyed_twin


def _jitted(module) -> dict:
    return {name: f for name, f in vars(module).items()
            if isinstance(f, CPUDispatcher) and f.py_func.__module__ == module.__name__}


def specialise(modules, options: dict, tag: str) -> dict:
    """Return {name: dispatcher}: the functions of ``modules`` that read any global of
    ``options`` or call such a function, compiled with those globals set to ``options``
    (calling each other's clones). ``tag`` names the variant: it is part of each clone's cache
    key, since functions that do not take the effect's record would otherwise share their
    cached code between variants (same source, same argument types)."""
    found = {}
    for m in modules:
        for name, f in _jitted(m).items():
            if name in found:
                raise ValueError(f"variants: {name} is defined in {found[name][0].__name__} and {m.__name__}")
            found[name] = (m, f)

    def calls(name, members):
        m, f = found[name]
        space = vars(m)
        return any(n in options or (n in members and space.get(n) is found[n][1]) for n in f.py_func.__code__.co_names)

    members: set = set()
    while True:
        grown = {n for n in found if n not in members and calls(n, members)}
        if not grown:
            break
        members |= grown
    spaces = {m: dict(vars(m), **options) for m in modules}
    clones = {n: _clone(found[n][1], spaces[found[n][0]], tag) for n in members}
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
