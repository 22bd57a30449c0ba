"""Draw docs/adaptive_layers.png: the adaptive layer schedule of 3DBenchy.

Usage: python docs/plot_adaptive_layers.py [MESH]
(default: $VECSLICE_SHARED/meshes/3DBenchy.3mf, the shared data being
../shared beside the repository unless VECSLICE_SHARED names it, as for the tests)

Needs matplotlib (the ``notebooks`` extra). Thickness of every layer against the
height of its top, with CuraEngine's default adaptive settings and with a smaller
topography threshold, beside the uniform 0.1 mm schedule.
"""

from __future__ import annotations

import os
import sys
from pathlib import Path

import matplotlib

matplotlib.use("Agg")
import matplotlib.pyplot as plt
import numpy as np

import vecslice as vs

HERE = Path(__file__).resolve().parent
SHARED = Path(os.environ.get("VECSLICE_SHARED", HERE.parent.parent / "shared"))
MESH = SHARED / "meshes" / "3DBenchy.3mf"


def main() -> None:
    """Draw the schedules and save the PNG beside this script."""
    mesh = vs.load_mesh(sys.argv[1] if len(sys.argv) > 1 else MESH)
    fig, ax = plt.subplots(figsize=(8, 3.2), dpi=100)
    for threshold, color in ((200, "tab:blue"), (50, "tab:orange")):
        s = vs.SliceSettings(adaptive_layers=True, adaptive_threshold=threshold)
        _, print_z, thickness = vs.layer_heights(mesh, s)
        # each layer spans (top - thickness, top]: draw it as a horizontal step
        bottom = (print_z - thickness) / 1000
        ax.stairs(thickness, np.append(bottom, print_z[-1] / 1000), baseline=None,
                  color=color,
                  label=f"adaptive, threshold {threshold / 1000:g} mm "
                        f"({len(print_z)} layers)")
    _, print_z, _ = vs.layer_heights(mesh, vs.SliceSettings())
    ax.axhline(100, color="gray", ls="--", lw=1,
               label=f"uniform 0.1 mm ({len(print_z)} layers)")
    ax.set_xlabel("z (mm above the lowest point)")
    ax.set_ylabel("layer thickness (µm)")
    ax.set_ylim(0, 320)
    ax.set_xlim(0, print_z[-1] / 1000 + 0.5)
    ax.set_title("3DBenchy: CuraEngine's adaptive layer heights (vs.layer_heights)",
                 fontsize=10)
    ax.legend(fontsize=8, loc="upper right")
    fig.tight_layout()
    fig.savefig(HERE / "adaptive_layers.png", dpi=100)


if __name__ == "__main__":
    main()
