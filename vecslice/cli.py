"""The ``vecslice`` command: slice, inspect, preview and browse models, in mm.

Subcommands (``vecslice MODEL`` is short for ``vecslice slice MODEL``, and
``vecslice`` alone slices the built-in demo model)::

    vecslice slice [MODEL] [-o OUT.npz] [slicing options in mm] [--scale S]
    vecslice info FILE                      # a mesh file or a saved .npz
    vecslice preview FILE (--layer N | --z MM) -o OUT.png|OUT.svg
    vecslice view FILE [-o OUT.html]

Exit status: 0 success, 1 bad input (one line on stderr, no traceback), 2 bad
usage (argparse), 130 interrupted (Ctrl-C).
"""

from __future__ import annotations

import argparse
import dataclasses
import math
import sys
import time
from collections.abc import Sequence
from dataclasses import dataclass
from pathlib import Path
from typing import Any

from vecslice._cli_support import (
    CliInputError,
    CliParser,
    CompileNotice,
    check_output,
    cli_path,
    flush_and_exit,
    human_bytes,
    load_info_lines,
    mm_to_microns,
    mm_value,
    note,
    say,
    shown,
    shown_mm,
    size_hint,
)
from vecslice.errors import SettingsError, VecsliceError

__all__ = ["SLICE_OPTIONS", "Option", "main", "run"]

COMMANDS = ("slice", "info", "preview", "view")
VIEW_SUFFIXES = (".html", ".htm")  # what `view -o` may write: a web page
INTERRUPTED = 130


@dataclass(frozen=True)
class Option:
    """A command-line option that sets one :class:`vecslice.SliceSettings` field.

    ``kind`` is ``"mm"`` (a length in mm, converted once to int µm from the
    decimal typed, rounding half away from zero, exactly; see
    :func:`vecslice._cli_support.mm_to_microns`), ``"int"`` (a count),
    ``"choice"`` (one of ``choices``), ``"on"`` or ``"off"`` (a flag setting the
    field to True/False).
    The default shown in ``--help`` is ``SliceSettings()``'s, i.e. Cura's.
    """

    flag: str
    setting: str
    kind: str
    help: str
    choices: tuple[str, ...] = ()


# one line per option; later options (adaptive layers, --compat) are added here
SLICE_OPTIONS: tuple[Option, ...] = (
    Option("--layer-height", "layer_height", "mm",
           "thickness of every layer after the first"),
    Option("--initial-layer-height", "initial_layer_height", "mm",
           "thickness of the first layer"),
    Option("--slicing-tolerance", "slicing_tolerance", "choice",
           "where a layer is cut: at its middle; or at its bottom, then united "
           "(inclusive) or intersected (exclusive) with the next layer",
           ("middle", "inclusive", "exclusive")),
    Option("--max-resolution", "max_resolution", "mm",
           "simplification may remove edges shorter than this"),
    Option("--max-deviation", "max_deviation", "mm",
           "largest distance a simplified contour may move from the raw one"),
    Option("--minimum-polygon-circumference", "minimum_polygon_circumference", "mm",
           "loops with a shorter perimeter are dropped"),
    Option("--even-odd", "union_overlapping_volumes", "off",
           "overlapping volumes cancel (even-odd rule) instead of merging (nonzero)"),
    Option("--compat", "compat", "choice",
           "'cura' reads the mesh and builds the polygons as CuraEngine does, its "
           "rounding included (the file is then not repaired)", ("vecslice", "cura")),
    Option("--adaptive-layers", "adaptive_layers", "on",
           "Cura's adaptive layer heights: thinner layers where the surface is "
           "shallow, thicker where it is steep"),
    Option("--adaptive-variation", "adaptive_variation", "mm",
           "adaptive layers are the layer height plus or minus this"),
    Option("--adaptive-variation-step", "adaptive_variation_step", "mm",
           "spacing of the allowed adaptive heights"),
    Option("--adaptive-threshold", "adaptive_threshold", "mm",
           "largest allowed stair-step width (Cura's topography size)"),
    Option("--max-layers", "max_layers", "int",
           "refuse a slice with more layers than this (a guard against files in "
           "the wrong unit)"),
)

# options that do nothing without --adaptive-layers
ADAPTIVE_ONLY = ("--adaptive-variation", "--adaptive-variation-step",
                 "--adaptive-threshold")
_SETTING = {opt.flag: opt.setting for opt in SLICE_OPTIONS}


