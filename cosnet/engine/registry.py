"""Effect declarations and their registry.

An effect is one class: a subclass of ``Effect`` stating its scene ``kind``, its scene
``keys`` (``Key``: converter, physical unit, required or not), its parameter ``record`` (a
NamedTuple) and, through the record, its kernel and stage: the kernel registered for the
record with ``@load_kernel(Record)`` (it adds forces and torques: stage "load") or
``@flow_kernel(Record)`` (an exact velocity flow: stage "flow"), cosnet.kernels.compose. The
scene loader, the ``[scale]`` conversion, the exports of ``cosnet`` and the scene reference
(cosnet.scene.reference) are derived from these declarations.

Effects of other packages register under the entry-point group ``cosnet.effects``: the entry
point's name is the scene kind and its value the class (docs/effects.md).
"""

from __future__ import annotations

import importlib
import inspect
import os
import sys
from dataclasses import dataclass
from importlib import metadata
from typing import Any, NamedTuple
from collections.abc import Callable

from ..core.net import Line, Node
from ..kernels.compose import DRIFT_CONSTRAINTS, FLOW_KERNELS, KERNELS, LOAD_KERNELS
from ..core.units import Unit

ENTRY_POINTS = "cosnet.effects"
# in the order kinds are listed
BUILTIN_MODULES = tuple(f"cosnet.effects.{m}" for m in ("loads", "drives", "active", "contact", "obstacles", "joints",
                                                           "bodies", "fluid", "internal_damping"))
REFERENCES = ("node", "line", "lines", "nodes", "path")   # converters naming parts of the net, or a file


@dataclass(frozen=True)
class Key:
    """One scene key of an effect: its ``convert``er (a scene_values converter, or "node" /
    "line" / "lines" for names of the net's nodes or lines), its physical ``unit`` (None: a
    pure number, a direction or a name; [scale] converts the others to SI), whether it is
    ``required`` and a short ``doc`` for the scene reference. The key is passed to the
    effect's constructor under its own name; the constructor's default is the key's default."""

    name: str
    convert: Callable | str
    unit: Unit | dict | None = None   # a dict: an inline table's unit per key
    required: bool = False
    doc: str = ""


class Binding(NamedTuple):
    """What an effect binds to: the net as declared, its flattened ``model``, the ``state``
    as built (cosnet.engine.flatten), the ``effects`` declared with it and the ``records`` of
    those bound before it (a simulation binds them in order; implied effects come last), and
    the thread count the simulation steps on."""

    net: Any
    model: Any
    state: Any
    effects: tuple = ()
    records: tuple = ()
    threads: int = 1   # the step's thread count (an effect whose kernels have a threaded variant picks it)

    @property
    def time(self) -> float:
        return float(self.state.clock[0])

    def check_node(self, node, who: str) -> int:
        """The index of ``node``, refused in one line unless it is a node of this net."""
        nodes = self.net.nodes
        if not isinstance(node, Node) or node.index >= len(nodes) or nodes[node.index] is not node:
            raise ValueError(f"{who}: {node!r} is not a node of this simulation's net")
        return node.index

    def check_line(self, line, who: str) -> int:
        """The index of ``line``, refused in one line unless it is a line of this net."""
        lines = self.net.lines
        if not isinstance(line, Line) or line.index >= len(lines) or lines[line.index] is not line:
            raise ValueError(f"{who}: {line!r} is not a line of this simulation's net")
        return line.index


# The accounts of the energy budget: each the Simulation method reading it and its sign in the
# balance energy() - driver - actuation - loads - supplied + dissipated, constant but for the
# scheme's error (read by Simulation.balance(), the output's energy.csv and its plots).
ACCOUNTS: dict[str, tuple[str, float]] = {
    "dissipated": ("dissipated", 1.0), "driver": ("driver_work", -1.0), "actuation": ("actuation_work", -1.0),
    "loads": ("load_work", -1.0), "supplied": ("supplied", -1.0)}


