"""Reading ROS 2 bags as frames: time alignment, dropouts, conversions, and bad bags.

The small bags here are written with hand-chosen stamps (tests/monitor/bagkit.py), so every
expectation is computed by hand from the alignment rule of docs/bags.md: tick T takes the
latest message stamped in (T - max_age, T]; max_age defaults to 1.5 periods.
"""

from __future__ import annotations

import itertools
import shutil
from pathlib import Path

import numpy as np
import pytest

from casewatch.monitor.bags.mapping import LoadedMapping, MappingError, TopicMapping, load_mapping
from casewatch.monitor.bags.reader import BagError, read_bag
from casewatch.monitor.bags.writer import default_mapping, write_bag
from casewatch.monitor.engine import MetricEngine
from casewatch.monitor.reader import StreamError, read_stream
from casewatch.monitor.source import source_kind
from casewatch.safety_case.loader import require_case
from tests.monitor.bagkit import MS, T0, TOPICS, BagKit, ego_state, mapping, one_object

ROOT = Path(__file__).resolve().parents[2]
DRIVE = ROOT / "examples" / "data" / "urban-realstack.jsonl.gz"


def frames_of(path: Path, m: LoadedMapping | None = None, **kw):
    reader = read_bag(path, m or mapping(), channels=["lav"], period=0.1, **kw)
    return reader, list(reader)


def stamps_every(step_ms: float, start_ms: float, end_ms: float) -> list[float]:
    return [round(start_ms + i * step_ms, 6) for i in range(int((end_ms - start_ms) / step_ms) + 1)]


def write_timeline(kit: BagKit, events: list[tuple[float, str, float]]) -> None:
    """(recording time ms, kind, stamp ms) in recording order, as a recorder writes them."""
    for log_ms, kind, stamp_ms in sorted(events):
        if kind == "odometry":
            kit.odometry(stamp_ms, x=stamp_ms / 100.0, log_ms=log_ms)
        else:
            kit.objects(stamp_ms, x=50.0 + stamp_ms / 100.0, log_ms=log_ms)


# -- alignment ----------------------------------------------------------------------------------


@pytest.fixture
def phased_bag(tmp_path: Path) -> Path:
    """Odometry at 50 Hz from 0 ms; objects at 10 Hz stamped 50, 150, ... 950 ms (the 450 ms
    one lost), each recorded 30 ms after its stamp."""
    kit = BagKit(tmp_path / "phased")
    events = [(s, "odometry", s) for s in stamps_every(20, 0, 1000)]
    events += [(s + 30, "objects", s) for s in stamps_every(100, 50, 950) if s != 450]
    write_timeline(kit, events)
    return kit.close()


def test_ticks_take_the_latest_message_of_the_last_period(phased_bag: Path) -> None:
    reader, frames = frames_of(phased_bag)
    # ticks on the absolute 100 ms grid from the first stamp (0 ms) to the last (1000 ms)
    assert [f.t for f in frames] == [round(0.1 * k, 10) for k in range(11)]
    present = [("lav" in f.channels) for f in frames]
    # 0 ms: no objects yet; 500 ms: the latest objects are from 350 ms, 150 ms old, not
    # younger than max_age (1.5 periods): a dropout, not the old message again
    assert present == [False, True, True, True, True, False, True, True, True, True, True]
    assert reader.dropouts == {"lav": 2}
    by_t = {f.t: f for f in frames}
    # ego: the odometry stamped exactly at the tick (x = stamp / 100); objects: the 50 ms
    # older message (x = 50 + stamp / 100), moved to the tick at its 5 m/s: + 0.25 m
    assert by_t[0.3].channels["lav"].ego.x == pytest.approx(3.0)
    assert by_t[0.3].channels["lav"].objects.pos[0, 0] == pytest.approx(50 + 2.5 + 0.25)
    assert by_t[1.0].channels["lav"].objects.pos[0, 0] == pytest.approx(50 + 9.5 + 0.25)
    _, as_stamped = frames_of(phased_bag, mapping(poses_at_tick=False))
    assert as_stamped[3].channels["lav"].objects.pos[0, 0] == pytest.approx(50 + 2.5)
    report = reader.topic_report()
    assert report[TOPICS["objects"]] == {"missing_ticks": 2, "late_messages": 0}
    assert report[TOPICS["odometry"]]["missing_ticks"] == 0
    assert reader.header.meta["t0_unix_ns"] == T0
    assert reader.defects == []


