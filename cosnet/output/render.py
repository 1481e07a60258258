"""Off-screen pictures of a written series (``cosnet render``): the lines as tubes of their
real radii (the ``radius`` point field, with a minimum visible size) coloured by the
magnitude of a point field over one colour range for every frame, rigid-body nodes as
spheres with their frames (d1 red, d2 green, d3 blue), fixed nodes as cubes, bodies and
obstacles with their shapes (meta.json's "shapes", Effect.drawn_shapes), the time, the
quantity and its unit on the colour bar, an axes triad and a length scale. ``warp``
exaggerates the motion from the first frame (the rest shape of a run built stress free, or
of a mode series). Works on a run directory (``series.pvd``) and on the mode series written
by ``cosnet modes`` (``mode_JJ.pvd``). Uses pyvista with ``OFF_SCREEN``; VTK's EGL/OSMesa
window renders without an X server; GIF and MP4 go through pyvista's movie writers
(imageio, the ``movie`` extra)."""

from __future__ import annotations

import importlib.util
import json
import math
import os
from pathlib import Path

import numpy as np

from .fields import FIELD_UNITS as UNITS
from .io import LINE_FIELDS, frame_files, read_output, read_pvd
VIEWS = ("iso", "xy", "xz", "yz")
VISIBLE = 0.002     # the thinnest line drawn, as a share of the scene's size (--min-radius's default)
MOVIE_EXTRA = "pip install 'cosnet[movie]'"


def parse_view(text: str):
    """``iso``, ``xy``, ``xz``, ``yz`` or ``AZIMUTH,ELEVATION`` in degrees (azimuth from +x
    about +z, elevation above the xy plane)."""
    if text in VIEWS:
        return text
    try:
        az, el = (float(v) for v in text.split(","))
    except ValueError:
        raise ValueError(f"--view {text!r}: use one of {', '.join(VIEWS)} or AZIMUTH,ELEVATION "
                         f"in degrees (e.g. -60,20)") from None
    if not (math.isfinite(az) and -90.0 <= el <= 90.0):
        raise ValueError(f"--view {text!r}: the elevation must lie in [-90, 90] degrees")
    return az, el


class _RunSeries:
    """Frames of a run directory: lines (positions, fields, radii) and nodes."""

    def __init__(self, directory):
        import meshio
        self.out = read_output(directory)
        self.dir = self.out.directory
        self.times = self.out.times
        meta = json.loads((self.dir / "meta.json").read_text())
        self.node_mass = np.array([float(m) for m in meta.get("node_mass", ["0"] * len(self.out.node_names))])
        self.shapes = meta.get("shapes", [])   # the effects' solid shapes (Effect.drawn_shapes)
        self.counts = list(self.out.vertices)
        self.fields = LINE_FIELDS
        pd = meshio.read(self.dir / frame_files(0)[0]).point_data if len(self.times) else {}
        # a line's radius does not change during a run: read once
        self.radius = np.asarray(pd["radius"], float) if "radius" in pd else np.zeros(sum(self.counts))

    def frame(self, k):
        fr = self.out.frame(k)
        names = self.out.line_names
        lines = {"position": np.concatenate([fr["lines"][n]["position"] for n in names]) if names else np.zeros((0, 3))}
        for f in self.fields:
            lines[f] = np.concatenate([fr["lines"][n][f] for n in names]) if names else np.zeros((0, 3))
        lines["radius"] = self.radius
        nodes = fr["nodes"]
        frames = np.stack([nodes["d1"], nodes["d2"], nodes["d3"]], axis=-1)
        return fr["time"], lines, nodes["position"], frames