class Effect:
    """Base of all declared effects. A concrete effect states ``kind`` (its scene name),
    ``keys`` (a tuple of Key), ``record`` (its kernel's parameter NamedTuple) and implements
    ``bind``; ``stage`` ("load" or "flow") and ``kernel`` follow from the kernel registered
    for the record. ``adds_energy`` says whether it can feed energy in (the instability watch
    then skips its energy test).

    Energy and stability are read from the bound record ``p`` (what the kernel reads):
    ``potential(p, on)``, ``exchange(p, on)`` and ``omega2(p, on)``; ``potential_energy``,
    ``energy_scale`` and ``max_omega2`` evaluate them on the record bound in a simulation.
    """

    kind: str | None = None
    keys: tuple = ()
    record: type | None = None
    stage: str = "load"
    kernel: Callable | None = None
    adds_energy = False
    # join(records) -> (joined, views), or None: effects of one class declared one after
    # another run as one record, so that their number is not part of the compiled step's type
    # (each effect keeps a record of views into the joined arrays; see cosnet.effects.loads.join_loads)
    join: Callable | None = None
    # integer arrays of its record that index nothing (flags, counters), which table_error
    # need not refuse out of range (cosnet.studies.effect_check plants bad entries in the others)
    free_integers: tuple = ()
    # integer arrays in which a negative entry means none (the kernel skips it)
    none_if_negative: tuple = ()
    # what its work() counts, part of which account of sim: "driver" (sim.driver_work(): a
    # prescribed motion), "actuation" (sim.actuation_work(): active lines) or "load"
    # (sim.load_work(): declared loads); None: no work account
    work_kind: str | None = None
    # whether its kernels move the net by the masses an effect that adds_mass gives it (read
    # from that effect's record): it then binds and runs after such effects
    reads_added_mass = False

    def __init_subclass__(cls, **kw):
        super().__init_subclass__(**kw)
        if cls.record is not None:
            cls.stage, cls.kernel = _stage_of(cls)
        if "kind" in cls.__dict__ or "keys" in cls.__dict__:
            _check_declaration(cls)

    # ------------------------------------------------------------------ the declaration
    @property
    def conservative(self) -> bool:
        """Whether its loads are minus the gradient of potential() in the net's positions and
        rotations (cosnet.studies.effect_check holds it to that)."""
        return False

    @property
    def internal(self) -> bool:
        """Whether its loads add up to no force and no moment about the origin: action and
        reaction inside the net, so the total momenta are conserved (effect_check holds it to
        that)."""
        return False

    @classmethod
    def end_probe_fields(cls, line, end: str) -> tuple:
        """The probe fields this effect offers at ``end`` ("start" or "end") of ``line``
        ("LINE@end:FIELD"); none by default."""
        return ()

    @classmethod
    def end_probe(cls, sim, line, end: str, field: str):
        """(3,) the value now of one of end_probe_fields (lab frame, SI)."""
        raise NotImplementedError

    @classmethod
    def implied(cls, net, grids):
        """The instance of this effect that ``net`` implies by what it declares (see
        IMPLIED), for its flattened line grids; None for effects a scene declares."""
        return None

    @classmethod
    def example(cls):
        """(net, effects): a small scene with an instance of this effect among ``effects`` (or
        implied by the net), on which cosnet.studies.effect_check holds the effect to its
        contract; None for an effect that gives none."""
        return None

    def bind(self, on: Binding):
        """Return the kernel's parameter record for the net, model and state of ``on``."""
        raise NotImplementedError

    @staticmethod
    def table_error(p, model):
        """What is wrong with the index tables of record ``p`` (the integer arrays its kernel
        indexes the model and state by) for ``model``, or None; the watch asks before every run
        whose tables changed, so a kernel may trust them. None: the kernel checks what it reads."""
        return None

    def potential(self, p, on: Binding) -> float:
        """Potential energy stored in record ``p`` (0 for effects that store none)."""
        return 0.0

    def exchange(self, p, on: Binding) -> float:
        """Energy (J) record ``p`` can exchange with the motion of the net as built; the
        instability watch tolerates Verlet's error on it. 0 for effects that store none."""
        return 0.0

    def omega2(self, p, on: Binding) -> float:
        """Upper bound on the squared frequency record ``p``'s stiffness adds to any mass of
        the net (k / m for a penalty spring); the stable step shrinks accordingly. 0 when the
        effect adds no stiffness."""
        return 0.0

    def added_mass(self, p, on: Binding):
        """(vertex, node) arrays (nv,), (nn,): the least mass record ``p`` adds to each vertex
        and node in every direction (a fluid's added mass), which lowers the frequencies and
        lengthens the stable step; None when it adds none."""
        return None

    def adds_mass(self) -> bool:
        """Whether this effect, as declared, may give the net a mass the kick divides by
        besides the model's (a fluid's added mass): effects that read it (reads_added_mass)
        bind and run after it."""
        return False

    def carried_mass(self, p, on: Binding):
        """(vertex, node) bool arrays (nv,), (nn,): where the kick sees a mass other than the
        model's in some direction (a fluid's added mass); None where it sees the model's
        everywhere. A constraint acting there moves the net by that mass: its record shares
        the arrays that hold it (carried_by, cosnet/effects/carried.py), which only the
        effect's own kernels know (a fluid's: kernels/sliding.py)."""
        return None

    def held_stiffness(self, p, on: Binding):
        """(points, B): Voronoi points whose bending and twisting stiffness B (k, 3) record
        ``p`` holds in place of the model (an articulated line end's), which the stable step
        then counts as the model's; None when it holds none."""
        return None

    def end_fields(self, p, on: Binding):
        """(vertices, frames, torque, curvature): the director frame (quaternion), internal
        torque (lab) and u - u0 at line-end vertices where record ``p`` holds what the model
        does not (an articulated end's), for sim.line_fields; None when it holds nothing."""
        return None

    def load_scale(self, net) -> float:
        """The largest force (N) this effect puts on the net's lines, an estimate for the fast
        modes' softening (cosnet.core.fast_modes); 0 for effects that apply no set load."""
        return 0.0

    def drives(self, node) -> bool:
        """Whether this effect prescribes the motion of ``node`` (sim.reaction asks it)."""
        return False

    def work(self, sim) -> float:
        """Work (J) done on the net so far, in the account ``work_kind`` names (0 without one)."""
        return 0.0

    def dissipated(self, sim) -> float:
        """Energy (J) this effect has taken out of the net so far, part of sim.dissipated()
        (0 for effects that keep no such account)."""
        return 0.0

    def supplied(self, sim) -> float:
        """Work (J) a medium moving on its own (a current, wind, waves) has done on the net
        through this effect so far, part of sim.supplied() (0 for other effects)."""
        return 0.0

    def check_state(self, sim):
        """Raise ValueError (one line) if the state contradicts this effect (a driven node
        moving against its drive); run() asks before it steps."""

    def start(self, sim):
        """Make the state consistent with this effect before a simulation's first step (a
        constraint's velocities: a ring takes its line's motion across it); run() calls it
        once, before step 0. Most effects have nothing to do."""

    def state_arrays(self, sim) -> dict:
        """The arrays of its parameter record that change as the net moves (friction anchors):
        a checkpoint saves and restores them with the state. Empty for most effects."""
        return {}

    def drawn_shapes(self) -> list:
        """The solid shapes it puts in the scene, for pictures (cosnet.output.render): each a
        dict of "shape" (sphere, capsule, box, plane or mesh), "node" (the node index it moves
        with, or None: fixed in the lab) and its geometry ("origin", "axis", "size", "rot",
        "points", "triangles", in the node's frame about its reference point). Most effects
        have none."""
        return []

    def describe(self) -> str:
        return type(self).__name__

    # ------------------------------------------------------------------ in a simulation
    def params(self, sim):
        """The parameter record this effect is bound to in ``sim`` (live: what its kernel
        reads and writes)."""
        return sim.effect_params(self)

    def _bound(self, sim):
        """(record, binding) in ``sim``: the bound record, or for an effect ``sim`` does not
        hold, the record it would get there."""
        on = Binding(sim.net, sim.model, sim.state)
        held = any(e is self for e in getattr(sim, "effects", ()))
        return (sim.effect_params(self) if held else self.bind(on)), on

    def potential_energy(self, sim) -> float:
        """Potential energy of the record bound in ``sim``."""
        return float(self.potential(*self._bound(sim)))

    def energy_scale(self, sim) -> float:
        """Energy the record bound in ``sim`` can exchange with the motion (see exchange)."""
        return float(self.exchange(*self._bound(sim)))

    def max_omega2(self, sim) -> float:
        """Squared-frequency bound of the record bound in ``sim`` (see omega2)."""
        return float(self.omega2(*self._bound(sim)))


