"""tests/ci_skips.py: under CI a skip for a package the test extra installs fails; elsewhere
it stays a skip, and other skips stay skips everywhere."""

import pytest

BODY = """
import pytest

def test_needs_a_package():
    pytest.importorskip("no_such_package_here", reason="X (pip install '.[peers]') is not installed")

def test_needs_a_browser():
    pytest.skip("the browser test needs Chromium")
"""


@pytest.mark.parametrize("ci, failed", [("true", 1), (None, 0)])
def test_a_skip_for_a_test_extra_package_fails_under_ci(pytester, monkeypatch, ci, failed):
    if ci:
        monkeypatch.setenv("CI", ci)
    else:
        monkeypatch.delenv("CI", raising=False)
    pytester.makepyfile(BODY)
    result = pytester.runpytest_inprocess("-p", "ci_skips", "-p", "no:cacheprovider")
    result.assert_outcomes(failed=failed, skipped=2 - failed)
    if failed:
        result.stdout.fnmatch_lines(["*CI installs the test extra, so this skip would hide the test*"])
