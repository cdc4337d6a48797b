"""A mission's items flown as an ArduPilot Rover flies them (Rover's ModeAuto, AP_Mission): RTL
as an item, a place at latitude and longitude 0 meaning "here", loiters for ever, NAV_DELAY
for a time or to a time of day, DO commands beginning with the leg after them and held back
by conditions, and the items a Rover passes over. Closed loop in lockstep: the mission is
stored on the leader mid-run, as a ground station's upload would store it."""

from __future__ import annotations

import dataclasses
import json
import math
from collections.abc import Callable
from datetime import UTC, datetime
from pathlib import Path

import numpy as np
import pytest
from mcap.reader import make_reader
from pymavlink.dialects.v20 import ardupilotmega as mav
from test_rover_modes import latlon, leader_at, mode, run_with, send

from lfctl.link.mission import (
    SUPPORTED,
    MissionItem,
    local_mission,
    seconds_until_utc,
    to_legs,
    validate_item,
)
from lfctl.link.mission_server import MISSION
from lfctl.sim.driver import condition_delay_s
from lfctl.sim.links import Links
from lfctl.sim.runner import RunReport

pytestmark = pytest.mark.fmu


def item(command: int, p1: float = 0.0, p2: float = 0.0, p3: float = 0.0, p4: float = 0.0) -> MissionItem:
    return MissionItem(0, mav.MAV_FRAME_GLOBAL_RELATIVE_ALT_INT, command, p1, p2, p3, p4)


def here(hold_s: float = 0.0) -> MissionItem:
    """A waypoint at latitude and longitude 0: where the vehicle is when it begins."""
    return item(mav.MAV_CMD_NAV_WAYPOINT, hold_s)


def store(*parts: list[MissionItem] | MissionItem) -> Callable[[Links], None]:
    """A ground station's upload of the items given (lists of local places, or single items)."""

    def upload(links: Links) -> None:
        items = local_mission([], links.home)
        for part in parts:
            for it in part if isinstance(part, list) else [part]:
                items.append(dataclasses.replace(it, seq=len(items)))
        links.endpoints[0].missions.store(MISSION, items, 255, 190, uploaded=True)

    return upload


def places(links_home: tuple[float, float, float], *points: tuple[float, ...]) -> list[MissionItem]:
    return local_mission(list(points), links_home)[1:]


def texts(links: Links, after_s: float = 0.0) -> list[str]:
    """The leader's STATUSTEXTs (from ``after_s``: the scenario's own mission says its first
    item before the test's upload replaces it)."""
    return [text for t_s, text in links.endpoints[0].statustexts if t_s >= after_s]


def test_a_mission_ending_in_rtl_drives_back_home_and_completes() -> None:
    def upload(links: Links) -> None:
        store(places(links.home, (4.0, 0.0), (4.0, 4.0)), item(mav.MAV_CMD_NAV_RETURN_TO_LAUNCH))(links)

    rep, links = run_with({0.5: upload}, duration_s=60.0)
    ep = links.endpoints[0]
    end = leader_at(rep, 60.0)
    assert math.hypot(*end) <= 0.5  # home: where it armed
    assert rep.result.final.vehicle(0).speed_mps == pytest.approx(0.0, abs=0.02)
    said = texts(links)
    assert "Reached destination" in said and said[-1] == "Mission Complete"
    # ArduPilot's mission library says each item as it starts it
    started = [s for s in texts(links, after_s=0.4) if s.startswith("Mission:")]
    assert started == ["Mission: 1 WP", "Mission: 2 WP", "Mission: 3 RTL"]
    assert ep.mission_complete and (rep.n_reached, rep.n_waypoints) == (3, 3)


def test_a_place_at_latitude_and_longitude_zero_is_where_the_vehicle_is() -> None:
    # Rover's Location::sanitize: not the Gulf of Guinea, but a wait of 3 s where it stands
    def upload(links: Links) -> None:
        store(places(links.home, (4.0, 0.0)), here(3.0), places(links.home, (4.0, 3.0)))(links)

    rep, links = run_with({0.5: upload}, duration_s=40.0)
    track = rep.result.pos_ned_m[:, 0]
    assert np.max(np.hypot(track[:, 0], track[:, 1])) <= 6.0
    assert math.hypot(*(leader_at(rep, 40.0) - np.array([4.0, 3.0]))) <= 0.5
    reached = dict(rep.waypoints_reached)  # item index from 0 -> time
    assert reached[1] - reached[0] == pytest.approx(0.0, abs=0.5)  # "here" is reached on arrival
    assert "Reached waypoint #2. Loiter for 3 seconds" in texts(links)
    t, speed = rep.result.t_s, np.abs(rep.result.speed_mps[:, 0])
    assert np.max(speed[(t > reached[1] + 0.5) & (t < reached[1] + 2.5)]) < 0.05  # waits there


def test_a_loiter_for_ever_holds_the_mission_there() -> None:
    def upload(links: Links) -> None:
        loiter = places(links.home, (4.0, 0.0))[0]
        loiter = MissionItem(0, loiter.frame, mav.MAV_CMD_NAV_LOITER_UNLIM, x=loiter.x, y=loiter.y)
        store(loiter, places(links.home, (4.0, 4.0)))(links)

    rep, links = run_with({0.5: upload}, duration_s=40.0)
    ep = links.endpoints[0]
    assert math.hypot(*(leader_at(rep, 40.0) - np.array([4.0, 0.0]))) <= 0.5
    assert not ep.mission_complete and ep.current_seq == 1  # still the loiter
    assert "Reached waypoint #1" in texts(links) and "Mission Complete" not in texts(links)


def sent(path: Path, *names: str) -> list[tuple[float, str, dict]]:
    """What the leader sent, from the run's log: (time since the first message, name, fields)."""
    out, t0 = [], None
    with open(path, "rb") as f:
        for _schema, _channel, message in make_reader(f).iter_messages(topics=["/mavlink/leader"]):
            record = json.loads(message.data)
            t0 = message.log_time if t0 is None else t0
            if record["direction"] == "out" and record.get("name") in names:
                out.append(((message.log_time - t0) / 1e9, record["name"], record["fields"]))
    return out


