"""The companion (`lfctl follow`) and the ground station (`lfctl gcs`) against peers that are
not lfctl's simulator: cut packets, floods, unknown message ids, commands answered
IN_PROGRESS and never again, acks from the wrong component, missions asked for without end,
parameter lists with holes. Nothing a peer sends may end, hang or lock them, or lose data."""

from __future__ import annotations

import contextlib
import math
import select
import threading
import time
from collections.abc import Callable, Iterator
from pathlib import Path
from typing import Any

import pytest
from pymavlink.dialects.v20 import ardupilotmega as mav
from support import loopback_udp

from lfctl.errors import ConfigError, LinkTimeoutError, MissionProtocolError
from lfctl.link import companion as companion_module
from lfctl.link.companion import COMPANION_COMPID, POLL_MAX_MESSAGES, Companion, answer_name
from lfctl.link.gcs import FORMATION_NAMES_MAX, FleetTable, GroundStation
from lfctl.link.mission import MissionItem
from lfctl.link.params import save_param_file
from lfctl.link.port import MavPort

pytestmark = pytest.mark.integration
ROVER = mav.MAVLink(None, srcSystem=1, srcComponent=1)


def position(k: int) -> bytes:
    return mav.MAVLink_local_position_ned_message(k, float(k), 0.0, 0.0, 0.0, 0.0, 0.0).pack(ROVER)


def test_a_cut_packet_swallows_none_of_the_datagrams_after_it() -> None:
    # pymavlink keeps one parse buffer across datagrams: a 2-byte v2 header announcing 255
    # bytes took the next ten positions with it (and a cut packet before each COMMAND_ACK
    # made a rover that answered everything look silent)
    port = MavPort.open("udpin:127.0.0.1:0", 1, COMPANION_COMPID)
    got: list[int] = []
    with loopback_udp() as s:
        for data in (position(1), b"\xfd\xff", *(position(k) for k in range(2, 12))):
            s.sendto(data, port.connection.port.getsockname())
        deadline = time.monotonic() + 5.0
        while len(got) < 11 and time.monotonic() < deadline:
            m = port.recv(0.1)
            if m is not None:
                got.append(m.time_boot_ms)
    port.close()
    assert got == list(range(1, 12)) and port.junk == 1


def test_unknown_message_ids_are_counted_and_nothing_is_kept_of_them() -> None:
    # pymavlink's connection kept the last message of every type name (UNKNOWN_<id>: 2**24)
    port = MavPort.open("udpin:127.0.0.1:0", 1, COMPANION_COMPID)
    with loopback_udp() as s:
        for k in range(200):  # (within the kernel's socket buffer)
            msg_id = 70_000 + k
            frame = bytes([0xFD, 4, 0, 0, k % 256, 1, 1]) + msg_id.to_bytes(3, "little") + b"\x01\x02\x03\x04\x00\x00"
            s.sendto(frame, port.connection.port.getsockname())
        s.sendto(position(7), port.connection.port.getsockname())
        deadline = time.monotonic() + 5.0
        m = None
        while m is None and time.monotonic() < deadline:
            m = port.recv(0.1)
    kept = list(port.connection.messages)
    port.close()
    assert m is not None and m.time_boot_ms == 7 and port.junk == 200
    assert not any(k.startswith("UNKNOWN") for k in kept)


