"""`casewatch warm-up` writes the package's bytecode even where imports may not."""

from __future__ import annotations

import importlib.util
import os
from pathlib import Path

import casewatch
from casewatch.commands.warm_up import write_bytecode


def test_every_module_gets_current_bytecode() -> None:
    package = Path(casewatch.__file__).parent
    module = package / "commands" / "warm_up.py"
    cached = Path(importlib.util.cache_from_source(str(module)))
    cached.unlink(missing_ok=True)
    assert write_bytecode()
    assert cached.exists()
    # the header records the source's time stamp: the bytecode is current, so an import
    # (even with PYTHONDONTWRITEBYTECODE set) reads it instead of compiling the source
    header = cached.read_bytes()[:16]
    assert int.from_bytes(header[8:12], "little") == int(os.stat(module).st_mtime) & 0xFFFFFFFF
    sources = {p.relative_to(package).with_suffix("") for p in package.rglob("*.py")}
    compiled = {
        p.parent.parent.relative_to(package) / p.name.split(".")[0]
        for p in package.rglob("__pycache__/*.cpython-*.pyc")
    }
    assert sources <= compiled
