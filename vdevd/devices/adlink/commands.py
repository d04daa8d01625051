"""The kernel's command table [spec adlink.md §4]: each mailbox command (vdevmaps.adlink.CALLS)
and the function of a kernel module that runs it, as `handler(kernel, *args)`. Plain data; the
kernel binds it."""

from __future__ import annotations

from vdevd.devices.commands import Command, CommandTable

COMMANDS = CommandTable([
    # system and parameters [M §4.1]
    Command("reset", "reset", section="vdevd"),
    Command("set_board_param", "set_board_param", section="M 4.9.3.6"),
    Command("get_board_param", "get_board_param", section="M 4.9.3.6"),
    Command("set_axis_param", "set_axis_param", section="M 4.1.1.3"),
    Command("get_axis_param", "get_axis_param", section="M 4.1.1.3"),
    Command("set_axis_param_f", "set_axis_param_f", section="M 4.4"),
    Command("get_axis_param_f", "get_axis_param_f", section="M 4.4"),
    Command("save_parameter_to_flash", "save_parameter_to_flash", section="X1"),
    Command("load_parameter_from_flash", "load_parameter_from_flash", section="X1"),
    Command("load_parameter_from_default", "load_parameter_from_default", section="X1"),
    Command("get_timing", "get_timing", section="M 4.1.2"),
    Command("reset_timing", "reset_timing", section="M 4.1.2"),
    Command("set_servo_on", "set_servo_on", section="M 4.1.1.4"),
    Command("set_command_f", "set_command_f", section="M 4.2.1"),
    Command("set_position_f", "set_position_f", section="M 4.2.1"),
    # single-axis motion [M §4.3-4.6, §4.9.5]
    Command("ptp", "ptp", section="M 4.6.1"),
    Command("vel", "vel", section="M 4.4"),
    Command("stop_move", "stop_move", section="M 4.4"),
    Command("emg_stop", "emg_stop", section="M 4.4"),
    Command("move_trigger", "move_trigger", section="M 4.9.5"),
    Command("home_move", "home_move", section="M 4.3"),
    Command("jog_start", "jog_start", section="M 4.5"),
    Command("ptp_counts", "ptp_counts", section="M 4.6.1"),
    Command("velocity_counts", "velocity_counts", section="M 4.4"),
    # interpolation [M §4.7]
    # -- end of interpolation
    # gearing and gantry [M §4.9.1]
    Command("start_gear", "start_gear", section="M 4.9.1"),
    # -- end of gearing
    # compare trigger and timer [M §4.9.2]
    # -- end of trigger
    # PWM and VAO [M §4.9.3]
    # -- end of PWM/VAO
    # digital I/O (spec §2.18)
    # -- end of digital I/O
    # interrupts [M §4.11]
    # -- end of interrupts
    # data sampling [M §4.9.4]
    # -- end of sampling
    # point table [M §4.9.6]
    # -- end of point table
    # safety and watchdog [M §4.10]
    Command("wdt_start", "wdt_start", section="M 4.10.2.3"),
    Command("wdt_get_timeout_period", "wdt_get_timeout_period", section="M 4.10.2.3"),
    Command("wdt_reset_counter", "wdt_reset_counter", section="M 4.10.2.3"),
    Command("wdt_get_counter", "wdt_get_counter", section="X1"),
    Command("wdt_set_action_event", "wdt_set_action_event", section="M 4.10.2.3"),
    Command("wdt_get_action_event", "wdt_get_action_event", section="M 4.10.2.3"),
    # -- end of safety
])
