"""The parameter protocol's server and MAVLink FTP worked by hand where no other test pinned
the answer (found by a mutation audit of param_server.py and ftp.py), and, marked xfail
(strict), the answers ArduPilot's source gives where lfctl's differ: each names the file and
function that shows it, and passes the day lfctl answers as ArduPilot does."""

from __future__ import annotations

import errno
import struct
from typing import Any

import pytest
from pymavlink.dialects.v20 import ardupilotmega as mav
from test_ftp import HEADER, Clock, parse, request

from lfctl.link import ftp
from lfctl.link import param_server as ps
from lfctl.link.param_server import ParamServer, pack_params, unpack_params
from lfctl.link.params import INT8, INT16, Param, default_params


class Served:
    """An FtpServer over ``files`` (default: one read-only file of 771 bytes and one
    writable), its replies and texts kept, on a clock the test moves."""

    def __init__(self, files: dict[str, ftp.FtpFile] | None = None) -> None:
        self.content = bytes(range(256)) * 3 + b"end"
        self.written: list[bytes] = []
        self.replies: list[bytes] = []
        self.texts: list[str] = []
        self.clock = Clock()
        if files is None:
            files = {
                "@SYS/data.bin": ftp.FtpFile(lambda q: self.content),
                "@SYS/in.bin": ftp.FtpFile(lambda q: b"", self.write),
            }
        self.server = ftp.FtpServer(files, lambda p, s, c: self.replies.append(p), self.texts.append, self.clock)

    def write(self, data: bytes, sysid: int, compid: int) -> str | None:
        self.written.append(data)
        return None

    def ask(self, payload: bytes, sysid: int = 255, compid: int = 190) -> list[tuple[tuple[int, ...], bytes]]:
        self.replies.clear()
        self.server.handle(payload, sysid, compid)
        return [parse(p) for p in self.replies]

    def tick(self, after_s: float) -> list[tuple[tuple[int, ...], bytes]]:
        """What the server sends at its tick ``after_s`` later (a burst going on)."""
        self.replies.clear()
        self.clock.t += after_s
        self.server.tick()
        return [parse(p) for p in self.replies]


def table() -> dict[str, Param]:
    return {
        "WP_SPEED": Param(2.5, 0.0, 100.0, "m/s", ""),
        "WP_RADIUS": Param(2.0, 0.0, 100.0, "m", ""),
        "CRUISE_THROTTLE": Param(50, 0, 100, "%", "", kind=INT8),
        "SYSID_THISMAV": Param(1, 1, 255, "", "", readonly=True, kind=INT16),
    }


class Said:
    """A ParamServer's sent messages and lines of text (with their severities)."""

    def __init__(self, params: dict[str, Param] | None = None, asker: Any = None) -> None:
        self.sent: list[Any] = []
        self.texts: list[tuple[str, int]] = []
        self.server = ParamServer(
            table() if params is None else params, self.sent.append, lambda t, s: self.texts.append((t, s)), asker
        )


def upload_file(params: dict[str, Param]) -> bytes:
    """``params`` as an upload of ``@PARAM/param.pck`` (the header's third number the length)."""
    data = bytearray(pack_params(params))
    struct.pack_into("<H", data, 4, len(data))
    return bytes(data)


# == what ArduPilot's source does (xfail, strict, where lfctl still answers otherwise) ==========


def test_a_set_naming_wp_speed_in_lower_case_sets_it_as_ap_param_find_finds_it() -> None:
    # AP_Param::find (libraries/AP_Param/AP_Param.cpp) matches a top-level group's prefix with
    # strncmp but a subgroup's prefix with strncasecmp and a member with strcasecmp: Rover's
    # WP_SPEED (ParametersG2, prefix '', subgroup 'WP_') is found as 'wp_speed'
    said = Said(default_params(1))
    said.server.set(mav.MAVLink_param_set_message(1, 1, b"wp_speed", 1.5, mav.MAV_PARAM_TYPE_REAL32))
    assert said.server.params["WP_SPEED"].value == 1.5


@pytest.mark.parametrize(
    ("asked", "found"),
    [
        ("wp_speed", "WP_SPEED"),  # ParametersG2 (group ''), its subgroup WP_: all in any case
        ("Wp_SpEeD", "WP_SPEED"),
        ("srtl_points", "SRTL_POINTS"),
        ("turn_radius", "TURN_RADIUS"),  # a member of ParametersG2
        ("rc_override_time", "RC_OVERRIDE_TIME"),  # ParametersG2's subgroup RC, RC_Channels' _OVERRIDE_TIME
        ("fence_enable", "FENCE_ENABLE"),  # AP_Vehicle (group ''), its subgroup FENCE_
        ("sysid_thismav", "SYSID_THISMAV"),  # a top-level scalar: strcasecmp over the whole name
        ("cruise_Throttle", "CRUISE_THROTTLE"),
        ("mis_done_behave", "MIS_DONE_BEHAVE"),  # ParametersG2's, not the top-level MIS_ group's
        ("SCHED_loop_rate", "SCHED_LOOP_RATE"),  # the top-level group SCHED_ in its case, the rest in any
        ("sched_loop_rate", None),  # strncmp: SCHED_ in another case is no group
        ("Sched_LOOP_RATE", None),
        ("ARMING_check", "ARMING_CHECK"),
        ("arming_CHECK", None),
        ("LFC_range", "LFC_RANGE"),  # lfctl's, as a script's table of prefix LFC_
        ("lfc_range", None),
        ("wp_speeds", None),  # the whole name, no more
        ("wp_spee", None),
        ("cruiſe_speed", None),  # strcasecmp folds ASCII only (Python's upper() makes this ſ an S)
    ],
)
def test_a_name_is_found_as_ap_param_find_finds_it(asked: str, found: str | None) -> None:
    assert Said(default_params(1)).server.name_of(asked.encode()) == found


def test_a_read_by_name_in_another_case_is_answered_in_the_case_asked() -> None:
    # GCS_MAVLINK::param_io_timer copies the request's param_name into the reply, then finds it
    said = Said()
    said.server.request_read(mav.MAVLink_param_request_read_message(1, 1, b"wp_Speed", -1))
    (m,) = said.sent
    assert (m.param_id, m.param_value, m.param_index, m.param_count) == ("wp_Speed", 2.5, 65535, 4)


