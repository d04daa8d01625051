"""PWM outputs and the VAO (laser power) controller [M §4.9.3; spec adlink.md §2.17]: plain PWM
per channel (frequency, width, on), the VAO tables that map the composite speed of selected
axes to PWM power, and the DO gating of PRB_PWMx_MAP_DO [M §4.9.3.6].

The outputs are state, not waveforms (spec §2.17 ASSUMPTION): per channel whether it outputs
and its frequency (Hz), width (ns) and duty (%), recomputed every motion cycle and after every
command that changes them. PWM channels are the TRG outputs: 2 on the AMP-204C, 4 on the
AMP-208C (spec Q25). One VAO controller drives the channels `APS_start_vao` enabled from the
table `APS_switch_vao_table` selected (spec Q17).
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field
from typing import TYPE_CHECKING, Any

import numpy as np
from vdevmaps.aps_defs import (
    PRB_PWM0_MAP_DO,
    PWM_FREQUENCY_MAX,
    PWM_FREQUENCY_MIN,
    PWM_MAP_DO_CH_MASK,
    PWM_MAP_DO_DISABLED,
    PWM_MAP_DO_LOGIC,
    PWM_WIDTH_MAX,
    PWM_WIDTH_MIN,
    VAO_INPUT_COMMAND,
    VAO_INPUT_FEEDBACK,
    VAO_OUTPUT_FIX_DUTY,
    VAO_OUTPUT_FIX_FREQUENCY,
    VAO_OUTPUT_FIX_WIDTH,
    VAO_TABLE_COUNT,
    VAO_TABLE_MAX_POINTS,
    VAO_TABLE_OUTPUT_TYPE,
    VAO_TABLE_PWM_CONFIG,
    VAO_TABLE_SRC,
)

from vdevd.devices.adlink.errors import ApsError, invalid

if TYPE_CHECKING:
    from vdevd.devices.adlink.kernel import Kernel

DUTY_STEPS = 2000  # mode 1 power and mode 3 config: N x 0.05 % [M §4.9.3.3, §4.9.3.5]
VAO_SRC_AXES = 0xF  # VAO_TABLE_SRC: axes 0-3 only, on both models [M §4.9.3.5] (Q17)
VAO_STATUS_PWM0 = 16  # APS_get_vao_status: bits 0-7 table active, bit 16 + n PWM n [X5 sample]
NO_TABLE = -1  # APS_switch_vao_table(-1) disables every table [X5 sample]
#: VAO_TABLE_PWM_Config's range by output type [M §4.9.3.5]
CONFIG_RANGE = {VAO_OUTPUT_FIX_FREQUENCY: (PWM_FREQUENCY_MIN, PWM_FREQUENCY_MAX),
                VAO_OUTPUT_FIX_WIDTH: (PWM_WIDTH_MIN, PWM_WIDTH_MAX),
                VAO_OUTPUT_FIX_DUTY: (1, DUTY_STEPS)}
#: the table's power range by output type: a duty 0-2000, or a frequency, Hz [M §4.9.3.3]
POWER_RANGE = {VAO_OUTPUT_FIX_FREQUENCY: (0, DUTY_STEPS),
               VAO_OUTPUT_FIX_WIDTH: (PWM_FREQUENCY_MIN, PWM_FREQUENCY_MAX),
               VAO_OUTPUT_FIX_DUTY: (PWM_FREQUENCY_MIN, PWM_FREQUENCY_MAX)}
# APS_check_vao_param's status bits (vdevd's encoding: 0 is "setting OK" [X5 sample])
CHECK_CONFIG, CHECK_NO_DATA, CHECK_POWER = 0x1, 0x2, 0x4


@dataclass
class VaoTable:
    """One VAO table: its parameters [M §4.9.3.5] and its (speed, power) points [X1]."""

    output: int = VAO_OUTPUT_FIX_FREQUENCY
    input: int = VAO_INPUT_FEEDBACK
    config: int = 100
    src: int = 0x01
    min_vel: int = 0
    interval: int = 0
    power: list[int] = field(default_factory=list)

    def check(self) -> int:
        """APS_check_vao_param's status: 0 when the table can drive the output."""
        lo, hi = CONFIG_RANGE[self.output]
        plo, phi = POWER_RANGE[self.output]
        return ((0 if lo <= self.config <= hi else CHECK_CONFIG)
                | (0 if self.power else CHECK_NO_DATA)
                | (0 if all(plo <= p <= phi for p in self.power) else CHECK_POWER))

    def power_at(self, speed: float) -> float:
        """The power at a composite speed: linear between points [M §4.9.3.3], the first or last
        point's power outside the table (spec §2.17 ASSUMPTION), to the 1-unit resolution."""
        pts = self.power
        if len(pts) == 1 or speed <= self.min_vel:
            return float(pts[0])
        x = (speed - self.min_vel) / self.interval
        i = int(x)
        if i >= len(pts) - 1:
            return float(pts[-1])
        return float(round(pts[i] + (pts[i + 1] - pts[i]) * (x - i)))

    def pwm(self, power: float) -> tuple[float, float, float]:
        """(frequency Hz, width ns, duty %) of a power in this table's output mode [M §4.9.3.2]."""
        if self.output == VAO_OUTPUT_FIX_FREQUENCY:
            freq, duty = float(self.config), power * 100.0 / DUTY_STEPS
            return freq, duty / 100.0 / freq * 1e9, duty
        if self.output == VAO_OUTPUT_FIX_WIDTH:
            width = float(self.config)
            return power, width, min(width * power / 1e7, 100.0)
        duty = self.config * 100.0 / DUTY_STEPS
        return power, duty / 100.0 / power * 1e9, duty