def _add_slice_options(parser: argparse.ArgumentParser) -> None:
    from vecslice.settings import SliceSettings

    defaults = SliceSettings()
    group = parser.add_argument_group("slicing (lengths in mm; defaults are Cura's)")
    for opt in SLICE_OPTIONS:
        default = getattr(defaults, opt.setting)
        if opt.kind == "mm":
            group.add_argument(opt.flag, dest=opt.setting, type=mm_value, metavar="MM",
                               help=f"{opt.help} (default {default / 1000:g})")
        elif opt.kind == "int":
            group.add_argument(opt.flag, dest=opt.setting, type=int, metavar="N",
                               help=f"{opt.help} (default {default:,})")
        elif opt.kind == "choice":
            group.add_argument(opt.flag, dest=opt.setting, choices=opt.choices,
                               help=f"{opt.help} (default {default})")
        else:
            group.add_argument(opt.flag, dest=opt.setting, action="store_const",
                               const=opt.kind == "on",
                               help=f"{opt.help} (default: off)")
    mesh = parser.add_argument_group("model file")
    mesh.add_argument("--scale", type=float, default=None, metavar="S",
                      help="multiply file units by S to get mm: 25.4 for inches, "
                      "1000 for metres (default 1)")
    mesh.add_argument("--no-repair", action="store_true",
                      help="slice the mesh as read: keep duplicate faces and "
                      "windings (default: repair them, see README)")
    parser.add_argument("--no-progress", action="store_true",
                        help="no progress bar (default: a bar on stderr when it is a "
                        "terminal, never in pipes or logs)")


def settings_from_args(args: argparse.Namespace) -> Any:
    """The :class:`vecslice.SliceSettings` of the parsed options (µm).

    Raises
    ------
    CliInputError
        If a value is not finite or the settings reject it, or an option of
        ``ADAPTIVE_ONLY`` is given without ``--adaptive-layers``; the message
        names the option and the value in mm.
    """
    from vecslice.errors import InputValueError
    from vecslice.settings import SliceSettings
    if not getattr(args, "adaptive_layers", None):
        for flag in ADAPTIVE_ONLY:
            v = getattr(args, _SETTING[flag], None)
            if v is not None:  # typed: the default is None
                raise CliInputError(f"{flag} only applies with --adaptive-layers; "
                                    f"got {shown_mm(v)} without it")
    values: dict[str, Any] = {}
    cura = getattr(args, "compat", None) == "cura"  # lengths as CuraEngine reads them
    for opt in SLICE_OPTIONS:
        v = getattr(args, opt.setting, None)
        if v is None:
            continue
        if opt.kind == "mm":
            v = mm_to_microns(v, opt.flag, cura=cura)
        try:
            SliceSettings(**{opt.setting: v})
        except InputValueError as exc:
            text = f"{shown_mm(getattr(args, opt.setting))} mm ({v} µm)" \
                if opt.kind == "mm" else repr(v)
            raise CliInputError(f"bad value for {opt.flag}: {text}: {exc}") from None
        values[opt.setting] = v
    return SliceSettings(**values)


def _slicing_given(args: argparse.Namespace) -> list[str]:
    given = [o.flag for o in SLICE_OPTIONS
             if getattr(args, o.setting, None) is not None]
    if getattr(args, "scale", None) is not None:
        given.append("--scale")
    if getattr(args, "no_repair", False):
        given.append("--no-repair")
    return given


