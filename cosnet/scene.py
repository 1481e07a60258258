"""Scene files: a whole simulation (net, effects, initial conditions, run settings) in TOML.

``load_scene(path)`` reads the file with the standard ``tomllib`` and builds the net through
the public ``Net.add_node`` / ``Net.add_line`` calls, so a scene and the same net built in
Python are identical. Tables (all numbers SI unless a [scale] table is present):

    title = "..."                   optional (and description)
    [scale]                         optional §5 reference scales time, length, area, density
                                    (torque): every number in the file is then in the scaled
                                    units (Table 5.2) and is converted to SI on loading
    [materials.NAME]                E, density, and G or poisson
    [sections.NAME]                 kind = circle | tube | rectangle | ellipse | explicit
    [nodes.NAME]                    position, frame, mass ("inf" allowed), inertia, fixed
    [lines.NAME]                    start, end, material, section, elements, start_offset,
                                    end_offset, start_frame, end_frame, rest_curvature, points, d1,
                                    rotary_inertia, rotary_inertia_scale, fast_modes
    [[effects]] or [effects.NAME]   kind = gravity | node_load | line_load | damping |
                                    spherical_joint | hinge_joint | fixed_joint |
                                    contact | drive | muscle_torque |
                                    active_curvature (docs/drives.md)
    [initial]                       velocity, angular_velocity, center; [initial.nodes.NAME],
                                    [initial.lines.NAME]; [initial.perturbation]
    [run]                           until, dt ("auto" or s), stepper, output_interval, probes,
                                    force_dt, limits (false lifts cosnet.limits), threads,
                                    fast_modes (docs/fast_modes.md)

A frame (node ``frame``, line ``start_frame`` / ``end_frame``) is the 3x3 matrix written as
its three rows (its columns are d1 d2 d3) or an inline table with two or three of d1, d2, d3
(a missing one completes the right-handed triad). A line's ``section`` names a
[sections.NAME] table or is an inline table of the same form.

Every unknown or misspelt key, wrong type, missing reference or unphysical value raises a
``ValueError`` whose one-line message names the file, the table and the key (``[[effects]]``
tables as ``[[effects]] #k (kind)``, counted from 1), on loading: what the simulation would
refuse later (a d1 hint along a line, an unknown contact line, a velocity for a fixed node)
is checked here too, so that the message names the table at fault.
"""

from __future__ import annotations

import re
import tomllib
from dataclasses import dataclass, field, replace
from pathlib import Path

import numpy as np

from . import materials as M
from .fast_modes import FAST_MODES
from .limits import check_elements
from .net import Net, frame_from_tangent
from .record import Probe, parse_probe
from .scaling import Scale
from .scene_values import (Table, Units, _Bad, _one_line, _show, _si, array, auto_or_positive, boolean,
                           choice, direction, floats, frame, integer, mass_value, nonnegative,
                           number, positive, quote_key, seed, string, string_list, vec3)

# what building a net from scene values may raise for values out of range: refused, not a crash
REFUSED = (ValueError, ArithmeticError)


def _why(e) -> str:
    if isinstance(e, ArithmeticError):
        return f"numbers out of range to compute with ({e.args[-1] if e.args else type(e).__name__})"
    return str(e)


TOP_KEYS = ("title", "description", "scale", "materials", "sections", "nodes", "lines",
            "effects", "initial", "run")


# ---------------------------------------------------------------------- net tables
def _material(t: Table, name) -> M.Material:
    t.expect("E", "density", "G", "poisson")
    kw = dict(E=t.get("E", positive), density=t.get("density", positive),
              G=t.get("G", positive, default=None), poisson=t.get("poisson", number, default=None))
    t.done()
    try:
        return M.Material(name=name, **kw)
    except REFUSED as e:
        raise t.err("G" if kw["G"] is not None else "poisson", _why(e)) from None


SECTIONS = {  # kind -> (constructor, required keys)
    "circle": (M.Circle, ("radius",)),
    "tube": (M.Tube, ("radius", "thickness")),
    "rectangle": (M.Rectangle, ("width", "height")),
    "ellipse": (M.Ellipse, ("a", "b")),
    "explicit": (M.Section, ("A", "I11", "I22", "J")),
}


