"""`openral-data tasks list|rename|set`: thin typer wrappers over `edit.tasks`."""

from __future__ import annotations

from pathlib import Path
from typing import Annotated

import typer

from openral_data import paths
from openral_data.cli.edit import report
from openral_data.cli.jsonout import JsonFlag, print_json
from openral_data.cli.takes import takes
from openral_data.cli.terminal import print_line
from openral_data.episodes import format_episodes
from openral_data.formats.repo_id import resolve_dataset
from openral_data.text import printable

tasks_app = typer.Typer(
    no_args_is_help=True,
    help="List the tasks of a LeRobot v3 dataset, rename one, or set the task of chosen episodes.",
)
Dataset = Annotated[Path, typer.Argument(help="a LeRobot v3 dataset (ours or lerobot's)")]
Out = Annotated[Path | None, typer.Option(help="new dataset folder (must not exist or be empty)")]
InPlace = Annotated[bool, typer.Option(help="replace DATASET itself (swapped in once complete)")]


@tasks_app.command("list")
@takes("dataset", pixels=False, v2="in place")
def list_cmd(dataset: Dataset, json: JsonFlag = False) -> None:
    """The tasks of DATASET: index, the episodes using it, text."""
    from openral_data.edit.tasks import list_tasks

    root = resolve_dataset(dataset)
    uses = list_tasks(root)
    if json:
        items = [{"task_index": u.index, "task": u.task, "episodes": u.episodes} for u in uses]
        print_json("tasks list", {"dataset": str(dataset), "tasks": items})
        return
    for u in uses:
        print_line(f"{u.index:>4}  episodes {format_episodes(u.episodes) or '-':<12}  {printable(u.task)}")


@tasks_app.command("rename")
@takes("dataset", pixels=True, v2="upgrade", writes="new or in place")
def rename_cmd(
    dataset: Dataset,
    from_: Annotated[str, typer.Option("--from", help="the task's current text")],
    to: Annotated[str, typer.Option(help="its new text (an existing task's text merges the two)")],
    out: Out = None,
    in_place: InPlace = False,
) -> None:
    """Write DATASET with task --from called --to."""
    from openral_data.edit.tasks import rename

    if out is not None:
        paths.check_creatable(out, "--out")
    report("renamed", [rename(resolve_dataset(dataset), from_, to, out, in_place)])


@tasks_app.command("set")
@takes("dataset", pixels=True, v2="upgrade", writes="new or in place", episodes={"episodes": "list"})
def set_cmd(
    dataset: Dataset,
    episodes: Annotated[str, typer.Option(help="episodes whose task to set, e.g. 0,2-4")],
    task: Annotated[str, typer.Option(help="the task text of every frame of those episodes")],
    out: Out = None,
    in_place: InPlace = False,
) -> None:
    """Write DATASET with every frame of the listed episodes doing --task."""
    from openral_data.edit.tasks import set_task

    if out is not None:
        paths.check_creatable(out, "--out")
    report("set", [set_task(resolve_dataset(dataset), episodes, task, out, in_place)])
