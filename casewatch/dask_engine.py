"""Fleets on Dask: one task per log on a `distributed` cluster (`casewatch run --engine dask`).

With no scheduler address a `LocalCluster` of `workers` single-threaded worker processes runs on
this machine; with `--scheduler tcp://HOST:PORT` any Dask cluster does (its workers need
casewatch installed and the logs and output folder at the same paths). Each task is
`casewatch.batch.run_job`: the log's results are written by the worker exactly as with
`--jobs`, and the summary is aggregated here. Dask retries a task whose worker died (the nanny
restarts it); a bad log is a failed summary, never a lost one.
"""

from __future__ import annotations

import contextlib
from collections.abc import Callable, Sequence
from typing import Any

from casewatch.errors import CasewatchError
from casewatch.evaluator.summary import LogSummary

#: Times a task is retried when its worker dies under it.
RETRIES = 3


class EngineError(CasewatchError, RuntimeError):
    """The distributed engine is not available or the scheduler cannot be reached."""


def run_on_dask(
    task: Callable[[Any], LogSummary],
    jobs: Sequence,
    workers: int,
    scheduler: str | None,
    on_done: Callable[[LogSummary], None] | None = None,
) -> list[LogSummary]:
    """`task` (`casewatch.batch.run_job`, passed in: this module never imports the batch
    module that calls it) over every job as a Dask task; summaries in job order."""
    try:
        from distributed import Client, LocalCluster, as_completed
    except ImportError:
        raise EngineError(
            "--engine dask needs Dask's distributed scheduler: pip install 'casewatch[fleet]'"
        ) from None
    with contextlib.ExitStack() as stack:
        if scheduler:
            try:
                client = stack.enter_context(Client(scheduler, timeout="10s"))
            except (OSError, TimeoutError) as exc:
                raise EngineError(f"cannot reach the Dask scheduler {scheduler}: {exc}") from None
        else:
            import dask

            from casewatch.monitor.warmup import warm_up

            # Local workers fork from this process after it has imported casewatch and loaded
            # its compiled kernels (as --jobs does), instead of spawning fresh interpreters
            # that import and load everything again (about 5 s per run on 2 cores).
            warm_up()
            stack.enter_context(
                dask.config.set(
                    {
                        "distributed.worker.multiprocessing-method": "fork",
                        # the statistical profiler samples the task thread every 10 ms:
                        # about a tenth of the throughput of these CPU-bound tasks
                        "distributed.worker.profile.enabled": False,
                    }
                )
            )
            try:
                cluster = stack.enter_context(
                    LocalCluster(
                        n_workers=workers,
                        threads_per_worker=1,
                        processes=True,
                        dashboard_address=None,
                        silence_logs=40,
                        memory_limit=0,
                    )
                )
            except RuntimeError as exc:  # distributed: "Nanny failed to start."
                raise EngineError(
                    f"the local Dask cluster of {workers} worker(s) did not "
                    f"start ({exc}): a worker process died while starting; "
                    "run again, or use --engine processes"
                ) from None
            client = stack.enter_context(Client(cluster))
        futures = client.map(task, list(jobs), retries=RETRIES, pure=False)
        index = {f.key: k for k, f in enumerate(futures)}
        results: list[LogSummary | None] = [None] * len(futures)
        for future in as_completed(futures):
            summary = future.result()
            results[index[future.key]] = summary
            if on_done is not None:
                on_done(summary)
    return [r for r in results if r is not None]
