"""The OMS MAXk issue's scenarios through the vendor API a user calls (`vdevclient.maxk`) against a
real lockstep daemon: the interrupt after a move, stepper and servo moves with their status
words, loops and ID, and the stored defaults surviving a daemon restart (spec oms.md §2.14,
§3.4, §4.3, §6.1)."""

from __future__ import annotations

from collections.abc import Iterator
from pathlib import Path

import pytest
import vdevclient
from vdevclient import maxk
from vdevmaps.oms import Omisr

from tests.client.galil import rack_config
from tests.client.test_maxk import MOVE_MS, maxk_card
from vdevd.testing import DaemonThread

FIRMWARE_USER_SET = 0x0001_0004  # running, power-up (user) parameters loaded [spec §2.3]
FIRMWARE_FACTORY = 0x0004_0004


@pytest.fixture
def mixed() -> Iterator[DaemonThread]:
    """One card, X a servo and Y a stepper with encoder (axis_types)."""
    cfg = rack_config(maxk_card(axis_types=["servo", "stepper_encoder", "stepper", "stepper"]))
    with DaemonThread(cfg) as d:
        yield d


def test_a_move_s_id_rings_the_done_doorbell_and_raises_inta(mixed: DaemonThread) -> None:
    """[S §3.4.1] "The host responds to the door bell interrupt": ID -> ODBR done bit -> ODI,
    published as an INTA event; wait_done sees the flag."""
    with vdevclient.connect(mixed.endpoint, mixed.events, timeout=10) as rack, \
            maxk.open(1, endpoint=mixed.endpoint) as m:
        irq = rack.card("maxk0").irq.subscribe()
        try:
            m.send_string("AX MR2000 GO ID")
            assert m.wait_done(0b1, MOVE_MS) == maxk.StatusFlags(done=0b1)
            rung = next((e for e in irq.events(timeout_s=10)
                         if e["line"] == "inta" and int(e["status"]) & Omisr.ODI), None)
            assert rung is not None  # the first such event ends the wait (not the timeout)
        finally:
            irq.close()


@pytest.mark.parametrize(("axis", "bit"), [("X", 0b1), ("Y", 0b10)])
def test_servo_and_stepper_moves_end_where_commanded_with_their_status(
        mixed: DaemonThread, axis: str, bit: int) -> None:
    """MR then MA on a servo (X) and a stepper with encoder (Y): done, RP and the positions
    words at the target, QA `P`/`M` by direction with done `D` (RA then clears it) [§4.3]."""
    index = "XY".index(axis)
    with vdevclient.connect(mixed.endpoint, mixed.events, timeout=10) as rack, \
            maxk.open(1, endpoint=mixed.endpoint) as m:
        m.send_string(f"A{axis} VL20000 AC200000 MR5000 GO ID")
        assert m.wait_done(bit, MOVE_MS).done == bit
        assert m.send_and_get_string(f"A{axis} RP") == "5000"
        assert m.send_and_get_string(f"A{axis} QA") == "PDNN"
        assert m.send_and_get_string(f"A{axis} RA") == "PDNN"
        assert m.send_and_get_string(f"A{axis} QA") == "PNNN"  # RA cleared done
        m.send_string(f"A{axis} MA-1200 GO ID")
        m.wait_done(bit, MOVE_MS)
        rack.sim.step(seconds=0.5)  # the servo's plant settles on the command
        positions = m.get_positions()
        assert positions.motor[index] == -1200
        assert abs(positions.encoder[index] + 1200) <= 2  # encoder ratio 1:1
        assert m.send_and_get_string(f"A{axis} QA") == "MDNN"


def test_a_loop_repeats_its_moves_and_id_marks_the_end(mixed: DaemonThread) -> None:
    """`LS3 ... LE` runs its body three times [S §6.2]; the ID after it sets done once."""
    with maxk.open(1, endpoint=mixed.endpoint) as m:
        m.send_string("AX VL20000 AC200000 LS3 MR1000 GO LE ID")
        assert m.wait_done(0b1, MOVE_MS) == maxk.StatusFlags(done=0b1)
        assert m.send_and_get_string("AX RP") == "3000"
        assert m.get_status_flags() == maxk.StatusFlags()  # one ID, one done


def test_stored_defaults_survive_a_daemon_restart(tmp_path: Path) -> None:
    """[S §2.14] APP stores the parameters; after a restart they are loaded and the firmware
    state word says the power-up (user) set is in use; RDF brings the factory set back."""
    cfg = rack_config(maxk_card())
    cfg.state_dir = str(tmp_path)
    with DaemonThread(cfg) as d, maxk.open(1, endpoint=d.endpoint) as m:
        assert m.read_fw_status() == FIRMWARE_FACTORY
        m.send_string("AX KP25 AY VL5000 ID")
        m.wait_done(0b10, MOVE_MS)
        m.send_string("APP")
    with DaemonThread(cfg) as d, maxk.open(1, endpoint=d.endpoint) as m:
        assert m.read_fw_status() == FIRMWARE_USER_SET
        assert m.send_and_get_string("AX KP?") == "=25.00"
        m.send_string("AY MR5000 GO")
        m.send_string("RDF")
        assert m.send_and_get_string("AX KP?") == "=10.00"
