"""How a push splits its files into commits (docs/hub.md#large-datasets-several-commits).

The Hub limits what one commit may carry (its size, the files in it); huggingface_hub's own multi-commit upload
starts at 256 files a commit. A push of at most `COMMIT_FILES` files and `COMMIT_BYTES` bytes is one commit; a
larger one is several, each within both limits, in a fixed order: `data/`, `videos/` (and `mcap/`, `.openral/`)
first, `meta/` and the card last, so the repo holds a dataset lerobot can load only once the last commit lands.
The same dataset always gives the same commits, which is what lets a rerun resume an interrupted push: the Hub
reports each file it already holds (preupload's oid) and huggingface_hub leaves an unchanged file out of its
commit, and a commit with nothing left out of the push.
"""

from __future__ import annotations

from huggingface_hub import CommitOperationAdd

COMMIT_FILES = 256  # files a commit, at most (huggingface_hub's multi-commit upload starts here)
COMMIT_BYTES = 1 << 30  # bytes of file content a commit, at most (1 GiB; a single larger file is one commit)
LAST = ("meta/", "README.md")  # what goes in the last commits: lerobot's metadata, then the card


def commit_batches(ops: list[CommitOperationAdd], max_files: int, max_bytes: int) -> list[list[CommitOperationAdd]]:
    """`ops` in commits of at most `max_files` files and `max_bytes` bytes, `LAST`'s paths at the end."""
    ordered = sorted(ops, key=lambda op: op.path_in_repo.startswith(LAST))  # stable: the plan's order otherwise
    batches: list[list[CommitOperationAdd]] = []
    current: list[CommitOperationAdd] = []
    size = 0
    for op in ordered:
        if current and (len(current) >= max_files or size + op.upload_info.size > max_bytes):
            batches.append(current)
            current, size = [], 0
        current.append(op)
        size += op.upload_info.size
    return [*batches, current] if current else batches
