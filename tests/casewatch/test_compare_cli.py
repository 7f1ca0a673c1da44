"""`casewatch compare`: runs grouped by agent and scenario, the violation map and its checks.

The fixtures are hand-written result.json files: a minimal valid `RunResult` plus the keys the
traffic-rule runs add (`stream.meta.agent/scenario`, `episodes[].x/y`, `formulas[].rule`,
`track`, `scores`), so every number below is checked by hand.
"""

from __future__ import annotations

import json
import math
from pathlib import Path

import numpy as np
import pytest

from casewatch.cli import main
from casewatch.evaluator.result import (
    CaseInfo,
    CaseNode,
    Episode,
    FormulaStats,
    RunResult,
    StreamInfo,
)
from casewatch.reports.roadmap import (
    check_markers,
    fit_transform,
    read_opendrive,
    read_sumo_net,
)

#: hazard formula id -> traffic rule
RULES = {"H1": "red_light", "H2": "speeding_light", "H3": "collision"}
#: the "straight" scenario drives y = -1.6 (lane e_0 of NET) from x = 0 to 100 m
STRAIGHT = [[t, 10.0 * t, -1.6] for t in range(11)]
#: the "curve" scenario drives a quarter circle of radius 50 m about the origin
CURVE = [
    [float(i), 50 * math.cos(i * math.pi / 40), 50 * math.sin(i * math.pi / 40)] for i in range(21)
]
NET = """<?xml version="1.0" encoding="UTF-8"?>
<net version="1.20">
  <location netOffset="0.00,0.00" convBoundary="0,0,100,0"/>
  <edge id="e" from="w" to="o" priority="1">
    <lane id="e_0" index="0" speed="13.9" length="100.0" width="3.2" shape="0.00,-1.60 100.00,-1.60"/>
    <lane id="e_1" index="1" speed="13.9" length="100.0" shape="0.00,1.60 50.00,1.60 100.00,1.60"/>
  </edge>
</net>
"""  # noqa: E501
#: a 10 m line east from the origin, then a left quarter circle of radius 10 m: it ends at
#: (20, 10) heading north; one 3.5 m lane each side of the reference line
XODR = """<?xml version="1.0" encoding="UTF-8"?>
<OpenDRIVE>
  <header revMajor="1" revMinor="6"/>
  <road id="1" length="25.708" junction="-1">
    <planView>
      <geometry s="0" x="0" y="0" hdg="0" length="10"><line/></geometry>
      <geometry s="10" x="10" y="0" hdg="0" length="15.707963267948966"><arc curvature="0.1"/></geometry>
    </planView>
    <lanes>
      <laneSection s="0">
        <left><lane id="1" type="driving"><width sOffset="0" a="3.5" b="0" c="0" d="0"/></lane></left>
        <center><lane id="0" type="none"/></center>
        <right><lane id="-1" type="driving"><width sOffset="0" a="3.5" b="0" c="0" d="0"/></lane>
               <lane id="-2" type="sidewalk"><width sOffset="0" a="2.0" b="0" c="0" d="0"/></lane></right>
      </laneSection>
    </lanes>
  </road>
</OpenDRIVE>
"""  # noqa: E501


def episode(formula: str, start: float, xy: tuple[float, float] | None) -> dict:
    kind = "hazard" if formula.startswith("H") else "spi"
    e = Episode(
        formula_id=formula,
        node_id=f"N{formula}",
        kind=kind,
        start=start,
        end=start + 2.0,
        ticks=20,
        worst_robustness=-1.0,
        t_worst=start + 1.0,
        trace=[],
    ).model_dump(mode="json")
    e["x"], e["y"] = xy if xy else (None, None)
    return e