def test_a_nav_delay_stops_and_conditions_hold_back_only_the_do_commands_after_them(tmp_path: Path) -> None:
    # 1 go to (4, 0); 2 wait 4 s there; 3 wait 2 s more "here"; then, beginning with the leg
    # to (4, 6): a 3 s condition, a slower speed behind it, a servo (nothing fitted), a mount
    # command (a Rover says it skips it), a take-off (a Rover skips it in silence, and with
    # it what follows it before the next waypoint: the reverse never comes)
    def upload(links: Links) -> None:
        store(
            places(links.home, (4.0, 0.0)),
            item(mav.MAV_CMD_NAV_DELAY, 4.0),
            here(2.0),
            item(mav.MAV_CMD_CONDITION_DELAY, 3.0),
            item(mav.MAV_CMD_DO_CHANGE_SPEED, 1.0, 0.2),
            item(mav.MAV_CMD_DO_SET_SERVO, 5.0, 1900.0),
            item(mav.MAV_CMD_DO_MOUNT_CONTROL),
            item(mav.MAV_CMD_NAV_TAKEOFF),
            item(mav.MAV_CMD_DO_SET_REVERSE, 1.0),
            places(links.home, (4.0, 6.0)),
        )(links)

    rep, links = run_with({0.5: upload}, duration_s=60.0, record_to=tmp_path / "m.mcap")
    said = texts(links)
    assert "Delaying 4 sec" in said and "Reached waypoint #3. Loiter for 2 seconds" in said
    # the search after item 3: the condition started, the take-off tried, then the waypoint;
    # the speed, servo and mount once the condition is met
    started = [s.split(" ", 2)[2] for s in texts(links, after_s=0.4) if s.startswith("Mission:")]
    assert started == [
        "WP", "Delay", "WP", "CondDelay", "Takeoff", "WP", "ChangeSpeed", "SetServo", "MountControl",
    ]  # fmt: skip
    assert "Mission 6: DO_SET_SERVO not fitted" in said and "Skipping invalid cmd #205" in said
    assert "speed: 0.2 m/s" in said
    assert not any("#22" in s for s in said) and not links.endpoints[0].reversed
    reached = dict(rep.waypoints_reached)
    t, speed = rep.result.t_s, np.abs(rep.result.speed_mps[:, 0])
    at = reached[0]
    assert np.max(speed[(t > at + 0.5) & (t < at + 5.5)]) < 0.05  # the delay and the wait: standing
    # the leg to (4, 6) drives at once at 0.4 m/s; 3 s into it the speed change comes
    assert np.median(speed[(t > at + 7.5) & (t < at + 8.8)]) == pytest.approx(0.4, abs=0.03)
    assert np.median(speed[(t > at + 10.5) & (t < at + 14.0)]) == pytest.approx(0.2, abs=0.02)
    assert links.endpoints[0].mission_complete
    # MISSION_ITEM_REACHED as a Rover sends it: each navigation item once done (the delay
    # after its 4 s, "here" after its 2 s), the DO commands its own mode carries out (the
    # condition once its 3 s are up, then the speed and the mount it skips behind it), not
    # the servo (ArduPilot's mission library runs it), the skipped take-off, or the reverse
    log = sent(tmp_path / "m.mcap", "MISSION_ITEM_REACHED", "MISSION_CURRENT")
    done = [(round(t - log[0][0], 1), f["seq"]) for t, name, f in log if name == "MISSION_ITEM_REACHED"]
    assert [seq for _t, seq in done] == [1, 2, 3, 4, 5, 7, 10], done
    times = dict((seq, t) for t, seq in done)
    assert times[2] - times[1] == pytest.approx(4.0, abs=0.25) and times[3] - times[2] == pytest.approx(2.0, abs=0.25)
    assert times[4] - times[3] == pytest.approx(3.0, abs=0.25) and times[5] == times[7] == times[4]
    current = {f["seq"] for t, name, f in log if name == "MISSION_CURRENT" and t > 1.0}  # after the upload
    assert sorted(current) == [1, 2, 3, 10]  # only navigation items are current


def test_a_nav_delay_to_a_time_of_day_waits_for_it() -> None:
    # the vehicle's clock (SYSTEM_TIME's) set so that 12:00:10 UTC comes 10 s after the upload
    noon = datetime(2026, 12, 4, 12, 0, 0, tzinfo=UTC).timestamp()

    def upload(links: Links) -> None:
        links.endpoints[0].epoch_us = int((noon - 0.5) * 1e6)
        store(item(mav.MAV_CMD_NAV_DELAY, -1.0, 12.0, 0.0, 10.0), places(links.home, (3.0, 0.0)))(links)

    rep, links = run_with({0.5: upload}, duration_s=30.0)
    assert "Delaying 10 sec" in texts(links)
    (_index, t_reached), *_ = rep.waypoints_reached
    assert t_reached > 10.5 and t_reached < 20.0  # set off at 10.5 s, 3 m at 0.4 m/s


def test_do_set_reverse_in_a_mission_backs_the_next_leg() -> None:
    def upload(links: Links) -> None:
        store(places(links.home, (4.0, 0.0)), item(mav.MAV_CMD_DO_SET_REVERSE, 1.0), places(links.home, (1.0, 0.0)))(
            links
        )

    rep, links = run_with({0.5: upload}, duration_s=40.0)
    reached = dict(rep.waypoints_reached)  # by item index from 0: the waypoints are items 1 and 3
    t, speed = rep.result.t_s, rep.result.speed_mps[:, 0]
    assert np.median(speed[(t > reached[0] + 1.0) & (t < reached[2] - 1.0)]) < -0.2  # backing
    assert links.endpoints[0].reversed
    assert math.hypot(*(leader_at(rep, 40.0) - np.array([1.0, 0.0]))) <= 0.5


# -- the legs, upload ------------------------------------------------------------------------
HOME = (12.96, 77.67, 900.0)


def test_rtl_and_here_take_their_places_from_the_leg_before() -> None:
    items = [
        *local_mission([(4.0, 0.0)], HOME),
        MissionItem(2, 0, mav.MAV_CMD_NAV_RETURN_TO_LAUNCH),
        MissionItem(3, 0, mav.MAV_CMD_NAV_DELAY, 5.0),
        MissionItem(4, mav.MAV_FRAME_GLOBAL_RELATIVE_ALT_INT, mav.MAV_CMD_NAV_LOITER_UNLIM),
        *local_mission([(9.0, 9.0)], HOME)[1:],
    ]
    legs = to_legs(items, HOME, start=(1.0, 1.0), return_to=lambda n, e: (n - 1.0, e + 2.0))
    ends = [(leg.seq, round(leg.north_m, 2), round(leg.east_m, 2), leg.hold_s) for leg in legs]
    # RTL from (4, 0); the delay and the loiter where RTL ends; nothing after the loiter
    assert ends == [(1, 4.0, 0.0, 0.0), (2, 3.0, 2.0, 0.0), (3, 3.0, 2.0, 5.0), (4, 3.0, 2.0, math.inf)]


@pytest.mark.parametrize(
    ("hms", "seconds"),
    [
        ((23, 45, 0), 900.0),
        ((12, 0, 0), 45000.0),  # past: tomorrow
        ((-1, -1, 30), 30.0),
        ((-1, 10, 0), 2400.0),  # ten past the next hour
        ((23, 30, 0), 0.0),  # now
        ((-1, -1, -1), 0.0),  # no time given
    ],
)
def test_the_wait_to_a_time_of_day_is_rovers(hms: tuple[int, int, int], seconds: float) -> None:
    now = datetime(2026, 12, 4, 23, 30, 0, tzinfo=UTC).timestamp()  # 23:30:00 UTC
    assert seconds_until_utc(now, *hms) == seconds


def test_a_time_of_day_counts_the_fields_below_the_first_given_as_they_are() -> None:
    # Rover's get_time_utc at 10:20:15: hour 12 with minute and second -1 is 11:58:59, not
    # 12:20:15; a quarter of a second past a whole one, "any time" waits for the next
    now = datetime(2026, 12, 4, 10, 20, 15, tzinfo=UTC).timestamp()
    assert seconds_until_utc(now, 12, -1, -1) == 5924.0
    assert seconds_until_utc(now + 0.25, -1, -1, -1) == 0.75


def test_every_command_a_rover_mission_takes_is_taken_and_no_other() -> None:
    for cmd in SUPPORTED:
        it = MissionItem(1, mav.MAV_FRAME_GLOBAL_RELATIVE_ALT_INT, cmd, 1.0, 1.0, x=129600000, y=776700000)
        assert validate_item(it, 3) == mav.MAV_MISSION_ACCEPTED, mav.enums["MAV_CMD"][cmd].name
    for cmd in (mav.MAV_CMD_USER_1, mav.MAV_CMD_NAV_FOLLOW, mav.MAV_CMD_DO_SET_MODE, 65535):
        assert validate_item(MissionItem(1, 0, cmd), 3) == mav.MAV_MISSION_UNSUPPORTED


