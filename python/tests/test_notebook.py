"""Runs docs/python-notebook.md as a notebook would: its ```python blocks, in order, in one
namespace, in a fresh directory holding the repository's configs/ and testdata/ (links), so
that the page's relative paths and the files it writes behave as in a checkout. Any exception
fails the test, naming the block."""

import os
import re

from conftest import REPO

PAGE = REPO / "docs" / "python-notebook.md"


def python_blocks(text):
    return re.findall(r"^```python\n(.*?)^```$", text, flags=re.DOTALL | re.MULTILINE)


def test_notebook_page_runs(tmp_path, monkeypatch):
    blocks = python_blocks(PAGE.read_text(encoding="utf-8"))
    assert len(blocks) >= 5, "the page lost its code"
    for name in ("configs", "testdata"):
        os.symlink(REPO / name, tmp_path / name)
    monkeypatch.chdir(tmp_path)
    namespace = {"__name__": "__notebook__"}
    for k, block in enumerate(blocks):
        code = compile(block, f"{PAGE.name}, python block {k + 1}", "exec")
        exec(code, namespace)  # noqa: S102 - the page's own code, as a reader runs it
