"""vecslice: a vectorised, array-programming slicer for 3D printing.

Triangle meshes in, per-layer int64-micron polygons out, following CuraEngine's
design (layer schedules, simplification, layer parts) but working on whole arrays.
"""

from vecslice.adaptive import adaptive_layer_heights
from vecslice.demo import demo_mesh
from vecslice.errors import (
    InputIndexError,
    InputTypeError,
    InputValueError,
    LayoutError,
    MeshFileError,
    SettingsError,
    StorageFileError,
    VecsliceError,
    VecsliceWarning,
)
from vecslice.layers import layer_heights
from vecslice.mesh import Mesh, MeshReport, check_mesh, load_mesh
from vecslice.metrics import ResolutionStats, resolution_stats
from vecslice.parts import make_parts
from vecslice.paths import LayerPaths, Paths
from vecslice.pipeline import StageTimes, clean_loops, slice_mesh
from vecslice.settings import SliceSettings
from vecslice.simplify import simplify
from vecslice.slicing import slice_contours
from vecslice.stitch import Stitched, stitch
from vecslice.storage import SlicedModel, load_sliced
from vecslice.sweeps import sweep
from vecslice.units import COORD_LIMIT, to_microns

__version__ = "0.1.0"

__all__ = [
    "COORD_LIMIT",
    "InputIndexError",
    "InputTypeError",
    "InputValueError",
    "LayerPaths",
    "LayoutError",
    "Mesh",
    "MeshFileError",
    "MeshReport",
    "Paths",
    "ResolutionStats",
    "SettingsError",
    "SliceSettings",
    "SlicedModel",
    "StageTimes",
    "Stitched",
    "StorageFileError",
    "VecsliceError",
    "VecsliceWarning",
    "__version__",
    "adaptive_layer_heights",
    "check_mesh",
    "clean_loops",
    "demo_mesh",
    "layer_heights",
    "load_mesh",
    "load_sliced",
    "make_parts",
    "resolution_stats",
    "simplify",
    "slice_contours",
    "slice_mesh",
    "stitch",
    "sweep",
    "to_microns",
]
