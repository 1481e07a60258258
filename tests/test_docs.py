"""The README and every page of docs/ say only what runs: a page's blocks run in its order
(Python as one script, each `cosnet ...` line of a shell block through the command, each TOML
block that is a whole scene loaded and built), or a test module named on the page runs them
and checks what they print. The two set-up lines' `pip install` and `pytest` halves are what
.ci/run itself runs."""

import importlib.util
import os
import re
import shlex
import tomllib
from pathlib import Path

import pytest

from cosnet.cli import main
from cosnet.scene.loader import load_scene

REPO = Path(__file__).resolve().parents[1]
PAGES = [REPO / "README.md", *sorted((REPO / "docs").glob("*.md"))]
FENCE = re.compile(r"^( *)```(\w*)\n(.*?)^\1```", re.S | re.M)
SETUP = ("pip install", "pytest")   # run by .ci/run on a clean clone, not from here


OWN_TEST = re.compile(r"<!-- code blocks run by (tests/[\w/]+\.py) -->")
SHELL = ("bash", "sh")


def fences(page: Path) -> list[tuple[str, str]]:
    """(language, code) of each fenced block of a page, in order, dedented."""
    out = []
    for m in FENCE.finditer(page.read_text(encoding="utf-8")):
        indent = len(m.group(1))
        out.append((m.group(2), "\n".join(line[indent:] for line in m.group(3).splitlines())))
    return out


def blocks(page: Path, lang: str) -> list[str]:
    return [code for kind, code in fences(page) if kind == lang]


def own_test(page: Path) -> str | None:
    """The test module that runs this page's blocks itself (it says so in a comment)."""
    m = OWN_TEST.search(page.read_text(encoding="utf-8"))
    return m.group(1) if m else None


def commands(code: str, page: Path) -> list[list[str]]:
    """The `cosnet` commands of a shell block (each `&&` part of a line separately; comments
    dropped)."""
    out = []
    for line in code.splitlines():
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
        for kind, _ in fences(page):
            assert kind in ("python", "toml", "text", *SHELL), f"{page.name}: ```{kind} block"


@pytest.mark.parametrize("page", [p for p in PAGES if own_test(p)], ids=lambda p: p.name)
def test_pages_with_a_test_of_their_own_name_it(page):
    test = REPO / own_test(page)
    assert test.is_file() and f"docs/{page.name}" in test.read_text(encoding="utf-8")


@pytest.mark.parametrize("page", [p for p in PAGES if not own_test(p) and fences(p)], ids=lambda p: p.name)
def test_blocks_run_in_order(page, tmp_path, monkeypatch):
    """Python blocks run as one script, shell blocks' cosnet commands through the command's
    main, both in the page's order in a fresh directory beside the ready cases (as in a
    checkout); a TOML block that is a whole scene loads and builds its simulation."""
    (tmp_path / "cases").symlink_to(REPO / "cases")
    monkeypatch.chdir(tmp_path)
    namespace = {"__name__": f"docs_{page.stem}"}
    for k, (kind, code) in enumerate(fences(page)):
        where = f"{page.name} block {k + 1}"
        if kind == "python":
            exec(compile(code, where, "exec"), namespace)
        elif kind in SHELL:
            for words in commands(code, page):
                assert main(words) == 0, f"{where}: cosnet {' '.join(words)} failed"
        elif kind == "toml":
            tomllib.loads(code)   # a fragment must at least be TOML
            if "[lines." in code:
                path = tmp_path / f"{page.stem}_{k + 1}.toml"
                path.write_text(code, encoding="utf-8")
                assert load_scene(path).simulation().dt > 0, where


def test_pages_link_only_to_files_that_exist():
    for page in PAGES:
        for target in re.findall(r"\]\(([^)#:]+)\)", page.read_text(encoding="utf-8")):
            assert (page.parent / target).exists(), f"{page.name} links to missing {target}"