@pytest.mark.parametrize(
    ("params", "result"),
    [
        ((-1.0, 24.0, 0.0, 0.0), mav.MAV_MISSION_INVALID_PARAM2),  # hour 24
        ((-1.0, 12.0, 60.0, 0.0), mav.MAV_MISSION_INVALID_PARAM3),  # minute 60
        ((0.0, 12.0, 0.0, 0.5), mav.MAV_MISSION_INVALID_PARAM4),  # half a second
        ((math.nan, 0.0, 0.0, 0.0), mav.MAV_MISSION_INVALID_PARAM1),
        ((-1.0, -1.0, -1.0, 30.0), mav.MAV_MISSION_ACCEPTED),  # at the next half minute
        ((2.5, 99.0, 99.0, 99.0), mav.MAV_MISSION_ACCEPTED),  # 2.5 s: the time of day unused
    ],
)
def test_a_nav_delay_names_the_parameter_it_cannot_take(params: tuple[float, ...], result: int) -> None:
    assert validate_item(MissionItem(1, 0, mav.MAV_CMD_NAV_DELAY, *params), 3) == result


@pytest.mark.parametrize(
    ("cmd", "params", "result"),
    [
        (mav.MAV_CMD_NAV_WAYPOINT, (0.0, 0.0, 0.0, math.nan), mav.MAV_MISSION_ACCEPTED),  # the yaw unset
        (mav.MAV_CMD_NAV_WAYPOINT, (0.0, math.nan, 0.0, 0.0), mav.MAV_MISSION_INVALID_PARAM2),
        (mav.MAV_CMD_NAV_WAYPOINT, (0.0, 0.0, 0.0, math.inf), mav.MAV_MISSION_INVALID_PARAM4),
        (mav.MAV_CMD_DO_CHANGE_SPEED, (1.0, 0.5, math.nan, 0.0), mav.MAV_MISSION_INVALID_PARAM3),
        (mav.MAV_CMD_DO_CHANGE_SPEED, (1.0, 0.5, -1.0, math.nan), mav.MAV_MISSION_INVALID_PARAM4),
        (mav.MAV_CMD_NAV_RETURN_TO_LAUNCH, (math.nan, 0.0, 0.0, 0.0), mav.MAV_MISSION_INVALID_PARAM1),
        (mav.MAV_CMD_NAV_LOITER_UNLIM, (0.0, 0.0, 0.0, math.nan), mav.MAV_MISSION_INVALID_PARAM4),
        (mav.MAV_CMD_DO_JUMP, (1.0, 1.0, math.nan, 0.0), mav.MAV_MISSION_INVALID_PARAM3),
        (mav.MAV_CMD_USER_1, (-math.inf, 0.0, 0.0, 0.0), mav.MAV_MISSION_INVALID_PARAM1),  # checked first
    ],
)
def test_params_1_to_4_are_numbers_unless_rover_takes_nan_for_unset(
    cmd: int, params: tuple[float, ...], result: int
) -> None:
    """As AP_Mission::sanity_check_params: an unused parameter may not be NaN or infinite
    either (QGroundControl's plans hold numbers there); only the yaw of a waypoint (and a
    landing's, a takeoff's) may be NaN."""
    it = MissionItem(1, mav.MAV_FRAME_GLOBAL_RELATIVE_ALT_INT, cmd, *params, x=129600000, y=776700000)
    assert validate_item(it, 3) == result


def test_a_waypoints_or_loiters_wait_is_whole_seconds_as_rovers_16_bit_time() -> None:
    home = local_mission([], HOME)[0]
    waits = [
        to_legs([home, dataclasses.replace(item(cmd, p1), seq=1)], HOME)[0].hold_s
        for cmd, p1 in ((mav.MAV_CMD_NAV_WAYPOINT, 0.6), (mav.MAV_CMD_NAV_WAYPOINT, 2.5),
                        (mav.MAV_CMD_NAV_LOITER_TIME, 3.9), (mav.MAV_CMD_NAV_DELAY, 2.5))
    ]  # fmt: skip
    assert waits == [0.0, 2.0, 3.0, 2.5]  # NAV_DELAY's seconds are a float on Rover


def test_a_fractional_jump_is_cut_to_whole_numbers_as_rovers_integers() -> None:
    home = local_mission([], HOME)[0]
    wps = [dataclasses.replace(it, seq=k) for k, it in enumerate(local_mission([(1.0, 0.0), (2.0, 0.0)], HOME))][1:]
    jump = MissionItem(3, mav.MAV_FRAME_MISSION, mav.MAV_CMD_DO_JUMP, 1.7, 2.9)  # to item 1, twice
    assert validate_item(jump, 4) == mav.MAV_MISSION_ACCEPTED
    legs = to_legs([home, *wps, jump], HOME)
    assert [leg.seq for leg in legs] == [1, 2, 1, 2, 1, 2]
    # the counted jumps each leg is reached by, as Rover says them: (item, times taken, of)
    assert [leg.jumped for leg in legs] == [(), (), ((3, 1, 2),), (), ((3, 2, 2),), ()]
    forever = dataclasses.replace(jump, param2=-1.0)  # repeated for ever: not counted, not said
    assert not any(leg.jumped for leg in to_legs([home, *wps, forever], HOME))


def test_a_negative_hold_is_none_as_on_a_rover() -> None:
    wp = MissionItem(1, mav.MAV_FRAME_GLOBAL_RELATIVE_ALT_INT, mav.MAV_CMD_NAV_WAYPOINT, -5.0, x=129600000, y=1)
    assert validate_item(wp, 2) == mav.MAV_MISSION_ACCEPTED
    assert to_legs([local_mission([], HOME)[0], wp], HOME)[0].hold_s == 0.0


# -- what a review against ArduPilot's source found ---------------------------------------------
def speed_between(rep: RunReport, t0: float, t1: float) -> float:
    t, speed = rep.result.t_s, np.abs(rep.result.speed_mps[:, 0])
    return float(np.median(speed[(t > t0) & (t < t1)]))


def test_the_do_commands_after_a_wait_run_when_the_next_item_is_reached_at_once() -> None:
    # 1 waits 2 s, 2 slows to 0.2 m/s, 3 is "here" (done the step it begins), 4 is far: the
    # speed change still comes (AP_Mission starts the first DO command before the next item)
    def upload(links: Links) -> None:
        store(
            places(links.home, (4.0, 0.0, 2.0)),
            item(mav.MAV_CMD_DO_CHANGE_SPEED, 1.0, 0.2),
            here(),
            places(links.home, (4.0, 8.0)),
        )(links)

    rep, _links = run_with({0.5: upload}, duration_s=40.0)
    left = dict(rep.waypoints_reached)[2]
    assert speed_between(rep, left + 2.0, left + 10.0) == pytest.approx(0.2, abs=0.02)


