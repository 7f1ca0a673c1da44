"""ROS 2 bags (MCAP or sqlite3) with Autoware messages as casewatch frames.

`read_bag(path, mapping, channels, period)` reads a bag through a topic mapping
(`mapping.load_mapping`) and yields `Frame`s on the case's period; `write_bag` writes frames as
a bag. The Autoware message definitions ship in `msg/`, so no ROS installation is needed.
docs/bags.md is the user's guide.
"""

from casewatch.monitor.bags.mapping import LoadedMapping, MappingError, TopicMapping, load_mapping
from casewatch.monitor.bags.reader import BagError, BagReader, read_bag
from casewatch.monitor.bags.writer import BagWriteError, write_bag

__all__ = [
    "BagError",
    "BagReader",
    "BagWriteError",
    "LoadedMapping",
    "MappingError",
    "TopicMapping",
    "load_mapping",
    "read_bag",
    "write_bag",
]