def test_a_set_in_another_case_answers_the_name_and_a_read_only_one_the_name_asked() -> None:
    # handle_param_set: a value taken is saved and sent by its own name (save_sync's
    # copy_name_info); a read-only one is refused with the set's own key, in its text and its answer
    said = Said()
    assert said.server.set(mav.MAVLink_param_set_message(1, 1, b"wp_radius", 3.0, mav.MAV_PARAM_TYPE_REAL32)) == (
        "WP_RADIUS"
    )
    fixed = mav.MAVLink_param_set_message(1, 1, b"sysid_THISMAV", 7, mav.MAV_PARAM_TYPE_INT16)
    assert said.server.set(fixed) is None
    assert [(m.param_id, m.param_value) for m in said.sent] == [("WP_RADIUS", 3.0), ("sysid_THISMAV", 1.0)]
    assert said.texts == [("Param write denied (sysid_THISMAV)", mav.MAV_SEVERITY_WARNING)]
    assert said.server.params["WP_RADIUS"].value == 3.0 and said.server.params["SYSID_THISMAV"].value == 1


def test_an_upload_finds_its_names_as_ap_param_find_does() -> None:
    # param_upload_parse looks each name up with AP_Param::find
    said = Said(default_params(1))
    data = upload_file({"wp_radius": Param(3.0, 0, 100, "", ""), "arming_check": Param(0, 0, 1, "", "", kind=INT16)})
    assert said.server.upload(data) is None
    assert said.server.params["WP_RADIUS"].value == 3.0 and said.server.params["ARMING_CHECK"].value == 1
    assert said.texts == [("Param upload: 1 of 2 set; no such parameter arming_check", mav.MAV_SEVERITY_WARNING)]


def test_an_uploaded_name_is_read_to_its_first_nul_as_a_c_string() -> None:
    # param_upload_parse copies the name into a char array and AP_Param::find reads it as
    # a C string: 'WP_RADIUS\0xy' is WP_RADIUS (set), 'NOPE\0WP_SPEED' is NOPE (unknown, and
    # said without its NUL)
    said = Said(default_params(1))
    data = upload_file({"WP_RADIUS\0xy": Param(3.0, 0, 100, "", ""), "NOPE\0WP_SPEED": Param(0.5, 0, 100, "", "")})
    assert said.server.upload(data) is None
    assert said.server.params["WP_RADIUS"].value == 3.0 and said.server.params["WP_SPEED"].value != 0.5
    assert said.texts == [("Param upload: 1 of 2 set; no such parameter NOPE", mav.MAV_SEVERITY_WARNING)]


def test_a_read_with_index_minus_2_is_by_index_and_gets_no_answer() -> None:
    said = Said()
    said.server.request_read(mav.MAVLink_param_request_read_message(1, 1, b"WP_SPEED", -2))
    assert said.sent == []


def test_an_upload_damaged_partway_keeps_the_parameters_before_the_damage() -> None:
    said = Said()
    data = bytearray(upload_file({"WP_SPEED": Param(4.0, 0, 100, "", ""), "WP_RADIUS": Param(3.0, 0, 100, "", "")}))
    data[6 + 2 + 8 + 4] = 0x07  # the second parameter's type: 7, no such type
    assert said.server.upload(bytes(data)) is not None  # the file is refused (close: EINVAL) ...
    assert said.server.params["WP_SPEED"].value == 4.0  # ... after the first was set


@pytest.mark.parametrize("query", ["foo=1", "count=x"])
def test_param_pck_options_ardupilot_does_not_know_are_skipped(query: str) -> None:
    said = Said()
    assert said.server.packed(query) == said.server.packed("")


def test_param_pck_opened_with_start_past_the_end_opens_and_its_read_fails() -> None:
    # AP_Filesystem_Param::open takes start=N whatever N (below 65535); only the read fails
    # (AP_Filesystem_Param::read: total_params <= start is EINVAL), so GCS_FTP's OpenFileRO is ACKed
    said = Said()
    s = Served({"@PARAM/param.pck": said.server.ftp_file()})
    ((head, _),) = s.ask(request(0, ftp.OP_OPEN_RO, b"@PARAM/param.pck?start=4"))
    assert head[2] == ftp.ACK
    ((head, data),) = s.ask(request(1, ftp.OP_READ, size=239))
    assert (head[2], data) == (ftp.NAK, bytes([ftp.ERR_FAIL_ERRNO, errno.EINVAL]))


def test_param_pck_past_the_end_gives_its_stat_size_fails_from_the_header_and_ends_after_it() -> None:
    said = Said()  # four parameters
    s = Served({"@PARAM/param.pck": said.server.ftp_file()})
    # the open's size is GCS_FTP's stat of it: AP_Filesystem_Param::stat, 12 bytes a parameter, 4 x 12 = 48
    ((head, data),) = s.ask(request(0, ftp.OP_OPEN_RO, b"@PARAM/param.pck?start=9"))
    assert (head[2], data) == (ftp.ACK, struct.pack("<I", 48))
    assert s.texts == ["FTP: @PARAM/param.pck?start=9 cannot be read: param.pck start=9: there are 4 parameters"]
    # a read from inside the 6-byte header fails (EINVAL), as it is the header's read that fails ...
    ((head, data),) = s.ask(request(1, ftp.OP_READ, offset=5, size=10))
    assert (head[2], head[7], data) == (ftp.NAK, 0, bytes([ftp.ERR_FAIL_ERRNO, errno.EINVAL]))
    # ... one from byte 6 on finds no parameter past start: the end (EndOfFile)
    ((head, data),) = s.ask(request(2, ftp.OP_READ, offset=6, size=10))
    assert (head[2], data) == (ftp.NAK, bytes([ftp.ERR_END_OF_FILE]))
    # a burst from 0: its first read fails, one NAK marked complete at the burst's offset
    ((head, data),) = s.ask(request(3, ftp.OP_BURST))
    assert (head[2], head[5], head[7], data) == (ftp.NAK, 1, 0, bytes([ftp.ERR_FAIL_ERRNO, errno.EINVAL]))
    # start=3, the last of the four: a file of one parameter, read as ever
    ((head, _),) = s.ask(request(4, ftp.OP_OPEN_RO, b"@PARAM/param.pck?start=3", session=1))
    ((head, data),) = s.ask(request(5, ftp.OP_READ, session=1, size=239))
    assert data == said.server.packed("start=3") and data[:6] == b"\x1b\x67\x01\x00\x04\x00"


