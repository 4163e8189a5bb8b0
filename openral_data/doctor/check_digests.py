"""Files we wrote against the content digests our writer recorded (`.openral/digests.json`): any changed byte
in them is an error. A dataset without digests (written by lerobot or another tool) has nothing to compare."""

from __future__ import annotations

from openral_data.doctor.check_missing import absent
from openral_data.doctor.findings import Finding, error
from openral_data.doctor.inspect import Dataset
from openral_data.errors import DatasetError
from openral_data.formats.lerobot_v3 import digests


def check_digests(ds: Dataset) -> list[Finding]:
    try:
        stored = digests.read(ds.root)
        if stored is None:
            return []
        changed = digests.changed(ds.root, stored)
    except (DatasetError, OSError) as exc:
        return [error("file.digests", digests.DIGESTS_PATH, f"unusable: {exc}")]
    gone = set(absent(ds).files())  # not downloaded: `check_missing`
    return [
        error("file.digest", rel, f"changed since it was written: {what}") for rel, what in changed if rel not in gone
    ]