def test_rtl_in_a_mission_goes_to_home_as_it_is_when_the_rtl_begins() -> None:
    # DO_SET_HOME (here) after the first waypoint: the RTL at the end goes to the new home
    def upload(links: Links) -> None:
        store(
            places(links.home, (4.0, 0.0)),
            item(mav.MAV_CMD_DO_SET_HOME, 1.0),
            places(links.home, (4.0, 5.0)),
            item(mav.MAV_CMD_NAV_RETURN_TO_LAUNCH),
        )(links)

    rep, links = run_with({0.5: upload}, duration_s=50.0)
    assert links.endpoints[0].mission_complete
    assert math.hypot(*(leader_at(rep, 50.0) - np.array([4.0, 0.0]))) <= 0.6


def test_a_mission_without_waypoints_runs_its_first_do_command_and_completes() -> None:
    def upload(links: Links) -> None:
        store(item(mav.MAV_CMD_DO_SET_REVERSE, 1.0), item(mav.MAV_CMD_DO_SET_SERVO, 5.0, 1900.0))(links)

    # (uploaded while the scenario's own mission is on item 1: Rover restarts item 1 of the new
    # mission, finds no navigation item from it, runs the first DO command and completes the
    # mission, and says the restart failed)
    _rep, links = run_with({0.5: upload}, duration_s=3.0)
    ep = links.endpoints[0]
    assert ep.reversed and ep.mission_complete
    assert texts(links)[-2:] == ["Mission Complete", "Auto mission changed but failed to restart command"]
    assert not any("DO_SET_SERVO" in s for s in texts(links))  # only the first runs, as on a Rover


def test_the_first_do_command_after_the_last_waypoint_runs_before_the_mission_completes() -> None:
    def upload(links: Links) -> None:
        store(places(links.home, (3.0, 0.0)), item(mav.MAV_CMD_DO_SET_SERVO, 5.0, 1900.0))(links)

    _rep, links = run_with({0.5: upload}, duration_s=20.0)
    said = texts(links)
    assert said[-2:] == ["Mission 2: DO_SET_SERVO not fitted", "Mission Complete"]


def test_mission_current_is_the_navigation_item_under_way() -> None:
    seen: list[int] = []

    def upload(links: Links) -> None:
        store(
            item(mav.MAV_CMD_DO_CHANGE_SPEED, 1.0, 0.3),
            item(mav.MAV_CMD_CONDITION_DELAY, 1.0),
            places(links.home, (4.0, 0.0)),
        )(links)

    run_with({0.5: upload, 3.0: lambda links: seen.append(links.endpoints[0].current_seq)}, duration_s=4.0)
    assert seen == [3]


def test_a_missions_speed_holds_over_a_new_current_item_and_ends_when_auto_is_entered_again() -> None:
    # Rover: DO_CHANGE_SPEED sets its one waypoint speed; MISSION_SET_CURRENT keeps it, a mode
    # entered starts again at WP_SPEED (0.4 m/s here)
    def upload(links: Links) -> None:
        store(
            item(mav.MAV_CMD_DO_CHANGE_SPEED, 1.0, 0.2),
            places(links.home, (3.0, 0.0), (3.0, 8.0), (0.0, 8.0)),
        )(links)

    def set_current(links: Links) -> None:
        send(links, mav.MAVLink_mission_set_current_message(1, 1, 3))

    moved, _links = run_with({0.5: upload, 25.0: set_current}, duration_s=40.0)
    assert speed_between(moved, 30.0, 38.0) == pytest.approx(0.2, abs=0.02)
    again, _links = run_with({0.5: upload, 25.0: mode("HOLD"), 26.0: mode("AUTO")}, duration_s=40.0)
    assert speed_between(again, 30.0, 38.0) == pytest.approx(0.4, abs=0.02)


@pytest.mark.parametrize("speed", [0.0, 0.04, -5.0])
def test_a_speed_too_slow_for_rover_is_stored_and_changes_nothing(speed: float) -> None:
    # AP_Mission stores any speed; Rover's AR_WPNav::set_speed_max takes none under 0.05 m/s,
    # so the item runs without its "speed:" text and the waypoints stay at WP_SPEED (0.4 m/s)
    slow = item(mav.MAV_CMD_DO_CHANGE_SPEED, 1.0, speed)
    assert validate_item(dataclasses.replace(slow, seq=1), 3) == mav.MAV_MISSION_ACCEPTED

    def upload(links: Links) -> None:
        store(slow, places(links.home, (8.0, 0.0)))(links)

    rep, links = run_with({0.5: upload}, duration_s=15.0)
    assert speed_between(rep, 6.0, 12.0) == pytest.approx(0.4, abs=0.02)
    assert "Mission: 1 ChangeSpeed" in texts(links) and not any(s.startswith("speed:") for s in texts(links))


def test_auto_entered_again_drives_back_to_the_item_under_way_and_waits_its_whole_time() -> None:
    def upload(links: Links) -> None:
        store(places(links.home, (4.0, 0.0, 20.0)), places(links.home, (4.0, 6.0)))(links)

    def away(links: Links) -> None:  # GUIDED to (0, -3) part-way through the wait
        x, y = latlon(links, 0.0, -3.0)
        send(
            links,
            mav.MAVLink_command_int_message(
                1, 1, mav.MAV_FRAME_GLOBAL_INT, mav.MAV_CMD_DO_REPOSITION, 0, 0, -1, 1, 0, 0, x, y, 0
            ),
        )

    rep, links = run_with({0.5: upload, 12.0: mode("GUIDED"), 12.5: away, 40.0: mode("AUTO")}, duration_s=80.0)
    arrivals = [t for index, t in rep.waypoints_reached if index == 0]
    assert len(arrivals) == 2 and arrivals[1] > 40.0  # back at item 1
    back = arrivals[1]
    assert math.hypot(*leader_at(rep, back + 19.0) - np.array([4.0, 0.0])) <= 0.6  # the whole 20 s
    assert texts(links).count("Reached waypoint #1. Loiter for 20 seconds") == 2


def test_rtls_start_sets_its_own_speed_over_a_do_change_speed_before_it() -> None:
    def upload(links: Links) -> None:
        store(
            places(links.home, (5.0, 0.0)),
            item(mav.MAV_CMD_DO_CHANGE_SPEED, 1.0, 0.2),
            item(mav.MAV_CMD_NAV_RETURN_TO_LAUNCH),
        )(links)

    rep, _links = run_with({0.5: upload}, duration_s=40.0)
    left = dict(rep.waypoints_reached)[0]
    assert speed_between(rep, left + 4.0, left + 9.0) == pytest.approx(0.4, abs=0.02)  # WP_SPEED


@pytest.mark.parametrize(
    ("command", "frame", "z", "result"),
    [
        (mav.MAV_CMD_DO_SET_HOME, mav.MAV_FRAME_LOCAL_NED, 0.0, mav.MAV_MISSION_UNSUPPORTED_FRAME),
        (mav.MAV_CMD_DO_SET_HOME, mav.MAV_FRAME_GLOBAL_INT, math.nan, mav.MAV_MISSION_INVALID_PARAM7),
        (mav.MAV_CMD_NAV_LOITER_TURNS, mav.MAV_FRAME_GLOBAL_INT, 1e9, mav.MAV_MISSION_INVALID_PARAM7),
        (mav.MAV_CMD_NAV_WAYPOINT, mav.MAV_FRAME_GLOBAL_TERRAIN_ALT_INT, 5.0, mav.MAV_MISSION_ACCEPTED),
        (mav.MAV_CMD_NAV_WAYPOINT, mav.MAV_FRAME_MISSION, 0.0, mav.MAV_MISSION_ACCEPTED),
    ],
)
def test_every_place_is_checked_for_its_frame_and_altitude(command: int, frame: int, z: float, result: int) -> None:
    assert validate_item(MissionItem(1, frame, command, x=129600000, y=776700000, z=z), 2) == result