def test_a_flood_is_read_a_bounded_amount_a_step_and_said_as_such() -> None:
    # 40 heartbeats a datagram from another system, faster than a step reads: each poll takes
    # at most POLL_MAX_MESSAGES, so the heartbeat and the setpoints keep their rate
    companion = Companion(MavPort.open("udpin:127.0.0.1:0", 1, COMPANION_COMPID), 1)
    other = mav.MAVLink(None, srcSystem=42, srcComponent=1)
    beat = mav.MAVLink_heartbeat_message(mav.MAV_TYPE_GROUND_ROVER, 3, 0, 0, 4, 3)
    datagram = b"".join(beat.pack(other) for _ in range(40))
    with loopback_udp() as s:
        address = companion.port.connection.port.getsockname()
        for _ in range(100):
            s.sendto(datagram, address)
        s.sendto(position(3), address)
        time.sleep(0.2)
        first = companion.poll(0.0)
        reads = [first]
        while companion.vehicle.t_s is None and len(reads) < 50:
            reads.append(companion.poll(0.1 * len(reads)))
    companion.close()
    assert first <= POLL_MAX_MESSAGES and companion.overloaded >= 1
    assert companion.vehicle.north_m == 3.0  # the rover's message behind the flood, not lost
    assert companion.other_autopilots == {42} and not companion.vehicle.heard  # not the rover's


class _AnsweredOnce:
    """A port whose autopilot answers the first COMMAND_LONG IN_PROGRESS, then nothing; it
    records each read's timeout."""

    def __init__(self) -> None:
        self.sysid, self.sent, self.timeouts, self.junk = 1, 0, [], 0
        self.codec = mav.MAVLink(None, srcSystem=1, srcComponent=1)

    def send(self, msg: Any) -> None:
        self.sent += msg.get_type() == "COMMAND_LONG"

    def echo(self, m: Any) -> bool:  # (nothing comes back: see MavPort.echo)
        return False

    def recv(self, timeout_s: float = 0.0) -> Any:
        self.timeouts.append(timeout_s)
        if len(self.timeouts) > 1:
            time.sleep(timeout_s)  # nothing more comes: a read waits as long as it was told
            return None
        ack = mav.MAVLink_command_ack_message(
            mav.MAV_CMD_DO_SET_MODE, mav.MAV_RESULT_IN_PROGRESS, 0, 0, 1, COMPANION_COMPID
        )
        return self.codec.decode(bytearray(ack.pack(self.codec)))


def test_an_answer_in_progress_and_then_silence_waits_without_spinning(monkeypatch: pytest.MonkeyPatch) -> None:
    # the wait read with a zero timeout in a tight loop (100 % CPU for 10 s a request)
    monkeypatch.setattr(companion_module, "IN_PROGRESS_MAX_S", 0.5)
    port = _AnsweredOnce()
    result = Companion(port, 1).request(mav.MAV_CMD_DO_SET_MODE, 1, 15, try_s=0.1, tries=3)  # type: ignore[arg-type]
    assert result == mav.MAV_RESULT_IN_PROGRESS and port.sent == 1
    assert len(port.timeouts) < 40  # each read waits for the answer (about 10 of 0.05 s; it spun)
    assert answer_name(result) == "answered IN_PROGRESS, no final answer within 0.5 s"


# -- the ground station against a scripted vehicle -------------------------------------------
@contextlib.contextmanager
def vehicle(answer: Callable[[Any, Callable[[Any], None]], None]) -> Iterator[GroundStation]:
    """A vehicle (system 1) on loopback UDP that beats once a second and hands each message
    it gets to ``answer(m, send)``; a ground station connected to it."""
    port = MavPort.open("udpin:127.0.0.1:0", 1, 1)
    stop = threading.Event()

    def run() -> None:
        beat = 0.0
        while not stop.is_set():
            if time.monotonic() - beat >= 1.0:
                beat = time.monotonic()
                port.send(mav.MAVLink_heartbeat_message(mav.MAV_TYPE_GROUND_ROVER, 3, 0, 4, 4, 3))
            m = port.recv(0.02)
            if m is not None:
                answer(m, send)

    def send(x: Any) -> None:  # a message from the autopilot, or bytes packed by someone else
        port.connection.write(x) if isinstance(x, bytes) else port.send(x)

    thread = threading.Thread(target=run, daemon=True)
    thread.start()
    g = GroundStation(f"udpout:127.0.0.1:{port.connection.port.getsockname()[1]}", target_system=1, timeout_s=3.0)
    try:
        g.wait_heartbeat()
        yield g
    finally:
        g.close()
        stop.set()
        thread.join(timeout=5)
        port.close()