@dataclass
class Channel:
    """What one PWM output does now."""

    on: bool = False
    source: str = "off"  # off, pwm, vao
    frequency: float = 0.0
    width: float = 0.0
    duty: float = 0.0


class PwmUnit:
    """The PWM outputs and the VAO controller of one card."""

    def __init__(self, k: Kernel) -> None:
        self.k = k
        self.channels = 2 if k.n == 4 else 4
        self.tables = [VaoTable() for _ in range(VAO_TABLE_COUNT)]
        self.reset()

    def reset(self) -> None:
        """Power-up: every output off; PWM 1000 Hz, 1000 ns (vdevd's choice, the values of
        ADLINK's PWM sample [X5]); the VAO tables keep their parameters (flash image)."""
        self.frequency = [1000] * 4
        self.width = [1000] * 4
        self.pwm_on = [False] * 4
        self.vao_mask = 0  # the channels APS_start_vao enabled
        self.table = NO_TABLE  # the table APS_switch_vao_table selected
        self.speed = 0.0  # the VAO's composite speed, pulses/s
        self.power = 0.0
        self.vao: tuple[float, float, float] | None = None  # its (frequency, width, duty)
        self.out = [Channel() for _ in range(4)]

    # -- the cycle ---------------------------------------------------------------------------
    def before_motion(self, t: float) -> None:
        pass

    def after_motion(self, t: float) -> None:
        self.refresh()

    def busy(self) -> bool:
        return False  # the outputs follow the axes and the DO word, both at rest then

    def motion_only(self) -> bool:
        """The outputs are those of the axes and the DO word now: a run's last cycle sets them
        (runs.py)."""
        return True

    def refresh(self) -> None:
        """Recompute every channel: VAO (it takes precedence when both are on, [X5]: "do not use
        them at the same time"), else plain PWM; then the DO gating [M §4.9.3.6]."""
        self.vao = vao = self.vao_output()
        for ch in range(self.channels):
            c = self.out[ch]
            if self.vao_mask >> ch & 1 and vao is not None:
                c.source = "vao"
                c.frequency, c.width, c.duty = vao
            elif self.pwm_on[ch]:
                c.source = "pwm"
                c.frequency, c.width = float(self.frequency[ch]), float(self.width[ch])
                c.duty = min(c.width * c.frequency / 1e7, 100.0)
            else:
                c.source, c.frequency, c.width, c.duty = "off", 0.0, 0.0, 0.0
            c.on = c.source != "off" and self.gate(ch)

    def gate(self, ch: int) -> bool:
        """PRB_PWMx_MAP_DO: -1 no gating; else DO channel (bits 0-7) and logic (bit 8: 1, the DO
        on enables the PWM; 0, the DO on disables it) [M §4.9.3.6]. "On" is the DO bit as
        written (APS_write_d_output), before PRB_DO_LOGIC (ASSUMPTION)."""
        m = int(self.k.board_params.values[PRB_PWM0_MAP_DO + ch])
        if m == PWM_MAP_DO_DISABLED:
            return True
        do_on = bool(self.k.do_word >> (m & PWM_MAP_DO_CH_MASK) & 1)
        return do_on == bool(m & PWM_MAP_DO_LOGIC)

    def vao_output(self) -> tuple[float, float, float] | None:
        """The VAO's (frequency, width, duty) from the composite speed of the active table's
        source axes (command or feedback velocity, pulses/s) [M §4.9.3.1, §4.9.3.3]; None when
        no usable table is selected."""
        if self.table == NO_TABLE:
            self.speed = self.power = 0.0
            return None
        tab = self.tables[self.table]
        if tab.check():
            return None
        k = self.k
        ax = k.core.axes
        if tab.input == VAO_INPUT_COMMAND:
            vel = ax.cmd_vel
        else:
            vel = ax.vel if k.drive == "servo" else ax.cmd_vel * k.svon
        axes = [a for a in range(min(4, k.n)) if tab.src >> a & 1]
        self.speed = float(math.sqrt(float(np.sum(vel[axes] ** 2))))
        self.power = tab.power_at(self.speed)
        return tab.pwm(self.power)

    def outputs(self) -> dict[str, Any]:
        """The backdoor's view of the PWM channels and the VAO controller."""
        freq, width, duty = self.vao if self.vao is not None else (0.0, 0.0, 0.0)
        return {
            "pwm": [{"on": c.on, "source": c.source, "frequency": c.frequency,
                     "width": c.width, "duty": c.duty} for c in self.out[:self.channels]],
            "vao": [{"table": self.table, "channels": self.vao_mask, "speed": self.speed,
                     "power": self.power, "frequency": freq, "width": width, "duty": duty}],
        }

    def image(self) -> dict[str, Any]:
        return {"tables": [vars(t).copy() for t in self.tables]}

    def restore(self, image: Any) -> int:
        """Take a saved image's tables, each one a table the commands could have left (else it
        keeps its parameters); the count of tables left out."""
        saved = image.get("tables") if isinstance(image, dict) else None
        if not isinstance(saved, list) or len(saved) != VAO_TABLE_COUNT:
            return 1
        dropped = 0
        for no, t in enumerate(saved):
            tab = _saved_table(t)
            if tab is None:
                dropped += 1
            else:
                self.tables[no] = tab
        return dropped

    def pwm_off(self) -> None:
        """Every PWM output off, plain and VAO (the watchdog's action bit 2, safety.py)."""
        self.pwm_on = [False] * 4
        self.vao_mask = 0
        self.refresh()

    def channel(self, ch: int) -> int:
        if not 0 <= ch < self.channels:
            raise invalid(f"PWM channel {ch} outside 0..{self.channels - 1} (spec Q25)")
        return ch


