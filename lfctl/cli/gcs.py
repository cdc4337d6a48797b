"""`lfctl gcs`: a MAVLink ground station (system 255, component 190) for one vehicle."""

from __future__ import annotations

import argparse
import math
import sys
import time
from pathlib import Path
from typing import Any

from lfctl.cli.options import connection, integer, number, param_name


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
    g.add_argument("--target", type=integer(1, 255), default=1, help="target system id (leader 1, follower n: 1+n)")
    g.add_argument(
        "--timeout", type=number(0, 3600, lo_open=True, unit="s"), default=5.0, help="seconds to wait for each answer"
    )
    g.add_argument("--signing-passphrase", help="MAVLink 2 signing: the vehicle's [link] signing_passphrase")
    gsub = g.add_subparsers(dest="action", required=True, metavar="ACTION")
    gu = gsub.add_parser("upload", help="upload a mission (QGC WPL 110 .waypoints/.txt or .plan)")
    gu.add_argument("file", type=Path)
    gd = gsub.add_parser("download", help="download the mission (print it, or save to FILE)")
    gd.add_argument("file", type=Path, nargs="?")
    gsub.add_parser("clear", help="clear the mission")
    gm = gsub.add_parser("mode", help="set the mode: MANUAL, HOLD, AUTO, GUIDED")
    gm.add_argument("mode", type=str.upper, choices=("MANUAL", "HOLD", "AUTO", "GUIDED"))
    gsub.add_parser("arm", help="arm")
    gsub.add_parser("disarm", help="disarm")
    gp = gsub.add_parser("param", help="parameters: list, get NAME, set NAME VALUE, save FILE, load FILE")
    gps = gp.add_subparsers(dest="param_action", required=True, metavar="OP")
    gps.add_parser("list")
    gpg = gps.add_parser("get")
    gpg.add_argument("name", type=param_name)
    gpsv = gps.add_parser("set")
    gpsv.add_argument("name", type=param_name)
    gpsv.add_argument("value", type=number(-3.4e38, 3.4e38))  # what a MAVLink float carries
    gpsave = gps.add_parser("save", help="write every parameter to FILE (MAVProxy's NAME VALUE, or QGroundControl's)")
    gpsave.add_argument("file", type=Path)
    gpsave.add_argument("--format", choices=("mavproxy", "qgc"), default="mavproxy", help="file format")
    gpload = gps.add_parser("load", help="set every parameter FILE names (MAVProxy's or QGroundControl's format)")
    gpload.add_argument("file", type=Path)
    gw = gsub.add_parser("watch", help="live table of every vehicle heard (Ctrl-C to stop)")
    gw.add_argument("--count", type=integer(1, 10**9), help="stop after this many refreshes")
    g.set_defaults(func=run)


def run(args: argparse.Namespace) -> int:
    """Connect, do the action, print the outcome."""
    from lfctl.link.gcs import GroundStation, result_name
    from lfctl.link.mission import load_mission, save_mission
    from lfctl.link.params import load_param_file
    from lfctl.link.signing import signing_key_from_passphrase

    # files are read before connecting: a bad one is named as such, not as a silent vehicle
    items = load_mission(args.file) if args.action == "upload" else None
    wanted = load_param_file(args.file) if args.action == "param" and args.param_action == "load" else None
    key = signing_key_from_passphrase(args.signing_passphrase)
    gcs = GroundStation(args.connect, target_system=args.target, timeout_s=args.timeout, signing_key=key)
    try:
        gcs.wait_heartbeat()
        action = args.action
        if items is not None:  # upload
            gcs.upload(items)
            print(f"uploaded {len(items) - 1} items (+ home) to system {args.target}")
        elif action == "download":
            items = gcs.download()
            if args.file:
                save_mission(items, args.file)
                print(f"downloaded {len(items)} items to {args.file}")
            else:
                for it in items:
                    print(
                        f"{it.seq:3d} cmd {it.command:3d} frame {it.frame} p1 {it.param1:g} p2 {it.param2:g} lat {it.lat_deg:.7f} lon {it.lon_deg:.7f} alt {it.z:g}"
                    )
        elif action == "clear":
            gcs.clear()
            print("mission cleared")
        elif action in ("mode", "arm", "disarm"):
            result = gcs.set_mode(args.mode) if action == "mode" else gcs.arm(action == "arm")
            name = result_name(result)
            print(f"{action} {args.mode if action == 'mode' else ''}: {name}".replace("  ", " "))
            if name != "MAV_RESULT_ACCEPTED":
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
        print(f"{args.name} = {gcs.param_get(args.name):g}")
    elif args.param_action == "save":
        values = gcs.param_list()
        save_param_file(values, args.file, args.format, args.target)
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
            got = gcs.param_set(name, value)
            if args.param_action == "set":
                print(f"{name} = {got:g}")
            if not (math.isfinite(value) and math.isclose(got, value, rel_tol=1e-6, abs_tol=1e-6)):
                refused.append(f"{name} kept {got:g} (refused {value:g})")
        if args.param_action == "load":
            print(f"set {len(wanted) - len(refused)} of {len(wanted)} parameters from {args.file}")
        if refused:
            print(f"lfctl: error: {'; '.join(refused)}; see the vehicle's STATUSTEXT", file=sys.stderr)
            return 1
    return 0


def _cell(value: object, fmt: str) -> str:
    return "?" if value is None else format(value, fmt)


def watch(gcs: Any, count: int | None) -> None:
    """Print the fleet table once a second (``count`` times, or until Ctrl-C)."""
    from lfctl.link.gcs import FleetTable

    table = FleetTable()
    shown = 0
    next_draw = time.monotonic()
    while count is None or shown < count:
        gcs.heartbeat()
        m = gcs.next_message(0.1)
        if m is not None:
            table.add(m, time.monotonic())
        if time.monotonic() < next_draw:
            continue
        next_draw = time.monotonic() + 1.0
        shown += 1
        print(
            f"{'sys':>3} {'mode':<7} {'armed':<8} {'lat':>12} {'lon':>12} {'m/s':>5} {'rng_err':>7} {'brg_err':>7} {'trk_q':>5}  last message"
        )
        for sysid, r in sorted(table.rows.items()):
            armed = "?" if r.armed is None else ("armed" if r.armed else "disarmed")
            f = r.formation
            print(
                f"{sysid:>3} {r.mode or '?':<7} {armed:<8} {_cell(r.lat_deg, '12.7f'):>12} {_cell(r.lon_deg, '12.7f'):>12} "
                f"{_cell(r.speed_mps, '5.2f'):>5} {_cell(f.get('rng_err'), '.2f'):>7} {_cell(f.get('brg_err'), '.2f'):>7} "
                f"{_cell(f.get('trk_q'), '.2f'):>5}  {r.text}"
            )
        print(flush=True)
