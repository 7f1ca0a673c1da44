"""Progress of `casewatch run` on the terminal, and nothing anywhere else.

tqdm draws the bars: it redraws one line in place, rate-limits its updates and knows the
terminal's width, which the hand-written `\\r` lines it replaces did not. The bars exist only
when standard error is a terminal: a log file or a CI job gets no carriage returns and no
partial lines, only the per-log lines (`FleetProgress.log`).
"""

from __future__ import annotations

import sys
from types import TracebackType

from tqdm import tqdm


def on_terminal() -> bool:
    """Standard error is an interactive terminal."""
    try:
        return sys.stderr.isatty()
    except (AttributeError, ValueError):  # replaced or closed stderr
        return False


class _Bar:
    def __init__(self, enabled: bool, **options: object) -> None:
        self.bar = tqdm(
            file=sys.stderr,
            disable=not (enabled and on_terminal()),
            leave=False,
            dynamic_ncols=True,
            **options,
        )

    def __enter__(self):
        return self

    def __exit__(
        self, kind: type[BaseException] | None, exc: BaseException | None, tb: TracebackType | None
    ) -> None:
        self.bar.close()  # erases the bar (leave=False): the summary lines follow cleanly


class StreamProgress(_Bar):
    """One stream: frames read and stream time, e.g. `1200 frames [00:04, 290 frames/s, t =
    119.9 s]`; `update` is `RunOptions.progress`."""

    def __init__(self, enabled: bool) -> None:
        super().__init__(enabled, unit=" frames", desc="  judging")

    def update(self, frames: int, t: float) -> None:
        if self.bar.disable:
            return
        self.bar.set_postfix_str(f"t = {t:.1f} s", refresh=False)
        self.bar.update(frames - self.bar.n)


class FleetProgress(_Bar):
    """Many logs: logs done of all, hours judged and the time left, above the per-log lines."""

    def __init__(self, logs: int, enabled: bool) -> None:
        super().__init__(enabled, total=logs, unit=" logs", desc="  fleet")
        self.hours = 0.0

    def advance(self, hours: float) -> None:
        self.hours += hours
        if self.bar.disable:
            return
        self.bar.set_postfix_str(f"{self.hours:.3f} h judged", refresh=False)
        self.bar.update(1)

    def resumed(self) -> None:
        """A log reused by `--resume`: no longer to do, and no judged hours (the rate and the
        time left count only the logs judged in this run)."""
        if self.bar.total is not None:
            self.bar.total -= 1
        self.bar.refresh()

    def log(self, line: str) -> None:
        """A line on standard error that the bar, when there is one, is redrawn below."""
        if self.bar.disable:
            print(line, file=sys.stderr, flush=True)
        else:
            self.bar.write(line, file=sys.stderr)