def test_a_size_shorter_than_the_name_is_invalid_data_size() -> None:
    s = Served()
    ((head, data),) = s.ask(request(0, ftp.OP_OPEN_RO, b"@SYS/data.binXYZ", size=len(b"@SYS/data.bin")))
    assert (head[2], data) == (ftp.NAK, bytes([ftp.ERR_INVALID_DATA_SIZE]))


def test_a_listing_never_fills_the_whole_data_field() -> None:
    # two files whose entries are 120 + 119 = 239 bytes: ArduPilot sends the first alone
    first, second = "a" * (120 - 4), "b" * (119 - 4)  # "F" + name + "\t0" + NUL
    s = Served({f"@X/{first}": ftp.FtpFile(lambda q: b""), f"@X/{second}": ftp.FtpFile(lambda q: b"")})
    ((_, data),) = s.ask(request(0, ftp.OP_LIST, b"@X"))
    assert data == f"F{first}\t0\0".encode()


def test_five_sessions_may_be_open_at_once_as_ardupilots_gcs_ftp_keeps() -> None:
    s = Served()
    replies = [s.ask(request(0, ftp.OP_OPEN_RO, b"@SYS/data.bin", session=k))[0] for k in range(6)]
    assert [h[2] for h, _ in replies] == [ftp.ACK] * 5 + [ftp.NAK]


def test_a_burst_of_a_100_reply_file_runs_to_its_end_in_one_request() -> None:
    # GCS_FTP::Session::handle_request, BurstReadFile: a burst runs to transfer_size replies
    # (2000; 500 in the single-session GCS_FTP) before it is marked burst_complete
    s = Served()
    s.content = bytes(239 * 100)
    s.ask(request(0, ftp.OP_OPEN_RO, b"@SYS/data.bin"))
    replies = s.ask(request(1, ftp.OP_BURST))
    assert [h[2] for h, _ in replies] == [ftp.ACK] * 100 + [ftp.NAK]
    assert [h[5] for h, _ in replies] == [0] * 100 + [1]  # only the end is marked complete


# == the packed parameter file ===================================================================


def test_an_upload_of_the_header_alone_sets_nothing_and_is_read() -> None:
    # six bytes, no parameter: the smallest file ArduPilot reads (length < sizeof(hdr) is refused)
    assert unpack_params(b"\x1b\x67\x00\x00\x06\x00") == []
    said = Said()
    assert said.server.upload(b"\x1b\x67\x00\x00\x06\x00") is None
    assert said.texts == [("Param upload: 0 of 0 set", mav.MAV_SEVERITY_INFO)]


@pytest.mark.parametrize(
    ("data", "words"),
    [
        # the header names one parameter, the file ends before its two bytes (or after one)
        (b"\x1b\x67\x01\x00\x06\x00", r"parameter 1 of 1 \(byte 6\): the file ends"),
        (b"\x1b\x67\x01\x00\x07\x00\x04", r"parameter 1 of 1 \(byte 6\): the file ends"),
        # a float named "A", two of its four bytes
        (b"\x1b\x67\x01\x00\x0b\x00\x04\x00A\x00\x00", r"parameter 1 of 1 \(byte 6\): the file ends"),
        (b"\x1b\x67\x01\x00\x0c\x00\x04\x00A\x00\x00\x00", r"parameter 1 of 1 \(byte 6\): the file ends"),  # one short
        # the name itself cut short
        (b"\x1b\x67\x01\x00\x0a\x00\x04\x70AB", r"parameter 1 of 1 \(byte 6\): the file ends"),
    ],
)
def test_an_upload_that_ends_inside_a_parameter_is_refused_not_raised(data: bytes, words: str) -> None:
    with pytest.raises(ValueError, match=words):
        unpack_params(data)
    said = Said()
    assert (said.server.upload(data) or "").startswith("param.pck not read: parameter 1 of 1")


@pytest.mark.parametrize(
    ("lens", "words"),
    [
        (0x73, r"a name of 3 \+ 8 bytes after ''"),  # shares 3 bytes with no name before it
        (0x0F, r"a name of 15 \+ 1 bytes after ''"),
    ],
)
def test_a_name_sharing_more_than_the_name_before_it_has_is_refused(lens: int, words: str) -> None:
    data = bytearray(b"\x1b\x67\x01\x00\x00\x00\x01" + bytes([lens]) + b"ABCDEFGH" + b"\x05")
    struct.pack_into("<H", data, 4, len(data))
    with pytest.raises(ValueError, match=words):
        unpack_params(bytes(data))


def test_a_name_past_16_bytes_is_refused_even_when_it_shares_no_more_than_it_may() -> None:
    # "ABCDEFGHIJ" then a name sharing all 10 of its bytes and adding 7: 17 bytes
    first = b"\x01\x90ABCDEFGHIJ\x05"
    second = b"\x01" + bytes([0x0A | (6 << 4)]) + b"KLMNOPQ" + b"\x06"
    data = bytearray(b"\x1b\x67\x02\x00\x00\x00" + first + second)
    struct.pack_into("<H", data, 4, len(data))
    with pytest.raises(ValueError, match=r"parameter 2 of 2 .*a name of 10 \+ 7 bytes after 'ABCDEFGHIJ'"):
        unpack_params(bytes(data))
    # the same sharing all ten and adding six: 16 bytes, taken
    second = b"\x01" + bytes([0x0A | (5 << 4)]) + b"KLMNOP" + b"\x06"
    data = bytearray(b"\x1b\x67\x02\x00\x00\x00" + first + second)
    struct.pack_into("<H", data, 4, len(data))
    assert unpack_params(bytes(data)) == [("ABCDEFGHIJ", 5.0), ("ABCDEFGHIJKLMNOP", 6.0)]


# == the parameter server =======================================================================