def test_an_ack_from_another_component_or_to_another_station_is_not_the_answer() -> None:
    def answer(m: Any, send: Callable[[Any], None]) -> None:
        if m.get_type() != "COMMAND_LONG":
            return
        camera = mav.MAVLink_command_ack_message(m.command, mav.MAV_RESULT_DENIED, 0, 0, 255, 190)
        send(camera.pack(mav.MAVLink(None, srcSystem=1, srcComponent=100)))  # the vehicle's camera's, to us
        send(mav.MAVLink_command_ack_message(m.command, mav.MAV_RESULT_DENIED, 0, 0, 42, 42))  # to someone else
        send(mav.MAVLink_command_ack_message(m.command, mav.MAV_RESULT_IN_PROGRESS, 50, 0, 255, 190))
        send(mav.MAVLink_command_ack_message(m.command, mav.MAV_RESULT_ACCEPTED, 0, 0, 255, 190))

    with vehicle(answer) as g:
        assert g.arm() == mav.MAV_RESULT_ACCEPTED  # past the stranger's DENIED and the IN_PROGRESS


def test_a_vehicle_asking_for_an_item_without_end_ends_the_upload_with_an_error() -> None:
    def answer(m: Any, send: Callable[[Any], None]) -> None:
        if m.get_type() in ("MISSION_COUNT", "MISSION_ITEM_INT"):
            send(mav.MAVLink_mission_request_int_message(255, 190, 0, 0))

    items = [MissionItem(k, 3, 16, x=129_600_000 + k, y=776_700_000) for k in range(3)]
    with vehicle(answer) as g, pytest.raises(MissionProtocolError, match="asked for item 0 again and again"):
        g.upload(items)


def test_a_vehicle_refusing_every_count_before_asking_is_named_not_called_silent() -> None:
    def answer(m: Any, send: Callable[[Any], None]) -> None:
        if m.get_type() == "MISSION_COUNT":
            send(mav.MAVLink_mission_ack_message(255, 190, mav.MAV_MISSION_ERROR, 0))

    items = [MissionItem(k, 3, 16, x=129_600_000 + k, y=776_700_000) for k in range(2)]
    with (
        vehicle(answer) as g,
        pytest.raises(MissionProtocolError, match="before any item was asked for: MAV_MISSION_ERROR"),
    ):
        g.upload(items, item_timeout_s=0.1, restarts=2)


def _params(send: Callable[[Any], None], indexes: range, count: int) -> None:
    for k in indexes:
        send(mav.MAVLink_param_value_message(f"P{k}".encode(), float(k), mav.MAV_PARAM_TYPE_REAL32, count, k))


def test_a_parameter_lost_from_the_list_is_asked_for_by_index() -> None:
    def answer(m: Any, send: Callable[[Any], None]) -> None:
        if m.get_type() == "PARAM_REQUEST_LIST":
            _params(send, range(10), 11)  # index 10 lost on the way
        elif m.get_type() == "PARAM_REQUEST_READ" and m.param_index == 10:
            _params(send, range(10, 11), 11)

    with vehicle(answer) as g:
        assert g.param_list() == {f"P{k}": float(k) for k in range(11)}


def test_many_parameters_lost_are_asked_for_as_fast_as_ardupilot_takes_reads() -> None:
    # ArduPilot queues 20 PARAM_REQUEST_READs and drops the rest: 100 lost of 300 take rounds
    window = {"t": 0.0, "n": 0}

    def answer(m: Any, send: Callable[[Any], None]) -> None:
        if m.get_type() == "PARAM_REQUEST_LIST":
            _params(send, range(200), 300)  # 200..299 lost
        elif m.get_type() == "PARAM_REQUEST_READ":
            if time.monotonic() - window["t"] > 0.2:
                window["t"], window["n"] = time.monotonic(), 0
            window["n"] += 1
            if window["n"] <= 20:
                _params(send, range(m.param_index, m.param_index + 1), 300)

    with vehicle(answer) as g:
        assert g.param_list() == {f"P{k}": float(k) for k in range(300)}