def test_a_longer_max_age_bridges_the_lost_message_by_choice(phased_bag: Path) -> None:
    m = mapping(
        channels={
            "lav": {
                "odometry": TOPICS["odometry"],
                "objects": {"topic": TOPICS["objects"], "max_age": "200ms"},
            }
        }
    )
    reader, frames = frames_of(phased_bag, m)
    by_t = {f.t: f for f in frames}
    assert by_t[0.5].channels["lav"].objects.pos[0, 0] == pytest.approx(50 + 3.5 + 5 * 0.15)
    assert reader.dropouts == {"lav": 1}  # only the first tick, before any objects


def test_poses_move_to_the_tick_with_their_own_velocity_and_yaw_rate(tmp_path: Path) -> None:
    """Odometry stamped 40 ms before the tick at 10 m/s along a 30 degree heading, turning at
    0.5 rad/s: at the tick it is 0.4 m further along that heading, turned by 0.02 rad."""
    kit = BagKit(tmp_path / "motion")
    build, store = kit.build, kit.store
    T = build.T
    heading = np.pi / 6
    msg = build.odometry(
        T0 + 60 * MS, ego_state(2.0, vx=10 * np.cos(heading), yaw=heading, vy=10 * np.sin(heading))
    )
    msg.twist.twist.angular = T["geometry_msgs/msg/Vector3"](x=0.0, y=0.0, z=0.5)
    kit.raw(
        TOPICS["odometry"],
        "nav_msgs/msg/Odometry",
        store.serialize_cdr(msg, "nav_msgs/msg/Odometry"),
        T0 + 60 * MS,
    )
    kit.objects(100, x=50.0)
    kit.close()
    _, frames = frames_of(tmp_path / "motion")
    ego = frames[0].channels["lav"].ego  # the tick at 100 ms
    assert frames[0].t == 0.0
    assert ego.x == pytest.approx(2.0 + 0.4 * np.cos(heading))
    assert ego.y == pytest.approx(0.4 * np.sin(heading))
    assert ego.yaw == pytest.approx(heading + 0.02)
    assert (ego.vx, ego.vy) == pytest.approx((10 * np.cos(heading), 10 * np.sin(heading)))


def test_stamps_jittering_around_the_ticks_leave_no_tick_empty(tmp_path: Path) -> None:
    """A stack whose stamps fall 2 ms either side of the ticks (98, 202, 298, 402 ms ...):
    tick 200 ms has only the 98 ms message, 102 ms old. The default max_age (150 ms) takes
    it; a limit of exactly one period would leave every other tick empty."""
    kit = BagKit(tmp_path / "jitter")
    for k in range(1, 21):
        s = 100 * k + (2 if k % 2 == 0 else -2)
        kit.odometry(s, x=float(k))
        kit.objects(s, x=50.0 + k)
    kit.close()
    reader, frames = frames_of(tmp_path / "jitter")
    assert [f.t for f in frames][:3] == [0.0, 0.1, 0.2]  # first tick: 100 ms, the grid after 98
    assert reader.dropouts == {"lav": 0}
    # the 98 ms odometry serves ticks 100 and 200 ms, moved on at its 10 m/s each time
    assert [f.channels["lav"].ego.x for f in frames[:4]] == pytest.approx([1.02, 2.02, 3.02, 4.02])
    strict = mapping(max_age="100ms")
    reader, frames = frames_of(tmp_path / "jitter", strict)
    assert reader.dropouts == {"lav": 10}


