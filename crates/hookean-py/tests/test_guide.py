"""The user's guide's Python examples (docs/guide/src/*.md, ```python blocks) run.

Each block runs on its own, in a fresh namespace, as a reader would paste it;
a block's own asserts check what it shows.
"""

import pathlib
import re

import pytest

GUIDE = pathlib.Path(__file__).resolve().parents[3] / "docs" / "guide" / "src"
BLOCK = re.compile(r"^```python\n(.*?)^```", re.MULTILINE | re.DOTALL)


def blocks():
    for page in sorted(GUIDE.glob("*.md")):
        for k, match in enumerate(BLOCK.finditer(page.read_text(encoding="utf-8"))):
            yield pytest.param(match.group(1), id=f"{page.name}-{k + 1}")


def test_the_guide_has_python_examples():
    assert len(list(blocks())) >= 2


@pytest.mark.parametrize("code", list(blocks()))
def test_guide_python_block_runs(code):
    exec(compile(code, "<guide>", "exec"), {"__name__": "__guide__"})
