"""Traces for the compiled spec: every path from a formula's node up to the root goal.

One definition of a trace exists, `safety_case.trace.traces_to_root`; this only turns its
paths into the serialisable steps the compiled spec carries.
"""

from __future__ import annotations

from casewatch.safety_case.model import Case
from casewatch.safety_case.trace import traces_to_root
from casewatch.spec.model import TraceStep


def traces_for(case: Case, node_id: str) -> list[list[TraceStep]]:
    """Every path from `node_id` to the root, node first, as serialisable steps."""
    return [[TraceStep(id=i, text=t) for i, t in path] for path in traces_to_root(case, node_id)]
