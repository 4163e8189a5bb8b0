"""The Hugging Face Hub both ways: `openral-data push DATASET REPO_ID`, and `--download` (docs/hub.md).

`plan_push(root, PushOptions(...))` checks a dataset and prepares its push offline (the files, the card, the
commit's operations); `upload(plan)` sends it. `select_files` and `dataset_card` are the two halves of a plan.
`fetch_dataset(repo_id, DownloadOptions(...))` fetches a dataset repo into lerobot's cache (`--download`).
"""

from openral_data.hub._card import CardOptions, dataset_card
from openral_data.hub._files import select_files
from openral_data.hub.download import DownloadOptions, codebase_revision, fetch_dataset
from openral_data.hub.push import PushOptions, PushPlan, PushResult, plan_push, upload

__all__ = [
    "CardOptions",
    "DownloadOptions",
    "PushOptions",
    "PushPlan",
    "PushResult",
    "codebase_revision",
    "dataset_card",
    "fetch_dataset",
    "plan_push",
    "select_files",
    "upload",
]
