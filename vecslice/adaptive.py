"""CuraEngine's adaptive layer heights, bit for bit (spec/ADAPTIVE.md).

Thin layers where the surface is shallow (where stair-stepping shows), thick layers
where it is steep. The per-face data (integer z range, float64 slope) is computed
for all faces in one kernel, the layer loop in another (an active window over the
faces sorted by their lowest z).
"""

from __future__ import annotations

from typing import Any, Literal

import numpy as np
from numpy.typing import NDArray

from vecslice._kernels._jit import even_chunks
from vecslice._kernels.adaptive import (
    adaptive_layers_sorted,
    face_slopes_range,
    sort_faces,
)
from vecslice._threads import run_chunks
from vecslice._validate import (
    check_int,
    check_layer_count,
    check_option,
    check_schedule_limits,
)
from vecslice.errors import InputTypeError, SettingsError
from vecslice.interrupt import keyboard_interrupts
from vecslice.mesh import Mesh
from vecslice.ragged import freeze
from vecslice.settings import SliceSettings

__all__ = ["FRAMES", "adaptive_layer_heights", "allowed_heights", "face_slopes"]

FRAMES = ("mesh", "bed")
MAX_HEIGHTS = 2**20  # longest list allowed_heights gives (8 MiB)

Frame = Literal["mesh", "bed"]
Schedule = tuple[NDArray[np.int64], NDArray[np.int64], NDArray[np.int64]]

_FACE_CHUNK = 1 << 14  # faces per chunk of face_slopes_range (about 2 ms)


def _height_range(layer_height: int, variation: int, step: int) -> tuple[int, int]:
    """``(hmax, hmin)`` of the allowed heights, without listing them.

    The values are validated: ``layer_height >= 1``, ``variation >= 0`` and
    ``step >= 1``, so the list is never empty.
    """
    hmax = layer_height + variation
    lowest = max(layer_height - variation, 1)  # heights <= 0 are never allowed
    return hmax, hmax - (hmax - lowest) // step * step


def allowed_heights(layer_height: int, variation: int, step: int) -> NDArray[np.int64]:
    """The layer heights adaptive layers choose from, thickest first.

    ``layer_height + variation``, then ``step`` less each time, down to
    ``layer_height - variation`` (included only if ``2 * variation`` is a multiple
    of ``step``); heights <= 0 are left out.

    Parameters
    ----------
    layer_height : int
        Base layer height in µm, ``> 0``.
    variation : int
        Largest deviation from ``layer_height`` in µm, ``>= 0``.
    step : int
        Spacing in µm, ``> 0``.

    Returns
    -------
    ndarray of shape (K,), int64
        The allowed heights in µm, strictly decreasing.

    Raises
    ------
    SettingsError
        If a value is out of range (the list would be empty or endless), or the
        list would hold more than ``MAX_HEIGHTS`` (2**20) heights. The schedule
        itself never lists them: any settings ``SliceSettings`` accepts slice.

    Examples
    --------
    >>> allowed_heights(100, 100, 30).tolist()
    [200, 170, 140, 110, 80, 50, 20]
    """
    base = check_int(layer_height, "layer_height", minimum=1, maximum=2**30)
    v = check_int(variation, "adaptive_variation", minimum=0, maximum=2**30)
    s = check_int(step, "adaptive_variation_step", minimum=1, maximum=2**30)
    hmax, hmin = _height_range(base, v, s)
    count = (hmax - hmin) // s + 1
    if count > MAX_HEIGHTS:
        raise SettingsError(
            f"layer_height={base}, adaptive_variation={v} and "
            f"adaptive_variation_step={s} µm allow {count} heights; "
            f"allowed_heights lists at most {MAX_HEIGHTS} (a larger step lists "
            "fewer; adaptive_layer_heights works without the list)")
    return np.arange(hmax, hmin - 1, -s, dtype=np.int64)


def _check_mesh(mesh: Any) -> Mesh:
    if not isinstance(mesh, Mesh):
        raise InputTypeError(
            f"`mesh` must be a vecslice.Mesh; got {type(mesh).__name__}"
        )
    return mesh


def _shift(mesh: Mesh, frame: str) -> int:
    """How far z is lowered: 0 in the bed frame, the lowest face corner otherwise."""
    check_option(frame, FRAMES, "frame")
    if frame == "bed":
        return 0
    # the model's lowest point (see Mesh._corner_zrange)
    return mesh._corner_zrange()[0]


