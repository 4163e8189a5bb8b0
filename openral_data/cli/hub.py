"""`openral-data push`: a thin typer wrapper over `openral_data.hub` (docs/hub.md)."""

from __future__ import annotations

from pathlib import Path
from typing import Annotated

import typer

from openral_data.cli.takes import takes
from openral_data.cli.terminal import print_done, print_line, progress_bar
from openral_data.errors import NotFound
from openral_data.formats.repo_id import resolve_dataset


@takes("dataset", pixels=True, v2="refused", writes="new", download=False)  # --revision: its branch
def push(
    dataset: Annotated[Path, typer.Argument(help="a LeRobot v3 dataset (ours or lerobot's), or a cached repo id")],
    repo_id: Annotated[str, typer.Argument(help="the Hub dataset repo to push to, owner/name")],
    private: Annotated[
        bool | None, typer.Option("--private/--public", help="visibility of a new repo (default: the Hub's)")
    ] = None,
    revision: Annotated[str | None, typer.Option(help="push to this branch (created when missing)")] = None,
    include_mcap: Annotated[bool, typer.Option("--include-mcap", help="also upload the MCAP bags (mcap/)")] = False,
    include_state: Annotated[
        bool, typer.Option("--include-state", help="also upload openral-data's bookkeeping (.openral/)")
    ] = False,
    license: Annotated[str, typer.Option(help="the card's license (a Hub license id)")] = "apache-2.0",
    citation: Annotated[Path | None, typer.Option(help="a BibTeX file for the card's citation")] = None,
    tags: Annotated[
        list[str] | None, typer.Option("--tags", help="a tag for the card, after LeRobot (repeatable)", metavar="TAG")
    ] = None,
    force: Annotated[bool, typer.Option("--force", help="push even when `doctor` finds errors")] = False,
    dry_run: Annotated[
        bool, typer.Option("--dry-run", help="print the files and the card; no network, nothing uploaded")
    ] = False,
) -> None:
    """Upload a dataset to the Hugging Face Hub with a generated dataset card (README.md)."""
    from openral_data.hub import PushOptions, plan_push, upload

    if citation is not None and not citation.is_file():
        raise NotFound(f"--citation: {citation}: no such file")
    bibtex = citation.read_text(errors="replace").strip() if citation is not None else None
    opts = PushOptions(
        repo_id, private, revision, include_mcap, include_state, force, license, bibtex, tuple(tags or ())
    )
    plan = plan_push(resolve_dataset(dataset), opts)
    if dry_run:
        print_line(plan.text())
        return
    with progress_bar("pushing", "files") as bar:
        task = bar.add_task("push", total=len(plan.files) + 1)
        result = upload(plan, lambda files: bar.advance(task, files))
    commits = f" in {result.commits} commits" if result.commits > 1 else ""
    print_done(f"pushed {len(plan.files)} files + the card to {repo_id}{commits} (tag {result.tag}): {result.url}")
