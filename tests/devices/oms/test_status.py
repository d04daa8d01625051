"""Status the host reads from the MAXk: the QA/RA/QI/RI replies and their done flag [spec oms.md
§3.4, §4.2, §8.8], the per-axis reports (`AA RP`, PP, PE), and the status words published in
shared memory every update cycle (positions, Table 3-2 limits, Table 3-3 home, Table 3-4 firmware
state) [S §3.6 Table 3-1; spec §2.2-2.3]."""

from __future__ import annotations

import re
from collections.abc import Iterator

import pytest
import vdevclient
from vdevmaps.oms import AxisFlags, FirmwareState, MaxkDoorbell, Shm

from tests.devices.oms.conftest import Maxk, card_config
from vdevd.testing import DaemonThread

QA_FIELD = re.compile(r"[PM][DN][LN][HN]")  # direction, done, over-travel, home [spec §4.2]


def finish(maxk: Maxk, moves: str, ticks: int = 200) -> None:
    """Send moves that end with ID and let them finish."""
    maxk.send(moves)
    maxk.step(ticks)


# -- reply formats ------------------------------------------------------------------------------------
def test_qa_is_four_characters(maxk: Maxk) -> None:
    """spec §4.2: `[P|M]` direction, `[D|N]` done, `[L|N]` over-travel, `[H|N]` home."""
    assert maxk.query("AX QA;") == "PNNN"
    assert QA_FIELD.fullmatch(maxk.query("AY RA;"))


@pytest.mark.parametrize("query", ["QI;", "RI;", "AA QA;", "AM QA;"])
def test_multi_axis_status_is_one_field_per_installed_axis(maxk: Maxk, query: str) -> None:
    """spec §4.2: `MDNN,MDNN,PNLN,PNNN,...`: comma separated, no trailing comma (§8.9)."""
    fields = maxk.query(query).split(",")
    assert len(fields) == 4
    assert all(QA_FIELD.fullmatch(f) for f in fields)


@pytest.mark.parametrize("query", ["AA RP;", "AA RE;", "AM PP;", "AM PE;", "AA RV;", "AA RQC;"])
def test_aa_reports_have_four_fields(maxk: Maxk, query: str) -> None:
    """spec §4.1: "The number of fields in `AA RP` is how EPICS discovers the axis count"."""
    assert len(maxk.query(query).split(",")) == 4


@pytest.mark.parametrize("axes", [1, 2, 10])
def test_aa_rp_counts_the_installed_axes(axes: int) -> None:
    with DaemonThread(card_config(axes=axes)) as d, \
            vdevclient.connect(d.endpoint, d.events, timeout=10) as rack:
        maxk = Maxk(rack)
        assert maxk.query("AA RP;") == ",".join(["0"] * axes)
        assert len(maxk.query("QI;").split(",")) == axes


def test_direction_follows_the_last_move(maxk: Maxk) -> None:
    finish(maxk, "AX MR-100 GO ID; AY MR100 GO ID;")
    assert maxk.query("AX QA;")[0] == "M"
    assert maxk.query("AY QA;")[0] == "P"


# -- the done flag [spec §3.4, §8.8] ------------------------------------------------------------------
def test_qa_does_not_clear_done_and_ra_does(maxk: Maxk) -> None:
    """spec §8.8: "RA/RI clear done only; QA/QI are non-destructive"."""
    finish(maxk, "AX MR100 GO ID;")
    assert maxk.query("QA;") == "PDNN"
    assert maxk.query("QA;") == "PDNN"
    assert maxk.query("RA;") == "PDNN"
    assert maxk.query("QA;") == "PNNN"
    assert maxk.query("RA;") == "PNNN"


def test_ra_clears_the_addressed_axis_only(maxk: Maxk) -> None:
    finish(maxk, "AX MR100 GO ID; AY MR100 GO ID;")
    assert maxk.query("AY RA;") == "PDNN"
    assert maxk.query("QI;") == "PDNN,PNNN,PNNN,PNNN"


def test_qi_does_not_clear_done_and_ri_does(maxk: Maxk) -> None:
    """CRM-1-11 "Query interrupt status" / "Report axes status" (spec §4.3)."""
    finish(maxk, "AX MR100 GO ID; AZ MR-100 GO ID;")
    assert maxk.query("QI;") == "PDNN,PNNN,MDNN,PNNN"
    assert maxk.query("QI;") == "PDNN,PNNN,MDNN,PNNN"
    assert maxk.query("RI;") == "PDNN,PNNN,MDNN,PNNN"
    assert maxk.query("QI;") == "PNNN,PNNN,MNNN,PNNN"


