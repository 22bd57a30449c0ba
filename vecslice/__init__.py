"""vecslice: a vectorised, array-programming slicer for 3D printing.

Triangle meshes in, per-layer int64-micron polygons out, following CuraEngine's
design (layer schedules, simplification, layer parts) but working on whole arrays.

Importing vecslice is cheap: only the error classes load at once. Every other name
(and the numba kernels, trimesh and manifold3d behind it) is imported the first
time it is used, so ``vecslice --help`` or ``import vecslice`` never waits for them.
"""

from __future__ import annotations

import importlib
import sys
import types
from typing import TYPE_CHECKING, Any

from vecslice.errors import (
    InputIndexError,
    InputTypeError,
    InputValueError,
    LayoutError,
    MeshFileError,
    MissingDependencyError,
    SettingsError,
    StorageFileError,
    VecsliceError,
    VecsliceWarning,
)

__version__ = "0.1.0"

# public name -> module that defines it; loaded on first access (PEP 562)
_LAZY = {
    "COORD_LIMIT": "vecslice.units",
    "LayerParts": "vecslice.layerparts",
    "LayerPaths": "vecslice.paths",
    "Mesh": "vecslice.mesh",
    "MeshReport": "vecslice.mesh",
    "Paths": "vecslice.paths",
    "ResolutionStats": "vecslice.metrics",
    "SliceSettings": "vecslice.settings",
    "SlicedModel": "vecslice.storage",
    "StageTimes": "vecslice.pipeline",
    "Stitched": "vecslice.stitch",
    "adaptive_layer_heights": "vecslice.adaptive",
    "check_mesh": "vecslice.mesh",
    "clean_loops": "vecslice.pipeline",
    "demo_mesh": "vecslice.demo",
    "layer_heights": "vecslice.layers",
    "load_mesh": "vecslice.mesh",
    "load_sliced": "vecslice.storage",
    "make_parts": "vecslice.parts",
    "resolution_stats": "vecslice.metrics",
    "run_interruptible": "vecslice.interrupt",
    "simplify": "vecslice.simplify",
    "slice_contours": "vecslice.slicing",
    "slice_mesh": "vecslice.pipeline",
    "stitch": "vecslice.stitch",
    "sweep": "vecslice.sweeps",
    "to_microns": "vecslice.units",
}

# submodules reachable as attributes without an explicit import (vs.plot.layer(...),
# vs.metrics.contour_errors(...))
_SUBMODULES = ("metrics", "plot", "svg", "viewer")

__all__ = [
    "COORD_LIMIT",
    "InputIndexError",
    "InputTypeError",
    "InputValueError",
    "LayerParts",
    "LayerPaths",
    "LayoutError",
    "Mesh",
    "MeshFileError",
    "MeshReport",
    "MissingDependencyError",
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
    "run_interruptible",
    "simplify",
    "slice_contours",
    "slice_mesh",
    "stitch",
    "sweep",
    "to_microns",
]


class _Package(types.ModuleType):
    """The vecslice package: a public function named like its submodule wins.

    Importing ``vecslice.simplify`` (or ``vecslice.stitch``) makes Python bind the
    submodule as an attribute of the package, which would hide the lazily loaded
    function ``vs.simplify``; such bindings are skipped (the submodule stays in
    ``sys.modules``), as the eager ``from vecslice.simplify import simplify`` did.
    """

    def __setattr__(self, name: str, value: Any) -> None:
        if name in _LAZY and isinstance(value, types.ModuleType):
            return
        super().__setattr__(name, value)


sys.modules[__name__].__class__ = _Package


def __getattr__(name: str) -> Any:
    module = _LAZY.get(name)
    if module is not None:
        value = getattr(importlib.import_module(module), name)
        globals()[name] = value  # later lookups skip this function
        return value
    if name in _SUBMODULES:
        return importlib.import_module(f"vecslice.{name}")
    raise AttributeError(f"module 'vecslice' has no attribute {name!r}")


def __dir__() -> list[str]:
    return sorted(set(globals()) | set(__all__) | set(_SUBMODULES))


if TYPE_CHECKING:  # static analysers see the plain imports
    from vecslice.adaptive import adaptive_layer_heights
    from vecslice.demo import demo_mesh
    from vecslice.interrupt import run_interruptible
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
