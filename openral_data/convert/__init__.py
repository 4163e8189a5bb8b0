"""`openral-data convert`: robot logs (ROS 1/2 bags, MCAP), HDF5, Zarr replay buffers and RLDS -> LeRobot v3,
and LeRobot v3 -> ROS 2 MCAP; `export(dataset, out, to)` (`openral-data export`) writes a LeRobot dataset as RLDS,
robomimic HDF5 or MCAP. `convert(source, dst, ...)` (`convert.entry`) is the one entry; what SRC is
decides the direction (`convert.kinds`, the source registry). The package itself is callable too:
`openral_data.convert(source, dst, ...)` is `convert.entry.convert`."""

import sys
import types
from typing import Any

from openral_data.convert.entry import convert, plan
from openral_data.convert.exporting import export
from openral_data.convert.kinds.base import Parallel
from openral_data.convert.summary import ConvertSummary
from openral_data.convert.to_lerobot import convert_bags
from openral_data.convert.to_mcap import ExportSummary, export_mcap, is_lerobot_dataset
from openral_data.convert.to_rlds import export_rlds
from openral_data.convert.to_robomimic import export_robomimic

__all__ = [
    "ConvertSummary",
    "ExportSummary",
    "Parallel",
    "convert",
    "convert_bags",
    "export",
    "export_mcap",
    "export_rlds",
    "export_robomimic",
    "is_lerobot_dataset",
    "plan",
]


class _CallablePackage(types.ModuleType):
    """`openral_data.convert` is this package once any of its modules is imported: calling it converts."""

    def __call__(self, *args: Any, **kwargs: Any) -> Any:
        return convert(*args, **kwargs)


sys.modules[__name__].__class__ = _CallablePackage