def _stage_of(cls) -> tuple[str, Callable]:
    """(stage, kernel) of the kernel registered for cls.record."""
    rec = cls.record
    stages = [s for s, reg in (("load", LOAD_KERNELS), ("flow", FLOW_KERNELS), ("constraint", DRIFT_CONSTRAINTS))
              if rec in reg]
    name = getattr(rec, "__name__", repr(rec))
    if len(stages) != 1:
        why = "no kernel is" if not stages else "both a load and a flow kernel are"
        raise TypeError(f"{cls.__name__}: {why} registered for its record {name}; decorate one "
                        f"@njit kernel with @load_kernel({name}) or @flow_kernel({name})")
    kernel = cls.__dict__.get("kernel")
    if kernel is not None and kernel is not KERNELS[rec]:
        raise TypeError(f"{cls.__name__}: kernel is not the kernel registered for {name}")
    return stages[0], KERNELS[rec]


def _check_declaration(cls):
    """Refuse a malformed declaration when its class is created (a TypeError naming it)."""
    who = cls.__name__
    if not isinstance(cls.kind, str) or not cls.kind.isidentifier():
        raise TypeError(f"{who}: kind must be a scene name such as 'my_force', got {cls.kind!r}")
    if cls.record is None:
        raise TypeError(f"{who}: declares kind {cls.kind!r} but no record (its kernel's NamedTuple)")
    names = [k.name for k in cls.keys]
    if not all(isinstance(k, Key) for k in cls.keys) or len(set(names)) != len(names):
        raise TypeError(f"{who}: keys must be distinct cosnet Key declarations")
    params = inspect.signature(cls.__init__).parameters
    takes_any = any(p.kind is p.VAR_KEYWORD for p in params.values())
    for k in cls.keys:
        if not (callable(k.convert) or k.convert in REFERENCES):
            raise TypeError(f"{who}: key {k.name!r}: convert must be a converter or one of {REFERENCES}")
        if k.name not in params and not takes_any:
            raise TypeError(f"{who}: key {k.name!r} is not a parameter of {who}.__init__")


