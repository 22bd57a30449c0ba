from pathlib import Path

from vecslice._kernels import _cachestamp
from vecslice._kernels._cachestamp import STAMP, sources_digest, sync


def _fill(d):
    for name in ("a.f-1.py311.nbi", "a.f-1.py311.1.nbc", "b.g-9.py311.nbi"):
        (d / name).write_bytes(b"x")
    (d / "other.txt").write_text("kept")


def _cached(d):
    return sorted(p.name for p in d.iterdir() if p.suffix in (".nbi", ".nbc"))


def test_a_changed_kernel_source_empties_the_cache(tmp_path):
    # numba checks a cached kernel against its own file only: one stamp for all
    # kernel sources drops every cached kernel when any of them changed
    _fill(tmp_path)
    assert sync(tmp_path, "one")  # no stamp yet (caches of unknown sources)
    assert _cached(tmp_path) == [] and (tmp_path / STAMP).read_text() == "one"
    assert (tmp_path / "other.txt").read_text() == "kept"
    _fill(tmp_path)
    assert not sync(tmp_path, "one")  # same sources: the cache is kept
    assert len(_cached(tmp_path)) == 3
    assert sync(tmp_path, "two")
    assert _cached(tmp_path) == [] and (tmp_path / STAMP).read_text() == "two"


def test_digest_follows_every_source(tmp_path):
    (tmp_path / "a.py").write_text("x = 1\n")
    (tmp_path / "b.py").write_text("y = 1\n")
    first = sources_digest(tmp_path)
    assert sources_digest(tmp_path) == first
    (tmp_path / "b.py").write_text("y = 2\n")
    assert sources_digest(tmp_path) != first


def test_the_kernels_cache_carries_the_current_stamp():
    from numba import config, njit

    from vecslice._kernels import _jit  # noqa: F401  (its import stamps the cache)

    if config.DISABLE_JIT:
        return
    cache = Path(njit(cache=True)(_cachestamp._probe)._cache._cache_path)
    want = sources_digest(Path(_cachestamp.__file__).parent)
    assert (cache / STAMP).read_text() == want


def test_no_writable_cache_directory_compiles_uncached(tmp_path):
    # audit D18: numba's "no locator available" error at import when no cache
    # directory is writable (NUMBA_CACHE_DIR, the package's __pycache__ and the
    # user's cache under HOME). Unwritable here even for root: each lies under a
    # regular file
    import os
    import shutil
    import subprocess
    import sys

    import vecslice
    import vecslice._kernels

    # the package and its kernels (which an editable install maps from kernels/)
    pkg = tmp_path / "site"
    shutil.copytree(Path(vecslice.__file__).parent, pkg / "vecslice",
                    ignore=shutil.ignore_patterns("__pycache__", "_kernels"))
    shutil.copytree(Path(vecslice._kernels.__file__).parent,
                    pkg / "vecslice" / "_kernels",
                    ignore=shutil.ignore_patterns("__pycache__"))
    (pkg / "vecslice" / "_kernels" / "__pycache__").write_text("a file")
    env = {k: v for k, v in os.environ.items()
           if k not in ("XDG_CACHE_HOME", "NUMBA_DISABLE_JIT", "PYTHONPATH")}
    env.update(NUMBA_CACHE_DIR="/dev/null/numba", HOME="/dev/null/home",
               PYTHONPATH=str(pkg))
    code = (
        "import warnings\n"
        "warnings.simplefilter('always')\n"
        "with warnings.catch_warnings(record=True) as seen:\n"
        "    import vecslice as vs\n"
        "    area = vs.Paths([[0, 0], [10, 0], [0, 10]], [0, 3]).area2().tolist()\n"
        "from vecslice._kernels import _jit\n"
        "print(vs.__file__, area, _jit.CACHED)\n"
        "print(*(f'{w.category.__name__}: {w.message}' for w in seen), sep='\\n')\n")
    run = subprocess.run([sys.executable, "-c", code], cwd=tmp_path, env=env,
                         capture_output=True, text=True, timeout=600)
    assert run.returncode == 0, run.stderr
    first, *warned = run.stdout.splitlines()
    assert first == f"{pkg / 'vecslice' / '__init__.py'} [100] False"
    assert len(warned) == 1 and warned[0].startswith(
        "RuntimeWarning: vecslice: numba has no writable cache directory for its "
        "kernels")
    assert "set NUMBA_CACHE_DIR to a writable directory" in warned[0]
    assert not (pkg / "vecslice" / "_kernels" / "__pycache__").is_dir()
