"""`--download`: fetch a Hub dataset repo into lerobot's cache folder, `HF_LEROBOT_HOME/owner/name` (docs/hub.md).

`fetch_dataset(repo_id, DownloadOptions(...))` runs huggingface_hub's `snapshot_download` for the files a command
needs (`patterns`): `meta/` and `data/`, `videos/` only for a command that reads pixels, or `meta/` and the
`--include` patterns. The folder is the one `LeRobotDataset(repo_id)` looks in first, so lerobot finds it as a
local dataset too.

The revision is `--revision` (a branch, tag or commit), else lerobot's codebase-version convention
(`codebase_revision`, what lerobot 0.6.1's `get_safe_version` picks); it is resolved to one commit before a byte
is fetched, so every file of one download comes from that commit.

Never looking complete: the files arrive in a hidden staging folder beside the target,
`HF_LEROBOT_HOME/owner/.name.download/`, where huggingface_hub keeps its per-file state
(`.cache/huggingface/`); a killed download, rerun, skips every file it had finished and fetches the rest. Only
once every file has arrived is that state removed and the folder renamed to `owner/name` (one rename), or, when
`owner/name` exists already (an earlier download without videos), each new file renamed into it. A downloaded
dataset is untrusted input like any other (docs/threat-model.md): nothing in it is run, and the commands read it
under the same rules.
"""

from __future__ import annotations

import contextlib
import os
import shutil
from collections.abc import Iterator
from dataclasses import dataclass
from pathlib import Path

import httpx
from huggingface_hub import HfApi, constants, snapshot_download
from huggingface_hub.errors import (
    GatedRepoError,
    HfHubHTTPError,
    LocalEntryNotFoundError,
    OfflineModeIsEnabled,
    RepositoryNotFoundError,
    RevisionNotFoundError,
)
from huggingface_hub.utils.tqdm import disable_progress_bars
from packaging.version import InvalidVersion, Version

from openral_data.errors import HubError, UsageError
from openral_data.formats.lerobot_v3 import layout
from openral_data.formats.repo_id import lerobot_home, looks_like_repo_id

META, DATA, VIDEOS = "meta/", "data/", "videos/"


@dataclass(frozen=True)
class DownloadOptions:
    revision: str | None = None  # a branch, tag or commit; None: the codebase-version tag (`codebase_revision`)
    include: tuple[str, ...] = ()  # fnmatch patterns (huggingface_hub's); () : meta/, data/ (+ videos/)
    videos: bool = True  # the command reads pixels: fetch videos/ too
    progress: bool = False  # huggingface_hub's progress bars on stderr


def patterns(opts: DownloadOptions, target: Path) -> list[str]:
    """The `allow_patterns` still to fetch into `target`: `meta/` always, then `--include`'s patterns, or else
    `data/` (and `videos/` for a command reading pixels); a folder the target already holds is not fetched again."""
    wanted = [META, *opts.include] if opts.include else [META, DATA, *((VIDEOS,) if opts.videos else ())]
    if opts.include:
        return wanted if not (target / layout.INFO_PATH).is_file() else wanted[1:]
    return [p for p in wanted if not (target / (layout.INFO_PATH if p == META else p)).exists()]


def fetch_dataset(repo_id: str, opts: DownloadOptions) -> Path:
    """`HF_LEROBOT_HOME/repo_id`, with what `opts` asks fetched from the Hub when it is not there yet."""
    if not looks_like_repo_id(repo_id):
        raise UsageError(f"{repo_id!r} is not a Hub repo id (owner/name)")
    target = lerobot_home() / repo_id
    wanted = patterns(opts, target)
    if not wanted:
        return target
    if constants.HF_HUB_OFFLINE:
        raise HubError(
            f"{repo_id}: not in the local cache and HF_HUB_OFFLINE is set; unset it to download", code="hub.network"
        )
    staging = target.parent / f".{target.name}.download"
    with _hub_errors(repo_id, opts.revision), contextlib.nullcontext() if opts.progress else disable_progress_bars():
        api = HfApi()
        revision = opts.revision or codebase_revision(api, repo_id)
        commit = api.repo_info(repo_id, repo_type="dataset", revision=revision).sha
        snapshot_download(
            repo_id,
            repo_type="dataset",
            revision=commit,
            local_dir=staging,
            cache_dir=lerobot_home() / "hub",  # lerobot's own snapshot cache: a file already there is copied
            allow_patterns=wanted,
        )
    _publish(staging, target)
    return target


