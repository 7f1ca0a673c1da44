"""The one base of every error casewatch raises on purpose, and the exit codes they map to.

Every layer raises its own subclass (a `CaseError` names the YAML line, a `StreamError` the
frame, a `BagError` the topic...), so a caller that only wants "did casewatch refuse this
input?" catches `CasewatchError`, and the command line turns any of them that reaches it into
one line on stderr and the subclass's `exit_code`, never a traceback. An exception that is not a
`CasewatchError` is a bug (exit 3, `casewatch/crash.py`).

This module sits below every layer (it imports nothing of casewatch), so the lowest layer,
`casewatch.safety_case`, can use it as freely as the front door.
"""

from __future__ import annotations

from typing import ClassVar

#: The exit codes every command shares (README.md, "Exit codes").
EXIT_OK = 0
EXIT_FINDINGS = 1  # violations, findings, a damaged log
EXIT_UNUSABLE = 2  # usage or input that cannot be used
EXIT_BUG = 3  # an internal error: a bug in casewatch
EXIT_ENGINES_DISAGREE = 4  # `run --stl-engine both`: rtamt and numpy disagree


class CasewatchError(Exception):
    """An input or a request casewatch refuses, with a message that says what to change.

    Subclasses set `exit_code` when refusing means something other than "unusable input"."""

    exit_code: ClassVar[int] = EXIT_UNUSABLE
