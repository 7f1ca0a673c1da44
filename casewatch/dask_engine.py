"""Fleets on Dask: one task per log on a `distributed` cluster (`casewatch run --engine dask`).

With no scheduler address a `LocalCluster` of `workers` single-threaded worker processes runs on
this machine; with `--scheduler tcp://HOST:PORT` any Dask cluster does. Each task is
`casewatch.shipping.run_task` (`casewatch.batch.run_job` where the worker shares the file
system): the log's results are written exactly as with `--jobs`, and the summary is aggregated
by `batch.run_many`. Every fault ends as a per-log entry, never a lost fleet:

- before the fleet starts, every worker checks it can read the case and each log (and write the
  output folder) at the absolute paths it is sent: a clear `EngineError` names the path and the
  worker otherwise;
- a worker that dies under a task is restarted by its nanny and the task runs again; a log that
  kills its worker every time is a failed entry after the scheduler's allowed failures, and the
  other logs are judged;
- each finished task's value is taken and its future released at once, so a worker lost later
  never makes the scheduler judge a written log again;
- a lost scheduler ends the fleet with the unfinished logs as failed entries (`batch.FleetLost`,
  exit 2), and `--resume` after a restart judges only those.
"""

from __future__ import annotations

import contextlib
import logging
import os
import uuid
from collections.abc import Callable, Iterator

from casewatch.batch import Job, Runner
from casewatch.errors import CasewatchError
from casewatch.evaluator.summary import LogSummary
from casewatch.shipping import receive, run_task, ship, written_summary

#: Times a task that raised is retried (run_task never raises: this covers Dask's own errors).
RETRIES = 3

#: Deaths of a task's worker before a LocalCluster gives the log up (Dask's default); an
#: external cluster uses its scheduler's `distributed.scheduler.allowed-failures`.
ALLOWED_FAILURES = 3

#: Seconds an external scheduler has to show its first worker.
WORKER_WAIT_S = 30


class EngineError(CasewatchError, RuntimeError):
    """The distributed engine is not available, the scheduler cannot be reached, or a worker
    cannot see the files it is sent."""


def dask_runner(workers: int, scheduler: str | None = None, ship_mib: float = 0.0) -> Runner:
    """A `batch.Runner` for Dask: a LocalCluster of `workers` (no `scheduler`) or the cluster
    at `scheduler`; logs of at most `ship_mib` MiB are shipped with their tasks."""

    def run(work: list[Job], finished: Callable[[int, LogSummary], None]) -> str | None:
        return run_on_dask(work, workers, scheduler, finished, ship_mib)

    return run


def run_on_dask(
    work: list[Job],
    workers: int,
    scheduler: str | None,
    finished: Callable[[int, LogSummary], None],
    ship_mib: float = 0.0,
) -> str | None:
    """Every job as a task; `finished(i, summary)` as each ends (its files written). Returns
    None, or the one-line reason the scheduler was lost before every job finished."""
    try:
        from distributed import as_completed
        from distributed.client import FutureCancelledError
        from distributed.scheduler import KilledWorker
    except ImportError:
        raise EngineError(
            "--engine dask needs Dask's distributed scheduler: pip install 'casewatch[fleet]'"
        ) from None
    if not work:
        return None
    sent = [ship(job, int(ship_mib * 2**20)) for job in work]
    where = scheduler or "local cluster"
    with contextlib.ExitStack() as stack:
        stack.enter_context(_quiet_dask())
        client = _client(stack, workers, scheduler)
        check_workers(client, sent)
        fleet = uuid.uuid4().hex  # this run of the fleet (shipping.TASK_FILE)
        futures = client.map(run_task, sent, fleet=fleet, retries=RETRIES, pure=False)
        index = {f.key: k for k, f in enumerate(futures)}
        pending = as_completed(futures)
        reported: set[int] = set()
        del futures  # as_completed holds them until each is yielded, then it is released
        try:
            for future in pending:
                k = index[future.key]
                try:
                    value = future.result()
                except KilledWorker as exc:
                    summary = killed(work[k], exc.allowed_failures + 1)
                else:
                    summary = receive(work[k], value)
                finally:
                    future.release()  # the scheduler forgets it: never recomputed
                reported.add(k)
                finished(k, summary)
        except (FutureCancelledError, OSError, TimeoutError) as exc:
            _close_now(client)
            for k, job in enumerate(work):  # finished and written, but not yet reported
                if k not in reported:
                    written = written_summary(job, fleet)
                    if written is not None:
                        finished(k, written)
            return f"the Dask scheduler ({where}) was lost ({type(exc).__name__})"
    return None


def killed(job: Job, tries: int) -> LogSummary:
    """The failed entry of a log whose worker died under it on every try."""
    return LogSummary(
        stream=job.stream,
        out_dir=job.out_dir,
        ok=False,
        error=f"failed after {tries} tries: the worker judging this log died each time "
        "(killed, out of memory, or a crash in native code); the other logs were judged",
    )