def test_the_logs_reached_event_names_the_item_current_after_it(tmp_path: Path) -> None:
    def upload(links: Links) -> None:
        store(places(links.home, (3.0, 0.0), (3.0, 3.0)))(links)

    run_with({0.5: upload}, duration_s=30.0, record_to=tmp_path / "m.mcap")
    with open(tmp_path / "m.mcap", "rb") as f:
        events = [json.loads(m.data) for _s, _c, m in make_reader(f).iter_messages(topics=["/leader/mission"])]
    reached = [(e["index"], e["active"]) for e in events if e.get("event") == "reached"]
    assert reached == [(0, 2), (1, 2)]


# -- and what a second review found ---------------------------------------------------------------
def test_the_do_commands_after_a_skipped_take_off_run_when_none_came_before_it() -> None:
    # AP_Mission's search passes the take-off it cannot start and starts the first DO command
    # it meets; get_next_do_cmd stops only the DO commands after one that is already running
    def upload(links: Links) -> None:
        store(
            item(mav.MAV_CMD_NAV_TAKEOFF), item(mav.MAV_CMD_DO_CHANGE_SPEED, 1.0, 0.2), places(links.home, (4.0, 0.0))
        )(links)

    rep, _links = run_with({0.5: upload}, duration_s=20.0)
    assert speed_between(rep, 8.0, 18.0) == pytest.approx(0.2, abs=0.02)
    items = [
        *local_mission([(1.0, 0.0)], HOME),
        MissionItem(2, 0, mav.MAV_CMD_DO_SET_SERVO),
        MissionItem(3, 0, mav.MAV_CMD_NAV_LAND),
        MissionItem(4, 0, mav.MAV_CMD_DO_SET_RELAY),
        MissionItem(5, 0, mav.MAV_CMD_NAV_TAKEOFF),
        MissionItem(6, 0, mav.MAV_CMD_DO_CHANGE_SPEED, 1.0, 0.2),
        *[dataclasses.replace(it, seq=7) for it in local_mission([(2.0, 0.0)], HOME)[1:]],
    ]
    # the leg's items: the DO commands run and the skipped navigation items tried (and said)
    assert [it.seq for it in to_legs(items, HOME)[1].before] == [2, 3, 5]  # not the relay, nor the speed
    assert [it.seq for it in to_legs(items[:2] + items[4:], HOME)[1].before] == [4, 5]  # not the speed after
    skipped_first = [items[0], items[1], MissionItem(2, 0, mav.MAV_CMD_NAV_LAND), *items[3:]]
    assert [it.seq for it in to_legs(skipped_first, HOME)[1].before] == [2, 3, 4, 5]


def test_a_time_of_day_wait_after_a_waypoints_wait_begins_before_it_is_reached() -> None:
    noon = datetime(2026, 12, 4, 12, 0, 0, tzinfo=UTC).timestamp()

    def upload(links: Links) -> None:
        links.endpoints[0].epoch_us = int(noon * 1e6)  # the run's t = 0 is 12:00:00 UTC
        store(
            places(links.home, (4.0, 0.0, 2.0)),
            item(mav.MAV_CMD_NAV_DELAY, -1.0, 12.0, 0.0, 30.0),  # until 12:00:30
            places(links.home, (4.0, 6.0)),
        )(links)

    rep, links = run_with({0.5: upload}, duration_s=60.0)
    assert any(s.startswith("Delaying 1") for s in texts(links))  # 18-19 s from the wait's end
    assert math.hypot(*(leader_at(rep, 29.0) - np.array([4.0, 0.0]))) <= 0.6  # still there at 29 s
    assert dict(rep.waypoints_reached)[2] > 30.0


def with_jump(links: Links) -> None:
    """Two waypoints, a DO_JUMP back to the first (once), and one back home."""
    store(
        places(links.home, (3.0, 0.0), (3.0, 3.0)),
        item(mav.MAV_CMD_DO_JUMP, 1.0, 1.0),  # back to 1, once
        places(links.home, (0.0, 0.0)),
    )(links)


def test_a_jump_taken_is_said_before_the_item_it_leads_to() -> None:
    _rep, links = run_with({0.5: with_jump}, duration_s=60.0)
    started = [s for s in texts(links, after_s=0.4) if s.startswith("Mission:")]
    # AP_Mission's increment_jump_times_run, then the item the jump leads to starts
    assert started == [
        "Mission: 1 WP",
        "Mission: 2 WP",
        "Mission: 3 Jump 1/1",
        "Mission: 1 WP",
        "Mission: 2 WP",
        "Mission: 4 WP",
    ]


def test_a_tagged_jump_is_flown_and_said_as_rover_says_it() -> None:
    # Mission Planner's and QGroundControl's tagged loops: JUMP_TAG marks the place, DO_JUMP_TAG
    # goes back to it (MISSION_ITEM_INT 600 and 601, refused as UNSUPPORTED until ArduPilot's
    # mission library took them)
    def with_tag(links: Links) -> None:
        store(
            places(links.home, (3.0, 0.0)),
            item(mav.MAV_CMD_JUMP_TAG, 7.0),
            places(links.home, (3.0, 3.0)),
            item(mav.MAV_CMD_DO_JUMP_TAG, 7.0, 1.0),  # back to the tag, once
            places(links.home, (0.0, 0.0)),
        )(links)

    rep, links = run_with({0.5: with_tag}, duration_s=70.0)
    started = [s for s in texts(links, after_s=0.4) if s.startswith("Mission:")]
    assert started == [
        "Mission: 1 WP",
        "Mission: 2 Tag 0",
        "Mission: 3 WP",
        "Mission: 4 Jump 1/1",
        "Mission: 2 Tag 0",
        "Mission: 3 WP",
        "Mission: 5 WP",
    ]
    assert "Mission Complete" in texts(links)
    assert math.hypot(*leader_at(rep, 69.0)) <= 0.6  # home at the end


def test_auto_entered_again_or_a_new_current_item_keeps_the_jump_counts_and_a_resume_its_condition() -> None:
    def with_condition(links: Links) -> None:
        store(
            places(links.home, (4.0, 0.0)),
            item(mav.MAV_CMD_CONDITION_DELAY, 8.0),
            item(mav.MAV_CMD_DO_CHANGE_SPEED, 1.0, 0.2),
            places(links.home, (4.0, 14.0)),
        )(links)

    rep, _links = run_with({0.5: with_condition, 12.0: mode("HOLD"), 13.0: mode("AUTO")}, duration_s=40.0)
    assert speed_between(rep, 25.0, 35.0) == pytest.approx(0.2, abs=0.02)  # 8 s from 13 s, then slower

    rep, _links = run_with({0.5: with_jump, 30.0: mode("HOLD"), 31.0: mode("AUTO")}, duration_s=70.0)
    assert [index + 1 for index, _t in rep.waypoints_reached] == [1, 2, 1, 2, 4]

    def back_to_1(links: Links) -> None:  # MISSION_SET_CURRENT 1 on the way round the second time
        send(links, mav.MAVLink_mission_set_current_message(1, 1, 1))

    rep, _links = run_with({0.5: with_jump, 30.0: back_to_1}, duration_s=80.0)
    # the jump already taken stays taken (AP_Mission keeps its count over a new current item)
    assert [index + 1 for index, _t in rep.waypoints_reached] == [1, 2, 1, 1, 2, 4]

    def restart(links: Links) -> None:  # MISSION_SET_CURRENT 0: the mission from its start
        send(links, mav.MAVLink_mission_set_current_message(1, 1, 0))

    rep, _links = run_with({0.5: with_jump, 30.0: restart}, duration_s=90.0)
    # item 0 restarts it as AP_Mission::set_current_cmd(0) does: the jump counts afresh
    assert [index + 1 for index, _t in rep.waypoints_reached] == [1, 2, 1, 1, 2, 1, 2, 4]


