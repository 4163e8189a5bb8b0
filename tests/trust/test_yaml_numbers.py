"""Class 6 of #49, every YAML number bounded at parse time: a 5000-digit integer (over Python's int-from-text
limit: a ValueError traceback before) or float in any YAML we read is one line naming the file and line; the
numbers manifests hold still parse as YAML says (the CLI cases are in the malformed corpus:
`<slot>-5000-digit-integer`)."""

from __future__ import annotations

from pathlib import Path

import pytest

from openral_data.errors import ConfigError
from openral_data.generate.annotations import read_annotations
from openral_data.schemas.base import MAX_NUMBER_CHARS, parse_yaml, read_yaml


def test_ordinary_numbers_parse_as_yaml_says() -> None:
    doc = parse_yaml("a: 12\nb: -1.5e+3\nc: 0x1F\nd: 1_000\ne: .inf\nf: 017\n", "s")
    assert doc == {"a": 12, "b": -1500.0, "c": 31, "d": 1000, "e": float("inf"), "f": 15}
    assert parse_yaml(f"a: {'9' * MAX_NUMBER_CHARS}\n", "s") == {"a": int("9" * MAX_NUMBER_CHARS)}


@pytest.mark.parametrize("number", ["9" * 5000, "-" + "9" * 5000, "1." + "9" * 5000, "0x" + "f" * 5000])
def test_a_huge_number_is_one_line(number: str, tmp_path: Path) -> None:
    path = tmp_path / "scene.yaml"
    path.write_text(f"id: x\nlimits:\n  - 1\n  - {number}\n")
    with pytest.raises(ConfigError, match=rf"^{path} \(line 4\): invalid YAML: a number of {len(number)} characters"):
        read_yaml(path)


def test_an_annotations_file_bounds_its_numbers(tmp_path: Path) -> None:
    path = tmp_path / "annotations.yaml"
    path.write_text(f"episodes:\n  - {'9' * 5000}\n")
    with pytest.raises(ConfigError, match=rf"^{path} \(line 2\): invalid YAML: a number of 5000 characters"):
        read_annotations(path)
