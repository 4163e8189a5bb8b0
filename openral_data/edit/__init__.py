"""Episode editing of LeRobot v3 datasets: `delete`, `split` and `merge` (see ops.py), `filter_episodes` and
`split_fractions` (see select.py), `reencode` and `encode_images` (see videos.py), `trim` and `resample` (frames
dropped inside episodes, see trim.py, resample.py, subset.py and cut.py; with the `subset.Counts` of what was done
to the videos), each returning `EditResult`s;
`tasks.rename`/`tasks.set_task`, `features.remove` and `stats.recompute` change what is copied (through
`ops.Rewrite`), as `videos` does.

Every edit writes a complete new dataset atomically through our LeRobot v3 writer (`assemble`), reading its
episodes from the sources without re-encoding video (`source`), except the cameras `videos` is asked to encode
and the frames `trim` and `resample` cannot keep by copying packets.
"""

from openral_data.edit.ops import EditResult, delete, merge, split
from openral_data.edit.resample import resample
from openral_data.edit.select import filter_episodes, split_fractions
from openral_data.edit.trim import trim
from openral_data.edit.videos import encode_images, reencode

__all__ = [
    "EditResult",
    "delete",
    "encode_images",
    "filter_episodes",
    "merge",
    "reencode",
    "resample",
    "split",
    "split_fractions",
    "trim",
]
