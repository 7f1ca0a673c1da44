"""`run --foxglove`: the annotate topics published live on the Foxglove SDK's WebSocket server,
read by a client speaking Foxglove's WebSocket protocol (subscribe, then binary message data:
opcode 1, subscription id, log time, payload)."""

from __future__ import annotations

import asyncio
import json
import struct
import threading

import aiohttp
import pytest
from foxglove_schemas_protobuf.Log_pb2 import Log
from foxglove_schemas_protobuf.SceneUpdate_pb2 import SceneUpdate

from casewatch import api
from casewatch.evaluator.options import RunOptions, RunSinks
from casewatch.evaluator.session import evaluate_stream
from casewatch.live.address import ServeAddress
from casewatch.live.foxglove_ws import FoxgloveLive
from tests.evaluator.streams import write_case
from tests.live.drives import FRAMES, write_rich_stream

PROTOCOL = "foxglove.sdk.v1"  # the subprotocol the SDK's server speaks


async def watch(url: str, topics: list[str], judge: threading.Thread) -> tuple[dict, dict]:
    """Subscribe to `topics`, start `judge`, and collect every message until it is done and
    the server has been quiet for a second: (advertised channels, topic -> [(ns, payload)])."""
    got: dict[str, list[tuple[int, bytes]]] = {t: [] for t in topics}
    async with (
        aiohttp.ClientSession() as session,
        session.ws_connect(url, protocols=[PROTOCOL]) as ws,
    ):
        channels: dict[str, dict] = {}
        while not all(t in channels for t in topics):
            message = json.loads((await asyncio.wait_for(ws.receive(), 10)).data)
            if message["op"] == "advertise":
                channels.update({c["topic"]: c for c in message["channels"]})
        wanted = [{"id": k, "channelId": channels[t]["id"]} for k, t in enumerate(topics)]
        await ws.send_str(json.dumps({"op": "subscribe", "subscriptions": wanted}))
        await asyncio.sleep(0.5)  # the server registers the subscriptions
        judge.start()
        while True:
            try:
                message = await asyncio.wait_for(ws.receive(), 1.0)
            except TimeoutError:
                if not judge.is_alive():
                    break
                continue
            if message.type == aiohttp.WSMsgType.BINARY and message.data[0] == 1:
                sub, ns = struct.unpack_from("<IQ", message.data, 1)
                got[topics[sub]].append((ns, message.data[13:]))
    return channels, got


def test_the_annotate_topics_are_published_while_judging(tmp_path):
    case, spec = api.prepare(str(write_case(tmp_path / "case.yaml")))
    stream = write_rich_stream(tmp_path / "drive.jsonl")
    fox = FoxgloveLive(["lav", "tfuse"], spec.root_id, 0.1, ServeAddress("127.0.0.1", 0))
    assert fox.url.startswith("ws://127.0.0.1:")
    sinks = RunSinks(on_event=fox.on_event, on_tick=fox.on_tick)
    judge = threading.Thread(
        target=evaluate_stream, args=(case, spec, str(stream), RunOptions(), sinks)
    )
    topics = ["/casewatch/log", "/casewatch/status", "/casewatch/scene/lav", "/casewatch/markers"]
    try:
        channels, got = asyncio.run(watch(fox.url, topics, judge))
    finally:
        fox.stop()
    assert {t: (c["schemaName"], c["encoding"]) for t, c in channels.items()} == {
        "/casewatch/log": ("foxglove.Log", "protobuf"),
        "/casewatch/status": ("casewatch.NodeStatus", "json"),
        "/casewatch/markers": ("foxglove.SceneUpdate", "protobuf"),
        "/casewatch/scene/lav": ("foxglove.SceneUpdate", "protobuf"),
        "/casewatch/scene/tfuse": ("foxglove.SceneUpdate", "protobuf"),
    }
    status = [(ns, json.loads(p)) for ns, p in got["/casewatch/status"]]
    assert len(status) == FRAMES
    at = {v["t"]: (ns, v) for ns, v in status}
    assert at[2.5][0] == 2_500_000_000
    assert at[2.5][1]["status"]["Sn1"] == "violated" and at[2.5][1]["root"] == "undermined"
    assert at[5.2][1]["status"]["Sn1"] == "no-data" and at[1.0][1]["root"] == "satisfied"
    logs = [(ns, Log.FromString(p)) for ns, p in got["/casewatch/log"]]
    assert [(ns, log.name, log.message.split(" s")[0]) for ns, log in logs] == [
        (2_000_000_000, "Sn1", "VIOLATED Sn1 from 2.0"),
        (3_000_000_000, "Sn1", "SPI EPISODE Sn1 2.0-3.0"),
        (5_500_000_000, "Sn1", "NO DATA Sn1 5.0-5.5"),
    ]
    scenes = [SceneUpdate.FromString(p) for _, p in got["/casewatch/scene/lav"]]
    assert len(scenes) == FRAMES
    assert sorted(e.id for e in scenes[0].entities) == [
        "ego",
        "object-7",
        "object-lead",
        "plan",
        "prediction-lead",
    ]
    markers = [SceneUpdate.FromString(p) for _, p in got["/casewatch/markers"]]
    assert [m.entities[0].id for m in markers[:1]] == ["open-Sn1"]  # at the onset, 2.0 s
    sphere = markers[0].entities[0].spheres[0].pose.position
    assert (sphere.x, sphere.y) == (20.0, 0.0)  # lav's ego at 2.0 s
    assert [d.id for d in markers[1].deletions] == ["open-Sn1"]  # gone when it closes


