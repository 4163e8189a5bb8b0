"""The malformed-input corpus: each case builds one bad input in a fresh workspace and names the command line
that must refuse it with exit 2 and one `error:` line naming the file or option (and the field).

A case is (id, build, names, new): `build(w)` makes the bad input under `w.root` and returns the arguments;
`names` is a regex the error line must match; `new` are outputs (relative to `w.root`) that must not exist
afterwards. Everything else under `w.root` must be byte-identical before and after.

The cases are grouped by the kind of damage: `yaml_files`, `datasets` (datasets, replay results, repair targets),
`options`, `outputs`, `bags`, `foreign_mcap` (MCAP of other profiles), `hdf5`, `array_sources` (Zarr, RLDS),
`offline` (D4RL, Minari, ManiSkill), `checkpoints`; each adds its cases to `CASES` (`cases.case`) when imported.
"""

from tests.malformed.corpus import (
    array_sources,
    bags,
    checkpoints,
    datasets,
    foreign_mcap,
    hdf5,
    offline,
    options,
    outputs,
    yaml_files,
)
from tests.malformed.corpus.cases import CASES, Case

PARTS = (yaml_files, datasets, options, outputs, bags, foreign_mcap, hdf5, array_sources, checkpoints, offline)

__all__ = ["CASES", "PARTS", "Case"]
