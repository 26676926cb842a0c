"""The compiled-kernel cache (mbs_clearance/_cache.py), with real processes.

Every test copies packages to a temporary directory and imports them in new Python processes:
(i) an edit of a file a cached kernel calls into (not the kernel's own file) is computed by
the next process; (ii) a process that imported before an edit and compiles after it does not
hand its old code to a process with the new sources; (iii) a read-only install with a
read-only home imports, computes the same numbers and prints one CacheWarning line.

The fast tests use two small packages registered like mbs_clearance and validation (a
kernel, a helper it inlines, and a second package whose kernel inlines the first one's
code), so that they compile in about a second; the tests on copies of the real packages
compile all of mbs_clearance's kernels once (the read-only one is fast, the others slow).
"""

from __future__ import annotations

import json
import os
import re
import shlex
import shutil
import subprocess
import sys
import textwrap
import time
from pathlib import Path

import numpy as np
import pytest

import mbs_clearance
from mbs_clearance import SliderCrank, _cache
from mbs_clearance.solve import reduced

REPO = Path(mbs_clearance.__file__).resolve().parents[1]

# ---------------------------------------------------------------- the small packages

KPKG = {
    "__init__.py": """
        from mbs_clearance._cache import register_package

        register_package(__name__)
    """,
    "helper.py": """
        import numba as nb

        SCALE = 2.0


        @nb.njit(inline="always")
        def scaled(x):
            return SCALE * x
    """,
    "kern.py": """
        import numba as nb

        from .helper import scaled


        @nb.njit(cache=True)
        def kernel(x):
            return scaled(x) + 1.0
    """,
}
# a package whose kernel inlines kpkg's code, registered as validation is
KCON = {
    "__init__.py": """
        from mbs_clearance._cache import register_package

        register_package(__name__, depends_on=("kpkg",))
    """,
    "outer.py": """
        import numba as nb

        from kpkg.helper import scaled


        @nb.njit(cache=True)
        def outer(x):
            return 10.0 * scaled(x)
    """,
}
# kpkg without the registration: numba's own cache, the control
KRAW = {**KPKG, "__init__.py": ""}


def write_package(root: Path, name: str, files: dict[str, str]) -> Path:
    pkg = root / name
    pkg.mkdir(parents=True)
    for fname, text in files.items():
        (pkg / fname).write_text(textwrap.dedent(text).lstrip())
    return pkg


def edit(path: Path, old: str, new: str) -> None:
    """Replace the one occurrence of `old` in `path` (fails if the file no longer has it)."""
    text = path.read_text()
    assert text.count(old) == 1, f"{path.name} changed: update the test's edit"
    path.write_text(text.replace(old, new))


def clean_env(pythonpath: list[Path], **extra: str) -> dict[str, str]:
    env = {k: v for k, v in os.environ.items()
           if not k.startswith("NUMBA_CACHE") and k != "XDG_CACHE_HOME"}
    # no .pyc: an edit within the second of the last import that keeps the file's size
    # would otherwise be run from the old .pyc (Python's own check)
    env.update(PYTHONPATH=os.pathsep.join(map(str, pythonpath)), PYTHONDONTWRITEBYTECODE="1",
               **extra)
    return env


def stats_code(name: str) -> str:
    return (f"st = {name}.stats; print(json.dumps({{'value': float(value), "
            f"'hits': sum(st.cache_hits.values()), 'misses': sum(st.cache_misses.values()), "
            f"'path': st.cache_path}}))")


KERNEL_RUN = "import json\nfrom kpkg.kern import kernel\nvalue = kernel(1.0)\n" + \
    stats_code("kernel")
OUTER_RUN = "import json\nfrom kcon.outer import outer\nvalue = outer(1.0)\n" + \
    stats_code("outer")


def first_path(env: dict[str, str]) -> str:
    """The directory to run in: the first of PYTHONPATH (`python -c` puts the working
    directory first on sys.path: the worktree's packages would shadow the copies)."""
    return env["PYTHONPATH"].split(os.pathsep)[0]