def test_trajectories_count_from_the_tick(tmp_path: Path) -> None:
    """A plan stamped 50 ms before the tick: its points move 50 ms earlier and the ones
    already past are dropped; a prediction the same way."""
    kit = BagKit(tmp_path / "plans")
    plan = np.array([[0.0, 0.0, 0.0], [0.5, 5.0, 0.0], [1.0, 10.0, 0.0]])
    pred = np.array([[0.0, 50.0, 3.0], [0.5, 52.5, 3.0], [1.0, 55.0, 3.0]])
    kit.odometry(0, x=0.0)
    kit.odometry(50, x=0.5)
    kit.objects(50, x=50.0, pred=pred)
    kit.plan(50, plan)
    kit.odometry(100, x=1.0)
    kit.close()
    _, frames = frames_of(tmp_path / "plans", mapping(with_plan=True))
    state = frames[1].channels["lav"]  # the tick at 100 ms
    np.testing.assert_allclose(state.plan, [[0.45, 5.0, 0.0], [0.95, 10.0, 0.0]])
    objs = state.objects
    assert objs.pred_len.tolist() == [2]
    np.testing.assert_allclose(objs.pred[0], [[0.45, 52.5, 3.0], [0.95, 55.0, 3.0]])
    assert objs.ids == [b"7".rjust(16, b"\0").hex()] and objs.cls == ["car"]


def test_missing_plan_leaves_the_channel_without_a_plan_not_absent(tmp_path: Path) -> None:
    """One plan, stamped 0 ms: tick 100 ms still takes it (100 ms old, under the 150 ms
    default), without its point now in the past; tick 200 ms has none, yet keeps the channel."""
    kit = BagKit(tmp_path / "noplan")
    kit.odometry(0, x=0.0)
    kit.objects(0, x=50.0)
    kit.plan(0, np.array([[0.0, 0.0, 0.0], [1.0, 10.0, 0.0]]))
    for s in (100, 200):
        kit.odometry(s, x=s / 100)
        kit.objects(s, x=50.0 + s / 100)
    kit.close()
    reader, frames = frames_of(tmp_path / "noplan", mapping(with_plan=True))
    assert [f.channels["lav"].plan.tolist() for f in frames] == [
        [[0.0, 0.0, 0.0], [1.0, 10.0, 0.0]],
        [[0.9, 10.0, 0.0]],
        [],
    ]
    assert reader.dropouts == {"lav": 0}
    assert reader.topic_report()[TOPICS["plan"]]["missing_ticks"] == 1


def test_plans_without_times_are_timed_from_their_velocities(tmp_path: Path) -> None:
    """time_from_start all 0 (as several planners leave it): 10 m at a mean of 5 m/s is 2 s;
    the plan ends at the stop (velocity 0 from the third point on)."""
    kit = BagKit(tmp_path / "velo")
    build, store = kit.build, kit.store
    T = build.T
    pts = [
        T["autoware_planning_msgs/msg/TrajectoryPoint"](
            time_from_start=build.duration(0),
            pose=build.pose(x, 0.0, 0.0),
            longitudinal_velocity_mps=v,
            lateral_velocity_mps=0.0,
            acceleration_mps2=0.0,
            heading_rate_rps=0.0,
            front_wheel_angle_rad=0.0,
            rear_wheel_angle_rad=0.0,
        )
        for x, v in [(0.0, 4.0), (10.0, 6.0), (12.0, 0.0), (14.0, 0.0)]
    ]
    msg = T["autoware_planning_msgs/msg/Trajectory"](header=build.header(T0), points=pts)
    kit.odometry(0, x=0.0)
    kit.objects(0, x=50.0)
    kit.raw(
        TOPICS["plan"],
        "autoware_planning_msgs/msg/Trajectory",
        store.serialize_cdr(msg, "autoware_planning_msgs/msg/Trajectory"),
        T0,
    )
    kit.close()
    _, frames = frames_of(tmp_path / "velo", mapping(with_plan=True))
    # segments: 10 m at (4 + 6) / 2 = 5 m/s -> 2 s; 2 m at (6 + 0) / 2 = 3 m/s -> 2/3 s;
    # then 0 m/s: the plan stops at the third point
    np.testing.assert_allclose(
        frames[0].channels["lav"].plan,
        [[0.0, 0.0, 0.0], [2.0, 10.0, 0.0], [2.0 + 2 / 3, 12.0, 0.0]],
    )
    _, strict = frames_of(tmp_path / "velo", mapping(with_plan=True, plan_time="stamps"))
    assert "lav" not in strict[0].channels  # not increasing, and stamps were asked for


