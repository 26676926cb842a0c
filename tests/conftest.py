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


@pytest.fixture
def tmpfs(tmp_path):
    """mount(options): a small tmpfs mounted on a new folder of tmp_path (e.g.
    "ro,size=64k"), unmounted after the test; the test is skipped where mounting is not
    allowed (it needs root)."""
    import shutil
    import subprocess

    mounted = []

    def mount(options: str):
        path = tmp_path / f"tmpfs{len(mounted)}"
        path.mkdir()
        if shutil.which("mount") is None or subprocess.run(
                ["mount", "-t", "tmpfs", "-o", options, "tmpfs", str(path)],
                capture_output=True).returncode != 0:
            pytest.skip(f"cannot mount a tmpfs ({options}) here (needs root / CAP_SYS_ADMIN)")
        mounted.append(path)
        return path

    yield mount
    for path in mounted:
        subprocess.run(["umount", str(path)], check=True)