def face_slopes(
    mesh: Any, *, frame: Frame = "mesh"
) -> tuple[NDArray[np.int64], NDArray[np.float64]]:
    """Each face's z range and slope, exactly as CuraEngine's adaptive layers see them.

    Parameters
    ----------
    mesh : Mesh
        Triangle mesh in µm.
    frame : {'mesh', 'bed'}, default 'mesh'
        'mesh' measures z from the mesh's lowest point (the project's frame),
        'bed' uses z as given (CuraEngine's frame, z = 0 is the build plate).

    Returns
    -------
    face_z : ndarray of shape (F, 2), int64
        Lowest and highest corner z of each face, µm, in ``frame``.
    slope : ndarray of shape (F,), float64
        Angle between each face and the horizontal plane in radians: in
        ``(0, pi/2]`` for a sloped face, exactly ``pi`` for a horizontal one, NaN
        for a face of zero area.

    Raises
    ------
    InputTypeError
        If ``mesh`` is not a :class:`vecslice.Mesh`.
    SettingsError
        If ``frame`` is unknown.

    Notes
    -----
    The slope is computed in float64 in CuraEngine's order: corners converted to
    mm by multiplying by 0.001, the cross product of two edges, the z component of
    the unit normal, libm ``acos``, then CuraEngine's wrap of the angle into
    [0, 2 pi) (which rounds it to a multiple of 2**-50), with 0 replaced by pi.
    The z used is the shifted one, so the bits depend on ``frame``; x and y are
    used as given (CuraEngine's own x, y placement on the bed may differ in the
    last bits of a slope).

    Examples
    --------
    >>> wedge = Mesh.from_arrays(
    ...     [[0, 0, 0], [1000, 0, 0], [0, 1000, 0], [0, 0, 1000]],
    ...     [[0, 2, 1], [0, 1, 3], [1, 2, 3], [0, 3, 2]])
    >>> z, s = face_slopes(wedge)
    >>> z.tolist()
    [[0, 0], [0, 1000], [0, 1000], [0, 1000]]
    >>> [round(x, 6) for x in s.tolist()]
    [3.141593, 1.570796, 0.955317, 1.570796]
    """
    m = _check_mesh(mesh)
    return _face_slopes(m.vertices, m.faces, _shift(m, frame))


def _face_slopes(
    vertices: NDArray[np.int64], faces: NDArray[np.int64], dz: int
) -> tuple[NDArray[np.int64], NDArray[np.float64]]:
    """The kernel ``face_slopes`` on threads (chunks of faces), same bits.

    A plain ``nogil`` kernel per chunk, not a parfor: numba's ``workqueue``
    threading layer aborts the process when two threads run parfors at once.
    """
    n = faces.shape[0]
    face_z = np.empty((n, 2), dtype=np.int64)
    slope = np.empty(n, dtype=np.float64)
    run_chunks(lambda f0, f1: face_slopes_range(vertices, faces, dz, f0, f1, face_z,
                                                slope), even_chunks(n, _FACE_CHUNK))
    return face_z, slope


def _sorted_faces(m: Mesh, dz: int) -> tuple[NDArray[Any], ...]:
    """The faces' z ranges and slopes in zmin order, built once per mesh and frame.

    They depend only on the (immutable) mesh and the frame shift ``dz``, so every
    later schedule of the mesh (other thresholds, a sweep, either frame) reuses
    them. The cache holds one entry per frame (there are two shifts at most: the
    mesh's lowest point and 0); threads racing on the first call may each build
    them (equal results).
    """
    cached = m._adaptive or ()
    for entry in cached:
        if entry[0] == dz:
            return entry[1:]
    face_z, slope = _face_slopes(m.vertices, m.faces, dz)
    arrays = tuple(freeze(a) for a in sort_faces(face_z, slope))
    # the newest entry first; the other frame's entry, if any, is kept
    object.__setattr__(m, "_adaptive", ((dz, *arrays), *cached[:1]))
    return arrays


