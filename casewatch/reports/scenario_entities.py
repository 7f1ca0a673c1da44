"""What kind of OpenSCENARIO entity a tracked object becomes, from its class and its size.

A replay should show a 12 m truck as a truck and a pedestrian as a pedestrian: players pick
models, dynamics limits and sensor signatures by category. The object's class decides when it
names a kind (`truck`, `bus`, `van`, `motorcycle`, `bicycle`, `pedestrian` and their usual
synonyms); a generic class (`car`, `vehicle`) is refined by length only (a 12 m "car" is a
truck); an `unknown` (or unrecognised) class is decided by size alone. The thresholds are
documented in docs/scenarios.md ("Entities").
"""

from __future__ import annotations

from dataclasses import dataclass

#: Entity kinds written: OpenSCENARIO 1.2 `VehicleCategory` values, and `pedestrian` (a
#: `Pedestrian` entity of `pedestrianCategory="pedestrian"`).
KINDS = ("car", "van", "truck", "bus", "motorbike", "bicycle", "pedestrian")

#: Class names (lower case) that name a kind outright.
CLASS_KINDS: dict[str, str] = {
    "truck": "truck",
    "lorry": "truck",
    "trailer": "truck",
    "bus": "bus",
    "van": "van",
    "motorcycle": "motorbike",
    "motorbike": "motorbike",
    "motorcyclist": "motorbike",
    "bicycle": "bicycle",
    "bike": "bicycle",
    "cyclist": "bicycle",
    "pedestrian": "pedestrian",
    "person": "pedestrian",
    "walker": "pedestrian",
}

#: Generic vehicle classes: a vehicle whose category follows its length.
GENERIC_VEHICLE = frozenset({"car", "vehicle"})

#: Longest side [m] up to which an unknown object is a pedestrian.
PEDESTRIAN_MAX = 1.5
#: Width [m] up to which an unknown object longer than a pedestrian is a two-wheeler.
TWO_WHEELER_MAX_WIDTH = 1.2
#: Length [m] up to which such a two-wheeler is a bicycle (longer: a motorbike, up to 3 m).
BICYCLE_MAX_LENGTH = 2.0
TWO_WHEELER_MAX_LENGTH = 3.0
#: Lengths [m] from which a vehicle is a van, and a truck.
VAN_MIN_LENGTH = 5.5
TRUCK_MIN_LENGTH = 8.0

#: Mass [kg] written for each kind (OpenSCENARIO requires one for pedestrians; players use it
#: for dynamics): typical values, not measured ones.
MASS: dict[str, float] = {
    "car": 1500.0,
    "van": 2500.0,
    "truck": 15000.0,
    "bus": 12000.0,
    "motorbike": 250.0,
    "bicycle": 90.0,
    "pedestrian": 75.0,
}


@dataclass(frozen=True)
class EntityKind:
    """An entity's kind and why: `from_class` is True when the class named it outright."""

    kind: str
    from_class: bool


def _by_length(length: float) -> str:
    if length >= TRUCK_MIN_LENGTH:
        return "truck"
    if length >= VAN_MIN_LENGTH:
        return "van"
    return "car"


def entity_kind(cls: str, length: float, width: float) -> EntityKind:
    """The kind of an object of class `cls` with a footprint `length` x `width` metres (the
    extents of its footprint along and across its heading)."""
    name = cls.strip().lower()
    if name in CLASS_KINDS:
        return EntityKind(CLASS_KINDS[name], True)
    if name in GENERIC_VEHICLE:
        return EntityKind(_by_length(length), False)
    if max(length, width) <= PEDESTRIAN_MAX:
        return EntityKind("pedestrian", False)
    if width <= TWO_WHEELER_MAX_WIDTH and length <= TWO_WHEELER_MAX_LENGTH:
        kind = "bicycle" if length <= BICYCLE_MAX_LENGTH else "motorbike"
        return EntityKind(kind, False)
    return EntityKind(_by_length(length), False)