class _ModeSeries:
    """Frames of one mode series (``mode_JJ.pvd``): lines and node reference points in one file."""

    def __init__(self, pvd: Path):
        import meshio
        self._meshio = meshio
        self.pvd = pvd
        listed = read_pvd(pvd)
        self.times = np.array([t for t, _ in listed])
        stem = pvd.stem
        self.files = [pvd.parent / f"{stem}_{k:03d}.vtu" for _, k in listed]
        for f in self.files:
            if not f.exists():
                raise ValueError(f"{pvd}: lists {f.name}, which is missing")
        m = meshio.read(self.files[0])
        lid = np.asarray(m.point_data["line_id"])
        self._on_line = lid >= 0
        self.counts = [int(c) for c in np.bincount(lid[self._on_line])] if self._on_line.any() else []
        self.node_mass = np.zeros(int((~self._on_line).sum()))
        self.shapes: list = []   # a mode series carries no bodies' or obstacles' shapes
        self.fields = ("displacement",)

    def frame(self, k):
        m = self._meshio.read(self.files[k])
        on = self._on_line
        lines = {"position": m.points[on], "displacement": m.point_data["displacement"][on]}
        r = m.point_data.get("radius")
        lines["radius"] = np.asarray(r, float)[on] if r is not None else np.zeros(int(on.sum()))
        return float(self.times[k]), lines, m.points[~on], None


def mode_file(directory, mode) -> Path:
    """The series of mode J (``--mode J``) in a `cosnet modes` directory."""
    p = Path(directory) / f"mode_{int(mode):02d}.pvd"
    if not p.exists():
        have = sorted(x.stem for x in Path(directory).glob("mode_*.pvd"))
        raise ValueError(f"--mode {mode}: {p} not found; the directory has {', '.join(have) or 'no modes'}")
    return p


def open_series(directory):
    """A run directory, a modes directory (its first mode; ``mode=J`` in ``render`` picks
    another) or a ``mode_JJ.pvd`` file."""
    p = Path(directory)
    if p.suffix == ".pvd" and p.name != "series.pvd":
        if not p.exists():
            raise ValueError(f"{p}: no such mode series")
        return _ModeSeries(p)
    if (p / "series.pvd").exists() or not sorted(p.glob("mode_*.pvd")):
        return _RunSeries(p)
    return _ModeSeries(sorted(p.glob("mode_*.pvd"))[0])


def _nice_length(span: float) -> float:
    """A round length (1, 2 or 5 times a power of ten) of about a fifth of ``span``."""
    target = max(span, 1e-300) / 5
    p = 10.0 ** math.floor(math.log10(target))
    return max((m * p for m in (1, 2, 5) if m * p <= target), default=p)


