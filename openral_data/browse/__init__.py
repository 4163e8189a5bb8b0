"""`openral-data browse`: a local, read-only web server over datasets (docs/browse.md).

Pages: the episodes table (paged, sorted, filtered by the `--where` of `episodes filter`, through
`metrics.where`), an episode page (every camera's mp4 served with HTTP range requests and sought to the episode's
span, depth cameras as the decoded frame at the cursor; state/action plots and replay/eval error plots with a
cursor on the video time; the task), a side-by-side compare of two datasets, and a selection panel that prints
the `episodes delete/split/filter` command to run. Results folders given add their per-episode columns. The
server never writes, runs nothing, and serves only the files of the datasets and results given
(docs/threat-model.md). Needs the `browse` extra (Starlette + uvicorn).
"""

from openral_data.browse._app import create_app
from openral_data.browse._catalog import Catalog
from openral_data.browse._serve import Browser, open_catalogs

__all__ = ["Browser", "Catalog", "create_app", "open_catalogs"]