def test_without_subscribers_no_scene_is_built(tmp_path, monkeypatch):
    case, spec = api.prepare(str(write_case(tmp_path / "case.yaml")))
    stream = write_rich_stream(tmp_path / "drive.jsonl", frames=20)
    fox = FoxgloveLive(["lav", "tfuse"], spec.root_id, 0.1, ServeAddress("127.0.0.1", 0))
    built = []
    monkeypatch.setattr(
        "casewatch.live.foxglove_ws.channel_entities", lambda *a: built.append(a) or []
    )
    try:
        sinks = RunSinks(on_event=fox.on_event, on_tick=fox.on_tick)
        evaluate_stream(case, spec, str(stream), RunOptions(), sinks)
    finally:
        fox.stop()
    assert built == []


@pytest.mark.parametrize("extra", [["--foxglove", "0.0.0.0:0"], ["--foxglove", "x"]])
def test_foxglove_addresses_follow_the_serve_rules(tmp_path, capsys, extra):
    from casewatch.cli import main

    case = write_case(tmp_path / "case.yaml")
    stream = write_rich_stream(tmp_path / "drive.jsonl", frames=10)
    assert main(["run", str(case), str(stream), "-o", str(tmp_path / "o"), *extra]) == 2
    assert "--serve" in capsys.readouterr().err


def test_a_bag_is_published_on_its_own_clock(tmp_path):
    from casewatch.cli import main

    case, spec = api.prepare(str(write_case(tmp_path / "case.yaml")))
    stream = write_rich_stream(tmp_path / "drive.jsonl", frames=30)
    bag = tmp_path / "bag" / "drive"
    assert main(["convert", str(stream), "-o", str(bag)]) == 0
    options = RunOptions(topics=str(tmp_path / "bag" / "drive.topics.yaml"))
    fox = FoxgloveLive(["lav", "tfuse"], spec.root_id, 0.1, ServeAddress("127.0.0.1", 0))
    results = []
    sinks = RunSinks(on_event=fox.on_event, on_tick=fox.on_tick)
    judge = threading.Thread(
        target=lambda: results.append(evaluate_stream(case, spec, str(bag), options, sinks))
    )
    try:
        _, got = asyncio.run(watch(fox.url, ["/casewatch/status"], judge))
    finally:
        fox.stop()
    t0 = int(results[0].stream.meta["t0_unix_ns"])  # the bag's first tick, as annotate uses
    assert t0 > 0
    assert [ns for ns, _ in got["/casewatch/status"]] == [t0 + k * 100_000_000 for k in range(30)]
