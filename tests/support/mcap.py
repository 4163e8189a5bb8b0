"""Check an MCAP/rosbag2 output with three independent readers: rosbags, the `mcap` package, and rerun."""

from __future__ import annotations

import subprocess
from collections import Counter
from pathlib import Path
from typing import Any

from mcap.reader import make_reader
from mcap_ros2.decoder import DecoderFactory
from rosbags.highlevel import AnyReader

from tests.support.rrd import RERUN


def rerun_cli() -> str:
    assert RERUN.is_file(), "the rerun CLI (rerun-sdk) is not installed"
    return str(RERUN)


def check_bag(bag: Path) -> dict[str, list[tuple[int, Any]]]:
    """Every message of `bag` (a rosbag2 dir) deserialised by rosbags; each .mcap CRC-checked and decoded by
    the mcap reader and passed by `rerun mcap check --full`. Returns {topic: [(log ns, message), ...]}."""
    out: dict[str, list[tuple[int, Any]]] = {}
    with AnyReader([bag]) as reader:
        for conn, ns, raw in reader.messages():
            out.setdefault(conn.topic, []).append((ns, reader.deserialize(raw, conn.msgtype)))
    counts = Counter({t: len(v) for t, v in out.items()})
    mcaps = sorted(bag.glob("*.mcap")) if bag.is_dir() else [bag]
    assert mcaps, f"{bag}: no .mcap file"
    seen: Counter[str] = Counter()
    for path in mcaps:
        with path.open("rb") as fh:
            reader2 = make_reader(fh, validate_crcs=True, decoder_factories=[DecoderFactory()])
            summary = reader2.get_summary()
            assert summary is not None, f"{path}: no summary section"
            for _schema, channel, message, decoded in reader2.iter_decoded_messages(log_time_order=True):
                assert decoded is not None
                assert message.log_time >= 0
                seen[channel.topic] += 1
        cmd = [rerun_cli(), "mcap", "check", "--full", str(path)]
        proc = subprocess.run(cmd, capture_output=True, text=True, timeout=300, check=False)
        assert proc.returncode == 0, f"rerun mcap check {path}: {proc.stdout}{proc.stderr}"
        assert_rerun_ok(proc.stdout, path)
    assert seen == counts, (seen, counts)
    return out


def chunk_compressions(bag: Path) -> set[str]:
    """The compression of every chunk of `bag`'s .mcap (a rosbag2 dir), read from its summary's chunk indexes."""
    (path,) = bag.glob("*.mcap")
    with path.open("rb") as fh:
        summary = make_reader(fh).get_summary()
    assert summary is not None and summary.chunk_indexes
    return {index.compression for index in summary.chunk_indexes}


def assert_rerun_ok(report: str, path: Path) -> None:
    """`rerun mcap check` prints one row per topic/timeline: status `ok` and no issues (`—`) on every row."""
    lines = report.splitlines()
    header = next(i for i, line in enumerate(lines) if line.split()[:2] == ["Status", "ID"])
    rows = [line for line in lines[header + 2 :] if line.strip()]
    assert rows, f"rerun mcap check {path}: no topics reported\n{report}"
    for row in rows:
        cells = row.split()
        assert cells[0] == "ok" and cells[-1] == "—", f"rerun mcap check {path}: {row}\n{report}"
