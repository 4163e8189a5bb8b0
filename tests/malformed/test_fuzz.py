"""Fuzzing the readers of untrusted files: every input gives a result or an `OpenralError`, never anything else.

Deterministic (`derandomize`) and bounded (200 examples each) so CI stays fast and reproducible.
"""

from __future__ import annotations

import copy
import json
import shutil
from collections.abc import Callable
from pathlib import Path
from typing import Any

import pyarrow as pa
import pyarrow.parquet as pq
import pytest
import yaml
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st

from openral_data.episodes import parse_episodes
from openral_data.errors import EpisodeSelectionError, OpenralError
from openral_data.formats.lerobot_v3 import layout
from openral_data.formats.lerobot_v3.reader import read_episodes, read_info, read_tasks, summarize
from openral_data.pipeline.schema import load_pipeline
from openral_data.replay.rerecord import load_view
from openral_data.schemas.base import load_model
from openral_data.schemas.mapping import load_mapping
from openral_data.schemas.robot import RobotManifest
from openral_data.schemas.rskill import RSkillManifest
from openral_data.schemas.scene import load_scene
from tests.support.bags import MAPPING
from tests.support.home import BUILTIN, REPO
from tests.support.scenes import mock_scene

FUZZ = settings(
    max_examples=200,
    deadline=None,
    derandomize=True,
    suppress_health_check=[HealthCheck.function_scoped_fixture, HealthCheck.too_slow],
)

# -- values YAML and JSON can hold, including the awkward ones
scalars = st.one_of(
    st.none(),
    st.booleans(),
    st.integers(min_value=-(2**70), max_value=2**70),
    st.floats(allow_nan=True, allow_infinity=True),
    st.text(max_size=12),
)
values = st.recursive(
    scalars,
    lambda inner: st.one_of(st.lists(inner, max_size=4), st.dictionaries(st.text(max_size=8), inner, max_size=4)),
    max_leaves=12,
)


def _paths(doc: Any, prefix: tuple[Any, ...] = ()) -> list[tuple[Any, ...]]:
    """Every key/index path in `doc`, the root included."""
    out = [prefix]
    if isinstance(doc, dict):
        for k, v in doc.items():
            out += _paths(v, (*prefix, k))
    elif isinstance(doc, list):
        for i, v in enumerate(doc):
            out += _paths(v, (*prefix, i))
    return out


@st.composite
def mutated(draw: st.DrawFn, base: Any) -> Any:
    """`base` with one to three nodes replaced by arbitrary values, deleted, or given an extra key."""
    doc = copy.deepcopy(base)
    for _ in range(draw(st.integers(1, 3))):
        where = draw(st.sampled_from(_paths(doc)))
        if not where:
            return draw(values)
        parent = doc
        for part in where[:-1]:
            parent = parent[part]
        action = draw(st.sampled_from(["replace", "delete", "extra"]))
        if action == "replace" or not isinstance(parent, dict | list):
            parent[where[-1]] = draw(values)
        elif action == "delete":
            del parent[where[-1]]
        elif isinstance(parent, dict):
            parent[draw(st.text(max_size=8))] = draw(values)
        else:
            parent.append(draw(values))
    return doc


def _doc(path: Path) -> Any:
    return yaml.safe_load(path.read_text())


PIPELINE = _doc(REPO / "pipelines/mock_campaign.yaml")
CAMERAS = {"cameras": [{"name": "front", "width": 64, "height": 48}], "render": {"shadows": False}}
LOADERS: dict[str, tuple[Callable[[Path], object], Any]] = {
    "scene": (load_scene, mock_scene()),
    "rskill": (lambda p: load_model(RSkillManifest, p), _doc(BUILTIN / "rskills/random-mock/rskill.yaml")),
    "robot": (lambda p: load_model(RobotManifest, p), _doc(BUILTIN / "robots/mock_arm/robot.yaml")),
    "mapping": (load_mapping, MAPPING),
    "pipeline": (load_pipeline, PIPELINE),
    "cameras": (load_view, CAMERAS),
}


def _loads_or_refuses(load: Callable[[Path], object], path: Path) -> None:
    try:
        load(path)
    except OpenralError as exc:
        assert "\n" not in str(exc) and str(path) in str(exc), str(exc)


@pytest.mark.parametrize("kind", list(LOADERS))
def test_schema_loaders_on_mutated_documents(kind: str, tmp_path: Path) -> None:
    load, base = LOADERS[kind]
    path = tmp_path / f"{kind}.yaml"

    @FUZZ
    @given(doc=mutated(base))
    def check(doc: Any) -> None:
        path.write_text(yaml.safe_dump(doc, sort_keys=False, allow_unicode=True))
        _loads_or_refuses(load, path)

    check()


@pytest.mark.parametrize("kind", list(LOADERS))
def test_schema_loaders_on_arbitrary_bytes(kind: str, tmp_path: Path) -> None:
    load, base = LOADERS[kind]
    path = tmp_path / f"{kind}.yaml"
    valid = yaml.safe_dump(base, sort_keys=False).encode()

    @FUZZ
    @given(
        data=st.one_of(
            st.binary(max_size=200),
            st.text(max_size=200).map(str.encode),
            # a valid file with a slice replaced: YAML syntax errors at every depth
            st.tuples(st.integers(0, len(valid)), st.integers(0, 40), st.binary(max_size=20)).map(
                lambda t: valid[: t[0]] + t[2] + valid[t[0] + t[1] :]
            ),
        )
    )
    def check(data: bytes) -> None:
        path.write_bytes(data)
        _loads_or_refuses(load, path)

    check()


