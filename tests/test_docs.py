"""The README and every page of docs/ say only what runs: each page's Python blocks run in
order as one script, each TOML block that is a whole scene loads and builds its simulation,
and each `cosnet ...` line of a shell block runs and exits 0. The two set-up lines'
`pip install` and `pytest` halves are what .ci/run itself runs."""

import os
import re
import shlex
import tomllib
from pathlib import Path

import pytest

from cosnet.cli import main
from cosnet.scene import load_scene

REPO = Path(__file__).resolve().parents[1]
PAGES = [REPO / "README.md", *sorted((REPO / "docs").glob("*.md"))]
FENCE = re.compile(r"^( *)```(\w*)\n(.*?)^\1```", re.S | re.M)
SETUP = ("pip install", "pytest")   # run by .ci/run on a clean clone, not from here


def blocks(page: Path, lang: str) -> list[str]:
    out = []
    for m in FENCE.finditer(page.read_text(encoding="utf-8")):
        if m.group(2) == lang:
            indent = len(m.group(1))
            out.append("\n".join(line[indent:] for line in m.group(3).splitlines()))
    return out


def commands(page: Path) -> list[list[str]]:
    """The `cosnet` commands of a page's shell blocks (each `&&` part of a line separately;
    comments dropped)."""
    out = []
    for block in blocks(page, "bash"):
        for line in block.splitlines():
            for part in line.split("#", 1)[0].split("&&"):
                words = shlex.split(part)
                if not words or part.strip().startswith(SETUP):
                    continue
                assert words[0] == "cosnet", f"{page.name}: a shell line the tests cannot run: {line!r}"
                out.append(words[1:])
    return out


def test_every_fence_is_a_known_kind():
    """A block of another language would escape the checks below."""
    for page in PAGES:
        for m in FENCE.finditer(page.read_text(encoding="utf-8")):
            assert m.group(2) in ("python", "toml", "bash", "text"), f"{page.name}: ```{m.group(2)} block"


@pytest.mark.parametrize("page", [p for p in PAGES if blocks(p, "python")], ids=lambda p: p.name)
def test_python_blocks_run(page, tmp_path, monkeypatch):
    monkeypatch.chdir(tmp_path)
    namespace = {"__name__": f"docs_{page.stem}"}
    for k, code in enumerate(blocks(page, "python")):
        exec(compile(code, f"{page.name} python block {k + 1}", "exec"), namespace)


@pytest.mark.parametrize("page", [p for p in PAGES if blocks(p, "toml")], ids=lambda p: p.name)
def test_scene_blocks_load_and_build(page, tmp_path):
    for k, text in enumerate(blocks(page, "toml")):
        tomllib.loads(text)   # a fragment must at least be TOML
        if "[lines." in text:
            path = tmp_path / f"{page.stem}_{k + 1}.toml"
            path.write_text(text, encoding="utf-8")
            scene = load_scene(path)
            assert scene.simulation().dt > 0


@pytest.mark.parametrize("page", [p for p in PAGES if commands(p)], ids=lambda p: p.name)
def test_commands_run(page, tmp_path, monkeypatch):
    monkeypatch.chdir(tmp_path)
    for words in commands(page):
        assert main(words) == 0, f"{page.name}: cosnet {' '.join(words)} failed"


def test_pages_link_only_to_files_that_exist():
    for page in PAGES:
        for target in re.findall(r"\]\(([^)#:]+)\)", page.read_text(encoding="utf-8")):
            assert (page.parent / target).exists(), f"{page.name} links to missing {target}"


def test_readme_setup_is_what_ci_runs():
    ci = (REPO / ".ci" / "run").read_text()
    setup = blocks(REPO / "README.md", "bash")[0]
    assert 'pip install ".[test]"' in setup and 'pip install --quiet ".[test]"' in ci
    assert "pytest -n auto" in setup and re.search(r"^pytest .*-n auto", ci, re.M)
    assert os.path.isfile(REPO / "cases" / "bridge.toml")
