"""VTK time series written while a simulation runs, and read back for analysis.

A series directory holds, per output frame k,

    lines_{k:06d}.vtu   every line as a chain of 2-point segments (its vertices in order),
                        cell data line_id and element, point data line_id, velocity, d1, d2,
                        d3, force, torque (lab), strain, curvature (director frame) from
                        ``sim.line_fields`` (SI units)
    nodes_{k:06d}.vtu   every node as a vertex cell at its reference point, point data
                        node_id, velocity (of the reference point), angular_velocity (lab),
                        d1, d2, d3 (its frame D(nu))

plus ``series.pvd`` (the ParaView collection: time, part 0 = lines, part 1 = nodes), rewritten
atomically after every frame so that a killed run leaves a valid series, and ``meta.json``
(line and node names, per-line vertex counts, node masses). Frames are written through meshio (which
has no polyline cell, hence segments); memory does not grow with the number of frames.
"""

from __future__ import annotations

import json
import os
import re
import xml.etree.ElementTree as ET
from dataclasses import dataclass
from pathlib import Path

import meshio
import numpy as np

from .fields import ENERGY_COLUMNS, FIELD_UNITS  # noqa: F401  (the output's names, kept importable here)

LINE_FIELDS = ("velocity", "d1", "d2", "d3", "force", "torque", "strain", "curvature")
NODE_FIELDS = ("velocity", "angular_velocity", "d1", "d2", "d3", "reaction", "reaction_torque")
PVD = "series.pvd"
META = "meta.json"
PROBES = "probes.csv"
ENERGY = "energy.csv"


def frame_files(k: int) -> tuple[str, str]:
    return f"lines_{k:06d}.vtu", f"nodes_{k:06d}.vtu"


def replace_atomically(path: Path, write):
    """Create ``path`` through ``write(tmp)`` on a temporary file renamed over it: the file
    is either its previous version or the new one, whole; on failure (a full disk) the
    temporary file is removed and the error raised."""
    tmp = path.with_name(path.name + ".tmp")
    try:
        write(tmp)
        os.replace(tmp, path)
    except BaseException:
        tmp.unlink(missing_ok=True)
        raise


def _atomic_write(path: Path, text: str):
    def write(tmp):
        with open(tmp, "w") as f:
            f.write(text)
            f.flush()
            os.fsync(f.fileno())
    replace_atomically(path, write)


class SeriesWriter:
    """Write a VTK time series of a simulation into ``directory``.

    ``write(sim)`` appends one frame at ``sim.time``. ``resume_after=k`` keeps the frames
    0..k of an existing series (and overwrites later ones) so a resumed run continues it.
    ``shapes`` (the effects' Effect.drawn_shapes) go to meta.json for pictures.
    """

    def __init__(self, directory, net, resume_after: int | None = None, shapes=()):
        self.dir = Path(directory)
        if self.dir.exists() and not self.dir.is_dir():
            raise ValueError(f"{self.dir}: exists and is not a directory")
        self.dir.mkdir(parents=True, exist_ok=True)
        self.net = net
        counts = [l.elements + 1 for l in net.lines]
        self._offsets = np.concatenate([[0], np.cumsum(counts)]).astype(np.int64)
        seg = [np.column_stack([np.arange(a, b - 1), np.arange(a + 1, b)])
               for a, b in zip(self._offsets[:-1], self._offsets[1:])]
        self._segments = np.concatenate(seg).astype(np.int64) if seg else np.zeros((0, 2), np.int64)
        self._seg_line = np.repeat(np.arange(len(counts)), [c - 1 for c in counts]).astype(np.int32)
        self._seg_elem = np.concatenate([np.arange(c - 1) for c in counts]).astype(np.int32) \
            if counts else np.zeros(0, np.int32)
        self._vert_line = np.repeat(np.arange(len(counts)), counts).astype(np.int32)
        self._radius = np.concatenate([[l.section_at(s).radius for s in np.linspace(0, 1, l.elements + 1)]
                                       for l in net.lines]) if net.lines else np.zeros(0)
        self._nodes_pts = np.zeros((len(net.nodes), 3))
        self._node_buf = {k: np.zeros((len(net.nodes), 3)) for k in NODE_FIELDS}
        meta = {"lines": [l.name for l in net.lines], "nodes": [n.name for n in net.nodes],
                "vertices": counts, "node_mass": [str(n.mass) for n in net.nodes], "format": 1,
                "shapes": list(shapes)}
        _atomic_write(self.dir / META, json.dumps(meta, ensure_ascii=False, indent=1))
        self.times: list[float] = []
        if resume_after is not None:
            if not (self.dir / PVD).is_file():
                raise ValueError(f"{self.dir / PVD}: missing, so there is no series to resume")
            self.times = [t for t, _ in read_pvd(self.dir / PVD)][: resume_after + 1]
            if len(self.times) != resume_after + 1:
                raise ValueError(f"{self.dir / PVD}: has fewer than {resume_after + 1} frames to resume from")
        else:
            self._write_pvd()

    @property
    def frames(self) -> int:
        return len(self.times)

    def write(self, sim) -> int:
        """Write the current state as the next frame, once it has passed the instability
        watch (``sim.check()``); return its index. Each file is written whole or not at all."""
        sim.check()
        k = len(self.times)
        lines_file, nodes_file = frame_files(k)
        f = sim.net_fields()   # vertices in line order, as self._offsets
        mesh = meshio.Mesh(f["position"], [("line", self._segments)],
                           point_data={"line_id": self._vert_line, "radius": self._radius,
                                       **{k: np.ascontiguousarray(f[k]) for k in LINE_FIELDS}},
                           cell_data={"line_id": [self._seg_line], "element": [self._seg_elem]})
        replace_atomically(self.dir / lines_file, lambda tmp: mesh.write(tmp, file_format="vtu", binary=True))
        nb = self._node_buf
        for node in self.net.nodes:
            i = node.index
            self._nodes_pts[i] = sim.node_position(node)
            for name, value in node_point_fields(sim, node).items():
                nb[name][i] = value
        ids = np.arange(len(self.net.nodes), dtype=np.int32)
        nodes = meshio.Mesh(self._nodes_pts, [("vertex", ids[:, None].astype(np.int64))],
                            point_data={"node_id": ids, **nb}, cell_data={"node_id": [ids]})
        replace_atomically(self.dir / nodes_file, lambda tmp: nodes.write(tmp, file_format="vtu", binary=True))
        self.times.append(float(sim.time))
        self._write_pvd()
        return k

    def _write_pvd(self):
        """Rewrite the ParaView collection listing every frame written so far (atomically)."""
        # a generator: a list of every frame's entries, made anew per frame, grew the peak
        write_collection(self.dir / PVD, ((t, p, name) for k, t in enumerate(self.times)
                                          for p, name in enumerate(frame_files(k))))


