"""`openral-data browse`: a local, read-only web server over datasets (docs/browse.md).

Pages: the episodes table (paged, sorted, filtered by the `--where` of `episodes filter`, through
`metrics.where`), an episode page (every camera's mp4 served with HTTP range requests and sought to the episode's
span; state/action plots with a cursor on the video time; the task), and a selection panel that prints the
`episodes delete/split/filter` command to run. The server never writes, runs nothing, and serves only the files of
the datasets given (docs/threat-model.md). Needs the `browse` extra (Starlette + uvicorn).
"""

from openral_data.browse._app import create_app
from openral_data.browse._catalog import Catalog
from openral_data.browse._serve import Browser, open_catalogs

__all__ = ["Browser", "Catalog", "create_app", "open_catalogs"]
