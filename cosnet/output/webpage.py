"""A run as one self-contained web page (``cosnet render OUT --html``, ``cosnet view OUT``):
the lines as tubes of their true radii, bodies and obstacles with their shapes, nodes as
spheres (with mass) and cubes (fixed), orbit and zoom, a time slider with a play button and
the colour field chosen from a menu. The page draws with three.js (bundled with the package,
viewer/three-viewer.min.js, MIT; viewer/README.md says how it is built), so it opens offline
from a file; the data go in as base64 float32 arrays, so a frame of a 1000-vertex net costs
about 16 kB per field and 12 kB of positions."""

from __future__ import annotations

import base64
import http.server
import json
import math
import threading
import webbrowser
from functools import partial
from pathlib import Path

import numpy as np

from .fields import FIELD_UNITS
from .render import VISIBLE, mode_file, open_series, shape_mesh

VIEWER = Path(__file__).with_name("viewer")
PAGE = "view.html"
MAX_FRAMES = 600          # a longer series is thinned to this many frames (say --every to choose)
# d1, d2, d3 are unit vectors: their magnitude is 1 everywhere and colours nothing
UNCOLOURED = ("d1", "d2", "d3")


def _b64(a, dtype=np.float32) -> str:
    return base64.b64encode(np.ascontiguousarray(a, dtype=dtype).tobytes()).decode("ascii")


def _triangles(mesh) -> tuple[np.ndarray, np.ndarray]:
    """(points (P, 3), triangles (T, 3)) of a pyvista surface."""
    import pyvista as pv
    surface = mesh if isinstance(mesh, pv.PolyData) else mesh.extract_surface()
    tri = surface.triangulate()
    return np.asarray(tri.points, float), np.asarray(tri.faces).reshape(-1, 4)[:, 1:]


def page_data(directory, every: int = 1, min_radius: float | None = None, mode: int | None = None) -> dict:
    """The page's data for the series in ``directory`` (a run, or a modes directory / mode
    file as for ``render``): times, the line vertices per frame, their drawn radii (true,
    at least ``min_radius``, default 0.2 % of the scene's size), each field's magnitude per
    vertex and frame with its range over the frames, nodes per frame, and the shapes (a
    body's in its node's frame with the node's placement per frame, a static one in place)."""
    import pyvista as pv
    if not (isinstance(every, int) and every >= 1):
        raise ValueError(f"--every must be an integer >= 1, got {every}")
    if min_radius is not None and not (math.isfinite(min_radius) and min_radius >= 0):
        raise ValueError(f"--min-radius must be a finite length >= 0, got {min_radius}")
    src = Path(directory) if mode is None else mode_file(directory, mode)
    series = open_series(src)
    n = len(series.times)
    if n == 0:
        raise ValueError(f"{directory}: the series has no frames")
    every = max(every, math.ceil(n / MAX_FRAMES))
    ks = list(range(0, n, every))
    fields = [f for f in series.fields if f not in UNCOLOURED]
    if "displacement" not in fields:
        fields.append("displacement")
    x, nodes, turns, times = [], [], [], []
    values: dict[str, list] = {f: [] for f in fields}
    ref = radius = None
    for k in ks:
        t, lines, nd, fr = series.frame(k)
        if ref is None:
            ref, radius = lines["position"], lines["radius"]
        times.append(t)
        x.append(lines["position"])
        for f in fields:
            v = lines["position"] - ref if f == "displacement" and f not in lines else lines[f]
            values[f].append(np.linalg.norm(v, axis=-1))
        nodes.append(nd)
        turns.append(fr if fr is not None else np.broadcast_to(np.eye(3), (len(nd), 3, 3)))
    xs, nodes_x = np.array(x).reshape(len(ks), -1, 3), np.array(nodes).reshape(len(ks), -1, 3)
    everything = np.concatenate([xs.reshape(-1, 3), nodes_x.reshape(-1, 3)])
    box = (np.array([everything.min(0), everything.max(0)]) if len(everything) else np.zeros((2, 3)))
    size = float(np.linalg.norm(box[1] - box[0])) or 1.0
    floor = VISIBLE * size if min_radius is None else float(min_radius)
    coloured = {}
    for f in fields:
        v = np.array(values[f]).reshape(len(ks), -1)
        lo, hi = (float(v.min()), float(v.max())) if v.size else (0.0, 1.0)
        if not hi > lo:                 # a constant field still needs a colour range
            lo, hi = lo - 1.0, hi + 1.0
        coloured[f] = {"unit": FIELD_UNITS.get(f, ""), "range": [lo, hi], "values": _b64(v)}
    shapes = []
    for s in series.shapes:
        # a static shape is placed as declared; a body's in its node's frame, placed per frame
        # by the node's position and frame, (F, 3, 4): x, then the columns d1 d2 d3
        p, tri = _triangles(shape_mesh(pv, s, np.zeros(3), np.eye(3), box, 1.2 * size))
        node = s["node"]
        place = None if node is None else _b64(np.concatenate(
            [nodes_x[:, node, :, None], np.array([t[node] for t in turns])], axis=2))
        shapes.append({"points": _b64(p), "triangles": _b64(tri, np.uint32), "node": node, "place": place,
                       "kind": s["shape"]})
    from matplotlib import colormaps
    lut = (colormaps["viridis"](np.linspace(0.0, 1.0, 256))[:, :3] * 255).round().astype(int)
    return {
        "title": src.stem if src.suffix == ".pvd" else src.resolve().name,   # a mode's: mode_JJ
        "times": [float(t) for t in times],
        "counts": [int(c) for c in series.counts],
        "positions": _b64(xs),
        "radius": _b64(np.maximum(np.asarray(radius, float), floor)),
        "fields": coloured,
        "field": "velocity" if "velocity" in coloured else fields[0],
        "nodes": _b64(nodes_x),
        "node_mass": ["inf" if np.isinf(m) else float(m) for m in series.node_mass],
        "node_size": 5 * floor,
        "box": box.tolist(),
        "shapes": shapes,
        "colormap": lut.tolist(),
    }