def test_a_companions_own_parameters_are_not_taken_for_the_autopilots() -> None:
    # through a rehearsal's port (or a Rover's routing) the companion's LFC_* come to a ground
    # station too, with their own count and indexes: they were taken into the autopilot's list
    companion = mav.MAVLink(None, srcSystem=1, srcComponent=191)

    def answer(m: Any, send: Callable[[Any], None]) -> None:
        theirs = mav.MAVLink_param_value_message(b"LFC_RANGE", 2.5, mav.MAV_PARAM_TYPE_REAL32, 6, 0)
        if m.get_type() == "PARAM_REQUEST_LIST":
            send(theirs.pack(companion))
            _params(send, range(11), 11)
        elif m.get_type() == "PARAM_REQUEST_READ":
            send(mav.MAVLink_param_value_message(b"P3", 99.0, mav.MAV_PARAM_TYPE_REAL32, 6, 65535).pack(companion))
            _params(send, range(3, 4), 11)

    with vehicle(answer) as g:
        assert g.param_list() == {f"P{k}": float(k) for k in range(11)}
        assert g.param_get("P3") == 3.0


def test_a_parameter_never_sent_ends_the_list_with_its_index_named() -> None:
    def answer(m: Any, send: Callable[[Any], None]) -> None:
        if m.get_type() == "PARAM_REQUEST_LIST":
            _params(send, range(10), 11)
        elif m.get_type() == "PARAM_REQUEST_READ":
            _params(send, range(0, 1), 11)  # (only ever P0 again: no progress)

    with vehicle(answer) as g, pytest.raises(LinkTimeoutError, match="got 10 of 11 parameters; still missing index 10"):
        g.param_list()


def test_parameters_that_could_not_be_loaded_back_are_not_saved(tmp_path: Path) -> None:
    with pytest.raises(ConfigError, match=r"2 parameters could not be loaded back.*'A B' = 1.0, 'NANP' = nan"):
        save_param_file({"WP_SPEED": 2.0, "A B": 1.0, "NANP": math.nan}, tmp_path / "p.parm")
    assert not (tmp_path / "p.parm").exists()


def test_the_watch_keeps_a_bounded_number_of_formation_values() -> None:
    table = FleetTable()
    codec = mav.MAVLink(None, srcSystem=1, srcComponent=COMPANION_COMPID)
    for k in range(200):
        m = mav.MAVLink_named_value_float_message(0, f"n{k}".encode(), 1.0)
        table.add(codec.decode(bytearray(m.pack(codec))), 0.0)
    m = mav.MAVLink_named_value_float_message(0, b"n0", 2.0)
    table.add(codec.decode(bytearray(m.pack(codec))), 1.0)
    assert len(table.rows[1].formation) == FORMATION_NAMES_MAX and table.rows[1].formation["n0"] == 2.0


def _heartbeats(n: int) -> bytes:
    codec = mav.MAVLink(None, srcSystem=1, srcComponent=1)
    out = b""
    for _ in range(n):
        out += mav.MAVLink_heartbeat_message(mav.MAV_TYPE_GROUND_ROVER, 3, 0, 0, 4, 3).pack(codec)
        codec.seq = (codec.seq + 1) % 256
    return out


def _read_all(port: MavPort, want: int) -> list[Any]:
    got: list[Any] = []
    deadline = time.monotonic() + 5.0
    while len(got) < want and time.monotonic() < deadline:
        m = port.recv(0.1)
        if m is not None:
            got.append(m)
    return got