def test_readme_setup_is_what_ci_runs():
    ci = (REPO / ".ci" / "run").read_text()
    setup = blocks(REPO / "README.md", "bash")[0]
    assert 'pip install ".[test]"' in setup and re.search(r'pip install --quiet[^"\n]* "\.\[test[,\]]', ci)
    assert "pytest -n auto" in setup and re.search(r"^pytest .*-n auto", ci, re.M)
    assert os.path.isfile(REPO / "cases" / "bridge.toml")


def _bench_tables():
    spec = importlib.util.spec_from_file_location("bench_tables", REPO / "bench" / "tables.py")
    tables = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(tables)
    return tables


def test_bench_tables_are_made_from_the_bench_json():
    """The tables and the marked figures of README.md and docs/ are bench/tables.py's
    rendering of the committed JSON: a figure edited by hand, or JSON rerun without the pages,
    fails."""
    assert _bench_tables().stale() == [], "pages differ from bench/*.json: run python bench/tables.py"


def test_a_figure_edited_by_hand_is_rendered_back_and_a_bad_source_named(tmp_path):
    """A marked figure is its expression over the JSON, whatever the page says; an expression
    naming a key the JSON lacks fails with the page and the expression."""
    tables = _bench_tables()
    ns = {"run": tables._wrap({"rows": [{"n": 10, "rate": 41_417.4}, {"n": 100, "rate": 40_375.6}],
                              "error": 0.0010337})} | tables.FORMATS
    page = tmp_path / "page.md"
    page.write_text("rate <!-- fig: sci(run.rows.where(n=100).rate, 3) -->5.0 × 10^4<!-- /fig --> rod-steps/s, "
                    "error <!-- fig: pct(run.error) -->0.01 %<!-- /fig -->, "
                    "<!-- fig: span([r.rate / 1000 for r in run.rows], 3) -->x<!-- /fig --> k\n", encoding="utf-8")
    assert tables.render(page, ns) == (
        "rate <!-- fig: sci(run.rows.where(n=100).rate, 3) -->4.04 × 10^4<!-- /fig -->"
        " rod-steps/s, error <!-- fig: pct(run.error) -->0.10 %<!-- /fig -->, "
        "<!-- fig: span([r.rate / 1000 for r in run.rows], 3) -->40.4–41.4<!-- /fig --> k\n")
    page.write_text("<!-- fig: run.rows.where(n=7).rate -->1<!-- /fig -->\n", encoding="utf-8")
    with pytest.raises(ValueError, match=r"page.md: figure 'run.rows.where\(n=7\).rate': LookupError: 0 rows"):
        tables.render(page, ns)


def test_the_site_lists_every_page():
    """mkdocs.yml's nav names each page of docs/ once, and only pages that exist."""
    nav = re.findall(r":\s*([\w/]+\.md)\s*$", (REPO / "mkdocs.yml").read_text(encoding="utf-8"), re.M)
    pages = sorted(p.name for p in (REPO / "docs").glob("*.md"))
    assert sorted(nav) == pages


def test_the_gallery_shows_every_case():
    """docs/cases.md lists every case of cases/ in its table and draws each in its gallery, a
    picture and a GIF from the case's own run (bench/gallery.json, rendered into the page)."""
    import json
    page = (REPO / "docs" / "cases.md").read_text(encoding="utf-8")
    drawn = {r["case"]: r for r in json.loads((REPO / "bench" / "gallery.json").read_text())["rows"]}
    for scene in sorted((REPO / "cases").glob("*.toml")):
        name = scene.stem
        assert f"| `{name}`" in page, f"docs/cases.md has no row for {name}"
        assert name in drawn, f"bench/gallery.json has not drawn {name}: python bench/gallery.py {name}"
        for kind in ("png", "gif"):
            assert (REPO / "docs" / "cases" / f"{name}.{kind}").exists(), f"no picture docs/cases/{name}.{kind}"
            assert f"](cases/{name}.{kind})" in page, f"docs/cases.md does not show {name}.{kind}"
