"""`print_json`: one line, `command` and `version` first, the fields in the order given, valid JSON always."""

from __future__ import annotations

import json
from pathlib import Path

import pytest

from openral_data.cli.jsonout import print_json
from openral_data.version import __version__


def test_one_line_in_order_utf8_and_no_nan(capsys: pytest.CaptureFixture[str]) -> None:
    print_json("info", {"z": 1, "path": Path("/d/ß"), "a": [float("nan"), float("inf"), 0.5], "t": ("ü",)})
    out = capsys.readouterr()
    assert out.err == "" and out.out.endswith("\n") and out.out.count("\n") == 1
    assert "ß" in out.out and "\\u" not in out.out  # not escaped
    doc = json.loads(out.out)
    assert list(doc) == ["command", "version", "z", "path", "a", "t"]
    assert doc == {"command": "info", "version": __version__, "z": 1, "path": "/d/ß", "a": [None, None, 0.5],
                   "t": ["ü"]}  # fmt: skip
