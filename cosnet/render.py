"""Off-screen pictures of a written series (``cosnet render``): the lines as tubes coloured by
the magnitude of a point field, nodes with mass as spheres with their frames (d1 red, d2
green, d3 blue), fixed nodes as cubes, and the time. Uses pyvista with ``OFF_SCREEN``; VTK's
EGL/OSMesa window renders without an X server."""

from __future__ import annotations

import json
import os
import shutil
import subprocess
from pathlib import Path

import numpy as np

if not os.environ.get("DISPLAY"):
    # go straight to VTK's EGL (headless GPU/software) window instead of failing on X first
    os.environ.setdefault("VTK_DEFAULT_OPENGL_WINDOW", "vtkEGLRenderWindow")

from .io import read_output


def _polylines(points, vertices):
    import pyvista as pv
    cells, start = [], 0
    for c in vertices:
        cells += [c] + list(range(start, start + c))
        start += c
    return pv.PolyData(points, lines=np.array(cells, dtype=np.int64))


def _scene_size(out, frames):
    pts = np.concatenate([out.frame(k)["lines"][n]["position"] for k in frames for n in out.line_names]
                         + [out.frame(k)["nodes"]["position"] for k in frames])
    return float(np.linalg.norm(pts.max(0) - pts.min(0))) or 1.0


class _Painter:
    def __init__(self, out, field, frames, window_size=(1024, 768)):
        import pyvista as pv
        pv.OFF_SCREEN = True
        self.pv, self.out, self.field = pv, out, field
        meta = json.loads((out.directory / "meta.json").read_text())
        self.mass = np.array([float(m) for m in meta.get("node_mass", ["0"] * len(out.node_names))])
        f0 = out.frame(frames[0])
        if field not in next(iter(f0["lines"].values()), {"position": 0}) and out.line_names:
            raise ValueError(f"--field {field!r}: the series has {sorted(f0['lines'][out.line_names[0]])}")
        self.size = _scene_size(out, sorted({frames[0], frames[-1]}))
        last = out.frame(frames[-1])
        mags = [np.linalg.norm(last["lines"][n][field], axis=-1) for n in out.line_names]
        hi = max((float(m.max()) for m in mags), default=1.0)
        self.clim = (0.0, hi if hi > 0 else 1.0)
        self.plotter = pv.Plotter(off_screen=True, window_size=window_size)
        self.camera = None

    def draw(self, k):
        pv, p, out = self.pv, self.plotter, self.out
        fr = out.frame(k)
        p.clear()
        r_vis = 0.004 * self.size
        if out.line_names:
            pts = np.concatenate([fr["lines"][n]["position"] for n in out.line_names])
            val = np.concatenate([np.linalg.norm(fr["lines"][n][self.field], axis=-1) for n in out.line_names])
            poly = _polylines(pts, [len(fr["lines"][n]["position"]) for n in out.line_names])
            poly.point_data[self.field] = val
            tubes = poly.tube(radius=r_vis, n_sides=12)
            p.add_mesh(tubes, scalars=self.field, clim=self.clim, cmap="viridis",
                       scalar_bar_args={"title": f"|{self.field}|"})
        nodes = fr["nodes"]
        for i, x in enumerate(nodes["position"]):
            m = self.mass[i]
            if np.isinf(m):
                p.add_mesh(pv.Cube(center=x, x_length=4 * r_vis, y_length=4 * r_vis, z_length=4 * r_vis),
                           color="gray")
            elif m > 0:
                p.add_mesh(pv.Sphere(radius=3 * r_vis, center=x), color="tan")
                for d, c in (("d1", "red"), ("d2", "green"), ("d3", "blue")):
                    p.add_mesh(pv.Arrow(start=x, direction=nodes[d][i], scale=12 * r_vis), color=c)
        p.add_text(f"t = {fr['time']:.4f} s", position="upper_left", font_size=12)
        if self.camera is None:
            p.camera_position = "iso"
            p.reset_camera()
            self.camera = p.camera_position
        else:
            p.camera_position = self.camera
        return p.screenshot(return_img=True)


def render(directory, kind="png", field="velocity", output=None, frame=-1, every=1) -> Path:
    """Render the series in ``directory`` to a PNG (one frame), GIF or MP4; return the path."""
    out = read_output(directory)
    n = len(out.times)
    if n == 0:
        raise ValueError(f"{directory}: the series has no frames")
    if every < 1:
        raise ValueError(f"--every must be >= 1, got {every}")
    path = Path(output) if output else Path(directory) / f"render.{kind}"
    if kind == "png":
        k = frame if frame >= 0 else n + frame
        if not 0 <= k < n:
            raise ValueError(f"--frame {frame}: the series has frames 0..{n - 1}")
        from PIL import Image
        Image.fromarray(_Painter(out, field, [k]).draw(k)).save(path)
        return path
    frames = list(range(0, n, every))
    painter = _Painter(out, field, frames)
    if kind == "gif":
        from PIL import Image
        imgs = [Image.fromarray(painter.draw(k)).convert("P", palette=Image.ADAPTIVE) for k in frames]
        imgs[0].save(path, save_all=True, append_images=imgs[1:], duration=60, loop=0)
        return path
    ffmpeg = shutil.which("ffmpeg")
    if ffmpeg is None:
        try:
            import imageio_ffmpeg
            ffmpeg = imageio_ffmpeg.get_ffmpeg_exe()
        except ImportError:
            raise ValueError("--mp4 needs an ffmpeg executable on PATH (or the imageio-ffmpeg "
                             "package); use --gif instead") from None
    first = painter.draw(frames[0])
    h, w = first.shape[:2]
    proc = subprocess.Popen([ffmpeg, "-y", "-loglevel", "error", "-f", "rawvideo", "-pix_fmt", "rgb24",
                             "-s", f"{w}x{h}", "-r", "20", "-i", "-", "-pix_fmt", "yuv420p",
                             "-vf", "pad=ceil(iw/2)*2:ceil(ih/2)*2", str(path)], stdin=subprocess.PIPE)
    proc.stdin.write(np.ascontiguousarray(first[..., :3]).tobytes())
    for k in frames[1:]:
        proc.stdin.write(np.ascontiguousarray(painter.draw(k)[..., :3]).tobytes())
    proc.stdin.close()
    if proc.wait() != 0:
        raise ValueError(f"ffmpeg failed writing {path}")
    return path
