"""The firmware options NOTCH and LOW_PASS at the control law's output, and OFFSET [Ch5 NOTCH,
LOW_PASS, OFFSET; spec §5.2]."""

from __future__ import annotations

import numpy as np
import pytest
from vdevmaps.octavia import Dpr, DspStat2, HostInt

from tests.devices.octavia.host import Host
from vdevd.devices.octavia import filters

DAC = 32767 / 10.0
KP = 2000  # 2000 x 0.595e-6 V x 3276.7 = 3.9 DAC codes per count of error


def output_path(option: str, rtc: str, head: dict[str, int]) -> tuple[np.ndarray, np.ndarray]:
    """Axis 1 blocked, Kp alone, a quick 400-count move: the law's output u = Kp x FE sample by
    sample, and what the DAC put out."""
    host = Host(firmware=option)
    host.rtc("CTRL", {"n": 1}, [dict(ki=0, kp=KP, kf=0, kd=0)])
    host.rtc(rtc, head)
    host.card.control("jam", {"axis": 1})
    host.rtc("AXMOVE", {"n": 1}, [{"acc": 0xFFFF, "pos": 400, "vel": 0xFFFFFF}])
    u, dac = [], []
    for _ in range(100):
        host.run(1)
        u.append(host.card.control("axis_state", {"axis": 1})["ferr"] * KP * 0.595e-6 * DAC)
        dac.append(host.card.control("get_outputs", {})["dac"][0])
    return np.array(u), np.array(dac, dtype=float)


def filtered(coeffs: filters.Coeffs | None, u: np.ndarray) -> np.ndarray:
    bq = filters.Biquads(1)
    if coeffs is not None:
        bq.set(0, coeffs)
    out = np.zeros(len(u))
    for k, x in enumerate(u):
        y = np.array([x])
        bq.apply(y, y)
        out[k] = y[0]
    return out


def test_low_pass_filters_the_law_output_every_sample() -> None:
    """LOW_PASS n=01h index 10 (275 Hz, damping 0.6) [Ch5 LOW_PASS example]: the DAC follows the
    law's output through the second-order low-pass: it lags a quick ramp, overshoots it (by less
    than a step's 9.5 % at damping 0.6) and settles on it (gain 1)."""
    u, dac = output_path("low_pass", "LOW_PASS", {"n": 0x01, "idx": 10})
    want = filtered(filters.low_pass(275), u)
    assert np.abs(dac - np.rint(want)).max() <= 1
    assert dac[3] < 0.8 * u[3]  # it lags
    assert u[-1] + 2 < dac.max() < u[-1] * (1 + np.exp(-np.pi * 0.6 / 0.8))
    assert dac[-1] == pytest.approx(u[-1], abs=1)


def test_notch_filters_the_law_output_and_index_0_or_freq_0_removes_it() -> None:
    """NOTCH n=02h freq 300 Hz q=01h [Ch5 NOTCH example] on axis 1 here: the DAC is the notch
    of the law's output (gain 1 at DC); NOTCH with freq 0 removes the filter."""
    u, dac = output_path("notch", "NOTCH", {"n": 0x01, "freq": 300, "q": 1})
    assert np.abs(dac - np.rint(filtered(filters.notch(300, 1), u))).max() <= 1
    assert np.abs(dac - np.rint(u)).max() > 2  # not the unfiltered output
    assert dac[-1] == pytest.approx(u[-1], abs=1)
    u, dac = output_path("notch", "NOTCH", {"n": 0x01, "freq": 0, "q": 0})
    assert np.abs(dac - np.rint(u)).max() <= 1


def test_an_out_of_range_filter_argument_is_ignored() -> None:
    host = Host(firmware="notch")
    host.rtc("NOTCH", {"n": 0x01, "freq": 2000, "q": 0})
    host.rtc("NOTCH", {"n": 0x01, "freq": 300, "q": 7})
    assert not host.card.fw.filters.active and host.card.fw.refused == 2
    lp = Host(firmware="low_pass")
    lp.rtc("LOW_PASS", {"n": 0x01, "idx": 47})
    assert not lp.card.fw.filters.active


def test_offset_measures_the_amplifier_offset_and_cancels_it() -> None:
    """OFFSET [Ch5 OFFSET]: an amplifier with +0.5 V of input offset; the integral channel
    holds the axis with -0.5 V at the DAC; OFFSET makes that the compensation, reports
    (DSPSTAT2 b2, 00Ch = 01h, 1FFEh b6), and the output goes on, now from the offset term."""
    host = Host()
    host.card.control("set_amp_offset", {"axis": 1, "volts": 0.5})
    host.rtc("CTRL", {"n": 1}, [dict(ki=2000, kp=4000, kf=3000, kd=2500)])
    host.run(25_000)
    out = host.card.control("get_outputs", {})
    assert out["dac_volts"][0] == pytest.approx(-0.5, abs=0.01)
    host.rtc("OFFSET", {"n": 0x01})
    k = host.run_until(Dpr.DSPSTAT2, DspStat2.OFFSET, 20_000)
    assert k >= 249  # 250 samples settled (the RTC's own sample was the first)
    assert host.u8(Dpr.INTAXIS_OFFSET) == 0x01 and host.u8(Dpr.HOSTINT1) & HostInt.STAT2
    fw = host.card.fw
    assert fw.params.offset_v[0] == pytest.approx(-0.5, abs=0.01)
    assert abs(fw.core.pid.integ[0] * fw.core.pid.ki[0]) < 0.01 * DAC
    host.run(5000)
    assert host.card.control("get_outputs", {})["dac_volts"][0] == pytest.approx(-0.5, abs=0.01)
    assert abs(host.error(1)) <= 1


def test_offset_without_an_integral_gain_reports_after_its_timeout_unchanged() -> None:
    """spec §5.2: Ki = 0 cannot settle the integrator: completion after 10 s, no change."""
    host = Host()
    host.rtc("CTRL", {"n": 1}, [dict(ki=0, kp=4000, kf=3000, kd=2500)])
    host.rtc("OFFSET", {"n": 0x01})
    assert host.run_until(Dpr.DSPSTAT2, DspStat2.OFFSET, 49_000) == -1
    assert host.run_until(Dpr.DSPSTAT2, DspStat2.OFFSET, 2_000) > 0
    assert host.card.fw.params.offset_v[0] == 0
