"""Checkpoints: the whole state of a simulation in one .npz file, with a fingerprint of the
model it belongs to, so that a state is never restored into a different net, material, set of
effects, step or stepper.

The fingerprint hashes every array of the flattened Model, per line (its vertices, elements
and ends), per node and for the net's structure, in three groups (net geometry,
materials/stiffness, masses); each effect's kind and bound parameters; dt and the stepper.
A mismatch is refused with one line naming the groups (and lines or nodes) that differ.
"""

from __future__ import annotations

import contextlib
import hashlib
import os
import signal
import threading

import numpy as np

from ..kernels.checksum import FNV_OFFSET, hash_segments, scan_state
from ..kernels.layout import Model

FORMAT = 1
GROUPS = ("net geometry", "materials/stiffness", "masses")
GEOMETRY, STIFFNESS, MASSES = range(3)
# Model field -> (group, what its rows are); a field not listed is hashed whole as geometry
FIELDS = {
    "line_vertex_offsets": (GEOMETRY, "net"), "line_element_offsets": (GEOMETRY, "net"),
    "vertex_mass": (MASSES, "vertex"), "vertex_inv_mass": (MASSES, "vertex"),
    "vertex_inv_mass3": (MASSES, "vertex"),
    "element_rest_length": (GEOMETRY, "element"), "element_inv_rest_length": (GEOMETRY, "element"),
    "element_stiffness": (STIFFNESS, "element"), "element_inertia": (MASSES, "element"),
    "element_inv_inertia": (MASSES, "element"),
    "voronoi_rest_length": (GEOMETRY, "vertex"), "voronoi_inv_rest_length": (GEOMETRY, "vertex"),
    "voronoi_stiffness": (STIFFNESS, "vertex"), "voronoi_rest_curvature": (GEOMETRY, "vertex"),
    "attach_node": (GEOMETRY, "end"), "attach_vertex": (GEOMETRY, "end"),
    "attach_element": (GEOMETRY, "end"), "attach_offset": (GEOMETRY, "end"),
    "attach_frame": (GEOMETRY, "end"),
    "node_attach_offsets": (GEOMETRY, "net"), "node_attach_list": (GEOMETRY, "net"),
    "node_mass": (MASSES, "node"), "node_inv_mass": (MASSES, "node"), "node_own_mass": (MASSES, "node"),
    "node_inertia": (MASSES, "node"), "node_inv_inertia": (MASSES, "node"),
    "node_locked": (MASSES, "node"), "node_com_offset": (MASSES, "node"),
    "node_principal": (MASSES, "node"),
}


def _words(a: np.ndarray) -> tuple[np.ndarray, int]:
    """(a's values as C-ordered uint64 words, words per row)."""
    if a.dtype.itemsize != 8:
        a = a.astype(np.int64 if a.dtype.kind in "biu" else np.float64)
    a = np.ascontiguousarray(a)
    width = a.size // a.shape[0] if a.ndim and a.shape[0] else 1
    return a.reshape(-1).view(np.uint64), width


def _effect_hash(effect, params) -> int:
    h = hashlib.blake2b(type(effect).__name__.encode(), digest_size=8)
    for name, value in zip(params._fields, params):
        h.update(name.encode())
        if isinstance(value, np.ndarray):
            h.update(f"{value.dtype.str}{value.shape}".encode())
            h.update(np.ascontiguousarray(value).tobytes())
        else:
            h.update(repr(value).encode())
    return int.from_bytes(h.digest(), "little")