def drawn_shapes(sim) -> list:
    """The solid shapes of sim's effects (Effect.drawn_shapes), for meta.json."""
    return [shape for e in sim.effects for shape in e.drawn_shapes()]


def write_collection(path: Path, datasets) -> None:
    """Write a ParaView collection (.pvd) listing ``datasets``, (time, part, file name)
    each, atomically."""
    root = ET.Element("VTKFile", type="Collection", version="0.1", byte_order="LittleEndian")
    coll = ET.SubElement(root, "Collection")
    for t, part, name in datasets:
        ET.SubElement(coll, "DataSet", timestep=repr(t), group="", part=str(part), file=name)
    ET.indent(root)
    _atomic_write(path, ET.tostring(root, encoding="unicode", xml_declaration=True) + "\n")


def node_point_fields(sim, node) -> dict:
    """NODE_FIELDS of a node, each (3,): velocity of its reference point, angular velocity
    (lab), its frame's d1, d2, d3 and the force and torque its drive supplies (zero for a node
    without a drive, sim.reaction)."""
    r = sim.node_rotation(node)
    x = sim.node_position(node)
    w_lab = r @ _node_body_w(sim, node)
    v = sim.node_velocity(node) + np.cross(w_lab, x - sim.state.node_x[node.index])
    force, torque = sim.reaction(node)
    return {"velocity": v, "angular_velocity": w_lab, "d1": r[:, 0], "d2": r[:, 1], "d3": r[:, 2],
            "reaction": force, "reaction_torque": torque}


def _node_body_w(sim, node) -> np.ndarray:
    """Angular velocity of the node in its own body frame D(nu)."""
    from ..core.rotations import matrix_from_quat
    p = matrix_from_quat(sim.model.node_principal[node.index])  # user body -> principal
    return p @ sim.node_angular_velocity(node)


def read_pvd(path) -> list[tuple[float, int]]:
    """(time, frame index) of each frame listed in a series.pvd; ValueError (one line) if it
    cannot be read as one."""
    try:
        root = ET.parse(path).getroot()
    except (ET.ParseError, OSError) as e:
        raise ValueError(f"{path}: not a readable ParaView collection ({e})") from None
    out = {}
    for ds in root.iter("DataSet"):
        m = re.search(r"_(\d+)\.vtu$", ds.get("file", ""))
        if m:
            try:
                out[int(m.group(1))] = float(ds.get("timestep", ""))
            except (TypeError, ValueError):
                raise ValueError(f"{path}: frame {m.group(1)} has no valid timestep") from None
    return [(out[k], k) for k in sorted(out)]