def test_set_returns_the_name_only_when_the_value_was_stored() -> None:
    said = Said()
    ok = mav.MAVLink_param_set_message(1, 1, b"WP_SPEED", 3.0, mav.MAV_PARAM_TYPE_REAL32)
    far = mav.MAVLink_param_set_message(1, 1, b"WP_SPEED", 300.0, mav.MAV_PARAM_TYPE_REAL32)
    fixed = mav.MAVLink_param_set_message(1, 1, b"SYSID_THISMAV", 3, mav.MAV_PARAM_TYPE_INT16)
    nope = mav.MAVLink_param_set_message(1, 1, b"NOPE", 3, mav.MAV_PARAM_TYPE_REAL32)
    assert said.server.set(ok) == "WP_SPEED"
    assert said.server.set(far) is None and said.server.set(fixed) is None and said.server.set(nope) is None
    # each set of a known parameter is answered with the value in force, index -1 (65535)
    assert [(m.param_id, m.param_value, m.param_index) for m in said.sent] == [
        ("WP_SPEED", 3.0, 65535),
        ("WP_SPEED", 3.0, 65535),
        ("SYSID_THISMAV", 1.0, 65535),
    ]


def test_lfctls_warnings_are_bounded_and_a_flood_of_them_forgets_the_old(monkeypatch: pytest.MonkeyPatch) -> None:
    # a peer making up names: 1,024 recent warnings are remembered; past that the memory of
    # them is cleared, so the first name asked again is said again although within REPEAT_S
    monkeypatch.setattr(ps.time, "monotonic", lambda: 50.0)
    said = Said()
    read = mav.MAVLink_param_request_read_message
    for k in range(1024):
        said.server.request_read(read(1, 1, f"NO_{k}".encode(), -1))
    said.server.request_read(read(1, 1, b"NO_0", -1))  # 1,024 remembered: not said again
    assert len(said.texts) == 1024
    said.server.request_read(read(1, 1, b"NO_1024", -1))  # the 1,025th: said, the memory cleared
    said.server.request_read(read(1, 1, b"NO_1024", -1))  # itself remembered
    assert len(said.texts) == 1025
    said.server.request_read(read(1, 1, b"NO_0", -1))  # forgotten in the flood: said again
    assert said.texts[-1] == ("Unknown parameter NO_0", mav.MAV_SEVERITY_WARNING) and len(said.texts) == 1026


def test_a_hundred_recent_warnings_are_all_remembered_and_old_ones_do_not_count(
    monkeypatch: pytest.MonkeyPatch,
) -> None:
    now = [50.0]
    monkeypatch.setattr(ps.time, "monotonic", lambda: now[0])
    said = Said()
    read = mav.MAVLink_param_request_read_message
    for k in range(100):
        said.server.request_read(read(1, 1, f"NO_{k}".encode(), -1))
    said.server.request_read(read(1, 1, b"NO_0", -1))  # 100 remembered: the first is not said again
    assert len(said.texts) == 100
    # 1,000 said long ago do not fill the memory: 30 new ones now are all remembered
    for k in range(100, 1000):
        said.server.request_read(read(1, 1, f"NO_{k}".encode(), -1))
    now[0] += 10.0
    for k in range(30):
        said.server.request_read(read(1, 1, f"NEW_{k}".encode(), -1))
    said.server.request_read(read(1, 1, b"NEW_0", -1))
    assert len(said.texts) == 1030


def test_a_warning_is_said_again_once_repeat_s_has_passed(monkeypatch: pytest.MonkeyPatch) -> None:
    now = [50.0]
    monkeypatch.setattr(ps.time, "monotonic", lambda: now[0])
    said = Said()
    nope = mav.MAVLink_param_request_read_message(1, 1, b"NOPE", -1)
    said.server.request_read(nope)
    now[0] = 50.0 + ps.REPEAT_S / 2
    said.server.request_read(nope)
    now[0] = 50.0 + ps.REPEAT_S  # REPEAT_S since it was said: said again
    said.server.request_read(nope)
    assert [t for t, _ in said.texts] == ["Unknown parameter NOPE"] * 2


def test_a_read_by_index_answers_from_the_first_to_the_last_and_names_one_past_it() -> None:
    said = Said()
    read = mav.MAVLink_param_request_read_message
    for index in (0, 3):
        said.server.request_read(read(1, 1, b"", index))
    assert [(m.param_id, m.param_index, m.param_count) for m in said.sent] == [
        ("WP_SPEED", 0, 4),
        ("SYSID_THISMAV", 3, 4),
    ]
    said.server.request_read(read(1, 1, b"", 4))
    assert len(said.sent) == 2 and said.texts == [("No parameter at index 4 (there are 4)", mav.MAV_SEVERITY_WARNING)]


def test_param_pck_without_options_is_the_whole_table_without_defaults() -> None:
    said = Said()
    params = said.server.params
    assert said.server.packed("") == pack_params(params)
    assert said.server.packed("withdefaults=1") == pack_params(params, said.server.defaults)
    assert said.server.packed("count=65534") == pack_params(params)  # ArduPilot's largest
    with pytest.raises(ValueError, match="out of range"):
        said.server.packed("count=65535")  # AP_Filesystem_Param::open: v >= UINT16_MAX fails
    with pytest.raises(ValueError, match="out of range"):
        said.server.packed("start=65535")


def test_a_name_that_is_the_start_of_the_one_before_tells_one_byte_again() -> None:
    # AP_Filesystem_Param::pack_param: no new byte left, common_len-- and one byte told
    params = {"LFC_RANGE2": Param(1.0, 0, 10, "", ""), "LFC_RANGE": Param(2, 0, 10, "", "", kind=INT8)}
    assert pack_params(params)[6 + 2 + 10 + 4 :] == b"\x01\x08E\x02"  # shares 8, one new byte: "E"
    # and two 16-byte names sharing 15: the most a name may share, one new byte
    params = {
        "ABCDEFGHIJKLMNOP": Param(1, 0, 10, "", "", kind=INT8),
        "ABCDEFGHIJKLMNOQ": Param(2, 0, 10, "", "", kind=INT8),
    }
    assert pack_params(params)[6 + 2 + 16 + 1 :] == b"\x01\x0fQ\x02"