@contextlib.contextmanager
def tcp_vehicle(serve: Callable[[Any], None]) -> Iterator[MavPort]:
    """A vehicle on a local TCP server that runs ``serve(connection)`` once a ground station
    connects and then closes; a port connected to it."""
    import socket

    server = socket.socket()
    server.bind(("127.0.0.1", 0))
    server.listen(1)

    def vehicle() -> None:
        conn, _ = server.accept()
        serve(conn)
        conn.close()

    threading.Thread(target=vehicle, daemon=True).start()
    port = MavPort.open(f"tcp:127.0.0.1:{server.getsockname()[1]}", 255, 190)
    try:
        yield port
    finally:
        port.close()
        server.close()


def test_a_vehicle_on_tcp_is_heard_packets_split_anywhere() -> None:
    # ArduPilot SITL's tcp:5760: a stream, where a packet may come in pieces (and the port's
    # own reading of the stream must not pass over senders pymavlink had not registered)
    beats = _heartbeats(11)
    data = beats[: 10 * 21] + b"\x00junk" + beats[10 * 21 :]  # (a v2 heartbeat is 21 bytes)

    def serve(conn: Any) -> None:
        for k in range(0, len(data), 7):  # in 7-byte pieces
            conn.sendall(data[k : k + 7])
            time.sleep(0.002)
        time.sleep(2.0)

    with tcp_vehicle(serve) as port:
        got = _read_all(port, 11)
    assert [(m.get_type(), m.get_srcSystem()) for m in got] == [("HEARTBEAT", 1)] * 11
    assert port.lost == 0


def test_a_vehicle_on_a_serial_port_is_heard() -> None:
    # a companion on the rover's telemetry UART: a pseudo-terminal stands in for it
    import os
    import pty

    parent, child = pty.openpty()
    try:
        import tty

        tty.setraw(child)
        port = MavPort.open(f"{os.ttyname(child)},115200", 255, 190)
        try:
            os.write(parent, _heartbeats(5))
            got = _read_all(port, 5)
        finally:
            port.close()
    finally:
        os.close(parent)
        with contextlib.suppress(OSError):
            os.close(child)
    assert [(m.get_type(), m.get_srcSystem()) for m in got] == [("HEARTBEAT", 1)] * 5


def test_large_junk_datagrams_are_passed_over_unparsed() -> None:
    # pymavlink parses byte by byte: 64 KB of junk took it 40 ms a datagram, seconds a read
    port = MavPort.open("udpin:127.0.0.1:0", 1, COMPANION_COMPID)
    parsed: list[int] = []
    parse = port.connection.mav.parse_buffer
    port.connection.mav.parse_buffer = lambda data: parsed.append(len(data)) or parse(data)
    with loopback_udp() as s:
        for _ in range(3):
            s.sendto(b"\xfd" * 60_000, port.connection.port.getsockname())  # start bytes all through
        s.sendto(b"no start byte here", port.connection.port.getsockname())
        s.sendto(position(5), port.connection.port.getsockname())
        deadline = time.monotonic() + 5.0
        m = None
        while m is None and time.monotonic() < deadline:
            m = port.recv(0.1)
    port.close()
    assert m is not None and m.time_boot_ms == 5 and port.junk == 4
    assert parsed == [len(position(5))]  # only the packet was parsed


def test_a_tcp_peer_that_closes_is_noted_once_and_read_no_more(capsys: pytest.CaptureFixture[str]) -> None:
    # pymavlink printed "EOF on TCP socket" and tried again on every read: 150,000 lines a second
    def serve(conn: Any) -> None:
        conn.sendall(_heartbeats(2))
        time.sleep(0.2)

    with tcp_vehicle(serve) as port:
        got = _read_all(port, 2)
        deadline = time.monotonic() + 5.0
        while not port.closed and time.monotonic() < deadline:
            assert port.recv(0.05) is None
        reads = [port.recv(0.01) for _ in range(20)]
    assert len(got) == 2 and port.closed and reads == [None] * 20
    assert "EOF" not in capsys.readouterr().out