@FUZZ
@given(text=st.one_of(st.text(max_size=30), st.text(alphabet="0123456789,- ", max_size=30)), total=st.integers(0, 50))
def test_episode_selection_parser(text: str, total: int) -> None:
    try:
        chosen = parse_episodes(text, total)
    except EpisodeSelectionError as exc:
        assert exc.code in {"episodes.syntax", "episodes.range", "episodes.duplicate"}
        return
    assert chosen and len(set(chosen)) == len(chosen) and all(0 <= e < total for e in chosen)


@FUZZ
@given(parts=st.lists(st.tuples(st.integers(0, 30), st.integers(0, 5)), min_size=1, max_size=6))
def test_episode_selection_round_trip(parts: list[tuple[int, int]]) -> None:
    text = ",".join(f"{a}-{a + n}" if n else str(a) for a, n in parts)
    expected = [e for a, n in parts for e in range(a, a + n + 1)]
    if len(set(expected)) != len(expected):
        with pytest.raises(EpisodeSelectionError):
            parse_episodes(text, 100)
    else:
        assert parse_episodes(text, 100) == expected


@pytest.fixture(scope="module")
def dataset_copy(tmp_path_factory: pytest.TempPathFactory, corpus_dataset: Path) -> Path:
    dst = tmp_path_factory.mktemp("fuzz") / "ds"
    shutil.copytree(corpus_dataset, dst)
    return dst


def _summarize_or_refuse(root: Path) -> None:
    try:
        read_info(root)
        summarize(root)
        read_tasks(root)
    except OpenralError as exc:
        assert "\n" not in str(exc)


def test_info_json_readers(dataset_copy: Path) -> None:
    info_path = dataset_copy / layout.INFO_PATH
    original = info_path.read_bytes()
    base = json.loads(original)

    @FUZZ
    @given(
        data=st.one_of(
            mutated(base).map(lambda d: json.dumps(d).encode()),
            st.binary(max_size=100),
            st.tuples(st.integers(0, len(original)), st.binary(max_size=8)).map(
                lambda t: original[: t[0]] + t[1] + original[t[0] + len(t[1]) :]
            ),
        )
    )
    def check(data: bytes) -> None:
        info_path.write_bytes(data)
        _summarize_or_refuse(dataset_copy)

    try:
        check()
    finally:
        info_path.write_bytes(original)


_ARROW_VALUES = st.one_of(
    st.lists(st.integers(-(2**63), 2**63 - 1), min_size=0, max_size=3),
    st.lists(st.floats(), min_size=0, max_size=3),
    st.lists(st.text(max_size=5), min_size=0, max_size=3),
    st.lists(st.none(), min_size=0, max_size=3),
    st.lists(st.booleans(), min_size=0, max_size=3),
)


def test_episodes_and_tasks_readers(dataset_copy: Path) -> None:
    """A fuzzed meta/episodes table (real columns with other types or missing, extra columns, flipped bytes) and
    a fuzzed tasks table."""
    ep_path = layout.episodes_files(dataset_copy)[0]
    tasks_path = dataset_copy / layout.TASKS_PATH
    originals = {p: p.read_bytes() for p in (ep_path, tasks_path)}
    episodes = pq.read_table(ep_path)

    @st.composite
    def tables(draw: st.DrawFn) -> tuple[Path, bytes]:
        target = draw(st.sampled_from([ep_path, tasks_path]))
        raw = originals[target]
        if draw(st.booleans()):  # flipped or cut bytes
            at = draw(st.integers(0, len(raw) - 1))
            cut = draw(st.booleans())
            return target, raw[:at] if cut else raw[:at] + bytes([raw[at] ^ 0xFF]) + raw[at + 1 :]
        base = episodes if target == ep_path else pq.read_table(target)
        names = draw(st.lists(st.sampled_from(base.column_names), unique=True, max_size=4))
        cols = {n: base.column(n) for n in base.column_names if n not in names}
        n_rows = base.num_rows
        for n in names:
            if draw(st.booleans()):
                vals = draw(_ARROW_VALUES)
                vals = (vals * n_rows)[:n_rows] if vals else [None] * n_rows
                try:
                    cols[n] = pa.chunked_array([pa.array(vals)])
                except (pa.ArrowException, OverflowError):
                    continue
        buf = pa.BufferOutputStream()
        pq.write_table(pa.table(cols) if cols else pa.table({"x": [1]}), buf)
        return target, buf.getvalue().to_pybytes()

    @FUZZ
    @given(case=tables())
    def check(case: tuple[Path, bytes]) -> None:
        target, data = case
        target.write_bytes(data)
        try:
            try:
                read_episodes(dataset_copy)
            except OpenralError as exc:
                assert "\n" not in str(exc)
            _summarize_or_refuse(dataset_copy)
        finally:
            target.write_bytes(originals[target])

    check()