def _section(t: Table) -> M.Section:
    kind = t.get("kind", choice(*SECTIONS))
    make, keys = SECTIONS[kind]
    t.expect("kind", "shear_coefficient", "rotary_inertia", *keys,
             *(("I12", "radius") if kind == "explicit" else ()))
    kw = {k: t.get(k, positive) for k in keys}
    kw["shear_coefficient"] = t.get("shear_coefficient", positive, default=1.0)
    rot = t.get("rotary_inertia", vec3, default=None)
    if kind == "explicit":
        kw["I12"] = t.get("I12", number, default=0.0)
        kw["radius"] = t.get("radius", positive, default=None)
    t.done()
    try:
        sec = make(**kw)
    except REFUSED as e:
        raise t.err(keys[-1], _why(e)) from None
    try:
        return sec if rot is None else replace(sec, rotary_inertia=tuple(rot))
    except ValueError as e:
        raise t.err("rotary_inertia", e) from None


def _node(t: Table, net: Net, name: str):
    t.expect("position", "frame", "mass", "inertia", "fixed")
    kw = dict(position=t.get("position", vec3), frame=t.get("frame", frame, default=None),
              mass=t.get("mass", mass_value, default=0.0),
              inertia=t.get("inertia", _inertia, default=None),
              fixed=t.get("fixed", boolean, default=False))
    t.done()
    if kw["fixed"] and ("mass" in t.data or "inertia" in t.data):
        raise t.err("fixed", "a fixed node has infinite mass and inertia; drop mass/inertia")
    _wrap(t, "frame", lambda: net.add_node(name=name, **kw))


def _inertia(v):
    """(3,) diagonal or (3, 3) matrix rows; "inf" entries lock an axis."""
    nested = isinstance(v, list) and any(isinstance(x, list) for x in v)
    return array((3, 3) if nested else (3,), allow_inf=True)(v)


def _line(t: Table, net: Net, name: str, materials, sections):
    t.expect("start", "end", "material", "section", "elements", "start_offset", "end_offset",
             "rest_curvature", "d1", "start_frame", "end_frame", "points", "rotary_inertia",
             "rotary_inertia_scale", "fast_modes")
    ends = []
    for role in ("start", "end"):
        ref = t.get(role, string)
        try:
            ends.append(net.node(ref))
        except KeyError:
            raise t.err(role, f"unknown node {ref!r}; nodes are {[n.name for n in net.nodes]}") from None
    mname = t.get("material", string)
    if mname not in materials:
        raise t.err("material", f"unknown material {mname!r}; materials are {sorted(materials)}")
    sec = t.get("section", lambda v: v)
    if isinstance(sec, dict):
        sec = _section(Table(t.file, f"{t.name}.section", sec))
    elif isinstance(sec, str) and sec in sections:
        sec = sections[sec]
    else:
        raise t.err("section", f"must name one of the sections {sorted(sections)} or be an "
                               f"inline table, got {_show(sec)}")
    kw = dict(material=materials[mname], section=sec, elements=t.get("elements", integer))
    for key in ("start_offset", "end_offset", "rest_curvature"):
        kw[key] = t.get(key, vec3, default=None)
    kw["d1"] = t.get("d1", direction, default=None)
    for key in ("start_frame", "end_frame"):
        kw[key] = t.get(key, frame, default=None)
    kw["points"] = t.get("points", array((-1, 3)), default=None)
    kw["rotary_inertia"] = t.get("rotary_inertia", vec3, default=None)
    kw["rotary_inertia_scale"] = t.get("rotary_inertia_scale", _auto_or_number, default=1.0)
    kw["fast_modes"] = t.get("fast_modes", choice(*FAST_MODES), default=None)
    t.done()
    for key in ("start_offset", "end_offset"):
        if kw[key] is None:
            kw[key] = (0.0, 0.0, 0.0)
    line = _wrap(t, "points", lambda: net.add_line(*ends, name=name, **kw))
    _check_first_frame(t, line)