@pytest.mark.parametrize("comes", ["noise", "signed with another key"])
def test_a_serial_port_that_hears_only_noise_asks_for_its_baud(comes: str) -> None:
    # a UART at another baud than the rover's reads noise: the timeout said only "is the
    # vehicle up, the address right...", as for a silent one; packets of another key are no noise
    import os
    import pty
    import random
    import tty

    from lfctl.link.signing import setup_signing, signing_key_from_passphrase

    parent, child = pty.openpty()
    tty.setraw(child)
    companion = Companion.open(f"{os.ttyname(child)},57600", 1, signing_key_from_passphrase("convoy-7"))
    try:
        if comes == "noise":
            os.write(parent, random.Random(3).randbytes(4000))
        else:
            codec = mav.MAVLink(None, srcSystem=1, srcComponent=1)
            setup_signing(codec, signing_key_from_passphrase("another"))
            hb = mav.MAVLink_heartbeat_message(mav.MAV_TYPE_GROUND_ROVER, 3, 0, 0, 4, 3)
            os.write(parent, b"".join(hb.pack(codec) for _ in range(20)))
        with pytest.raises(LinkTimeoutError) as timeout:
            companion.wait_vehicle(1.0, 20.0)
    finally:
        companion.close()
        os.close(parent)
        os.close(child)
    baud = "is the baud the rover's SERIALn_BAUD, and the port set to MAVLink (SERIALn_PROTOCOL 2)?"
    assert (baud in str(timeout.value)) == (comes == "noise"), str(timeout.value)


def test_a_serial_device_that_stops_reading_does_not_hold_the_sender(caplog: pytest.LogCaptureFixture) -> None:
    # a flight controller on USB that stops reading its port: the writes filled the buffer and
    # the next one (pyserial's, no write timeout) waited for ever, the step, the heartbeat and
    # Ctrl-C's last zero setpoints with it
    import os
    import pty
    import tty

    parent, child = pty.openpty()
    tty.setraw(child)
    port = MavPort.open(f"{os.ttyname(child)},115200", 255, 190)
    hb = mav.MAVLink_heartbeat_message(mav.MAV_TYPE_ONBOARD_CONTROLLER, 8, 0, 0, 4, 3)
    sent: list[int] = []

    def send() -> None:
        while len(sent) < 20_000 and getattr(port, "stalled", 0) < 50:  # (a pty holds some 60 KB: 3000 heartbeats)
            port.send(hb)
            sent.append(port.stalled)

    sender = threading.Thread(target=send, daemon=True)
    try:
        sender.start()
        sender.join(timeout=20.0)
        # the sender was not held: it went on past the full buffer, each write after the first
        # stalled one lost at once (without the fix the first stalled write waits for ever)
        assert not sender.is_alive() and port.stalled == 50 and not port.closed
        assert sent[-50:] == list(range(1, 51))
        said = [r.getMessage() for r in caplog.records if "takes no bytes" in r.getMessage()]
        assert len(said) == 1, said
        while select.select([parent], [], [], 0.2)[0]:  # it reads again: the next whole packet goes
            os.read(parent, 65536)
        port.send(hb)
        assert port.stalled == 0
    finally:
        port.close()
        os.close(parent)
        os.close(child)
        sender.join(timeout=5.0)


