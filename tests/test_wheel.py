"""The installed package is one namespace, and a user's folders cannot shadow it.

Built as a user gets it (a wheel from a clean copy of the sources, unpacked as pip installs it),
then the README's Python example run from a working folder that holds ordinary `spec/`,
`reports/`, `monitor/`, `evaluator/` and `safety_case/` packages of its own: casewatch must
import its own modules and find its own data files (the formula grammar, the report templates),
whatever the user's folder holds.
"""

from __future__ import annotations

import os
import re
import shutil
import subprocess
import sys
import zipfile
from pathlib import Path

import pytest

REPO = Path(__file__).resolve().parents[1]
COMPONENTS = ["safety_case", "spec", "monitor", "evaluator", "reports"]


def _readme_example() -> str:
    text = (REPO / "README.md").read_text(encoding="utf-8")
    blocks = re.findall(r"```python\n(.*?)```", text, re.S)
    assert blocks, "README.md has no Python example"
    return blocks[0]


@pytest.fixture(scope="module")
def wheel(tmp_path_factory) -> Path:
    """The wheel, built from a copy of the sources (no stale `build/` of the working tree)."""
    src = tmp_path_factory.mktemp("src")
    for name in ["pyproject.toml", "README.md"]:
        shutil.copy(REPO / name, src / name)
    shutil.copytree(
        REPO / "casewatch", src / "casewatch", ignore=shutil.ignore_patterns("__pycache__")
    )
    out = tmp_path_factory.mktemp("wheel")
    subprocess.run(
        [
            sys.executable,
            "-m",
            "pip",
            "wheel",
            "-q",
            "--no-deps",
            "--no-build-isolation",
            "-w",
            str(out),
            str(src),
        ],
        check=True,
        capture_output=True,
        text=True,
    )
    (built,) = out.glob("casewatch-*.whl")
    return built


def test_wheel_installs_only_the_casewatch_namespace(wheel):
    with zipfile.ZipFile(wheel) as archive:
        names = archive.namelist()
    tops = {name.split("/")[0] for name in names}
    assert {t for t in tops if not t.endswith(".dist-info")} == {"casewatch"}
    # the data files travel with the code, and no repository tooling does
    for data in [
        "casewatch/spec/grammar.lark",
        "casewatch/reports/templates/report.html.j2",
        "casewatch/safety_case/libraries/contracts.yaml",
    ]:
        assert data in names
    assert not [n for n in names if n.split("/")[1:2] in (["bench"], ["tools"], ["demo.py"])]


def test_wheel_version_is_the_packages_own(wheel):
    """One version, written in casewatch/__init__.py: the wheel's metadata (what result.json
    records, `evaluator.session.casewatch_version`) and `casewatch --version` agree."""
    from casewatch import __version__

    assert wheel.name.startswith(f"casewatch-{__version__}-")
    with zipfile.ZipFile(wheel) as archive:
        (meta,) = [n for n in archive.namelist() if n.endswith(".dist-info/METADATA")]
        text = archive.read(meta).decode()
    assert f"\nVersion: {__version__}\n" in text


def test_readme_example_runs_from_a_folder_that_shadows_every_component(wheel, tmp_path):
    site = tmp_path / "site"
    with zipfile.ZipFile(wheel) as archive:
        archive.extractall(site)
    work = tmp_path / "work"
    for name in COMPONENTS:  # a user's own packages with our component names
        (work / name).mkdir(parents=True)
        (work / name / "__init__.py").write_text("raise ImportError('the user folder')\n")
    (work / "examples").symlink_to(REPO / "examples")
    probe = (
        _readme_example()
        + "\nimport casewatch, casewatch.spec.parser as p\n"
        + "print('FROM', casewatch.__file__)\n"
    )
    env = {**os.environ, "PYTHONPATH": str(site), "NUMBA_CACHE_DIR": str(tmp_path / "numba")}
    done = subprocess.run(
        [sys.executable, "-c", probe], cwd=work, env=env, capture_output=True, text=True
    )
    assert done.returncode == 0, done.stderr[-2000:]
    assert f"FROM {site / 'casewatch' / '__init__.py'}" in done.stdout
    verdict = done.stdout.splitlines()[0]
    assert verdict.startswith("undermined [('CSn2', 18.6")  # its hazard episodes
    assert (work / "out" / "api" / "result.json").is_file()