def _check_first_frame(t: Table, line):
    """The director frame of the first element, which the simulation derives from the d1 hint
    or the start frame, must exist: checked here so that the message names this table."""
    seg = np.linalg.norm(np.diff(line.points, axis=0), axis=1)
    if not np.all(np.isfinite(seg)):
        raise t.err("points" if "points" in t.data else "end",
                    "the line's length overflows: coordinates too large (keep them below 1e150)")
    hint = line.d1
    if hint is None and line.start_frame is not None:
        hint = (line.start.frame @ line.start_frame)[:, 0]
    try:
        frame_from_tangent(line.points[1] - line.points[0], hint)
    except ValueError as e:
        raise t.err("d1" if line.d1 is not None else "start_frame", e) from None


def _auto_or_number(v):
    return "auto" if v == "auto" else number(v)


def _wrap(t: Table, fallback_key, build):
    """Run a Net call, turning its ValueError into one naming the file, table and key."""
    try:
        return build()
    except REFUSED as e:
        msg = _one_line(_why(e))
        said = msg.split(":", 1)[1] if ":" in msg else msg
        words = set(re.findall(r"[A-Za-z_0-9]+", said))
        if "points" in t.data and words & {"point", "points"}:
            words = {"points"}
        key = next((k for k in sorted(t.data, key=len, reverse=True) if k in words), fallback_key)
        raise t.err(key, msg) from None


# ---------------------------------------------------------------------- effects
@dataclass(frozen=True)
class EffectKind:
    """One [[effects]] kind: the cosnet class (looked up lazily on the cosnet module) and its
    keys -> converter; a converter ``"node"`` / ``"line"`` resolves a name in the net."""

    cls: str
    keys: dict
    required: tuple = ()


def path_table(v):
    """An inline table of Path keywords: numbers or (nested) lists of numbers."""
    from .drives import PATH_KEYS
    if not isinstance(v, dict):
        raise _Bad(f"must be an inline table of {', '.join(PATH_KEYS)}, got {_show(v)}")
    out = {}
    for k, x in v.items():
        if k not in PATH_KEYS:
            raise _Bad(f"unknown key {k!r} in the path; a path has {', '.join(PATH_KEYS)}")
        if isinstance(x, list):
            try:
                out[k] = np.array(x, dtype=float)
            except (ValueError, TypeError):
                raise _Bad(f"{k} must be numbers or lists of numbers, got {_show(x)}") from None
            if not np.all(np.isfinite(out[k])):
                raise _Bad(f"{k} must be finite, got {_show(x)}")
        else:
            try:
                out[k] = number(x)
            except _Bad as e:
                raise _Bad(f"{k} {e}") from None
    return out


def _number_or_floats(v):
    return floats(v) if isinstance(v, list) else number(v)


def _vec3_or_rows(v):
    return array((-1, 3))(v) if isinstance(v, list) and v and isinstance(v[0], list) else vec3(v)


_AMPLITUDE = {"times": floats, "values": floats, "omega": number, "phase": number}
_JOINT = {"line_a": "line", "end_a": choice("start", "end"), "line_b": "line",
          "end_b": choice("start", "end"), "k": positive, "nu": nonnegative, "rest_offset": vec3}
_JOINT_REQUIRED = ("line_a", "end_a", "line_b", "end_b", "k")
_TORQUE_JOINT = {"kt": positive, "nut": nonnegative}
EFFECTS = {
    "gravity": EffectKind("Gravity", {"g": vec3}),
    "node_load": EffectKind("NodeLoad", {"node": "node", "force": vec3, "torque": vec3, **_AMPLITUDE},
                            ("node",)),
    "line_load": EffectKind("LineLoad", {"line": "line", "force_per_length": vec3,
                                         "torque_per_length": vec3, **_AMPLITUDE}, ("line",)),
    "damping": EffectKind("Damping", {"translational": nonnegative, "rotational": nonnegative},
                          ("translational",)),
    "drive": EffectKind("Drive", {"node": "node", "position": path_table, "rotation": path_table,
                                  "axis": direction, "slide": boolean}, ("node",)),
    "muscle_torque": EffectKind("MuscleTorque", {"line": "line", "moment": _number_or_floats, "points": floats,
                                                 "direction": direction, "period": nonnegative,
                                                 "wavelength": positive, "phase": number,
                                                 "ramp_time": nonnegative}, ("line", "moment")),
    "active_curvature": EffectKind("ActiveCurvature", {"line": "line", "curvature": _vec3_or_rows,
                                                       "points": floats, "period": nonnegative,
                                                       "wavelength": positive, "phase": number,
                                                       "ramp_time": nonnegative}, ("line", "curvature")),
    "contact": EffectKind("Contact", {"k": positive, "gamma": nonnegative, "self_contact": boolean,
                                      "lines": string_list, "self_gap": nonnegative}, ("k",)),
    "spherical_joint": EffectKind("SphericalJoint", _JOINT, _JOINT_REQUIRED),
    "hinge_joint": EffectKind("HingeJoint", {**_JOINT, **_TORQUE_JOINT, "normal": vec3},
                              _JOINT_REQUIRED + ("kt",)),
    "fixed_joint": EffectKind("FixedJoint", {**_JOINT, **_TORQUE_JOINT, "angle": number, "axis": vec3},
                              _JOINT_REQUIRED + ("kt",)),
}