def write_run(
    folder: Path,
    meta: dict,
    duration: float,
    episodes: list[dict],
    track: list,
    scores: dict | None,
) -> Path:
    """A run folder with a result.json shaped like a traffic-rule run."""
    formulas = [
        FormulaStats(
            id=f, node_id=f"N{f}", node_text=f"{rule} broken", kind="hazard", source="x", rtamt="x"
        )
        for f, rule in RULES.items()
    ]
    formulas.append(
        FormulaStats(id="S1", node_id="NS1", node_text="spi", kind="spi", source="x", rtamt="x")
    )
    case = CaseInfo(
        path="rules.yaml",
        digest="sha256:" + "0" * 64,
        module="rules",
        root_id="G1",
        channels=["ego"],
        period=0.1,
        nodes=[CaseNode(id="G1", type="G", text="drive lawfully")],
    )
    result = RunResult(
        casewatch_version="0.1.0",
        created="2026-01-01T00:00:00Z",
        case=case,
        stream=StreamInfo(path=f"{folder.name}.jsonl", digest=None, meta=meta, duration=duration),
        verdict="violated",
        formulas=formulas,
        episodes=[],
        data_gaps=[],
        status=[],
        series=[],
    )
    data = result.model_dump(mode="json")
    for f in data["formulas"]:
        f["rule"] = RULES.get(f["id"])
    data["episodes"] = episodes
    data["track"] = track
    data["scores"] = scores
    folder.mkdir(parents=True)
    (folder / "result.json").write_text(json.dumps(data))
    return folder


def scores(penalty: float, driving: float, per_rule: dict[str, tuple[int, float]]) -> dict:
    return {
        "penalty": {
            "score": penalty,
            "c": 1.0,
            "t": 60.0,
            "t_o": 60.0,
            "d": 1.0,
            "route_length": 100.0,
            "v_avg": 10.0,
            "stop_time": 0.0,
            "gamma": 1.0,
            "penalty_sum": sum(p for _, p in per_rule.values()),
            "per_rule": {
                r: {"events": n, "while_speeding": 0, "penalty": p}
                for r, (n, p) in per_rule.items()
            },
        },
        "carla": {
            "driving_score": driving,
            "route_completion": 1.0,
            "infraction_penalty": driving,
            "per_infraction": {"red_light": {"events": 1, "coefficient": 0.7}},
        },
    }


@pytest.fixture
def four_runs(tmp_path: Path) -> list[Path]:
    """2 agents x 2 scenarios. r1 A/straight 1 h, r2 A/curve, r3 B/straight, r4 B/curve
    (0.5 h each); r4 is an older result without scores and its hazard has no position."""
    runs = tmp_path / "runs"
    return [
        write_run(
            runs / "r1",
            {"agent": "A", "scenario": "straight"},
            3600.0,
            [episode("S1", 1.0, (10.0, -1.6)), episode("H1", 12.0, (50.0, -1.6))],
            STRAIGHT,
            scores(0.8, 0.7, {"red_light": (1, 0.2)}),
        ),
        write_run(
            runs / "r2",
            {"agent": "A", "scenario": "curve"},
            1800.0,
            [
                episode("H2", 5.0, (50 * math.cos(math.pi / 4), 50 * math.sin(math.pi / 4))),
                episode("H2", 9.0, (0.0, 0.0)),
            ],  # 50 m from the arc: off its track
            CURVE,
            scores(0.6, 0.5, {"speeding_light": (2, 0.4)}),
        ),
        write_run(
            runs / "r3",
            {"agent": "B", "scenario": "straight"},
            1800.0,
            [episode("H3", 3.0, (50.0, 21.6))],  # 23.2 m off its track, 20 m off lane e_1
            STRAIGHT,
            scores(0.5, 0.9, {"collision": (1, 0.5)}),
        ),
        write_run(
            runs / "r4",
            {"agent": "B", "scenario": "curve"},
            1800.0,
            [episode("H1", 4.0, None)],
            CURVE,
            None,
        ),
    ]


def compare(tmp_path: Path, *args: str) -> tuple[int, dict | None]:
    out = tmp_path / "out"
    code = main(["compare", *args, "-o", str(out)])
    path = out / "compare.json"
    return code, json.loads(path.read_text()) if code == 0 else None