def default_of(cls, key: Key):
    """The constructor's default of ``key`` (inspect.Parameter.empty: none)."""
    p = inspect.signature(cls.__init__).parameters.get(key.name)
    return inspect.Parameter.empty if p is None else p.default


def _declared(base=Effect):
    for sub in base.__subclasses__():
        if sub.__dict__.get("kind") is not None:
            yield sub
        yield from _declared(sub)


def builtin_effects() -> dict:
    """kind -> class of the effects cosnet itself declares."""
    for name in BUILTIN_MODULES:
        importlib.import_module(name)
    found = {cls.kind: cls for cls in _declared() if cls.__module__ in BUILTIN_MODULES}
    order = {m: i for i, m in enumerate(BUILTIN_MODULES)}
    return dict(sorted(found.items(), key=lambda kv: order[kv[1].__module__]))


# Effects a net implies by what its lines and nodes declare (a joint at a line end, a ring),
# which a Simulation adds itself ("module:Class", each class's ``implied``). By name, as the
# effects' modules import this one.
IMPLIED = ("cosnet.effects.articulations:Articulations", "cosnet.effects.sliders:Sliders",
           "cosnet.effects.sheaves:Sheaves")


def implied_classes() -> list:
    """The classes of the effects a net may imply."""
    out = []
    for spec in IMPLIED:
        module, _, name = spec.partition(":")
        out.append(getattr(importlib.import_module(module), name))
    return out


