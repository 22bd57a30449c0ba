"""The README's library snippet runs as written."""

import re
from pathlib import Path

README = Path(__file__).resolve().parents[1] / "README.md"


def test_library_snippet_runs(tmp_path, monkeypatch):
    text = README.read_text(encoding="utf-8")
    section = text[text.index("## Use it as a library"):]
    code = re.search(r"```python\n(.*?)```", section, re.S).group(1)
    monkeypatch.chdir(tmp_path)  # it saves demo.npz
    scope = {}
    exec(compile(code, "README.md", "exec"), scope)
    assert scope["model"].n_layers > 0 and scope["simple"].n_rings > 0
    assert scope["svg"].startswith("<svg") and (tmp_path / "demo.npz").exists()
