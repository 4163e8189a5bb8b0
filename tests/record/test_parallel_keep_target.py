"""`--workers` with a keep target (`generate --n N`, n_episodes the attempts' cap): the attempts' seeds are split
into contiguous blocks as ever, and each worker keeps its near-equal share of the target (a worker whose share is
0, when the target is below the workers, keeps none)."""

from __future__ import annotations

from pathlib import Path

from openral_data.record.options import RecordOptions
from openral_data.record.parallel.plan import plan


def test_each_worker_keeps_its_share_of_the_target(tmp_path: Path) -> None:
    opts = RecordOptions(scene="mock_pick", n_episodes=9, seed=100, keep="success", keep_target=4, out=tmp_path)
    jobs = plan(opts, 3, tmp_path / "work")
    assert [(j.opts.seed, j.opts.n_episodes, j.opts.keep_target) for j in jobs] == [
        (100, 3, 2),
        (103, 3, 1),
        (106, 3, 1),
    ]
    few = plan(RecordOptions(scene="mock_pick", n_episodes=6, keep="success", keep_target=1, out=tmp_path), 3, tmp_path)
    assert [j.opts.keep_target for j in few] == [1, 0, 0]
    assert all(j.opts.keep_target is None for j in plan(RecordOptions(scene="mock_pick", n_episodes=4), 2, tmp_path))
