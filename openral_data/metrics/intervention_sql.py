"""Interventions (a person took over from the policy: `openral.intervention`, columns.py; written by
policies/intervention.py) as SQL
views; the `stats` report's tables (report.py) read them.

Views (docs/stats.md):

* `interventions` — one row per takeover: dataset, episode_index, start_frame (the first frame the person
  drove), end_frame (the first frame after it: the policy's again, or the episode's end), length (frames).
* `intervention_episodes` — one row per episode of a dataset that records interventions: dataset,
  episode_index, policy (the rSkill that drove), frames, intervention_frames, rate (their share), interventions
  (takeovers), mean_length, max_length (frames; NULL without a takeover).

A dataset without the column (a plain recording, a foreign dataset) adds no rows; with none, both are empty. So
does a dataset whose `openral.intervention` is not our flag (a foreign dataset may carry anything under that name):
only a bool of shape [1] (info.json and the data) is read as one (`records_interventions`).
"""

from __future__ import annotations

from collections.abc import Sequence

from openral_data.columns import INTERVENTION
from openral_data.metrics.sources import DatasetSource

_EMPTY_RUNS = (
    "SELECT NULL::VARCHAR AS dataset, NULL::BIGINT AS episode_index, NULL::BIGINT AS start_frame, "
    "NULL::BIGINT AS end_frame, NULL::BIGINT AS length LIMIT 0"
)
_EMPTY_FRAMES = (
    "SELECT NULL::VARCHAR AS dataset, NULL::BIGINT AS episode_index, NULL::BIGINT AS frames, "
    "NULL::BIGINT AS intervention_frames LIMIT 0"
)
_FLAG = '"' + INTERVENTION + '"'
# the policy that drove: `policy:<rskill>+teleop:<device>` (`script:` for a scripted expert) in the episode's
# operator, else the dataset's rSkill
_POLICY = (
    "CASE WHEN e.operator LIKE 'policy:%' OR e.operator LIKE 'script:%' "
    "THEN split_part(split_part(e.operator, '+', 1), ':', 2) ELSE e.rskill END"
)
EPISODE_COLUMNS = [
    *("dataset", "episode_index", "policy", "frames", "intervention_frames", "rate", "interventions"),
    *("mean_length", "max_length"),
]
# one row per dataset (a DAgger round): the share of its episodes taken over at least once and of its frames
ROUND_COLUMNS = [
    *("dataset", "episodes", "episodes_taken_over", "episode_rate", "frames", "intervention_frames", "rate"),
    "interventions",
]
ROUNDS_SQL = (
    "SELECT dataset, count(*)::BIGINT, (count(*) FILTER (WHERE interventions > 0))::BIGINT, "
    "(count(*) FILTER (WHERE interventions > 0)) / count(*)::DOUBLE, sum(frames)::BIGINT, "
    "sum(intervention_frames)::BIGINT, sum(intervention_frames) / sum(frames)::DOUBLE, sum(interventions)::BIGINT "
    "FROM intervention_episodes GROUP BY dataset ORDER BY dataset"
)
POLICY_COLUMNS = [
    *("policy", "episodes", "frames", "intervention_frames", "rate", "interventions", "mean_length", "max_length"),
]
EPISODES_SQL = f"SELECT {', '.join(EPISODE_COLUMNS)} FROM intervention_episodes ORDER BY dataset, episode_index"
POLICIES_SQL = (
    "SELECT policy, count(*), sum(frames)::BIGINT, sum(intervention_frames)::BIGINT, "
    "sum(intervention_frames) / sum(frames)::DOUBLE, sum(interventions)::BIGINT, "
    "CASE WHEN sum(interventions) > 0 THEN sum(intervention_frames) / sum(interventions)::DOUBLE END, "
    "max(max_length) FROM intervention_episodes GROUP BY policy ORDER BY policy"
)


def records_interventions(ds: DatasetSource) -> bool:
    """Whether `ds` has our intervention flags: `openral.intervention` a bool of shape [1] in info.json and a bool
    column in its (first) data file (`bool_data_columns`, read with `data_columns`)."""
    feature = ds.info["features"].get(INTERVENTION)
    if INTERVENTION not in ds.bool_data_columns or not ds.data_files or not isinstance(feature, dict):
        return False
    return feature.get("dtype") == "bool" and feature.get("shape") == [1]


def _union(parts: list[str], empty: str) -> str:
    return "\nUNION ALL\n".join(parts) if parts else empty


def view_statements(sources: Sequence[tuple[str, str]]) -> list[str]:
    """CREATE VIEW for both views (run after the `episodes` view): `sources` are (the dataset's label as an SQL
    literal, its data files as an SQL table expression) of the datasets that have the column."""
    runs, frames = [], []
    for label, data in sources:
        # consecutive flagged frames of an episode share frame_index - their rank among the flagged ones
        runs.append(
            f"SELECT {label} AS dataset, episode_index, min(frame_index)::BIGINT AS start_frame, "
            "(max(frame_index) + 1)::BIGINT AS end_frame, count(*)::BIGINT AS length FROM ("
            "SELECT episode_index, frame_index, frame_index - row_number() OVER "
            f"(PARTITION BY episode_index ORDER BY frame_index) AS run FROM {data} WHERE {_FLAG}) "
            "GROUP BY episode_index, run"
        )
        frames.append(
            f"SELECT {label} AS dataset, episode_index, count(*)::BIGINT AS frames, "
            f"(count(*) FILTER ({_FLAG}))::BIGINT AS intervention_frames FROM {data} GROUP BY episode_index"
        )
    episodes = (
        "CREATE VIEW intervention_episodes AS "
        f"SELECT f.dataset, f.episode_index, ({_POLICY})::VARCHAR AS policy, f.frames, f.intervention_frames, "
        "f.intervention_frames / f.frames::DOUBLE AS rate, coalesce(r.n, 0)::BIGINT AS interventions, "
        "r.mean_length, r.max_length "
        f"FROM ({_union(frames, _EMPTY_FRAMES)}) f "
        "LEFT JOIN (SELECT dataset, episode_index, count(*) AS n, avg(length) AS mean_length, "
        "max(length)::BIGINT AS max_length FROM interventions GROUP BY dataset, episode_index) r "
        "USING (dataset, episode_index) "
        "LEFT JOIN episodes e USING (dataset, episode_index)"
    )
    return ["CREATE VIEW interventions AS " + _union(runs, _EMPTY_RUNS), episodes]
