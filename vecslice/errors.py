"""The vecslice error hierarchy.

Every error vecslice raises derives from :class:`VecsliceError` and also from the
builtin that fits (``ValueError``, ``TypeError`` or ``OSError``), so generic
``except ValueError`` handlers keep working.
"""

from __future__ import annotations

__all__ = [
    "InputIndexError",
    "InputTypeError",
    "InputValueError",
    "LayoutError",
    "MeshFileError",
    "MissingDependencyError",
    "SettingsError",
    "StorageFileError",
    "VecsliceError",
    "VecsliceWarning",
]


class VecsliceError(Exception):
    """Base class for every vecslice error."""


class InputValueError(VecsliceError, ValueError):
    """An argument has the right type but a bad value (NaN, out of range, empty...)."""


class InputTypeError(VecsliceError, TypeError):
    """An argument has the wrong type or dtype."""


class InputIndexError(InputValueError, IndexError):
    """An index (of a layer, part or ring) is out of range."""


class LayoutError(InputValueError):
    """Invalid coords/offsets layout of ragged arrays."""


class SettingsError(InputValueError):
    """An invalid slicing setting (non-positive height, unknown option...).

    ``layers_needed``: when a slice would have more layers than ``max_layers``
    allows, the smallest limit the message suggests (at least the layer count),
    so that a caller can word its own hint (the command line says
    ``--max-layers N``); None for other errors.
    """

    layers_needed: int | None = None


class MeshFileError(VecsliceError, OSError):
    """A mesh file is missing, unreadable or not a mesh."""


class StorageFileError(VecsliceError, OSError):
    """A file is not a saved vecslice model."""


class MissingDependencyError(VecsliceError, ModuleNotFoundError):
    """An optional dependency is not installed; the message names the extra."""


class VecsliceWarning(UserWarning):
    """Base class for every vecslice warning."""
