"""Publishing to the Hugging Face Hub: `openral-data push DATASET REPO_ID` (docs/hub.md).

`plan_push(root, PushOptions(...))` checks a dataset and prepares its push offline (the files, the card, the
commit's operations); `upload(plan)` sends it. `select_files` and `dataset_card` are the two halves of a plan.
"""

from openral_data.hub._card import CardOptions, dataset_card
from openral_data.hub._files import select_files
from openral_data.hub.push import PushOptions, PushPlan, PushResult, plan_push, upload

__all__ = [
    "CardOptions",
    "PushOptions",
    "PushPlan",
    "PushResult",
    "dataset_card",
    "plan_push",
    "select_files",
    "upload",
]