def test_late_messages_are_counted_and_their_ticks_go_without(tmp_path: Path) -> None:
    """The objects stamped 200 ms arrive at 1600 ms, after max_delay (1 s) had let ticks up to
    400 ms be built: tick 200 ms went with the 100 ms objects, and a late-message defect says
    so."""
    kit = BagKit(tmp_path / "late")
    events = [(s, "odometry", s) for s in stamps_every(100, 0, 2000)]
    events += [(s, "objects", s) for s in stamps_every(100, 0, 2000) if s != 200]
    events += [(1600, "objects", 200)]
    write_timeline(kit, events)
    kit.close()
    reader, frames = frames_of(tmp_path / "late")
    assert reader.dropouts == {"lav": 0}
    # the 100 ms objects (x = 51 m), moved on at their 5 m/s for 100 ms
    assert frames[2].t == 0.2 and frames[2].channels["lav"].objects.pos[0, 0] == 51.5
    assert [d.kind for d in reader.defects] == ["late-message"]
    assert reader.topic_report()[TOPICS["objects"]]["late_messages"] == 1


def test_header_stamps_of_zero_are_defects_and_receive_time_reads_them(tmp_path: Path) -> None:
    kit2 = BagKit(tmp_path / "zero2")  # stamps of 0 ns since 1970: not a time
    build, store = kit2.build, kit2.store
    for k in range(3):
        msg = build.odometry(0, ego_state(k))
        raw = store.serialize_cdr(msg, "nav_msgs/msg/Odometry")
        kit2.raw(TOPICS["odometry"], "nav_msgs/msg/Odometry", raw, T0 + 100 * k * MS)
        obj = build.objects(0, one_object(9))
        kit2.raw(
            TOPICS["objects"],
            "autoware_perception_msgs/msg/PredictedObjects",
            store.serialize_cdr(obj, "autoware_perception_msgs/msg/PredictedObjects"),
            T0 + 100 * k * MS,
        )
    kit2.close()
    m = LoadedMapping(
        TopicMapping.model_validate(
            {
                "ego": {"length": 4, "width": 2},
                "channels": {"lav": {"odometry": TOPICS["odometry"], "objects": TOPICS["objects"]}},
            }
        ),
        "m",
    )
    reader, frames = frames_of(tmp_path / "zero2", m)
    assert frames == [] and {d.kind for d in reader.defects} == {"bad-stamp"}
    assert len(reader.defects) == 6
    with pytest.raises(StreamError, match="bad-stamp"):
        frames_of(tmp_path / "zero2", m, strict=True)
    receive = LoadedMapping(m.mapping.model_copy(update={"time": "receive"}), "m")
    reader, frames = frames_of(tmp_path / "zero2", receive)
    assert [f.t for f in frames] == [0.0, 0.1, 0.2]
    assert [f.channels["lav"].ego.x for f in frames] == [0.0, 1.0, 2.0]


def test_a_stamp_from_another_clock_is_a_defect_not_hours_of_ticks(tmp_path: Path) -> None:
    kit = BagKit(tmp_path / "clock")
    for s in stamps_every(100, 0, 300):
        kit.odometry(s, x=s / 100)
        kit.objects(s, x=50.0)
    kit.odometry(2 * 3600 * 1000, x=9.0, log_ms=350)  # two hours ahead, recorded in line
    kit.close()
    reader, frames = frames_of(tmp_path / "clock")
    assert [f.t for f in frames] == [0.0, 0.1, 0.2, 0.3]
    assert [d.kind for d in reader.defects] == ["bad-stamp"]
    assert "stamped 7199.7 s after every message before it" in reader.defects[0].message


