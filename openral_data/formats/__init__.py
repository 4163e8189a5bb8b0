"""On-disk formats, each a subpackage or module whose face names its reader and writer API.

* `lerobot_v3`: LeRobotDataset v3 (read its metadata and frames back; write it episode by episode, crash-safe);
* `lerobot_v2`: LeRobot v2.0/v2.1 read in place, read-only, in the v3 readers' shapes; `dataset`: `open_lerobot`,
  the one place the read-only commands pick the v3 or v2.x reader by `codebase_version`;
* `mcap`: ROS 2 MCAP, one rosbag2 bag per episode (write the bags; list the finished ones, decode images);
* `episodic`: the protocol episodic array sources show; `zarr_replay`: diffusion policy / UMI zarr replay buffers
  and `rlds`: RLDS / TFDS episodes (TFRecord + features.json), each an `ArraySource`;
* `results`: the replay / evaluation results layout (`write_results` / `open_results`);
* `atomic`: crash-safe file writes (temp file, fsync, rename; journaled batches);
* `jsonfile`: reading their JSON files with one error message;
* `write_errors`: the error a failed write becomes (`DiskError` for a full or failing disk), for every writer;
* `progress`: the ambient `(done, total)` of long loops (edits, `doctor --deep`), for the CLI's progress bar.

Formats import only the shared types, errors and schemas below them. The subpackages are not imported here
(`from openral_data.formats import lerobot_v3`), so using one never loads the others' libraries.
"""

__all__ = [
    "atomic",
    "dataset",
    "episodic",
    "jsonfile",
    "lerobot_v2",
    "lerobot_v3",
    "mcap",
    "progress",
    "results",
    "rlds",
    "zarr_replay",
]
