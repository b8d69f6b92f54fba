"""The README's Python examples run as they are (blocks of its "Python" section, in order,
in one namespace, as in a notebook)."""

import os
import re
from pathlib import Path

import pytest

README = Path(os.environ.get("IMUNOISE_ROOT", Path(__file__).resolve().parents[2])) / "README.md"


def blocks():
    text = README.read_text(encoding="utf-8")
    sec = text.split("\n## Python\n", 1)[1].split("\n## ", 1)[0]
    return re.findall(r"```python\n(.*?)```", sec, flags=re.S)


def test_readme_has_python_examples():
    assert len(blocks()) >= 4


def test_readme_python_examples_run(tmp_path, monkeypatch):
    pytest.importorskip("distributed")
    monkeypatch.chdir(tmp_path)
    ns = {}
    for i, b in enumerate(blocks()):
        exec(compile(b, f"README.md python block {i + 1}", "exec"), ns)