@pytest.mark.parametrize(("reset", "laps"), [(0.0, [1, 2, 1, 1, 2, 4]), (1.0, [1, 2, 1, 1, 2, 1, 2, 4])])
def test_do_set_mission_current_with_reset_starts_the_jump_counts_afresh(reset: float, laps: list[int]) -> None:
    # DO_SET_MISSION_CURRENT 1 on the way round the second time: param2 0 keeps the jump
    # already taken (as MISSION_SET_CURRENT 1), param2 1 resets the mission first
    # (AP_Mission::reset): the jump is taken again
    def back_to_1(links: Links) -> None:
        send(links, mav.MAVLink_command_long_message(
            1, 1, mav.MAV_CMD_DO_SET_MISSION_CURRENT, 0, 1, reset, 0, 0, 0, 0, 0,
        ))  # fmt: skip

    rep, _links = run_with({0.5: with_jump, 30.0: back_to_1}, duration_s=90.0)
    assert [index + 1 for index, _t in rep.waypoints_reached] == laps


def test_do_set_home_in_the_mission_frame_is_above_mean_sea_level() -> None:
    def upload(links: Links) -> None:
        spot = places(links.home, (4.0, 0.0))[0]
        home_item = MissionItem(0, mav.MAV_FRAME_MISSION, mav.MAV_CMD_DO_SET_HOME, 0.0, x=spot.x, y=spot.y, z=905.0)
        store(places(links.home, (2.0, 0.0)), home_item, item(mav.MAV_CMD_NAV_RETURN_TO_LAUNCH))(links)

    rep, links = run_with({0.5: upload}, duration_s=30.0)
    assert "Set HOME to 12.960236 77.669000 at 905.00m" in texts(links)
    assert math.hypot(*(leader_at(rep, 30.0) - np.array([4.0, 0.0]))) <= 0.6


def test_a_partial_update_edits_the_mission_being_flown_without_starting_it_again() -> None:
    # MAVProxy's `wp changealt N` uploads item N again (MISSION_WRITE_PARTIAL_LIST): Rover
    # writes it in place; the mission flown is the same mission (DO_JUMP counts, its number,
    # a finished one stays finished)
    def edit(seq: int) -> Callable[[Links], None]:
        def write(links: Links) -> None:
            send(links, mav.MAVLink_mission_write_partial_list_message(1, 1, seq, seq, 0))

        return write

    def item_again(seq: int, z: float) -> Callable[[Links], None]:
        def send_item(links: Links) -> None:
            it = links.endpoints[0].mission[seq]
            send(links, mav.MAVLink_mission_item_int_message(
                1, 1, seq, it.frame, it.command, 0, 1, it.param1, it.param2, it.param3, it.param4, it.x, it.y, z, 0,
            ))  # fmt: skip

        return send_item

    # on the second lap, item 4 edited: the jump already taken stays taken
    rep, links = run_with({0.5: with_jump, 30.0: edit(4), 30.1: item_again(4, 5.0)}, duration_s=70.0)
    assert links.endpoints[0].mission[4].z == 5.0
    assert [index + 1 for index, _t in rep.waypoints_reached] == [1, 2, 1, 2, 4]
    assert rep.n_reached == rep.n_waypoints == 3  # the same mission: its waypoints counted on
    assert [(c.kind, c.edit) for c in rep.mission_changes if c.t_s > 1.0] == [("mission", True)]

    def square(links: Links) -> None:
        store(places(links.home, (4.0, 0.0), (4.0, 4.0), (0.0, 4.0)))(links)

    # `wp move 2` while item 1 is under way: item 2 is one of the next navigation items
    # Rover's AP_Mission_ChangeDetector watches, so ModeAuto restarts item 1 (said again, with
    # "Auto mission changed, restarted command"), and item 2 is flown at its new place
    def move_2(links: Links) -> None:
        (moved,) = places(links.home, (4.0, -4.0))
        send(links, mav.MAVLink_mission_write_partial_list_message(1, 1, 2, 2, 0))
        send(links, mav.MAVLink_mission_item_int_message(
            1, 1, 2, moved.frame, moved.command, 0, 1, 0, 0, 0, 0, moved.x, moved.y, 0, 0,
        ))  # fmt: skip

    rep, links = run_with({0.5: square, 3.0: move_2}, duration_s=70.0)
    said = texts(links, after_s=1.0)  # (the upload at 0.5 s restarted item 1 of the new mission)
    assert said.count("Mission: 1 WP") == 1 and "Mission: 2 WP" in said
    assert said.count("Auto mission changed, restarted command") == 1
    assert [i + 1 for i, _t in rep.waypoints_reached] == [1, 2, 3]
    t2 = dict(rep.waypoints_reached)[1]
    assert math.hypot(*(leader_at(rep, t2) - np.array([4.0, -4.0]))) <= 0.6  # at the new place

    # after "Mission Complete", an edit does not fly it again
    rep, links = run_with({0.5: square, 35.0: edit(1), 35.1: item_again(1, 5.0)}, duration_s=50.0)
    ep = links.endpoints[0]
    assert ep.mission_complete and [i + 1 for i, _t in rep.waypoints_reached] == [1, 2, 3]
    assert [s for t, s in ep.statustexts if t > 35.0 and ("Reached" in s or "Complete" in s)] == []


def circle_item(
    links_home: tuple[float, float, float], centre: tuple[float, float], turns: float, radius: float
) -> MissionItem:
    c = places(links_home, centre)[0]
    return MissionItem(0, c.frame, mav.MAV_CMD_NAV_LOITER_TURNS, turns, 0.0, radius, x=c.x, y=c.y)


def fly(
    duration_s: float, parts: Callable[[tuple[float, float, float]], list[list[MissionItem] | MissionItem]]
) -> tuple[RunReport, dict[str, float]]:
    """Run with the mission ``parts(home)`` stored at 0.5 s; the run, and when the leader said
    each of its STATUSTEXTs after that (the last time for one said twice)."""

    def upload(links: Links) -> None:
        store(*parts(links.home))(links)

    rep, links = run_with({0.5: upload}, duration_s=duration_s)
    return rep, {text: t_s for t_s, text in links.endpoints[0].statustexts if t_s > 0.4}


