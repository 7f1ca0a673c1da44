"""Hand-made streams for the evaluator's end-to-end tests."""

from __future__ import annotations

import json
from collections.abc import Callable
from pathlib import Path

SMALL_CASE = """\
module: {name: small-e2e, brief: One SPI and one hazard}
monitor:
  channels: [lav, tfuse]
  period: 0.1s
  signals: {speed: "ego speed from the vehicle bus, m/s"}
G1:
  text: EGO vehicle goes from Point A to Point B safely
  supportedBy: [S1]
S1:
  text: Argue over localisation
  supportedBy: [G2]
G2:
  text: Ego location is consistent across channels
  supportedBy: [Sn1]
Sn1:
  text: ELS stays above 0.6
  spi: {signal: els, threshold: ">= 0.6"}
CSn1:
  text: Ego far off the speed limit
  challenges: G2
  hazard: {when: "speed > 20"}
"""


def ego(x: float, y: float) -> dict[str, float]:
    return {"x": x, "y": y, "yaw": 0.0, "vx": 10.0, "vy": 0.0, "length": 4.5, "width": 1.8}


def frame(i: int, period: float = 0.1) -> dict[str, object]:
    """Tick i: both channels agree, except tfuse's ego is 2 m off from t = 2.0 to 3.0 s
    (els = 1 / (1 + 2) = 1/3 < 0.6) and tfuse is absent from t = 5.0 to 5.5 s."""
    t = round(i * period, 6)
    x = 10.0 * t
    channels = {"lav": {"ego": ego(x, 0.0), "plan": [], "objects": []}}
    if not 5.0 <= t <= 5.5:
        offset = 2.0 if 2.0 <= t <= 3.0 else 0.0
        channels["tfuse"] = {"ego": ego(x, offset), "plan": [], "objects": []}
    return {"t": t, "channels": channels, "signals": {"speed": 10.0}}


def write_stream(
    path: Path, frames: int = 100, make: Callable[[int], dict] | None = None, test: str = "e2e"
) -> Path:
    """A two-channel stream of `frames` frames, frame `i` from `make(i)` (default `frame`)."""
    header = {
        "header": {
            "format": "casewatch-frames",
            "version": 1,
            "channels": ["lav", "tfuse"],
            "period": 0.1,
            "meta": {"test": test},
        }
    }
    make = make or frame
    lines = [json.dumps(header)] + [json.dumps(make(i)) for i in range(frames)]
    path.write_text("\n".join(lines) + "\n")
    return path


def write_case(path: Path) -> Path:
    path.write_text(SMALL_CASE)
    return path