def codebase_revision(api: HfApi, repo_id: str) -> str:
    """The revision lerobot 0.6.1 loads by default (`get_safe_version(repo_id, "v3.0")`): the `v3.0` branch or
    tag, else the newest `v3.x` below it; where lerobot refuses, the newest older version (`v2.1`, a layout we
    read), and a repo without any version ref is read at `main`. Only newer versions is one line."""
    refs = api.list_repo_refs(repo_id, repo_type="dataset")
    versions: list[Version] = []
    for ref in [*refs.branches, *refs.tags]:
        with contextlib.suppress(InvalidVersion):
            versions.append(Version(ref.name))
    target = Version(layout.CODEBASE_VERSION)
    same = [v for v in versions if v.major == target.major and v <= target]
    older = [v for v in versions if v.major < target.major]
    if same or older:
        return f"v{max(same or older)}"
    if versions:
        raise HubError(
            f"{repo_id}: has only newer codebase versions ({', '.join(f'v{v}' for v in sorted(versions))}) than "
            f"this version reads ({layout.CODEBASE_VERSION}); pass --revision to choose one",
            code="hub.refused",
        )
    return "main"


def _publish(staging: Path, target: Path) -> None:
    """Move a finished download into place: the whole folder in one rename when `target` is new, else file by
    file (each an atomic rename), huggingface_hub's state dropped first."""
    shutil.rmtree(staging / ".cache", ignore_errors=True)
    if not target.exists():
        staging.rename(target)
        return
    for path in sorted(staging.rglob("*")):
        if path.is_file() and not path.is_symlink():
            dest = target / path.relative_to(staging)
            dest.parent.mkdir(parents=True, exist_ok=True)
            os.replace(path, dest)
    shutil.rmtree(staging)


@contextlib.contextmanager
def _hub_errors(repo_id: str, revision: str | None) -> Iterator[None]:
    """Every Hub or network failure of a download as one `HubError` line saying what to do."""
    try:
        yield
    except (HfHubHTTPError, LocalEntryNotFoundError, httpx.HTTPError, ConnectionError, TimeoutError, ValueError) as exc:
        raise _hub_error(repo_id, revision, exc) from None


def _hub_error(repo_id: str, revision: str | None, exc: BaseException) -> HubError:
    """The one line for `exc`; huggingface_hub wraps a failed file lookup in `LocalEntryNotFoundError`, whose
    cause says what happened."""
    if isinstance(exc, LocalEntryNotFoundError) and exc.__cause__ is not None:
        exc = exc.__cause__
    if isinstance(exc, GatedRepoError):
        return HubError(
            f"{repo_id}: a gated dataset; accept its conditions at https://huggingface.co/datasets/{repo_id} and "
            "use that account's token (HF_TOKEN or `hf auth login`)",
            code="hub.auth",
        )
    if isinstance(exc, RevisionNotFoundError):
        return HubError(f"{repo_id}: no revision {revision!r} on the Hub", code="hub.missing")
    if isinstance(exc, RepositoryNotFoundError):
        return HubError(
            f"{repo_id}: no such dataset repo on the Hub, or it is private and your token cannot read it "
            "(set HF_TOKEN or run `hf auth login`)",
            code="hub.missing",
        )
    if isinstance(exc, ValueError) and not isinstance(exc, HfHubHTTPError):  # e.g. a repo path leaving the folder
        return HubError(f"{repo_id}: the Hub's answer is refused: {one_line(exc)}", code="hub.refused")
    if isinstance(exc, OfflineModeIsEnabled):
        return HubError(f"{repo_id}: HF_HUB_OFFLINE is set; unset it to download", code="hub.network")
    if isinstance(exc, HfHubHTTPError):
        message = f"{repo_id}: the Hub refused the download: {one_line(exc)}"
        if exc.response is not None and exc.response.status_code in (401, 403):
            return HubError(f"{message}; use a token that can read it (HF_TOKEN or `hf auth login`)", code="hub.auth")
        return HubError(message, code="hub.refused")
    return HubError(
        f"{repo_id}: cannot reach the Hub: {one_line(exc)}; rerun to resume the download", code="hub.network"
    )


def one_line(exc: BaseException) -> str:
    """The client's message on one line (it may list the Hub's reasons on several)."""
    return " ".join(str(exc).split()) or type(exc).__name__