def test_groups_and_numbers_by_agent_and_scenario(tmp_path, four_runs, capsys):
    code, report = compare(tmp_path, *map(str, four_runs))
    assert code == 0
    assert report["format"] == "casewatch-compare" and report["by"] == ["agent", "scenario"]
    groups = {g["label"]: g for g in report["groups"]}
    assert list(groups) == ["A / curve", "A / straight", "B / curve", "B / straight"]
    assert groups["A / straight"]["hours"] == 1.0 and groups["A / curve"]["hours"] == 0.5
    assert groups["A / straight"]["penalty_score"] == {
        "mean": 0.8,
        "min": 0.8,
        "max": 0.8,
        "runs": 1,
    }
    assert groups["B / straight"]["driving_score"]["mean"] == 0.9
    assert groups["B / curve"]["penalty_score"] is None  # an older, unscored result
    assert report["rules"] == ["collision", "red_light", "speeding_light"]
    assert groups["A / curve"]["per_rule"]["speeding_light"] == {"events": 2, "penalty": 0.4}
    # unscored: the hazard episodes counted per rule, no penalty
    assert groups["B / curve"]["per_rule"]["red_light"] == {"events": 1, "penalty": None}
    assert groups["B / straight"]["per_rule"]["red_light"] == {"events": 0, "penalty": None}
    assert groups["A / straight"]["per_infraction"] == {"red_light": 1}
    table = report["table"]
    assert (table["rows"], table["cols"]) == (["A", "B"], ["curve", "straight"])
    assert [[c and c["mean"] for c in row] for row in table["cells"]] == [[0.6, 0.8], [None, 0.5]]
    # markers: hazard episodes with a position (the SPI episode is none); one has no position
    checks = report["checks"]
    assert (checks["hazard_events"], checks["markers"], checks["without_position"]) == (5, 4, 1)
    assert [m["rule"] for m in report["markers"]] == [
        "red_light",
        "speeding_light",
        "speeding_light",
        "collision",
    ]
    assert checks["track"]["off"] == 2 and checks["network"] is None
    off = [report["markers"][i] for i in checks["track"]["off_markers"]]
    # the origin is 50 m from the arc, 50 cos(pi/80) m from its nearest chords
    assert [(m["run"], m["track_distance"]) for m in off] == [
        ("r2", pytest.approx(50 * math.cos(math.pi / 80), abs=1e-3)),
        ("r3", 23.2),
    ]
    assert report["markers"][1]["track_distance"] < 0.05  # on the arc, between two samples
    printed = capsys.readouterr().out
    assert "A / straight" in printed and "0.800" in printed
    assert "off-track markers: 2" in printed and "off-road markers: not checked" in printed
    md = (tmp_path / "out" / "compare.md").read_text()
    assert "| A | straight | 1 | 1.000 | 0.800 | 0.700 | 1.000 | 1 |" in md
    assert "| A | 0.600 | 0.800 |" in md
    assert "| B / curve |  | 1 |  |" in md
    assert "- speeding_light in run r2 (agent A) at 9.0 s, (0.0, 0.0) m" in md
    html = (tmp_path / "out" / "compare.html").read_text()
    assert "<script" not in html and "http" not in html.replace('xmlns="http', "")
    assert html.count('<circle class="marker') == 4


def test_group_by_one_key_gives_min_and_max(tmp_path, four_runs, capsys):
    code, report = compare(tmp_path, *map(str, four_runs), "--by", "agent")
    assert code == 0
    a, b = report["groups"]
    assert (a["label"], a["runs"], a["hours"]) == ("A", 2, 1.5)
    assert a["penalty_score"] == {"mean": 0.7, "min": 0.6, "max": 0.8, "runs": 2}
    assert b["penalty_score"] == {"mean": 0.5, "min": 0.5, "max": 0.5, "runs": 1}
    assert b["per_rule"]["red_light"] == {"events": 1, "penalty": None}
    assert report["table"]["cols"] == ["all"]
    assert "0.700 (0.600-0.800)" in capsys.readouterr().out


def test_runs_without_the_key_are_grouped_under_none_and_fleets_are_read(
    tmp_path, four_runs, capsys
):
    old = write_run(tmp_path / "runs" / "old", {"town": "Town01"}, 360.0, [], [], None)
    fleet = tmp_path / "fleet"
    fleet.mkdir()
    (fleet / "summary.json").write_text(
        json.dumps({"per_log": [{"out_dir": str(p)} for p in four_runs[:2]]})
    )
    code, report = compare(tmp_path, str(fleet), str(old))
    assert code == 0
    assert [g["label"] for g in report["groups"]] == [
        "(none) / (none)",
        "A / curve",
        "A / straight",
    ]
    assert report["without_key"] == {"agent": ["old"], "scenario": ["old"]}
    printed = capsys.readouterr().out
    assert "1 run(s) without 'agent' in the stream meta, grouped under (none)" in printed


