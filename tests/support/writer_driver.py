"""Write a `tests.support.patterned` dataset through `LeRobotV3Writer` + `DatasetBridge` in this process, printing
what a test that crashes it needs to know, line by line (flushed):

* `mutation I OP PATH` after the I-th filesystem mutation (`tests.support.crash`) is done, PATH relative to
  the dataset root;
* `committed N` after a mutation that put `meta/info.json` in place: N is its `total_episodes`;
* `finished E` when `end_episode` of episode E returned;
* `mutations M` at the end, after `close()`.

`python -m tests.support.writer_driver '{"root": ..., "lengths": [3, 5], "die_at": 7, "config": {...}}'` (from
the repo root): with `die_at`, the process exits abruptly (os._exit(137), no cleanup, as SIGKILL) instead of
doing its `die_at`-th mutation. `config`: `WriterConfig` fields (`data_files_size_in_mb`, `video_files_size_in_mb`,
`staged_episodes`, ...), passed only when given; the codec is h264. `shape` (default 64 x 64) and `state_dim`
(default 4) shape the dataset. `mb`: the bytes the writer's file sizes count as one MB (`use_megabyte`), so a
small dataset rotates its files as a large one does. `tests.support.forked` runs it many times from one
process (`warm_up` first).
"""

from __future__ import annotations

import json
import sys
from pathlib import Path
from typing import Any

from openral_data.formats.lerobot_v3 import LeRobotV3Writer, VideoSettings, WriterConfig
from openral_data.formats.lerobot_v3 import config as writer_config_module
from openral_data.formats.lerobot_v3 import warm_up as warm_up_pyarrow
from openral_data.formats.lerobot_v3.layout import INFO_PATH
from openral_data.runtime.bridge import DatasetBridge
from tests.support.crash import die_at_mutation
from tests.support.patterned import unit_schema, write_episodes

SHAPE = (64, 64)


def writer_config(knobs: dict[str, Any]) -> WriterConfig:
    """The driver's writer settings: h264 and the given `WriterConfig` fields."""
    return WriterConfig(video=VideoSettings(codec="h264"), **knobs)


def use_megabyte(size: int | None) -> None:
    """Scale the writer's file-size limits: `size` bytes count as the 1 MB of `data_files_size_in_mb: 1`. The
    rotation and consolidation logic is the writer's own; only its unit shrinks, so tens of frames of a few floats
    fill a data file the way megabytes do (None: the real MB)."""
    writer_config_module.MB = size if size is not None else 1 << 20


def warm_up() -> None:
    """What a run would otherwise pay in its first commit (pyarrow's first array imports pandas), paid once in
    the `tests.support.forked` server before it forks the runs."""
    warm_up_pyarrow()


def main() -> None:
    args = json.loads(sys.argv[1])
    use_megabyte(args.get("mb"))
    root = Path(args["root"])
    shape = tuple(args.get("shape", SHAPE))
    state_dim = int(args.get("state_dim", 4))

    def report(i: int, op: str, target: Path) -> None:
        rel = target.relative_to(root) if target.is_relative_to(root) else target
        print(f"mutation {i} {op} {rel}", flush=True)
        if target == root / INFO_PATH and op in ("replace", "rename"):
            print(f"committed {json.loads(target.read_text())['total_episodes']}", flush=True)

    counted = die_at_mutation(args.get("die_at"), report=report)
    schema = unit_schema(state_dim, (shape[0], shape[1]))
    writer = LeRobotV3Writer(root, schema, writer_config(args.get("config", {})))
    bridge = DatasetBridge(schema, [writer])
    write_episodes(
        bridge,
        list(args["lengths"]),
        state_dim=state_dim,
        shape=(shape[0], shape[1]),
        after_each=lambda e: print(f"finished {e}", flush=True),
    )
    bridge.close()
    print(f"mutations {counted()}", flush=True)


if __name__ == "__main__":
    main()
