"""The observation side: channel frames, stream readers and the built-in SPI metrics.

`read_stream` turns a JSON Lines stream into `Frame`s (defects recorded, dropouts counted);
`MetricEngine.step` turns each frame into every built-in signal of `docs/spi-reference.md`.
"""

from casewatch.monitor.engine import MetricEngine
from casewatch.monitor.frames import ChannelState, Ego, Frame, Header, Objects
from casewatch.monitor.reader import StreamDefect, StreamError, StreamReader, read_stream

__all__ = [
    "ChannelState",
    "Ego",
    "Frame",
    "Header",
    "MetricEngine",
    "Objects",
    "StreamDefect",
    "StreamError",
    "StreamReader",
    "read_stream",
]
