"""A small drive with objects, predictions and plans, for the annotate and live tests.

The hand-made stream of tests.evaluator.streams (both channels agree except tfuse's ego is
2 m off from 2.0 to 3.0 s, an SPI episode of Sn1, and tfuse is absent 5.0-5.5 s), with one
lead car (box footprint, 3-point prediction) and one pedestrian (polygon footprint), and a
4-point plan per channel.
"""

from __future__ import annotations

from pathlib import Path

from tests.evaluator.streams import frame, write_stream

FRAMES = 100
#: Frames without tfuse (t = 5.0 .. 5.5 s).
TFUSE_ABSENT = 6


def rich_frame(i: int) -> dict:
    record = frame(i)
    t = record["t"]
    for state in record["channels"].values():
        x, y = state["ego"]["x"], state["ego"]["y"]
        state["plan"] = [[k * 0.1, x + k * 1.0, y] for k in range(4)]
        lead = 10.0 * t + 30.0
        state["objects"] = [
            {
                "id": "lead",
                "cls": "car",
                "x": lead,
                "y": 0.0,
                "vx": 10.0,
                "length": 4.4,
                "width": 1.8,
                "prediction": [[0.0, lead, 0.0], [0.1, lead + 1.0, 0.0], [0.2, lead + 2.0, 0.0]],
            },
            {
                "id": 7,
                "cls": "pedestrian",
                "x": 50.0,
                "y": 6.0,
                "polygon": [[0.3, 0.3], [-0.3, 0.3], [-0.3, -0.3], [0.3, -0.3]],
            },
        ]
    return record


def write_rich_stream(path: Path, frames: int = FRAMES) -> Path:
    return write_stream(path, frames, rich_frame, test="annotate")