def _ref(t: Table, key, kind, net: Net):
    name = t.get(key, string)
    try:
        return net.node(name) if kind == "node" else net.line(name)
    except KeyError:
        have = [x.name for x in (net.nodes if kind == "node" else net.lines)]
        raise t.err(key, f"unknown {kind} {name!r}; {kind}s are {have}") from None


def _named(t: Table, name, kind, net: Net):
    """The node or line a sub-table [...nodes.NAME] refers to."""
    try:
        return net.node(name) if kind == "node" else net.line(name)
    except KeyError:
        have = [x.name for x in (net.nodes if kind == "node" else net.lines)]
        raise ValueError(f"{t.file}: [{t.name}]: unknown {kind} {name!r}; {kind}s are {have}") from None


def _effect(t: Table, net: Net, units: Units):
    import cosnet
    name = t.get("kind", choice(*EFFECTS))
    kind = EFFECTS[name]
    if t.label.startswith("[[effects]]"):
        t.label += f" ({name})"
    t.expect("kind", *kind.keys)
    kw = {}
    for key, conv in kind.keys.items():
        if key not in t.data and key not in kind.required:
            continue
        kw[key] = _ref(t, key, conv, net) if isinstance(conv, str) else _si(units, key, t.get(key, conv))
        if isinstance(kw[key], dict):   # a path: its keys carry the units of the path they belong to
            from .drives import PATH_DIMS
            dims = PATH_DIMS.get(key, {})
            kw[key] = {k: x * units.factor(*dims[k]) if k in dims else x for k, x in kw[key].items()}
    t.done()
    if kw.get("lines") is not None:
        have = [x.name for x in net.lines]
        for name in kw["lines"]:
            if name not in have:
                raise t.err("lines", f"unknown line {name!r}; lines are {have}")
    cls = getattr(cosnet, kind.cls, None)
    if cls is None:
        raise t.err("kind", f"effect {kind.cls} is not available in this version of cosnet")
    return _wrap(t, "kind", lambda: cls(**kw))


def _effects(top: Table, net: Net, units: Units) -> list:
    if "effects" not in top.data:
        top.used.add("effects")
        return []
    raw = top.data["effects"]
    if isinstance(raw, list):
        top.used.add("effects")
        return [_effect(Table(top.file, f"effects[{i}]", e, label=f"[[effects]] #{i + 1}"), net, units)
                for i, e in enumerate(raw)]
    return [_effect(t, net, units) for _, t in top.tables("effects")]


