"""`lfctl gcs`: a MAVLink ground station (system 255, component 190) for one vehicle."""

from __future__ import annotations

import argparse
import math
import sys
import time
from pathlib import Path
from typing import Any

from lfctl.cli.options import connection, counted, integer, number, param_name


def register(sub: Any) -> None:
    """Add the ``gcs`` command to the parser."""
    g = sub.add_parser(
        "gcs",
        help="a MAVLink ground station: missions, modes, arming, parameters, a live table",
        description="Talk to a vehicle (lfctl sim --realtime, or a real ArduPilot rover) as system 255, component 190.",
    )
    g.add_argument(
        "--connect",
        default="udpout:127.0.0.1:14561",
        type=connection,
        help="pymavlink connection (default: the leader of lfctl sim --realtime)",
    )
    g.add_argument(
        "--target", type=integer(1, 255), help="target system id (leader 1, follower n: 1+n; default 1; not for watch)"
    )
    g.add_argument(
        "--timeout", type=number(0, 3600, lo_open=True, unit="s"), default=5.0, help="seconds to wait for each answer"
    )
    g.add_argument("--signing-passphrase", help="MAVLink 2 signing: the vehicle's [link] signing_passphrase")
    gsub = g.add_subparsers(dest="action", required=True, metavar="ACTION")
    gu = gsub.add_parser(
        "upload",
        help="upload a mission (QGC WPL 110 .waypoints/.txt, or a QGroundControl .plan with its fence and rally "
        "points; or a shipped one by name: square.waypoints)",
    )
    gu.add_argument("file", type=Path, help="a .waypoints, .txt or .plan file, or a shipped mission's name (square)")
    gd = gsub.add_parser(
        "download", help="download the mission (print it, or save to FILE; a .plan gets the fence and rally points too)"
    )
    gd.add_argument("file", type=Path, nargs="?", help="write it here (.waypoints or .plan) instead of printing it")
    gsub.add_parser("clear", help="clear the mission")
    modes = ("MANUAL", "HOLD", "AUTO", "GUIDED", "RTL", "SMART_RTL")  # every mode lfctl's vehicles fly
    gm = gsub.add_parser("mode", help=f"set the mode: {', '.join(modes)}")
    gm.add_argument("mode", type=str.upper, choices=modes)
    gsub.add_parser("arm", help="arm")
    gsub.add_parser("disarm", help="disarm")
    gp = gsub.add_parser("param", help="parameters: list, get NAME, set NAME VALUE, save FILE, load FILE")
    gps = gp.add_subparsers(dest="param_action", required=True, metavar="OP")
    gps.add_parser("list", help="print every parameter and its value")
    gpg = gps.add_parser("get", help="print one parameter's value")
    gpg.add_argument("name", type=param_name)
    gpsv = gps.add_parser("set", help="set one parameter; exit 1 when the vehicle refuses the value")
    gpsv.add_argument("name", type=param_name)
    gpsv.add_argument("value", type=number(-3.4e38, 3.4e38))  # what a MAVLink float carries
    gpsave = gps.add_parser("save", help="write every parameter to FILE (MAVProxy's NAME VALUE, or QGroundControl's)")
    gpsave.add_argument("file", type=Path)
    gpsave.add_argument("--format", choices=("mavproxy", "qgc"), default="mavproxy", help="file format")
    gpload = gps.add_parser("load", help="set every parameter FILE names (MAVProxy's or QGroundControl's format)")
    gpload.add_argument("file", type=Path)
    gw = gsub.add_parser(
        "watch",
        help="every vehicle heard: a screen that redraws in place, or one JSON object per update on a pipe (Ctrl-C to stop)",
    )
    gw.add_argument("--count", type=integer(1, 10**9), help="stop after this many updates")
    g.set_defaults(func=run)


