"""An RLDS build folder cannot make `info` or `convert` allocate without bound (#49): a picture feature declared
`[-1, -1, 3]` whose PNG header says 12000x12000 (a 17 kB PNG of 432 MB of pixels) is refused from its header
before its pixels are decoded, and a record holding 3 M strings in one feature is refused before they become
Python objects; each in one line, exit 2, in a process whose memory is bounded."""

from __future__ import annotations

import re
from pathlib import Path

from tests.support.bounded import run_bounded
from tests.support.rlds_written import DAMAGES, SHARD, write_rlds


def _damaged(tmp_path: Path, name: str) -> tuple[Path, str]:
    folder = write_rlds(tmp_path / "toy")
    damage, says = DAMAGES[name]
    damage(folder)
    return folder, says


def _refused(args: list[str], says: str) -> str:
    run = run_bounded(*args)
    assert not run.timed_out
    assert run.returncode == 2, run.stderr[-2000:]
    lines = run.stderr.splitlines()
    assert len(lines) == 1 and lines[0].startswith("error: "), run.stderr[-2000:]
    assert re.search(says, lines[0]), lines[0]
    return lines[0]


def test_a_picture_header_over_the_cap_is_refused_before_decoding(tmp_path: Path) -> None:
    folder, says = _damaged(tmp_path, "huge-picture")
    out = tmp_path / "out"
    line = _refused(["convert", str(folder), str(out), "--fps", "5", "--codec", "h264"], re.escape(SHARD) + ".*" + says)
    assert "over the 8192-pixel side" in line  # the cap, not a failed decode
    assert not out.exists()  # nothing published


def test_a_record_of_millions_of_strings_is_refused_in_info(tmp_path: Path) -> None:
    folder, says = _damaged(tmp_path, "many-strings")
    line = _refused(["info", str(folder)], says)
    assert line.endswith("3000000 strings, over the 1048576-string limit")
