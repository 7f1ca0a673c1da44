"""`casewatch run`'s progress: tqdm bars on a terminal, and not one carriage return in a log."""

from __future__ import annotations

import functools
import io
import shutil

from tqdm import tqdm

from casewatch import progress
from casewatch.cli import main
from tests.evaluator.streams import write_case, write_stream


def test_no_carriage_return_when_stderr_is_not_a_terminal(tmp_path, capsys):
    case = write_case(tmp_path / "case.yaml")
    (tmp_path / "logs").mkdir()
    stream = write_stream(tmp_path / "logs" / "one.jsonl", frames=100)
    shutil.copy(stream, tmp_path / "logs" / "two.jsonl")
    assert main(["run", str(case), str(stream), "-o", str(tmp_path / "one")]) == 1
    err = capsys.readouterr().err
    assert "\r" not in err and "frames [" not in err
    assert main(["run", str(case), str(tmp_path / "logs"), "-o", str(tmp_path / "fleet")]) == 1
    err = capsys.readouterr().err
    assert "\r" not in err and "logs [" not in err
    assert "one.jsonl: 100 frames" in err and "two.jsonl: 100 frames" in err  # per-log lines


def test_on_a_terminal_the_bars_count_frames_and_logs(monkeypatch):
    terminal = io.StringIO()
    monkeypatch.setattr(progress, "on_terminal", lambda: True)
    monkeypatch.setattr(progress, "tqdm", functools.partial(tqdm, mininterval=0, miniters=1))
    monkeypatch.setattr("sys.stderr", terminal)
    with progress.StreamProgress(enabled=True) as bar:
        bar.update(120, 11.9)
        bar.update(240, 23.9)
    with progress.FleetProgress(2, enabled=True) as fleet:
        fleet.log("  one.jsonl: 100 frames, undermined")
        fleet.advance(0.25)
        fleet.advance(0.5)
    shown = terminal.getvalue()
    assert "240 frames" in shown and "t = 23.9 s" in shown
    assert "2/2" in shown and "0.750 h judged" in shown
    assert "  one.jsonl: 100 frames, undermined\n" in shown
    # --quiet (enabled=False) draws nothing even on a terminal
    quiet = io.StringIO()
    monkeypatch.setattr("sys.stderr", quiet)
    with progress.StreamProgress(enabled=False) as bar:
        bar.update(10, 1.0)
    assert quiet.getvalue() == ""
