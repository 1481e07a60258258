"""Under CI (the environment variable CI set), a skip for a package the test extra installs
fails instead: CI installs ``.[test]``, so there such a skip would hide the test it skips.
Those skips say how to install what they miss ("pip install ..."); skips for what pip does
not install (a browser, a mount) decide for themselves."""

import os

import pytest


@pytest.hookimpl(hookwrapper=True)
def pytest_runtest_makereport(item, call):
    outcome = yield
    report = outcome.get_result()
    if os.environ.get("CI") and report.skipped and "pip install" in str(report.longrepr):
        reason = report.longrepr[2] if isinstance(report.longrepr, tuple) else str(report.longrepr)
        report.outcome = "failed"
        report.longrepr = f"CI installs the test extra, so this skip would hide the test: {reason}"
