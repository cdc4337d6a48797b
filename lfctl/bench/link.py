"""lfctl bench link: the MAVLink endpoint against a minimal pymavlink responder.

COMMAND_LONG -> COMMAND_ACK round trip (median, p99) over loopback UDP against (a) a vehicle
endpoint streaming its full telemetry while a second endpoint streams too, and (b) a minimal
pymavlink responder that only answers, in the same run; the time to upload a 100-item mission
at 0 % and 20 % datagram loss; the parameters and that mission fetched by the messages
(PARAM_REQUEST_LIST, the mission protocol) and as files over MAVLink FTP (pymavlink's
``mavftp``, the client MAVProxy's is), at 0 % and 20 % loss; how many datagrams per second
one endpoint parses.
"""

from __future__ import annotations

import contextlib
import math
import random
import select
import socket
import statistics
import tempfile
import threading
import time
from pathlib import Path

from pymavlink import mavutil
from pymavlink.dialects.v20 import ardupilotmega as mav

from lfctl.bench.common import print_json, print_table, run_as_script
from lfctl.link.endpoint import VehicleEndpoint
from lfctl.link.gcs import GroundStation
from lfctl.link.mission import local_mission
from lfctl.link.transport import LossyLink, UdpLink

__all__ = ["main"]

HOME = (12.9602, 77.6690, 900.0)
STATE = {"north_m": 1.0, "east_m": 2.0, "yaw_rad": 0.5, "speed_mps": 0.2, "yaw_rate_radps": 0.0}


def start_endpoints(n: int, loss: float = 0.0) -> tuple[list[VehicleEndpoint], threading.Event, threading.Thread]:
    eps = []
    for i in range(n):
        udp = UdpLink(("127.0.0.1", 0))
        eps.append(VehicleEndpoint(f"v{i}", 1 + i, LossyLink(udp, loss, seed=11) if loss else udp, HOME))
    stop = threading.Event()
    t0 = time.monotonic()

    socks = [ep.link.sock for ep in eps]

    def run() -> None:
        while not stop.is_set():
            for ep in eps:
                ep.tick(time.monotonic() - t0, STATE)
            select.select(socks, [], [], 0.005)  # wake on a datagram, or tick telemetry

    th = threading.Thread(target=run, daemon=True)
    th.start()
    return eps, stop, th


def port_of(ep: VehicleEndpoint) -> int:
    return ep.link.port


def round_trips(port: int, n: int) -> list[float]:
    g = GroundStation(f"udpout:127.0.0.1:{port}", timeout_s=2.0)
    g.wait_heartbeat()
    out = []
    for _ in range(n):
        t0 = time.perf_counter()
        g.command(mav.MAV_CMD_REQUEST_MESSAGE, mav.MAVLINK_MSG_ID_HOME_POSITION, retries=1)
        out.append((time.perf_counter() - t0) * 1000)
    g.close()
    return out


def minimal_responder() -> tuple[int, threading.Event]:
    """A bare pymavlink vehicle: heartbeat once a second, ACK every COMMAND_LONG."""
    s = socket.socket(socket.AF_INET, socket.SOCK_DGRAM)
    s.bind(("127.0.0.1", 0))
    port = s.getsockname()[1]
    s.close()
    stop = threading.Event()

    def run() -> None:
        conn = mavutil.mavlink_connection(
            f"udpin:127.0.0.1:{port}", source_system=1, source_component=1, dialect="ardupilotmega"
        )
        last = 0.0
        while not stop.is_set():
            if time.monotonic() - last > 1.0:
                last = time.monotonic()
                if conn.port is not None and getattr(conn, "last_address", None):
                    conn.mav.heartbeat_send(mav.MAV_TYPE_GROUND_ROVER, mav.MAV_AUTOPILOT_ARDUPILOTMEGA, 0, 0, 0)
            m = conn.recv_match(blocking=True, timeout=0.05)
            if m is None:
                continue
            if m.get_type() == "HEARTBEAT":
                conn.mav.heartbeat_send(mav.MAV_TYPE_GROUND_ROVER, mav.MAV_AUTOPILOT_ARDUPILOTMEGA, 0, 0, 0)
            elif m.get_type() == "COMMAND_LONG":
                conn.mav.command_ack_send(m.command, 0, 0, 0, m.get_srcSystem(), m.get_srcComponent())
        conn.close()

    threading.Thread(target=run, daemon=True).start()
    time.sleep(0.2)
    return port, stop