@pytest.mark.parametrize("ccw", [False, True])
def test_loiter_turns_drives_to_the_edge_then_round_the_circle_in_its_direction(ccw: bool) -> None:
    # Rover 4.5's circle in AUTO: out to the edge on the line from the centre (6, 0) through
    # the vehicle (at home: the edge at (4, 0)), once round at 2 m (param3 negative: counter-
    # clockwise) at WP_SPEED (0.4 m/s), then on to the next waypoint
    def upload(links: Links) -> None:
        store(circle_item(links.home, (6.0, 0.0), 1.0, -2.0 if ccw else 2.0), places(links.home, (0.0, 0.0)))(links)

    rep, links = run_with({0.5: upload}, duration_s=70.0)
    said = links.endpoints[0].statustexts
    started = {text: t_s for t_s, text in said if text.startswith("Mission:") and t_s > 0.4}
    assert list(started) == ["Mission: 1 LoitTurns", "Mission: 2 WP"]
    t, track = rep.result.t_s, rep.result.pos_ned_m[:, 0]
    r = np.hypot(track[:, 0] - 6.0, track[:, 1])
    first = int(np.argmax(r < 2.9))  # on the circle: within TURN_RADIUS (0.9 m) of its edge
    assert abs(track[first, 0] - 3.1) < 0.2 and abs(track[first, 1]) < 0.2  # towards the edge nearest home
    # once round (12.6 m at 0.4 m/s) takes about 31 s, and then the next item begins
    t_done = started["Mission: 2 WP"]
    assert t_done - t[first] == pytest.approx(2 * math.pi * 2.0 / 0.4, abs=3.0)
    circling = (t > t[first] + 3.0) & (t < t_done - 1.0)
    assert np.all(np.abs(r[circling] - 2.0) < 0.2)  # drawn in from 0.9 m outside ...
    assert np.all(np.abs(r[circling & (t > t[first] + 8.0)] - 2.0) < 0.05)  # ... onto it
    # all four sides, and the first in the circle's direction: clockwise from the south edge
    # (NED) is west, counter-clockwise east
    assert track[circling, 0].max() > 7.9 and track[circling, 1].max() > 1.9 and track[circling, 1].min() < -1.9
    quarter = int(np.argmax(circling & (np.abs(track[:, 0] - 6.0) < 0.3)))
    assert (track[quarter, 1] > 0) == ccw
    assert math.hypot(*(track[np.argmin(np.abs(t - t_done))] - (4.0, 0.0))) < 0.3  # back where it began
    assert math.hypot(*leader_at(rep, 70.0)) < 0.5  # then home, the next waypoint
    assert rep.waypoints_reached[-1][0] == 1  # (the waypoint; a circle is not one)


def test_a_circle_smaller_than_the_turning_radius_is_raised_to_it_and_zero_turns_end_at_once() -> None:
    # Rover's check_config_radius and verify_circle; radius 0.5 (under TURN_RADIUS 0.9)
    def upload(links: Links) -> None:
        store(
            circle_item(links.home, (3.0, 0.0), 0.0, 2.0),
            circle_item(links.home, (3.0, 0.0), 2.7, 0.5),  # 2 turns (whole), raised to 0.9 m
            places(links.home, (3.0, 3.0)),
        )(links)

    rep, links = run_with({0.5: upload}, duration_s=60.0)
    said = links.endpoints[0].statustexts
    at = {text: t_s for t_s, text in said if t_s > 0.4}
    assert "Circle: radius increased to TURN_RADIUS ( 0.9)" in at
    assert at["Mission: 2 LoitTurns"] - at["Mission: 1 LoitTurns"] < 0.2  # no turns: done at once
    t, track = rep.result.t_s, rep.result.pos_ned_m[:, 0]
    r = np.hypot(track[:, 0] - 3.0, track[:, 1])
    circling = (t > at["Mission: 2 LoitTurns"] + 8.0) & (t < at["Mission: 3 WP"] - 1.0)
    assert np.median(r[circling]) == pytest.approx(0.9, abs=0.1)
    # twice round 0.9 m: 11.3 m at 0.4 m/s, about 28 s
    assert 25.0 < at["Mission: 3 WP"] - at["Mission: 2 LoitTurns"] < 40.0


def test_a_speed_change_during_a_circle_is_the_circles_alone() -> None:
    # Rover's ModeAuto::set_desired_speed in its circle submode: the circle takes the speed
    # (the second DO_CHANGE_SPEED starts once the circle has), the waypoint after it drives
    # at the speed set before the circle (0.2), not the circle's (0.3)
    rep, at = fly(
        75.0,
        lambda home: [
            item(mav.MAV_CMD_DO_CHANGE_SPEED, 1.0, 0.2),
            item(mav.MAV_CMD_DO_CHANGE_SPEED, 1.0, 0.3),
            circle_item(home, (3.0, 0.0), 1.0, 1.5),
            places(home, (3.0, 8.0)),
        ],
    )
    t_done = at["Mission: 4 WP"]
    assert speed_between(rep, t_done - 12.0, t_done - 1.0) == pytest.approx(0.3, abs=0.02)
    assert speed_between(rep, t_done + 12.0, t_done + 22.0) == pytest.approx(0.2, abs=0.02)


def test_one_circle_after_another_drives_on_without_stopping() -> None:
    # two LOITER_TURNS in a row round one centre: the second begins where the first ends and
    # is steered from the same guidance step (it used to command a stop for one step)
    rep, at = fly(
        60.0,
        lambda home: [
            circle_item(home, (3.0, 0.0), 1.0, 1.5),
            circle_item(home, (3.0, 0.0), 1.0, 1.5),
            places(home, (3.0, 4.0)),
        ],
    )
    t_next = at["Mission: 2 LoitTurns"]
    assert 20.0 < t_next - at["Mission: 1 LoitTurns"] < 35.0  # once round 1.5 m at 0.4 m/s, from 1.5 m out
    t, speed = rep.result.t_s, rep.result.speed_mps[:, 0]
    around = (t > t_next - 1.0) & (t < t_next + 1.0)
    assert speed[around].min() > 0.39, speed[around]


# -- a second review against Rover's mode_auto.cpp and AR_WPNav --------------------------------
def test_a_missions_rtl_drives_home_forwards_after_a_reverse_before_it() -> None:
    # the RTL item enters Rover's RTL mode, whose Mode::enter clears DO_SET_REVERSE: it drove
    # all the way home backwards
    def upload(links: Links) -> None:
        store(
            places(links.home, (4.0, 0.0)),
            item(mav.MAV_CMD_DO_SET_REVERSE, 1.0),
            places(links.home, (2.0, 0.0)),
            item(mav.MAV_CMD_NAV_RETURN_TO_LAUNCH),
        )(links)

    rep, links = run_with({0.5: upload}, duration_s=50.0)
    reached = dict(rep.waypoints_reached)  # items 1 and 3: indices 0 and 2
    assert speed_between(rep, reached[0] + 1.0, reached[2] - 1.0) > 0.2  # (the speed's size)
    t, speed = rep.result.t_s, rep.result.speed_mps[:, 0]
    assert np.median(speed[(t > reached[0] + 1.0) & (t < reached[2] - 1.0)]) < -0.2  # backed to 2 m
    home = speed[t > reached[2] + 0.5]  # it turns round on the spot, then drives home forwards
    assert home.min() > -0.02 and home.max() > 0.3
    assert not links.endpoints[0].reversed and links.endpoints[0].mission_complete
    assert math.hypot(*leader_at(rep, 50.0)) <= 0.1  # onto home


def test_the_command_after_the_last_waypoint_is_never_said_done(tmp_path: Path) -> None:
    # AP_Mission starts it, then completes the mission before checking it: no
    # MISSION_ITEM_REACHED for it, so the last one reached is the last waypoint's
    def upload(links: Links) -> None:
        store(places(links.home, (3.0, 0.0)), item(mav.MAV_CMD_DO_CHANGE_SPEED, 1.0, 0.2))(links)

    _rep, links = run_with({0.5: upload}, duration_s=20.0, record_to=tmp_path / "m.mcap")
    assert links.endpoints[0].mission_complete and "speed: 0.2 m/s" in texts(links)
    reached = [f["seq"] for _t, _name, f in sent(tmp_path / "m.mcap", "MISSION_ITEM_REACHED")]
    assert reached and reached[-1] == 1 and 2 not in reached