def unit(k: Kernel) -> PwmUnit:
    return next(u for u in k.units if isinstance(u, PwmUnit))


def _saved_table(t: Any) -> VaoTable | None:
    """A table of a flash image, if the VAO commands could have made it: whole numbers, a known
    output and input type, source axes, powers in the output type's range and a positive
    interval between two or more points (PWM_Config may lie outside its output type's range:
    set_vao_param allows that, APS_check_vao_param reports it)."""
    if not isinstance(t, dict) or set(t) != set(vars(VaoTable())):
        return None
    power = t["power"]
    numbers = [t[name] for name in ("output", "input", "config", "src", "min_vel", "interval")]
    if not isinstance(power, list) or not all(
            isinstance(v, int) and not isinstance(v, bool) for v in numbers + power):
        return None
    tab = VaoTable(**t)
    try:
        for name in ("output", "input", "src"):
            _check_value(tab, name, t[name])
        if power:
            _check_table(tab.output, tab.min_vel, tab.interval, power)
    except ApsError:
        return None
    return tab


def _table(no: int) -> int:
    if not 0 <= no < VAO_TABLE_COUNT:
        raise invalid(f"VAO table {no} outside 0..{VAO_TABLE_COUNT - 1}")
    return no


def _param(no: int) -> tuple[str, int]:
    """A VAO parameter number -> (field, table) [M §4.9.3.5]."""
    if VAO_TABLE_OUTPUT_TYPE <= no < VAO_TABLE_OUTPUT_TYPE + 2 * VAO_TABLE_COUNT:
        return ("output" if no % 2 == VAO_TABLE_OUTPUT_TYPE else "input"), no // 2
    for base, name in ((VAO_TABLE_PWM_CONFIG, "config"), (VAO_TABLE_SRC, "src")):
        if base <= no < base + VAO_TABLE_COUNT:
            return name, no - base
    raise invalid(f"VAO parameter {no:#x}")


def _check_value(tab: VaoTable, name: str, v: int) -> None:
    ok = {"output": v in CONFIG_RANGE,
          "input": v in (VAO_INPUT_FEEDBACK, VAO_INPUT_COMMAND),
          "config": CONFIG_RANGE[tab.output][0] <= v <= CONFIG_RANGE[tab.output][1],
          "src": 0 < v <= VAO_SRC_AXES}[name]
    if not ok:
        raise invalid(f"VAO {name} {v}")


def _check_table(output: int, min_vel: int, interval: int, data: list[int]) -> None:
    lo, hi = POWER_RANGE[output]
    if not 1 <= len(data) <= VAO_TABLE_MAX_POINTS or min_vel < 0:
        raise invalid(f"{len(data)} VAO points from {min_vel}")
    if len(data) > 1 and interval <= 0:
        raise invalid(f"VelInterval {interval}")
    if not all(lo <= p <= hi for p in data):
        raise invalid(f"VAO power outside {lo}..{hi}")