# ---------------------------------------------------------------------- initial conditions
@dataclass
class Initial:
    """[initial] (SI, lab frame): a rigid motion of the whole net (velocity, angular_velocity
    about center, default the centre of mass), per-node and per-line velocities, and a seeded
    random velocity perturbation of the free vertices."""

    velocity: np.ndarray | None = None
    angular_velocity: np.ndarray | None = None
    center: np.ndarray | None = None
    nodes: dict = field(default_factory=dict)   # Node -> (velocity or None, angular_velocity or None)
    lines: dict = field(default_factory=dict)   # Line -> (velocity, profile)
    perturbation: float = 0.0
    seed: int = 0

    def apply(self, sim, where="[initial]"):
        """Set the simulation's velocities (call before running)."""
        from .flatten import matrix_from_quat
        m, s = sim.model, sim.state
        if self.velocity is not None or self.angular_velocity is not None:
            if any(n.fixed_position or n.locked_axes.any() for n in sim.net.nodes):
                raise ValueError(f"{where} velocity: a rigid motion of the whole net needs a net "
                                 f"without fixed nodes or locked axes")
            v0 = np.zeros(3) if self.velocity is None else self.velocity
            w = np.zeros(3) if self.angular_velocity is None else self.angular_velocity
            c = _centre_of_mass(m, s) if self.center is None else self.center
            s.v[:] = v0 + np.cross(w, s.x - c)
            s.w[:] = np.einsum("eji,j->ei", matrix_from_quat(s.q), w)
            s.node_v[:] = v0 + np.cross(w, s.node_x - c)
            s.node_w[:] = np.einsum("nji,j->ni", matrix_from_quat(s.node_q), w)
        for node, (v, w) in self.nodes.items():
            if v is not None:
                if node.fixed_position:
                    raise ValueError(f"{where} nodes.{node.name} velocity: node {node.name!r} is fixed")
                sim.node_velocity(node)[:] = v
            if w is not None:
                wb = matrix_from_quat(s.node_q[node.index]).T @ w
                if np.any((m.node_locked[node.index] > 0) & (np.abs(wb) > 1e-12 * np.abs(w).max())):
                    raise ValueError(f"{where} nodes.{node.name} angular_velocity: it turns node "
                                     f"{node.name!r} about a locked (fixed) axis")
                sim.node_angular_velocity(node)[:] = np.where(m.node_locked[node.index] > 0, 0.0, wb)
        for line, (v, profile) in self.lines.items():
            _line_velocity(sim, line, v, profile)
        if self.perturbation > 0:
            free = m.vertex_inv_mass > 0
            rng = np.random.default_rng(self.seed)
            s.v[free] += self.perturbation * rng.standard_normal((int(free.sum()), 3))


def _line_velocity(sim, line, v, profile):
    """Set the interior vertex velocities of a line: ``uniform`` v, or ``half_sine``
    v sin(pi s / L) with every element turning with its tangent (w = t x dv / |t|^2), a smooth
    bending perturbation whose ends stay at rest."""
    from .flatten import matrix_from_quat
    vel = sim.line_velocities(line)
    if profile == "uniform":
        vel[1:-1] = v
        return
    x = sim.line_positions(line)
    n = x.shape[0] - 1
    shape = np.sin(np.pi * np.arange(n + 1) / n)[:, None] * v
    vel[1:-1] = shape[1:-1]
    seg = np.diff(x, axis=0)
    w_lab = np.cross(seg, np.diff(shape, axis=0)) / np.einsum("ij,ij->i", seg, seg)[:, None]
    es = sim._erange(line)
    sim.state.w[es] = np.einsum("eji,ej->ei", matrix_from_quat(sim.state.q[es]), w_lab)


def _centre_of_mass(m, s) -> np.ndarray:
    free = m.vertex_inv_mass > 0
    mv = m.vertex_mass[free]
    mn = np.where(np.isfinite(m.node_mass), m.node_mass, 0.0)
    total = mv.sum() + mn.sum()
    return (mv @ s.x[free] + mn @ s.node_x) / total


def _initial(t: Table | None, net: Net, units: Units) -> Initial:
    init = Initial()
    if t is None:
        return init
    for key in ("velocity", "angular_velocity", "center"):
        setattr(init, key, _si(units, key, t.get(key, vec3, default=None)))
    rigid = [k for k in ("velocity", "angular_velocity") if getattr(init, k) is not None]
    if rigid and any(n.fixed_position or n.locked_axes.any() for n in net.nodes):
        raise t.err(rigid[0], "a rigid motion of the whole net needs a net without fixed nodes "
                              "or locked axes")
    for name, nt in t.tables("nodes"):
        node = _named(nt, name, "node", net)
        v, w = (_si(units, k, nt.get(k, vec3, default=None)) for k in ("velocity", "angular_velocity"))
        nt.done()
        if v is not None and node.fixed_position:
            raise nt.err("velocity", f"node {node.name!r} is fixed")
        if w is not None and np.any(node.locked_axes & (np.abs(node.frame.T @ w) > 1e-12 * np.abs(w).max())):
            raise nt.err("angular_velocity", f"it turns node {node.name!r} about a locked (fixed) axis")
        init.nodes[node] = (v, w)
    for name, lt in t.tables("lines"):
        lt.expect("velocity", "profile")
        line = _named(lt, name, "line", net)
        init.lines[line] = (_si(units, "velocity", lt.get("velocity", vec3)),
                            lt.get("profile", choice("uniform", "half_sine"), default="uniform"))
        lt.done()
    p = t.sub("perturbation", optional=True)
    if p is not None:
        p.expect("velocity", "seed")
        init.perturbation = p.get("velocity", nonnegative) * units.factor(1, 0, -1)
        init.seed = p.get("seed", seed, default=0)
        p.done()
    t.done()
    return init


