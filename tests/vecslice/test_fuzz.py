"""Random triangle soups: slicing raises nothing but vecslice errors, never hangs,
and every loop it returns lies inside the mesh's bounds."""

import numpy as np
from hypothesis import given, settings
from hypothesis import strategies as st

import vecslice as vs
from strategies import closed_meshes

PLANES = np.arange(-3000, 3001, 500, dtype=np.int64)


@st.composite
def soups(draw):
    n_v = draw(st.integers(3, 30))
    # coordinates on a coarse grid, so vertices land exactly on planes and repeat
    coord = st.integers(-6, 6).map(lambda c: 500 * c)
    verts = draw(st.lists(st.tuples(coord, coord, coord), min_size=n_v, max_size=n_v))
    idx = st.integers(0, n_v - 1)
    faces = draw(st.lists(st.tuples(idx, idx, idx), min_size=1, max_size=60))
    return np.array(verts, np.int64), np.array(faces, np.int64)


@st.composite
def damaged_closed_meshes(draw):
    v, f, planes = draw(closed_meshes())
    rng = np.random.default_rng(draw(st.integers(0, 2**32 - 1)))
    f = f.copy()
    flip = rng.random(len(f)) < draw(st.sampled_from([0.0, 0.05, 0.5]))
    f[flip] = f[flip][:, ::-1]
    f = f[rng.random(len(f)) > draw(st.sampled_from([0.0, 0.02, 0.2]))]
    dup = f[rng.random(len(f)) < 0.05]
    f = np.concatenate([f, dup])
    v = np.concatenate([v, v[: len(v) // 3]])  # duplicated positions, unused
    return v, f, planes


def _check(mesh, planes):
    loops = vs.slice_contours(mesh, planes)
    lo = mesh.vertices[:, :2].min(axis=0)
    hi = mesh.vertices[:, :2].max(axis=0)
    for part in (loops, loops.open):
        assert part.n_layers == len(planes)
        assert ((part.coords >= lo) & (part.coords <= hi)).all()
    # every closed loop is a ring of at least one vertex; open chains keep >= 2
    assert (np.diff(loops.ring_offsets) >= 1).all()
    assert (np.diff(loops.open.ring_offsets) >= 2).all()
    # meshes up to ~60 m tall (scale 1000): above the default layer limit
    s = vs.SliceSettings(layer_height=250, initial_layer_height=250,
                         max_layers=1_000_000)
    model = vs.slice_mesh(mesh, s)
    # simplification may move a vertex up to max_deviation (CuraEngine's rule:
    # a short edge is replaced by the intersection of its neighbours)
    dev = s.max_deviation
    assert ((model.coords >= lo - dev) & (model.coords <= hi + dev)).all()
    assert (model.layer_areas() >= 0).all()


@settings(max_examples=80)
@given(soups())
def test_random_soups_only_raise_vecslice_errors(case):
    v, f = case
    try:
        mesh = vs.Mesh.from_arrays(v, f)
    except vs.VecsliceError:
        return  # e.g. every face degenerate: a clear error is the right answer
    _check(mesh, PLANES)


@settings(max_examples=30)
@given(damaged_closed_meshes())
def test_damaged_meshes_slice(case):
    v, f, planes = case
    try:
        mesh = vs.Mesh.from_arrays(v, f)
    except vs.VecsliceError:
        return
    _check(mesh, planes)
    # the same soup with repair still slices
    _check(mesh.repaired(), planes)


@st.composite
def hollow_convex_parts(draw):
    """A convex closed mesh with a shrunken copy inside it, each shell wound either
    way (a void when wound opposite to the outer shell), randomly rotated and
    moved (int64 µm)."""
    import trimesh

    from strategies import _primitive

    kind = draw(st.sampled_from(["box", "icosphere", "cylinder"]))
    rng = np.random.default_rng(draw(st.integers(0, 2**32 - 1)))
    m = _primitive(kind, rng)
    m.apply_transform(trimesh.transformations.random_rotation_matrix(rng.random(3)))
    v = np.rint((m.vertices + rng.uniform(-100, 100, 3)) * 1000).astype(np.int64)
    f = np.asarray(m.faces, dtype=np.int64)
    # the vertex centroid is inside a convex shape (the box centre need not be),
    # so the copy shrunk towards it is strictly inside (shapes are >= 1 mm)
    c = np.rint(v.mean(axis=0)).astype(np.int64)
    inner = c + (v - c) // 3
    flip_outer, flip_inner = draw(st.booleans()), draw(st.booleans())
    fo = f[:, ::-1] if flip_outer else f
    fi = f if flip_inner else f[:, ::-1]  # as written, the void faces inward
    void = flip_outer == flip_inner  # wound opposite to the outer shell
    return (np.concatenate([v, inner]), np.concatenate([fo, fi + len(v)]), len(f),
            void)


@settings(max_examples=40)
@given(hollow_convex_parts())
def test_repair_keeps_relative_windings_and_turns_the_part_outward(case):
    v, f, n_outer, is_void = case
    mesh = vs.Mesh.from_arrays(v, f)
    assert mesh.n_faces == 2 * n_outer  # nothing collapsed
    r = mesh.repaired()
    assert r.load_info.cavities_kept == int(is_void)
    outer = vs.Mesh.from_arrays(r.vertices, r.faces[:n_outer])
    inner = vs.Mesh.from_arrays(r.vertices, r.faces[n_outer:])
    assert outer.volume > 0
    assert (inner.volume < 0) == is_void
    assert outer.is_watertight and inner.is_watertight
