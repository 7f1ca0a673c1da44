"""monitor.jit compiles one variant of a kernel per argument type: a constant passed by another
kernel (`inner(x, True)`) is typed as a plain bool, not as a literal per value, which numba
would compile once per constant (issue 36: the variants were 18 % of a first run's compile
time). The values are the plain-Python function's."""

from __future__ import annotations

import importlib.util
import sys
from pathlib import Path

import pytest

MODULE = """
from casewatch.monitor.jit import kernel


@kernel
def inner(x, flag, k):
    return (x + k if flag else x - k) * 2.0


@kernel
def outer(x):
    return inner(x, True, 1) + inner(x, False, 2) + inner(x, True, 0)
"""


@pytest.fixture
def kernels(tmp_path: Path):
    path = tmp_path / "variant_kernels.py"
    path.write_text(MODULE, encoding="utf-8")
    spec = importlib.util.spec_from_file_location("variant_kernels", path)
    assert spec is not None and spec.loader is not None
    module = importlib.util.module_from_spec(spec)
    sys.modules["variant_kernels"] = module
    try:
        spec.loader.exec_module(module)
        yield module
    finally:
        del sys.modules["variant_kernels"]


def test_constants_from_another_kernel_compile_one_variant(kernels):
    # (1.5 + 1) * 2 + (1.5 - 2) * 2 + (1.5 + 0) * 2 = 5 - 1 + 3
    assert kernels.outer(1.5) == 7.0 == kernels.outer.py_func(1.5)
    assert [str(s) for s in kernels.inner.signatures] == ["(float64, bool, int64)"]


def test_a_call_from_python_is_typed_as_before(kernels):
    assert kernels.inner(1.5, False, 3) == -3.0 == kernels.inner.py_func(1.5, False, 3)
    assert [str(s) for s in kernels.inner.signatures] == ["(float64, bool, int64)"]