def test_a_serial_device_that_stalls_mid_packet_gets_the_rest_of_it_first() -> None:
    # a device that stops reading when its buffer holds part of a packet: the rest was lost and
    # the line carried half a packet, whose length made the rover's parser take the next
    # packet's bytes for its rest (a CRC error: both lost)
    import os
    import pty
    import tty

    parent, child = pty.openpty()
    tty.setraw(child)
    tty.setraw(parent)
    port = MavPort.open(f"{os.ttyname(child)},115200", 255, 190)
    target = mav.MAVLink_set_position_target_local_ned_message(0, 1, 1, 1, 0xFFF, 0, 0, 0, 0.5, 0, 0, 0, 0, 0, 0, 0)
    try:
        while port.stalled < 20:  # (a pty holds some 60 KB)
            port.send(target)
        got = b""
        for _ in range(5):  # it reads again: all it was given is whole packets
            while select.select([parent], [], [], 0.2)[0]:
                got += os.read(parent, 65536)
            port.send(target)
        while select.select([parent], [], [], 0.2)[0]:
            got += os.read(parent, 65536)
        reader = mav.MAVLink(None)
        reader.robust_parsing = True
        kinds = [m.get_type() for m in reader.parse_buffer(got) or []]
        assert len(got) % len(target.get_msgbuf()) == 0 and "BAD_DATA" not in kinds, (len(got), kinds[-8:])
        assert port.stalled == 0
    finally:
        port.close()
        os.close(parent)
        os.close(child)


def test_a_serial_device_that_goes_away_and_comes_back_is_read_again(caplog: pytest.LogCaptureFixture) -> None:
    # a flight controller on USB that reboots: its /dev/ttyACM0 goes away and comes back as a
    # new device under the same name (a pseudo-terminal behind a link stands in for it); the
    # port was closed for good, and the companion heard nothing for the rest of the run
    import os
    import pty
    import tempfile
    import tty

    def device() -> tuple[int, int]:
        parent, child = pty.openpty()
        tty.setraw(child)
        return parent, child

    with tempfile.TemporaryDirectory() as folder:
        name = os.path.join(folder, "ttyACM0")
        parent, child = device()
        os.symlink(os.ttyname(child), name)
        port = MavPort.open(f"{name},115200", 255, 190)
        try:
            os.write(parent, _heartbeats(2))
            assert len(_read_all(port, 2)) == 2
            os.close(parent)  # the device goes away: a read fails
            os.close(child)
            deadline = time.monotonic() + 3.0
            while not port.closed and time.monotonic() < deadline:
                port.recv(0.05)
            assert port.closed and not port.connection.port.is_open  # let go at once: the name is freed
            os.remove(name)
            parent, child = device()  # back, a new device under the old name
            os.symlink(os.ttyname(child), name)
            got = []  # it beats on (what came before the port was opened again is flushed as it opens)
            deadline = time.monotonic() + 5.0
            while len(got) < 3 and time.monotonic() < deadline:
                os.write(parent, _heartbeats(1))
                got += [m for m in (port.recv(0.1),) if m is not None]
        finally:
            port.close()
            os.close(parent)
            with contextlib.suppress(OSError):
                os.close(child)
    assert [(m.get_type(), m.get_srcSystem()) for m in got] == [("HEARTBEAT", 1)] * 3
    said = [r.getMessage() for r in caplog.records]
    assert any("went away" in s for s in said) and any("is back: reading it again" in s for s in said)


def test_a_file_that_is_no_serial_port_is_the_connection_strings_error() -> None:
    # /dev/null exists, so it passed the device check, and pyserial's termios call failed:
    # "Inappropriate ioctl for device", exit 1, as if the link had failed
    with pytest.raises(ConfigError, match=r"'/dev/null,57600': /dev/null is not a serial port \(no terminal device"):
        MavPort.open("/dev/null,57600", 255, 190)


def test_a_serial_port_the_user_may_not_open_names_the_dialout_group() -> None:
    import serial

    from lfctl.errors import LinkError
    from lfctl.link.port import _open_error

    # pyserial's own words for EACCES (errno 13), as it raises them
    refused = serial.SerialException(13, "could not open port /dev/ttyUSB0: [Errno 13] Permission denied")
    err = _open_error("/dev/ttyUSB0,57600", refused)
    assert isinstance(err, LinkError) and "Permission denied" in str(err) and "dialout" in str(err)
    other = _open_error("/dev/ttyUSB0,57600", serial.SerialException(5, "could not open port: I/O error"))
    assert isinstance(other, LinkError) and "dialout" not in str(other)
