"""The README's Python examples run as written, and its commands exist."""

import re

import pytest
from conftest import REPO

README = (REPO / "README.md").read_text(encoding="utf-8")
EXAMPLES = re.findall(r"```python\n(.*?)```", README, re.DOTALL)


def test_readme_has_examples() -> None:
    assert len(EXAMPLES) >= 4


@pytest.mark.parametrize("source", EXAMPLES, ids=[f"example{i}" for i in range(len(EXAMPLES))])
def test_example_runs(source: str) -> None:
    # A name no file has: tools that look source up by file name (hypothesis does) must not
    # read README.md itself, where the example's line numbers mean other lines.
    exec(compile(source, "<README example>", "exec"), {"__name__": "readme"})
