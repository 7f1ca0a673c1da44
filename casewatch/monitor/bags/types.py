"""The message types casewatch reads from a bag, and the typestore that decodes them.

The Autoware definitions ship as `.msg` text under `msg/` (`autoware_msgs` 1.x field layout),
so no ROS installation is needed: they are registered on top of rosbags' ROS 2 Humble store
(std_msgs, geometry_msgs, nav_msgs, unique_identifier_msgs). A bag that carries its own
definitions (MCAP always does, rosbag2 sqlite3 from Iron on) is decoded with those instead,
because they describe exactly the bytes that were written.
"""

from __future__ import annotations

from functools import cache
from pathlib import Path

from rosbags.typesys import Stores, get_types_from_msg, get_typestore
from rosbags.typesys.store import Typestore

MSG_DIR = Path(__file__).parent / "msg"

ODOMETRY = "nav_msgs/msg/Odometry"
OBJECTS = "autoware_perception_msgs/msg/PredictedObjects"
TRAJECTORY = "autoware_planning_msgs/msg/Trajectory"

#: The role of a topic in the mapping -> the message type it must carry.
ROLE_TYPES: dict[str, str] = {"odometry": ODOMETRY, "objects": OBJECTS, "plan": TRAJECTORY}

#: Scalar message types a `signals:` topic may carry (their `data` field is the value).
SCALAR_TYPES: frozenset[str] = frozenset(
    f"std_msgs/msg/{name}"
    for name in (
        "Float64",
        "Float32",
        "Int8",
        "Int16",
        "Int32",
        "Int64",
        "UInt8",
        "UInt16",
        "UInt32",
        "UInt64",
        "Bool",
    )
)


def shipped_definitions() -> dict[str, str]:
    """Message type name -> `.msg` text of every definition shipped with casewatch."""
    return {
        f"{path.parent.name}/msg/{path.stem}": path.read_text(encoding="utf-8")
        for path in sorted(MSG_DIR.glob("*/*.msg"))
    }


@cache
def base_typestore() -> Typestore:
    """ROS 2 Humble's standard types plus the shipped Autoware definitions (built once)."""
    store = get_typestore(Stores.ROS2_HUMBLE)
    types: dict = {}
    for name, text in shipped_definitions().items():
        types.update(get_types_from_msg(text, name))
    store.register(types)
    return store


def field_layout(store: Typestore, msgtype: str) -> tuple:
    """The wire layout of a type and every type it contains, as a comparable value: two
    definitions with the same layout serialise to the same bytes (names and constants aside,
    which do not change the bytes; field names are kept because the generic decoder reads by
    name)."""
    seen: dict[str, tuple] = {}

    def walk(name: str) -> None:
        if name in seen:
            return
        _consts, fields = store.fielddefs[name]
        seen[name] = tuple((fname, _wire(ftype)) for fname, ftype in fields)
        for _fname, ftype in fields:
            for inner in _names(ftype):
                walk(inner)

    walk(msgtype)
    return tuple(sorted(seen.items()))


def _wire(ftype: tuple) -> str:
    """A field type as it goes on the wire: a bounded sequence (`T[<=10]`) is written exactly
    like an unbounded one, so the bound is dropped."""
    kind, detail = ftype
    if kind.name == "SEQUENCE":
        return f"sequence<{_wire(detail[0])}>"
    if kind.name == "ARRAY":
        return f"array<{_wire(detail[0])}, {detail[1]}>"
    if kind.name == "BASE":
        return str(detail[0])
    return str(detail)


def _names(ftype: tuple) -> list[str]:
    """Message type names referenced by one rosbags field type description."""
    kind, detail = ftype
    if kind.name == "NAME":
        return [detail]
    if kind.name in ("ARRAY", "SEQUENCE"):
        return _names(detail[0])
    return []
