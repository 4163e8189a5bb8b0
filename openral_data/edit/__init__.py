"""Episode editing of LeRobot v3 datasets: `delete`, `split` and `merge` (see ops.py), `filter_episodes` and
`split_fractions` (see select.py), each returning `EditResult`s; `tasks.rename`/`tasks.set_task`,
`features.remove` and `stats.recompute` change what is copied (through `ops.Rewrite`).

Every edit writes a complete new dataset atomically through our LeRobot v3 writer (`assemble`), reading its
episodes from the sources without re-encoding video (`source`).
"""

from openral_data.edit.ops import EditResult, delete, merge, split
from openral_data.edit.select import filter_episodes, split_fractions

__all__ = ["EditResult", "delete", "filter_episodes", "merge", "split", "split_fractions"]
