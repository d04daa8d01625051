"""The configuration reference, generated so it cannot drift from the code (issue 22 "Docs").

`python -m vdevd.docs` rewrites, from the declarations:

- README.md's table of the default rack, its key table and its `vdevd types` sample (between
  `<!-- generated: NAME -->` and `<!-- end generated: NAME -->` markers), from `SETTINGS` below
  (the sections' keys, which vdevd/config.py parses) and every card type's `options`
  (vdevd/devices/options.py);
- examples/rack.toml, every section and key, one card of each type with every key at its
  default.

`python -m vdevd.docs --check` changes nothing and exits 1 naming each file that differs
(tests/test_docs.py runs it, and checks `SETTINGS` against what config.py accepts).
"""

from __future__ import annotations

import argparse
import contextlib
import io
import json
import re
import sys
from collections.abc import Callable
from dataclasses import dataclass
from pathlib import Path
from typing import Any

from vdevd import config as configmod
from vdevd.devices import CARD_TYPES, DEFAULT_NAMES, card_class
from vdevd.devices.options import COMMON_OPTIONS, Option
from vdevd.rt.world import AXIS_KEYS

ROOT = Path(__file__).resolve().parents[1]


@dataclass(frozen=True)
class Setting:
    """A key of a configuration section: what it means, its default as the table shows it, and
    the line examples/rack.toml gives it (`value`: TOML text; `active`: false, commented out)."""

    section: str
    key: str
    meaning: str
    default: str
    value: str
    active: bool = True


SETTINGS: tuple[Setting, ...] = (
    Setting("server", "endpoint", "ROUTER endpoint for requests (`tcp://host:port`, `ipc://path`); "
            "loopback or `ipc://` unless `[security]` says otherwise", "`tcp://127.0.0.1:5555`",
            '"tcp://127.0.0.1:5555"'),
    Setting("server", "events", "PUB endpoint for interrupts and events (topic: the card name)",
            "`tcp://127.0.0.1:5556`", '"tcp://127.0.0.1:5556"'),
    Setting("server", "shm_dir", "where the shared memory of local clients is created (an "
            "owner-only file named after the endpoint, removed at exit; `\"\"`: none)",
            "`/dev/shm`", '"/dev/shm"'),
    Setting("server", "max_scheduled_per_client", "scheduled `control` actions (`at_ns`/"
            "`after_ns`) one client may have pending; past it `busy`", "`1000`", "1000"),
    Setting("server", "max_scheduled", "scheduled `control` actions all clients together may "
            "have pending; past it `busy`", "`10000`", "10000"),
    Setting("server", "heartbeat_s", "period of the heartbeat on the events socket, wall "
            "seconds, 0.01..3: a subscriber that hears nothing for three periods takes the "
            "daemon for gone", "`2.0`", "2.0"),
    Setting("clock", "mode", "`realtime` (locked to wall time) or `lockstep` (moves only on "
            "`step` and during waits)", "`realtime`", '"realtime"'),
    Setting("clock", "wake_us", "realtime: scheduler wake period, 100..100000 us", "`1000`",
            "1000"),
    Setting("clock", "waker", "realtime: `thread` (a sleeping thread wakes the loop) or `timer` "
            "(event-loop timer, 1 ms resolution)", "`thread`", '"thread"'),
    Setting("clock", "skip_quiet", "a card at rest runs its quiet ticks in closed form, with "
            "the same replies and events as ticking every period (decision 0008); `false` ticks "
            "every period in full", "`true`", "true"),
    Setting("state", "dir", "where cards keep what a real card keeps in flash (one file per "
            "card, written atomically, restored at start)", "none: nothing is saved",
            '"/var/lib/vdevd"', active=False),
    Setting("security", "server_secret_key", "the server's CURVE secret key file (pyzmq "
            "`zmq.auth` certificate); with `client_keys_dir`, both sockets are CURVE servers",
            "none", '"/etc/vdevd/keys/server.key_secret"', active=False),
    Setting("security", "client_keys_dir", "directory of the public key files of the allowed "
            "clients", "none", '"/etc/vdevd/keys/clients"', active=False),
    Setting("security", "allow_unauthenticated_networks", "instead of CURVE keys: serve a "
            "non-loopback endpoint without CURVE to these networks (and loopback) only, e.g. a "
            "private CI network; logged as a warning at start", "none",
            '["10.0.0.0/8"]', active=False),
    Setting("metrics", "listen", "the HTTP endpoint of Prometheus metrics, `/healthz` and "
            "`/readyz` (`host:port`); no `[metrics]`: off", "`127.0.0.1:9750`",
            '"127.0.0.1:9750"', active=False),
    Setting("metrics", "allow", "networks that may connect to a non-loopback `listen` "
            "(required for one; loopback always may)", "none", '["10.0.0.0/8"]',
            active=False),
    Setting("metrics", "unresponsive_s", "`/healthz` fails when the event loop has not run a "
            "heartbeat for this long, 0.1..600 s", "`5.0`", "5.0", active=False),
    Setting("web", "listen", "the live web view of the rack (`host:port`; README \"Web "
            "view\"); no `[web]`: off", "`127.0.0.1:8080`", '"127.0.0.1:8080"', active=False),
    Setting("web", "allow", "networks that may connect to a non-loopback `listen` (required "
            "for one; loopback always may)", "none", '["10.0.0.0/8"]', active=False),
)