class Picture:
    """Pictures of a series: ``field`` (a line point field, or ``displacement`` from the
    first frame), the frames to draw (every ``every``-th), ``clim`` (default: the range of the
    field's magnitude over those frames), ``view``, ``warp`` (exaggeration of the motion
    from frame 0), ``min_radius`` (m; default 0.2 % of the scene's size) and the window size.
    """

    def __init__(self, directory, field="velocity", every=1, clim=None, view="iso", warp=1.0,
                 min_radius=None, window_size=(1024, 768), mode=None):
        if not os.environ.get("DISPLAY"):
            # go straight to VTK's EGL (headless GPU/software) window instead of failing on X
            # first; VTK reads this when it opens its first window, so here is early enough
            os.environ.setdefault("VTK_DEFAULT_OPENGL_WINDOW", "vtkEGLRenderWindow")
        import pyvista as pv
        pv.OFF_SCREEN = True
        self.pv = pv
        if mode is not None:
            directory = mode_file(directory, mode)
        self.series = open_series(directory)
        n = len(self.series.times)
        if n == 0:
            raise ValueError(f"{directory}: the series has no frames")
        fields = tuple(self.series.fields) + (() if "displacement" in self.series.fields else ("displacement",))
        if field not in fields:
            raise ValueError(f"--field {field!r}: the series has {', '.join(fields)}")
        if not (isinstance(warp, (int, float)) and math.isfinite(warp) and warp >= 0):
            raise ValueError(f"--warp must be a finite number >= 0, got {warp}")
        if min_radius is not None and not (math.isfinite(min_radius) and min_radius >= 0):
            raise ValueError(f"--min-radius must be a finite length >= 0, got {min_radius}")
        self.field, self.warp, self.view = field, float(warp), parse_view(view) if isinstance(view, str) else view
        if not (isinstance(every, int) and every >= 1):
            raise ValueError(f"--every must be an integer >= 1, got {every}")
        self.frames = list(range(0, n, every))
        self.unit = UNITS.get(field, "")
        self.title = f"{field} magnitude" + (f" ({self.unit})" if self.unit else "")
        _, first, self.ref_nodes, _ = self.series.frame(0)
        self.ref = first["position"]
        lo, hi, box, sample = math.inf, -math.inf, None, []
        self.motion = np.zeros(n)            # r.m.s. distance of the line vertices from frame 0
        self.spread = np.zeros((n, 2))       # the field's (min, max) in each frame
        for k in self.frames:      # one colour range and one camera for every frame drawn
            _, lines, nodes, _ = self.series.frame(k)
            v = self.values(lines)
            if v.size:
                lo, hi = min(lo, float(v.min())), max(hi, float(v.max()))
                self.spread[k] = float(v.min()), float(v.max())
                self.motion[k] = math.sqrt(float(np.mean(np.sum((lines["position"] - self.ref) ** 2, axis=-1))))
            pts = np.concatenate([self.warped(lines["position"], self.ref),
                                  self.warped(nodes, self.ref_nodes)])
            if len(pts):
                sample.append(pts[:: max(1, len(pts) * len(self.frames) // 20000)])
                b = np.array([pts.min(0), pts.max(0)])
                box = b if box is None else np.array([np.minimum(box[0], b[0]), np.maximum(box[1], b[1])])
        if clim is not None:
            lo, hi = (float(c) for c in clim)
            if not (math.isfinite(lo) and math.isfinite(hi) and lo < hi):
                raise ValueError(f"--clim needs two finite numbers LO < HI, got {clim[0]} {clim[1]}")
        elif not lo < hi:                  # a constant field still needs a colour range
            lo, hi = (lo - 1.0, hi + 1.0) if math.isfinite(lo) else (0.0, 1.0)
        self.clim = (lo, hi)
        self.box = box if box is not None else np.zeros((2, 3))
        self._sample = np.concatenate(sample) if sample else np.zeros((1, 3))  # framing the camera
        self.size = float(np.linalg.norm(self.box[1] - self.box[0])) or 1.0
        self.min_radius = VISIBLE * self.size if min_radius is None else float(min_radius)
        if len(window_size) != 2 or min(window_size) < 16:
            raise ValueError(f"--size needs a width and height of at least 16 pixels, got {window_size}")
        self.plotter = pv.Plotter(off_screen=True, window_size=[int(v) for v in window_size])
        self._camera = None
        self._depth_cue = False
        self._scale = min(window_size[0] / 1024, window_size[1] / 768)

    def shape_meshes(self, k) -> list:
        """(mesh, fixed) of each solid shape of the run's effects in frame k: a body's placed
        by its node's reference point (warped as the nodes are) and frame, a static obstacle's
        as declared (a plane as a square across the scene)."""
        if not self.series.shapes:
            return []
        _, _, nodes, frames = self.series.frame(k)
        return self._placed_shapes(nodes, frames)

    def _placed_shapes(self, nodes, frames) -> list:
        """shape_meshes for the nodes' positions (as written) and frames of one frame."""
        x = self.warped(nodes, self.ref_nodes)
        out = []
        for s in self.series.shapes:
            nd = s["node"]
            place, turn = (np.zeros(3), np.eye(3)) if nd is None else (x[nd], frames[nd])
            out.append((shape_mesh(self.pv, s, place, turn, self.box, 1.2 * self.size), nd is None))
        return out

    def _font(self, points: int) -> int:
        """A font size that keeps its share of a window smaller or larger than 1024 x 768."""
        return max(6, round(points * self._scale))

    def busiest(self) -> int:
        """The frame where the lines are farthest (r.m.s.) from where they were in frame 0,
        the last of them on a tie (the last frame of a series that does not move)."""
        m = self.motion[self.frames]
        return self.frames[len(m) - 1 - int(np.argmax(m[::-1]))]

    def colour_share(self, k) -> float:
        """The share of the colour range the field spans in frame k."""
        return float(self.spread[k, 1] - self.spread[k, 0]) / (self.clim[1] - self.clim[0])

    def warped(self, x, ref):
        return ref + self.warp * (x - ref) if self.warp != 1.0 else x

    def values(self, lines) -> np.ndarray:
        """Magnitude of the field at every line vertex of a frame."""
        if self.field == "displacement" and "displacement" not in lines:
            return np.linalg.norm(lines["position"] - self.ref, axis=-1)
        return np.linalg.norm(lines[self.field], axis=-1)

    def points(self, k) -> np.ndarray:
        """The line vertices of frame k as drawn (warped), in line order."""
        return self.warped(self.series.frame(k)[1]["position"], self.ref)

    def tubes(self, k):
        """Frame k's lines as the tubes drawn: the warped polylines swept at radius
        max(radius, min_radius), carrying the field's magnitude."""
        pv = self.pv
        _, lines, _, _ = self.series.frame(k)
        pts = self.warped(lines["position"], self.ref)
        cells, start = [], 0
        for c in self.series.counts:
            cells += [c] + list(range(start, start + c))
            start += c
        poly = pv.PolyData(pts, lines=np.array(cells, dtype=np.int64))
        poly.point_data["tube_radius"] = np.maximum(lines["radius"], self.min_radius)
        poly.point_data[self.title] = self.values(lines)
        return poly.tube(scalars="tube_radius", absolute=True, n_sides=16, capping=True)

    def draw(self, k) -> np.ndarray:
        """Frame k as an RGB image (h, w, 3)."""
        pv, p = self.pv, self.plotter
        time, _, nodes, frames = self.series.frame(k)
        p.clear()
        p.set_background("white")
        if self.series.counts:
            p.add_mesh(self.tubes(k), scalars=self.title, clim=self.clim, cmap="viridis",
                       smooth_shading=True, specular=0.4, specular_power=20,
                       scalar_bar_args=dict(title="", vertical=False, n_labels=5 if self._scale > 0.7 else 3,
                                            fmt="%.3g",
                                            position_x=0.3, position_y=0.02, width=0.4, height=0.09,
                                            label_font_size=max(10, self._font(13)), color="black"))
            # labels under the bar and the title, as a text of its own, over it: they never
            # share a row whatever the font
            p.scalar_bar.SetTextPositionToPrecedeScalarBar()
            w, h = p.window_size
            title = p.add_text(self.title, position=(w // 2, int(0.02 * h + 0.09 * h) + 4),
                               font_size=self._font(12), color="black")
            title.GetTextProperty().SetJustificationToCentered()
        for (mesh, fixed), s in zip(self._placed_shapes(nodes, frames), self.series.shapes):
            # static obstacles see-through (a plane, the lightest, behind the net it carries)
            opacity = 1.0 if not fixed else 0.2 if s["shape"] == "plane" else 0.4
            p.add_mesh(mesh, color="lightgray" if fixed else "tan", opacity=opacity, smooth_shading=True)
        x = self.warped(nodes, self.ref_nodes)
        r = 2.5 * self.min_radius
        for i, m in enumerate(self.series.node_mass):
            if np.isinf(m):
                p.add_mesh(pv.Cube(center=x[i], x_length=4 * r, y_length=4 * r, z_length=4 * r), color="dimgray")
            elif m > 0:
                p.add_mesh(pv.Sphere(radius=2 * r, center=x[i]), color="tan", smooth_shading=True)
                for j, c in enumerate(("red", "green", "blue")):
                    p.add_mesh(pv.Arrow(start=x[i], direction=frames[i][:, j], scale=8 * r), color=c)
        text = f"t = {time:.4g} s"
        if self.warp != 1.0:
            text += f"   motion x {self.warp:g}"
        p.add_text(text, position=(12, p.window_size[1] - int(34 * self._scale)), font_size=self._font(11),
                   color="black")
        self._scale_bar()
        p.add_axes(color="black", line_width=2)
        if not self._depth_cue:
            # ambient occlusion darkens what other parts hide: tubes behind tubes read as such
            p.enable_ssao(radius=0.01 * self.size, bias=0.002 * self.size, kernel_size=64)
            self._depth_cue = True
        self._place_camera()
        return p.screenshot(return_img=True)[..., :3]

    def _scale_bar(self):
        """A ruler of a round length along the scene's front lower edge, along x (or y if x is
        flat)."""
        lo, hi = self.box
        span = hi - lo
        axis = 0 if span[0] >= span[1] else 1
        length = _nice_length(float(span[axis]) or self.size)
        d = self._view_direction()
        front = [hi[i] + 0.03 * self.size if d[i] >= 0 else lo[i] - 0.03 * self.size for i in range(2)]
        a = np.array([lo[0], front[1], lo[2]]) if axis == 0 else np.array([front[0], lo[1], lo[2]])
        b = a.copy()
        b[axis] += length
        self.plotter.add_ruler(a, b, number_labels=2, title="", font_size_factor=0.7, tick_color="black",
                               label_color="black", show_labels=False)
        # the length as a label of its own, hung below the ruler's middle on the side away from
        # the scene: the ruler's own title sits on its line once its tick labels are hidden
        out = np.zeros(3)
        out[1 - axis] = 1.0 if d[1 - axis] >= 0 else -1.0
        self.plotter.add_point_labels([(a + b) / 2 + 0.02 * self.size * out], [f"{length:g} m"],
                                      font_size=self._font(16), text_color="black", shape=None,
                                      show_points=False, always_visible=True, bold=False,
                                      justification_horizontal="center", justification_vertical="top")

    def _view_direction(self) -> np.ndarray:
        """Unit vector from the scene towards the camera."""
        if isinstance(self.view, str):
            return {"iso": np.ones(3) / math.sqrt(3), "xy": np.array([0.0, 0.0, 1.0]),
                    "xz": np.array([0.0, -1.0, 0.0]), "yz": np.array([1.0, 0.0, 0.0])}[self.view]
        az, el = np.radians(self.view)
        return np.array([math.cos(el) * math.cos(az), math.cos(el) * math.sin(az), math.sin(el)])

    def _place_camera(self):
        p = self.plotter
        if self._camera is not None:
            p.camera_position = self._camera
            return
        lo, hi = self.box
        pad = 0.05 * self.size
        bounds = [lo[0] - pad, hi[0] + pad, lo[1] - pad, hi[1] + pad, lo[2] - 2 * pad, hi[2] + pad]
        if isinstance(self.view, str):
            p.camera_position = self.view
        else:
            centre = (lo + hi) / 2
            d = self._view_direction()
            up = (0.0, 0.0, 1.0) if abs(d[2]) < 0.999 else (0.0, 1.0, 0.0)
            p.camera_position = [tuple(centre + self.size * d), tuple(centre), up]
        p.reset_camera(bounds=bounds)
        # reset_camera frames the bounding sphere, loose for a long thin net: zoom until the
        # points drawn over all frames span the window, less the bands of text and colour bar
        w, h = p.window_size
        m = p.camera.GetCompositeProjectionTransformMatrix(w / h, -1, 1)
        m = np.array([[m.GetElement(i, j) for j in range(4)] for i in range(4)])
        hom = np.c_[self._sample, np.ones(len(self._sample))] @ m.T
        reach = np.abs(hom[:, :2] / hom[:, 3:]).max(axis=0)
        p.camera.zoom(float(min(0.9 / max(reach[0], 1e-9), 0.64 / max(reach[1], 1e-9))))
        self._camera = p.camera_position


def shape_mesh(pv, s: dict, x, r, box, span: float):
    """The pyvista mesh of shape record ``s`` (Effect.drawn_shapes) whose frame is at x (3,)
    turned by r (3, 3, columns its axes in the lab); a plane drawn as a square of side
    ``span`` about the point of it nearest the centre of ``box``."""
    def place(p):
        return x + r @ np.asarray(p, float)
    kind, size = s["shape"], s["size"]
    if kind == "sphere":
        return pv.Sphere(radius=size[0], center=place(s["origin"]), theta_resolution=32, phi_resolution=32)
    if kind == "capsule":
        a, b = place(s["origin"]), place(s["axis"])
        ends = pv.Sphere(radius=size[0], center=a).merge(pv.Sphere(radius=size[0], center=b))
        length = float(np.linalg.norm(b - a))
        if length == 0.0:
            return ends
        return ends.merge(pv.Cylinder(center=(a + b) / 2, direction=b - a, radius=size[0], height=length,
                                      resolution=32, capping=False))
    if kind == "box":
        h = size
        mesh = pv.Box(bounds=(-h[0], h[0], -h[1], h[1], -h[2], h[2]))
        m = np.eye(4)
        m[:3, :3] = r @ np.asarray(s["rot"], float).T     # the box's axes: columns of rot^T in the node frame
        m[:3, 3] = place(s["origin"])
        return mesh.transform(m, inplace=False)
    if kind == "plane":
        n = r @ np.asarray(s["axis"], float)
        o = place(s["origin"])
        centre = np.mean(np.asarray(box, float), axis=0)
        return pv.Plane(center=centre - ((centre - o) @ n) * n, direction=n, i_size=span, j_size=span)
    points = np.array([place(p) for p in s["points"]]).reshape(-1, 3)
    faces = np.column_stack([np.full(len(s["triangles"]), 3), np.asarray(s["triangles"], int).reshape(-1, 3)])
    return pv.PolyData(points, faces=faces.ravel())


def _movie_check(kind: str):
    need = ["imageio"] + (["imageio_ffmpeg"] if kind == "mp4" else [])
    missing = [m.replace("_", "-") for m in need if importlib.util.find_spec(m) is None]
    if missing:
        raise ValueError(f"--{kind} needs {' and '.join(missing)}: {MOVIE_EXTRA}")


AUTO_FIELD = "velocity"    # the colour of a picture whose field is not named, where it varies
AUTO_SHARE = 0.5           # ... over at least this share of its range in the frame drawn


def choose(directory, field=None, frame=None, mode=None) -> tuple[str, int, str]:
    """(field, frame, why) of a PNG whose field or frame is not given: the frame where the
    lines are farthest from frame 0 (a mode's quarter period, at full amplitude), coloured by
    velocity if it spans at least AUTO_SHARE of its range there, else by the displacement
    from frame 0 (a run come to rest is one colour of velocity)."""
    pic = Picture(directory, field=field or AUTO_FIELD, mode=mode, window_size=(16, 16))
    n = len(pic.series.times)
    if frame is not None:
        k, why = (frame if frame >= 0 else n + frame), "as asked"
    elif isinstance(pic.series, _ModeSeries):
        k, why = n // 4, "a quarter period: the mode at full amplitude"
    else:
        k, why = pic.busiest(), "the lines farthest (r.m.s.) from frame 0"
    if not 0 <= k < n:
        raise ValueError(f"--frame {frame}: the series has frames 0..{n - 1}")
    if field is None and pic.colour_share(k) < AUTO_SHARE:
        field = "displacement"
        why += f"; coloured by displacement, as velocity spans {pic.colour_share(k):.0%} of its range there"
    pic.plotter.close()
    return field or AUTO_FIELD, k, why


def render(directory, kind="png", field=None, output=None, frame=None, every=1, clim=None,
           view="iso", warp=1.0, min_radius=None, window_size=(1024, 768), mode=None, fps=20) -> Path:
    """Render the series in ``directory`` to a PNG (one frame), GIF or MP4; return the path.
    A PNG's frame and field default to ``choose``'s (the frame where most has happened); a
    movie's field to velocity. The colour range spans every frame of the series (PNG) or
    every frame drawn (movies) unless ``clim`` = (lo, hi) is given."""
    if kind not in ("png", "gif", "mp4"):
        raise ValueError(f"unknown picture kind {kind!r}: png, gif or mp4")
    if kind != "png":
        _movie_check(kind)
    elif field is None or frame is None:
        field, frame, _ = choose(directory, field, frame, mode)
    pic = Picture(directory, field=field or AUTO_FIELD, every=1 if kind == "png" else every, clim=clim, view=view,
                  warp=warp, min_radius=min_radius, window_size=window_size, mode=mode)
    src = Path(directory)
    stem = src.parent if src.suffix == ".pvd" else src
    name = src.stem if src.suffix == ".pvd" else "render" if mode is None else f"mode_{int(mode):02d}"
    path = Path(output) if output else stem / f"{name}.{kind}"
    n = len(pic.series.times)
    if kind == "png":
        k = frame if frame >= 0 else n + frame
        if not 0 <= k < n:
            raise ValueError(f"--frame {frame}: the series has frames 0..{n - 1}")
        from PIL import Image
        Image.fromarray(pic.draw(k)).save(path)
        return path
    p = pic.plotter
    if kind == "gif":
        p.open_gif(str(path), fps=fps)
    else:
        p.open_movie(str(path), framerate=fps, quality=7)
    for k in pic.frames:
        pic.draw(k)
        p.write_frame()
    p.close()
    return path