def build_parser() -> argparse.ArgumentParser:
    """The argument parser of ``vecslice`` (all subcommands)."""
    from vecslice import __version__

    fmt = argparse.RawDescriptionHelpFormatter
    # allow_abbrev=False (here and in every sub-parser): an unknown option is an
    # error, never taken for a prefix of another (`view --layer 10` must not set
    # --layer-height)
    common: dict[str, Any] = {"formatter_class": fmt, "allow_abbrev": False}
    p = CliParser(
        prog="vecslice", **common,
        description="Slice triangle meshes into CuraEngine-style layers of parts "
        "(outline + holes), look at them and save them. Lengths on the command "
        "line are in mm.",
        epilog="examples:\n"
        "  vecslice                                  slice the built-in demo model\n"
        "  vecslice part.stl --layer-height 0.2 -o part.npz\n"
        "  vecslice info part.stl                    mesh report (or: info part.npz)\n"
        "  vecslice preview part.npz --z 5 -o layer.png\n"
        "  vecslice view part.stl -o part.html       layer viewer for a browser\n\n"
        "'vecslice MODEL ...' is short for 'vecslice slice MODEL ...'.\n"
        "exit status: 0 success, 1 bad input, 2 bad usage, 130 interrupted",
    )
    p.add_argument("--version", action="version", version=f"vecslice {__version__}")
    sub = p.add_subparsers(dest="command", metavar="COMMAND")

    s = sub.add_parser("slice", **common, help="slice a model (default)",
                       description="Slice a mesh file (or, without MODEL, the "
                       "built-in demo model) and print a summary.")
    s.add_argument("model", nargs="?", metavar="MODEL",
                   help="STL, OBJ, PLY, OFF or 3MF file; omitted: the demo model")
    s.add_argument("-o", "--output", metavar="OUT.npz",
                   help="save the sliced model to this .npz file (read it with "
                   "vecslice.load_sliced; default: not saved)")
    _add_slice_options(s)

    i = sub.add_parser("info", **common, help="describe a mesh or .npz",
                       description="For a mesh file: size, faces, open and "
                       "non-manifold edges, bodies, volume and what loading "
                       "repaired. For a saved .npz: layers, z range, parts, "
                       "vertices.")
    i.add_argument("file", metavar="FILE", help="mesh file or .npz")
    i.add_argument("--scale", type=float, default=None, metavar="S",
                   help="file units to mm, as for slice (default 1)")
    i.add_argument("--no-repair", action="store_true",
                   help="report the mesh as read, before repair")

    pv = sub.add_parser("preview", **common, help="picture of one layer",
                        description="Draw one layer: parts filled, holes open, "
                        "open chains in orange. SVG needs nothing extra; PNG "
                        "needs matplotlib (pip install 'vecslice[plot]'). A mesh "
                        "file is sliced first.")
    pv.add_argument("file", metavar="FILE",
                    help="saved .npz, or a mesh file to slice")
    which = pv.add_mutually_exclusive_group(required=True)
    which.add_argument("--layer", type=int, metavar="N",
                       help="layer index, 0 = first (negative: from the top)")
    which.add_argument("--z", type=mm_value, metavar="MM",
                       help="the layer printed at this height above the bed")
    pv.add_argument("-o", "--output", required=True,
                    metavar="OUT.png|OUT.svg", help="the picture to write")
    _add_slice_options(pv)

    v = sub.add_parser("view", **common, help="layer viewer (HTML)",
                       description="Write the layer viewer: one self-contained "
                       "HTML file (no network, no server) with a layer slider, "
                       "keyboard stepping, zoom and pan. A mesh file is sliced "
                       "first.")
    v.add_argument("file", metavar="FILE",
                   help="saved .npz, or a mesh file to slice")
    v.add_argument("-o", "--output", metavar="OUT.html",
                   help="an .html or .htm file (default: FILE's name with .html, "
                   "in the current directory)")
    _add_slice_options(v)
    return p


# --- the work ---------------------------------------------------------------


def _work(fn: Any, *args: Any, **kwargs: Any) -> Any:
    from vecslice.interrupt import run_interruptible

    return run_interruptible(fn, *args, **kwargs)


def _n(count: int, word: str, plural: str | None = None) -> str:
    """``1 face``, ``2 faces``, with thousands separators."""
    return f"{count:,} {word if count == 1 else plural or word + 's'}"


def _is_npz(path: Path) -> bool:
    return path.suffix.lower() == ".npz"


def _scale(args: argparse.Namespace) -> float:
    """``--scale`` (default 1), checked: the library's message names `scale`."""
    if args.scale is None:
        return 1.0
    if not (math.isfinite(args.scale) and args.scale > 0):
        raise CliInputError("--scale must be a positive finite number (file units "
                            f"to mm); got {args.scale:g}")
    return float(args.scale)