def run(code: str, env: dict[str, str], prefix: tuple[str, ...] = (),
        timeout: float = 600) -> tuple[dict, str]:
    """Run `code` in a new process; returns the JSON of its last stdout line and its stderr."""
    proc = subprocess.run([*prefix, sys.executable, "-c", code], env=env, cwd=first_path(env),
                          capture_output=True, text=True, timeout=timeout)
    assert proc.returncode == 0, proc.stderr
    return json.loads(proc.stdout.strip().splitlines()[-1]), proc.stderr


@pytest.fixture
def small(tmp_path):
    """kpkg and kcon in tmp_path/src; returns (src, env)."""
    src = tmp_path / "src"
    write_package(src, "kpkg", KPKG)
    write_package(src, "kcon", KCON)
    return src, clean_env([src, REPO])


# ---------------------------------------------------------------- (i) edits of helpers


def test_an_edit_of_an_inlined_helper_is_computed_by_the_next_process(small, tmp_path):
    """kpkg.kern.kernel and kcon.outer (another package) inline kpkg/helper.py; after an edit
    of the helper the next process computes the new value; numba's own cache (the control,
    the same package unregistered) goes on returning the old one."""
    src, env = small
    write_package(tmp_path / "raw", "kpkg", KRAW)
    raw_env = clean_env([tmp_path / "raw", REPO])
    raw_run = "import mbs_clearance\n" + KERNEL_RUN      # locator installed, not for kpkg
    expected = {KERNEL_RUN: 2.0 * 1.0 + 1.0, OUTER_RUN: 10.0 * 2.0, raw_run: 2.0 * 1.0 + 1.0}
    for code, e in ((KERNEL_RUN, env), (OUTER_RUN, env), (raw_run, raw_env)):
        first, _ = run(code, e)
        again, _ = run(code, e)
        assert first["misses"] == 1 and again["hits"] == 1 and again["misses"] == 0
        assert first["value"] == again["value"] == expected[code]
    assert Path(first["path"]) == tmp_path / "raw" / "kpkg" / "__pycache__"   # numba's place
    edit(src / "kpkg" / "helper.py", "SCALE = 2.0", "SCALE = 3.0")
    edit(tmp_path / "raw" / "kpkg" / "helper.py", "SCALE = 2.0", "SCALE = 3.0")
    kernel, _ = run(KERNEL_RUN, env)
    outer, _ = run(OUTER_RUN, env)
    assert kernel["value"] == 3.0 * 1.0 + 1.0 and kernel["misses"] == 1
    assert outer["value"] == 10.0 * 3.0 and outer["misses"] == 1
    digest = _cache.sources_digest(src / "kpkg")
    assert Path(kernel["path"]) == src / "kpkg" / "__pycache__" / (_cache.PREFIX + digest[:12])
    assert Path(outer["path"]).name == _cache.PREFIX + _cache.sources_digest(
        src / "kcon", (digest,))[:12]
    assert run(raw_run, raw_env)[0]["value"] == 2.0 * 1.0 + 1.0        # numba alone: stale


# ---------------------------------------------------------------- (ii) the race


class Waiting:
    """A process that runs `first`, prints 'ready', and runs `then` when told to."""

    def __init__(self, first: str, then: str, env: dict[str, str]):
        code = f"{first}\nprint('ready', flush=True)\ninput()\n{then}"
        self.proc = subprocess.Popen([sys.executable, "-c", code], env=env, text=True,
                                     cwd=first_path(env), stdin=subprocess.PIPE,
                                     stdout=subprocess.PIPE, stderr=subprocess.PIPE)
        line = self.proc.stdout.readline()
        if line.strip() != "ready":
            self.proc.kill()
            raise AssertionError(line + self.proc.stderr.read())

    def go(self, timeout: float = 600) -> dict:
        out, err = self.proc.communicate("go\n", timeout=timeout)
        assert self.proc.returncode == 0, err
        return json.loads(out.strip().splitlines()[-1])


