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


def printable(text: str) -> str:
    r"""``text`` with lone surrogates written as backslash escapes.

    A file name that is not valid UTF-8 (``caf\xe9.stl`` in Latin-1) reaches
    Python with surrogates (``'caf\udce9.stl'``), which no strict encoder
    accepts: printing a message that quotes it raises UnicodeEncodeError. Here
    its bytes are shown as the command line shows them, ``caf\xe9.stl``.
    """
    try:
        raw = text.encode("utf-8", "surrogateescape")
        return raw.decode("utf-8", "backslashreplace")
    except UnicodeEncodeError:  # a surrogate that no file name's byte gives
        return text.encode("utf-8", "backslashreplace").decode("utf-8")


class _Printable(Exception):
    """An exception whose text arguments go through :func:`printable`.

    Every message can be printed, whatever file name it quotes.
    """

    def __init__(self, *args: object) -> None:
        super().__init__(*(printable(a) if isinstance(a, str) else a for a in args))


class VecsliceError(_Printable):
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


class VecsliceWarning(_Printable, UserWarning):
    """Base class for every vecslice warning."""
