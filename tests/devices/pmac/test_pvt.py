"""PVT mode planner: Hermite segments from position, velocity and time [Turbo SRM "PVT{data}",
"{axis}{data}:{data}"; Turbo UM "PVT-Mode Moves", figure "PVT Segment Shapes"]."""

from __future__ import annotations

import numpy as np
import pytest
from hypothesis import given, settings
from hypothesis import strategies as st

from tests.devices.pmac.trajectory import accel, joints, move, sample, total, vec
from vdevd.devices.pmac.pieces import Piece
from vdevd.devices.pmac.planerr import RUN_TIME_ERROR, PlanError
from vdevd.devices.pmac.pvt import PvtPlanner, hermite_pieces, segment_time, velocity_per_second


def test_segment_ends_at_the_programmed_position_and_velocity() -> None:
    pl = PvtPlanner(vec(X=0))
    (piece,) = pl.add(move(vec(X=10), "X", PVT=0.1, V=vec(X=50)))
    assert piece.dur == pytest.approx(0.1)
    pos, vel = piece.end()
    assert pos[6] == pytest.approx(10) and vel[6] == pytest.approx(50)
    p0, v0 = piece.at(0.0)
    assert p0[6] == 0 and v0[6] == 0


@pytest.mark.parametrize(("fraction", "v0", "v1", "shape"), [
    (1 / 2, 0, 1, "constant acceleration"),     # P = 1/2 Vt
    (1 / 3, 0, 1, "zero start acceleration"),   # P = 1/3 Vt
    (2 / 3, 0, 1, "zero end acceleration"),     # P = 2/3 Vt
    (1, 1, 1, "constant velocity"),             # P = Vt
])
def test_segment_shapes_of_the_user_manual(fraction: float, v0: float, v1: float, shape: str) -> None:
    """The UM's PVT segment shapes: the distance fixes the shape of the parabolic velocity."""
    v, t = 20.0, 0.25
    pl = PvtPlanner(vec(X=0), velocity=vec(X=v0 * v))
    (piece,) = pl.add(move(vec(X=fraction * v * t), "X", PVT=t, V=vec(X=v1 * v)))
    a0, a1 = accel(piece, 0.0)[6], accel(piece, t)[6]
    if shape == "constant acceleration":
        assert piece.coef[3][6] == pytest.approx(0, abs=1e-9) and a0 == pytest.approx(v / t)
    elif shape == "zero start acceleration":
        assert a0 == pytest.approx(0, abs=1e-9)
    elif shape == "zero end acceleration":
        assert a1 == pytest.approx(0, abs=1e-9)
    else:
        assert a0 == pytest.approx(0, abs=1e-9) and a1 == pytest.approx(0, abs=1e-9)


def test_velocity_is_in_units_per_isx90_ms() -> None:
    assert velocity_per_second(50, 1000) == 50
    assert velocity_per_second(50, 1) == 50_000


def test_segment_time_has_12_fraction_bits_with_i42_0_and_whole_ms_with_i42_1() -> None:
    assert segment_time(0.0100001) == pytest.approx(round(10.0001 * 4096) / 4096 / 1000)
    assert segment_time(10.0) == pytest.approx((4096 - 1 / 4096) / 1000)   # 4095.9998 ms at most
    assert segment_time(0.0104, i42=1) == pytest.approx(0.010)
    assert segment_time(10.0, i42=1) == pytest.approx(10.0)


def test_axes_without_velocity_and_axes_not_named_end_at_zero_velocity() -> None:
    pl = PvtPlanner(vec(X=0, Y=0), velocity=vec(Y=5))
    (piece,) = pl.add(move(vec(X=1, Y=0), "X", PVT=0.1))
    _, vel = piece.end()
    assert vel[6] == pytest.approx(0, abs=1e-9) and vel[7] == pytest.approx(0, abs=1e-9)
    assert piece.at(0.0)[1][7] == 5   # Y leaves with the velocity it had


def test_a_sequence_is_continuous_in_position_and_velocity() -> None:
    pl = PvtPlanner(vec(X=0))
    pieces = []
    for k in range(1, 20):
        pieces += pl.add(move(vec(X=k * k), "X", PVT=0.05, V=vec(X=40 * k)))
    for pa, va, pb, vb in joints(pieces):
        assert pa == pytest.approx(pb) and va == pytest.approx(vb)
    assert total(pieces) == pytest.approx(19 * 0.05)
    assert pieces[-1].end()[0][6] == pytest.approx(361)


def test_zero_segment_time_is_a_run_time_error() -> None:
    with pytest.raises(PlanError) as exc:
        PvtPlanner(vec()).add(move(vec(X=1), "X", PVT=0.0))
    assert exc.value.bit == RUN_TIME_ERROR


def test_flush_adds_nothing_and_the_next_segment_starts_from_rest() -> None:
    pl = PvtPlanner(vec(X=0))
    pl.add(move(vec(X=1), "X", PVT=0.1, V=vec(X=10)))
    assert pl.flush() == []
    (piece,) = pl.add(move(vec(X=2), "X", PVT=0.1))
    assert piece.at(0.0)[1][6] == 0 and piece.at(0.0)[0][6] == 1


@settings(max_examples=60, deadline=None)
@given(st.lists(st.tuples(st.floats(-1e3, 1e3), st.floats(-1e3, 1e3), st.floats(1e-3, 2.0)),
                min_size=1, max_size=30))
def test_batch_hermite_equals_the_piece_form(points: list[tuple[float, float, float]]) -> None:
    """The vectorised form (many points at once) gives the same cubics as Piece.hermite."""
    pos = np.array([vec(X=0)] + [vec(X=p) for p, _, _ in points])
    vel = np.array([vec(X=0)] + [vec(X=v) for _, v, _ in points])
    dur = np.array([t for _, _, t in points])
    batch = hermite_pieces(pos, vel, dur)
    for k, piece in enumerate(batch):
        ref = Piece.hermite(pos[k], vel[k], pos[k + 1], vel[k + 1], float(dur[k]))
        assert piece.coef == pytest.approx(ref.coef, rel=1e-9, abs=1e-6)
        end_p, end_v = piece.end()
        assert end_p[6] == pytest.approx(pos[k + 1][6], abs=1e-6)
        assert end_v[6] == pytest.approx(vel[k + 1][6], abs=1e-6)


def test_pvt_scan_passes_through_every_point() -> None:
    """A PVT scan passes exactly through the programmed points (a Hermite spline) [UM]."""
    pl = PvtPlanner(vec(X=0))
    pts = np.sin(np.linspace(0, 3, 50)) * 100
    pieces = []
    for p in pts:
        pieces += pl.add(move(vec(X=float(p)), "X", PVT=0.02, V=vec(X=1.0)))
    ends = [pc.end()[0][6] for pc in pieces]
    assert ends == pytest.approx(list(pts))
    ts, ps, _ = sample(pieces, 0.005)
    assert np.all(np.isfinite(ps))