def _load(path: Path | None, args: argparse.Namespace, settings: Any) -> Any:
    """The mesh (or the demo model), with the load report printed."""
    import numpy as np

    compat: dict[str, str] = {}
    if path is None:
        if args.scale is not None:
            raise CliInputError("--scale only applies to a model file; got "
                                f"{args.scale:g} without one")
        if args.no_repair:
            raise CliInputError("--no-repair only applies to a model file; got it "
                                "without one (the built-in demo model needs no "
                                "repair)")
        from vecslice.demo import demo_mesh

        say("no model given: slicing the built-in demo model")
        mesh = _work(demo_mesh)
    else:
        from vecslice.mesh import load_mesh

        scale = _scale(args)
        # compat="cura" reads the file as CuraEngine does (the default: omitted)
        if getattr(settings, "compat", "vecslice") != "vecslice":
            if path.suffix.lower() != ".stl":
                raise CliInputError(
                    "--compat cura reads STL files only (CuraEngine's own reader); "
                    f"got '{shown(path)}': slice it with --compat vecslice (the "
                    "default)")
            compat = {"compat": settings.compat}
        mesh = _work(load_mesh, path, scale=scale, repair=not args.no_repair,
                     **compat)
    from vecslice.mesh import check_mesh

    report = _work(check_mesh, mesh)
    size = (report.bounds[1] - report.bounds[0]) / 1000.0
    state = "watertight" if report.is_watertight else (
        f"not watertight: {report.boundary_edges:,} open edges, "
        f"{report.nonmanifold_edges:,} non-manifold, "
        f"{report.inconsistent_edges:,} inconsistent")
    name = "demo model" if path is None else shown(path)
    say(f"model     {name}: {_n(report.n_faces, 'face')}, "
        f"{_n(report.n_bodies, 'body', 'bodies')}, "
        f"{size[0]:.3f} x {size[1]:.3f} x {size[2]:.3f} mm, {state}")
    for line in load_info_lines(mesh.load_info, melded=bool(compat)):
        say(line)
    if path is not None and np.all(np.isfinite(size)):
        hint = size_hint(size, args.scale is not None)
        if hint:
            note(f"note: {hint}")
    return mesh


def _slice(mesh: Any, args: argparse.Namespace, settings: Any,
           load_seconds: float) -> Any:
    from vecslice.pipeline import StageTimes, slice_mesh

    times = StageTimes()
    progress = not args.no_progress and sys.stderr.isatty()
    try:
        model = _work(slice_mesh, mesh, settings, progress=progress, times=times)
    except SettingsError as exc:
        if exc.layers_needed is None:
            raise
        raise CliInputError(  # the library's hint is SliceSettings(max_layers=N)
            f"the slice has more layers than --max-layers {settings.max_layers} "
            f"allows (up to {exc.layers_needed}). Memory and time grow with the "
            "layers; if this is intended, raise the limit: --max-layers "
            f"{exc.layers_needed} or more") from None
    _summary(model, {"load": load_seconds, **times.seconds},
             getattr(times, "counts", {}))
    if model.n_layers == 0:
        size = (mesh.bounds[1] - mesh.bounds[0]) / 1000.0
        hint = size_hint(size, args.scale is not None)
        note(f"warning: the result has 0 layers (the model is {size[2]:.3f} mm "
             f"tall; the first layer is {settings.initial_layer_height / 1000:g} mm)"
             + (f"; {hint.split('; ', 1)[1]}" if hint and "; " in hint else ""))
    return model


def _summary(model: Any, seconds: dict[str, float], counts: dict[str, int]) -> None:
    n_open = int(model.open_chains.sum())
    raw = counts.get("raw_vertices")
    stored = int(model.coords.shape[0])
    z = model.print_z / 1000.0
    span = f", z {z[0]:.3f} to {z[-1]:.3f} mm" if model.n_layers else ""
    say(f"layers    {model.n_layers:,}{span}")
    say(f"parts     {model.n_parts:,} ({_n(model.n_rings - model.n_parts, 'hole')})")
    ratio = f" ({stored / raw:.0%})" if raw else ""
    raw_text = f"{raw:,} raw -> " if raw is not None else ""
    say(f"vertices  {raw_text}{stored:,} stored{ratio}")
    say(f"open      {_n(n_open, 'chain')} left open, "
        f"{_n(int(model.stitched_gaps.sum()), 'gap')} stitched")
    stages = ", ".join(f"{k} {v:.3f}" for k, v in seconds.items())
    say(f"seconds   {stages} (total {sum(seconds.values()):.3f})")