#: the `[[card.axis]]` keys (vdevd/rt/world.py `AXIS_KEYS`): meaning and default
AXIS_HELP: dict[str, tuple[str, str]] = {
    "limits": ("the stage's hard limits `[negative, positive]` in counts: each switch is active "
               "at or beyond its position", "no limit switches"),
    "home": ("the home switch window `[from, to]`: active while from <= position <= to",
             "no home switch"),
    "index": ("encoder index pulses `{period = 4000, phase = 250}`: one at phase + k x period",
              "none"),
    "probe": ("positions where the probe (registration/latch input) fires as the axis crosses "
              "them", "none"),
    "amp_fault": ("the amplifier fault is present from power-up", "`false`"),
    "encoder_loss": ("the encoder loss is present from power-up", "`false`"),
}


def toml_value(value: Any) -> str:
    """`value` as TOML writes it."""
    if isinstance(value, bool):
        return "true" if value else "false"
    if isinstance(value, str):
        return json.dumps(value)
    if isinstance(value, list | tuple):
        return "[" + ", ".join(toml_value(v) for v in value) + "]"
    return repr(value)


def _cell(text: str) -> str:
    return text.replace("|", "\\|")


def key_table() -> str:
    """The README's table of every configuration key."""
    rows = ["| key | meaning | default |", "|---|---|---|"]
    rows += [f"| `[{s.section}] {s.key}` | {_cell(s.meaning)} | {s.default} |" for s in SETTINGS]
    rows.append("| `[[card]] type` | card type, one of " + ", ".join(f"`{t}`" for t in CARD_TYPES)
                + " | required |")
    rows.append("| `[[card]] name` | unique card name: letters, digits, `-`, `_` | required |")
    period = COMMON_OPTIONS["period_ns"]
    rows.append(f"| `[[card]] period_ns` | {_cell(period.help)}, 10000..1000000000 (the types "
                "whose period a card setting gives refuse it: `vdevd types`) | the type's own |")
    rows += [f"| `[[card.axis]] {key}` | {_cell(AXIS_HELP[key][0])} | {AXIS_HELP[key][1]} |"
             for key in AXIS_KEYS]
    for ctype in CARD_TYPES:
        for key, opt in card_class(ctype).options.items():
            rows.append(f"| `[[card]] {key}` | {ctype}: {_cell(_meaning(opt))} | "
                        f"{_default(opt)} |")
    return "\n".join(rows)


def default_rack() -> str:
    """The README's table of the embedded default rack: one card of each type."""
    rows = ["| card | type | what | period | configuration keys, registers, commands |",
            "|---|---|---|---|---|"]
    for spec in configmod.default_config().cards:
        cls = card_class(spec.type)
        module = sys.modules[cls.__module__]
        what = (module.__doc__ or "").split(" (type", 1)[0].strip()
        readme = Path(module.__file__ or "").parent / "README.md"
        rows.append(f"| `{spec.name}` | `{spec.type}` | {_cell(what)} | "
                    f"{float(cls.default_period_ns):.10g} ns | "
                    f"`{readme.relative_to(ROOT).as_posix()}` |")
    return "\n".join(rows)


def _meaning(opt: Option) -> str:
    parts = []
    if opt.choices is not None and len(opt.choices) <= 8:
        parts.append("one of " + ", ".join(f"`{c}`" for c in opt.choices))
    elif opt.choices is not None:
        parts.append(f"each `{opt.choices[0]}`..`{opt.choices[-1]}`")
    if opt.min is not None or opt.max is not None:
        parts.append(f"{'' if opt.min is None else f'{opt.min:g}'}.."
                     f"{'' if opt.max is None else f'{opt.max:g}'}")
    extra = f" ({'; '.join(parts)})" if parts else ""
    return (opt.help or "") + extra


def _default(opt: Option) -> str:
    return "none" if opt.default is None else f"`{_cell(toml_value(opt.default))}`"


def types_sample() -> str:
    """What `vdevd types` prints, as a console block's body."""
    from vdevd.cli import main as vdevd

    out = io.StringIO()
    with contextlib.redirect_stdout(out):
        vdevd(["types"])
    return "$ vdevd types\n" + out.getvalue().rstrip("\n")


