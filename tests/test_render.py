"""Pictures checked by their content: the colour range over all frames, the warp factor in
the drawn geometry, tubes of the lines' radii, the quantity and unit on the colour bar,
movie frame counts, mode series, one-line errors; the commands of docs/pictures.md."""

import importlib.util
import re
import shlex
import tomllib
from pathlib import Path

import numpy as np
import pytest

from cosnet.cli import main
from cosnet.core.samples import cantilever_scene
from cosnet.output.io import read_output
from nets import written_run
from procs import served_page

REPO = Path(__file__).resolve().parents[1]
# a cantilever sagging and swinging under gravity (G = E / (2 (1 + 0.3)))
ROD = cantilever_scene("rod", E="1.0e8", G=repr(1.0e8 / 2.6), density="1000.0", elements=6, material="m",
                       rest='[[effects]]\nkind = "gravity"\n[run]\nuntil = 0.02\noutput_interval = 0.005\n')
W, H = 200, 150


@pytest.fixture(autouse=True)
def _no_display(monkeypatch):
    monkeypatch.delenv("DISPLAY", raising=False)


@pytest.fixture(scope="module")
def run(tmp_path_factory):
    return written_run(tmp_path_factory.mktemp("render"), ROD)


def magnitudes(out, field, frames):
    return [np.linalg.norm(out.frame(k)["lines"]["rod"][field], axis=-1) for k in frames]


def picture(directory, **kw):
    from cosnet.output.render import Picture
    return Picture(directory, window_size=(W, H), **kw)


def test_colour_range_is_that_of_all_frames_and_drawn_so(run):
    out = read_output(run)
    n = len(out.times)
    assert n == 5
    mags = magnitudes(out, "velocity", range(n))
    pic = picture(run, field="velocity")
    assert pic.clim == (min(m.min() for m in mags), max(m.max() for m in mags))
    assert pic.clim[0] == 0.0 < pic.clim[1]               # frame 0 is at rest
    pic.draw(0)                                           # drawn with the range of all frames
    assert pic.plotter.scalar_bar.GetLookupTable().GetRange() == pytest.approx(pic.clim, rel=1e-12)
    every2 = picture(run, field="force", every=2)
    m2 = magnitudes(out, "force", range(0, n, 2))
    assert every2.frames == [0, 2, 4]
    assert every2.clim == (min(m.min() for m in m2), max(m.max() for m in m2))
    fixed = picture(run, field="force", clim=(0.0, 2.5))
    fixed.draw(3)
    assert fixed.plotter.scalar_bar.GetLookupTable().GetRange() == (0.0, 2.5)


def test_colour_bar_title_names_quantity_and_unit(run):
    for field, unit in (("velocity", "(m/s)"), ("force", "(N)"), ("curvature", "(1/m)"),
                        ("displacement", "(m)")):
        pic = picture(run, field=field)
        pic.draw(1)
        texts = [a.GetInput() for a in pic.plotter.actors.values() if hasattr(a, "GetInput")]
        assert pic.title == f"{field} magnitude {unit}" and pic.title in texts
    assert picture(run, field="strain").title == "strain magnitude"       # dimensionless


def test_warp_scales_the_motion_from_the_first_frame(run):
    out = read_output(run)
    x0, x4 = out.frame(0)["lines"]["rod"]["position"], out.frame(4)["lines"]["rod"]["position"]
    for f in (0.0, 1.0, 10.0):
        np.testing.assert_allclose(picture(run, warp=f).points(4), x0 + f * (x4 - x0), rtol=0, atol=1e-15)
    r = 0.01                                              # the rod's radius
    assert x0[-1, 2] - x4[-1, 2] > 0.1 * r               # it moved (the tip sags)
    for f in (1.0, 10.0):                  # the tube's bounds: the warped rod's, and a radius more
        pic = picture(run, warp=f, min_radius=0.0)
        lo, hi = pic.points(4).min(0), pic.points(4).max(0)
        b = np.array(pic.tubes(4).bounds).reshape(3, 2)
        np.testing.assert_allclose(lo, (x0 + f * (x4 - x0)).min(0), rtol=0, atol=1e-15)
        assert np.all(b[:, 0] <= lo + 1e-12) and np.all(b[:, 0] >= lo - 1.1 * r)
        assert np.all(b[:, 1] >= hi - 1e-12) and np.all(b[:, 1] <= hi + 1.1 * r)


