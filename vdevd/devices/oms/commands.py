"""The MAXk command table: every mnemonic the firmware runs, as plain data [spec oms.md §4.3].

Each `Command` names the handler function (in `cmd_system`, `cmd_motion`, `cmd_servo`, `cmd_io`
or `cmd_vector`; each takes the firmware and the parsed command and returns the reply text or
None), its operand kind (`syntax.Operand`, what the lexer lets follow the mnemonic) and the
section of the seed manual (`S §x`) or of its digest (`spec §x`) it comes from. The firmware binds
the table to those modules once (firmware.py); the lexer takes `OPERANDS`. Nothing here imports
a handler, so building the table has no side effect.

`COMMANDS.not_emulated` lists the mnemonics the digest names that the card refuses on purpose
(a command error), each with the reason (README "The command language").
"""

from __future__ import annotations

from vdevmaps.oms import AXES

from vdevd.devices.commands import Command, CommandTable
from vdevd.devices.oms.syntax import Operand

_NONE, _NUM, _HEX, _LET, _PT = (Operand.NONE, Operand.NUMBERS, Operand.HEX, Operand.LETTERS,
                                Operand.POINT)


def _same(names: str, handler: str, kind: Operand, section: str) -> list[Command]:
    """Several mnemonics one handler runs (it tells them apart by `cmd.mnemonic`)."""
    return [Command(name, handler, kind=kind, section=section) for name in names.split()]


#: servo gains [S §2.13]: `KP5` sets, `KP?` and the older `?KP` query
_GAINS = "KP KI KD KU KV KA KF KO"

