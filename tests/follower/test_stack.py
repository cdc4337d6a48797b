"""The follower stack that `lfctl sim` and `lfctl follow` share: a setpoint every step, the
formation status at its own rate from the estimate, text when the target is lost or back."""

from __future__ import annotations

import math

import pytest

from lfctl.follower.stack import Follower
from lfctl.guidance.formation import FormationSettings, Odometry
from lfctl.vision.track_state import RelativeMeasurement, TrackStatus


class FakeCompanion:
    def __init__(self) -> None:
        self.setpoints: list[tuple[float, float, float]] = []
        self.reports: list[tuple[float, float | None, float | None, float]] = []
        self.texts: list[str] = []

    def setpoint(self, t_s: float, speed_mps: float, yaw_rate_radps: float) -> None:
        self.setpoints.append((t_s, speed_mps, yaw_rate_radps))

    def report(
        self, t_s: float, range_err_m: float | None, bearing_err_deg: float | None, track_quality: float
    ) -> None:
        self.reports.append((t_s, range_err_m, bearing_err_deg, track_quality))

    def statustext(self, text: str) -> None:
        self.texts.append(text)


def run(
    measure, steps: int = 80, rate_hz: float = 20.0, status_hz: float = 2.0, search_degps: float = 45.0
) -> tuple[Follower, FakeCompanion]:
    comp = FakeCompanion()
    f = Follower(
        "f1",
        FormationSettings(
            range_cmd_m=1.5, coast_s=0.5, slowdown_s=0.5, search_yaw_rate_radps=math.radians(search_degps)
        ),
        comp,
        step_rate_hz=rate_hz,
        status_rate_hz=status_hz,
    )
    for k in range(steps):
        t = k / rate_hz
        f.step(t, measure(t), Odometry(t, 0.0, 0.0, 0.0, 0.0))
    return f, comp


def test_a_setpoint_every_step_and_the_status_at_its_rate_from_the_estimate() -> None:
    _f, comp = run(lambda t: RelativeMeasurement(t, TrackStatus.TRACKING, 2.0, math.radians(10), 1.0))
    assert len(comp.setpoints) == 80
    assert [round(r[0], 2) for r in comp.reports] == [0.0, 0.5, 1.0, 1.5, 2.0, 2.5, 3.0, 3.5]
    _t, range_err, bearing_err, q = comp.reports[0]
    assert range_err == pytest.approx(0.5) and bearing_err == pytest.approx(10.0) and q == 1.0


def test_the_status_rate_comes_from_the_settings_not_the_step_count() -> None:
    _f, comp = run(
        lambda t: RelativeMeasurement(t, TrackStatus.TRACKING, 2.0, 0.0, 1.0), steps=100, rate_hz=50.0, status_hz=5.0
    )
    assert len(comp.reports) == 10


@pytest.mark.parametrize(("search_degps", "said"), [(45.0, "lost, looking round"), (0.0, "lost, stopping")])
def test_lost_and_reacquired_are_said_once_each(search_degps: float, said: str) -> None:
    def measure(t: float) -> RelativeMeasurement:
        if 1.0 <= t < 3.0:
            return RelativeMeasurement(t, TrackStatus.OCCLUDED)
        return RelativeMeasurement(t, TrackStatus.TRACKING, 1.5, 0.0, 1.0)

    f, comp = run(measure, search_degps=search_degps)
    assert comp.texts == [f"f1: leader {said}", "f1: leader reacquired"]
    assert [e.kind for e in f.events] == ["lost", "reacquired"]
    lost_at = f.events[0].t_s
    assert 2.0 <= lost_at <= 2.1  # after coast_s + slowdown_s without a sighting
    lost = [sp for sp in comp.setpoints if lost_at <= sp[0] < 3.0]
    assert lost and all(sp[1] == 0.0 for sp in lost)  # stopped
    assert {round(math.degrees(sp[2]), 9) for sp in lost} == {search_degps}  # looking round, or still


def test_a_ground_station_tunes_the_coast_and_the_search_while_running() -> None:
    f, _comp = run(lambda t: RelativeMeasurement(t, TrackStatus.TRACKING, 2.0, 0.0, 1.0), steps=1)
    before = f.controller.settings
    f.tune(coast_s=0.5, search_yaw_rate_radps=math.radians(45.0))  # as they are: the same object
    assert f.controller.settings is before
    f.tune(coast_s=1.25, search_yaw_rate_radps=0.0)
    assert (f.settings.coast_s, f.settings.search_yaw_rate_radps) == (1.25, 0.0)
    assert f.settings.range_cmd_m == 1.5  # the rest kept


def test_no_estimate_is_reported_as_no_value() -> None:
    _f, comp = run(lambda t: None, steps=3)
    assert comp.reports[0][1:] == (None, None, 0.0)


def test_a_new_slot_moves_the_follower() -> None:
    f, _comp = run(lambda t: RelativeMeasurement(t, TrackStatus.TRACKING, 2.0, 0.0, 1.0), steps=1)
    f.set_slot(2.5, math.radians(-30))
    assert (f.settings.range_cmd_m, f.settings.bearing_cmd_rad) == (2.5, math.radians(-30))
    assert f.settings.coast_s == 0.5  # the rest kept
