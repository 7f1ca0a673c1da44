"""Small builders of Foxglove's published protobuf messages (foxglove-schemas-protobuf).

Times are nanoseconds since the Unix epoch, as MCAP stores them; positions are metres in the
stream's world frame, which every casewatch entity names `map`.
"""

from __future__ import annotations

import math

from foxglove_schemas_protobuf.Color_pb2 import Color
from foxglove_schemas_protobuf.KeyValuePair_pb2 import KeyValuePair
from foxglove_schemas_protobuf.Point3_pb2 import Point3
from foxglove_schemas_protobuf.Pose_pb2 import Pose
from foxglove_schemas_protobuf.Quaternion_pb2 import Quaternion
from foxglove_schemas_protobuf.Vector3_pb2 import Vector3
from google.protobuf.duration_pb2 import Duration
from google.protobuf.timestamp_pb2 import Timestamp

#: The frame every casewatch entity is placed in: the stream's world frame.
WORLD_FRAME = "map"


def timestamp(ns: int) -> Timestamp:
    return Timestamp(seconds=ns // 1_000_000_000, nanos=ns % 1_000_000_000)


def duration(seconds: float) -> Duration:
    ns = max(0, round(seconds * 1e9))
    return Duration(seconds=ns // 1_000_000_000, nanos=ns % 1_000_000_000)


def color(hex_rgb: str, alpha: float = 1.0) -> Color:
    """`#rrggbb` as a Foxglove colour (components 0-1)."""
    value = hex_rgb.lstrip("#")
    r, g, b = (int(value[i : i + 2], 16) / 255.0 for i in (0, 2, 4))
    return Color(r=r, g=g, b=b, a=alpha)


def pose(x: float, y: float, z: float = 0.0, yaw: float = 0.0) -> Pose:
    """A pose at (x, y, z) turned by `yaw` about the vertical axis."""
    return Pose(
        position=Vector3(x=x, y=y, z=z),
        orientation=Quaternion(x=0.0, y=0.0, z=math.sin(yaw / 2), w=math.cos(yaw / 2)),
    )


def size(x: float, y: float, z: float) -> Vector3:
    return Vector3(x=x, y=y, z=z)


def points(xy, z: float = 0.0) -> list[Point3]:
    """Point3s from an (N, 2) sequence of x, y."""
    return [Point3(x=float(p[0]), y=float(p[1]), z=z) for p in xy]


def metadata(**items: object) -> list[KeyValuePair]:
    return [KeyValuePair(key=k, value=str(v)) for k, v in items.items()]
