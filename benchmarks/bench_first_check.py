"""The first-episode check's CPU (`loadable.check_loadable`, what `record` runs after a new recording's first
episode), as `datasets` 4.8.5 does it and with `datasets` 5.x's per-column `Features.__setitem__`.

lerobot 0.6.1 needs `datasets` < 5. There, `Features.__setitem__` re-derives `_column_requires_decoding` for every
column, so building `Features` is quadratic in the columns: 141 in W's `meta/episodes/` table, most of them
lerobot's own `stats/...`. `datasets` 5.x updates only the column it sets. The second measurement applies that
one method in this process only, to preview what the check would cost once lerobot allows `datasets` 5: it
measures, it ships nothing.

The dataset is one episode of workload W's shape recorded by the real CLI (the mock scene of
bench_cli_writer.py, AV1, the check itself off while recording). Each figure is the median `time.process_time`
of `--repeats` checks, in one warm process, after one untimed check (first-use costs).

Run from the repository root::

    .venv/bin/python benchmarks/bench_first_check.py --repeats 7
"""

from __future__ import annotations

import argparse
import os
import statistics
import subprocess
import sys
import tempfile
import time
from pathlib import Path
from typing import Any

REPO = Path(__file__).resolve().parent.parent
sys.path.insert(0, str(REPO))

from bench_cli_writer import RSKILL, child_env, write_scene  # noqa: E402
from workload import Workload  # noqa: E402

from openral_data.formats.lerobot_v3.layout import episodes_files  # noqa: E402
from openral_data.formats.lerobot_v3.loadable import check_loadable, warm_up  # noqa: E402
from openral_data.formats.parquetfile import read_schema  # noqa: E402


def record_one(folder: Path) -> Path:
    """One W-shaped episode recorded by `record` (check off: this script times it)."""
    scene = write_scene(folder / "w.yaml", Workload(episodes=1))
    out = folder / "ds"
    args = ["record", "--scene", str(scene), "--rskill", RSKILL, "--n-episodes", "1", "--codec", "av1"]
    env = child_env() | {"OPENRAL_PUBLISH_LOAD": "0"}
    cmd = [sys.executable, "-P", "-m", "openral_data.cli", *args, "--out", str(out)]
    subprocess.run(cmd, env=env, check=True, capture_output=True)
    return out


def median_cpu(out: Path, repeats: int) -> float:
    spent = []
    for _ in range(repeats):
        t = time.process_time()
        check_loadable(out, out)
        spent.append(time.process_time() - t)
    return statistics.median(spent)


def per_column_sync() -> None:
    """`datasets` 5.x's `Features.__setitem__`: the one column set is synced (this process only)."""
    from datasets.features import features

    def setitem(self: Any, column: str, feature: Any) -> None:
        dict.__setitem__(self, column, feature)
        self._column_requires_decoding[column] = features.require_decoding(feature)

    features.Features.__setitem__ = setitem  # type: ignore[method-assign]


def main(argv: list[str] | None = None) -> int:
    p = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    p.add_argument("--repeats", type=int, default=7)
    args = p.parse_args(argv)
    os.environ.pop("OPENRAL_PUBLISH_LOAD", None)  # this process runs the check with lerobot's load
    import datasets

    with tempfile.TemporaryDirectory(prefix="openral-bench-check-") as tmp:
        out = record_one(Path(tmp))
        columns = len(read_schema(episodes_files(out)[0]).names)
        warm_up()
        check_loadable(out, out)  # untimed: first-use costs
        old = median_cpu(out, args.repeats)
        print(f"datasets {datasets.__version__}, meta/episodes/ columns: {columns}")
        print(f"first-episode check, CPU s (median of {args.repeats}): {old:.3f}")
        if int(datasets.__version__.split(".")[0]) < 5:
            per_column_sync()
            new = median_cpu(out, args.repeats)
            print(f"  with datasets 5.x's per-column Features.__setitem__: {new:.3f} ({new / old:.2f}x)")
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
