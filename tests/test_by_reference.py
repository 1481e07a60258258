"""A large record (the model: a few hundred arguments flattened) is passed to a compiled
function as one pointer (kernels/by_reference.py), to the memory it was loaded from where that
holds it unchanged, else to a copy: a function reads the record it was given wherever the
value came from (an argument, a tuple, a variable assigned on two branches or again in a
loop), and the function's LLVM signature holds one pointer for it; a call passing memory
that may not hold its value (a variable stored twice, a pointer not defined on every path to
the call) is refused at compile time."""

import re
from typing import NamedTuple

import numpy as np
import pytest
from llvmlite import ir
from numba import njit

import cosnet
from cosnet.kernels.bodies import BodyParams
from cosnet.kernels.by_reference import BIG, _notes, by_reference, check_passed, leaves
from cosnet.kernels.compiler import INNER
from numba import typeof


def models():
    """Two models of one type and different values (lines of 4 and 7 elements, 1 and 2 m)."""
    out = []
    for n in (4, 7):
        net = cosnet.Net()
        a, b = net.add_node((0.0, 0.0, 0.0)), net.add_node((n / 4.0, 0.0, 0.0))
        net.add_line(a, b, material=cosnet.Material(E=1e9, G=4e8, density=1000.0), section=cosnet.Circle(0.01),
                     elements=n)
        out.append(cosnet.Simulation(net, [], threads=1).model)
    assert typeof(out[0]) == typeof(out[1])
    return out


@njit(**INNER)
def mass_of(model):
    """An interior vertex's mass times the number of vertices (no sum: exact to compare)."""
    return model.vertex_mass[1] * model.vertex_mass.shape[0]


def expected(model):
    return model.vertex_mass[1] * model.vertex_mass.shape[0]


@njit(**INNER)
def twice(model):
    return mass_of(model) + mass_of(model)


@njit
def through(model):
    return twice(model)


@njit
def member(pair):
    return mass_of(pair[0]) * pair[1]


@njit
def either(a, b, first):
    r = a if first else b   # two definitions: the call is given a copy, not a's memory
    return mass_of(r)


@njit
def in_turn(a, b):
    r, total = a, 0.0
    for _ in range(2):
        total += mass_of(r)   # r is a, then b: stored twice, so copied at the call
        r = b
    return total


def test_the_model_is_large_enough_to_pass_by_reference():
    model = models()[0]
    assert leaves(typeof(model)) >= BIG and by_reference(typeof(model))
    assert not by_reference(typeof(np.zeros(3))) and not by_reference(typeof((np.zeros(3),)))


def test_a_called_function_takes_the_model_as_one_pointer_and_reads_it():
    a, b = models()
    assert through(a) == 2.0 * expected(a) and through(b) == 2.0 * expected(b)
    ir = twice.inspect_llvm(twice.signatures[0])
    define = next(line for line in ir.splitlines() if line.startswith("define") and "twice" in line)
    assert len(re.findall(r"%\"?arg\.", define)) == 1   # the record one argument, not hundreds


def test_a_record_within_a_tuple_is_read_where_it_lies():
    a, _ = models()
    assert member((a, 3.0)) == 3.0 * expected(a)


def test_a_variable_given_two_values_passes_each():
    a, b = models()
    ma, mb = expected(a), expected(b)
    assert ma != mb
    assert either(a, b, True) == ma and either(a, b, False) == mb
    assert in_turn(a, b) == ma + mb
    assert in_turn(b, a) == mb + ma


def _diamond():
    """A function entry -> (left | right) -> join, with a record slot stored in both arms."""
    module = ir.Module()
    record = ir.LiteralStructType([ir.DoubleType(), ir.DoubleType()])
    fn = ir.Function(module, ir.FunctionType(ir.VoidType(), [record.as_pointer(), ir.IntType(1)]), "f")
    entry, left, right, join = (fn.append_basic_block(n) for n in ("entry", "left", "right", "join"))
    b = ir.IRBuilder(entry)
    slot = b.alloca(record)
    b.cbranch(fn.args[1], left, right)
    b.position_at_end(left)
    inner = b.gep(fn.args[0], [ir.Constant(ir.IntType(32), 0)])   # a pointer defined in one arm only
    b.store(b.load(inner), slot)
    b.branch(join)
    b.position_at_end(right)
    b.store(b.load(fn.args[0]), slot)
    b.branch(join)
    b.position_at_end(join)
    b.ret_void()
    return fn, slot, inner, join


def test_a_call_passing_memory_it_may_not_hold_is_refused():
    """check_passed: a variable stored twice, or a pointer that does not dominate the call,
    raises; the argument itself, which dominates every block, passes."""
    fn, slot, inner, join = _diamond()
    notes = _notes(fn)
    notes["passed"].append(([], fn.args[0], join))
    check_passed(fn)
    notes["passed"].append(([], inner, join))
    with pytest.raises(RuntimeError, match="may be undefined"):
        check_passed(fn)
    notes["passed"][:] = [([slot], fn.args[0], join)]
    with pytest.raises(RuntimeError, match="stored more than once"):
        check_passed(fn)


def test_a_record_class_may_keep_its_records_flattened():
    """A large record of cosnet's passes by reference unless its class says ``by_value`` (a
    rigid body's contacts: cosnet.kernels.bodies.BodyParams)."""
    wide = NamedTuple("Wide", [(f"a{i}", np.ndarray) for i in range(20)])
    wide.__module__ = "cosnet.kernels.example"
    kept = type("Kept", (wide,), {"by_value": True, "__module__": "cosnet.kernels.example"})
    arrays = [np.zeros(3) for _ in range(20)]
    assert leaves(typeof(wide(*arrays))) == 20 * 7 >= BIG
    assert by_reference(typeof(wide(*arrays))) and not by_reference(typeof(kept(*arrays)))
    assert BodyParams.by_value