def test_tubes_have_the_lines_radii_or_the_visible_minimum(run):
    b = picture(run, min_radius=0.0).tubes(0).bounds
    assert b[3] - b[2] == pytest.approx(2 * 0.01, rel=0.02)           # polygon of 16 sides
    b = picture(run, min_radius=0.03).tubes(0).bounds
    assert b[3] - b[2] == pytest.approx(2 * 0.03, rel=0.02)
    pic = picture(run)
    assert pic.min_radius == pytest.approx(0.002 * pic.size)


def test_png_of_each_view_is_drawn(run, tmp_path):
    from PIL import Image

    from cosnet.output.render import render
    for view in ("iso", "xy", "xz", "yz", "-60,20"):
        path = render(run, field="force", view=view, output=tmp_path / "v.png", window_size=(W, H))
        img = np.asarray(Image.open(path).convert("L"))
        assert img.shape == (H, W) and img.min() < 100 and img.max() > 240


@pytest.mark.parametrize("kind", ["gif", "mp4"])
def test_movie_has_one_frame_per_frame_drawn(run, tmp_path, kind):
    pytest.importorskip("imageio")
    if kind == "mp4":
        pytest.importorskip("imageio_ffmpeg")
    import imageio.v3 as iio

    from cosnet.output.render import render
    path = render(run, kind=kind, every=2, output=tmp_path / f"m.{kind}", window_size=(160, 128))
    assert len(list(iio.imiter(path))) == 3


def test_movie_without_the_extra_names_it(run, tmp_path, monkeypatch, capsys):
    real = importlib.util.find_spec
    monkeypatch.setattr(importlib.util, "find_spec",
                        lambda name, *a: None if name.startswith("imageio") else real(name, *a))
    assert main(["render", str(run), "--mp4"]) == 2
    err = capsys.readouterr().err.strip()
    assert err.count("\n") == 0 and "cosnet[movie]" in err and "imageio-ffmpeg" in err


def test_movie_extra_is_declared():
    extras = tomllib.loads((REPO / "pyproject.toml").read_text())["project"]["optional-dependencies"]
    assert {re.split(r"[<>=]", d)[0] for d in extras["movie"]} == {"imageio", "imageio-ffmpeg"}


def test_mode_series_render_with_displacement_and_radius(tmp_path):
    from cosnet.studies.modes import main_modes, write_modes
    from cosnet.output.render import render
    from cosnet.scene.loader import load_scene
    res = main_modes(load_scene(REPO / "cases" / "cantilever.toml"), 2)
    write_modes(res, tmp_path, frames=8, amplitude=0.02)
    import meshio
    pic = picture(tmp_path, field="displacement", mode=1)
    files = [meshio.read(tmp_path / f"mode_01_{k:03d}.vtu") for k in range(8)]
    mags = [np.linalg.norm(m.point_data["displacement"][m.point_data["line_id"] >= 0], axis=1) for m in files]
    assert pic.frames == list(range(8))
    assert pic.clim == (min(m.min() for m in mags), max(m.max() for m in mags))
    assert pic.clim[0] == 0.0 and pic.clim[1] == pytest.approx(0.02, rel=0.05)   # peak 2 cm
    rod = load_scene(REPO / "cases" / "cantilever.toml").net.lines[0]
    b = picture(tmp_path, mode=0, field="displacement", min_radius=0.0).tubes(0).bounds
    assert b[3] - b[2] == pytest.approx(2 * rod.section.radius, rel=0.02)
    path = render(tmp_path, field="displacement", mode=1, window_size=(W, H))
    assert path == tmp_path / "mode_01.png" and path.exists()
    assert main(["render", str(tmp_path), "--mode", "7"]) == 2
    assert len(res) == 2


def farthest(out) -> int:
    """The frame whose line vertices are farthest (r.m.s.) from frame 0, the last on a tie."""
    pos = [np.concatenate([out.frame(k)["lines"][n]["position"] for n in out.line_names])
           for k in range(len(out.times))]
    rms = np.array([np.sqrt(np.mean(np.sum((p - pos[0]) ** 2, axis=1))) for p in pos])
    return len(rms) - 1 - int(np.argmax(rms[::-1]))


def test_a_picture_shows_the_frame_where_the_lines_moved_most(run, tmp_path, capsys):
    """Without --frame the PNG is the frame farthest from frame 0; without --field it is
    coloured by velocity where velocity spans half its colour range in that frame, else by
    the displacement; the command says which, on stderr, after the picture is written."""
    from cosnet.output.render import AUTO_SHARE, Picture, choose
    out = read_output(run)
    field, k, why = choose(run)
    assert k == farthest(out) and 0 < k
    share = Picture(run, field="velocity", window_size=(W, H)).colour_share(k)
    assert field == ("velocity" if share >= AUTO_SHARE else "displacement")
    assert choose(run, field="force") == ("force", k, "the lines farthest (r.m.s.) from frame 0")
    assert choose(run, frame=-1)[1] == len(out.times) - 1
    assert main(["render", str(run), "--size", str(W), str(H), "--output", str(tmp_path / "a.png")]) == 0
    assert capsys.readouterr().err.strip() == f"frame {k}, coloured by {field}: {why}"


