"""The configuration reference is generated from the declarations (issue 22 "Docs",
vdevd/docs.py): README.md's key table and `vdevd types` sample and examples/rack.toml must be
what `python -m vdevd.docs` writes, and its declarations must match what the loader accepts."""

from __future__ import annotations

import re
import shutil
from pathlib import Path

import pytest

from vdevd import config, docs
from vdevd.devices import CARD_TYPES, card_class
from vdevd.devices.options import parse_options
from vdevd.rt.world import AXIS_KEYS

ROOT = Path(__file__).resolve().parents[1]


def test_readme_and_example_are_generated_from_the_declarations() -> None:
    assert docs.main(["--check"]) == 0, "run `python -m vdevd.docs` and commit the result"


def test_the_check_fails_when_a_file_drifts(tmp_path: Path) -> None:
    (tmp_path / "examples").mkdir()
    shutil.copy(ROOT / "README.md", tmp_path / "README.md")
    shutil.copy(ROOT / "examples" / "rack.toml", tmp_path / "examples" / "rack.toml")
    readme = (tmp_path / "README.md").read_text()
    row = next(line for line in readme.splitlines() if line.startswith("| `[[card]] motors`"))
    (tmp_path / "README.md").write_text(readme.replace(row + "\n", ""))
    assert docs.main(["--check", "--root", str(tmp_path)]) == 1
    assert docs.main(["--root", str(tmp_path)]) == 0  # rewritten
    assert docs.main(["--check", "--root", str(tmp_path)]) == 0
    assert row in (tmp_path / "README.md").read_text()


def accepted_keys(section: str) -> set[str]:
    """The keys config.py accepts in `[section]`, from its own unknown-key message."""
    with pytest.raises(config.ConfigError, match="unknown key") as err:
        config.parse({section: {"no_such_key": 1}})
    listed = re.search(r"\(keys: (.*)\)", str(err.value))
    assert listed is not None
    return set(listed.group(1).split(", "))


def test_the_declared_sections_are_the_loaders() -> None:
    sections = {s.section for s in docs.SETTINGS}
    assert sections | {"card"} == config._SECTIONS
    for section in sections:
        assert {s.key for s in docs.SETTINGS if s.section == section} == accepted_keys(section)
    assert set(docs.AXIS_HELP) == set(AXIS_KEYS)


def test_the_example_loads_with_every_key_at_its_default() -> None:
    text = (ROOT / "examples" / "rack.toml").read_text()
    cfg = config.load(ROOT / "examples" / "rack.toml")
    defaults = config.Config()
    assert (cfg.endpoint, cfg.events, cfg.shm_dir) == (defaults.endpoint, defaults.events,
                                                       defaults.shm_dir)
    assert (cfg.clock, cfg.wake_us, cfg.waker, cfg.skip_quiet) == (
        defaults.clock, defaults.wake_us, defaults.waker, defaults.skip_quiet)
    assert [c.type for c in cfg.cards] == list(CARD_TYPES)  # one card of each type
    for spec in cfg.cards:
        cls = card_class(spec.type)
        assert dict(spec.options) == dict(parse_options(cls.options, {}, spec.name,
                                                        cls.axes_option))
        block = text.split(f'type = "{spec.type}"', 1)[1].split("[[card]]", 1)[0]
        for key in cls.options:  # shown, set or (no default value) commented out
            assert re.search(rf"^(# )?{key} = ", block, re.M), (spec.type, key)
    for s in docs.SETTINGS:
        assert re.search(rf"^(# )?{s.key} = ", text, re.M), s.key


def test_every_card_type_is_in_the_readme() -> None:
    readme = (ROOT / "README.md").read_text()
    for ctype in CARD_TYPES:
        assert f"`{ctype}`" in readme.split("| `[[card]] type` |")[1].split("\n")[0]
        for key in card_class(ctype).options:
            assert f"| `[[card]] {key}` | {ctype}: " in readme, (ctype, key)
        assert re.search(rf"^\| `\w+0` \| `{ctype}` \|", readme, re.M), ctype  # the default rack
        assert f"{ctype} (period " in readme  # the `vdevd types` sample
