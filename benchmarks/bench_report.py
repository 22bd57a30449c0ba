"""``python benchmarks/report.py --quick`` runs and prints the README's table format.

The README's performance table is that script's output; this smoke run (one copy,
one repeat, no timing asserted) keeps it from rotting between full runs.
"""

from __future__ import annotations

import re
import subprocess
import sys
from pathlib import Path

README = Path(__file__).resolve().parent.parent / "README.md"


def _table_rows(text: str) -> list[str]:
    return [line.split(" | ")[0].lstrip("| ") for line in text.splitlines()
            if line.startswith("| ") and not line.startswith("| what ")]


def test_report_quick_prints_the_readme_table_format():
    script = Path(__file__).with_name("report.py")
    out = subprocess.run([sys.executable, str(script), "--quick"], check=True,
                         capture_output=True, text=True, timeout=900).stdout
    lines = out.splitlines()
    assert lines[:2] == ["| what | vecslice | peer | ratio (range) |",
                         "|---|---|---|---|"]
    rows = _table_rows(out)
    # every row of the quick run is a row of the README's table, in its order
    # (the quick run leaves out trimesh, the scaling and the memory rows)
    readme = _table_rows(README.read_text(encoding="utf-8").split("## Performance")[1])
    assert rows and rows == [r for r in readme if r in rows]
    skipped = [r for r in readme if r not in rows]
    assert len(skipped) == 3
    assert any("one Benchy" in r for r in skipped)  # the trimesh row
    for line in lines[2:2 + len(rows)]:
        assert re.search(r"\d×", line.rsplit(" | ", 1)[1]), line  # the ratio cell
    notes = out.split("\n\n", 1)[1]
    assert "with `python benchmarks/report.py --quick` (1 interleaved repeat;" in notes
    assert "scaling row" not in notes and "trimesh row" not in notes
    assert "Workload: one 3DBenchy," in notes and "Versions: vecslice " in notes


def _report():
    """report.py as a module (it is a script, not a package member)."""
    import importlib.util

    spec = importlib.util.spec_from_file_location(
        "report", Path(__file__).with_name("report.py"))
    report = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(report)
    return report


def test_scaling_note_gives_each_size_median_user_and_system_time():
    split = {2: [(0.11, 0.0004), (0.12, 0.0), (0.10, 0.002)],
             4: [(0.22, 0.016), (0.23, 0.012), (0.25, 0.020)],
             8: [(0.45, 0.052), (0.44, 0.061), (0.47, 0.049)]}
    assert _report().scaling_note(split) == (
        "Scaling row, CPU time per call (medians) at 2, 4 and 8 copies: user "
        "0.11, 0.23, 0.45 s, system 0.4, 16, 52 ms (mostly the kernel zeroing "
        "memory new to the process).")


def test_fresh_note_gives_medians_and_each_step_with_the_rounds_range():
    fresh = {2: [(0.10, 0.01), (0.12, 0.02), (0.11, 0.03)],
             4: [(0.20, 0.02), (0.26, 0.04), (0.21, 0.05)],
             8: [(0.40, 0.05), (0.48, 0.07), (0.44, 0.09)]}
    # steps of the medians 0.11 -> 0.21 -> 0.44; rounds' ratios 2, 2.17, 1.91
    # and 2, 1.85, 2.10
    assert _report().fresh_note(fresh) == (
        "The same sizes sliced once each in a fresh process, where all memory is "
        "new (medians of 3 rounds): 0.11 s → 0.21 s → 0.44 s, 1.91× (1.91–2.17) / "
        "2.1× (1.85–2.1) per doubling; system 20, 40, 70 ms.")


def test_fresh_rounds_time_each_size_in_new_processes():
    import numpy as np

    import vecslice as vs

    box = vs.load_mesh(__import__("trimesh").creation.box((10, 10, 10)))
    z = np.arange(-4000, 5000, 1000, dtype=np.int64)
    sizes = {1: (box.vertices, box.faces, z), 2: (box.vertices, box.faces, z[::2])}
    fresh = _report().fresh_rounds(sizes, 2)
    assert sorted(fresh) == [1, 2]
    for times in fresh.values():
        assert len(times) == 2
        assert all(0 < wall < 60 and 0 <= system < 60 for wall, system in times)