def test_ca_clears_the_done_flag_of_the_addressed_axis(maxk: Maxk) -> None:
    """CA "Clear done of addressed axis" [E-drvMAXv] (spec §3.4)."""
    finish(maxk, "AX MR100 GO ID; AY MR100 GO ID;")
    maxk.send("AX CA;")
    assert maxk.query("QI;") == "PNNN,PDNN,PNNN,PNNN"


def test_done_flag_and_doorbell_are_independent(maxk: Maxk) -> None:
    """spec §3.4: RA clears D, not the ODBR done bit; W1C of the ODBR bit leaves D."""
    finish(maxk, "AX MR100 GO ID;")
    assert maxk.odbr() == MaxkDoorbell.DONE_X
    maxk.query("RA;")
    assert maxk.odbr() == MaxkDoorbell.DONE_X
    finish(maxk, "MR100 GO ID;")
    maxk.clear_odbr(MaxkDoorbell.DONE_X)
    assert maxk.query("QA;") == "PDNN"


def test_gd_clears_done_as_it_starts(maxk: Maxk) -> None:
    """`GD`, EPICS' GO (spec §4.3, ✚): the done flag is cleared when the move starts."""
    finish(maxk, "AX MR100 GO ID;")
    maxk.send("AX VL1000 MR1000 GD;")
    maxk.step(5)
    assert maxk.query("QA;")[1] == "N"


# -- limits and home in QA [spec §3.4, §5.6, §5.5] -----------------------------------------------------
def test_limit_stops_the_axis_flags_overtravel_and_flushes_the_id(maxk: Maxk) -> None:
    """spec §3.4 "Over-travel": the axis stops, the queue is flushed (no done), ODBR bit 8 + axis,
    and QA shows 'L' while the switch is active."""
    maxk.send("AX VL10000; MR100000; GO; ID;")
    maxk.step(50)
    maxk.control("set_limits", axis="X", positive=True)
    maxk.step(5)
    assert maxk.query("RV;") == "0"
    assert maxk.query("QA;") == "PNLN"
    assert maxk.odbr() == MaxkDoorbell.OVERTRAVEL_X
    assert maxk.query("RQC;") == "2559"
    maxk.step(200)
    assert maxk.odbr() & 0xFF == 0


def test_move_away_from_the_limit_is_allowed(maxk: Maxk) -> None:
    """spec §5.6: "Motion away from it is allowed"."""
    maxk.control("set_limits", axis="X", positive=True)
    finish(maxk, "AX MR-100 GO ID;")
    assert maxk.query("RP;") == "-100"
    assert maxk.query("QA;") == "MDNN"


def test_home_switch_shows_in_qa(maxk: Maxk) -> None:
    """spec §5.5: "The home switch state is published in word 0x44 and as QA char 4 'H'"."""
    maxk.control("set_home", axis="Y", active=True)
    assert maxk.query("QI;") == "PNNN,PNNH,PNNN,PNNN"
    maxk.control("set_home", axis="Y", active=False)
    assert maxk.query("AY QA;") == "PNNN"


# -- the shared-memory status words [S Table 3-1 to 3-4; spec §2.2-2.3] ---------------------------------
def test_positions_are_published_every_cycle(maxk: Maxk) -> None:
    """Table 3-1: X..S motor positions at 0x000, encoder positions at 0x020, "updated each update
    cycle"; they agree with RP and RE."""
    maxk.send("AM VL10000,10000,10000,10000; MR1000,-2000,3000,-4000; GO;")
    maxk.step(30)
    moving = [maxk.word(Shm.MOTOR_POSITION + 4 * a) for a in range(4)]
    assert moving == [int(v) for v in maxk.query("AA RP;").split(",")]
    assert 0 < moving[0] < 1000
    maxk.step(600)
    assert [maxk.word(Shm.MOTOR_POSITION + 4 * a) for a in range(4)] == [1000, -2000, 3000, -4000]
    assert [maxk.word(Shm.ENCODER_POSITION + 4 * a) for a in range(4)] == [
        int(v) for v in maxk.query("AA RE;").split(",")]