# ---------------------------------------------------------------------- run settings
def _probe(t: Table, text, net: Net) -> Probe:
    try:
        return parse_probe(text, net)
    except ValueError as e:
        raise t.err("probes", str(e)) from None


@dataclass
class RunSettings:
    """[run] (SI): end time ``until``, ``dt`` (None = the estimated stable step), ``stepper``,
    ``output_interval`` (default until / 50), ``probes``, ``force_dt``, ``limits`` (False:
    skip the resource limits of cosnet.limits) and ``threads`` (None: chosen by the
    simulation, see Simulation)."""

    until: float
    dt: float | None = None
    stepper: str = "verlet"
    output_interval: float | None = None
    probes: list = field(default_factory=list)
    force_dt: bool = False
    limits: bool = True
    threads: int | None = None
    fast_modes: str = "resolve"

    @property
    def interval(self) -> float:
        return self.until / 50.0 if self.output_interval is None else self.output_interval


def thread_count(v) -> int:
    """[run] threads: an integer from 1 to numba's thread count."""
    from .simulation import check_threads
    try:
        return check_threads(v)
    except ValueError as e:
        raise _Bad(str(e)) from None


def _run(t: Table, net: Net, units: Units) -> RunSettings:
    t.expect("until", "dt", "stepper", "output_interval", "probes", "force_dt", "limits", "threads",
             "fast_modes")
    sec = units.factor(0, 0, 1)
    until = t.get("until", positive) * sec
    dt = t.get("dt", auto_or_positive, default="auto")
    out = t.get("output_interval", positive, default=None)
    run = RunSettings(until, None if dt == "auto" else dt * sec,
                      t.get("stepper", choice("verlet", "pefrl"), default="verlet"),
                      None if out is None else out * sec,
                      [_probe(t, p, net) for p in t.get("probes", string_list, default=[])],
                      t.get("force_dt", boolean, default=False), t.get("limits", boolean, default=True),
                      t.get("threads", thread_count, default=None),
                      t.get("fast_modes", choice(*FAST_MODES), default="resolve"))
    if run.output_interval is not None and run.output_interval > until:
        raise t.err("output_interval", f"must not exceed until = {until:g} s")
    if run.output_interval is not None and run.dt is not None and run.output_interval < run.dt:
        raise t.err("output_interval", f"{run.output_interval:g} s is shorter than dt = {run.dt:g} s "
                                       f"(frames would repeat); give at least dt")
    t.done()
    return run


# ---------------------------------------------------------------------- the scene
@dataclass
class Scene:
    """A loaded scene: ``net``, ``effects`` (cosnet effect objects), ``run`` (RunSettings),
    ``initial`` (Initial), the ``scale`` it was written in (or None), ``path`` and ``title``."""

    path: Path
    title: str
    net: Net
    effects: list
    run: RunSettings
    initial: Initial
    scale: Scale | None = None

    def simulation(self, **overrides):
        """Build ``cosnet.Simulation`` with the scene's effects, stepper and dt and apply the
        initial conditions; keyword overrides go to the Simulation (e.g. ``dt=...``)."""
        from .simulation import Simulation
        kw = dict(effects=self.effects, stepper=self.run.stepper, dt=self.run.dt,
                  force_dt=self.run.force_dt, threads=self.run.threads,
                  fast_modes=self.run.fast_modes)
        kw.update(overrides)
        try:
            with np.errstate(all="ignore"):   # a net that overflows is refused below, in one line
                sim = Simulation(self.net, **kw)
        except REFUSED as e:
            msg = _one_line(_why(e))
            key = next((k for k in ("dt", "stepper", "fast_modes") if re.search(rf"\b{k}\b", msg)), None)
            where = f"[run] {key}: " if key else ""
            raise ValueError(f"{self.path}: {where}{msg}") from None
        self.initial.apply(sim, f"{self.path}: [initial]")
        return sim

    def describe_effects(self) -> list[str]:
        return [e.describe() for e in self.effects]


