"""The Octavia's command table [Ch5; spec octavia.md §4.2]: each RTC mnemonic and the function of
a `cmd_*` module that runs it, as `handler(fw, head, groups)` with the fields `vdevmaps.octavia`
decoded. Plain data; the firmware binds it."""

from __future__ import annotations

from vdevd.devices.commands import Command, CommandTable

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
    # cam and gearing [Ch5 "Coordinated Motion - Cam", "- Gearing"]: cmd_cam, cmd_gear
    Command("CAM", "cam", section="Ch5 CAM"),
    Command("CAM_POS", "cam_pos", section="Ch5 CAM_POS"),
    Command("CAM_PROBE", "cam_probe", section="Ch5 CAM_PROBE"),
    Command("CAM_OFF", "cam_off", section="Ch5 CAM_OFF"),
    Command("CAM_OFF_ACC", "cam_off_acc", section="Ch5 CAM_OFF_ACC"),
    Command("CAM_POINT", "cam_point", section="Ch5 CAM_POINT"),
    Command("LOAD_CAM_TABLE", "load_cam_table", section="Ch5 LOAD_CAM_TABLE"),
    Command("GEAR", "gear", section="Ch5 GEAR"),
    Command("GEAR_POS", "gear_pos", section="Ch5 GEAR_POS"),
    Command("GEAR_PROBE", "gear_probe", section="Ch5 GEAR_PROBE"),
    Command("GEAR_OFF", "gear_off", section="Ch5 GEAR_OFF"),
    Command("GEAR_OFF_ACC", "gear_off_acc", section="Ch5 GEAR_OFF_ACC"),
    Command("REL_AXMOVE_SLAVE", "rel_axmove_slave", section="Ch5 REL_AXMOVE_SLAVE"),
    # tables [Ch5 "DSPL ... Table Related", LOAD_CUBIC_TABLE, CLEAR_CUBIC_TABLE; Ch8]: cmd_tables
    Command("TABLE_SEL", "table_sel", section="Ch5 TABLE_SEL"),
    Command("LOAD_POS_TABLE", "load_pos_table", section="Ch5 LOAD_POS_TABLE"),
    Command("LOAD_VEL_TABLE", "load_vel_table", section="Ch5 LOAD_VEL_TABLE"),
    Command("CLEAR_POS_TABLE", "clear_pos_table", section="Ch5 CLEAR_POS_TABLE"),
    Command("CLEAR_VEL_TABLE", "clear_vel_table", section="Ch5 CLEAR_VEL_TABLE"),
    Command("LOAD_CUBIC_TABLE", "load_cubic_table", section="Ch5 LOAD_CUBIC_TABLE"),
    Command("CLEAR_CUBIC_TABLE", "clear_cubic_table", section="Ch5 CLEAR_CUBIC_TABLE"),
    # DSPL [Ch5 "DSPL ... Variable Related", "Flagging"; spec §7]: cmd_dspl
    Command("CHANGE_VAR", "change_var", section="Ch5 CHANGE_VAR"),
    Command("MONITOR_VAR", "monitor_var", section="Ch5 MONITOR_VAR"),
    Command("START_DSPL", "start_dspl", section="Ch5 START_DSPL"),
    Command("STOP_DSPL", "stop_dspl", section="Ch5 STOP_DSPL"),
    Command("SIGNAL_DSPL", "signal_dspl", section="Ch5 SIGNAL_DSPL"),
    Command("CLEAR_DSPL", "clear_dspl", section="Ch5 CLEAR_DSPL"),
    Command("DSPL_AUTOSTART", "dspl_autostart", section="Ch5 DSPL_AUTOSTART"),
])
