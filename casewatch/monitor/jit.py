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
- `no_cfunc_wrapper=True`: numba otherwise also builds a C-callable wrapper for every compiled
  variant, used only when a kernel is passed to another kernel as a first-class function value
  (none is): 6 % of the compile time of a machine's first run.
- one compiled variant of a kernel per argument type, not per constant: numba types a constant
  argument of a call from one kernel to another as a literal (`_path(..., False, ...)` is
  typed `Literal[bool](False)`) and compiles a variant of the callee for every such value
  (`history._along` four times, the reader's `_put_number` and `_points` twice each: 18 % of
  a machine's first-run compile time). `_Kernel` types those calls with the plain types
  instead. The arithmetic is the same (a literal only lets LLVM fold a branch the general
  variant takes at run time); the kernels' run time on the bundled drives' recorded calls was
  unchanged within the noise (sum 77.6 -> 74.9 us).

Rule: a kernel calls only kernels of its own module. numba's cache checks the source file of
the kernel it loads, not of the kernels compiled into it, so a kernel from another module would
silently keep its old code after that module changes. Across modules, call from Python.

Setting the environment variable `NUMBA_DISABLE_JIT=1` runs the kernels as plain Python, which
is slow but lets a debugger step through them.
"""

from __future__ import annotations

from collections.abc import Callable, Sequence
from typing import Any, TypeVar

from numba import njit, types
from numba.core.registry import CPUDispatcher

F = TypeVar("F", bound=Callable)

#: numba's options for every kernel (the module docstring says why each). A module that calls
#: `njit` itself (another signature or `inline`) passes these: `njit(**KERNEL_OPTIONS, ...)`
#: (typed as a dict, so mypy accepts the options numba's stubs do not list).
KERNEL_OPTIONS: dict[str, Any] = {
    "cache": True,
    "nogil": True,
    "error_model": "numpy",
    "no_cfunc_wrapper": True,
}


class _Kernel(CPUDispatcher):
    """numba's CPU dispatcher, except that a call from another kernel is typed (and so
    compiled) with the plain types of its arguments, not literals (module docstring)."""

    def get_call_template(
        self, args: Sequence[Any], kws: Sequence[tuple[str, Any]] | dict[str, Any]
    ) -> Any:
        """numba's type inference asks this for calls from compiled code only (a call from
        Python is typed from its values, which are never literals)."""
        plain = tuple(types.unliteral(a) for a in args)
        named = {k: types.unliteral(v) for k, v in dict(kws).items()}
        return super().get_call_template(plain, named)


def kernel(fn: F) -> F:
    """Compile `fn` as a metric kernel (see the module docstring for the settings)."""
    compiled = njit(**KERNEL_OPTIONS)(fn)
    if isinstance(compiled, CPUDispatcher):  # else NUMBA_DISABLE_JIT=1 gave `fn` back
        compiled.__class__ = _Kernel  # njit's option handling kept; only call typing changes
    return compiled  # type: ignore[no-any-return]
