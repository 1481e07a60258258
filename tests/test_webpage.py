"""The run as a web page (``cosnet render OUT --html``, ``cosnet view OUT``): the page holds the
run's own positions, radii and field magnitudes; a 3-frame run's page is small and asks the
network for nothing; in a real browser (headless Chromium driven by Playwright) the canvas
is drawn, the slider changes the frame drawn and the menu the colours; ``cosnet view``
serves it on localhost."""

import base64
import io
import os
import shutil
import tomllib
from pathlib import Path

import numpy as np
import pytest

from cosnet.cli import main
from cosnet.core.samples import cantilever_scene
from cosnet.output.io import read_output
from cosnet.output.webpage import page_data, write_html
from nets import written_run
from procs import served_page

REPO = Path(__file__).resolve().parents[1]
# a cantilever swinging down under gravity, three frames (t = 0, 0.005, 0.01 s)
ROD = cantilever_scene("rod", E="1.0e8", G=repr(1.0e8 / 2.6), density="1000.0", elements=6, material="m",
                       rest='[[effects]]\nkind = "gravity"\n[run]\nuntil = 0.01\noutput_interval = 0.005\n')
# what the browser is started with: no GPU here, so WebGL on SwiftShader; no background traffic
CHROMIUM_ARGS = ["--headless=new", "--no-sandbox", "--disable-gpu", "--use-angle=swiftshader",
                 "--enable-unsafe-swiftshader", "--disable-background-networking", "--disable-component-update",
                 "--disable-sync", "--no-first-run", "--disable-quic"]


def decode(text, dtype=np.float32):
    return np.frombuffer(base64.b64decode(text), dtype=dtype)


@pytest.fixture(scope="module")
def run(tmp_path_factory):
    return written_run(tmp_path_factory.mktemp("page"), ROD)


def test_the_page_holds_the_runs_positions_radii_and_field_magnitudes(run):
    out = read_output(run)
    data = page_data(run)
    frames = len(out.times)
    assert frames == 3 and data["times"] == list(out.times) and data["counts"] == [7]
    x = decode(data["positions"]).reshape(frames, -1, 3)
    v = decode(data["fields"]["velocity"]["values"]).reshape(frames, -1)
    d = decode(data["fields"]["displacement"]["values"]).reshape(frames, -1)
    for k in range(frames):
        line = out.frame(k)["lines"]["rod"]
        np.testing.assert_allclose(x[k], line["position"], rtol=1e-6, atol=1e-7)
        np.testing.assert_allclose(v[k], np.linalg.norm(line["velocity"], axis=-1), rtol=1e-6, atol=1e-7)
        np.testing.assert_allclose(d[k], np.linalg.norm(line["position"] - out.frame(0)["lines"]["rod"]["position"],
                                                        axis=-1), rtol=1e-6, atol=1e-7)
    # one colour range over all frames: the field's extremes
    assert data["fields"]["velocity"]["range"] == pytest.approx([v.min(), v.max()], rel=1e-6)
    # the rod's true radius (its section), well above the visible minimum of 0.2 % of the scene
    radius = float(tomllib.loads(ROD)["sections"]["rod"]["radius"])
    np.testing.assert_allclose(decode(data["radius"]), radius, rtol=1e-6)
    assert set(data["fields"]) >= {"velocity", "force", "torque", "strain", "curvature", "displacement"}
    assert not set(data["fields"]) & {"d1", "d2", "d3"}      # unit vectors colour nothing


def test_a_bodys_shape_follows_its_node_in_the_page(tmp_path):
    """cases/net_catch.toml's ball (a sphere of radius 0.07 on node "ball"): the page holds
    the sphere about the node's origin and, per frame, the node's position and frame."""
    assert main(["run", str(REPO / "cases" / "net_catch.toml"), "--until", "0.02", "--out", str(tmp_path)]) == 0
    out = read_output(tmp_path)
    data = page_data(tmp_path)
    (ball,) = data["shapes"]
    assert ball["node"] == out.node_names.index("ball") and ball["kind"] == "sphere"
    pts = decode(ball["points"]).reshape(-1, 3)
    np.testing.assert_allclose(np.linalg.norm(pts, axis=1), 0.07, rtol=1e-6)
    place = decode(ball["place"]).reshape(len(out.times), 3, 4)
    for k in range(len(out.times)):
        nodes = out.frame(k)["nodes"]
        np.testing.assert_allclose(place[k, :, 0], nodes["position"][ball["node"]], rtol=1e-6, atol=1e-7)
        np.testing.assert_allclose(place[k, :, 1], nodes["d1"][ball["node"]], atol=1e-6)


