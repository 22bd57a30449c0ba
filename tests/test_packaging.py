"""Where vecslice is imported from: the checkout (editable) or an installed wheel."""

import os
from pathlib import Path

import vecslice
import vecslice._kernels

ROOT = Path(__file__).resolve().parents[1]
INSTALLED = os.environ.get("VECSLICE_EXPECT_INSTALLED")


def test_kernels_live_inside_the_vecslice_package():
    assert vecslice._kernels.__name__ == "vecslice._kernels"
    kernels_dir = Path(vecslice._kernels.__file__).parent
    if INSTALLED:
        # the wheel run (.ci/wheel_check): the installed copy, not the checkout
        site = Path(INSTALLED).resolve()
        assert Path(vecslice.__file__).resolve().is_relative_to(site)
        assert kernels_dir.resolve() == site / "vecslice" / "_kernels"
        assert not [p.name for p in site.iterdir() if p.name.startswith("kernels")]
    else:
        # editable install: vecslice._kernels is the repository's kernels/ folder
        assert kernels_dir.resolve() == ROOT / "kernels"


def test_the_viewer_template_is_package_data():
    from importlib import resources

    text = resources.files("vecslice").joinpath("viewer.html").read_text("utf-8")
    assert "{{DATA}}" in text and "DecompressionStream" in text