def run(args: argparse.Namespace) -> int:
    """Connect, do the action, print the outcome."""
    from lfctl.data import resolve_mission
    from lfctl.errors import ConfigError
    from lfctl.link.gcs import IN_PROGRESS_MAX_S, GroundStation, result_name
    from lfctl.link.mission import command_name, load_mission_file, save_mission
    from lfctl.link.mission_server import FENCE, RALLY
    from lfctl.link.params import load_param_file
    from lfctl.link.signing import signing_key_from_passphrase

    # files are read before connecting: a bad one is named as such, not as a silent vehicle
    plan = load_mission_file(resolve_mission(args.file)) if args.action == "upload" else None
    wanted = load_param_file(args.file) if args.action == "param" and args.param_action == "load" else None
    key = signing_key_from_passphrase(args.signing_passphrase)
    if args.action == "watch" and args.target is not None:  # it would be ignored: watch shows every vehicle
        raise ConfigError("--target is not for watch: it shows every vehicle heard on the link")
    args.target = args.target or 1
    gcs = GroundStation(args.connect, target_system=args.target, timeout_s=args.timeout, signing_key=key)
    try:
        if args.action != "watch":  # watch shows every vehicle as it is heard, from none
            gcs.wait_heartbeat()
        action = args.action
        if plan is not None:  # upload
            _warn_if_far(gcs, plan, args.file)
            gcs.upload(plan.mission)
            said = f"uploaded {counted(len(plan.mission) - 1, 'item')} (+ home)"
            if plan.plan:  # a plan's three lists go together, as QGroundControl uploads them
                _upload_rest(gcs, [("fence", plan.fence, FENCE), ("rally points", plan.rally, RALLY)])
                said += _fence_and_rally(plan.fence, plan.rally)
            print(f"{said} to system {args.target}")
        elif action == "download":
            items = gcs.download()
            if args.file and Path(args.file).suffix == ".plan":
                fence = gcs.download(mission_type=FENCE)
                rally = gcs.download(mission_type=RALLY)
                save_mission(items, args.file, fence, rally)
                said = f"downloaded {counted(max(0, len(items) - 1), 'item')} (+ home)"
                print(f"{said}{_fence_and_rally(fence, rally)} to {args.file}")
            elif args.file:
                save_mission(items, args.file)
                print(f"downloaded {counted(max(0, len(items) - 1), 'item')} (+ home) to {args.file}")
            elif not items:
                print(f"system {args.target} has no mission")
            else:
                for it in items:
                    print(
                        f"{it.seq:3d} cmd {it.command:3d} {command_name(it.command)} frame {it.frame}"
                        f" p1 {it.param1:g} p2 {it.param2:g} lat {it.lat_deg:.7f} lon {it.lon_deg:.7f} alt {it.z:g}"
                    )
        elif action == "clear":
            gcs.clear()
            print("mission cleared")
        elif action in ("mode", "arm", "disarm"):
            t0 = time.monotonic()
            result = gcs.set_mode(args.mode) if action == "mode" else gcs.arm(action == "arm")
            name = result_name(result)
            if name == "MAV_RESULT_IN_PROGRESS":
                name += f" (no final answer within {IN_PROGRESS_MAX_S:g} s)"
            print(f"{action} {args.mode}: {name}" if action == "mode" else f"{action}: {name}")
            if name != "MAV_RESULT_ACCEPTED":
                for text in gcs.said_since(t0):  # the vehicle's reasons ("PreArm: ...")
                    print(f"vehicle: {text}", file=sys.stderr)
                return 1
        elif action == "param":
            return _param(gcs, args, wanted)
        elif action == "watch":
            watch(gcs, args.count)
        return 0
    finally:
        gcs.close()


def _param(gcs: Any, args: argparse.Namespace, from_file: dict[str, float] | None) -> int:
    """The ``param`` actions (``from_file``: what ``param load`` read); 1 when the vehicle refused a value."""
    from lfctl.link.params import save_param_file

    if args.param_action == "list":
        for k, v in gcs.param_list().items():
            print(f"{k:<16} {v:g}")
    elif args.param_action == "get":
        value = gcs.param_get(args.name)
        print(f"{args.name} = {value:g}")
        if not math.isfinite(value):
            print(f"lfctl: error: system {args.target} gave {args.name} as {value}: not a number", file=sys.stderr)
            return 1
    elif args.param_action == "save":
        values = gcs.param_list()
        save_param_file(values, args.file, args.format, args.target)  # (refuses what could not load back)
        print(f"saved {len(values)} parameters to {args.file}")
    else:
        wanted = {args.name: args.value} if from_file is None else from_file
        skipped = []
        if args.param_action == "load":  # a file from another vehicle names parameters this one has not
            known = gcs.param_list()
            skipped = sorted(n for n in wanted if n not in known)
            wanted = {n: v for n, v in wanted.items() if n in known}
            if skipped:
                print(f"skipped {len(skipped)} parameters this vehicle does not have: {', '.join(skipped[:8])}"
                      + (", ..." if len(skipped) > 8 else ""))  # fmt: skip
        refused = []
        for name, value in wanted.items():
            t0 = time.monotonic()
            got = gcs.param_set(name, value)
            if args.param_action == "set":
                print(f"{name} = {got:g}")
            if not (math.isfinite(value) and math.isclose(got, value, rel_tol=1e-6, abs_tol=1e-6)):
                why = "; ".join(gcs.said_since(t0))  # the vehicle's reason ("WP_SPEED rejected: ...")
                refused.append(f"{name} kept {got:g} (refused {value:g}" + (f": {why})" if why else ")"))
        if args.param_action == "load":
            print(f"set {len(wanted) - len(refused)} of {len(wanted)} parameters from {args.file}")
        if refused:
            print(f"lfctl: error: {'; '.join(refused)}", file=sys.stderr)
            return 1
    return 0