def test_a_process_compiling_pre_edit_code_does_not_serve_it_to_others(small):
    """A imports, the helper is edited, B imports the new sources, A compiles and caches
    (its own, old code), then B compiles: B computes the new value (with numba's own cache B
    would load A's entry: kern.py itself did not change); a later process C loads B's."""
    src, env = small
    a = Waiting("import json\nfrom kpkg.kern import kernel",
                "value = kernel(1.0)\n" + stats_code("kernel"), env)
    edit(src / "kpkg" / "helper.py", "SCALE = 2.0", "SCALE = 3.0")
    b = Waiting("import json\nfrom kpkg.kern import kernel",
                "value = kernel(1.0)\n" + stats_code("kernel"), env)
    ra = a.go()
    rb = b.go()
    assert ra["value"] == 2.0 * 1.0 + 1.0 and ra["misses"] == 1     # A: the code it imported
    assert rb["value"] == 3.0 * 1.0 + 1.0 and rb["misses"] == 1     # B: not A's entry
    assert ra["path"] != rb["path"] and list(Path(ra["path"]).glob("*.nbi"))
    rc, _ = run(KERNEL_RUN, env)
    assert rc["value"] == 3.0 * 1.0 + 1.0 and rc["hits"] == 1 and rc["path"] == rb["path"]


def test_an_edit_during_the_import_is_never_cached_for_others(small):
    """kcon is registered (digest taken), then kpkg's helper is edited before kcon.outer is
    defined: that process's outer gets a stamp no other process matches."""
    src, env = small
    code = ("import json, pathlib, kcon\n"
            f"p = pathlib.Path({str(src / 'kpkg' / 'helper.py')!r})\n"
            "p.write_text(p.read_text().replace('SCALE = 2.0', 'SCALE = 5.0'))\n"
            "from kcon.outer import outer\nvalue = outer(1.0)\n" + stats_code("outer"))
    mixed, _ = run(code, env)
    assert mixed["value"] == 10.0 * 5.0 and mixed["misses"] == 1
    edit(src / "kpkg" / "helper.py", "SCALE = 5.0", "SCALE = 2.0")   # back to the digest's
    back, _ = run(OUTER_RUN, env)
    assert back["path"] == mixed["path"]                # same key: the sources of the digest
    assert back["value"] == 10.0 * 2.0 and back["misses"] == 1 and back["hits"] == 0


# ------------------------------------------------ (iv) kernels of modules loaded from files

# a shared kernel taking a kernel as argument (as integrator.integrate takes a model's), and
# a kernel in a module imported from a file under a name no other process can import (as a
# model generated on demand is)
APPLY = """
    import numba as nb


    @nb.njit(cache=True)
    def apply(f, x):
        return f(x) + 1.0
"""
FILE_MODULE = """
import importlib.util, json, sys
spec = importlib.util.spec_from_file_location("loose_{tag}", {path!r})
mod = importlib.util.module_from_spec(spec)
sys.modules[spec.name] = mod
spec.loader.exec_module(mod)
from kpkg.apply import apply
{control}value = apply(mod.f, 2.0)
"""


#: code that gives numba's own cache files and loaders back (the controls)
NUMBA_ONLY = ("from numba.core import caching\nfrom mbs_clearance import _cache\n"
              "cls = caching.IndexDataCacheFile\n"
              "cls._load_index, cls._load_data = _cache._LOAD_INDEX, _cache._LOAD_DATA\n"
              "cls._save_index, cls._save_data = _cache._SAVE_INDEX, _cache._SAVE_DATA\n"
              "cls.save, cls.load = _cache._SAVE, _cache._LOAD\n")