def test_signals_take_their_own_age_limit(tmp_path: Path) -> None:
    kit = BagKit(tmp_path / "signals")
    for s in stamps_every(100, 0, 1500):
        kit.odometry(s, x=s / 100)
        kit.objects(s, x=50.0)
        if s == 0:
            kit.scalar("/limits/speed", s, 13.9)
    kit.close()
    m = mapping(signals={"speed_limit": {"topic": "/limits/speed", "max_age": "1s"}})
    _, frames = frames_of(tmp_path / "signals", m)
    values = [f.signals["speed_limit"] for f in frames]
    assert values == [13.9] * 10 + [None] * 6  # fresh up to 0.9 s, then no value


# -- equivalence with the JSON Lines drive -------------------------------------------------------


@pytest.mark.parametrize("storage", ["mcap", "sqlite3"])
def test_a_bundled_drive_as_a_bag_gives_the_same_metrics(tmp_path: Path, storage: str) -> None:
    frames = list(itertools.islice(read_stream(DRIVE), 300))
    # a channel dropout the bag must reproduce: no messages for tfuse at frames 100-104
    for f in frames[100:105]:
        del f.channels["tfuse"]
    signals = sorted({k for f in frames for k in f.signals})
    m = TopicMapping.model_validate(
        default_mapping(["lav", "tfuse"], signals, 4.6, 1.9, period=0.1)
    )
    write_bag(frames, tmp_path / "drive", m, storage)
    reader = read_bag(tmp_path / "drive", LoadedMapping(m, "m"), ["lav", "tfuse"], 0.1)
    back = list(reader)
    assert reader.dropouts == {"lav": 0, "tfuse": 5} and reader.defects == []
    assert reader.header.meta["storage"] == storage
    case = require_case(ROOT / "examples" / "reference-case.yaml")
    ours = MetricEngine(case.monitor.metrics, ["lav", "tfuse"])
    theirs = MetricEngine(case.monitor.metrics, ["lav", "tfuse"])
    compared = 0
    for a, b in zip(frames, back, strict=True):
        assert b.t == a.t
        va, vb = ours.step(a), theirs.step(b)
        assert va.keys() == vb.keys()
        for name, x in va.items():
            y = vb[name]
            assert (x is None) == (y is None), (a.t, name, x, y)
            if x is not None:
                assert y == pytest.approx(x, rel=1e-9, abs=1e-9), (a.t, name)
                compared += 1
    assert compared > 20_000
    assert sum(1 for f in back if "tfuse" not in f.channels) == 5


def test_a_bare_mcap_file_reads_like_its_folder(tmp_path: Path) -> None:
    frames = list(itertools.islice(read_stream(DRIVE), 30))
    m = TopicMapping.model_validate(default_mapping(["lav", "tfuse"], [], 4.6, 1.9))
    write_bag(frames, tmp_path / "drive", m, "mcap")
    bare = tmp_path / "drive.mcap"
    shutil.copy(tmp_path / "drive" / "drive.mcap", bare)
    kinds = [source_kind(bare), source_kind(tmp_path / "drive"), source_kind(DRIVE)]
    assert kinds == ["bag", "bag", "stream"]
    a = list(read_bag(bare, LoadedMapping(m, "m"), ["lav", "tfuse"], 0.1))
    b = list(read_bag(tmp_path / "drive", LoadedMapping(m, "m"), ["lav", "tfuse"], 0.1))
    assert [f.t for f in a] == [f.t for f in b] == [f.t for f in frames]
    assert [f.channels["lav"].ego.x for f in a] == [f.channels["lav"].ego.x for f in frames]


# -- bags and mappings that cannot be used -------------------------------------------------------


@pytest.fixture
def small_bag(tmp_path: Path) -> Path:
    kit = BagKit(tmp_path / "small")
    for s in stamps_every(100, 0, 500):
        kit.odometry(s, x=s / 100)
        kit.objects(s, x=50.0)
    return kit.close()


