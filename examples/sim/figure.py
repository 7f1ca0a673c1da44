"""The figure of `docs/reference-data.md`: one scenario's trajectories from both channels.

Read back from the written stream (so the figure shows exactly what the bundled file holds):
left, the ego path of each channel and the truth with the channels' object detections; right
top, the distance between the two channels' ego estimates with the injected-fault labels; right
bottom, the true time gap to the lead vehicle with the tailgating labels and the 1.0 s threshold.
"""

from __future__ import annotations

import gzip
import json
from pathlib import Path
from typing import TYPE_CHECKING

import numpy as np

from examples.sim.labels import TIME_GAP_THRESHOLD

if TYPE_CHECKING:
    from examples.sim.frames import Generated
    from examples.sim.scenarios import Scenario

COLOURS = {"lav": "tab:blue", "tfuse": "tab:orange"}


def plot_scenario(sc: Scenario, g: Generated, out: Path) -> None:
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    with gzip.open(g.stream, "rt") as fh:
        rows = [json.loads(line) for line in fh]
    frames = [r for r in rows if "t" in r]
    t = np.array([f["t"] for f in frames])
    names = [c.name for c in sc.channels]
    ego = {
        n: np.array([[f["channels"][n]["ego"]["x"], f["channels"][n]["ego"]["y"]] for f in frames])
        for n in names
    }
    gt = g.ground_truth
    keep = gt.times <= sc.duration + 1e-9
    true_xy = np.column_stack([gt.x[keep, gt.ego_index], gt.y[keep, gt.ego_index]])
    labels = [json.loads(line) for line in g.labels.read_text().splitlines() if line]

    fig = plt.figure(figsize=(12, 6.5))
    ax = fig.add_subplot(1, 2, 1)
    for n in names:
        objs = np.array(
            [[o["x"], o["y"]] for f in frames[::5] for o in f["channels"][n]["objects"]]
        )
        if len(objs):
            ax.scatter(
                objs[:, 0],
                objs[:, 1],
                s=1.5,
                alpha=0.25,
                color=COLOURS.get(n),
                label=f"{n} objects (every 5th frame)",
            )
    ax.plot(true_xy[:, 0], true_xy[:, 1], color="black", lw=2.5, label="ego, truth (SUMO)")
    for n in names:
        ax.plot(ego[n][:, 0], ego[n][:, 1], color=COLOURS.get(n), lw=1.0, label=f"ego, {n}")
    ax.set_aspect("equal")
    ax.set_xlabel("x [m] (east)")
    ax.set_ylabel("y [m] (north)")
    ax.set_title(f"{sc.name}: ego and detections per channel")
    ax.legend(loc="upper right", fontsize=7, markerscale=4)

    ax2 = fig.add_subplot(2, 2, 2)
    d = np.hypot(*(ego[names[0]] - ego[names[1]]).T)
    ax2.plot(t, d, color="tab:purple", lw=0.8, label=f"|ego {names[0]} - ego {names[1]}|")
    for lab in labels:
        if lab["hazard"] == "CSn1":
            ax2.axvspan(
                lab["start"],
                lab["end"],
                color="tab:red",
                alpha=0.25,
                label="CSn1 label (injected fault)",
            )
    ax2.set_ylabel("distance [m]")
    ax2.set_title("cross-channel ego distance")
    ax2.legend(fontsize=7)

    ax3 = fig.add_subplot(2, 2, 4, sharex=ax2)
    tg = np.array(
        [
            np.nan if f["signals"]["gt_lead_time_gap"] is None else f["signals"]["gt_lead_time_gap"]
            for f in frames
        ]
    )
    ax3.plot(t, np.clip(tg, 0, 5), color="black", lw=0.8, label="true time gap to lead (<= 5 s)")
    ax3.axhline(TIME_GAP_THRESHOLD, color="tab:red", ls="--", lw=0.8, label="threshold 1.0 s")
    for lab in labels:
        if lab["hazard"] == "CSn2":
            ax3.axvspan(
                lab["start"],
                lab["end"],
                color="tab:green",
                alpha=0.25,
                label="CSn2 label (tailgating)",
            )
    ax3.set_xlabel("t [s]")
    ax3.set_ylabel("time gap [s]")
    handles, texts = ax3.get_legend_handles_labels()
    uniq = dict(zip(texts, handles, strict=True))
    ax3.legend(uniq.values(), uniq.keys(), fontsize=7)
    fig.tight_layout()
    out.parent.mkdir(parents=True, exist_ok=True)
    fig.savefig(out, dpi=110)
    plt.close(fig)