def test_an_upload_is_said_as_info_when_all_was_set_and_as_a_warning_naming_what_was_not() -> None:
    said = Said()
    assert said.server.upload(upload_file({"WP_SPEED": Param(4.0, 0, 100, "", "")})) is None
    assert said.server.upload(upload_file({"NO_SUCH": Param(1.0, 0, 10, "", "")})) is None
    fixed = upload_file(
        {"SYSID_THISMAV": Param(7, 1, 255, "", "", kind=INT16), "WP_RADIUS": Param(3.0, 0, 100, "", "")}
    )
    assert said.server.upload(fixed) is None
    assert said.texts == [
        ("Param upload: 1 of 1 set", mav.MAV_SEVERITY_INFO),
        ("Param upload: 0 of 1 set; no such parameter NO_SUCH", mav.MAV_SEVERITY_WARNING),
        ("Param upload: 1 of 2 set; refused SYSID_THISMAV (read-only)", mav.MAV_SEVERITY_WARNING),
    ]
    assert (said.server.params["SYSID_THISMAV"].value, said.server.params["WP_RADIUS"].value) == (1, 3.0)


# == the FTP server: its numbers, by hand ========================================================


def test_five_sessions_at_once_and_a_sixth_sender_waits_three_seconds_for_an_idle_one() -> None:
    s = Served()
    for k in range(5):
        assert s.ask(request(0, ftp.OP_OPEN_RO, b"@SYS/data.bin", session=k))[0][0][2] == ftp.ACK
    s.clock.t = 102.5  # idle, not yet 3 s (FTP_SESSION_TIMEOUT 3000 ms)
    assert s.ask(request(0, ftp.OP_OPEN_RO, b"@SYS/data.bin", session=9))[0][1] == bytes([ftp.ERR_NO_SESSIONS])
    s.clock.t = 103.0  # 3 s: the oldest may be taken over (ArduPilot refuses below 3,000 ms only)
    assert s.ask(request(1, ftp.OP_OPEN_RO, b"@SYS/data.bin", session=9))[0][0][2] == ftp.ACK


def test_a_session_idle_past_twenty_seconds_is_closed() -> None:
    # GCS_FTP::worker: now - last_send_ms > FTP_SESSION_KILL_TIMEOUT (20,000 ms) closes it
    s = Served()
    s.ask(request(0, ftp.OP_OPEN_RO, b"@SYS/data.bin", session=1))
    s.clock.t += 20.0
    s.server.tick()
    assert s.ask(request(1, ftp.OP_READ, session=1, size=4))[0][0][2] == ftp.ACK  # 20 s: still open
    s.clock.t += 20.5
    s.server.tick()
    assert s.ask(request(2, ftp.OP_READ, session=1, size=4))[0][1] == bytes([ftp.ERR_FILE_NOT_FOUND])


def test_the_replies_of_the_last_32_askers_are_kept_for_a_request_sent_again() -> None:
    s = Served()
    old = ftp.ardupilot_crc32(s.content)

    def crc(sysid: int, seq: int = 5) -> int:
        return struct.unpack("<I", s.ask(request(seq, ftp.OP_CRC, b"@SYS/data.bin"), sysid=sysid)[0][1])[0]

    for sysid in range(1, 33):  # 32 askers
        crc(sysid)
    s.content = b"changed"
    assert crc(1) == old  # the first asker's reply is still kept: sent again, not answered anew
    crc(33)  # a 33rd: the oldest kept (the first asker's) is let go
    assert crc(1) == ftp.ardupilot_crc32(b"changed")  # (the second asker's let go in turn)
    # a new request makes its asker the newest kept: the next new asker lets the fourth go, not it
    assert crc(3, seq=6) == ftp.ardupilot_crc32(b"changed")
    crc(34)
    s.content = b"again"
    assert (crc(3, seq=6), crc(4)) == (ftp.ardupilot_crc32(b"changed"), ftp.ardupilot_crc32(b"again"))


def test_256_replies_at_once_then_400_a_second() -> None:
    s = Served()
    answered = sum(len(s.ask(request(k, ftp.OP_NONE))) for k in range(257))
    assert (answered, s.server.unanswered) == (256, 1)
    s.clock.t += 0.01  # 4 replies' worth
    answered = sum(len(s.ask(request(1000 + k, ftp.OP_NONE))) for k in range(5))
    assert (answered, s.server.unanswered) == (4, 2)
    # none left: one comes back after 1/400 s, not before
    s.clock.t += 0.002497
    assert s.ask(request(2000, ftp.OP_NONE)) == [] and s.server.unanswered == 3
    s.clock.t += 0.0001
    assert len(s.ask(request(2001, ftp.OP_NONE))) == 1


def test_the_codes_on_the_wire_are_mavlinks() -> None:
    # the numbers a ground station reads (MAV_FTP_ERR, MAV_FTP_OPCODE), not the module's names
    assert (ftp.ACK, ftp.NAK) == (mav.MAV_FTP_OPCODE_ACK, mav.MAV_FTP_OPCODE_NAK) == (128, 129)
    assert (
        [
            ftp.ERR_FAIL,
            ftp.ERR_FAIL_ERRNO,
            ftp.ERR_INVALID_DATA_SIZE,
            ftp.ERR_NO_SESSIONS,
            ftp.ERR_END_OF_FILE,
            ftp.ERR_UNKNOWN_COMMAND,
            ftp.ERR_FILE_NOT_FOUND,
        ]
        == [
            mav.MAV_FTP_ERR_FAIL,
            mav.MAV_FTP_ERR_FAILERRNO,
            mav.MAV_FTP_ERR_INVALIDDATASIZE,
            mav.MAV_FTP_ERR_NOSESSIONSAVAILABLE,
            mav.MAV_FTP_ERR_EOF,
            mav.MAV_FTP_ERR_UNKNOWNCOMMAND,
            mav.MAV_FTP_ERR_FILENOTFOUND,
        ]
        == [1, 2, 3, 5, 6, 7, 10]
    )
    s = Served()
    ((head, data),) = s.ask(request(0, ftp.OP_READ, size=4))  # no file open
    assert (head[2], data) == (129, b"\x0a")


def test_a_written_file_may_reach_128_kib_and_no_further() -> None:
    s = Served()
    s.ask(request(0, ftp.OP_CREATE, b"@SYS/in.bin"))
    assert s.ask(request(1, ftp.OP_WRITE, b"xy", offset=131070))[0][0][2] == ftp.ACK  # ends at 131,072
    too_far = s.ask(request(2, ftp.OP_WRITE, b"xy", offset=131071))[0]
    assert too_far[1] == bytes([ftp.ERR_FAIL_ERRNO, errno.ENOSPC])
    s.ask(request(3, ftp.OP_TERMINATE))
    assert len(s.written) == 1 and len(s.written[0]) == 131072