def test_a_mapped_topic_missing_from_the_bag_is_an_error_listing_the_topics(
    small_bag: Path,
) -> None:
    m = mapping(channels={"lav": {"odometry": TOPICS["odometry"], "objects": "/lav/objects_typo"}})
    with pytest.raises(BagError) as err:
        read_bag(small_bag, m, ["lav"], 0.1)
    text = str(err.value)
    assert "/lav/objects_typo" in text and "are not in the bag" in text
    assert f"{TOPICS['odometry']}  (nav_msgs/msg/Odometry)" in text


def test_a_topic_of_the_wrong_type_is_an_error(small_bag: Path) -> None:
    m = mapping(channels={"lav": {"odometry": TOPICS["objects"], "objects": TOPICS["objects"]}})
    with pytest.raises(
        BagError,
        match=r"carries autoware_perception_msgs/msg/PredictedObjects; "
        r"as the odometry of a channel it must carry "
        r"nav_msgs/msg/Odometry",
    ):
        read_bag(small_bag, m, ["lav"], 0.1)


def test_an_unknown_message_type_is_an_error(tmp_path: Path) -> None:
    kit = BagKit(tmp_path / "unknown")
    kit.odometry(0, x=0.0)
    kit.objects(0, x=1.0)
    kit.raw(
        "/lav/speed",
        "acme_msgs/msg/Speed",
        b"\x00\x01\x00\x00\x00\x00\x00\x00",
        T0,
        msgdef="",
        rihs01="RIHS01_" + "0" * 64,
    )
    kit.close()
    m = mapping(signals={"speed": "/lav/speed"})
    with pytest.raises(BagError, match="acme_msgs/msg/Speed, an unknown message type"):
        read_bag(tmp_path / "unknown", m, ["lav"], 0.1)


def test_a_mapping_must_cover_exactly_the_case_channels(small_bag: Path) -> None:
    with pytest.raises(BagError, match="the case's channel\\(s\\) tfuse have no topics"):
        read_bag(small_bag, mapping(), ["lav", "tfuse"], 0.1)
    with pytest.raises(BagError, match="channel\\(s\\) lav are not channels of the case"):
        read_bag(small_bag, mapping(), ["front"], 0.1)


def test_not_a_bag_is_a_clear_error(tmp_path: Path) -> None:
    fake = tmp_path / "fake.mcap"
    fake.write_bytes(b"this is not an mcap file at all")
    with pytest.raises(BagError, match="cannot open as a ROS 2 bag"):
        read_bag(fake, mapping(), ["lav"], 0.1)
    with pytest.raises(BagError, match="no such bag"):
        read_bag(tmp_path / "absent.mcap", mapping(), ["lav"], 0.1)


def _cut(tmp_path: Path, storage: str, share: float, frames: int = 200):
    drive = list(itertools.islice(read_stream(DRIVE), frames))
    m = TopicMapping.model_validate(default_mapping(["lav", "tfuse"], [], 4.6, 1.9))
    write_bag(drive, tmp_path / "drive", m, storage)
    store = next((tmp_path / "drive").glob("*.mcap" if storage == "mcap" else "*.db3"))
    data = store.read_bytes()
    store.write_bytes(data[: int(len(data) * share)])
    return tmp_path / "drive", LoadedMapping(m, "m"), drive


def test_an_mcap_recording_cut_short_is_judged_up_to_the_break(tmp_path: Path) -> None:
    """A recorder killed mid-drive leaves an MCAP file without its end (no footer, no index):
    the frames up to the break are read and the break is a truncated-bag defect."""
    bag, m, drive = _cut(tmp_path, "mcap", 0.5)
    reader = read_bag(bag, m, ["lav", "tfuse"], 0.1)
    back = list(reader)
    assert 0.3 * len(drive) < len(back) < len(drive)
    assert [d.kind for d in reader.defects] == ["truncated-bag"]
    assert "ends inside a record" in reader.defects[0].message
    assert reader.header.meta["recovered"].startswith("read record by record")
    for a, b in zip(drive, back[:-1], strict=False):  # the last tick may miss the cut topic
        assert b.channels["lav"].ego.x == a.channels["lav"].ego.x
    with pytest.raises(BagError, match="cut short before it names topic"):
        read_bag(*_cut(tmp_path / "early", "mcap", 0.02)[:2], ["lav", "tfuse"], 0.1)


