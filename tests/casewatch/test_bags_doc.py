"""docs/bags.md: its example mapping is valid and its quick start runs as written."""

from __future__ import annotations

import json
import re
import shlex
from pathlib import Path

import pytest

from casewatch.cli import main
from casewatch.monitor.bags.mapping import load_mapping
from casewatch.monitor.bags.reader import BagReader

REPO = Path(__file__).resolve().parents[2]
DOC = (REPO / "docs" / "bags.md").read_text()


def test_the_example_mapping_loads(tmp_path: Path) -> None:
    block = re.search(r"```yaml\n(\s*# topics.yaml.*?)```", DOC, re.S).group(1)
    path = tmp_path / "topics.yaml"
    path.write_text("\n".join(line[3:] for line in block.splitlines()))  # the list indent
    m = load_mapping(path).mapping
    assert list(m.channels) == ["lav", "tfuse"]
    assert m.age_limit(m.channels["tfuse"].objects, 0.1) == pytest.approx(0.15)
    assert m.signals["speed_limit"].max_age == 1.0 and m.coverage["tfuse"].range_m == 70


def test_the_quick_start_runs(tmp_path: Path, monkeypatch: pytest.MonkeyPatch) -> None:
    block = re.search(r"## Try it on a bundled drive.*?```bash\n(.*?)```", DOC, re.S).group(1)
    commands = [shlex.split(c) for c in block.replace("\\\n", " ").splitlines() if c.strip()]
    assert [c[:2] for c in commands] == [
        [".venv/bin/casewatch", "convert"],
        [".venv/bin/casewatch", "run"],
    ]
    for example in ("examples",):
        (tmp_path / example).symlink_to(REPO / example)
    monkeypatch.chdir(tmp_path)
    assert main(commands[0][1:]) == 0
    assert main([*commands[1][1:], "--format", "none", "--quiet"]) == 1  # it has hazards
    result = json.loads((tmp_path / "out/bag-demo/result/result.json").read_text())
    assert result["stream"]["frames_read"] == 1201 and result["stream"]["defect_count"] == 0


def test_every_bag_defect_kind_is_documented() -> None:
    for kind in BagReader.DEFECT_KINDS:
        assert f"| `{kind}` |" in DOC, kind
