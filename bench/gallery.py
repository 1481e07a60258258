"""The gallery of docs/cases.md, made from the cases' own runs: each ready case run to its
``[run] until`` (``cosnet run CASE``), drawn by ``cosnet render --png`` with its defaults (the
frame where the lines are farthest from where they started, coloured by velocity where it
varies there, else by displacement) and as a short GIF of the whole run coloured alike.

    python bench/gallery.py [CASE ...]

Writes docs/cases/CASE.png and CASE.gif, and bench/gallery.json (what each picture shows:
frame, time, field, why); `python bench/tables.py` then writes the gallery's text in
docs/cases.md from the JSON. Without CASE arguments every case of cases/ is drawn; with them,
their rows are replaced and the others kept.
"""

from __future__ import annotations

import json
import math
import subprocess
import sys
import tempfile
import time
from pathlib import Path

from harness import commit, write_json

REPO = Path(__file__).resolve().parents[1]
PICTURES = REPO / "docs" / "cases"
# a view that shows the motion better than the default iso one, or a field the case is about
OPTIONS = {"flagellum": {"view": "xy"}, "hinged_chain": {"view": "xz"}, "cardan": {"field": "torque"},
           "crane": {"view": "xz"}}
PNG_SIZE = (1024, 768)
GIF_SIZE = (320, 240)
GIF_FRAMES = 30          # at most; every n-th frame of the run
GIF_FPS = 10


def draw(case: Path, scratch: Path) -> dict:
    from cosnet.output.render import choose, render
    from cosnet.scene.loader import load_scene
    out = scratch / case.stem
    t0 = time.perf_counter()
    done = subprocess.run([sys.executable, "-c", "import sys; from cosnet.cli import command; sys.exit(command())",
                           "run", str(case), "--out", str(out)], capture_output=True, text=True)
    if done.returncode:
        raise SystemExit(f"cosnet run {case.stem} failed: {done.stderr.strip().splitlines()[-1:]}")
    ran = time.perf_counter() - t0
    opts = OPTIONS.get(case.stem, {})
    field, frame, why = choose(out, opts.get("field"), None)
    view = opts.get("view", "iso")
    png = render(out, kind="png", field=field, frame=frame, view=view, window_size=PNG_SIZE,
                 output=PICTURES / f"{case.stem}.png")
    from cosnet.output.io import read_output
    times = read_output(out).times
    every = max(1, math.ceil(len(times) / GIF_FRAMES))
    gif = render(out, kind="gif", field=field, every=every, view=view, window_size=GIF_SIZE, fps=GIF_FPS,
                 output=PICTURES / f"{case.stem}.gif")
    return {"case": case.stem, "title": load_scene(case).title, "frame": frame, "time": float(times[frame]),
            "field": field, "why": why, "view": view, "frames": len(times), "gif_every": every,
            "until": float(times[-1]), "png_bytes": png.stat().st_size, "gif_bytes": gif.stat().st_size,
            "run_s": round(ran, 1), "commit": commit()}


def main(argv: list[str]) -> int:
    cases = sorted((REPO / "cases").glob("*.toml"))
    if argv:
        unknown = [a for a in argv if not (REPO / "cases" / f"{a}.toml").exists()]
        if unknown:
            print(f"no such case: {', '.join(unknown)}", file=sys.stderr)
            return 2
        cases = [REPO / "cases" / f"{a}.toml" for a in argv]
    path = Path(__file__).with_suffix(".json")
    rows = {r["case"]: r for r in json.loads(path.read_text())["rows"]} if argv and path.exists() else {}
    t0 = time.perf_counter()
    with tempfile.TemporaryDirectory() as scratch:
        for case in cases:
            rows[case.stem] = draw(case, Path(scratch))
            print(f"{case.stem}: frame {rows[case.stem]['frame']} of {rows[case.stem]['frames']}, "
                  f"{rows[case.stem]['field']} ({rows[case.stem]['run_s']} s run)", flush=True)
    write_json(__file__, {"command": " ".join(["python bench/gallery.py", *argv]),
                          "wall_s": round(time.perf_counter() - t0, 1),
                          "rows": [rows[k] for k in sorted(rows)]})
    return 0


if __name__ == "__main__":
    sys.exit(main(sys.argv[1:]))