@pytest.mark.parametrize("opcode", [ftp.OP_LIST, ftp.OP_CRC, ftp.OP_OPEN_RO, ftp.OP_CREATE])
@pytest.mark.parametrize(
    ("data", "size"),
    [
        (b"", 0),  # no name (check_name_len: size 0 is false)
        (b"@SYS/data.bin", 16),  # the name and three NULs: neither its length nor one more
    ],
)
def test_a_name_whose_size_does_not_match_is_invalid_data_size(opcode: int, data: bytes, size: int) -> None:
    s = Served()
    ((head, answer),) = s.ask(request(0, opcode, data, size=size))
    assert (head[2], answer) == (ftp.NAK, bytes([ftp.ERR_INVALID_DATA_SIZE]))


def test_a_listing_gives_the_size_a_file_says_it_has() -> None:
    # FtpFile.size, where given, is what a listing shows (the file is not read for it)
    reads: list[str] = []

    def read(query: str) -> bytes:
        reads.append(query)
        return b"abc"

    s = Served({"@X/f.bin": ftp.FtpFile(read, size=lambda: 12), "@X/g.bin": ftp.FtpFile(read)})
    ((_, data),) = s.ask(request(0, ftp.OP_LIST, b"@X"))
    assert data == b"Ff.bin\t12\0Fg.bin\t3\0" and reads == [""]


def test_a_request_sent_again_spends_the_ration_as_a_new_one() -> None:
    s = Served()
    s.ask(request(0, ftp.OP_NONE))
    answered = sum(len(s.ask(request(0, ftp.OP_NONE))) for _ in range(256))  # its reply sent again
    assert (answered, s.server.unanswered) == (255, 1)


def test_a_payload_of_the_header_alone_is_a_request() -> None:
    s = Served()
    ((head, _),) = s.ask(HEADER.pack(4, 0, ftp.OP_NONE, 0, 0, 0, 0, 0))  # 12 bytes, no data
    assert head[:3] == (5, 0, ftp.ACK)
    assert s.ask(HEADER.pack(4, 0, ftp.OP_NONE, 0, 0, 0, 0, 0)[:11]) == []  # 11: no header, ignored


def test_a_listing_longer_than_the_data_field_goes_on_at_the_next_offset() -> None:
    first, second = "a" * (120 - 4), "b" * (120 - 4)  # two entries of 120 bytes: 240, one too many
    s = Served({f"@X/{first}": ftp.FtpFile(lambda q: b""), f"@X/{second}": ftp.FtpFile(lambda q: b"")})
    ((_, data),) = s.ask(request(0, ftp.OP_LIST, b"@X"))
    assert data == f"F{first}\t0\0".encode()
    ((head, data),) = s.ask(request(1, ftp.OP_LIST, b"@X", offset=1))
    assert (head[7], data) == (1, f"F{second}\t0\0".encode())


def test_the_oldest_idle_session_is_the_one_taken_over() -> None:
    s = Served()
    newest = ftp.MAX_SESSIONS - 1
    for k in range(ftp.MAX_SESSIONS):  # opened a second apart
        s.clock.t = 100.0 + k
        s.ask(request(0, ftp.OP_OPEN_RO, b"@SYS/data.bin", session=k))
    s.clock.t = 103.5 + newest  # every one idle 3 s or more
    assert s.ask(request(0, ftp.OP_OPEN_RO, b"@SYS/data.bin", session=9))[0][0][2] == ftp.ACK
    assert s.ask(request(1, ftp.OP_READ, session=0, size=4))[0][1] == bytes([ftp.ERR_FILE_NOT_FOUND])  # taken
    assert s.ask(request(1, ftp.OP_READ, session=newest, size=4))[0][0][2] == ftp.ACK  # the newest: still open
    # the oldest idle 3 s but the newest not: the oldest is taken over all the same
    s.clock.t = 105.0 + newest
    s.ask(request(2, ftp.OP_READ, session=newest, size=4))
    s.clock.t = 107.0 + newest  # sessions 1.. idle 8.5 s and more, 9 idle 3.5 s, the newest 2 s
    assert s.ask(request(0, ftp.OP_OPEN_RO, b"@SYS/data.bin", session=8))[0][0][2] == ftp.ACK


def test_a_file_open_on_a_session_is_reopened_only_after_more_than_three_idle_seconds() -> None:
    # GCS_FTP's OpenFileRO: fd != -1 && now - last_send_ms > FTP_SESSION_TIMEOUT closes it first
    s = Served()
    s.ask(request(0, ftp.OP_OPEN_RO, b"@SYS/data.bin"))
    s.clock.t = 103.0  # exactly 3 s: still the session's open file
    assert s.ask(request(1, ftp.OP_OPEN_RO, b"@SYS/data.bin"))[0][1] == bytes([ftp.ERR_FAIL])
    s.clock.t = 106.5
    assert s.ask(request(2, ftp.OP_OPEN_RO, b"@SYS/data.bin"))[0][0][2] == ftp.ACK


def test_a_request_sent_again_three_seconds_later_still_gets_its_reply() -> None:
    s = Served()
    first = s.ask(request(1, ftp.OP_CRC, b"@SYS/data.bin"))
    s.content = b"changed"
    s.clock.t = 103.0  # SESSION_TIMEOUT_S exactly: still the same request
    assert s.ask(request(1, ftp.OP_CRC, b"@SYS/data.bin")) == first


def test_reset_sessions_forgets_the_senders_kept_replies_and_no_others() -> None:
    s = Served()
    s.ask(request(5, ftp.OP_CRC, b"@SYS/data.bin", session=1))
    other = s.ask(request(5, ftp.OP_CRC, b"@SYS/data.bin"), sysid=254)
    s.content = b"changed"
    s.ask(request(0, ftp.OP_RESET))  # (on session 0: session 1's kept reply is the sender's too)
    # the same numbers after a reset are a new request; another sender's are still kept
    assert struct.unpack("<I", s.ask(request(5, ftp.OP_CRC, b"@SYS/data.bin", session=1))[0][1]) == (
        ftp.ardupilot_crc32(b"changed"),
    )
    assert s.ask(request(5, ftp.OP_CRC, b"@SYS/data.bin"), sysid=254) == other


