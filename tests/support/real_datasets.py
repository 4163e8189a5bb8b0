"""Real LeRobot datasets that nobody on this team wrote, copied from public GitHub repositories (see
tests/fixtures/lerobot/README.md: source, commit, license, what was dropped, quirks of each).

The bytes are third-party data, so they are not committed in this repository: they live in the steering
repository's shared/ folder (`../shared/fixtures/lerobot/<name>/` beside the checkout, which CI also has), or in
the folder named by `OPENRAL_REAL_LEROBOT`, or in tests/fixtures/lerobot/<name>/ if ever committed there.
`REAL` describes each one; `real_root(name)` finds it (None when absent, and tests then skip); `copy_real` copies
it to a temporary folder, since tests must never write into the fixtures."""

from __future__ import annotations

import os
import shutil
from dataclasses import dataclass
from pathlib import Path

ENV_VAR = "OPENRAL_REAL_LEROBOT"
REPO = Path(__file__).resolve().parents[2]


@dataclass(frozen=True)
class RealDataset:
    """One fixture as its files are (not as its info.json claims): `files` lists every file but README.md."""

    name: str
    version: str  # meta/info.json codebase_version
    layout: str  # "v2.1" (per-episode files), "v3.0-early" (lerobot < 0.5 writer), "v3.0"
    cameras: tuple[str, ...]  # image/video features declared in info.json
    episodes: int  # rows in the episodes table / lines in episodes.jsonl
    frames: int  # rows in the data files
    lerobot_loads: bool  # lerobot 0.6.1's LeRobotDataset(repo_id, root=...) loads every frame
    source: str  # repository URL @ commit : path inside it
    license: str
    files: tuple[str, ...]
    quirks: tuple[str, ...]


_V3_META = ("meta/info.json", "meta/stats.json", "meta/tasks.parquet", "meta/episodes/chunk-000/file-000.parquet")

REAL: dict[str, RealDataset] = {
    d.name: d
    for d in (
        RealDataset(
            name="v21_g1_inspire_av1",
            version="v2.1",
            layout="v2.1",
            cameras=("observation.images.cam_high",),
            episodes=1,
            frames=221,
            lerobot_loads=False,
            source="https://github.com/YifanTian07/G1-policy-train@d1d3bb45f16a99eb3220c88b4f84f6c92d306f88:/",
            license="MIT",
            files=(
                "meta/info.json",
                "meta/tasks.jsonl",
                "meta/episodes.jsonl",
                "meta/episodes_stats.jsonl",
                "data/chunk-000/episode_000029.parquet",
                "videos/chunk-000/observation.images.cam_high/episode_000029.mp4",
            ),
            quirks=(
                "only episode is 29; global index starts at 10640",
                "state/action names are a nested list [[...]]",
                "AV1 video 640x480, names height/width/channel (singular)",
                "lerobot's v2.1->v3.0 converter refuses it: 'Number of episodes is not the same ({0, 29})'",
            ),
        ),
        RealDataset(
            name="v21_cr5_wallclock_timestamps_av1",
            version="v2.1",
            layout="v2.1",
            cameras=("observation.images.top",),
            episodes=1,
            frames=197,
            lerobot_loads=False,
            source="https://github.com/HuangJunkai2023/CR5_TCP_test@f4783b212a090c9f8668b85fb04cea57b8d8fa61"
            ":lerobot_data/",
            license="MIT",
            files=(
                "meta/info.json",
                "meta/tasks.jsonl",
                "meta/episodes.jsonl",
                "meta/episodes_stats.jsonl",
                "data/chunk-000/episode_000000.parquet",
                "videos/chunk-000/observation.images.top/episode_000000.mp4",
            ),
            quirks=(
                "wall-clock timestamps (0.0313 .. 20.5476 s for 197 frames at 10 fps), video on a clean 0.1 s grid",
                "lerobot's converter converts it; loading the result fails with FrameTimestampError",
                "AV1 video 640x480, names height/width/channel (singular); action 7 values, state 6",
            ),
        ),
        RealDataset(
            name="v30early_rebot_b601_state_only",
            version="v3.0",
            layout="v3.0-early",
            cameras=(),
            episodes=1,
            frames=871,
            lerobot_loads=True,
            source="https://github.com/keertimanney/reBot-DevArm@6c813527a8e0bc4c6d7440171e77b179109b5cd9:data/",
            license="CERN-OHL-W-2.0",
            files=(*_V3_META, "data/chunk-000/file-000.parquet"),
            quirks=(
                "tasks.parquet task text in __index_level_0__",
                "no camera at all (video_path set, no videos/)",
                "episodes table with stats quantiles and meta/episodes/* columns",
            ),
        ),
        RealDataset(
            name="v30early_apple_storage_no_video",
            version="v3.0",
            layout="v3.0-early",
            cameras=("observation.image",),
            episodes=3,
            frames=899,
            lerobot_loads=False,
            source="https://github.com/rerun-io/rerun@473c6d44474cc8f071425dfca5467b3882f57d0b"
            ":tests/assets/lerobot/v30_apple_storage/",
            license="Apache-2.0",
            files=(*_V3_META, "data/chunk-000/file-000.parquet"),
            quirks=(
                "partial download: videos/observation.image/chunk-000/file-000.mp4 absent",
                "info.json total_frames 14983 and splits 0:50 disagree with the 3 episodes / 899 rows",
                "tasks.parquet task text in __index_level_0__",
                "channel-first shape [3,720,960], names channel/height/width; per-feature fps keys",
            ),
        ),
    )
}


def _candidates() -> list[Path]:
    env = os.environ.get(ENV_VAR)
    found = [Path(env)] if env else []
    return [*found, REPO / "tests" / "fixtures" / "lerobot", REPO.parent / "shared" / "fixtures" / "lerobot"]


def real_root(name: str) -> Path | None:
    """Where fixture `name` is (the first place holding its meta/info.json), or None when it is nowhere."""
    if name not in REAL:
        raise KeyError(name)
    for base in _candidates():
        if (base / name / "meta" / "info.json").is_file():
            return base / name
    return None


def copy_real(name: str, dest_dir: Path) -> Path:
    """Copy fixture `name` to `dest_dir/name` (a fresh folder) and return it; FileNotFoundError when absent."""
    src = real_root(name)
    if src is None:
        raise FileNotFoundError(f"real fixture {name!r} is not present (see tests/fixtures/lerobot/README.md)")
    dest = dest_dir / name
    shutil.copytree(src, dest)
    return dest