#: a vehicle not heard for this long is shown stale, s
STALE_S = 3.0
#: redraws per second
WATCH_HZ = 2.0
#: the first update waits this long for the vehicles on the link (each sends its heartbeat
#: once a second), s: a snapshot (``--count 1``) lists them all
WATCH_SETTLE_S = 1.2


def _cell(value: object, fmt: str) -> str:
    return "-" if value is None else format(value, fmt)


def fleet_rows(table: Any, now_s: float) -> list[dict[str, Any]]:
    """One dict per vehicle whose autopilot has been heard, by system id: what ``watch``
    shows (and prints as JSON on a pipe).

    Parameters
    ----------
    table : FleetTable
        What the ground station has heard.
    now_s : float
        Now, on the table's clock, s.
    """
    out = []
    for sysid, r in sorted(table.rows.items()):
        if not r.autopilot:
            continue  # a companion or a camera before its vehicle: no row of "?" yet
        f = r.formation
        age = now_s - r.last_heard_s
        track = None if "trk_q" not in f else ("tracking" if f["trk_q"] >= 0.5 else "lost")
        out.append(
            {
                "sysid": sysid,
                "mode": r.mode,
                "armed": r.armed,
                "north_m": _rounded(r.north_m, 2),
                "east_m": _rounded(r.east_m, 2),
                "speed_mps": _rounded(r.speed_mps, 2),
                "link_age_s": round(age, 1),
                "stale": age > STALE_S,
                "mission_seq": r.mission_seq,
                "mission_total": r.mission_total,
                "range_err_m": _rounded(f.get("rng_err"), 3),  # the companion's NaN: no estimate
                "bearing_err_deg": _rounded(f.get("brg_err"), 2),
                "track": track,
                "text": r.text,
            }
        )
    return out


def _rounded(value: float | None, digits: int) -> float | None:
    """``value`` rounded, None where there is none or it is not a number (JSON has no NaN)."""
    return None if value is None or not math.isfinite(value) else round(value, digits)


def render_fleet(rows: list[dict[str, Any]]) -> list[str]:
    """The watch screen's lines: a header and one line per vehicle (a stale one says so).

    Parameters
    ----------
    rows : list of dict
        As :func:`fleet_rows` makes them.
    """
    lines = [
        f"{'sys':>3} {'mode':<7} {'armed':<8} {'north m':>8} {'east m':>8} {'m/s':>5} {'link':>7} "
        f"{'mission':>7} {'rng err m':>9} {'brg err':>7} {'track':<8} last message"
    ]
    for r in rows:
        armed = "-" if r["armed"] is None else ("armed" if r["armed"] else "disarmed")
        mission = "-"
        if r["mission_seq"] is not None:
            total = r["mission_total"]
            mission = f"{r['mission_seq']}/{total}" if total else ("none" if total == 0 else str(r["mission_seq"]))
        link = f"{r['link_age_s']:.1f}s" + ("!" if r["stale"] else "")
        lines.append(
            f"{r['sysid']:>3} {(r['mode'] or '-'):<7} {armed:<8} {_cell(r['north_m'], '8.2f'):>8} {_cell(r['east_m'], '8.2f'):>8} "
            f"{_cell(r['speed_mps'], '5.2f'):>5} {link:>7} {mission:>7} {_cell(r['range_err_m'], '9.3f'):>9} "
            f"{_cell(r['bearing_err_deg'], '7.2f'):>7} {(r['track'] or '-'):<8} "
            + ("STALE: not heard for more than 3 s" if r["stale"] else r["text"])
        )
    if not rows:
        lines.append("(waiting for a vehicle's heartbeat)")
    return lines