def _model_for(args: argparse.Namespace) -> tuple[Any, str]:
    """A SlicedModel from a saved .npz, or by slicing a mesh file; and its title."""
    if _is_npz(args.file):
        given = _slicing_given(args)
        if given:
            raise CliInputError(f"{given[0]} applies to a mesh file, not to a saved "
                                f"model '{shown(args.file)}'")
        from vecslice.storage import load_sliced

        return _work(load_sliced, args.file), shown(args.file.name)
    settings = settings_from_args(args)
    t = time.perf_counter()
    mesh = _load(args.file, args, settings)
    return (_slice(mesh, args, settings, time.perf_counter() - t),
            shown(args.file.name))


def cmd_slice(args: argparse.Namespace) -> None:
    """``vecslice slice``."""
    settings = settings_from_args(args)
    out = check_output(args.output, (".npz",), inputs=(args.model,))
    t = time.perf_counter()
    mesh = _load(args.model, args, settings)
    model = _slice(mesh, args, settings, time.perf_counter() - t)
    if out is not None:
        model.save(out)
        say(f"saved     {shown(out)} ({human_bytes(out.stat().st_size)})")


def cmd_info(args: argparse.Namespace) -> None:
    """``vecslice info``."""
    if _is_npz(args.file):
        if args.scale is not None or args.no_repair:
            raise CliInputError("--scale and --no-repair apply to a mesh file, not "
                                f"to a saved model '{shown(args.file)}'")
        from vecslice.storage import load_sliced

        _describe_model(_work(load_sliced, args.file), args.file)
        return
    import numpy as np

    from vecslice.mesh import check_mesh, load_mesh

    mesh = _work(load_mesh, args.file, scale=_scale(args),
                 repair=not args.no_repair)
    report = _work(check_mesh, mesh)
    if report.load_info is not None:  # its source: the path, shown as above
        info = dataclasses.replace(report.load_info, source=shown(args.file))
        report = dataclasses.replace(report, load_info=info)
    say(f"file                {shown(args.file)}")
    say(str(report))  # its last lines say what loading merged, dropped and repaired
    size = (report.bounds[1] - report.bounds[0]) / 1000.0
    hint = size_hint(size, args.scale is not None) \
        if np.all(np.isfinite(size)) else None
    if hint:
        note(f"note: {hint}")


def _describe_model(model: Any, path: Path) -> None:
    say(f"file      {shown(path)} ({human_bytes(path.stat().st_size)})")
    say(f"layers    {model.n_layers:,}")
    if model.n_layers:
        pz, sz = model.print_z / 1000.0, model.slice_z / 1000.0
        th = model.thickness / 1000.0
        say(f"z         {pz[0]:.3f} to {pz[-1]:.3f} mm (printed), cut at "
            f"{sz[0]:.3f} to {sz[-1]:.3f} mm")
        rest = sorted({float(t) for t in th[1:]})
        then = "" if not rest else f", then {rest[0]:g} mm" if len(rest) == 1 \
            else f", then {rest[0]:g} to {rest[-1]:g} mm"
        say(f"thickness first layer {th[0]:g} mm{then}")
    say(f"parts     {model.n_parts:,} ({_n(model.n_rings - model.n_parts, 'hole')})")
    say(f"vertices  {model.coords.shape[0]:,}")
    box = model.bounds()
    if box is not None:
        (x0, y0), (x1, y1) = box / 1000.0
        say(f"bounds    x {x0:.3f} to {x1:.3f} mm, y {y0:.3f} to {y1:.3f} mm")
    say(f"open      {_n(int(model.open_chains.sum()), 'chain')} left open, "
        f"{_n(model.open_ring_offsets.shape[0] - 1, 'polyline')} kept")


def _layer_for(model: Any, args: argparse.Namespace) -> int:
    import numpy as np

    n = model.n_layers
    if n == 0:
        raise CliInputError(f"'{shown(args.file)}' has no layers to preview")
    if args.layer is not None:
        if not -n <= args.layer < n:
            raise CliInputError(f"--layer must be a layer index from 0 to {n - 1} "
                                f"(or -{n} to -1 from the top); got {args.layer}")
        return args.layer % n
    z, top = args.z, int(model.print_z[-1])
    try:
        um: int | None = mm_to_microns(z, "--z")  # compared in µm, as stored
    except CliInputError:  # not finite, or far out
        um = None
    if um is None or z < 0 or um > top:
        raise CliInputError(f"--z must be a height from 0 to {top / 1000:g} mm (the "
                            f"top of the last layer); got {shown_mm(z)}")
    return int(np.searchsorted(model.print_z, um))