def test_a_loiter_of_no_time_stops_on_its_point_and_a_long_wait_is_none() -> None:
    # Rover's do_nav_wp stops a loiter on its point however short; its 16-bit wait is read
    # signed, so 40000 s waits none
    def upload(links: Links) -> None:
        x, y = latlon(links, 4.0, 0.0)
        loiter = dataclasses.replace(item(mav.MAV_CMD_NAV_LOITER_TIME, 0.0), x=x, y=y)
        store(loiter, places(links.home, (4.0, 4.0, 40000.0)), places(links.home, (0.0, 4.0)))(links)

    rep, links = run_with({0.5: upload}, duration_s=60.0)
    reached = dict(rep.waypoints_reached)
    assert set(reached) == {0, 1, 2} and links.endpoints[0].mission_complete  # the long wait waited none
    t = rep.result.t_s
    k = int(np.argmin(np.abs(t - reached[0])))
    assert math.hypot(*(rep.result.pos_ned_m[k, 0] - np.array([4.0, 0.0]))) < 0.1  # on the loiter's point
    near = np.abs(rep.result.speed_mps[(t > reached[0] - 1.0) & (t < reached[0] + 1.0), 0])
    assert near.min() < 0.1  # it (nearly) stopped there (from 0.4 m/s), then turned for the next
    assert math.hypot(*(leader_at(rep, 60.0) - np.array([0.0, 4.0]))) < 0.1  # onto the last point


def test_a_negative_condition_delay_holds_the_commands_after_it_for_good() -> None:
    # Rover's verify_wait_delay compares unsigned milliseconds: -1 s is about 49.7 days
    assert condition_delay_s(-1.0) == pytest.approx(2**32 / 1000 - 1.0)
    assert condition_delay_s(2.5) == 2.5 and condition_delay_s(0.0) == 0.0

    def upload(links: Links) -> None:
        store(
            places(links.home, (2.0, 0.0)),
            item(mav.MAV_CMD_CONDITION_DELAY, -1.0),
            item(mav.MAV_CMD_DO_SET_REVERSE, 1.0),
            places(links.home, (6.0, 0.0)),
        )(links)

    _rep, links = run_with({0.5: upload}, duration_s=30.0)
    assert links.endpoints[0].mission_complete and not links.endpoints[0].reversed


def test_a_zero_waypoint_radius_is_flown_as_rover_flies_it() -> None:
    # WP_RADIUS 0 is in Rover's range: the waypoints are reached by passing them (it ended
    # the run with a ValueError at the next mission, GUIDED place or RTL)
    def zero(links: Links) -> None:
        send(links, mav.MAVLink_param_set_message(1, 1, b"WP_RADIUS", 0.0, mav.MAV_PARAM_TYPE_REAL32))

    def upload(links: Links) -> None:
        store(places(links.home, (3.0, 0.0), (3.0, 3.0)), item(mav.MAV_CMD_NAV_RETURN_TO_LAUNCH))(links)

    rep, links = run_with({0.3: zero, 0.5: upload}, duration_s=60.0)
    assert links.endpoints[0].param("WP_RADIUS") == 0.0
    assert links.endpoints[0].mission_complete and len(dict(rep.waypoints_reached)) == 3
    assert math.hypot(*leader_at(rep, 60.0)) <= 0.1


@pytest.mark.parametrize(
    ("behave", "mode_after", "said"),
    [
        (0, "AUTO", []),
        (1, "AUTO", []),  # loiter in AUTO: it holds its place
        (2, "AUTO", ["ACRO mode not supported", "Flight mode change failed"]),  # no ACRO here: it stops in AUTO
        (3, "MANUAL", []),
    ],
)
def test_the_missions_end_does_what_mis_done_behave_says(behave: int, mode_after: str, said: list[str]) -> None:
    from lfctl.link.endpoint import MODES

    def set_behave(links: Links) -> None:
        send(links, mav.MAVLink_param_set_message(1, 1, b"MIS_DONE_BEHAVE", behave, mav.MAV_PARAM_TYPE_INT8))

    def upload(links: Links) -> None:
        store(places(links.home, (3.0, 0.0)))(links)

    rep, links = run_with({0.3: set_behave, 0.5: upload}, duration_s=25.0)
    ep = links.endpoints[0]
    assert ep.param("MIS_DONE_BEHAVE") == behave and ep.mission_complete
    assert ep.mode == MODES[mode_after]
    end = texts(links)[texts(links).index("Mission Complete") + 1 :]
    assert [t for t in end if "mode" in t] == said
    assert math.hypot(*(leader_at(rep, 25.0) - np.array([3.0, 0.0]))) < 0.1
    assert abs(rep.result.final.vehicle(0).speed_mps) < 0.02


def test_a_waypoint_radius_set_on_the_way_acts_at_once() -> None:
    # Rover's AR_WPNav reads WP_RADIUS every update; it acted only from the next mission start
    def upload(links: Links) -> None:
        store(places(links.home, (6.0, 0.0), (6.0, 6.0)))(links)

    def wide(links: Links) -> None:
        send(links, mav.MAVLink_param_set_message(1, 1, b"WP_RADIUS", 3.0, mav.MAV_PARAM_TYPE_REAL32))

    rep, _links = run_with({0.5: upload, 1.0: wide}, duration_s=40.0)
    k = int(np.argmin(np.abs(rep.result.t_s - dict(rep.waypoints_reached)[0])))
    assert 2.5 < math.hypot(*(rep.result.pos_ned_m[k, 0] - np.array([6.0, 0.0]))) <= 3.0  # turned at 3 m


def test_a_delay_after_a_waypoint_driven_through_waits_where_the_vehicle_stops() -> None:
    # a NAV_DELAY is placed where the vehicle is as it begins; a fast vehicle coasts past
    # that place in the step: the wait must begin at once (Rover's start_stop), not after
    # turning round and driving back to it (a 3 s delay took 7.7 s)
    import test_rover_modes as trm

    fast = trm.SCENARIO.replace('role = "leader"', 'role = "leader"\nparameters = { max_wheel_speed = 2.0 }')
    fast = fast.replace("max_speed_mps = 0.5", "max_speed_mps = 2.0")

    def upload(links: Links) -> None:
        store(
            item(mav.MAV_CMD_DO_CHANGE_SPEED, 1.0, 1.5),
            places(links.home, (6.0, 0.0)),
            item(mav.MAV_CMD_NAV_DELAY, 3.0),
            places(links.home, (6.0, 6.0)),
        )(links)

    with pytest.MonkeyPatch.context() as mp:
        mp.setattr(trm, "SCENARIO", fast)
        rep, links = run_with({0.5: upload}, duration_s=30.0)
    said = [(t, s) for t, s in links.endpoints[0].statustexts if t > 0.5]
    begun = next(t for t, s in said if s == "Delaying 3 sec")
    after = next(t for t, s in said if t > begun and s.startswith("Mission: 4"))
    assert 3.0 <= after - begun < 3.3
    t, north = rep.result.t_s, rep.result.pos_ned_m[:, 0, 0]
    during = north[(t > begun) & (t < after)]
    assert np.all(np.diff(during) >= -1e-6)  # it stopped going on, never drove back