def test_an_index_naming_a_module_loaded_from_a_file_reads_as_a_miss(small, tmp_path):
    """Process 1 compiles the shared kernel `apply` for a kernel of a module loaded from a
    file (its index then names that module); process 2, which never loaded it, compiles
    `apply` for another such module: numba alone would raise ModuleNotFoundError reading the
    index (the control, with numba's loader restored); the cache reads it as a miss and
    computes, and so does process 1's code run again."""
    src, env = small
    (src / "kpkg" / "apply.py").write_text(textwrap.dedent(APPLY).lstrip())
    code = {}
    for tag, scale, control in (("a", 3.0, ""), ("b", 5.0, ""), ("numba_a", 3.0, NUMBA_ONLY),
                                ("control", 5.0, NUMBA_ONLY)):
        path = tmp_path / f"loose_{tag}.py"
        # (the generated sensitivity kernels name their module: _THIS.tangent)
        path.write_text(f"import sys\nimport numba as nb\n_THIS = sys.modules[__name__]\n\n\n"
                        f"@nb.njit(cache=True)\ndef g(x):\n    return {scale} * x\n\n\n"
                        f"@nb.njit(cache=True)\ndef f(x):\n    return _THIS.g(x)\n")
        code[tag] = ("import mbs_clearance\n"
                     + FILE_MODULE.format(tag=tag, path=str(path), control=control)
                     + stats_code("apply"))
    # the control: numba's own cache files and loaders
    numba_first, _ = run(code["numba_a"], env)
    proc = subprocess.run([sys.executable, "-c", code["control"]], env=env,
                          cwd=first_path(env), capture_output=True, text=True, timeout=600)
    assert proc.returncode != 0 and "No module named 'loose_numba_a'" in proc.stderr
    shutil.rmtree(numba_first["path"])
    first, _ = run(code["a"], env)
    assert first["value"] == 7.0 and first["misses"] == 1
    second, _ = run(code["b"], env)
    assert second["value"] == 11.0 and second["misses"] == 1
    again, _ = run(code["a"], env)                  # the index now names loose_b
    assert again["value"] == 7.0


# ---------------------------------------------------------------- (iii) read-only install


def readonly_prefix(paths: list[Path], request) -> tuple[str, ...]:
    """Command prefix under which `paths` are read-only. Not root: chmod -R a-w (undone at
    teardown). Root ignores permissions: a private mount namespace with read-only bind
    mounts of the paths (skips where unshare is not permitted)."""
    if os.geteuid() != 0:
        for path in paths:
            subprocess.run(["chmod", "-R", "a-w", str(path)], check=True)
            request.addfinalizer(lambda p=path: subprocess.run(["chmod", "-R", "u+w", str(p)]))
        return ()
    if shutil.which("unshare") is None or subprocess.run(
            ["unshare", "--mount", "--", "true"], capture_output=True).returncode != 0:
        pytest.skip("running as root without permission to make a read-only bind mount")
    mounts = " && ".join(f"mount --bind -o ro {shlex.quote(str(p))} {shlex.quote(str(p))}"
                         for p in paths)
    return ("unshare", "--mount", "--", "sh", "-c", mounts + ' && exec "$@"', "sh")


def cache_warnings(stderr: str) -> list[str]:
    return [line for line in stderr.splitlines() if "CacheWarning" in line]


def readonly_env(tmp_path: Path, pythonpath: list[Path]) -> tuple[dict[str, str], Path, Path]:
    home = tmp_path / "home"
    (home / ".cache").mkdir(parents=True)
    tmp = tmp_path / "tmp"
    tmp.mkdir()
    return clean_env(pythonpath, HOME=str(home), TMPDIR=str(tmp)), home, tmp


def test_a_read_only_install_caches_in_a_private_temporary_directory(small, tmp_path,
                                                                    request):
    src, _ = small
    env, home, tmp = readonly_env(tmp_path, [src, REPO])
    prefix = readonly_prefix([src, home], request)
    probe = "import pathlib; pathlib.Path({!r}).joinpath('x').write_text('')"
    for path in (src / "kpkg", home / ".cache"):
        proc = subprocess.run([*prefix, sys.executable, "-c", probe.format(str(path))],
                              env=env, capture_output=True, text=True)
        assert proc.returncode != 0 and ("Read-only" in proc.stderr
                                         or "Permission denied" in proc.stderr)
    code = "import json, kpkg, kcon\n" + OUTER_RUN
    first, err1 = run(code, env, prefix)
    again, err2 = run(code, env, prefix)
    assert first["value"] == again["value"] == 10.0 * 2.0
    assert len(cache_warnings(err1)) == 1 and len(cache_warnings(err2)) == 1, err1 + err2
    # one line, naming the place and the remedy, attributed to the import (`python -c`)
    assert re.match(r"<string>:3: CacheWarning: ", cache_warnings(err1)[0])  # from kcon.outer
    assert str(tmp) in cache_warnings(err1)[0] and "NUMBA_CACHE_DIR" in cache_warnings(err1)[0]
    private = tmp / f"mbs_clearance-numba-{os.geteuid()}"
    assert Path(first["path"]).is_relative_to(private) and first["misses"] == 1
    assert again["hits"] == 1 and again["misses"] == 0                  # reused
    assert oct(private.stat().st_mode & 0o777) == oct(0o700)
    assert not list(src.rglob("nb-*")) and not list(home.rglob("*.nbi"))