def page(data: dict) -> str:
    """The HTML text of one self-contained page showing ``data`` (page_data)."""
    template = (VIEWER / "view.html").read_text()
    three = (VIEWER / "three-viewer.min.js").read_text()
    # the data go in a script element of type application/json: "</" must not end it early
    payload = json.dumps(data, separators=(",", ":")).replace("</", "<\\/")
    return (template.replace("/*THREE*/", three.replace("</script", "<\\/script"))
            .replace("{/*DATA*/}", payload))


def write_html(directory, output=None, every: int = 1, min_radius: float | None = None,
               mode: int | None = None) -> Path:
    """Write the series in ``directory`` as one self-contained HTML page (default
    DIR/view.html; a mode's DIR/mode_JJ.html, as its picture is named); return its path."""
    src = Path(directory)
    name = f"{src.stem}.html" if src.suffix == ".pvd" else PAGE if mode is None else f"mode_{int(mode):02d}.html"
    path = Path(output) if output else (src.parent if src.suffix == ".pvd" else src) / name
    text = page(page_data(directory, every=every, min_radius=min_radius, mode=mode))
    tmp = path.with_name(path.name + ".part")
    tmp.write_text(text)
    tmp.replace(path)
    return path


class _Quiet(http.server.SimpleHTTPRequestHandler):
    def log_message(self, *args):      # the command says where it serves; requests are noise
        pass


def serve(directory, port: int = 0, browser: bool = True, ready=None):
    """Serve ``directory`` (holding view.html) on localhost; ``ready(url)`` is called once the
    server listens (the CLI prints it); opens the page in the default browser if ``browser``.
    Serves until interrupted."""
    handler = partial(_Quiet, directory=str(directory))
    with http.server.ThreadingHTTPServer(("127.0.0.1", port), handler) as server:
        url = f"http://127.0.0.1:{server.server_address[1]}/{PAGE}"
        if ready is not None:
            ready(url)
        if browser:
            threading.Thread(target=webbrowser.open, args=(url,), daemon=True).start()
        server.serve_forever()
