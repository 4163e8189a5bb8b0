"""Run `record` in this process and print `finished N` the moment record reports episode N finished (the
callback the CLI's progress bar advances on), so a test that kills this process knows what was reported.

`python -m tests.support.record_driver '{"scene": ..., "out": ..., "n": 4, "die_at_rename": ["info.json", 3]}'`: with
`die_at_rename`, the process exits abruptly (os._exit, no cleanup — as SIGKILL) instead of doing the k-th
rename onto a file of that name, to land a crash at one exact point of an episode's commit.
"""

from __future__ import annotations

import json
import sys
from pathlib import Path

from openral_data.record.options import RecordOptions
from openral_data.record.sim import record
from openral_data.types import EpisodeRecord
from tests.support.crash import die_at_mutation


def main() -> None:
    args = json.loads(sys.argv[1])
    if args.get("die_at_rename"):
        name, nth = args["die_at_rename"]
        die_at_mutation(nth, ops=("replace",), name=name)

    def progress(rec: EpisodeRecord | None, frames: int, total: int) -> None:
        if rec is not None:
            print(f"finished {rec.index}", flush=True)

    if args.get("resume"):  # like `record --resume --out OUT --n-episodes N [--scene SCENE]`
        named = {"scene"} if args.get("scene") else set()  # a scene file is named again (record/recorded.py)
        opts = RecordOptions(
            scene=args.get("scene"),
            out=Path(args["out"]),
            n_episodes=args["n"],
            resume=True,
            explicit=frozenset({"n_episodes", *named}),
        )
    else:
        opts = RecordOptions(
            scene=args["scene"],
            out=Path(args["out"]),
            n_episodes=args["n"],
            codec=args.get("codec", "h264"),
            formats=tuple(args.get("formats", ["lerobot"])),
        )
    record(opts, progress)


if __name__ == "__main__":
    main()
