"""Before anything is timed: do the peers compute what vecslice computes?

A peer that failed (manifold3d returns an empty ``Manifold`` with an error status
for input it rejects, and then slices in microseconds) or cut other heights would
print a ratio that means nothing. :func:`check_agreement` compares, layer by
layer, the number of closed contours and their net area of every peer with
vecslice's raw loops, and refuses to go on when they differ.

manifold3d's ``slice`` unions each layer's polygons (its ``CrossSection`` never
overlaps itself), which raw loops do not: on these meshes (no overlapping
bodies) the areas still agree.
"""

from __future__ import annotations

import numpy as np

import vecslice as vs

# per layer, the area may differ by this much (mm²) plus a share of the area: the
# peers cut float32 mm, vecslice int64 µm (0.02 mm² at most on a Benchy's layer)
MAX_AREA_DIFF_MM2 = 0.05
MAX_AREA_DIFF_SHARE = 1e-4
MAX_COUNT_MISMATCH = 0.01  # share of layers whose contour counts may differ
TRIMESH_LAYERS = 12  # trimesh is slow: layers sampled evenly


def _areas(points: list[np.ndarray]) -> float:
    """Net area (mm²) of closed contours given as (n, 2) arrays (shoelace)."""
    total = 0.0
    for p in points:
        if len(p) > 2 and np.array_equal(p[0], p[-1]):
            p = p[:-1]
        x, y = p[:, 0].astype(np.float64), p[:, 1].astype(np.float64)
        total += 0.5 * float(x @ np.roll(y, -1) - y @ np.roll(x, -1))
    return total


def vecslice_layers(loops: vs.LayerPaths) -> tuple[np.ndarray, np.ndarray]:
    """Closed contours per layer and their net area (mm²) of vecslice's loops."""
    area = np.bincount(loops.ring_layer(), weights=loops.area2() / 2e6,
                       minlength=loops.n_layers)
    return loops.rings_per_layer(), area


def manifold_layers(sections: list) -> tuple[np.ndarray, np.ndarray]:
    return (np.array([cs.num_contour() for cs in sections]),
            np.array([cs.area() for cs in sections]))


def meshlib_layers(sections: list) -> tuple[np.ndarray, np.ndarray]:
    # MeshLib's outer contours run clockwise: its areas are negated
    return (np.array([len(c) for c in sections]),
            np.array([-_areas([np.array([[q.x, q.y] for q in c]) for c in cs])
                      for cs in sections]))


def trimesh_layers(sections: list) -> tuple[np.ndarray, np.ndarray]:
    return (np.array([0 if s is None else len(s.polygons_closed) for s in sections]),
            np.array([0.0 if s is None else float(s.area) for s in sections]))


def compare(name: str, ref: tuple[np.ndarray, np.ndarray],
            got: tuple[np.ndarray, np.ndarray]) -> str:
    """How ``got`` (counts, areas) agrees with ``ref``, in a line; SystemExit if not."""
    (n_ref, a_ref), (n_got, a_got) = ref, got
    if n_got.shape != n_ref.shape:
        raise SystemExit(f"{name} returned {n_got.shape[0]} layers for "
                         f"{n_ref.shape[0]} heights: its ratio would mean nothing")
    diff = np.abs(a_got - a_ref)
    mismatched = int((n_got != n_ref).sum())
    line = (f"{name}: {int(n_got.sum()):,} contours against vecslice's "
            f"{int(n_ref.sum()):,} ({mismatched} of {n_ref.shape[0]} layers differ), "
            f"area within {diff.max():.3f} mm² per layer, "
            f"{abs(a_got.sum() - a_ref.sum()) / a_ref.sum():.1e} in total")
    limit = MAX_AREA_DIFF_MM2 + MAX_AREA_DIFF_SHARE * np.abs(a_ref)
    if (diff > limit).any() or mismatched > MAX_COUNT_MISMATCH * len(n_ref):
        raise SystemExit(f"the peers disagree with vecslice, so no ratio is printed: "
                         f"{line} (limits: {MAX_AREA_DIFF_MM2} mm² + "
                         f"{MAX_AREA_DIFF_SHARE:g} of the area per layer, contour "
                         f"counts in {MAX_COUNT_MISMATCH:.0%} of the layers)")
    return line


def check_agreement(five: vs.Mesh, one: vs.Mesh, *, trimesh: bool = True) -> list[str]:
    """Every peer's sections against vecslice's, once, before the timing.

    manifold3d on the reference workload (``five``, its status checked too);
    MeshLib and trimesh, whose contours are read point by point in Python, on
    one Benchy (``one``; trimesh at :data:`TRIMESH_LAYERS` heights). Returns the
    lines for the table's notes; raises SystemExit where a peer disagrees.
    """
    import manifold3d as m3

    from _workloads import (
        heights,
        manifold_build_slice,
        meshlib_build_slice,
        mm_arrays,
        trimesh_build_sections,
        vecslice_contours,
    )

    z, z1 = heights(five), heights(one)
    v32, f32 = mm_arrays(five)
    built = m3.Manifold(m3.Mesh(vert_properties=v32, tri_verts=f32.astype(np.uint32)))
    if built.status() != m3.Error.NoError:
        raise SystemExit(f"manifold3d refused the workload ({built.status()}): its "
                         "slices would be empty and its ratio would mean nothing")
    ref = vecslice_layers(vecslice_contours(five.vertices, five.faces, z))
    lines = [compare("manifold3d", ref, manifold_layers(
        manifold_build_slice(v32, f32, z / 1000.0)))]
    ref1 = vecslice_layers(vecslice_contours(one.vertices, one.faces, z1))
    v1, f1 = mm_arrays(one)
    lines.append(compare("MeshLib (one Benchy)", ref1, meshlib_layers(
        meshlib_build_slice(v1, f1, z1 / 1000.0))))
    if not trimesh:
        return lines
    pick = np.unique(np.linspace(0, len(z1) - 1, TRIMESH_LAYERS).round().astype(int))
    v64, f64 = mm_arrays(one, np.float64)
    lines.append(compare(
        f"trimesh (one Benchy, {len(pick)} layers)",
        (ref1[0][pick], ref1[1][pick]),
        trimesh_layers(trimesh_build_sections(v64, f64, z1[pick] / 1000.0))))
    return lines
