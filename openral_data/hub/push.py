"""`openral-data push DATASET REPO_ID`: upload a LeRobot v3 dataset to the Hugging Face Hub with a generated card.

`plan_push` does everything that needs no network: it refuses a dataset a writer holds or whose commit was
interrupted, one `doctor` finds errors in (unless `force`), selects the files (`select_files`) and writes the
card (`dataset_card`); the plan's `operations` are exactly the `CommitOperationAdd`s the commit sends.
`upload` sends them the way lerobot's `LeRobotDataset.push_to_hub` does: create the dataset repo (``exist_ok``),
the branch if one is named, the files and README.md (one commit, or several for a large dataset:
`hub._commits`), then the codebase-version tag (``v3.0``) on that revision. An interrupted push resumes when run
again: what the Hub already holds is not sent again. Nothing is written into the dataset. The token is
huggingface_hub's own (``HF_TOKEN``, else the cached `hf auth login`); a missing token, no network or an error
answer from the Hub is one `HubError` line, not a traceback.
"""

from __future__ import annotations

import contextlib
from collections.abc import Callable
from dataclasses import dataclass
from pathlib import Path

import httpx
from huggingface_hub import CommitOperationAdd, HfApi, get_token
from huggingface_hub.errors import HfHubHTTPError, OfflineModeIsEnabled, RevisionNotFoundError

from openral_data.doctor import PARTIAL_DOWNLOAD, check
from openral_data.errors import DatasetError, HubError, NotFound, UsageError
from openral_data.formats.lerobot_v3 import layout
from openral_data.formats.lerobot_v3.lock import check_settled
from openral_data.formats.repo_id import looks_like_repo_id
from openral_data.hub._card import CardOptions, dataset_card
from openral_data.hub._commits import COMMIT_BYTES, COMMIT_FILES, commit_batches
from openral_data.hub._files import select_files
from openral_data.hub.download import one_line

CARD_PATH = "README.md"


@dataclass(frozen=True)
class PushOptions:
    repo_id: str
    private: bool | None = None  # None: the Hub's (or the organisation's) default
    revision: str | None = None  # a branch, created from main when missing; None: main
    include_mcap: bool = False
    include_state: bool = False
    force: bool = False  # push even when doctor finds errors
    license: str = "apache-2.0"
    citation: str | None = None
    tags: tuple[str, ...] = ()  # more card tags, after LeRobot and openral-data
    commit_files: int = COMMIT_FILES  # a push of more files (or bytes) is several commits
    commit_bytes: int = COMMIT_BYTES


@dataclass(frozen=True)
class PushPlan:
    root: Path
    opts: PushOptions
    files: list[str]  # dataset-relative paths, sorted; README.md is the card, not one of them
    card: str

    @property
    def operations(self) -> list[CommitOperationAdd]:
        """The commit's operations: every selected file from disk, then README.md (the card)."""
        ops = [CommitOperationAdd(path_in_repo=rel, path_or_fileobj=str(self.root / rel)) for rel in self.files]
        return [*ops, CommitOperationAdd(path_in_repo=CARD_PATH, path_or_fileobj=self.card.encode())]

    def text(self) -> str:
        """What `push --dry-run` prints: the target, the files (with sizes) and the card."""
        size = sum((self.root / rel).stat().st_size for rel in self.files)
        where = f"{self.opts.repo_id}" + (f" (branch {self.opts.revision})" if self.opts.revision else "")
        lines = [
            f"would push {self.root} to the dataset repo {where}: {len(self.files)} files ({size} bytes) + the card"
        ]
        lines += [f"  {rel}" for rel in self.files]
        lines += [f"  {CARD_PATH} (generated, below)", "", self.card.rstrip("\n")]
        return "\n".join(lines)


@dataclass(frozen=True)
class PushResult:
    url: str  # the (last) commit's URL on the Hub
    files: int
    tag: str
    commits: int = 1


