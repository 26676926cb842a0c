"""The compiled-code cache of the core (core/build.py): built once per digest, loaded only from
trusted directories and only when its bytes match their record, rebuilt when damaged, the next
place tried when one is full, and a missing compiler named in one line."""

from __future__ import annotations

import errno
import os
import stat

import pytest

from mbs_clearance._warnings import CacheWarning
from mbs_clearance.core import build

SOURCE = [("probe.c", "double scaled(double x) { return 2.5 * x; }\n")]
CDEF = "double scaled(double x);"


@pytest.fixture
def cache(tmp_path, monkeypatch):
    """A fresh cache: MBS_CLEARANCE_CACHE_DIR and XDG_CACHE_HOME under tmp_path, nothing
    loaded or warned before."""
    first = tmp_path / "first"
    monkeypatch.setenv("MBS_CLEARANCE_CACHE_DIR", str(first))
    monkeypatch.setenv("XDG_CACHE_HOME", str(tmp_path / "xdg"))
    monkeypatch.setattr(build, "_LOADED", {})
    monkeypatch.setattr(build, "_WARNED", set())
    return first


def _count_compiles(monkeypatch) -> list:
    calls = []
    real = build._compile

    def counting(*args, **kwargs):
        calls.append(args[3])
        return real(*args, **kwargs)

    monkeypatch.setattr(build, "_compile", counting)
    return calls


def test_built_once_and_found_by_digest(cache, monkeypatch):
    calls = _count_compiles(monkeypatch)
    first = build.build("probe", SOURCE)
    again = build.build("probe", SOURCE)
    assert first == again and len(calls) == 1
    assert first.parent == cache
    ffi, lib = build.load("probe", SOURCE, CDEF)
    assert lib.scaled(4.0) == 10.0


def test_changed_source_is_a_new_library(cache, monkeypatch):
    calls = _count_compiles(monkeypatch)
    old = build.build("probe", SOURCE)
    changed = [("probe.c", SOURCE[0][1].replace("2.5", "3.5"))]
    new = build.build("probe", changed)
    assert old != new and len(calls) == 2
    # the old library stays valid for the old sources and is never loaded for the new ones
    assert build.build("probe", SOURCE) == old and len(calls) == 2


def test_damaged_library_is_rebuilt_with_one_warning(cache, monkeypatch):
    path = build.build("probe", SOURCE)
    data = bytearray(path.read_bytes())
    data[len(data) // 2] ^= 0xFF
    path.write_bytes(bytes(data))
    with pytest.warns(CacheWarning, match=str(path)):
        rebuilt = build.build("probe", SOURCE)
    assert rebuilt == path and build._valid(path)


def test_library_without_its_record_is_rebuilt(cache, monkeypatch):
    path = build.build("probe", SOURCE)
    path.with_suffix(".sha256").unlink()
    calls = _count_compiles(monkeypatch)
    with pytest.warns(CacheWarning, match="does not match its recorded digest"):
        build.build("probe", SOURCE)
    assert len(calls) == 1


def test_directory_writable_by_others_is_never_used(cache, tmp_path, monkeypatch):
    cache.mkdir(mode=0o700)
    os.chmod(cache, 0o777)
    with pytest.warns(CacheWarning, match=str(cache)):
        path = build.build("probe", SOURCE)
    assert path.parent == tmp_path / "xdg" / "mbs-clearance" / "core"
    assert not any(cache.iterdir())


def test_library_writable_by_others_is_rebuilt(cache):
    path = build.build("probe", SOURCE)
    os.chmod(path, 0o777)
    with pytest.warns(CacheWarning, match=str(path)):
        build.build("probe", SOURCE)
    assert not os.stat(path).st_mode & (stat.S_IWGRP | stat.S_IWOTH)


def test_full_directory_falls_through_to_the_next(cache, tmp_path, monkeypatch):
    real = build._compile

    def full_first(cc, sources, flags, lib, label):
        if lib.parent == cache:
            raise OSError(errno.ENOSPC, "No space left on device")
        return real(cc, sources, flags, lib, label)

    monkeypatch.setattr(build, "_compile", full_first)
    with pytest.warns(CacheWarning, match=f"{cache}.*No space left on device"):
        path = build.build("probe", SOURCE)
    assert path.parent != cache and build._valid(path)


def test_missing_compiler_is_one_line_naming_what_to_install(cache, monkeypatch):
    monkeypatch.setenv("CC", "no-such-compiler-xyz")
    with pytest.raises(build.CompilerMissing) as info:
        build.build("probe", SOURCE)
    message = str(info.value)
    assert "\n" not in message and "install gcc" in message
    assert "no-such-compiler-xyz" in message


def test_compile_error_names_the_library(cache):
    with pytest.raises(RuntimeError, match="compiling broken failed"):
        build.build("broken", [("broken.c", "double f(double x) { return x +; }\n")])