def test_a_refusal_for_want_of_room_is_not_sent_again_once_there_is_room() -> None:
    s = Served()
    for k in range(ftp.MAX_SESSIONS):
        s.ask(request(0, ftp.OP_OPEN_RO, b"@SYS/data.bin", session=k))
    assert s.ask(request(7, ftp.OP_OPEN_RO, b"@SYS/data.bin", session=9))[0][1] == bytes([ftp.ERR_NO_SESSIONS])
    s.ask(request(1, ftp.OP_TERMINATE, session=0))  # room now, at once
    assert s.ask(request(7, ftp.OP_OPEN_RO, b"@SYS/data.bin", session=9))[0][0][2] == ftp.ACK


def test_replies_other_than_a_listings_and_a_bursts_carry_offset_0_no_burst_mark_and_a_zero_pad() -> None:
    # GCS_FTP::setup_reply zeroes the reply: only ReadFile, WriteFile, a listing and a burst set an offset
    s = Served()
    asked = [
        request(0, ftp.OP_NONE, offset=12),
        request(1, ftp.OP_OPEN_RO, b"@SYS/data.bin", offset=12),
        request(2, ftp.OP_CRC, b"@SYS/data.bin", offset=12),
        request(3, ftp.OP_TERMINATE, offset=12),
        request(4, ftp.OP_CREATE, b"@SYS/in.bin", session=1, offset=12),
        request(5, ftp.OP_RESET, offset=12),
    ]
    for payload in asked:
        ((head, _),) = s.ask(payload)
        assert head[2] == ftp.ACK and (head[5], head[6], head[7]) == (0, 0, 0)


def test_a_burst_with_one_reply_left_in_the_ration_sends_one_and_the_rest_as_it_refills() -> None:
    s = Served()
    s.ask(request(0, ftp.OP_OPEN_RO, b"@SYS/data.bin"))
    for k in range(254):  # 256 at once: the open and 254 more leave one
        s.ask(request(1 + k, ftp.OP_NONE))
    replies = s.ask(request(300, ftp.OP_BURST, size=100))
    assert [(h[2], h[5], h[7]) for h, _ in replies] == [(ftp.ACK, 0, 0)]  # one, not the end: not marked
    # 0.0201 s later, 400 a second: 8.04, 8 more, the parts at 100 ... 700 (the last 71 bytes) and the end
    rest = s.tick(0.0201)
    assert [(h[2], h[5], h[7], len(d)) for h, d in rest] == [(ftp.ACK, 0, o, 100) for o in range(100, 700, 100)] + [
        (ftp.ACK, 0, 700, 71),
        (ftp.NAK, 1, 771, 1),  # EndOfFile, marked complete, at the burst's offset then
    ]
    assert [h[0] for h, _ in rest] == list(range(302, 310))  # 300 + 1 + 1 ... 300 + 1 + 8


def test_a_burst_runs_to_2000_replies_at_the_rations_pace_the_2000th_alone_marked() -> None:
    # GCS_FTP's transfer_size: the 2,000th reply is marked burst_complete, though the file goes on
    s = Served()
    s.content = bytes(239 * 2001)
    s.ask(request(0, ftp.OP_OPEN_RO, b"@SYS/data.bin"))  # 256 - 1 = 255 left
    replies = s.ask(request(1, ftp.OP_BURST))
    assert len(replies) == 255
    # 2,000 - 255 = 1,745 more at 400 a second: 200 each 0.5 s, 8 x 200 then 145
    ticks = [s.tick(0.5) for _ in range(10)]
    assert [len(t) for t in ticks] == [200] * 8 + [145, 0]
    replies += [r for t in ticks for r in t]
    assert [h[0] for h, _ in replies] == list(range(2, 2002))  # 1 + 1 ... 1 + 2,000
    assert [h[7] for h, _ in replies] == [239 * k for k in range(2000)]
    assert all(h[2] == ftp.ACK for h, _ in replies) and [h[5] for h, _ in replies] == [0] * 1999 + [1]
    # asked again from the 2,000th part: the last one and the end
    rest = s.ask(request(2002, ftp.OP_BURST, offset=239 * 2000))
    assert [(h[2], h[5], len(d)) for h, d in rest] == [(ftp.ACK, 0, 239), (ftp.NAK, 1, 1)]


def test_a_session_sending_a_burst_is_not_idle_and_is_not_taken_over() -> None:
    # GCS_FTP's push_reply sets last_send_ms at each reply: a session bursting is in use
    s = Served()
    s.content = bytes(239 * 2000)
    for k in range(ftp.MAX_SESSIONS):
        s.ask(request(0, ftp.OP_OPEN_RO, b"@SYS/data.bin", session=k))  # 256 - 5 = 251 left
    assert len(s.ask(request(1, ftp.OP_BURST))) == 251  # session 0's last request: at 100 s
    s.clock.t = 103.4  # the ration full again (256): the other four read, 252 left ...
    for k in range(1, ftp.MAX_SESSIONS):
        assert s.ask(request(1, ftp.OP_READ, session=k, size=4))[0][0][2] == ftp.ACK
    assert len(s.tick(0.0)) == 252  # ... which the burst sends, at 103.4 s
    assert len(s.tick(0.1001)) == 40  # and 40 (of 40.04) more at 103.5001 s
    # 0.0026 s later (1.08 in the ration) a sixth asks: session 0 asked nothing for 3.5 s but sent
    # 0.0026 s ago, the others read 0.1027 s ago: none idle 3 s, no session for it
    s.clock.t += 0.0026
    assert s.ask(request(0, ftp.OP_OPEN_RO, b"@SYS/data.bin", session=9))[0][1] == bytes([ftp.ERR_NO_SESSIONS])