def fingerprint(sim) -> dict:
    """The model's fingerprint: per-line (nl, 3), per-node (nn, 3) and net-wide (3,) hashes
    of the Model arrays by group, and one hash per effect (with its description)."""
    m = sim.model
    nl, nn = m.line_vertex_offsets.shape[0] - 1, m.node_mass.shape[0]
    rows = {"vertex": m.line_vertex_offsets, "element": m.line_element_offsets,
            "end": 2 * np.arange(nl + 1, dtype=np.int64), "node": np.arange(nn + 1, dtype=np.int64)}
    tables = {"line": np.full((len(GROUPS), nl), FNV_OFFSET), "node": np.full((len(GROUPS), nn), FNV_OFFSET),
              "net": np.full((len(GROUPS), 1), FNV_OFFSET)}
    for tag, name in enumerate(Model._fields):
        a = getattr(m, name)
        group, kind = FIELDS.get(name, (GEOMETRY, "net"))
        words, width = _words(a)
        if kind == "net":
            offsets, table = np.array([0, a.shape[0] if a.ndim else 1], np.int64), tables["net"]
        else:
            offsets, table = np.asarray(rows[kind], np.int64), tables["node" if kind == "node" else "line"]
        hash_segments(words, width, offsets, tag, table[group])
    effects = [_effect_hash(e, p) for e, p in zip(sim.effects, sim.records)]
    return {"fp_lines": tables["line"].T.copy(), "fp_nodes": tables["node"].T.copy(),
            "fp_net": tables["net"][:, 0].copy(), "fp_effects": np.array(effects, dtype=np.uint64),
            "fp_effect_names": np.array([e.describe() for e in sim.effects] or [""])[: len(effects)]}


def _named(kind: str, names: list) -> str:
    shown = ", ".join(f"{kind} {n!r}" for n in names[:3])
    return shown + (f" and {len(names) - 3} more" if len(names) > 3 else "")


def _effect_change(now: str, was: str) -> str:
    """An effect whose hash differs, as a phrase: its description then and now, or, where they
    read the same, that its record's arrays differ (a parameter the description leaves out, or
    a checkpoint written by a version that laid the record out otherwise)."""
    return f"{now} was {was}" if now != was else f"{now}: its record's arrays differ"


def differences(sim, saved) -> list[str]:
    """What differs between ``sim`` and the fingerprint, dt and stepper in ``saved`` (a
    mapping of arrays as written by save), each as a short phrase; empty if nothing."""
    now = sim.fingerprint
    out = []
    nl, nn = now["fp_lines"].shape[0], now["fp_nodes"].shape[0]
    if saved["fp_lines"].shape != now["fp_lines"].shape or saved["fp_nodes"].shape != now["fp_nodes"].shape:
        out.append(f"net geometry ({saved['fp_lines'].shape[0]} lines and {saved['fp_nodes'].shape[0]} "
                   f"nodes in the checkpoint, {nl} and {nn} here)")
    else:
        for g, group in enumerate(GROUPS):
            where = []
            if saved["fp_net"][g] != now["fp_net"][g]:
                where.append("net structure")
            lines = np.flatnonzero(saved["fp_lines"][:, g] != now["fp_lines"][:, g])
            nodes = np.flatnonzero(saved["fp_nodes"][:, g] != now["fp_nodes"][:, g])
            if lines.size:
                where.append(_named("line", [sim.net.lines[i].name for i in lines]))
            if nodes.size:
                where.append(_named("node", [sim.net.nodes[i].name for i in nodes]))
            if where:
                out.append(f"{group} ({'; '.join(where)})")
    old, new = saved["fp_effects"], now["fp_effects"]
    if old.shape != new.shape:
        out.append(f"effects ({old.shape[0]} in the checkpoint, {new.shape[0]} here)")
    else:
        changed = np.flatnonzero(old != new)
        if changed.size:
            names = saved["fp_effect_names"]
            out.append("effects (" + ", ".join(_effect_change(sim.effects[i].describe(), str(names[i]))
                                               for i in changed[:3]) + ")")
    if str(saved["stepper"]) != sim.stepper:
        out.append(f"stepper ({saved['stepper']} in the checkpoint, {sim.stepper} here)")
    if float(saved["dt"]) != sim.dt:
        out.append(f"dt ({float(saved['dt']):.9g} s in the checkpoint, {sim.dt:.9g} s here)")
    return out