def cmd_preview(args: argparse.Namespace) -> None:
    """``vecslice preview``."""
    out = check_output(args.output, (".png", ".svg"), inputs=(args.file,))
    if out is not None and out.suffix.lower() == ".png":
        from vecslice.plot import _matplotlib

        _matplotlib()  # before any slicing: say at once that the extra is missing
    model, _ = _model_for(args)
    k = _layer_for(model, args)
    assert out is not None
    from vecslice.npz import write_atomic  # all or nothing, even on Ctrl-C

    if out.suffix.lower() == ".svg":
        data = model.to_svg(k).encode("utf-8")
        write_atomic(str(out), lambda fh: fh.write(data), what="an SVG picture")
    else:
        from vecslice.plot import save_layer

        write_atomic(str(out), lambda fh: save_layer(model, k, fh, format="png"),
                     what="a PNG picture")
    say(f"layer {k} of {model.n_layers} (z {model.print_z[k] / 1000:g} mm) "
        f"-> {shown(out)}")


def cmd_view(args: argparse.Namespace) -> None:
    """``vecslice view``."""
    out = args.output if args.output is not None else Path(args.file.stem + ".html")
    check_output(out, VIEW_SUFFIXES, inputs=(args.file,))
    model, title = _model_for(args)
    from vecslice.npz import write_atomic
    from vecslice.viewer import viewer_html

    data = _work(viewer_html, model, title=title).encode("utf-8")
    # written from the main thread: Ctrl-C during the write removes the
    # temporary file before the process ends
    write_atomic(str(out), lambda fh: fh.write(data), what="a layer viewer page")
    say(f"wrote     {shown(out)} ({human_bytes(out.stat().st_size)}, "
        f"{model.n_layers:,} layers); open it in a browser")


_COMMANDS = {"slice": cmd_slice, "info": cmd_info, "preview": cmd_preview,
             "view": cmd_view}


def _normalise(argv: list[str]) -> list[str]:
    """``vecslice [MODEL] [options]`` means ``vecslice slice [MODEL] [options]``."""
    if argv and (argv[0] in COMMANDS or argv[0] in ("-h", "--help", "--version")):
        return argv
    return ["slice", *argv]


def _paths(args: argparse.Namespace) -> None:
    """The path arguments (kept as typed by argparse) as Paths, checked first."""
    for dest, flag in (("model", "MODEL"), ("file", "FILE"), ("output", "-o")):
        text = getattr(args, dest, None)
        if text is not None:
            setattr(args, dest, cli_path(text, flag, output=dest == "output"))


def main(argv: Sequence[str] | None = None) -> int:
    """Run the command line; return the exit status (see the module docstring).

    On Ctrl-C it prints ``vecslice: interrupted`` and returns 130 at once, even
    while a kernel is still running in the worker thread (:func:`run` then ends
    the process without waiting for it).
    """
    raw = list(sys.argv[1:] if argv is None else argv)
    try:
        parser = build_parser()
        try:
            args = parser.parse_args(_normalise(raw))
        except SystemExit as exc:  # --help, --version, usage errors (2)
            return int(exc.code or 0) if not isinstance(exc.code, str) else 2
        _paths(args)
        with CompileNotice():
            _COMMANDS[args.command](args)
    except KeyboardInterrupt:
        note("interrupted")
        return INTERRUPTED
    except (VecsliceError, OSError) as exc:
        text = " ".join(str(exc).split())  # one line
        say(f"vecslice: error: {text}", sys.stderr, flush=True)
        return 1
    except MemoryError as exc:  # numpy's names the size it could not allocate
        text = " ".join(str(exc).split()) or "no details"
        say(f"vecslice: error: not enough memory ({text}); slice fewer or thicker "
            "layers (--layer-height, --max-layers) or a smaller model",
            sys.stderr, flush=True)
        return 1
    except UnicodeEncodeError as exc:  # printed by other code than say() (argparse)
        bad = exc.object[exc.start:exc.end]
        say(f"vecslice: error: cannot write {bad!r} in the encoding {exc.encoding!r} "
            "of the terminal; set PYTHONIOENCODING=utf-8", sys.stderr, flush=True)
        return 1
    return 0


def run() -> None:
    """Console-script entry point: :func:`main`, then exit with its status."""
    code = main()
    if code == INTERRUPTED:
        flush_and_exit(code)  # do not wait for a kernel still running
    sys.exit(code)


if __name__ == "__main__":  # pragma: no cover
    run()
