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
    Command("get_axis_param_table", "get_axis_param_table", section="X1"),
    Command("get_board_param_table", "get_board_param_table", section="X1"),
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
    Command("line", "line", section="M 4.7.1"),
    Command("arc2_ca", "arc2_ca", section="M 4.7.2.2"),
    Command("arc2_ce", "arc2_ce", section="M 4.7.2.2"),
    Command("arc3_ca", "arc3_ca", section="M 4.7.2.1"),
    Command("arc3_ce", "arc3_ce", section="M 4.7.2.1"),
    Command("spiral_ca", "spiral_ca", section="M 4.7.2.3"),
    Command("spiral_ce", "spiral_ce", section="M 4.7.2.3"),
    Command("linear_counts", "linear_counts", section="M 4.7.1"),
    # -- end of interpolation
    # gearing and gantry [M §4.9.1]
    Command("start_gear", "start_gear", section="M 4.9.1"),
    # -- end of gearing
    # compare trigger and timer [M §4.9.2]
    Command("set_trigger_param", "set_trigger_param", section="M 4.9.2"),
    Command("get_trigger_param", "get_trigger_param", section="M 4.9.2"),
    Command("set_trigger_manual", "set_trigger_manual", section="M 4.9.2.1"),
    Command("set_trigger_linear", "set_trigger_linear", section="M 4.9.2.2.1"),
    Command("set_trigger_table", "set_trigger_table", section="M 4.9.2.2.2"),
    Command("get_trigger_linear_cmp", "get_trigger_linear_cmp", section="X1"),
    Command("get_trigger_table_cmp", "get_trigger_table_cmp", section="X1"),
    Command("get_trigger_count", "get_trigger_count", section="X1"),
    Command("reset_trigger_count", "reset_trigger_count", section="X1"),
    Command("enable_trigger_fifo_cmp", "enable_trigger_fifo_cmp", section="X1"),
    Command("get_trigger_fifo_status", "get_trigger_fifo_status", section="X1"),
    Command("set_trigger_fifo_data", "set_trigger_fifo_data", section="X1"),
    Command("get_timer_counter", "get_timer_counter", section="M 4.9.2"),
    Command("set_timer_counter", "set_timer_counter", section="M 4.9.2"),
    Command("start_timer", "start_timer", section="X1"),
    # -- end of trigger
    # PWM and VAO [M §4.9.3]
    Command("set_vao_param", "set_vao_param", section="M 4.9.3.5"),
    Command("get_vao_param", "get_vao_param", section="M 4.9.3.5"),
    Command("set_vao_table", "set_vao_table", section="M 4.9.3.7"),
    Command("switch_vao_table", "switch_vao_table", section="M 4.9.3.7"),
    Command("start_vao", "start_vao", section="M 4.9.3.4"),
    Command("get_vao_status", "get_vao_status", section="X1"),
    Command("check_vao_param", "check_vao_param", section="X1"),
    Command("set_vao_param_ex", "set_vao_param_ex", section="X1"),
    Command("get_vao_param_ex", "get_vao_param_ex", section="X1"),
    Command("set_pwm_frequency", "set_pwm_frequency", section="X5"),
    Command("get_pwm_frequency", "get_pwm_frequency", section="X5"),
    Command("set_pwm_width", "set_pwm_width", section="X5"),
    Command("get_pwm_width", "get_pwm_width", section="X5"),
    Command("set_pwm_on", "set_pwm_on", section="X5"),
    # -- end of PWM/VAO
    # digital I/O (spec §2.18)
    Command("read_d_input", "read_d_input", section="spec 2.18"),
    Command("write_d_output", "write_d_output", section="spec 2.18"),
    Command("read_d_output", "read_d_output", section="spec 2.18"),
    Command("write_d_channel_output", "write_d_channel_output", section="spec 2.18"),
    Command("read_d_channel_output", "read_d_channel_output", section="spec 2.18"),
    # -- end of digital I/O
    # interrupts [M §4.11]
    Command("int_enable", "int_enable", section="M 4.11"),
    Command("set_int_factor", "set_int_factor", section="M 4.11"),
    Command("get_int_factor", "get_int_factor", section="M 4.11"),
    Command("reset_int", "reset_int", section="M 4.11"),
    Command("set_int", "set_int", section="M 4.11"),
    # -- end of interrupts
    # data sampling [M §4.9.4]
    Command("set_sampling_param", "set_sampling_param", section="M 4.9.4"),
    Command("get_sampling_param", "get_sampling_param", section="M 4.9.4"),
    Command("set_sampling_param_ex", "set_sampling_param_ex", section="X3"),
    Command("get_sampling_param_ex", "get_sampling_param_ex", section="X3"),
    Command("start_trigger_sampling", "start_trigger_sampling", section="X1"),
    Command("stop_sampling", "stop_sampling", section="X1"),
    Command("auto_sampling", "auto_sampling", section="X1"),
    Command("read_sampling", "read_sampling", section="X1"),
    Command("take_sampling", "take_sampling", section="X1"),
    # -- end of sampling
    # point table [M §4.9.6]
    Command("pt_enable", "pt_enable", section="M 4.9.6.2"),
    Command("pt_disable", "pt_disable", section="M 4.9.6.2"),
    Command("pt_get_info", "pt_get_info", section="X1"),
    Command("pt_start", "pt_start", section="M 4.9.6.2"),
    Command("pt_stop", "pt_stop", section="M 4.9.6.2"),
    Command("pt_set_relative", "pt_set_relative", section="M 4.9.6.1"),
    Command("pt_set_profile", "pt_set_profile", section="M 4.9.6.1"),
    Command("pt_set_acc_dec", "pt_set_acc_dec", section="M 4.9.6.1"),
    Command("pt_get_profile", "pt_get_profile", section="X1"),
    Command("pt_set_trans", "pt_set_trans", section="M 4.9.6.1"),
    Command("pt_set_trans_inp", "pt_set_trans_inp", section="M 4.9.6.1"),
    Command("pt_ext_set_do_ch", "pt_ext_set_do_ch", section="M 4.9.6.1"),
    Command("pt_ext_set_table_no", "pt_ext_set_table_no", section="M 4.9.6.1"),
    Command("pt_line", "pt_line", section="M 4.9.6.1"),
    Command("pt_arc2_ca", "pt_arc2_ca", section="M 4.9.6.1"),
    Command("pt_arc2_ce", "pt_arc2_ce", section="M 4.9.6.1"),
    Command("pt_arc3_ca", "pt_arc3_ca", section="M 4.9.6.1"),
    Command("pt_arc3_ce", "pt_arc3_ce", section="M 4.9.6.1"),
    Command("pt_spiral_ca", "pt_spiral_ca", section="M 4.9.6.1"),
    Command("pt_spiral_ce", "pt_spiral_ce", section="M 4.9.6.1"),
    Command("pt_dwell", "pt_dwell", section="M 4.9.6.1"),
    Command("reset_pt_buffer", "reset_pt_buffer", section="X1"),
    Command("pt_roll_back", "pt_roll_back", section="X1"),
    Command("pt_get_error", "pt_get_error", section="X1"),
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