def test_numba_cache_dir_is_tried_first_then_pycache(tmp_path, monkeypatch):
    """Where the kernels of a registered package go (in this process, no kernel compiled)."""
    pkg = write_package(tmp_path / "src", "kpkg", KPKG)
    package = _cache._Package("kpkg", str(pkg), "ab" * 32, (), [], ())
    name = _cache.PREFIX + "ab" * 6
    monkeypatch.setattr(_cache, "_DIRS", {})
    monkeypatch.setattr("numba.core.config.CACHE_DIR", str(tmp_path / "numba"))
    chosen = Path(_cache._cache_dir(package, str(pkg / "kern.py")))
    assert chosen.parent.parent == tmp_path / "numba" and chosen.name == name
    monkeypatch.setattr(_cache, "_DIRS", {})
    monkeypatch.setattr("numba.core.config.CACHE_DIR", "")
    assert Path(_cache._cache_dir(package, str(pkg / "kern.py"))) == pkg / "__pycache__" / name


# ---------------------------------------------------------------- helpers, in this process


def test_old_digest_directories_and_legacy_files_are_pruned_after_prune_age(tmp_path):
    old = time.time() - 2 * _cache.PRUNE_AGE
    names = ["nb-aaaaaaaaaaaa", "nb-bbbbbbbbbbbb", "nb-cccccccccccc"]
    for name in names:
        (tmp_path / name).mkdir()
        (tmp_path / name / "k.f-1.py311.nbi").write_text("")
    for name in ("k.f-1.py311.nbi", "k.f-1.py311.1.nbc", "k.g-9.py311.nbi", "k.cpython.pyc"):
        (tmp_path / name).write_text("")
    for name in (names[0], names[2], "k.f-1.py311.nbi", "k.f-1.py311.1.nbc",
                 "k.cpython.pyc"):
        os.utime(tmp_path / name, (old, old))
    _cache._prune(str(tmp_path), keep=names[2])
    assert sorted(p.name for p in tmp_path.iterdir()) == [
        "k.cpython.pyc", "k.g-9.py311.nbi", names[1], names[2]]


def test_a_temporary_directory_others_can_write_to_is_not_used(tmp_path, monkeypatch):
    monkeypatch.setattr("tempfile.tempdir", str(tmp_path))
    shared = tmp_path / f"mbs_clearance-numba-{os.geteuid()}"
    shared.mkdir(mode=0o777)
    shared.chmod(0o777)
    path = _cache._private_temp_root()
    assert Path(path) != shared and Path(path).parent == tmp_path
    assert Path(path).stat().st_mode & 0o077 == 0
    shared.chmod(0o700)
    assert Path(_cache._private_temp_root()) == shared


# ---------------------------------------------------------------- the real packages


def copy_packages(dest: Path, names: tuple[str, ...], warm: bool = True) -> Path:
    """Copies of the worktree's packages; `warm` keeps the numba cache (valid for the copy:
    same sources, same digest), else no __pycache__ (a fresh install)."""
    for name in names:
        ignore = shutil.ignore_patterns("*.pyc", *(() if warm else ("__pycache__",)))
        shutil.copytree(REPO / name, dest / name, ignore=ignore)
    return dest


RHS_RUN = """
import json
import numpy as np
import mbs_clearance
from mbs_clearance import SliderCrank
from mbs_clearance.solve import reduced

mech = SliderCrank()
p = reduced.model_parameters(mech)
y = reduced.initial_state(mech, 1.5)          # 0.5 clearances into the wall
p[reduced.MEM_START] = 1.0
f = np.zeros(len(y))
reduced.MODEL.rhs(0.0, y, p, f)
st = reduced.MODEL.rhs.stats
print(json.dumps({"file": mbs_clearance.__file__, "rhs": f.tolist(), "path": st.cache_path,
                  "hits": sum(st.cache_hits.values()),
                  "misses": sum(st.cache_misses.values())}))
"""

