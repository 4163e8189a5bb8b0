"""`--json`: one JSON document on stdout (progress and logs stay on stderr)."""

from __future__ import annotations

import json
import sys
from collections.abc import Mapping

from openral_data.version import __version__


def print_json(doc: Mapping[str, object]) -> None:
    """`doc` with the package `version` after its `command`, indented, UTF-8, as the only thing on stdout."""
    out = {"command": doc.get("command"), "version": __version__, **{k: v for k, v in doc.items() if k != "command"}}
    sys.stdout.write(json.dumps(out, indent=2, ensure_ascii=False) + "\n")
