"""Episode editing of LeRobot v3 datasets: `delete`, `split` and `merge` (see ops.py), `filter_episodes` and
`split_fractions` (see select.py), `reencode` and `encode_images` (see videos.py), each returning `EditResult`s
(`trim.trim` and `resample.resample`, frames dropped inside episodes through subset.py and cut.py, also return the
`subset.Counts` of what was done to the videos; not re-exported here, where they would hide their modules);
`tasks.rename`/`tasks.set_task`, `features.remove`, `features.rename` (`renames`), `derive.add` (`features add`) and
`stats.recompute` change what is copied (through `ops.Rewrite`), as `videos` does; `align.merge` merges datasets
that differ (`--rename`, streams re-encoded where their encoder parameters differ) and `splits.split_spec` splits
by named episode lists.

Every edit writes a complete new dataset atomically through our LeRobot v3 writer (`assemble`), reading its
episodes from the sources without re-encoding video (`source`), except the cameras `videos` is asked to encode
and the frames `trim` and `resample` cannot keep by copying packets.
"""

from openral_data.edit.ops import EditResult, delete, merge, split
from openral_data.edit.select import filter_episodes, split_fractions
from openral_data.edit.videos import encode_images, reencode

__all__ = ["EditResult", "delete", "encode_images", "filter_episodes", "merge", "reencode", "split", "split_fractions"]
