"""Run the CLI in this process, crashing it at one exact filesystem mutation, as a SIGKILL would land there.

`python -m tests.support.cli_driver NAME NTH ARG…` runs `openral-data ARG…`, except that the NTH `os.replace`
onto a file or folder named NAME exits the process at once (`os._exit(137)`: no cleanup, as SIGKILL) instead
of happening, e.g. `dataset 1` kills a pipeline right before its merge step publishes its staged output.
"""

from __future__ import annotations

import sys

from openral_data.cli import main
from tests.support.crash import die_at_mutation

if __name__ == "__main__":
    name, nth, *argv = sys.argv[1:]
    die_at_mutation(int(nth), ops=("replace",), name=name)
    sys.argv = ["openral-data", *argv]
    main()
