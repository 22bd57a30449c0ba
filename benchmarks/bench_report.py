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