def plan_push(root: Path, opts: PushOptions) -> PushPlan:
    """Check `root` and prepare its push, without touching the network."""
    if not looks_like_repo_id(opts.repo_id):
        raise UsageError(f"REPO_ID: {opts.repo_id!r} is not a Hub repo id (owner/name)")
    if not root.is_dir():
        raise NotFound(f"{root}: no such dataset folder")
    check_settled(root, "push")
    # a partial download's absent files are warnings to doctor, but pushing it would publish an incomplete dataset
    errors = [f for f in check(root) if f.severity == "error" or f.code in PARTIAL_DOWNLOAD]
    if errors and not opts.force:
        raise DatasetError(
            f"{root}: doctor finds {len(errors)} problem(s) (first: {errors[0].line()}); see `openral-data doctor "
            f"{root}`, or push anyway with --force",
            code="dataset.invalid",
        )
    files = select_files(root, include_mcap=opts.include_mcap, include_state=opts.include_state)
    card = dataset_card(root, CardOptions(opts.repo_id, opts.license, opts.citation, opts.tags))
    return PushPlan(root, opts, files, card)


def upload(plan: PushPlan, progress: Callable[[int], None] | None = None) -> PushResult:
    """Send `plan` to the Hub (see the module docstring), calling `progress(files)` after each commit; every Hub
    or network failure is one `HubError`."""
    if get_token() is None:
        raise HubError(
            "no Hugging Face token: set HF_TOKEN or run `hf auth login` (a token with write access)", code="hub.auth"
        )
    opts = plan.opts
    api = HfApi()
    repo = opts.repo_id
    batches = commit_batches(plan.operations, opts.commit_files, opts.commit_bytes)
    landed = 0
    try:
        api.create_repo(repo, repo_type="dataset", private=opts.private, exist_ok=True)
        if opts.revision:
            api.create_branch(repo, branch=opts.revision, repo_type="dataset", exist_ok=True)
        for batch in batches:
            part = f" ({landed + 1}/{len(batches)})" if len(batches) > 1 else ""
            info = api.create_commit(
                repo,
                batch,
                commit_message=f"Upload {plan.root.name} with openral-data{part}",
                repo_type="dataset",
                revision=opts.revision,
            )
            landed += 1
            if progress is not None:
                progress(len(batch))
        with contextlib.suppress(RevisionNotFoundError):
            api.delete_tag(repo, tag=layout.CODEBASE_VERSION, repo_type="dataset")
        api.create_tag(repo, tag=layout.CODEBASE_VERSION, revision=opts.revision, repo_type="dataset")
    except (OfflineModeIsEnabled, HfHubHTTPError, httpx.HTTPError, ConnectionError, TimeoutError, ValueError) as exc:
        raise _push_error(repo, exc, landed, len(batches)) from None
    url = str(getattr(info, "commit_url", ""))
    return PushResult(url=url, files=len(plan.files) + 1, tag=layout.CODEBASE_VERSION, commits=len(batches))


def _push_error(repo: str, exc: Exception, landed: int, commits: int) -> HubError:
    """The one line for a failed push; after some of several commits landed, how to resume it."""
    resume = f" ({landed} of {commits} commits landed; run the same push again to send the rest)" if landed else ""
    if isinstance(exc, OfflineModeIsEnabled):
        return HubError(f"{repo}: HF_HUB_OFFLINE is set; unset it to push", code="hub.network")
    if isinstance(exc, HfHubHTTPError):
        message = f"{repo}: the Hub refused the push: {one_line(exc)}{resume}"
        status = exc.response.status_code if exc.response is not None else 0
        if status in (401, 403):
            return HubError(message, code="hub.auth")
        return HubError(message, code="hub.refused")
    if isinstance(exc, ValueError):  # huggingface_hub's own refusals: the card's metadata (validated by the Hub)
        return HubError(f"{repo}: the Hub refused the push: {one_line(exc)}{resume}", code="hub.refused")
    return HubError(f"{repo}: cannot reach the Hub: {one_line(exc)}{resume}", code="hub.network")
