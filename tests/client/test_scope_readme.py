"""The README's "Scope" section, run as written against a real lockstep daemon (the default
rack): its two commands make the committed picture's trace (written here to a temporary file
instead of docs/) and print the line the README shows; its Python block prints what its comment
says."""

from __future__ import annotations

import contextlib
import io
import os
import re
import shlex
import subprocess
import sys
from collections.abc import Iterator
from pathlib import Path

import pytest
from vdevclient.cli import main as vdevctl

from vdevd.testing import DaemonThread

README = Path(__file__).resolve().parents[2] / "README.md"
PICTURE = "docs/scope-galil-profiled-move.png"


def section() -> str:
    text = README.read_text()
    start = text.index("## Scope\n")
    return text[start:text.index("\n## ", start + 1)]


@pytest.fixture
def daemon(monkeypatch: pytest.MonkeyPatch) -> Iterator[DaemonThread]:
    with DaemonThread() as d:
        monkeypatch.setenv("VDEVD_ENDPOINT", d.endpoint)
        yield d


def test_the_scope_commands_make_the_picture(daemon: DaemonThread, tmp_path: Path,
                                            monkeypatch: pytest.MonkeyPatch) -> None:
    block = re.search(r"```console\n(.*?)```", section(), re.S)
    assert block is not None
    lines = block[1].splitlines()
    commands = [shlex.split(line[2:]) for line in lines if line.startswith("$ ")]
    shown = [line for line in lines if not line.startswith("$ ")]
    assert [c[0] for c in commands] == ["python", "vdevctl"]
    assert (README.parent / PICTURE).stat().st_size > 10_000  # the committed picture
    env = {**os.environ, "PYTHONPATH": os.pathsep.join(sys.path)}
    subprocess.run([sys.executable, *commands[0][1:]], check=True, env=env, timeout=60)
    png, csv = tmp_path / "move.png", tmp_path / "move.csv"
    argv = [str(png) if a == PICTURE else str(csv) if a == "move.csv" else a
            for a in commands[1][1:]]
    out = io.StringIO()
    with contextlib.redirect_stdout(out):
        assert vdevctl(argv) == 0
    assert out.getvalue().splitlines() == [
        line.replace(PICTURE, str(png)).replace("move.csv", str(csv)) for line in shown]
    assert png.read_bytes()[:4] == b"\x89PNG"
    last = csv.read_text().splitlines()[-1].split(",")
    assert float(last[1]) == 10_000 and float(last[2]) == 0  # at rest at the target

    code = re.search(r"```python\n(.*?)```", section(), re.S)
    assert code is not None
    expected = re.search(r"# (-?\d+\.\d+ -?\d+\.\d+)\n", code[1])  # what it prints
    assert expected is not None
    printed = io.StringIO()
    monkeypatch.chdir(tmp_path)
    with contextlib.redirect_stdout(printed):
        exec(compile(code[1], "README.md", "exec"), {})
    assert printed.getvalue().split() == expected[1].split()
    assert (tmp_path / "back.csv").read_text().splitlines()[0] == "time_s,X.position,X.error"