def test_the_default_case_is_drawn_as_the_lorry_crosses(tmp_path):
    """The bridge run to 4 s: the picture is a frame of the lorry's crossing (it is on the
    bridge from 1.5 to 4.5 s), its colours spanning more than half of their range."""
    from cosnet.output.render import Picture, choose
    assert main(["run", "--out", str(tmp_path / "bridge"), "--until", "4"]) == 0
    field, k, _ = choose(tmp_path / "bridge")
    t = read_output(tmp_path / "bridge").times[k]
    assert 1.5 < t <= 4.0
    assert Picture(tmp_path / "bridge", field=field, window_size=(W, H)).colour_share(k) > 0.5


def test_bad_options_give_one_line(run, capsys):
    for args, words in ((["--view", "sideways"], "AZIMUTH,ELEVATION"),
                        (["--view=10,95"], "elevation"),
                        (["--clim", "2", "1"], "LO < HI"),
                        (["--warp", "-1"], "--warp"),
                        (["--field", "nonsense"], "velocity"),
                        (["--frame", "9"], "0..4")):
        assert main(["render", str(run), *args]) == 2, args
        err = capsys.readouterr().err.strip()
        assert err.count("\n") == 0 and words in err, (args, err)


def _blocks(lang):
    text = (REPO / "docs" / "pictures.md").read_text()
    return re.findall(rf"```{lang}\n(.*?)```", text, flags=re.S)


def test_docs_commands_run(tmp_path, monkeypatch):
    """Every command of docs/pictures.md, verbatim, in a fresh directory; then its Python."""
    monkeypatch.chdir(tmp_path)
    movies = importlib.util.find_spec("imageio") is not None
    ran = 0
    for block in _blocks("sh"):
        for line in block.strip().splitlines():
            argv = shlex.split(line)
            assert argv[0] == "cosnet"
            if ("--gif" in argv or "--mp4" in argv) and not movies:
                continue
            if argv[1] == "view":           # serves until stopped: fetch its page, then stop it
                assert "window.cosnetView" in served_page(argv[2:])[1]
                ran += 1
                continue
            assert main(argv[1:]) == 0, line
            if "--output" in argv:
                assert (tmp_path / argv[argv.index("--output") + 1]).stat().st_size > 0
            ran += 1
    assert ran >= 7
    for block in _blocks("python"):
        exec(compile(block, "docs/pictures.md", "exec"), {})
    assert (tmp_path / "sag_fixed.png").exists()


def test_version_is_the_package_metadata(capsys):
    from importlib.metadata import version
    with pytest.raises(SystemExit) as e:
        main(["--version"])
    assert e.value.code == 0 and capsys.readouterr().out.strip() == f"cosnet {version('cosnet')}"


def test_bodies_and_obstacles_are_drawn_with_their_shapes(tmp_path):
    """A static capsule (cases/capstan.toml's drum, start (0, -0.1, 0), end (0, 0.1, 0),
    radius 0.1) is drawn where it is declared; a body's sphere (cases/net_catch.toml's ball,
    radius 0.07) follows its node, frame by frame."""
    from cosnet.output.render import Picture
    for case in ("capstan", "net_catch"):
        assert main(["run", str(REPO / "cases" / f"{case}.toml"), "--until", "0.02", "--out",
                     str(tmp_path / case)]) == 0
    ((drum, fixed),) = Picture(tmp_path / "capstan").shape_meshes(0)
    assert fixed
    # drawn as 32-sided spheres and cylinder: bounds within 1 % of the radius (the facets' chord)
    np.testing.assert_allclose(drum.bounds, (-0.1, 0.1, -0.2, 0.2, -0.1, 0.1), atol=1e-3)
    out = read_output(tmp_path / "net_catch")
    picture = Picture(tmp_path / "net_catch")
    ball = out.node_names.index("ball")
    for k in (0, len(out.times) - 1):
        ((sphere, fixed),) = picture.shape_meshes(k)
        centre = out.frame(k)["nodes"]["position"][ball]
        assert not fixed
        # pyvista keeps points in single precision
        np.testing.assert_allclose(np.reshape(sphere.bounds, (3, 2)).mean(axis=1), centre, atol=1e-6)
        np.testing.assert_allclose(np.diff(np.reshape(sphere.bounds, (3, 2)), axis=1).ravel(), 0.14, rtol=1e-2)