def test_a_modes_page_holds_the_mode_shape(tmp_path):
    """`cosnet modes` writes each mode as a series over one period; its page (mode_JJ.html,
    as its picture is named) holds those frames, coloured by the displacement."""
    import meshio
    assert main(["modes", "cantilever", "--count", "2", "--frames", "4", "--out", str(tmp_path)]) == 0
    assert main(["render", str(tmp_path), "--html", "--mode", "1"]) == 0
    assert (tmp_path / "mode_01.html").exists() and not (tmp_path / "view.html").exists()
    data = page_data(tmp_path, mode=1)
    assert data["title"] == "mode_01" and list(data["fields"]) == ["displacement"]
    x = decode(data["positions"]).reshape(len(data["times"]), -1, 3)
    for k in range(len(data["times"])):
        m = meshio.read(tmp_path / f"mode_01_{k:03d}.vtu")
        on = np.asarray(m.point_data["line_id"]) >= 0
        np.testing.assert_allclose(x[k], m.points[on], rtol=1e-6, atol=1e-7)
        d = decode(data["fields"]["displacement"]["values"]).reshape(len(data["times"]), -1)[k]
        np.testing.assert_allclose(d, np.linalg.norm(m.point_data["displacement"][on], axis=-1), rtol=1e-6,
                                   atol=1e-9)


def test_a_three_frame_page_is_small_and_names_no_outside_file(run, tmp_path):
    path = write_html(run, output=tmp_path / "page.html")
    text = path.read_text()
    assert path.stat().st_size < 2_000_000
    # scripts and styles are inline: nothing to fetch
    assert "<script src" not in text and "<link" not in text and "@import" not in text


def _browser():
    """Playwright and a Chromium to drive, or a skip saying which is missing."""
    try:
        from playwright.sync_api import sync_playwright
    except ImportError:
        pytest.skip("the browser test needs Playwright: pip install 'cosnet[test]'")
    exe = os.environ.get("COSNET_CHROMIUM") or shutil.which("chromium") or shutil.which("chromium-browser")
    if exe is None:
        pytest.skip("the browser test needs Chromium (Debian: apt-get install chromium; or set COSNET_CHROMIUM)")
    return sync_playwright, exe


def _shot(page) -> np.ndarray:
    """The canvas's own pixels (the page keeps its drawing buffer), without the panel over it."""
    from PIL import Image
    url = page.evaluate("document.querySelector('#view canvas').toDataURL('image/png')")
    png = base64.b64decode(url.split(",", 1)[1])
    return np.asarray(Image.open(io.BytesIO(png)).convert("RGB")).astype(int)


def test_the_page_in_a_real_browser(run, tmp_path):
    """Opened from a file with the network refused: drawn, the slider moves the rod, the
    menu recolours it."""
    sync_playwright, exe = _browser()
    path = write_html(run, output=tmp_path / "page.html")
    asked, errors = [], []
    with sync_playwright() as pw:
        browser = pw.chromium.launch(executable_path=exe, args=CHROMIUM_ARGS, timeout=120_000)
        try:
            page = browser.new_page(viewport={"width": 640, "height": 480})
            page.on("pageerror", lambda e: errors.append(str(e)))
            page.route("**/*", lambda r: r.continue_() if r.request.url.startswith("file:")
                       else (asked.append(r.request.url), r.abort()))
            page.goto(path.as_uri())
            page.wait_for_function("window.cosnetView && (window.cosnetView.ready || window.cosnetView.error)",
                                   timeout=60_000)
            assert page.evaluate("window.cosnetView.error") is None
            assert not errors and not asked
            first = _shot(page)
            background = np.all(first == 255, axis=-1)
            # the rod, the fixed end's cube: a few per cent of the canvas, shaded in many colours
            assert 0.002 < 1 - background.mean() < 0.5
            assert len(np.unique(first[~background].reshape(-1, 3), axis=0)) > 20
            page.locator("#slider").fill("2")
            assert page.evaluate("window.cosnetView.frame") == 2
            label = page.locator("#time").inner_text().split()
            assert float(label[2]) == pytest.approx(read_output(run).times[2], rel=1e-3)
            moved = _shot(page)
            assert np.any(np.all(moved == 255, axis=-1) != background)      # the rod is elsewhere
            page.select_option("#field", "displacement")
            recoloured = _shot(page)
            drawn = ~np.all(recoloured == 255, axis=-1)
            assert np.array_equal(drawn, ~np.all(moved == 255, axis=-1))    # the same shape...
            assert np.abs(recoloured - moved)[drawn].max() > 30              # ... in other colours
            assert page.locator("#unit").inner_text() == "displacement magnitude (m)"
            assert not errors and not asked
        finally:
            browser.close()


def test_view_serves_the_page_on_localhost(run):
    """`cosnet view DIR --no-browser` writes the page if needed, prints its address, serves it."""
    (run / "view.html").unlink(missing_ok=True)
    url, text = served_page([run])
    assert url.endswith("/view.html") and text == (run / "view.html").read_text()


def test_bad_input_gives_one_line(run, tmp_path, capsys):
    for argv, words in ((["render", str(tmp_path / "none"), "--html"], "not a cosnet output directory"),
                        (["view", str(tmp_path / "none")], "not a cosnet output directory"),
                        (["render", str(run), "--html", "--min-radius", "-1"], "--min-radius")):
        assert main(argv) == 2, argv
        err = capsys.readouterr().err.strip()
        assert err.count("\n") == 0 and words in err, (argv, err)
