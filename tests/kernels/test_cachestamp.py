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

    if config.DISABLE_JIT:
        return
    cache = Path(njit(cache=True)(_cachestamp._probe)._cache._cache_path)
    want = sources_digest(Path(_cachestamp.__file__).parent)
    assert (cache / STAMP).read_text() == want