@keyboard_interrupts
def adaptive_layer_heights(
    mesh: Any, settings: SliceSettings | None = None, *, frame: Frame = "mesh"
) -> Schedule:
    """CuraEngine's adaptive layer schedule of ``mesh``, bit for bit.

    The adaptive counterpart of :func:`vecslice.layer_heights`, which calls this
    when ``settings.adaptive_layers`` is true. Here the schedule is adaptive
    whatever that flag says.

    Parameters
    ----------
    mesh : Mesh
        Triangle mesh in µm. Every face counts, including zero-area ones.
    settings : SliceSettings, optional
        ``layer_height``, ``initial_layer_height``, ``slicing_tolerance`` and the
        ``adaptive_*`` values (µm); defaults to ``SliceSettings()``.
    frame : {'mesh', 'bed'}, default 'mesh'
        'mesh' runs the algorithm on z measured from the mesh's lowest point (the
        project's frame; a mesh resting on z = 0 gets exactly CuraEngine's
        schedule). 'bed' uses z as given, as CuraEngine does: z = 0 is the build
        plate, and a mesh floating above it gets thinnest layers in the gap.

    Returns
    -------
    slice_z : ndarray of shape (L,), int64
        Where each layer is cut, µm in the mesh's own coordinates: the **top** of
        the layer, for every layer and every slicing tolerance (CuraEngine never
        cuts adaptive layers in the middle).
    print_z : ndarray of shape (L,), int64
        Top of each layer in µm above the mesh's lowest point ('mesh') or above
        z = 0 ('bed').
    thickness : ndarray of shape (L,), int64
        Thickness of each layer in µm.

    Raises
    ------
    InputTypeError
        If ``mesh`` or ``settings`` has the wrong type.
    SettingsError
        If ``frame`` is unknown, or the schedule has more than
        ``settings.max_layers`` layers (the loop stops there).
    InputValueError
        If a layer would end at or beyond the 2**30 µm coordinate limit (the
        last layer ends above the model, so a mesh just below the limit cannot
        be sliced adaptively: move it down).

    Notes
    -----
    The candidates are :func:`allowed_heights`, thickest first. Layer 0 is always
    ``initial_layer_height`` thick. For each further layer starting at ``z``,
    candidate ``h`` looks at the faces whose z range meets ``[z, z + h // 2]``
    ('middle') or ``[z, z + h]`` ('inclusive', 'exclusive') and at the smallest
    slope among them; ``h`` is accepted if ``h / tan(slope) <=
    adaptive_threshold``, if it is the thinnest height, or if it is more than one
    step thinner than the previous layer. Candidates more than one step thicker
    than the previous layer are skipped, and no face in the band means the
    thinnest height. Layers are added while the last top is <= the model's top,
    and at least two. See spec/ADAPTIVE.md for every rounding and tie.

    Where the frames differ from CuraEngine's: the 'mesh' frame shifts z only, so
    the slopes are computed from the shifted z and the given x, y (CuraEngine uses
    the mesh's placement on the build plate; a different placement can change the
    last bit of a slope and, at a tie, a layer). CuraEngine pools the faces of all
    model meshes of a group into one schedule; here that is one ``Mesh`` (combine
    the meshes first). Exactness holds per platform, as for CuraEngine itself
    (x86-64, glibc ``acos``/``tan``, no FMA).

    Examples
    --------
    A 10 mm cube gets layer 0 of 300 µm, then 200 µm layers; the last layer ends
    above the cube:

    >>> import trimesh
    >>> from vecslice import load_mesh
    >>> cube = load_mesh(trimesh.creation.box((10, 10, 10)))
    >>> z, p, t = adaptive_layer_heights(cube)
    >>> len(z), z[:3].tolist(), p[:3].tolist(), t[:3].tolist(), int(p[-1])
    (50, [-4700, -4500, -4300], [300, 500, 700], [300, 200, 200], 10100)
    """
    if settings is None:
        settings = SliceSettings()
    if not isinstance(settings, SliceSettings):
        raise InputTypeError(
            "`settings` must be a vecslice.SliceSettings; "
            f"got {type(settings).__name__}"
        )
    m = _check_mesh(mesh)
    dz = _shift(m, frame)
    s = settings
    hmax, hmin = _height_range(s.layer_height, s.adaptive_variation,
                               s.adaptive_variation_step)
    zmin, zmax, slopes = _sorted_faces(m, dz)
    # CuraEngine's model_max_z: the model's top (see Mesh._corner_zrange)
    height = m._corner_zrange()[1] - dz
    thickness, top = adaptive_layers_sorted(
        zmin, zmax, slopes, s.initial_layer_height, hmax, hmin,
        s.adaptive_variation_step, s.adaptive_threshold,
        s.slicing_tolerance == "middle", s.max_layers, height,
    )
    if len(top) > s.max_layers:  # the kernel stopped one layer past the limit
        most = 2 + max(0, height - s.initial_layer_height) // hmin
        check_layer_count(
            len(top), s.max_layers,
            f"adaptive layers stopped there; down to {hmin} µm thick on an object "
            f"{height} µm tall they can be up to {most}",
            "SliceSettings(max_layers={n})", needed=most,
        )
    z = top + dz
    check_schedule_limits(z, top, *m._corner_zrange(), adaptive=True)
    return z, top, thickness
