"""The code of docs/getting_started.md runs as written (issue 26): its ```python blocks are
executed in order in one namespace, as a reader pastes them."""

from __future__ import annotations

import re
from pathlib import Path

PAGE = Path(__file__).resolve().parents[1] / "docs" / "getting_started.md"


def test_getting_started_code_runs(capsys):
    blocks = re.findall(r"```python\n(.*?)```", PAGE.read_text(encoding="utf-8"), flags=re.S)
    assert len(blocks) >= 4
    namespace: dict = {}
    for i, code in enumerate(blocks):
        exec(compile(code, f"{PAGE.name}[block {i}]", "exec"), namespace)  # noqa: S102 (the docs' own code)
    out = capsys.readouterr().out
    assert "torch.Size([90, 401])" in out and "torch.Size([90, 3])" in out
