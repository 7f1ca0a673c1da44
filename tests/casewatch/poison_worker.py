"""Preloaded into the test cluster's Dask workers (`dask worker --preload`): a log whose file
name starts with `poison` kills the worker process that takes it (`os._exit`), the way a log that
crashes its worker would, every time it is tried. The shipped code has no hook for this: the
preload wraps the function the tasks call, in the worker process only."""

from __future__ import annotations

import os
from pathlib import Path

from casewatch import batch, shipping


def _run_job(job: batch.Job, recorded: batch.Job | None = None) -> batch.LogSummary:
    if Path(job.stream).name.startswith("poison"):
        os._exit(70)
    return _judge(job, recorded)


# Dask may run a preload more than once in a process (nanny and worker): wrap only once.
_judge = getattr(batch.run_job, "__wrapped__", batch.run_job)
_run_job.__wrapped__ = _judge  # type: ignore[attr-defined]
batch.run_job = _run_job
shipping.run_job = _run_job
