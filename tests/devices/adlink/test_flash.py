"""The flash image of the AMP card (spec adlink.md §4.1 `APS_save_parameter_to_flash`,
ASSUMPTION: a per-card image in the state directory): what it keeps, and that an unreadable or
foreign image never stops the card from starting (it starts from its defaults, with a warning,
as a real card does after a flash checksum error)."""

from __future__ import annotations

import logging
import math
from pathlib import Path
from typing import Any

import pytest
from vdevmaps.aps_defs import (
    PRA_ACC,
    PRA_HOME_MODE,
    PRB_DO_LOGIC,
    TGR_TRG0_PWD,
    TIMR_EN,
    TIMR_ITV,
    VAO_OUTPUT_FIX_WIDTH,
)

from vdevd.devices.adlink import cmd_system, pwm, trigger
from vdevd.devices.adlink.card import AdlinkCard
from vdevd.devices.base import CardContext
from vdevd.nvram import NvramStore


def new_card(store: NvramStore, model: str = "AMP-208C") -> AdlinkCard:
    return AdlinkCard("amp0", {"model": model}, CardContext(emit=lambda e: None, nvram=store))


def defaults() -> dict[str, Any]:
    """What a card with no flash image holds."""
    k = new_card(NvramStore("/nonexistent-state-dir")).kernel
    return k.parameter_image()


def test_the_image_keeps_parameters_trigger_parameters_and_vao_tables(tmp_path: Path) -> None:
    store = NvramStore(tmp_path)
    k = new_card(store).kernel
    k.axis_params.set(3, PRA_ACC, 4321.0)
    k.board_params.values[PRB_DO_LOGIC] = 1.0
    trigger.set_trigger_param(k, TGR_TRG0_PWD, 77)
    trigger.set_trigger_param(k, TIMR_ITV, 12_345)
    trigger.set_trigger_param(k, TIMR_EN, 1)  # running is no parameter: not kept
    pwm.set_vao_param_ex(k, 1, VAO_OUTPUT_FIX_WIDTH, 0, 5000, 0b11, 100, 50, [1000, 2000, 3000])
    cmd_system.save_parameter_to_flash(k)
    store.save("amp0", {"flash": k.flash})
    card = new_card(store)
    k2 = card.kernel
    assert k2.axis_params.get(3, PRA_ACC) == 4321.0
    assert k2.board_params.values[PRB_DO_LOGIC] == 1.0
    u = trigger.unit(k2)
    assert (u.params[TGR_TRG0_PWD], u.params[TIMR_ITV], u.params[TIMR_EN]) == (77, 12_345, 0)
    tab = pwm.unit(k2).tables[1]
    assert (tab.output, tab.config, tab.src, tab.min_vel, tab.interval, tab.power) == (
        VAO_OUTPUT_FIX_WIDTH, 5000, 0b11, 100, 50, [1000, 2000, 3000])


def test_an_unreadable_image_starts_the_card_from_its_defaults(
        tmp_path: Path, caplog: pytest.LogCaptureFixture) -> None:
    store = NvramStore(tmp_path)
    store.path("amp0").write_bytes(b"\xc1\xff not msgpack")
    with caplog.at_level(logging.WARNING):
        card = new_card(store)
    assert card.kernel.parameter_image() == defaults()
    assert "unreadable flash image" in caplog.text
    assert (tmp_path / "amp0.nvram.corrupt").exists()


#: images another program (or another version, or another card type) could have left
FOREIGN: list[Any] = [
    {"flash": {"axis": [1, 2, 3], "board": "x", "units": ["TriggerUnit"]}},
    {"flash": {"axis": {1: [1.0] * 8, "0x0": "abc", "0x5": None, "zz": [0.0] * 8},
               "board": {2: 1.0, "0x0": "high", "0x1": None, "0x15": [1]},
               "units": {"TriggerUnit": {16: 5, "0x20": "wide", "0x21": None, "0x23": 1.5},
                         "PwmUnit": {"tables": [{"output": 99, "power": "abc"}] * 8}}}},
    {"flash": {"units": {"TriggerUnit": [1, 2], "PwmUnit": {"tables": [[1, 2]] * 8}}}},
    {"flash": {"units": {"PwmUnit": {"tables": [{"output": 1, "interval": 0,
                                                 "power": [5, 7], "config": 10.5}] * 8}}}},
    {"flash": {"axis": {f"{PRA_HOME_MODE:#x}": [99.0] * 8,
                        f"{PRA_ACC:#x}": [-5.0] * 8}}},  # out of range
]


@pytest.mark.parametrize("image", FOREIGN, ids=range(len(FOREIGN)))
def test_a_foreign_image_starts_the_card_from_its_defaults_with_a_warning(
        tmp_path: Path, caplog: pytest.LogCaptureFixture, image: Any) -> None:
    """Whatever the file holds, the card starts; what of it is not a legal value of this card
    is left at its default (a legal rest is kept), and the log says so."""
    store = NvramStore(tmp_path)
    store.save("amp0", image)
    with caplog.at_level(logging.WARNING):
        card = new_card(store)
    img = card.kernel.parameter_image()
    assert img == defaults()
    assert "flash image" in caplog.text
    k = card.kernel
    for no in range(len(pwm.unit(k).tables)):  # every table drives the VAO a while
        pwm.switch_vao_table(k, no)
        card.tick(5)
    assert all(math.isfinite(v) for v in k.board_params.values.values())


def test_an_image_of_the_4_axis_card_on_the_8_axis_card_is_set_aside(tmp_path: Path) -> None:
    """Rows of 4 values are no image an 8-axis card's commands make: the whole image is set
    aside, the card starts from its defaults (issue 22 §4: no partial restore)."""
    store = NvramStore(tmp_path)
    small = new_card(store, "AMP-204C").kernel
    small.axis_params.set(1, PRA_ACC, 777.0)
    small.board_params.values[PRB_DO_LOGIC] = 1.0
    cmd_system.save_parameter_to_flash(small)
    store.save("amp0", {"flash": small.flash})
    k = new_card(store).kernel
    assert k.axis_params.get(1, PRA_ACC) == 1e6
    assert k.parameter_image() == defaults()
    assert (tmp_path / "amp0.nvram.corrupt").exists()