def test_a_sumo_net_checks_markers_against_the_lanes(tmp_path, four_runs, capsys):
    net = tmp_path / "straight.net.xml"
    net.write_text(NET)
    code, report = compare(tmp_path, str(four_runs[0]), str(four_runs[2]), "--net", str(net))
    assert code == 0
    network = report["checks"]["network"]
    assert (network["kind"], network["lanes"], network["checked"]) == ("sumo", 2, 2)
    assert network["off_road"] == 1 and network["hint"] is None
    (off,) = network["off_road_markers"]
    assert report["markers"][off]["rule"] == "collision"
    assert report["markers"][off]["network_distance"] == 20.0
    assert "off-road markers: 1" in capsys.readouterr().out
    html = (tmp_path / "out" / "compare.html").read_text()
    assert html.count('class="lane"') == 2 and html.count('class="marker off-road"') == 1


def test_sumo_net_parsing_and_the_off_road_check(tmp_path):
    net = tmp_path / "two.net.xml"
    net.write_text(NET)
    network = read_sumo_net(net)
    assert [ln.id for ln in network.lanes] == ["e_0", "e_1"]
    assert [ln.width for ln in network.lanes] == [3.2, 3.2]  # e_1: SUMO's default width
    assert network.lanes[0].centre.tolist() == [[0.0, -1.6], [100.0, -1.6]]
    assert network.net_offset == (0.0, 0.0)
    markers = [{"x": 50.0, "y": -1.6}, {"x": 50.0, "y": 21.6}, {"x": 50.0, "y": 3.7}]
    summary = check_markers(markers, network)
    assert [m["network_distance"] for m in markers] == [0.0, 20.0, 2.1]
    # 3.7 is 2.1 m from e_1's centre: within half its width (1.6) + 0.5 m, so on the road
    assert [m["off_road"] for m in markers] == [False, True, False]
    assert summary["off_road"] == 1 and summary["off_road_markers"] == [1]


def test_a_frame_mistake_is_hinted_not_corrected(tmp_path):
    net = tmp_path / "offset.net.xml"
    net.write_text(NET.replace('netOffset="0.00,0.00"', 'netOffset="100.00,0.00"'))
    markers = [{"x": -50.0, "y": 1.6}, {"x": -20.0, "y": -1.6}]  # in the original frame
    summary = check_markers(markers, read_sumo_net(net))
    assert summary["off_road"] == 2 and markers[0]["x"] == -50.0  # reported, never moved
    assert "plus the net's netOffset" in summary["hint"]


def test_opendrive_line_and_arc(tmp_path):
    xodr = tmp_path / "road.xodr"
    xodr.write_text(XODR)
    network = read_opendrive(xodr)
    (reference,) = network.reference_lines
    assert reference[0].tolist() == [0.0, 0.0]
    # line end (10, 0); the arc of radius 10 about (10, 10) turns left a quarter to (20, 10)
    assert np.allclose(reference[-1], [20.0, 10.0], atol=1e-9)
    assert np.isclose(np.hypot(*(reference[reference[:, 0] > 10] - [10, 10]).T), 10).all()
    # drivable lanes only (not the sidewalk), centres 1.75 m each side; edges at 3.5 and 5.5 m
    assert [ln.id for ln in network.lanes] == ["1:1", "1:-1"]
    left, right = network.lanes
    assert np.allclose(left.centre[-1], [18.25, 10.0]) and np.allclose(
        right.centre[-1], [21.75, 10.0]
    )
    assert sorted(np.round(e[-1], 6).tolist() for e in network.edges) == [
        [16.5, 10.0],
        [25.5, 10.0],
    ]
    markers = [{"x": 5.0, "y": -1.75}, {"x": 5.0, "y": 30.0}]
    assert check_markers(markers, network)["off_road_markers"] == [1]


def test_the_world_to_svg_transform_flips_y_and_keeps_the_aspect():
    tf = fit_transform((0.0, 0.0, 100.0, 50.0), width=900, max_height=640, margin=16)
    assert tf.scale == pytest.approx(8.68)  # (900 - 32) / 100 < (640 - 32) / 50
    assert tf.height == pytest.approx(50 * 8.68 + 32)
    px = tf.apply([(0.0, 0.0), (100.0, 50.0), (10.0, 0.0), (0.0, 10.0)])
    assert px[0].tolist() == pytest.approx([16.0, 16 + 50 * 8.68])  # world origin: bottom left
    assert px[1].tolist() == pytest.approx([884.0, 16.0])  # top right
    assert px[2][0] - px[0][0] == pytest.approx(px[0][1] - px[3][1])  # 10 m is 10 m both ways
    tall = fit_transform((0.0, 0.0, 10.0, 1000.0), width=900, max_height=640, margin=16)
    (cx, _), (_, top) = tall.apply([(5.0, 0.0), (0.0, 1000.0)])
    assert tall.scale == pytest.approx(0.608) and cx == pytest.approx(450) and top == 16


