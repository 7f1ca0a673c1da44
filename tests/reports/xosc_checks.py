"""Checks shared by the scenario tests and `bench/scenario_replay.py`: a file is valid
OpenSCENARIO 1.2 (XSD and ASAM checker), and an export replays as recorded (`xosc_replay`)."""

from __future__ import annotations

import json
from pathlib import Path

from casewatch.monitor.reader import read_stream
from tests.reports.xosc_replay import ReplayCheck, check_replay, stream_state


def assert_valid_openscenario(path: Path) -> None:
    """`path` validates against the OpenSCENARIO 1.2 XSD and passes the ASAM checker bundle
    with 0 issues, its schema check having run (not been skipped)."""
    import qc_openscenario
    import xmlschema
    from qc_baselib import Configuration, Result, StatusType
    from qc_openscenario import constants
    from qc_openscenario.main import run_checks

    xsd = Path(qc_openscenario.__file__).parent / "schema" / "1.2.0" / "OpenSCENARIO.xsd"
    schema = xmlschema.XMLSchema(str(xsd))
    assert list(schema.iter_errors(str(path))) == [], path.name
    config = Configuration()
    config.set_config_param("InputFile", str(path))
    result = Result()
    result.register_checker_bundle(
        name=constants.BUNDLE_NAME, description="", version=constants.BUNDLE_VERSION, summary=""
    )
    result.set_result_version(version=constants.BUNDLE_VERSION)
    run_checks(config, result)
    checks = result.get_checker_results(constants.BUNDLE_NAME)
    assert all(c.status != StatusType.ERROR for c in checks), path.name
    assert result.get_checker_bundle_issue_count(constants.BUNDLE_NAME) == 0, path.name
    ran = {c.checker_id for c in checks if c.status == StatusType.COMPLETED}
    assert "check_asam_xosc_xml_valid_schema" in ran


def replay_checks(stream: Path, out: Path, waiting: bool = False) -> list[tuple[dict, ReplayCheck]]:
    """Every file of an export checked against the stream it came from."""
    catalogue = json.loads((out / "scenarios.json").read_text())["scenarios"]
    frames = list(read_stream(stream))
    checks = []
    for c in catalogue:
        t0, t1 = c["window"]
        seen = [
            (round(f.t - t0, 6), stream_state(f.channels[c["channel"]]))
            for f in frames
            if t0 - 1e-9 <= f.t <= t1 + 1e-9 and c["channel"] in f.channels
        ]
        checks.append((c, check_replay(out / c["file"], seen, waiting)))
    return checks


def assert_replays_as_recorded(checks: list[tuple[dict, ReplayCheck]], samples: int) -> None:
    """No new contact, presence exactly as observed, positions within 1 mm, and at least
    `samples` instants sampled (frames and halfway between them) over all files."""
    for c, check in checks:
        assert check.new_contacts == [], (c["file"], check.new_contacts[:5])
        assert check.presence_errors == [], (c["file"], check.presence_errors[:3])
        assert check.max_position_error <= 0.001, c["file"]
    assert sum(check.samples for _, check in checks) >= samples