def _effect_arrays(sim) -> dict:
    """The effects' changing arrays (friction anchors), keyed effect<i>_<name>."""
    return {f"effect{i}_{k}": a for i, e in enumerate(sim.effects) for k, a in e.state_arrays(sim).items()}


def save(sim, path):
    """Write the state, step count, dt, stepper and fingerprint of ``sim`` to ``path``
    atomically: the previous file stays whole until the new one is complete, and no temporary
    file is left behind on failure (a full disk). The state must pass the watch first."""
    sim.check()
    tmp = f"{path}.tmp.npz"
    try:
        with _interrupt_deferred():
            np.savez(tmp, format=FORMAT, steps=sim.steps, dt=sim.dt, stepper=sim.stepper,
                     **sim.fingerprint, **sim.state._asdict(), **_effect_arrays(sim))
            os.replace(tmp, path)
    except BaseException:
        if os.path.exists(tmp):
            os.unlink(tmp)
        raise


@contextlib.contextmanager
def _interrupt_deferred():
    """Hold a Ctrl-C back until the block is done, then raise it. The checkpoint is short and
    a KeyboardInterrupt inside zipfile's constructor leaves an object whose finaliser fails at
    exit, printing a second error after the run's own last line."""
    if (threading.current_thread() is not threading.main_thread()
            or signal.getsignal(signal.SIGINT) is not signal.default_int_handler):
        yield
        return
    caught = []
    previous = signal.signal(signal.SIGINT, lambda signum, frame: caught.append(signum))
    try:
        yield
    finally:
        signal.signal(signal.SIGINT, previous)
    if caught:
        raise KeyboardInterrupt


def load(sim, path):
    """Restore a state written by save into ``sim``, bit-exactly, after checking that it was
    written for the same model, effects, dt and stepper. Nothing is changed on refusal."""
    names = list(sim.state._fields)
    try:
        with np.load(path) as data:     # an .npy file or a pickle is refused here too
            saved = {k: data[k] for k in data.files}
    except Exception as e:  # whatever a damaged file makes the decoder raise, memory included
        raise ValueError(f"checkpoint {path}: unreadable, truncated or corrupted "
                         f"({type(e).__name__}: {e})".replace("\n", " ")) from None
    if "format" not in saved or "fp_lines" not in saved:
        raise ValueError(f"checkpoint {path}: has no model fingerprint (written by an older "
                         f"cosnet), so it cannot be matched to this model; start afresh")
    missing = sorted(set(names) - set(saved))
    if missing:
        raise ValueError(f"checkpoint {path}: lacks the state array(s) {', '.join(missing)}")
    try:
        diff = differences(sim, saved)
        steps = int(saved["steps"])
    except (IndexError, KeyError, TypeError, ValueError, AttributeError) as e:
        raise ValueError(f"checkpoint {path}: its fingerprint is damaged ({type(e).__name__})") from None
    if diff:
        raise ValueError(f"checkpoint {path}: written for a different model: {'; '.join(diff)}")
    for name, arr in sim.state._asdict().items():
        if saved[name].shape != arr.shape or saved[name].dtype != arr.dtype:
            raise ValueError(f"checkpoint {path}: {name} has shape {saved[name].shape}, "
                             f"this net needs {arr.shape}")
    restored = sim.state._make(saved[n] for n in names)
    if scan_state(restored)[1] is not None:
        raise ValueError(f"checkpoint {path}: holds non-finite values")
    effect_arrays = _effect_arrays(sim)
    for key, arr in effect_arrays.items():
        if key not in saved or saved[key].shape != arr.shape or saved[key].dtype != arr.dtype:
            raise ValueError(f"checkpoint {path}: lacks the effect state {key} (shape {arr.shape})")
        if not np.all(np.isfinite(saved[key])):
            raise ValueError(f"checkpoint {path}: holds non-finite values in {key}")
    for name, arr in sim.state._asdict().items():
        arr[...] = saved[name]
    for key, arr in effect_arrays.items():
        arr[...] = saved[key]
    sim.steps = steps
    return sim