class UnknownNameError(KeyError, ValueError):
    """A line, node or field name that a series does not hold; the message lists those it
    does (a KeyError for lookups, a ValueError for the command line's one-line errors)."""

    def __str__(self):
        return str(self.args[0]) if self.args else ""


def _known(kind: str, name, valid) -> None:
    if name not in valid:
        raise UnknownNameError(f"unknown {kind} {name!r}; the series has {', '.join(map(str, valid)) or 'none'}")


@dataclass
class Output:
    """A series read back: ``times`` (nf,), names of lines and nodes, and accessors that load
    frames from disk on demand."""

    directory: Path
    times: np.ndarray
    line_names: list
    node_names: list
    vertices: list

    def frame(self, k: int) -> dict:
        """Frame k: {"lines": {name: {field: (n+1, 3) array, "position": ...}},
        "nodes": {field: (nn, 3) array, "position": ...}}."""
        if not 0 <= k < len(self.times):
            raise IndexError(f"frame {k}: the series has frames 0..{len(self.times) - 1}")
        lf, nf = frame_files(k)
        lm = meshio.read(self.directory / lf)
        nm = meshio.read(self.directory / nf)
        lines, start = {}, 0
        for name, c in zip(self.line_names, self.vertices):
            sl = slice(start, start + c)
            lines[name] = {"position": lm.points[sl], **{f: lm.point_data[f][sl] for f in LINE_FIELDS}}
            start += c
        nodes = {"position": nm.points, **{f: nm.point_data[f] for f in NODE_FIELDS}}
        return {"time": float(self.times[k]), "lines": lines, "nodes": nodes}

    def line_series(self, name: str, field: str = "position") -> np.ndarray:
        """(nf, n+1, 3) history of one field of a line."""
        _known("line", name, self.line_names)
        _known("line field", field, ("position",) + LINE_FIELDS)
        return np.stack([self.frame(k)["lines"][name][field] for k in range(len(self.times))])

    def probes(self) -> dict:
        """{probe: (nf, 3)} from probes.csv, the probes named as written ("tip",
        "rod@0.5:force"); {} for a run without probes."""
        header, rows = _csv(self.directory / PROBES)
        names = [c[:-2] for c in header[2::3]]
        return {name: rows[:, 2 + 3 * j:5 + 3 * j] for j, name in enumerate(names)}

    def probe_times(self) -> np.ndarray:
        """(nf,) the times of the rows of probes.csv."""
        return _csv(self.directory / PROBES)[1][:, 1]

    def energy(self) -> dict:
        """{"time": (nf,), and each of ENERGY_COLUMNS: (nf,)} from energy.csv (J)."""
        header, rows = _csv(self.directory / ENERGY)
        return {name: rows[:, j] for j, name in enumerate(header) if name != "frame"}

    def plot(self, *probes, energy: bool = False):
        """A matplotlib Figure: a panel of x, y, z over time for each probe named (all of
        probes.csv when none is), and with ``energy`` the energy budget (cosnet.output.plots)."""
        from .plots import plot_output
        return plot_output(self, probes, energy)

    def node_series(self, name: str, field: str = "position") -> np.ndarray:
        """(nf, 3) history of one field of a node."""
        _known("node", name, self.node_names)
        _known("node field", field, ("position",) + NODE_FIELDS)
        i = self.node_names.index(name)
        return np.stack([self.frame(k)["nodes"][field][i] for k in range(len(self.times))])


def _csv(path: Path) -> tuple[list, np.ndarray]:
    """(header, rows (n, columns)) of a CSV file the recorder wrote; ValueError naming it."""
    try:
        text = path.read_text().splitlines()
    except OSError:
        raise ValueError(f"{path}: missing (a run writes it at every frame)") from None
    header = text[0].split(",") if text else []
    try:
        rows = np.array([[float(x) for x in ln.split(",")] for ln in text[1:] if ln], dtype=float)
    except ValueError:
        raise ValueError(f"{path}: not the numbers a run writes") from None
    if header[:2] != ["frame", "time"] or (rows.size and rows.shape[1] != len(header)):
        raise ValueError(f"{path}: not the table a run writes (frame, time, ...)")
    return header, rows.reshape(-1, len(header))


def read_output(directory) -> Output:
    """Open a series written by SeriesWriter (``cosnet run``) for analysis."""
    d = Path(directory)
    if not (d / PVD).exists() or not (d / META).exists():
        raise ValueError(f"{d}: not a cosnet output directory (no {PVD} / {META})")
    meta = json.loads((d / META).read_text())
    frames = read_pvd(d / PVD)
    if [k for _, k in frames] != list(range(len(frames))):
        raise ValueError(f"{d / PVD}: frame numbers are not consecutive from 0")
    return Output(d, np.array([t for t, _ in frames]), meta["lines"], meta["nodes"], meta["vertices"])
