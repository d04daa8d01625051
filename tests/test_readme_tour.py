"""The README's five-minute tour, run as written against a real daemon.

The tour's console blocks are parsed from README.md: every `$ vdevctl ...` line runs (with
$VDEVD_ENDPOINT set, as the tour's terminals have it) and must print the lines shown under it; a
`...` line stands for any lines. `vdevctl irq` runs in its own process, like the tour's third
terminal, and must print what the tour says it prints. The Python block runs and must print what
the README says it prints. A change to the README or to the daemon that breaks the tour fails here.
"""

from __future__ import annotations

import contextlib
import io
import os
import re
import shlex
import subprocess
import sys
from collections.abc import Iterator
from dataclasses import dataclass, field
from pathlib import Path

import pytest
from vdevclient.cli import main as vdevctl

from tests.conftest import free_endpoint

README = Path(__file__).resolve().parents[1] / "README.md"


@dataclass
class Command:
    argv: list[str]
    expected: list[str] = field(default_factory=list)


def tour_section() -> str:
    text = README.read_text()
    start = text.index("## A five-minute tour")
    return text[start : text.index("\n## ", start + 1)]


def fenced(section: str, lang: str) -> list[str]:
    return re.findall(rf"^```{lang}\n(.*?)^```", section, re.M | re.S)


def console_commands(section: str) -> list[Command]:
    """The `$ ...` lines of the console blocks, each with the output lines shown under it."""
    commands: list[Command] = []
    for block in fenced(section, "console"):
        for line in block.splitlines():
            if line.startswith("$ "):
                commands.append(Command(shlex.split(line[2:], comments=True)))
            elif commands:
                commands[-1].expected.append(line)
    return commands


def matches(expected: list[str], actual: list[str]) -> bool:
    """Every expected line appears in order; `...` stands for any number of lines."""
    if "..." not in expected:
        return [e.rstrip() for e in expected] == [a.rstrip() for a in actual]
    it = iter(actual)
    return all(any(a.rstrip() == e.rstrip() for a in it) for e in expected if e != "...")


def run_vdevctl(argv: list[str]) -> list[str]:
    out = io.StringIO()
    with contextlib.redirect_stdout(out):
        assert vdevctl(argv) == 0, argv
    return out.getvalue().splitlines()


@dataclass
class Daemon:
    endpoint: str
    events: str
    log_line: str


@pytest.fixture
def daemon(monkeypatch: pytest.MonkeyPatch) -> Iterator[Daemon]:
    """The tour's first terminal: `vdevd serve --clock lockstep`, on free loopback ports."""
    endpoint, events = free_endpoint(), free_endpoint()
    with subprocess.Popen([sys.executable, "-m", "vdevd", "serve", "--clock", "lockstep",
                           "--endpoint", endpoint, "--events", events],
                          stderr=subprocess.PIPE, text=True) as proc:
        try:
            assert proc.stderr is not None
            line = proc.stderr.readline().rstrip("\n")
            monkeypatch.setenv("VDEVD_ENDPOINT", endpoint)
            monkeypatch.delenv("VDEVD_EVENTS", raising=False)
            yield Daemon(endpoint, events, line)
        finally:
            proc.terminate()  # a clean exit removes its shared memory; SIGKILL would leave it
            try:
                proc.communicate(timeout=20)
            except subprocess.TimeoutExpired:
                proc.kill()
                proc.communicate()


def start_irq_terminal(argv: list[str], daemon: Daemon) -> tuple[subprocess.Popen[str], str]:
    """`vdevctl irq ...` in its own process; returns once its subscription is live, with the
    line it printed then (on stderr), the daemon's events port replaced by the tour's 5556."""
    proc = subprocess.Popen([sys.executable, "-m", "vdevclient.cli", *argv, "--timeout", "60"],
                            stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True,
                            env=os.environ.copy())
    assert proc.stderr is not None
    ready = proc.stderr.readline().rstrip("\n")
    return proc, ready.replace(daemon.events, "tcp://127.0.0.1:5556")


def read_events(proc: subprocess.Popen[str], n: int) -> list[str]:
    assert proc.stdout is not None
    return [proc.stdout.readline().rstrip("\n") for _ in range(n)]


def test_readme_tour_runs_as_written(daemon: Daemon) -> None:
    section = tour_section()
    commands = console_commands(section)
    assert commands[0].argv[-3:] == ["serve", "--clock", "lockstep"]
    stamp = r"^\d{4}-\d\d-\d\d \d\d:\d\d:\d\d,\d{3} "
    shown = re.sub(stamp, "", commands[0].expected[0])
    logged = re.sub(stamp, "", daemon.log_line).replace(daemon.endpoint, "tcp://127.0.0.1:5555")
    assert shown == logged.replace(daemon.events, "tcp://127.0.0.1:5556")
    irq_terminal: subprocess.Popen[str] | None = None
    ready = ""
    ran = 0
    try:
        for cmd in commands[1:]:
            assert cmd.argv[0] == "vdevctl", cmd.argv
            if cmd.argv[1] == "irq":
                if irq_terminal is None:  # the third terminal starts watching
                    irq_terminal, ready = start_irq_terminal(cmd.argv[1:], daemon)
                assert cmd.expected[0] == ready
                # what the third terminal has printed by now
                assert read_events(irq_terminal, len(cmd.expected) - 1) == cmd.expected[1:]
                continue
            actual = run_vdevctl(cmd.argv[1:])
            assert matches(cmd.expected, actual), (cmd.argv, cmd.expected, actual)
            ran += 1
        assert ran >= 8 and irq_terminal is not None

        code, = fenced(section, "python")
        prints = section.split(code, 1)[1]
        expected, = fenced(prints[prints.index("prints"):], "")
        out = io.StringIO()
        with contextlib.redirect_stdout(out):
            exec(compile(code, "README.md tour", "exec"), {})
        assert out.getvalue() == expected

        # "... and the `irq` terminal printed `610000000 servo0 inta seq=2 status=0x1`"
        said = re.search(r"terminal printed `([^`]+)`", prints)
        assert said is not None
        assert [line.strip() for line in read_events(irq_terminal, 1)] == [said.group(1)]
    finally:
        if irq_terminal is not None:
            irq_terminal.kill()
            irq_terminal.communicate()