def _client(stack: contextlib.ExitStack, workers: int, scheduler: str | None):
    """A client of the scheduler at `scheduler` (with at least one worker), or of a new
    LocalCluster of `workers` forked single-threaded workers."""
    import dask
    from distributed import Client, LocalCluster

    if scheduler:
        try:
            client = stack.enter_context(Client(scheduler, timeout="10s"))
        except (OSError, TimeoutError) as exc:
            raise EngineError(f"cannot reach the Dask scheduler {scheduler}: {exc}") from None
        try:
            client.wait_for_workers(1, timeout=WORKER_WAIT_S)
        except (OSError, TimeoutError):
            raise EngineError(
                f"the Dask scheduler {scheduler} has no worker (none joined in "
                f"{WORKER_WAIT_S} s): start `dask worker {scheduler} --nthreads 1` on the "
                "machines (docs/fleet.md)"
            ) from None
        return client
    from casewatch.monitor.warmup import warm_up

    # Local workers fork from this process after it has imported casewatch and loaded its
    # compiled kernels (as --jobs does), instead of spawning fresh interpreters that import
    # and load everything again (about 5 s per run on 2 cores).
    warm_up()
    stack.enter_context(
        dask.config.set(
            {
                "distributed.worker.multiprocessing-method": "fork",
                # the statistical profiler samples the task thread every 10 ms: about a
                # tenth of the throughput of these CPU-bound tasks
                "distributed.worker.profile.enabled": False,
                "distributed.scheduler.allowed-failures": ALLOWED_FAILURES,
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
                silence_logs=logging.ERROR,
                memory_limit=0,
                host="127.0.0.1",
            )
        )
    except RuntimeError as exc:  # distributed: "Nanny failed to start."
        raise EngineError(
            f"the local Dask cluster of {workers} worker(s) did not start ({exc}): a worker "
            "process died while starting; run again, or use --engine processes"
        ) from None
    return stack.enter_context(Client(cluster))


def unreadable(paths: list[str], folders: list[str]) -> list[str]:
    """Run on a worker: what of `paths` it cannot read and of `folders` it cannot create or
    write (the nearest existing parent must be writable), each as `PATH (why)`."""
    problems = []
    for path in paths:
        try:
            if os.path.isdir(path):
                os.listdir(path)
            else:
                with open(path, "rb") as fh:
                    fh.read(1)
        except OSError as exc:
            problems.append(f"cannot read {path} ({exc.strerror or exc})")
    for folder in folders:
        existing = folder
        while not os.path.exists(existing) and os.path.dirname(existing) != existing:
            existing = os.path.dirname(existing)
        if not os.access(existing, os.W_OK | os.X_OK):
            problems.append(f"cannot write {folder} ({existing} is not writable)")
    return problems


def check_workers(client, jobs: list[Job]) -> None:
    """Every connected worker can read the case and each log that is not shipped, and write
    the output folders; otherwise an `EngineError` naming the first path and its worker."""
    paths: dict[str, None] = {}
    folders: dict[str, None] = {}
    for job in jobs:
        paths[job.case_path] = None
        if job.options.topics:
            paths[job.options.topics] = None
        if not job.shipped:
            paths[job.stream] = None
            if job.options.labels:
                paths[job.options.labels] = None
            folders[os.path.dirname(job.out_dir)] = None
    found = client.run(unreadable, list(paths), list(folders))
    for worker, problems in sorted(found.items()):
        if problems:
            more = f" (and {len(problems) - 1} more)" if len(problems) > 1 else ""
            raise EngineError(
                f"Dask worker {worker} {problems[0]}{more}: every worker needs the case, the "
                "logs and the output folder at the same absolute paths as here (a shared file "
                "system), or --ship-logs MIB to send logs up to that size with their tasks "
                "(docs/fleet.md)"
            )


@contextlib.contextmanager
def _quiet_dask() -> Iterator[None]:
    """Dask's own log lines and tracebacks off while the fleet runs: what goes wrong reaches
    the user as failed entries and one line, not as 40 lines of another program's internals."""
    names = ["distributed", "tornado", "asyncio"]
    names += [n for n in logging.root.manager.loggerDict if n.startswith("distributed.")]
    loggers = [logging.getLogger(n) for n in names]
    levels = [lg.level for lg in loggers]
    for lg in loggers:
        lg.setLevel(logging.CRITICAL + 1)
    try:
        yield
    finally:
        for lg, level in zip(loggers, levels, strict=True):
            lg.setLevel(level)


def _close_now(client) -> None:
    """Close a client whose scheduler is gone without waiting out its reconnection attempts."""
    with contextlib.suppress(Exception):
        client.close(timeout=2)
