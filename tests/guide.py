"""The guides' example modules, as the tests that run them read them."""

from __future__ import annotations

import pathlib
import re

GUIDES = pathlib.Path(__file__).resolve().parents[1] / "docs" / "guide"


def guide_block(page: str, first_line: str) -> str:
    """The one ```python block of docs/guide/`page` that starts with `first_line`
    (``"# my_worlds.py"``): the module a user would save."""
    blocks = re.findall(r"```python\n(.*?)```", (GUIDES / page).read_text(), re.S)
    (block,) = [b for b in blocks if b.startswith(first_line)]
    return block