COMMANDS = CommandTable(
    [
        # -- axis selection, system, flags (cmd_system) ---------------------------------------
        *_same(" ".join("A" + a for a in AXES), "select_axis", _NONE, "S App C L1336-1342"),
        Command("AA", "all_axes", kind=_NONE, section="S App C L1336-1342"),
        Command("AM", "multitasking", kind=_NONE, section="S App C L1336-1342"),
        Command("WY", "who_are_you", kind=_NONE, section="S §2.6"),
        Command("CA", "clear_done", kind=_NONE, section="spec §4.3"),
        Command("IC", "interrupt_clear", kind=_NONE, section="spec §4.3"),
        *_same("II EF", "accepted", _NONE, "spec §4.3"),
        Command("QA", "query_axis", kind=_NONE, section="spec §4.2"),
        Command("RA", "report_axis", kind=_NONE, section="spec §4.2"),
        Command("QI", "query_all", kind=_NONE, section="spec §4.2"),
        Command("RI", "report_all", kind=_NONE, section="spec §4.2"),
        Command("RP", "report_position", kind=_NONE, section="S §2.13"),
        Command("RE", "report_encoder", kind=_NONE, section="S §2.13"),
        Command("RV", "report_velocity", kind=_NONE, section="S §2.13"),
        Command("PP", "positions", kind=_NONE, section="spec §4.2"),
        Command("PE", "encoders", kind=_NONE, section="spec §4.2"),
        Command("RQC", "queue_free", kind=_NONE, section="spec §4.2"),
        *_same("#WS WS", "watchdog", _NUM, "spec §4.2"),
        Command("#UR", "update_rate", kind=_NUM, section="S §2.13"),
        Command("APP", "store_defaults", kind=_NONE, section="S §2.13-2.14"),
        Command("RDF", "restore_factory", kind=_NONE, section="S §2.14"),
        Command("RDP", "restore_power_up", kind=_NONE, section="S §2.14"),
        Command("RS", "reset", kind=_NONE, section="spec §4.3"),
        # -- motion and the queue (cmd_motion) ------------------------------------------------
        Command("MA", "move_absolute", kind=_NUM, section="S App C"),
        Command("MR", "move_relative", kind=_NUM, section="S §2.13"),
        *_same("MP MM", "direction_logic", _NONE, "spec §4.3"),
        Command("MO", "move_one", kind=_NONE, section="spec §4.3 (proposed, README)"),
        *_same("GO GD", "go", _NONE, "S App C, §6.2"),
        Command("JG", "jog", kind=_NUM, section="spec §4.3"),
        Command("ID", "interrupt_done", kind=_NONE, section="S App C"),
        Command("ST", "stop", kind=_NONE, section="spec §4.3"),
        Command("SA", "stop_all", kind=_NONE, section="spec §4.3"),
        Command("KL", "kill_all", kind=_NONE, section="spec §4.3"),
        Command("KS", "kill_selected", kind=_NUM, section="spec §4.3"),
        Command("SI", "stop_individual", kind=_NUM, section="spec §4.3"),
        Command("FL", "flush", kind=_NONE, section="spec §4.3"),
        Command("WQ", "wait_queue", kind=_NONE, section="spec §4.3"),
        Command("LS", "loop_start", kind=_NUM, section="S §6.2"),
        Command("LE", "loop_end", kind=_NONE, section="S §6.2"),
        Command("SW", "wait_input", kind=_NUM, section="spec §4.3"),
        Command("WT", "wait_time", kind=_NUM, section="spec §4.3"),
        # -- motion parameters (cmd_motion) ---------------------------------------------------
        *_same("VL VB AC", "motion_parameter", _NUM, "S §2.14"),
        *_same("HV HD HG ES SE", "motion_parameter", _NUM, "S §2.14"),
        Command("LP", "load_position", kind=_NUM, section="S §2.13"),
        Command("LO", "load_motor", kind=_NUM, section="spec §4.3"),
        Command("LPE", "load_encoder", kind=_NUM, section="spec §4.3"),
        # -- homing, capture, absolute encoders (cmd_motion) ----------------------------------
        *_same("HM HR KM KR", "home_search", _NUM, "S §4.3, §4.8"),
        *_same("HI HS", "home_mode", _NONE, "S §4.8"),
        *_same("HT EH", "home_truth_table", _NUM, "S §4.3, §4.8"),
        Command("CPH", "capture_home", kind=_NUM, section="S §3.7"),
        *_same("CPR CPF", "capture_inputs", _HEX, "S §3.7"),
        Command("ECA", "ssi_encoder", kind=_NUM, section="S §4.9.1"),
        # -- axis types, servo, encoders (cmd_servo) ------------------------------------------
        Command("PS", "axis_type", kind=_LET, section="S §2.9"),
        Command("?PS", "axis_type_old", kind=_NONE, section="spec §4.1"),
        *_same(_GAINS, "gain", _NUM, "S §2.13"),
        *_same(" ".join("?" + g for g in _GAINS.split()), "gain", _NONE, "S §2.13"),
        Command("CL", "closed_loop", kind=_NUM, section="S §2.13"),
        *_same("HN HF", "hold", _NONE, "S §2.13"),
        Command("SVP", "servo_polarity", kind=_LET, section="S §2.9"),
        *_same("EDI EDN", "encoder_direction", _NONE, "S §2.9"),
        Command("EA", "encoder_status", kind=_NONE, section="spec §4.2"),
        Command("ER", "encoder_ratio", kind=_NUM, section="spec §4.3"),
        Command("UU", "user_units", kind=_NUM, section="spec §4.3"),
        Command("UF", "user_units_off", kind=_NONE, section="spec §4.3"),
        # -- limits, home switches, I/O (cmd_io) ----------------------------------------------
        Command("LT", "limit_level", kind=_LET, section="S §4.2"),
        *_same("LH LL", "limit_level_legacy", _NONE, "spec §4.3"),
        Command("LM", "limit_mode", kind=_LET, section="S §4.2"),
        *_same("LF LN", "limits_off_on", _NONE, "spec §4.3"),
        *_same("HH HL", "home_level", _NONE, "S §2.14"),
        *_same("QL RL", "query_limits", _NONE, "spec §4.2"),
        Command("BD", "bit_direction", kind=_HEX, section="S §4.4"),
        Command("IO", "io_direction", kind=_NUM, section="spec §4.3"),
        *_same("BH BL", "bit_high_low", _NUM, "S §4.4"),
        Command("BW", "bit_write", kind=_HEX, section="S §4.4"),
        Command("BX", "bit_report", kind=_NONE, section="S §4.4"),
        Command("AI", "analog_input", kind=_NUM, section="S §4.5.1"),
        Command("AO", "analog_output", kind=_NUM, section="S §4.5.1"),
        *_same("AN AF", "aux_output", _NONE, "spec §4.3"),
        # -- coordinated moves and contours (cmd_vector) --------------------------------------
        Command("MT", "move_together", kind=_NUM, section="S App C L1356"),
        Command("VV", "vector_velocity", kind=_NUM, section="S App C"),
        Command("VA", "vector_acceleration", kind=_NUM, section="spec §4.3"),
        Command("VP", "vector_point", kind=_PT, section="S App C"),
        Command("VC", "vector_circle", kind=_PT, section="S App C"),
        Command("VIO", "vector_io", kind=_HEX, section="S App C"),
        Command("VE", "vector_end", kind=_NONE, section="S App C"),
        Command("VID", "vector_done", kind=_NUM, section="spec §4.3"),
        Command("VO", "vector_override", kind=_NUM, section="S App C"),
        Command("VOA", "vector_override_analog", kind=_NUM, section="S §4.5.1"),
        Command("VH", "vector_hold", kind=_NUM, section="spec §4.3"),
        Command("VG", "vector_go", kind=_NONE, section="spec §4.3"),
    ],
    not_emulated={
        "IOK": "listed in S §4.4 with no meaning in any source and no proposal in the digest: "
               "a command error",
        "?LS": "named in spec §4.1 only as an example of the older `?XX` query form; no source "
               "gives its meaning: a command error",
        "?PM": "named in spec §4.1 only as an example of the older `?XX` query form; no source "
               "gives its meaning: a command error",
    },
)

#: mnemonic -> operand kind, what the lexer reads (syntax.Lexer)
OPERANDS: dict[str, Operand] = {name: cmd.kind for name, cmd in COMMANDS.items()}