# -- kernel commands [spec §4.9] -----------------------------------------------------------------

def set_vao_param(k: Kernel, no: int, value: int) -> None:
    """APS_set_vao_param [M §4.9.3.5]; PWM_Config is checked against the table's output type
    (a later change of type shows in APS_check_vao_param)."""
    u = unit(k)
    name, t = _param(no)
    _check_value(u.tables[t], name, value)
    setattr(u.tables[t], name, value)
    u.refresh()


def get_vao_param(k: Kernel, no: int) -> int:
    name, t = _param(no)
    return int(getattr(unit(k).tables[t], name))


def set_vao_table(k: Kernel, no: int, min_vel: int, interval: int, data: list[int]) -> None:
    """APS_set_vao_table: point i at speed MinVelocity + i x VelInterval (pulses/s) has power
    data[i]; 1-32 points [M §4.9.3.7], powers in the table's output mode's range."""
    u = unit(k)
    tab = u.tables[_table(no)]
    _check_table(tab.output, min_vel, interval, data)
    tab.min_vel, tab.interval, tab.power = min_vel, interval, list(data)
    u.refresh()


def switch_vao_table(k: Kernel, no: int) -> None:
    """APS_switch_vao_table [M §4.9.3.7]; -1 disables every table [X5 sample]."""
    u = unit(k)
    u.table = no if no == NO_TABLE else _table(no)
    u.refresh()


def start_vao(k: Kernel, mask: int, enable: int) -> None:
    """APS_start_vao [M §4.9.3.4]: Output_Ch is a bit mask of PWM channels (spec Q17)."""
    u = unit(k)
    if not 0 < mask < 1 << u.channels or enable not in (0, 1):
        raise invalid(f"Output_Ch {mask:#x}, Enable {enable}")
    u.vao_mask = u.vao_mask | mask if enable else u.vao_mask & ~mask
    u.refresh()


def get_vao_status(k: Kernel) -> int:
    """Bits 0-7: the active table; bit 16 + n: VAO drives PWM n [X5 sample's comment]."""
    u = unit(k)
    active = 1 << u.table if u.table != NO_TABLE else 0
    return active | u.vao_mask << VAO_STATUS_PWM0


def check_vao_param(k: Kernel, no: int) -> int:
    return unit(k).tables[_table(no)].check()


def set_vao_param_ex(k: Kernel, no: int, output: int, input_type: int, config: int, src: int,
                     min_vel: int, interval: int, data: list[int]) -> None:
    """APS_set_vao_param_ex: a whole table (VAO_DATA) at once, all checked first."""
    u = unit(k)
    _table(no)
    new = VaoTable(output=output if output in CONFIG_RANGE else VAO_OUTPUT_FIX_FREQUENCY)
    for name, v in (("output", output), ("input", input_type), ("config", config),
                    ("src", src)):
        _check_value(new, name, v)
    _check_table(output, min_vel, interval, data)
    u.tables[no] = VaoTable(output, input_type, config, src, min_vel, interval, list(data))
    u.refresh()


def get_vao_param_ex(k: Kernel, no: int) -> list[Any]:
    t = unit(k).tables[_table(no)]
    return [t.output, t.input, t.config, t.src, t.min_vel, t.interval, list(t.power)]


def set_pwm_frequency(k: Kernel, ch: int, hz: int) -> None:
    """APS_set_pwm_frequency [X5]: 3 ... 50 000 000 Hz."""
    u = unit(k)
    if not PWM_FREQUENCY_MIN <= hz <= PWM_FREQUENCY_MAX:
        raise invalid(f"PWM frequency {hz}")
    u.frequency[u.channel(ch)] = hz
    u.refresh()


def get_pwm_frequency(k: Kernel, ch: int) -> int:
    u = unit(k)
    return u.frequency[u.channel(ch)]


def set_pwm_width(k: Kernel, ch: int, ns: int) -> None:
    """APS_set_pwm_width [X5]: 20 ... 335 544 300 ns."""
    u = unit(k)
    if not PWM_WIDTH_MIN <= ns <= PWM_WIDTH_MAX:
        raise invalid(f"PWM width {ns}")
    u.width[u.channel(ch)] = ns
    u.refresh()


def get_pwm_width(k: Kernel, ch: int) -> int:
    u = unit(k)
    return u.width[u.channel(ch)]


def set_pwm_on(k: Kernel, ch: int, on: int) -> None:
    """APS_set_pwm_on [X5]."""
    u = unit(k)
    if on not in (0, 1):
        raise invalid(f"PWM_On {on}")
    u.pwm_on[u.channel(ch)] = bool(on)
    u.refresh()
