"""`casewatch warm-up`: compile every numba kernel into numba's cache, once per install.

Why: the metric kernels, the compiled frame reader, the ROS 2 bag decoder and the whole-log STL
engine's window loops are numba-compiled. A machine's first run compiles them (about 40 s of
CPU on the project's machine, most of it numba's own typing and lowering, in Python, so
compiler options do not shorten it); every later process loads them from the cache in about a
second. Installing with `make venv` runs this command, and after `pip install casewatch` a
user runs it once, so that the first real run starts in about a second instead of compiling.

The cache is the one every run reads: beside the installed modules (`__pycache__`) when that is
writable, else numba's per-user cache folder, or `NUMBA_CACHE_DIR` when set. numba checks each
entry against its source file's time stamp, so reinstalling or editing casewatch makes it
compile again, once: run this again after an upgrade. Running it with a filled cache only loads
(about a second) and says so.

It also writes the package's Python bytecode (`__pycache__/*.pyc`, `compileall`). Python does
that itself on a first import, except where it may not: a read-only install, or
`PYTHONDONTWRITEBYTECODE` set (common in containers and CI images). There every process
compiled the package's modules from source again, about a quarter of a second before the
first frame (measured, issue 36).
"""

from __future__ import annotations

import argparse
import sys
import time
from dataclasses import dataclass, field
from typing import Any

import numpy as np
from numba.core import event
from numba.core.dispatcher import Dispatcher

HELP = "fill numba's cache with the compiled kernels, once after installing or upgrading"


def register(subparsers: argparse._SubParsersAction) -> None:
    parser = subparsers.add_parser(
        "warm-up",
        help=HELP,
        description="Compile (or load, when the cache is filled) every numba kernel casewatch "
        "runs: the metrics, the ROS 2 bag decoder and the whole-log STL engine, into numba's "
        "cache, which every later run reads. Run once after installing or upgrading casewatch "
        "(make venv does); a first run then loads them in about a second instead of "
        "compiling them for up to a minute. Exit 0.",
    )
    parser.add_argument(
        "--quiet", action="store_true", help="print nothing (the exit code says it worked)"
    )


def main(args: argparse.Namespace) -> int:
    start = time.perf_counter()
    counter = _CompileCounter()
    with event.install_listener("numba:compile", counter):
        warm_up_all()
    write_bytecode()
    seconds = time.perf_counter() - start
    if not args.quiet:
        loaded, folders = _cache_use()
        where = ", ".join(sorted(folders)) or "none (caching unavailable)"
        print(
            f"casewatch warm-up: kernels ready in {seconds:.1f} s: {len(counter.compiled)} "
            f"variants compiled, {loaded} loaded from the cache (numba cache: {where})",
            file=sys.stderr,
        )
    return 0


def warm_up_all() -> None:
    """Every kernel a run may take, in the argument types the run passes: the metrics and
    the compiled reader (`monitor.warmup`, which reads its sample frames as a reader does),
    the bag decoder, and the STL window loops. The modules are imported here, inside what the
    command times and counts."""
    from casewatch.monitor.bags.decode import warm_up as warm_up_decoder
    from casewatch.monitor.warmup import warm_up as warm_up_metrics

    warm_up_metrics()
    warm_up_decoder()
    warm_up_stl()


def write_bytecode() -> bool:
    """Write the bytecode of every casewatch module (the module docstring says why); False
    where some could not be written (a read-only install keeps compiling from source)."""
    import compileall
    from pathlib import Path

    import casewatch

    package = Path(casewatch.__file__).parent
    return bool(compileall.compile_dir(package, quiet=2, workers=1))


def warm_up_stl() -> None:
    """The whole-log STL engine's loops (`evaluator.stl_kernels`), with the types
    `evaluator.vector_eval` passes: float64 ticks, int64 segment bounds, int sample bounds."""
    from casewatch.evaluator import stl_kernels

    values = np.array([0.5, -1.0, 2.0])
    bounds = np.zeros(3, dtype=np.int64)
    stl_kernels.past_window(values, bounds, 0, 1, True)
    stl_kernels.since(values, values, bounds, 0, 1)
    stl_kernels.until(values, values, bounds + 3, 0, 1)


@dataclass
class _CompileCounter(event.Listener):
    """The casewatch kernel variants numba compiles (it emits no event for a cache load)."""

    compiled: list[str] = field(default_factory=list)

    def on_start(self, ev: event.Event) -> None:
        pass

    def on_end(self, ev: event.Event) -> None:
        fn = ev.data["dispatcher"].py_func
        if fn.__module__.startswith("casewatch."):
            self.compiled.append(f"{fn.__module__}.{fn.__qualname__}")


def _cache_use() -> tuple[int, set[str]]:
    """Variants loaded from numba's cache in this process, and the cache folders in use."""
    loaded = 0
    folders: set[str] = set()
    for name, module in list(sys.modules.items()):
        if not name.startswith("casewatch.") or module is None:
            continue
        for value in vars(module).values():
            if isinstance(value, Dispatcher) and value.py_func.__module__ == name:
                stats: Any = value.stats
                loaded += sum(stats.cache_hits.values())
                if stats.cache_path:
                    folders.add(str(stats.cache_path))
    return loaded, folders
