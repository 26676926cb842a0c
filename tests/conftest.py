"""Shared fixtures; tests under tests/integration are marked `integration` by path."""

import pytest

from mbs_clearance import SliderCrank


def pytest_collection_modifyitems(config, items):
    for item in items:
        if "/integration/" in str(item.fspath):
            item.add_marker(pytest.mark.integration)


@pytest.fixture(scope="session")
def paper():
    return SliderCrank()
