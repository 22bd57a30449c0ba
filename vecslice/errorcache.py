"""Ring errors that earlier combinations of a sweep measured already.

The combinations of one (mesh, layer schedule) task in :func:`vecslice.sweep`
simplify the same raw rings with different settings, and a ring often comes out
the same for several of them: on five Benchies, half the (ring, combination)
pairs of a 4 x 3 XY grid repeat an earlier simplified ring (a third of the raw
vertices). The errors of a ring pair depend on the two rings alone, so a
repeated pair takes the numbers measured before, bit for bit, instead of being
measured again.

A pair is found by a 64-bit key of (ring index, simplified ring) and confirmed
by comparing the vertices, so a key shared by two different rings costs a
measurement, never a wrong number.
"""

from __future__ import annotations

import threading
from dataclasses import dataclass

import numpy as np
from numpy.typing import NDArray

from vecslice._kernels.rings import ring_keys, rings_equal
from vecslice.metrics import ContourErrors, _compare_rings, _errors_of, _raw_area_um2
from vecslice.paths import LayerPaths

__all__ = ["ErrorCache"]


@dataclass(frozen=True)
class _Store:
    """Measured ring pairs, each a ring of one of the calls' simplified arrays.

    Pair ``v`` is ring ``ring[v]`` of ``arrays[call[v]]`` (the simplified rings
    of an earlier call, held, not copied); ``keys`` is sorted, ``version`` the
    pair of each sorted key.
    """

    keys: NDArray[np.int64]
    version: NDArray[np.int64]
    call: NDArray[np.int64]
    ring: NDArray[np.int64]
    arrays: tuple[tuple[NDArray[np.int64], NDArray[np.int64]], ...]
    d1: NDArray[np.float64]
    d2: NDArray[np.float64]
    area: NDArray[np.float64]
    linear: NDArray[np.bool_]


def _empty_store() -> _Store:
    z = np.zeros(0, dtype=np.int64)
    f = np.zeros(0, dtype=np.float64)
    return _Store(z, z, z, z, (), f, f, f, np.zeros(0, dtype=np.bool_))


class ErrorCache:
    """:func:`vecslice.metrics.contour_errors` of many simplifications of one raw set.

    Parameters
    ----------
    raw : LayerPaths
        The raw rings every call is measured against.
    raw_area_um2 : ndarray of shape (L,), float64, optional
        The raw layers' net areas, when the caller has them.
    max_vertices : int, optional
        Hold the simplified rings of earlier calls up to this many vertices in
        all (default: as many as ``raw`` has, so the cache costs at most about
        the raw rings' memory again); later calls are measured in full and not
        held.

    Calls from several threads at once are safe; each call reuses the pairs of
    calls that finished before it started.
    """

    def __init__(self, raw: LayerPaths, raw_area_um2: NDArray[np.float64] | None = None,
                 max_vertices: int | None = None) -> None:
        self.raw = raw
        self.raw_area_um2 = (_raw_area_um2(raw) if raw_area_um2 is None
                             else raw_area_um2)
        self.max_vertices = (int(raw.coords.shape[0]) if max_vertices is None
                             else int(max_vertices))
        self._store = _empty_store()
        self._held = 0  # vertices of the held arrays
        self._lock = threading.Lock()
        self.measured = 0  # ring pairs measured, over all calls
        self.reused = 0  # ring pairs taken from the cache

    def errors(self, coords: NDArray[np.int64], offsets: NDArray[np.int64],
               threads: int | None = None) -> ContourErrors:
        """The errors of simplified rings ``(coords, offsets)``, one per raw ring.

        The same result as ``contour_errors(raw, simplified)`` (with the raw
        layers' offsets), bit for bit. ``threads``: at most this many threads.
        The arrays are held (not copied) for later calls: do not change them.
        """
        raw = self.raw
        store = self._store  # replaced, never changed: read without the lock
        keys = ring_keys(coords, offsets)
        n = keys.shape[0]
        found = np.full(n, -1, dtype=np.int64)  # the stored pair of each ring
        if store.keys.shape[0]:
            pos = np.minimum(np.searchsorted(store.keys, keys),
                             store.keys.shape[0] - 1)
            cand = np.flatnonzero(store.keys[pos] == keys)
            ver = store.version[pos[cand]]
            same = store.ring[ver] == cand
            for c, (b, b_offsets) in enumerate(store.arrays):  # confirm, per call
                sel = np.flatnonzero(same & (store.call[ver] == c))
                if sel.shape[0]:
                    same[sel] = rings_equal(coords, offsets, cand[sel], b, b_offsets,
                                            store.ring[ver[sel]])
            found[cand[same]] = ver[same]
        todo = np.flatnonzero(found < 0)
        reuse = np.flatnonzero(found >= 0)
        d1, d2, area, linear = _compare_rings(
            raw.coords, raw.ring_offsets, coords, offsets, threads,
            rings=None if todo.shape[0] == n else todo)
        version = found[reuse]
        d1[reuse] = store.d1[version]
        d2[reuse] = store.d2[version]
        area[reuse] = store.area[version]
        linear[reuse] = store.linear[version]
        self._hold(coords, offsets, keys, todo, (d1, d2, area, linear))
        with self._lock:
            self.measured += int(todo.shape[0])
            self.reused += int(reuse.shape[0])
        return _errors_of(raw, (d1, d2, area, linear), self.raw_area_um2)

    def _hold(self, coords: NDArray[np.int64], offsets: NDArray[np.int64],
              keys: NDArray[np.int64], todo: NDArray[np.int64],
              measured: tuple[NDArray[np.float64], NDArray[np.float64],
                              NDArray[np.float64], NDArray[np.bool_]]) -> None:
        """Add the freshly measured pairs ``todo`` to the store, within its size."""
        if not todo.shape[0]:
            return
        d1, d2, area, linear = measured
        with self._lock:
            old = self._store
            if self._held + coords.shape[0] > self.max_vertices:
                return
            self._held += coords.shape[0]
            new_keys = keys[todo]
            order = np.argsort(new_keys, kind="stable")
            # merge the sorted new keys into the sorted old ones
            at = np.searchsorted(old.keys, new_keys[order], side="right")
            n_old = old.call.shape[0]
            self._store = _Store(
                keys=np.insert(old.keys, at, new_keys[order]),
                version=np.insert(old.version, at, n_old + order),
                call=np.concatenate([old.call,
                                     np.full(todo.shape[0], len(old.arrays))]),
                ring=np.concatenate([old.ring, todo]),
                arrays=(*old.arrays, (coords, offsets)),
                d1=np.concatenate([old.d1, d1[todo]]),
                d2=np.concatenate([old.d2, d2[todo]]),
                area=np.concatenate([old.area, area[todo]]),
                linear=np.concatenate([old.linear, linear[todo]]),
            )
