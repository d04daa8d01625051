"""NOTCH and LOW_PASS: coefficients, ranges and the per-axis biquads [Ch5 NOTCH, LOW_PASS;
spec octavia.md §5.2, Q-25]."""

from __future__ import annotations

import math

import numpy as np
import pytest

from vdevd.devices.octavia.filters import (
    Biquads,
    Coeffs,
    low_pass,
    low_pass_frequency,
    notch,
)


def must(coeffs: Coeffs | None) -> Coeffs:
    assert coeffs is not None
    return coeffs


def gain(coeffs: Coeffs | None, freqs: list[float] | np.ndarray) -> np.ndarray:
    bank = Biquads(1)
    bank.set(0, must(coeffs))
    return bank.response(0, freqs)


def db(h: np.ndarray) -> np.ndarray:
    return 20 * np.log10(np.abs(h))


def run(bank: Biquads, inputs: np.ndarray) -> np.ndarray:
    """Feed rows of `inputs` (one column per axis) sample by sample."""
    out = np.zeros_like(inputs)
    for k, x in enumerate(inputs):
        bank.apply(x.copy(), out[k])
    return out


# --- NOTCH ---

@pytest.mark.parametrize("fn", [30, 300, 750, 1544])
@pytest.mark.parametrize("q", [0, 1])
def test_notch_removes_its_frequency_and_passes_far_from_it(fn: int, q: int) -> None:
    h = gain(notch(fn, q), [fn, 0.0, fn / 20, min(fn * 3, 2450)])
    assert db(h[:1])[0] < -40
    assert abs(h[1]) == pytest.approx(1.0, abs=1e-12)              # DC gain exactly 1
    assert abs(h[2]) == pytest.approx(1.0, abs=0.01)
    assert abs(h[3]) == pytest.approx(1.0, abs=0.15 if fn > 800 else 0.03)


@pytest.mark.parametrize(("q", "quality"), [(0, 4.0), (1, 10.0)])
def test_notch_bandwidth_is_fn_over_q(q: int, quality: float) -> None:
    fn = 300          # the NOTCH example: 300 Hz, q code 01h ("~10 %") [Ch5 NOTCH]
    f = np.linspace(200, 400, 200_001)
    below = f[np.abs(gain(notch(fn, q), f)) < math.sqrt(0.5)]
    # the analog edges ωn(√(1 + 1/4Q²) ± 1/2Q), ωn/Q apart, through Tustin's frequency warping
    wn, ts = 2 * math.pi * fn, 200e-6
    k = wn / math.tan(wn * ts / 2)
    edges = [wn * (math.sqrt(1 + 1 / (4 * quality**2)) + sign / (2 * quality)) for sign in (-1, 1)]
    digital = [math.atan(w / k) / (math.pi * ts) for w in edges]
    assert [below.min(), below.max()] == pytest.approx(digital, abs=0.002)
    assert (below.max() - below.min()) / fn == pytest.approx(1 / quality, rel=0.03)


def test_notch_zero_frequency_bypasses_and_ranges_are_checked() -> None:
    assert notch(0, 0) is None and notch(0, 1) is None
    for freq, q in ((1545, 0), (-1, 0), (300, 2), (300, -1)):
        with pytest.raises(ValueError):
            notch(freq, q)


# --- LOW_PASS ---

@pytest.mark.parametrize("fn", [50, 250, 1000, 1850])
def test_low_pass_gain_at_fn_is_that_of_the_zeta_0_6_prototype(fn: int) -> None:
    h = gain(low_pass(fn), [fn, 0.0])
    assert abs(h[0]) == pytest.approx(1 / (2 * 0.6), abs=1e-9)     # −1.58 dB: |1/(2jζ)|
    assert np.angle(h[0], deg=True) == pytest.approx(-90.0, abs=1e-6)
    assert abs(h[1]) == pytest.approx(1.0, abs=1e-12)               # DC gain 1


def test_low_pass_minus_3_db_and_resonance_follow_zeta_0_6() -> None:
    fn = 250              # the DSPL example [Ch5 LOW_PASS]; warping is small at 250 Hz
    u3 = math.sqrt((0.56 + math.sqrt(0.56**2 + 4)) / 2)             # |G(ju)|² = 1/2, ζ = 0.6
    assert db(gain(low_pass(fn), [u3 * fn]))[0] == pytest.approx(-3.01, abs=0.1)
    f = np.linspace(1, 2500, 25_000)
    h = np.abs(gain(low_pass(fn), f))
    assert h.max() == pytest.approx(1 / (2 * 0.6 * 0.8), rel=1e-3)  # peak 1/(2ζ√(1−ζ²))
    assert f[h.argmax()] == pytest.approx(fn * math.sqrt(1 - 2 * 0.36), rel=0.02)
    assert db(h[(f >= 2000) & (f < 2500)]).max() < -20           # Tustin: a double zero at 2500 Hz


def test_low_pass_index_table_of_the_manual() -> None:
    assert low_pass_frequency(10) == 275                            # the RTC example
    assert [low_pass_frequency(i) for i in (0, 1, 18, 19, 24, 45, 46)] == [0, 50, 475, 500, 750, 1800, 1850]
    assert low_pass(low_pass_frequency(0)) is None
    for bad in (47, -1):
        with pytest.raises(ValueError):
            low_pass_frequency(bad)
    with pytest.raises(ValueError):
        low_pass(1851)


# --- the per-axis biquads ---

def test_biquads_start_bypassed_and_inactive() -> None:
    bank = Biquads(4)
    assert not bank.active
    x = np.array([1.5, -2.0, 0.25, 10.0])
    out = np.zeros(4)
    bank.apply(x, out)
    assert np.array_equal(out, x)


def test_apply_matches_the_response_on_a_sine_and_filters_axes_independently() -> None:
    bank = Biquads(3)
    bank.set(0, must(low_pass(250)))
    bank.set(2, must(notch(300, 1)))
    assert bank.active
    t = np.arange(20_000)
    sine = np.sin(2 * np.pi * 250 * 200e-6 * t)
    notch_in = np.sin(2 * np.pi * 300 * 200e-6 * t)
    out = run(bank, np.stack([sine, sine, notch_in], axis=1))
    tail = out[-5000:]
    assert np.abs(tail[:, 0]).max() == pytest.approx(1 / 1.2, rel=1e-3)
    assert np.array_equal(out[:, 1], sine)    # bypassed axis untouched
    assert np.abs(tail[:, 2]).max() < 1e-3


def test_step_settles_at_the_dc_gain_and_out_may_be_the_input() -> None:
    bank = Biquads(2)
    bank.set(0, must(low_pass(50)))
    bank.set(1, must(notch(100, 0)))
    x = np.zeros(2)
    for _ in range(5000):
        x[:] = 2.0
        bank.apply(x, x)                      # in place
    assert x == pytest.approx([2.0, 2.0], abs=1e-9)


def test_set_restarts_from_rest_and_bypass_deactivates() -> None:
    bank = Biquads(1)
    coeffs = must(low_pass(100))
    bank.set(0, coeffs)
    first = run(bank, np.ones((10, 1)))
    run(bank, np.ones((100, 1)))
    bank.set(0, coeffs)
    assert np.array_equal(run(bank, np.ones((10, 1))), first)
    bank.bypass(0)
    assert not bank.active and run(bank, np.full((3, 1), 4.0)).tolist() == [[4.0]] * 3