def test_limit_word_is_raw_levels(maxk: Maxk) -> None:
    """Table 3-2: bits 0-7 negative, 8-15 positive limits, raw input levels; open inputs read 1
    and an active-low switch reads 0 (spec §2.3); QL answers the same word in hex."""
    assert maxk.shm.read32(Shm.LIMIT_SWITCH_STATUS) == 0x0F0F
    assert int(maxk.query("QL;"), 16) == 0x0F0F
    maxk.control("set_limits", axis="Y", positive=True)
    maxk.control("set_limits", axis="T", negative=True)
    assert maxk.shm.read32(Shm.LIMIT_SWITCH_STATUS) == 0x0F0F & ~(1 << 9) & ~(1 << 3)
    assert int(maxk.query("QL;"), 16) == maxk.shm.read32(Shm.LIMIT_SWITCH_STATUS)


def test_home_word_is_raw_levels(maxk: Maxk) -> None:
    """Table 3-3: bits 0-7 X..S home inputs (raw levels, factory active low)."""
    assert maxk.shm.read32(Shm.HOME_SWITCH_STATUS) == 0x0F
    maxk.control("set_home", axis="Z", active=True)
    assert maxk.shm.read32(Shm.HOME_SWITCH_STATUS) == 0x0F & ~(1 << 2)


def test_firmware_state_is_running_with_factory_parameters(maxk: Maxk) -> None:
    """Table 3-4 (spec §2.3): bit 2 running, bit 18 factory default parameter set loaded."""
    assert maxk.shm.read32(Shm.FIRMWARE_STATE) == FirmwareState.RUNNING | FirmwareState.FACTORY_SET


# -- a ten-axis card: W and K [S §3.4.5; spec §3.1, §8.4] --------------------------------------------
K_MOTOR = Shm.WK_MOTOR_POSITION + 4


def wk_flags(maxk: Maxk) -> tuple[int, int]:
    """The W and K status-flag words (spec §3.1)."""
    return maxk.shm.read32(Shm.W_STATUS_FLAGS), maxk.shm.read32(Shm.K_STATUS_FLAGS)


@pytest.fixture
def maxk10() -> Iterator[Maxk]:
    """A MAXk-A000: ten axes, X..S then W and K."""
    with DaemonThread(card_config(axes=10)) as d, \
            vdevclient.connect(d.endpoint, d.events, timeout=10) as rack:
        yield Maxk(rack)


def test_w_and_k_done_go_to_their_flag_words_and_notification_bits(maxk10: Maxk) -> None:
    """[S §3.4.5]: "The axis notification flags for the axes W and K in the ODBR indicate a
    done/overtravel/slip set bit in its axis status flag register"; the words at 0x0CC/0x0D0 have
    the ODBR layout (bit 0 done) and are cleared by writing ones (spec §3.1, ASSUMPTION)."""
    maxk = maxk10
    finish(maxk, "AW MR100 GO ID; AK MR-50 GO ID;", ticks=300)
    assert maxk.odbr() == MaxkDoorbell.W_NOTIFICATION | MaxkDoorbell.K_NOTIFICATION
    assert wk_flags(maxk) == (AxisFlags.DONE, AxisFlags.DONE)
    assert (maxk.word(Shm.WK_MOTOR_POSITION), maxk.word(K_MOTOR)) == (100, -50)
    assert maxk.query("QI;").split(",")[8:] == ["PDNN", "MDNN"]
    maxk.shm.write32(Shm.W_STATUS_FLAGS, AxisFlags.DONE)
    maxk.step(1)
    assert wk_flags(maxk) == (0, AxisFlags.DONE)
    assert maxk.odbr() == MaxkDoorbell.W_NOTIFICATION | MaxkDoorbell.K_NOTIFICATION, (
        "ODBR bit 25 stays until the host clears it")


def test_ten_axis_limit_and_home_words(maxk10: Maxk) -> None:
    """Table 3-2: W/K negative limits in bits 16-17, positive in 24-25; Table 3-3: W/K home in
    bits 8-9. Open inputs read 1."""
    assert maxk10.shm.read32(Shm.LIMIT_SWITCH_STATUS) == 0x0303FFFF
    assert maxk10.shm.read32(Shm.HOME_SWITCH_STATUS) == 0x3FF
    maxk10.control("set_limits", axis="K", positive=True)
    maxk10.control("set_home", axis="W", active=True)
    assert maxk10.shm.read32(Shm.LIMIT_SWITCH_STATUS) == 0x0103FFFF
    assert maxk10.shm.read32(Shm.HOME_SWITCH_STATUS) == 0x2FF
