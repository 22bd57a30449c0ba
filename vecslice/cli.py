"""The ``vecslice`` command: slice a model file (or the built-in demo) and report."""

from __future__ import annotations

import argparse
import sys
from collections.abc import Sequence
from pathlib import Path

__all__ = ["main"]


def _parser() -> argparse.ArgumentParser:
    p = argparse.ArgumentParser(
        prog="vecslice",
        description="Slice a triangle mesh into CuraEngine-style layer parts. "
        "Lengths are in µm unless stated otherwise.",
    )
    p.add_argument("model", nargs="?", type=Path,
                   help="STL, OBJ, PLY or 3MF file; omitted: the built-in demo model")
    p.add_argument("-o", "--output", type=Path,
                   help="save the sliced model to this .npz file")
    p.add_argument("--scale", type=float, default=1.0,
                   help="multiply file units to get mm (25.4 for inches, 1000 for m)")
    p.add_argument("--layer-height", type=int, default=100, metavar="UM")
    p.add_argument("--initial-layer-height", type=int, default=300, metavar="UM")
    p.add_argument("--slicing-tolerance", default="middle",
                   choices=("middle", "inclusive", "exclusive"))
    p.add_argument("--max-resolution", type=int, default=500, metavar="UM")
    p.add_argument("--max-deviation", type=int, default=25, metavar="UM")
    p.add_argument("--minimum-polygon-circumference", type=int, default=1000,
                   metavar="UM")
    p.add_argument("--even-odd", action="store_true",
                   help="union overlapping volumes with EvenOdd instead of NonZero")
    p.add_argument("--no-progress", action="store_true", help="no progress bar")
    return p


def main(argv: Sequence[str] | None = None) -> int:
    """Run the command line; returns the process exit code."""
    args = _parser().parse_args(argv)
    import vecslice as vs
    from vecslice.pipeline import StageTimes

    try:
        if args.model is None:
            from vecslice.demo import demo_mesh

            if args.scale != 1.0:
                raise vs.SettingsError(
                    f"`scale` only applies to a model file; got {args.scale} "
                    "without one"
                )

            print("no model given: slicing the built-in demo model")
            mesh = demo_mesh()
        else:
            mesh = vs.load_mesh(args.model, scale=args.scale)
        print(mesh)
        report = vs.check_mesh(mesh)
        if not report.is_clean:
            print(report)
        settings = vs.SliceSettings(
            layer_height=args.layer_height,
            initial_layer_height=args.initial_layer_height,
            slicing_tolerance=args.slicing_tolerance,
            max_resolution=args.max_resolution,
            max_deviation=args.max_deviation,
            minimum_polygon_circumference=args.minimum_polygon_circumference,
            union_overlapping_volumes=not args.even_odd,
        )
        times = StageTimes()
        model = vs.slice_mesh(mesh, settings, progress=not args.no_progress,
                              times=times)
        print(model)
        print(f"time: {times}")
        if args.output is not None:
            model.save(args.output)
            print(f"saved {args.output}")
    except vs.VecsliceError as exc:
        print(f"vecslice: error: {exc}", file=sys.stderr)
        return 2
    return 0


if __name__ == "__main__":  # pragma: no cover
    sys.exit(main())