@pytest.mark.parametrize(
    ("net_text", "flag", "message"),
    [
        ("<net><edge id='e'>", "--net", "not well-formed XML"),
        ("<nets/>", "--net", "root element is <nets>, expected <net>"),
        (
            "<net><edge id='e'><lane id='e_0'/></edge></net>",
            "--net",
            "lane 'e_0': attribute 'shape' missing",
        ),
        (
            "<net><edge id='e'><lane id='e_0' shape='0,0 a,b'/></edge></net>",
            "--net",
            "lane 'e_0': shape '0,0 a,b' is not a list of at least two x,y points",
        ),
        (
            "<OpenDRIVE><road id='7'><planView><geometry x='0' y='0' hdg='0' length='5'><arc/>"
            "</geometry></planView></road></OpenDRIVE>",
            "--xodr",
            "road '7' geometry 1 <arc>: attribute 'curvature' missing",
        ),
        (
            "<OpenDRIVE><road id='7'><planView><geometry x='0' y='0' hdg='0' length='5'><clothoid/>"
            "</geometry></planView></road></OpenDRIVE>",
            "--xodr",
            "road '7' geometry 1: <clothoid> where line, arc, spiral, poly3 or paramPoly3",
        ),
    ],
)
def test_an_unusable_network_is_refused_with_its_path(
    tmp_path, four_runs, capsys, net_text, flag, message
):
    path = tmp_path / ("bad.net.xml" if flag == "--net" else "bad.xodr")
    path.write_text(net_text)
    code, _ = compare(tmp_path, str(four_runs[0]), flag, str(path))
    err = capsys.readouterr().err
    assert code == 2 and err.startswith(f"casewatch compare: {path}") and message in err
    assert len(err.strip().splitlines()) == 1


def test_unusable_input_exits_2_with_one_line(tmp_path, four_runs, capsys):
    empty = tmp_path / "empty"
    empty.mkdir()
    broken = tmp_path / "broken"
    broken.mkdir()
    (broken / "result.json").write_text("{not json")
    other = tmp_path / "other"
    other.mkdir()
    (other / "result.json").write_text('{"format": "casewatch-diff"}')
    cases = [
        ([str(empty)], "neither a run folder (result.json) nor a fleet folder"),
        ([str(broken)], f"{broken / 'result.json'}:1:2: not valid JSON"),
        ([str(other)], "'format' is 'casewatch-diff', expected 'casewatch-result'"),
        ([str(four_runs[0]), "--by", "driver"], "--by driver: no run's stream meta has this key"),
        ([str(four_runs[0]), "--by", ","], "--by needs at least one stream meta key"),
        (
            [str(four_runs[0]), "--net", str(tmp_path / "missing.net.xml")],
            f"{tmp_path / 'missing.net.xml'}: no such file",
        ),
    ]
    for args, message in cases:
        code, _ = compare(tmp_path, *args)
        err = capsys.readouterr().err
        assert code == 2, args
        assert message in err and len(err.strip().splitlines()) == 1, err
    assert not (tmp_path / "out").exists()


def test_results_without_the_new_keys_still_compare(tmp_path, capsys):
    """A result written before agent, scores, track and positions existed."""
    folder = write_run(
        tmp_path / "old", {"scenario": "s"}, 36.0, [episode("H1", 1.0, None)], [], None
    )
    data = json.loads((folder / "result.json").read_text())
    for key in ("track", "scores"):
        del data[key]
    for e in data["episodes"]:
        del e["x"], e["y"]
    for f in data["formulas"]:
        del f["rule"]
    (folder / "result.json").write_text(json.dumps(data))
    code, report = compare(tmp_path, str(folder), "--by", "scenario")
    assert code == 0
    (group,) = report["groups"]
    assert group["label"] == "s" and group["hazard_events"] == 1
    assert group["penalty_score"] is None and group["per_rule"] == {}
    assert report["rules"] == [] and report["markers"] == []
    html = (tmp_path / "out" / "compare.html").read_text()
    assert "Nothing to map" in html