def test_a_cut_sqlite3_bag_is_a_clear_error(tmp_path: Path) -> None:
    bag, m, _ = _cut(tmp_path, "sqlite3", 0.5)
    with pytest.raises(BagError, match=r"cannot open as a ROS 2 bag .* malformed"):
        read_bag(bag, m, ["lav", "tfuse"], 0.1)


def test_a_corrupt_message_is_a_defect_and_a_dropout(tmp_path: Path) -> None:
    kit = BagKit(tmp_path / "corrupt")
    for s in stamps_every(100, 0, 300):
        kit.odometry(s, x=s / 100)
        if s == 200:
            good = kit.store.serialize_cdr(
                kit.build.objects(T0 + 200 * MS, one_object(1.0)),
                "autoware_perception_msgs/msg/PredictedObjects",
            )
            kit.raw(
                TOPICS["objects"],
                "autoware_perception_msgs/msg/PredictedObjects",
                good[:40],
                T0 + 200 * MS,
            )
        else:
            kit.objects(s, x=50.0)
    kit.close()
    reader, frames = frames_of(tmp_path / "corrupt")
    assert ["lav" in f.channels for f in frames] == [True, True, False, True]
    assert [d.kind for d in reader.defects] == ["bad-message"]
    message = reader.defects[0].message
    assert "cannot decode autoware_perception_msgs/msg/PredictedObjects" in message


# -- the mapping file ---------------------------------------------------------------------------


def test_mapping_errors_name_file_line_and_key(tmp_path: Path) -> None:
    path = tmp_path / "topics.yaml"
    path.write_text(
        "ego: {length: 4.6, width: 1.9}\nchannels:\n  lav:\n    odometry: /odom\n"
        "    objectz: /objects\n",
        encoding="utf-8",
    )
    with pytest.raises(MappingError) as err:
        load_mapping(path)
    assert str(err.value).startswith(f"{path}:3: channels.lav.objects: required here")
    path.write_text(
        "ego: {length: -1, width: 1.9}\nchannels: {lav: {odometry: a, objects: b}}\n",
        encoding="utf-8",
    )
    with pytest.raises(MappingError, match=r":1: ego.length: Input should be greater than 0"):
        load_mapping(path)
    path.write_text(
        "ego: {length: 4, width: 2}\nchannels: {lav: {odometry: a, objects: b}}\nmax_age: soon\n",
        encoding="utf-8",
    )
    with pytest.raises(MappingError, match=r":3: max_age: "):
        load_mapping(path)


def test_mapping_defaults_and_durations(tmp_path: Path) -> None:
    path = tmp_path / "topics.yaml"
    path.write_text(
        "ego: {length: 4.6, width: 1.9}\nmax_age: 150ms\nchannels:\n"
        "  lav: {odometry: /o, objects: {topic: /b, max_age: 0.3s}, plan: /p}\n",
        encoding="utf-8",
    )
    m = load_mapping(path).mapping
    lav = m.channels["lav"]
    assert m.age_limit(lav.objects, 0.1) == pytest.approx(0.3)
    assert m.age_limit(lav.odometry, 0.1) == pytest.approx(0.15)
    bare = TopicMapping.model_validate(
        {"ego": {"length": 4, "width": 2}, "channels": {"lav": {"odometry": "/o", "objects": "/b"}}}
    )
    assert bare.age_limit(bare.channels["lav"].odometry, 0.1) == pytest.approx(0.15)
    assert bare.time == "header" and bare.max_delay == 1.0 and bare.plan_time == "auto"