STRESS_RUN = """
import json
import numpy as np
from mbs_clearance import SliderCrank
from mbs_clearance.solve import reduced
from mbs_clearance.numerics.integrator import METHODS
from validation import stress

mech = SliderCrank()
p = reduced.model_parameters(mech)
y = reduced.initial_state(mech, 1.5)
ts, ys, ms, tab = np.array([0.0, 1e-3]), np.array([y, y]), np.zeros((2, 2)), METHODS["dopri5"]
value = stress._step_excursion(ts, ys, ms, p, tab.A, tab.B, tab.C, 5, 0)
st = stress._step_excursion.stats
print(json.dumps({"file": stress.__file__, "value": value, "path": st.cache_path,
                  "hits": sum(st.cache_hits.values()),
                  "misses": sum(st.cache_misses.values())}))
"""

CONTACT_EDIT = ("f = K * delta * math.sqrt(delta)", "f = 2.0 * K * delta * math.sqrt(delta)")


def rhs_here() -> np.ndarray:
    mech = SliderCrank()
    p = reduced.model_parameters(mech)
    y = reduced.initial_state(mech, 1.5)
    p[reduced.MEM_START] = 1.0
    f = np.zeros(len(y))
    reduced.MODEL.rhs(0.0, y, p, f)
    return f


def test_a_read_only_copy_of_mbs_clearance_imports_and_computes_the_same(tmp_path, request):
    """The issue's case: read-only site-packages and home, no NUMBA_CACHE_DIR (numba alone:
    "cannot cache function '_combine': no locator available")."""
    site = copy_packages(tmp_path / "site", ("mbs_clearance",), warm=False)
    env, home, tmp = readonly_env(tmp_path, [site])
    prefix = readonly_prefix([site, home], request)
    out, err = run(RHS_RUN, env, prefix)
    assert Path(out["file"]).is_relative_to(site)
    assert len(cache_warnings(err)) == 1, err
    assert Path(out["path"]).is_relative_to(tmp) and out["misses"] == 1
    assert out["rhs"] == rhs_here().tolist()            # the same numbers, to the bit
    assert rhs_here()[3] != 0.0                          # in contact: the force acts


@pytest.mark.slow
def test_an_edit_of_the_contact_force_is_computed_by_the_next_import_of_mbs_clearance(tmp_path):
    """The paper's generated rhs (reduced.MODEL.rhs) inlines laws.forces.contact_force: doubling
    the force in laws/forces.py doubles the slider's acceleration -F nx / m4 in the next
    process."""
    site = copy_packages(tmp_path / "site", ("mbs_clearance",))
    env = clean_env([site])
    before, _ = run(RHS_RUN, env)
    assert Path(before["file"]).is_relative_to(site)
    assert before["hits"] == 1 and before["misses"] == 0    # nothing recompiled
    edit(site / "mbs_clearance" / "laws" / "forces.py", *CONTACT_EDIT)
    after, _ = run(RHS_RUN, env)
    assert after["misses"] == 1 and after["path"] != before["path"]
    assert after["rhs"][3] == 2.0 * before["rhs"][3] != 0.0
    assert after["rhs"][:2] == before["rhs"][:2]            # the rates: no force in them


@pytest.mark.slow
def test_an_edit_of_the_generated_runtime_is_computed_by_validation_stress(tmp_path):
    """validation.stress._step_excursion inlines the generated model's event, which inlines
    generate/runtime.gap_state: with the penetration defined as r - 2c instead of r - c,
    the excursion (delta / c in free flight, where the motion does not depend on delta)
    drops by exactly one clearance."""
    site = copy_packages(tmp_path / "site", ("mbs_clearance", "validation"))
    env = clean_env([site])
    before, _ = run(STRESS_RUN, env)
    assert Path(before["file"]).is_relative_to(site)
    again, _ = run(STRESS_RUN, env)
    assert again["hits"] == 1 and again["misses"] == 0
    edit(site / "mbs_clearance" / "generate" / "runtime.py", "return r - clearance, ",
         "return r - 2.0 * clearance, ")
    after, _ = run(STRESS_RUN, env)
    assert after["misses"] == 1 and after["path"] != before["path"]
    assert after["value"] == pytest.approx(before["value"] - 1.0, rel=0, abs=1e-9)