def example_rack() -> str:
    """examples/rack.toml: every section and key; one card of each type with every key."""
    lines = [
        "# A vdevd rack: every section and key, one card of each type with every key at its default.",
        "# GENERATED by `python -m vdevd.docs` from the declarations (vdevd/docs.py SETTINGS and each",
        "# card type's options): edit those, not this file. Run it with:",
        "#   vdevd serve --config examples/rack.toml",
        "# Command-line options (--clock, --endpoint, --events, --state-dir) override what is set here.",
        "# Each table and key is optional except [[card]] type and name; a missing key takes its",
        "# default. A commented-out key has no default value to show, or turns a feature on.",
    ]
    section = ""
    for s in SETTINGS:
        if s.section != section:
            section = s.section
            active = any(x.active for x in SETTINGS if x.section == section)
            lines += ["", f"{'' if active else '# '}[{section}]"]
        lines += _commented(f"{'' if s.active else '# '}{s.key} = {s.value}",
                            _plain(s.meaning) + ("" if s.default.startswith("`") else
                                                 f"; default {_plain(s.default)}"))
    for i, ctype in enumerate(CARD_TYPES):
        cls = card_class(ctype)
        name = f"{DEFAULT_NAMES.get(ctype, ctype.split('-')[0])}0"
        lines += ["", "[[card]]", f'type = "{ctype}"', f'name = "{name}"']
        if cls.period_from:
            lines.append(f"# (no period_ns: {cls.period_from})")
        else:
            lines += _commented(f"# period_ns = {int(cls.default_period_ns)}",
                                "servo period in ns, 10000..1e9 (default shown)")
        for key, opt in cls.options.items():
            if opt.default is None:
                lines += _commented(f"# {key} = ...", f"{_plain(_meaning(opt))}; default none")
            else:
                lines += _commented(f"{key} = {toml_value(opt.default)}", _plain(_meaning(opt)))
        if i == 0:
            lines.append("# [[card.axis]] tables, one per axis in the card's axis order (the axis "
                         "world):")
            lines.append("# [[card.axis]]")
            for key, value in (("limits", "[-50000, 50000]"), ("home", "[12000, 12400]"),
                               ("index", "{period = 4000, phase = 250}"),
                               ("probe", "[1000, 2000]"), ("amp_fault", "false"),
                               ("encoder_loss", "false")):
                lines += _commented(f"# {key} = {value}", _plain(AXIS_HELP[key][0]))
    return "\n".join(lines) + "\n"


def _plain(markdown: str) -> str:
    return markdown.replace("`", "")


def _commented(code: str, comment: str, column: int = 36, width: int = 100) -> list[str]:
    """`code` with `comment` beside it from `column`, wrapped to `width` under it."""
    words, out, line = comment.split(), [], code.ljust(column - 1) + " #"
    for word in words:
        if len(line) + 1 + len(word) > width and not line.endswith("#"):
            out.append(line)
            line = " " * (column - 1) + " #"
        line += " " + word
    out.append(line)
    return out


def replace_block(text: str, name: str, body: str) -> str:
    """`text` with the block between the `name` markers replaced by `body`; ValueError when the
    markers are missing."""
    start, end = f"<!-- generated: {name} -->", f"<!-- end generated: {name} -->"
    pattern = re.compile(re.escape(start) + r"\n.*?" + re.escape(end), re.S)
    if not pattern.search(text):
        raise ValueError(f"README.md has no {start} ... {end} block")
    return pattern.sub(lambda _: f"{start}\n{body}\n{end}", text, count=1)


def readme(text: str) -> str:
    text = replace_block(text, "default-rack", default_rack())
    text = replace_block(text, "keys", key_table())
    return replace_block(text, "types", "```console\n" + types_sample() + "\n```")


OUTPUTS: dict[str, Callable[[str], str]] = {
    "README.md": readme,
    "examples/rack.toml": lambda _old: example_rack(),
}


def main(argv: list[str] | None = None) -> int:
    p = argparse.ArgumentParser(prog="python -m vdevd.docs", description=__doc__.split("\n")[0])
    p.add_argument("--check", action="store_true", help="change nothing; exit 1 if a file differs")
    p.add_argument("--root", type=Path, default=ROOT, help="the repository (default: this one)")
    args = p.parse_args(argv)
    stale = []
    for rel, render in OUTPUTS.items():
        path = args.root / rel
        old = path.read_text() if path.exists() else ""
        new = render(old)
        if new != old:
            stale.append(rel)
            if not args.check:
                path.write_text(new)
    for rel in stale:
        print(f"{rel}: {'differs from the declarations' if args.check else 'rewritten'}"
              f"{' (python -m vdevd.docs rewrites it)' if args.check else ''}", file=sys.stderr)
    return 1 if stale and args.check else 0


if __name__ == "__main__":
    sys.exit(main())