def read_toml(path) -> dict:
    """The parsed TOML of a scene file; an unreadable or malformed file is a ValueError."""
    try:
        with open(path, "rb") as f:
            return tomllib.load(f)
    except OSError as e:
        raise ValueError(f"{path}: cannot read the scene file ({e.strerror})") from None
    except tomllib.TOMLDecodeError as e:
        raise ValueError(f"{path}: not valid TOML: {_one_line(e)}") from None
    except UnicodeDecodeError as e:
        line = e.object[:e.start].count(b"\n") + 1
        raise ValueError(f"{path}: not UTF-8 text: byte {e.object[e.start]:#04x} in line {line} "
                         f"(TOML files are UTF-8)") from None
    except RecursionError:
        raise ValueError(f"{path}: arrays or tables nested too deeply to read") from None


def load_scene(path, limits: bool = True) -> Scene:
    """Read a TOML scene file and return a validated Scene. ``limits=False`` skips the
    resource limits (as ``[run] limits = false`` in the file does)."""
    path = Path(path)
    return build_scene(read_toml(path), path, limits=limits)


def build_scene(data: dict, path="<scene>", limits: bool = True) -> Scene:
    """Build a Scene from already-parsed TOML data (``path`` only appears in messages)."""
    path = Path(path)
    try:
        # extreme numbers overflow in checks that then refuse them: one message, no warnings
        with np.errstate(all="ignore"):
            return _build_scene(data, path, limits)
    except RecursionError:
        raise ValueError(f"{path}: values nested too deeply") from None
    except ArithmeticError as e:
        raise ValueError(f"{path}: {_why(e)}") from None


def _check_net_size(top: Table, data: dict):
    """Refuse a net above the element limit before building it (which would take minutes and
    gigabytes first): named by its largest line."""
    lines = data.get("lines")
    if not isinstance(lines, dict):
        return
    counts = {name: t.get("elements") for name, t in lines.items() if isinstance(t, dict)}
    counts = {n: c for n, c in counts.items() if isinstance(c, int) and not isinstance(c, bool) and c > 0}
    if counts:
        big = max(counts, key=counts.get)
        check_elements(sum(counts.values()), f"{top.file}: [lines.{quote_key(big)}] elements")


def _build_scene(data: dict, path: Path, limits: bool) -> Scene:
    top = Table(str(path), "", data)
    top.done(TOP_KEYS)
    run_data = data.get("run")
    if limits and not (isinstance(run_data, dict) and run_data.get("limits") is False):
        _check_net_size(top, data)
    title = top.get("title", string, default=path.stem)
    top.get("description", string, default="")
    scale = None
    st = top.sub("scale", optional=True)
    if st is not None:
        st.expect("time", "length", "area", "density", "torque")
        kw = {k: st.get(k, positive) for k in ("time", "length", "area", "density")}
        kw["torque"] = st.get("torque", positive, default=None)
        st.done()
        try:
            scale = Scale(**kw)
        except REFUSED as e:
            raise st.err("torque", _why(e)) from None
    units = Units(scale)
    materials = {n: _material(t, n) for n, t in top.tables("materials")}
    sections = {n: _section(t) for n, t in top.tables("sections")}
    net = Net()
    for name, t in top.tables("nodes"):
        _node(t, net, name)
    for name, t in top.tables("lines"):
        _line(t, net, name, materials, sections)
    if not net.nodes:
        raise top.err("nodes", "the scene needs at least one [nodes.NAME] table")
    try:
        net.validate()
    except REFUSED as e:
        msg = _one_line(_why(e))
        name = msg.split("'")[1] if msg.startswith("node '") else ""
        raise ValueError(f"{path}: [nodes.{name}] mass: {msg}") from None
    if scale is not None:
        net = scale.physical(net)
    effects = _effects(top, net, units)
    initial = _initial(top.sub("initial", optional=True), net, units)
    run = _run(top.sub("run"), net, units)
    return Scene(path, title, net, effects, run, initial, scale)