@pytest.mark.slow
def test_the_race_with_the_real_package(tmp_path):
    """As the small race test, with mbs_clearance: A imports, laws/forces.py is edited, B
    imports, A compiles reduced.MODEL.outputs for a new signature (F-ordered states) and caches
    it, B compiles the same: B's contact force is twice A's."""
    site = copy_packages(tmp_path / "site", ("mbs_clearance",))
    env = clean_env([site])
    first = textwrap.dedent("""
        import json
        import numpy as np
        from mbs_clearance import SliderCrank
        from mbs_clearance.solve import reduced
        mech = SliderCrank()
        p = reduced.model_parameters(mech)
        y = reduced.initial_state(mech, 1.5)
        ys = np.asfortranarray(np.array([y, y]))
        ms = np.array([[1.0, mech.impact_velocity_floor]] * 2)
        col = reduced.MODEL.OUT_COLUMNS.index("coupler_slider.contact_force")
    """)
    then = textwrap.dedent("""
        out = reduced.MODEL.outputs(np.array([0.0, 0.0]), ys, ms, p)
        st = reduced.MODEL.outputs.stats
        print(json.dumps({"force": out[:, col].tolist(), "path": st.cache_path,
                          "misses": sum(st.cache_misses.values())}))
    """)
    a = Waiting(first, then, env)
    edit(site / "mbs_clearance" / "laws" / "forces.py", *CONTACT_EDIT)
    b = Waiting(first, then, env)
    ra = a.go()
    rb = b.go()
    assert ra["misses"] == 1 and rb["misses"] == 1 and ra["path"] != rb["path"]
    assert ra["force"][0] > 0.0 and rb["force"] == [2.0 * f for f in ra["force"]]
    # x4dd = -F nx / m4 with n = (-1, 0) here: A's force is the unedited one
    assert ra["force"][0] == pytest.approx(rhs_here()[3] * SliderCrank().slider_mass,
                                           rel=1e-12)


# ---------------------------------------------------------------- damaged cache files


def _truncate(path: Path, keep: float) -> None:
    """Cut `path` to `keep` of its size (a full disk, a killed process)."""
    data = path.read_bytes()
    path.write_bytes(data[:int(len(data) * keep)])


@pytest.mark.parametrize("damage", ["index", "data", "index-empty", "both"])
def test_a_damaged_cache_file_is_dropped_and_recompiled_with_one_warning(small, damage):
    """Real cache files of a real compile, cut short: numba alone raises on every later run
    (the control, with numba's loaders restored); here the next process computes, warns
    once naming the file, compiles again and rewrites the entry, and the one after that
    loads it from the cache without a warning."""
    src, env = small
    code = "import json, kpkg\n" + KERNEL_RUN
    first, err = run(code, env)
    assert first["value"] == 3.0 and first["misses"] == 1 and not cache_warnings(err)
    index = next(Path(first["path"]).glob("kern.kernel-*.nbi"))
    data = next(Path(first["path"]).glob("kern.kernel-*.nbc"))
    damaged = {"index": [index], "data": [data], "index-empty": [index],
               "both": [index, data]}[damage]
    for path in damaged:
        _truncate(path, 0.0 if damage == "index-empty" else 0.5)
    restore = NUMBA_ONLY
    control = subprocess.run([sys.executable, "-c", "import kpkg\n" + restore + code],
                             env=env, cwd=first_path(env), capture_output=True, text=True,
                             timeout=600)
    assert control.returncode != 0
    assert re.search(r"(UnpicklingError|EOFError)", control.stderr), control.stderr
    second, err = run(code, env)
    assert second["value"] == 3.0 and second["misses"] == 1 and second["hits"] == 0
    warned = cache_warnings(err)
    assert len(warned) == 1, err
    assert "damaged" in warned[0] and str(damaged[0]) in warned[0]
    third, err = run(code, env)
    assert third["value"] == 3.0 and third["hits"] == 1 and third["misses"] == 0
    assert not cache_warnings(err), err