def test_a_request_during_a_burst_is_answered_at_once_and_the_burst_goes_on() -> None:
    s = Served()
    s.content = bytes(239 * 300)
    s.ask(request(0, ftp.OP_OPEN_RO, b"@SYS/data.bin"))
    s.ask(request(0, ftp.OP_OPEN_RO, b"@SYS/data.bin", session=1))
    assert len(s.ask(request(1, ftp.OP_BURST))) == 254  # 256 - 2 opens
    # 0.0101 s later: 4.04 in the ration; another session's read takes one at once ...
    s.clock.t += 0.0101
    ((head, data),) = s.ask(request(1, ftp.OP_READ, session=1, offset=239, size=4))
    assert (head[2], head[7], data) == (ftp.ACK, 239, bytes(4))
    # ... and the burst the other 3 (parts 254, 255, 256), 0.04 left
    assert [h[7] // 239 for h, _ in s.tick(0.0)] == [254, 255, 256]
    # 0.0101 s: 4.08; a read on the bursting session itself is answered at once too ...
    s.clock.t += 0.0101
    ((head, _),) = s.ask(request(5, ftp.OP_READ, offset=0, size=4))
    assert head[2] == ftp.ACK
    # ... and the burst goes on where it was: parts 257 ... 259, numbered 1 + 1 + 257 ...
    going = s.tick(0.0)
    assert [(h[0], h[7] // 239) for h, _ in going] == [(259, 257), (260, 258), (261, 259)]


def test_a_burst_ends_when_its_session_closes_and_a_new_one_replaces_it() -> None:
    s = Served()
    s.content = bytes(239 * 1000)
    s.ask(request(0, ftp.OP_OPEN_RO, b"@SYS/data.bin"))
    assert len(s.ask(request(1, ftp.OP_BURST))) == 255
    # a burst again on the session, from part 900, 0.0251 s later (10.04 in the ration): it
    # replaces the one under way, its parts 900 ... 909 numbered from its own request, 7
    s.clock.t += 0.0251
    again = s.ask(request(7, ftp.OP_BURST, offset=239 * 900))
    assert [(h[0], h[7] // 239) for h, _ in again] == [(8 + k, 900 + k) for k in range(10)]
    assert s.tick(0.0) == []  # (0.04 left)
    # TerminateSession ends it: the ration refills, nothing more is sent
    s.clock.t += 0.0101
    assert s.ask(request(20, ftp.OP_TERMINATE))[0][0][2] == ftp.ACK
    assert s.tick(1.0) == []
    # and ResetSessions the same
    s.ask(request(0, ftp.OP_OPEN_RO, b"@SYS/data.bin", session=3))
    assert len(s.ask(request(1, ftp.OP_BURST, session=3))) == ftp.REPLY_BURST - 1
    s.clock.t += 0.01
    s.ask(request(2, ftp.OP_RESET))
    assert s.tick(1.0) == []


def test_bursts_on_two_sessions_share_the_ration_one_reply_each_in_turn() -> None:
    s = Served()
    s.content = bytes(239 * 1000)
    s.ask(request(0, ftp.OP_OPEN_RO, b"@SYS/data.bin"))
    s.ask(request(0, ftp.OP_OPEN_RO, b"@SYS/data.bin", session=1))
    assert len(s.ask(request(1, ftp.OP_BURST))) == 254  # 256 - 2 opens: the ration spent
    s.clock.t += 0.0026  # 1.04 in the ration: the second burst's first part, 0.04 left
    assert [h[7] // 239 for h, _ in s.ask(request(1, ftp.OP_BURST, session=1, offset=239 * 500))] == [500]
    # 0.015 s: 6.04, 6 replies, three each, in turn
    going = s.tick(0.015)
    assert [(h[1], h[7] // 239) for h, _ in going] == [(0, 254), (1, 501), (0, 255), (1, 502), (0, 256), (1, 503)]


def test_bursts_on_three_sessions_each_get_a_reply_in_turn_however_little_the_ration_has() -> None:
    # Wrong, each tick would start again from the first session, and with one reply's worth
    # of ration a tick the third session's burst would get nothing for as long as the others
    # burst. By hand: 253 replies to the first burst (256 - 3 opens: the ration spent); 0.0026
    # s later 1.04 in the ration: the second burst's first reply (0.04 left), and again for
    # the third (0.08 left); then each 0.0025 s tick refills 1 (1.08): one reply a tick, to
    # sessions 0, 1, 2, 0, 1, 2 in turn
    s = Served()
    s.content = bytes(239 * 1000)
    for session in (0, 1, 2):
        s.ask(request(0, ftp.OP_OPEN_RO, b"@SYS/data.bin", session=session))
    assert len(s.ask(request(1, ftp.OP_BURST))) == 253
    s.clock.t += 0.0026
    assert len(s.ask(request(1, ftp.OP_BURST, session=1, offset=239 * 500))) == 1
    s.clock.t += 0.0026
    assert len(s.ask(request(1, ftp.OP_BURST, session=2, offset=239 * 800))) == 1
    served = [h[1] for _ in range(6) for h, _ in s.tick(0.0025)]
    assert served == [0, 1, 2, 0, 1, 2]


def test_a_burst_sent_again_starts_again_from_its_offset() -> None:
    # not its kept replies: GCS_FTP keeps only the last reply, numbered past a burst's request
    s = Served()
    s.ask(request(0, ftp.OP_OPEN_RO, b"@SYS/data.bin"))
    first = s.ask(request(1, ftp.OP_BURST, size=239))
    assert [h[7] for h, _ in first] == [0, 239, 478, 717, 771]  # 771 bytes: 3 x 239 + 54, then the end
    s.content = b"x" * 300  # (the file was read whole at the open: the same parts again)
    assert s.ask(request(1, ftp.OP_BURST, size=239)) == first


def test_writes_in_parts_make_the_file_of_their_bytes() -> None:
    s = Served()
    s.ask(request(0, ftp.OP_CREATE, b"@SYS/in.bin"))
    s.ask(request(1, ftp.OP_WRITE, b"abc", offset=0))
    s.ask(request(2, ftp.OP_WRITE, b"de", offset=3))
    s.ask(request(3, ftp.OP_WRITE, b"B", offset=1))  # written again over
    s.ask(request(4, ftp.OP_TERMINATE))
    assert s.written == [b"aBcde"]


def test_a_name_of_the_whole_239_bytes_is_a_name() -> None:
    s = Served()
    ((head, data),) = s.ask(request(0, ftp.OP_OPEN_RO, b"@SYS/" + b"x" * 234))
    assert (head[2], data) == (ftp.NAK, bytes([ftp.ERR_FILE_NOT_FOUND]))  # a name, of no file here


def test_a_file_that_cannot_be_read_whole_is_listed_at_size_0() -> None:
    def read(query: str) -> bytes:
        raise ValueError("no")

    s = Served({"@X/f.bin": ftp.FtpFile(read)})
    assert s.ask(request(0, ftp.OP_LIST, b"@X"))[0][1] == b"Ff.bin\t0\0"