def end_probe_owners(line, end: str) -> dict:
    """{field: the effect class offering it} of the probe fields at ``end`` of ``line`` that
    effects declare (Effect.end_probe_fields), cosnet's own, implied and installed."""
    owners: dict = {}
    for cls in (*implied_classes(), *catalogue().values()):
        for name in cls.end_probe_fields(line, end):
            owners.setdefault(name, cls)
    return owners


def implied_effects(net, grids) -> list:
    """The effects ``net`` implies, for its flattened line grids ``grids``."""
    return [e for e in (cls.implied(net, grids) for cls in implied_classes()) if e is not None]


_SCANNED: dict = {}   # (sys.path entries with their mtimes) -> entry points of the group


def _entry_points() -> tuple:
    """The entry points of the group cosnet.effects, read again only when sys.path or one of
    its folders changed (a package installed or removed): reading every installed
    distribution's metadata takes tens of milliseconds, and a scene names many effects."""
    stamps: list = []
    for p in sys.path:
        try:
            stamps.append((p, os.stat(p or ".").st_mtime_ns))
        except OSError:
            stamps.append((p, None))
    key = tuple(stamps)
    if key not in _SCANNED:
        _SCANNED.clear()
        _SCANNED[key] = tuple(metadata.entry_points(group=ENTRY_POINTS))
    return _SCANNED[key]


def catalogue() -> dict:
    """kind -> the class of each effect kind a scene may name: cosnet's own, then those other
    packages register (their entry points, loaded when a scene names them)."""
    out = dict(builtin_effects())
    for ep in _entry_points():
        out.setdefault(ep.name, ep)
    return out


def kinds() -> list[str]:
    """Every effect kind a scene may name: cosnet's, then those of installed packages."""
    return list(catalogue())


def effect_class(kind: str, known: dict | None = None):
    """The class declared for scene kind ``kind`` (looked up in ``known``, a catalogue(), when
    given); a ValueError in one line naming the entry point when another package's
    registration is broken."""
    known = catalogue() if known is None else known
    if kind not in known:
        raise ValueError(f"unknown effect kind {kind!r}; kinds are {list(known)}")
    found = known[kind]
    return found if inspect.isclass(found) else _load(found)


def _load(ep):
    where = f"entry point {ep.name} = {ep.value!r} of group {ENTRY_POINTS}"
    try:
        cls = ep.load()
    except Exception as e:   # any failure of a foreign import is reported, not raised through
        raise ValueError(f"{where} cannot be loaded ({type(e).__name__}: {e})") from None
    if not (inspect.isclass(cls) and issubclass(cls, Effect) and cls.kind is not None):
        raise ValueError(f"{where} is not a cosnet Effect declaration (got {cls!r})")
    if cls.kind != ep.name:
        raise ValueError(f"{where} declares kind {cls.kind!r}; the entry point's name must be its kind")
    return cls


def after_added_mass(effects: list) -> list:
    """``effects`` in the order a simulation binds and runs them: as declared, but that an
    effect which reads_added_mass comes after the last one that adds_mass (a dashpot declared
    before the fluid whose added mass it moves the lines by; the flows run in this order)."""
    last = max((i for i, e in enumerate(effects) if e.adds_mass()), default=-1)
    head = effects[:last + 1]
    return ([e for e in head if not e.reads_added_mass] + [e for e in head if e.reads_added_mass]
            + effects[last + 1:])


def carried_by(on: Binding, who: str, lines, nodes):
    """Return (effect, record, vertex, node) of the one effect bound before in ``on`` whose
    kick sees another mass than the model's on some of ``lines`` or ``nodes`` (a fluid's
    added mass; vertex, node: its carried_mass flags), or None; two such effects there are
    refused in one line naming ``who``."""
    found = []
    vo = on.model.line_vertex_offsets
    for e, p in zip(on.effects, on.records):
        carried = e.carried_mass(p, on)
        if carried is not None and (any(carried[0][vo[l.index]:vo[l.index + 1]].any() for l in lines)
                                    or any(carried[1][n.index] for n in nodes)):
            found.append((e, p) + tuple(carried))
    if len(found) > 1:
        raise ValueError(f"{who}: {found[0][0].kind} and {found[1][0].kind} both give their lines or nodes an "
                         f"added mass; give it in one effect")
    return found[0] if found else None
