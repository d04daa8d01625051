"""Card options declared once (vdevd/devices/options.py): config loading checks them and hands
the card one frozen object; a legal 0 stays 0; `[[card.axis]]` tables become the axis world."""

from __future__ import annotations

import tomllib
from pathlib import Path

import pytest

from vdevd import config as configmod
from vdevd.cli import main as vdevd_main
from vdevd.config import ConfigError
from vdevd.devices import CARD_TYPES, card_class
from vdevd.devices.base import CardContext
from vdevd.devices.options import CardOptions, Option, parse_options
from vdevd.rt.world import AxisMechanics

DECLARED = {"axes": Option(int, 4, min=1, max=8, help="number of axes"),
            "mode": Option(str, "a", choices=("a", "b"))}


def test_defaults_are_filled_and_the_object_is_frozen() -> None:
    opts = parse_options(DECLARED, {"axes": 2})
    assert (opts.axes, opts.mode, opts.period_ns, opts.axis) == (2, "a", None, ())
    assert opts["axes"] == 2 and dict(opts)["mode"] == "a"
    with pytest.raises(AttributeError, match="read-only"):
        opts.axes = 3  # type: ignore[misc]
    with pytest.raises(AttributeError, match="no card option 'speed'"):
        _ = opts.speed


def test_an_unknown_key_is_refused_naming_the_known_ones() -> None:
    with pytest.raises(ValueError, match=r"card\[0\].speed: unknown key \(keys: type, name, "
                                         r"period_ns, axis, axes, mode\)"):
        parse_options(DECLARED, {"speed": 1}, "card[0]")


def test_a_parsed_object_is_handed_on_as_it_is() -> None:
    opts = parse_options(DECLARED, {})
    assert parse_options(DECLARED, opts) is opts


def test_serial_zero_on_a_maxk_stays_zero() -> None:
    """The `x or default` form turned a legal 0 into the default (issue 16)."""
    cfg = configmod.parse({"card": [{"type": "oms-maxk", "name": "m", "serial": 0}]})
    assert isinstance(cfg.cards[0].options, CardOptions)
    assert cfg.cards[0].options.serial == 0


def test_axis_tables_in_toml_become_the_cards_mechanics() -> None:
    cfg = configmod.parse(tomllib.loads('''
[[card]]
type = "generic-servo"
name = "s"
axes = 2
[[card.axis]]
limits = [-1000, 1000]
home = [100, 150]
index = {period = 4000, phase = 250}
probe = [10, 20]
[[card.axis]]
amp_fault = true
'''))
    opts = cfg.cards[0].options
    assert opts.axis == (AxisMechanics((-1000, 1000), (100, 150), (4000, 250), (10, 20)),
                         AxisMechanics(amp_fault=True))
    card = card_class("generic-servo")("s", opts, CardContext(emit=lambda e: None))
    assert card.world.pos_at.tolist() == [1000, float("inf")]
    assert card.world.amp_fault.tolist() == [False, True]


@pytest.mark.parametrize(("card", "message"), [
    ({"axis": {"limits": [0, 1]}}, "card[0].axis: use [[card.axis]] tables"),
    ({"axis": [{"limits": [3, 1]}]}, "card[0].axis[0].limits: 3 must be below 1"),
    ({"axes": 1, "axis": [{}, {}]}, "card[0].axis: 2 [[card.axis]] tables for 1 axes"),
    ({"period_ns": 1000}, "card[0].period_ns: 1000 is not an integer in 10000..1e9"),
])
def test_bad_axis_tables_and_periods_name_the_key(card: dict[str, object], message: str) -> None:
    with pytest.raises(ConfigError) as info:
        configmod.parse({"card": [{"type": "generic-servo", "name": "s", **card}]})
    assert message in str(info.value)


@pytest.mark.parametrize(("card", "message"), [
    ({"type": "galil-dmc13x8", "axes": 2, "axis": [{}] * 3},
     "card[0].axis: 3 [[card.axis]] tables for 2 axes"),
    ({"type": "pmac-turbo", "motors": 2, "ethernet": "", "axis": [{}] * 3},
     "card[0].axis: 3 [[card.axis]] tables for 2 axes"),  # the PMAC counts its motors
    ({"type": "oms-maxk", "profiles": ["linear"] * 3}, "card[0].profiles: 3 entries for 8 axes"),
    ({"type": "oms-maxk", "axes": 2, "axis_types": ["servo"] * 3},
     "card[0].axis_types: 3 entries for 2 axes"),
    ({"type": "oms-maxk", "axes": 4, "servo_output": ["bipolar"] * 5},
     "card[0].servo_output: 5 entries for 4 axes"),
    ({"type": "oms-maxk", "travel_limits": [[0, 100]]}, "card[0].travel_limits: 1 entries for 8 axes"),
])
def test_axis_counts_are_checked_at_load_against_the_option_that_counts_axes(
        card: dict[str, object], message: str) -> None:
    with pytest.raises(ConfigError) as info:
        configmod.parse({"card": [{"name": "c", **card}]})
    assert str(info.value) == message


def test_too_many_axis_tables_stop_vdevd_serve_as_a_configuration_error(
        tmp_path: Path, capsys: pytest.CaptureFixture[str]) -> None:
    (tmp_path / "rack.toml").write_text(
        '[[card]]\ntype = "generic-servo"\nname = "servo0"\naxes = 2\n' + "[[card.axis]]\n" * 3)
    assert vdevd_main(["serve", "--config", str(tmp_path / "rack.toml")]) == 2
    assert capsys.readouterr().err == (
        "vdevd: configuration error: card[0].axis: 3 [[card.axis]] tables for 2 axes\n")


def test_a_list_option_takes_no_range_and_per_axis_is_a_list() -> None:
    with pytest.raises(TypeError, match="no min or max"):
        Option(list, None, min=1)
    with pytest.raises(TypeError, match="per_axis"):
        Option(int, 4, per_axis=True)
    assert Option(list, None, per_axis=True).check("k", ["a", "b"]) == ["a", "b"]


@pytest.mark.parametrize("type_name", list(CARD_TYPES))
def test_every_card_declares_its_options_with_help(type_name: str) -> None:
    for key, opt in card_class(type_name).options.items():
        assert opt.help, f"{type_name}.{key} has no help"
        if opt.default is not None:
            assert opt.check(key, opt.default) == opt.default


@pytest.mark.parametrize(("type_name", "named"), [
    ("galil-dmc13x8", "set tm_us instead"), ("oms-maxk", "set update_hz"),
    ("pmac-turbo", r"I10/2\^23 ms")])
def test_a_card_whose_period_follows_its_own_setting_refuses_period_ns(type_name: str,
                                                                      named: str) -> None:
    """The period is what the card reports (TM, #UR, I10): a `period_ns` beside it would run
    the card at a rate it does not report."""
    with pytest.raises(ConfigError, match=rf"card\[0\].period_ns: .*{named}"):
        configmod.parse({"card": [{"type": type_name, "name": "c", "period_ns": 500_000}]})
    assert card_class(type_name).period_from