def watch(gcs: Any, count: int | None, out: Any = None) -> None:
    """Every vehicle heard, until Ctrl-C (or ``count`` updates): on a terminal a screen that
    redraws in place; on a pipe one JSON object per update. The first update comes once a
    vehicle has been heard and every vehicle has had time to be (:data:`WATCH_SETTLE_S`), or
    with none after the ground station's timeout; a terminal's screens before it say that
    watch waits, and are not counted.

    Parameters
    ----------
    gcs : GroundStation
        The connection (its heartbeat goes out once a second).
    count : int, optional
        Stop after this many updates.
    out : text stream, optional
        Where to write (default standard output).
    """
    import json

    from lfctl.link.gcs import FleetTable

    out = out or sys.stdout
    screen = out.isatty()
    table = FleetTable()
    shown = 0
    t0 = time.monotonic()
    next_draw = t0
    if screen:
        out.write("\x1b[?25l\x1b[2J")  # hide the cursor, clear once
    try:
        while count is None or shown < count:
            gcs.heartbeat()
            m = gcs.next_message(0.05)
            now = time.monotonic()
            for _ in range(1000):  # what has come in before the table is shown (a flood: in parts)
                if m is None:
                    break
                table.add(m, now)
                m = gcs.next_message(0.0)
            if now < next_draw:
                continue
            # a snapshot lists the vehicles, not the moment before they are heard: until then a
            # terminal shows that it waits, and a pipe gets nothing; neither is an update counted
            settled = shown > 0 or now - t0 >= gcs.timeout_s
            if not settled:
                heard = any(r.autopilot for r in table.rows.values())
                settled = heard and now - t0 >= WATCH_SETTLE_S
            if not settled and not screen:
                continue
            next_draw = now + 1.0 / WATCH_HZ
            if settled:
                shown += 1
            rows = fleet_rows(table, now)
            if screen:
                head = (
                    f"lfctl gcs watch  {time.strftime('%H:%M:%S')}  {counted(len(rows), 'vehicle')}  (Ctrl-C to stop)"
                )
                body = "".join(line + "\x1b[K\n" for line in [head, "", *render_fleet(rows)])
                out.write("\x1b[H" + body + "\x1b[J")  # home, lines over the old ones, clear the rest
            else:
                out.write(json.dumps({"t_s": round(now - t0, 2), "vehicles": rows}) + "\n")
            out.flush()
    finally:
        if screen:
            out.write("\x1b[?25h")
            out.flush()


def _fence_and_rally(fence: list[Any], rally: list[Any]) -> str:
    """What a plan's other two lists held, for the line that says what went up or came down."""
    return f", a fence of {counted(len(fence), 'item')} and {counted(len(rally), 'rally point')}"


def _warn_if_far(gcs: Any, plan: Any, name: str) -> None:
    """Say (on stderr) when a plan's place is far from the vehicle's home: a plan made for
    another site. It is uploaded all the same, as a Rover takes it; a vehicle that does not
    tell its home within 2 s is not checked."""
    from lfctl.link.mission import far_place

    home = gcs.home(timeout_s=min(2.0, gcs.timeout_s))
    far = far_place(plan, home) if home is not None else None
    if far is not None:
        print(
            f"lfctl gcs: warning: {name}: {far} the vehicle's home {home[0]:.7f}, {home[1]:.7f} "
            "(a plan for another site? uploading it anyway, as a Rover takes it)",
            file=sys.stderr,
        )


def _upload_rest(gcs: Any, lists: list[tuple[str, list[Any], int]]) -> None:
    """Upload a plan's fence and rally points after its mission; a refusal says what went up."""
    from lfctl.errors import MissionProtocolError

    sent = ["the mission"]
    for k, (what, items, mission_type) in enumerate(lists):
        try:
            gcs.upload(items, mission_type=mission_type)
        except MissionProtocolError as exc:
            kept = " and its ".join(w for w, _items, _type in lists[k:])
            raise MissionProtocolError(
                f"{exc} ({' and '.join(sent)} went up; the vehicle keeps its {kept} as they were)", result=exc.result
            ) from None
        sent.append(f"the {what}")
