"""The compiler for the per-frame metric kernels: numba's `njit` with the project's settings.

Why compiled kernels: a frame of realistic traffic holds a handful of objects and plans of
30-50 points, so the numpy formulation of a metric spends its time in the fixed cost of a few
hundred small array calls, not in arithmetic. A kernel that loops over objects and points in
machine code does the same arithmetic in one call. Loops in a kernel are compiled, never
interpreted: the "no per-point Python loops" rule is about the interpreter.

Settings, and why:

- `cache=True`: compiled code is stored beside the module (`__pycache__`) or, where that is not
  writable, in numba's per-user cache, so only the first run on a machine pays for compiling.
- `error_model="numpy"`: division by zero gives inf / nan as in numpy, instead of raising; the
  kernels guard every division whose result they use.
- no `fastmath`: IEEE semantics, so a kernel and its numpy formulation agree to rounding.
- `nogil=True`: a kernel does not hold the interpreter lock (harmless for one thread, and lets
  an embedding application score channels from threads).

Compiling every kernel (a machine's first run: about 60 s on the project's machine since the
families' per-tick kernels, 2026-11-26) is mostly numba's own typing and lowering, in Python:
a lower NUMBA_OPT, numba's `no_cfunc_wrapper` and typing calls between kernels without
literals changed it by no more than the noise (measured, issue 36). `casewatch warm-up`, the
install step, pays it once instead.

Rule: a kernel calls only kernels of its own module. numba's cache checks the source file of
the kernel it loads, not of the kernels compiled into it, so a kernel from another module would
silently keep its old code after that module changes. Across modules, call from Python.
So a small kernel two modules' tick kernels both need is written in each (the window push
of `comfort._push_row` and `situation.push_row`), and a test holds every copy to the one
Python reference (`PoseWindow`, tests/monitor/reference_windows.py).

Setting the environment variable `NUMBA_DISABLE_JIT=1` runs the kernels as plain Python, which
is slow but lets a debugger step through them.
"""

from __future__ import annotations

from collections.abc import Callable
from typing import Any, TypeVar

from numba import njit

F = TypeVar("F", bound=Callable)

#: numba's options for every kernel (the module docstring says why each). A module that calls
#: `njit` itself (another signature or `inline`) passes these: `njit(**KERNEL_OPTIONS, ...)`
#: (typed as a dict, so mypy accepts the options numba's stubs do not list).
KERNEL_OPTIONS: dict[str, Any] = {
    "cache": True,
    "nogil": True,
    "error_model": "numpy",
}


def kernel(fn: F) -> F:
    """Compile `fn` as a metric kernel (see the module docstring for the settings)."""
    return njit(**KERNEL_OPTIONS)(fn)  # type: ignore[no-any-return]