def fetch_both_ways(loss: float) -> dict[str, tuple[float, float, bool]]:
    """The parameters and a 100-item mission fetched from one endpoint (``loss`` of the
    datagrams lost both ways): by PARAM_REQUEST_LIST and the mission protocol (lfctl's ground
    station), and as ``@PARAM/param.pck`` and ``@MISSION/mission.dat`` over MAVLink FTP
    (pymavlink's client); seconds each way, and whether the FTP copies are the vehicle's."""
    from pymavlink.mavftp import MAVFTP

    eps, stop, th = start_endpoints(1, loss)
    ep = eps[0]
    out: dict[str, tuple[float, float, bool]] = {}
    stack = contextlib.ExitStack()  # the clients, closed however the fetch ends
    try:
        ep.store_mission(local_mission([(float(k % 10), float(k // 10)) for k in range(100)], HOME))
        g = GroundStation(f"udpout:127.0.0.1:{port_of(ep)}", timeout_s=10.0)
        stack.callback(g.close)
        g.wait_heartbeat()
        t0 = time.perf_counter()
        g.param_list()
        params_s = time.perf_counter() - t0
        t0 = time.perf_counter()
        g.download()
        mission_s = time.perf_counter() - t0
        conn = mavutil.mavlink_connection(f"udpout:127.0.0.1:{port_of(ep)}", source_system=255, source_component=190)
        stack.callback(conn.close)
        conn.mav.heartbeat_send(mav.MAV_TYPE_GCS, mav.MAV_AUTOPILOT_INVALID, 0, 0, 0)
        conn.wait_heartbeat(timeout=5)
        client = MAVFTP(conn, 1, 1)
        with tempfile.TemporaryDirectory() as tmp:
            for name, remote, want in (
                ("parameters", "@PARAM/param.pck", ep.param_server.packed),
                ("100-item mission", "@MISSION/mission.dat", lambda: ep.missions.packed(0)),
            ):
                local = Path(tmp) / remote.rsplit("/", 1)[1]
                t0 = time.perf_counter()
                client.cmd_get([remote, str(local)])
                client.process_ftp_reply("get", timeout=30)
                dt = time.perf_counter() - t0
                whole = local.exists() and local.read_bytes() == want()
                out[name] = (round(params_s if name == "parameters" else mission_s, 3), round(dt, 3), whole)
    finally:
        stack.close()
        stop.set()
        th.join()
        ep.link.close()
    return out


def pct(values: list[float], q: float) -> float:
    """The ``q`` quantile by nearest rank: the smallest value with at least ``q`` of them at or
    below it (p99 of 200 is the 198th; ``int(q * n)`` took the 199th, p99.5)."""
    ranked = sorted(values)
    return ranked[max(0, math.ceil(q * len(ranked) - 1e-9) - 1)]  # (0.99 * 200 may land above 198)


def main(quick: bool = False) -> None:
    """Run the benchmark, print its table and JSON line (``quick``: shorter runs)."""
    n_rt = 200 if quick else 1000
    rows, results = [], {}
    # (a) our endpoint, two vehicles streaming telemetry
    eps, stop, th = start_endpoints(2)
    try:
        rt = round_trips(port_of(eps[0]), n_rt)
    finally:
        stop.set()
        th.join()
        for ep in eps:
            ep.link.close()
    # (b) minimal pymavlink responder
    port, stop_min = minimal_responder()
    try:
        rt_min = round_trips(port, n_rt)
    finally:
        stop_min.set()
    for name, v in (("lfctl endpoint (2 vehicles streaming)", rt), ("minimal pymavlink responder", rt_min)):
        rows.append((name, round(statistics.median(v), 3), round(pct(v, 0.99), 3)))
    results["command_ack_ms"] = {
        "endpoint_median": statistics.median(rt),
        "endpoint_p99": pct(rt, 0.99),
        "minimal_median": statistics.median(rt_min),
        "minimal_p99": pct(rt_min, 0.99),
        "ratio_endpoint_over_minimal_median": statistics.median(rt) / statistics.median(rt_min),
    }
    print_table(("COMMAND_LONG -> COMMAND_ACK", "median ms", "p99 ms"), rows)
    # mission upload, 100 items
    up_rows = []
    for loss in (0.0, 0.2):
        eps, stop, th = start_endpoints(1, loss)
        try:
            g = GroundStation(f"udpout:127.0.0.1:{port_of(eps[0])}", timeout_s=5.0)
            g.wait_heartbeat()
            items = local_mission([(float(k % 10), float(k // 10)) for k in range(100)], HOME)
            t0 = time.perf_counter()
            g.upload(items, item_timeout_s=0.5)
            dt = time.perf_counter() - t0
            ok = len(eps[0].mission) == len(items)
            g.close()
        finally:
            stop.set()
            th.join()
            eps[0].link.close()
        up_rows.append((f"{int(loss * 100)} %", round(dt, 3), ok))
        results[f"upload_100_items_s_loss_{int(loss * 100)}pct"] = dt
    print()
    print_table(("datagram loss (both ways)", "100-item upload s", "complete"), up_rows)
    # the parameters and the mission fetched by the messages and as files (MAVLink FTP)
    ftp_rows = []
    for loss in (0.0, 0.2):
        got = fetch_both_ways(loss)
        ftp_rows += [(f"{name}, {int(loss * 100)} % loss", *got[name]) for name in ("parameters", "100-item mission")]
        for name, (by_messages, by_ftp, whole) in got.items():
            key = name.split()[-1]
            results[f"fetch_{key}_messages_s_loss_{int(loss * 100)}pct"] = by_messages
            results[f"fetch_{key}_ftp_s_loss_{int(loss * 100)}pct"] = by_ftp
            results[f"fetch_{key}_ftp_whole_loss_{int(loss * 100)}pct"] = whole
    print()
    print_table(("fetched", "by the messages s", "by MAVLink FTP s", "FTP copy whole"), ftp_rows)
    # parse rate: datagrams per second one endpoint reads, decodes and handles
    udp = UdpLink(("127.0.0.1", 0))
    ep = VehicleEndpoint("v", 1, udp, HOME)
    m = mav.MAVLink(None, srcSystem=255, srcComponent=190)
    good = [
        mav.MAVLink_heartbeat_message(mav.MAV_TYPE_GCS, 8, 0, 0, 4, 3).pack(m),
        mav.MAVLink_param_request_read_message(7, 1, b"WP_SPEED", -1).pack(m),
        bytes(random.Random(1).getrandbits(8) for _ in range(40)),
    ]
    s = socket.socket(socket.AF_INET, socket.SOCK_DGRAM)
    s.bind(("127.0.0.1", 0))
    n_send = 20_000 if quick else 100_000

    def drain() -> None:
        """Every datagram waiting, tick after tick (a tick reads at most 256: reading once
        per 500 sent left half of them in the socket to be dropped, uncounted)."""
        while True:
            before = ep.stats.datagrams
            ep.receive()
            if ep.stats.datagrams == before:
                return

    t0 = time.perf_counter()
    for k in range(n_send):
        s.sendto(good[k % 3], ("127.0.0.1", udp.port))
        if k % 200 == 199:
            drain()
    drain()
    dt = time.perf_counter() - t0
    s.close()
    rate = ep.stats.datagrams / dt
    print(
        f"\nparse: {ep.stats.datagrams} of {n_send} datagrams read in {dt:.2f} s = {rate:,.0f} datagrams/s (sender in the same process); {ep.stats.bad} bad, {ep.stats.other_sysid} for other systems"
    )
    results["parse_datagrams_per_s"] = rate
    results["parse_datagrams_read"] = ep.stats.datagrams
    udp.close()
    print_json("link", {k: (round(v, 4) if isinstance(v, float) else v) for k, v in results.items()})


if __name__ == "__main__":
    run_as_script(main, __doc__)
