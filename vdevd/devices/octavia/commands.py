"""The Octavia's command table [Ch5; spec octavia.md §4.2]: each RTC mnemonic and the function of
a `cmd_*` module that runs it, as `handler(fw, head, groups)` with the fields `vdevmaps.octavia`
decoded. Plain data; the firmware binds it."""

from __future__ import annotations

from vdevd.devices.commands import Command, CommandTable

_LATER = "issue 18: the card's next step (contouring, cubic splines, cam, gearing, tables, DSPL)"

COMMANDS = CommandTable([
    # control law and initialization [Ch5 Control Law and Initialization]
    Command("CTRL", "ctrl", section="Ch5 CTRL"),
    Command("CTRL_KA", "ctrl_ka", section="Ch5 CTRL_KA"),
    Command("KILIMIT", "kilimit", section="Ch5 KILIMIT"),
    Command("OUTGAIN", "outgain", section="Ch5 OUTGAIN"),
    Command("TRQ_LIMIT", "trq_limit", section="Ch5 TRQ_LIMIT"),
    Command("MAXACC", "maxacc", section="Ch5 MAXACC"),
    Command("ESTOP_ACC", "estop_acc", section="Ch5 ESTOP_ACC"),
    Command("POS_PRESET", "pos_preset", section="Ch5 POS_PRESET"),
    Command("POS_SHIFT", "pos_shift", section="Ch5 POS_SHIFT"),
    Command("RESET", "reset", section="Ch5 RESET"),
    Command("SYNC", "sync", section="Ch5 SYNC"),
    Command("OVERRIDE", "override", section="Ch5 OVERRIDE"),
    Command("STEPPER_ON", "stepper_on", section="Ch5 STEPPER_ON"),
    Command("NOTCH", "notch", section="Ch5 NOTCH"),
    Command("LOW_PASS", "low_pass", section="Ch5 LOW_PASS"),
    Command("OFFSET", "offset", section="Ch5 OFFSET"),
    # simple motion [Ch5 Simple Motion]
    Command("AXMOVE", "axmove", ("abs", "trapezoid"), section="Ch5 AXMOVE"),
    Command("AXMOVE_S", "axmove", ("abs", "s_curve"), section="Ch5 AXMOVE_S"),
    Command("AXMOVE_T", "axmove", ("abs", "timed"), section="Ch5 AXMOVE_T"),
    Command("REL_AXMOVE", "axmove", ("rel", "trapezoid"), section="Ch5 REL_AXMOVE"),
    Command("REL_AXMOVE_S", "axmove", ("rel", "s_curve"), section="Ch5 REL_AXMOVE_S"),
    Command("REL_AXMOVE_T", "axmove", ("rel", "timed"), section="Ch5 REL_AXMOVE_T"),
    Command("DDAC", "ddac", section="Ch5 DDAC"),
    Command("STOP", "stop", section="Ch5 STOP"),
    Command("VELMODE", "velmode", section="Ch5 VELMODE"),
    # interrupt control [Ch5 Interrupt Control]
    Command("EN_BUFBRK", "en_bufbrk", section="Ch5 EN_BUFBRK"),
    Command("EN_ENCFLT", "en_encflt", section="Ch5 EN_ENCFLT"),
    Command("EN_ERR", "en_err", section="Ch5 EN_ERR"),
    Command("EN_ERRHLT", "en_errhlt", section="Ch5 EN_ERRHLT"),
    Command("EN_INDEX", "en_index", section="Ch5 EN_INDEX"),
    Command("EN_MOTCP", "en_motcp", section="Ch5 EN_MOTCP"),
    Command("EN_POSBRK", "en_posbrk", section="Ch5 EN_POSBRK"),
    Command("EN_PROBE", "en_probe", section="Ch5 EN_PROBE"),
    Command("DISABL_INT", "disabl_int", section="Ch5 DISABL_INT"),
    Command("DISABL2_INT", "disabl2_int", section="Ch5 DISABL2_INT"),
    Command("INT5MS", "int5ms", section="Ch5 INT5MS"),
    # input / output and diagnostics [Ch5 Input/Output, Diagnostics]
    Command("OUTP_ON", "outp", (True,), section="Ch5 OUTP_ON"),
    Command("OUTP_OFF", "outp", (False,), section="Ch5 OUTP_OFF"),
    Command("INP_STATE", "inp_state", section="Ch5 INP_STATE"),
    Command("POSBRK_OUT", "posbrk_out", section="Ch5 POSBRK_OUT"),
    Command("PARREAD", "parread", section="Ch5 PARREAD"),
    # NURBS [Ch9]: codes assigned by vdevd (vdevmaps.octavia NURBS_RTCS)
    Command("NURBS", "nurbs", section="Ch9"),
    Command("NURBS_BUFBRK", "nurbs_bufbrk", section="Ch9"),
    Command("NURBS_FEEDRATE", "nurbs_feedrate", section="Ch9"),
    # contouring [Ch5 Contouring; cmd_contour.py]
    Command("BTRATE", "btrate", section="Ch5 BTRATE"),
    Command("CUBIC_RATE", "cubic_rate", section="Ch5 CUBIC_RATE"),
    Command("START", "start", section="Ch5 START"),
    Command("VECCHG", "vecchg", section="Ch5 VECCHG"),
    Command("CUBIC_SCALE", "cubic_scale", section="Ch5 CUBIC_SCALE"),
    Command("CUBIC_INT", "cubic_int", section="Ch5 CUBIC_INT"),
], not_emulated={name: _LATER for name in (
    "LOAD_CUBIC_TABLE", "CLEAR_CUBIC_TABLE", "CAM", "CAM_POS", "CAM_PROBE",
    "CAM_OFF", "CAM_OFF_ACC", "CAM_POINT", "LOAD_CAM_TABLE", "GEAR", "GEAR_POS", "GEAR_PROBE",
    "GEAR_OFF", "GEAR_OFF_ACC", "REL_AXMOVE_SLAVE", "TABLE_SEL", "LOAD_POS_TABLE",
    "LOAD_VEL_TABLE", "CLEAR_POS_TABLE", "CLEAR_VEL_TABLE", "START_DSPL", "STOP_DSPL",
    "SIGNAL_DSPL", "CLEAR_DSPL", "DSPL_AUTOSTART", "CHANGE_VAR", "MONITOR_VAR")})
