"""Every Python snippet of the documentation runs.

The ```python blocks of `python/README.md` and of the user guide (`docs/guide/src/*.md`) are
run in order, file by file, in one namespace per file (a later block uses what an earlier one
made), from the repository root, as a reader would type them.
"""

import re
from pathlib import Path

import pytest

from conftest import ROOT

FENCE = re.compile(r"^```python\n(.*?)^```", re.S | re.M)


def documents():
    docs = [ROOT / "python" / "README.md"]
    docs += sorted((ROOT / "docs" / "guide" / "src").glob("*.md"))
    return [d for d in docs if FENCE.search(d.read_text(encoding="utf-8"))]


def test_the_documents_have_python_snippets():
    # A guard against the scan finding nothing (python/README.md has five).
    assert sum(len(FENCE.findall(d.read_text(encoding="utf-8"))) for d in documents()) >= 5


@pytest.mark.parametrize("doc", documents(), ids=lambda d: str(d.relative_to(ROOT)))
def test_every_python_snippet_runs(doc, monkeypatch):
    text = doc.read_text(encoding="utf-8")
    monkeypatch.chdir(ROOT)
    namespace = {"__name__": "doc_snippet"}
    for match in FENCE.finditer(text):
        line = text[: match.start()].count("\n") + 2
        code = compile(match.group(1), f"{doc.relative_to(ROOT)}:{line}", "exec")
        exec(code, namespace)  # noqa: S102 - the documentation's own code, run as written
