"""Shared test fixtures."""

import pytest


@pytest.fixture(scope="module")
def report(request):
    """Lines a statistical test wants shown (bias tables, confusion matrices): printed at
    the end of the module even when pytest captures output, so the test log carries them."""
    lines: list[str] = []
    yield lines
    capman = request.config.pluginmanager.getplugin("capturemanager")
    with capman.global_and_fixture_disabled():
        for line in lines:
            print(line)
