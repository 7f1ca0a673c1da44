"""Entity kinds from an object's class and size: a named class decides, a generic vehicle class
is refined by length, an unknown object is judged by size alone (docs/scenarios.md)."""

from __future__ import annotations

import pytest

from casewatch.reports.scenario_entities import KINDS, MASS, EntityKind, entity_kind


@pytest.mark.parametrize(
    ("cls", "length", "width", "kind", "from_class"),
    [
        ("truck", 4.0, 1.8, "truck", True),  # the class wins over the size
        ("Bus", 12.0, 2.5, "bus", True),
        ("van", 5.0, 2.0, "van", True),
        ("motorcycle", 2.2, 0.8, "motorbike", True),
        ("cyclist", 1.8, 0.6, "bicycle", True),
        ("person", 0.6, 0.6, "pedestrian", True),
        ("car", 4.5, 1.8, "car", False),
        ("car", 12.2, 2.5, "truck", False),  # a 12 m "car"
        ("car", 8.0, 2.4, "truck", False),  # TRUCK_MIN_LENGTH inclusive
        ("vehicle", 5.5, 2.0, "van", False),  # VAN_MIN_LENGTH inclusive
        ("car", 5.49, 2.0, "car", False),
        ("car", 0.9, 1.3, "car", False),  # a generic vehicle class never becomes a person
        ("unknown", 0.9, 1.3, "pedestrian", False),
        ("unknown", 1.5, 1.5, "pedestrian", False),  # PEDESTRIAN_MAX inclusive
        ("unknown", 1.8, 0.6, "bicycle", False),
        ("unknown", 2.0, 1.2, "bicycle", False),  # both two-wheeler bounds inclusive
        ("unknown", 2.9, 0.6, "motorbike", False),
        ("unknown", 3.1, 0.6, "car", False),  # too long for a two-wheeler
        ("unknown", 2.5, 1.9, "car", False),
        ("debris", 12.0, 2.4, "truck", False),  # an unrecognised class: by size
    ],
)
def test_kind_from_class_and_size(cls, length, width, kind, from_class) -> None:
    assert entity_kind(cls, length, width) == EntityKind(kind, from_class)


def test_every_kind_has_a_mass_and_is_an_openscenario_category() -> None:
    from scenariogeneration import xosc

    assert set(MASS) == set(KINDS)
    for kind in KINDS:
        if kind != "pedestrian":
            assert getattr(xosc.VehicleCategory, kind).get_name() == kind
