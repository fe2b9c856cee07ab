"""scan_tlog reads what pymavlink reads from a whole tlog, and goes on where pymavlink stops."""

import numpy as np
from pymavlink import mavutil
from pymavlink.dialects.v20 import common as mavlink2
from synthetic_run import TlogWriter, heartbeat, statustext, system_time

from harness.report.tlog_records import scan_tlog


def _tlog(path, seconds=60):
    log = TlogWriter(path)
    v1 = mavlink2.MAVLink(None, srcSystem=7, srcComponent=1)
    v1.mavlink20 = False  # a MAVLink 1 sender in the same file
    for s in range(seconds):
        log.add(float(s), heartbeat(s > 10, 4, 3), 1)
        log.add(s + 0.001, system_time(s + 0.001), 1)
        log.add(s + 0.5, statustext(6, f"tick {s}"), 1)
        log.records.append((s + 0.7, heartbeat(False, 0, 0).pack(v1)))
    return log.close()


def _key(stamp, msg):
    return (round(stamp, 6), msg.get_type(), msg.get_srcSystem(), str(msg.to_dict()))


def _everything(msgid, sysid, compid):
    return True


def test_a_whole_tlog_reads_as_pymavlink_reads_it(tmp_path):
    path = tmp_path / "a.tlog"
    data = _tlog(path)
    scan = scan_tlog(data, _everything)
    assert scan.cut_at is None and not scan.skipped and scan.bad_checksums == 0
    assert scan.frames == 4 * 60
    conn = mavutil.mavlink_connection(str(path))
    theirs = []
    while (m := conn.recv_match()) is not None:
        theirs.append(_key(m._timestamp, m))
    conn.close()
    assert [_key(s, m) for s, m in scan.records] == theirs
    assert {m.get_srcSystem() for _, m in scan.records} == {1, 7}  # MAVLink 1 and 2


def test_keep_decides_from_the_header(tmp_path):
    data = _tlog(tmp_path / "a.tlog")
    scan = scan_tlog(data, lambda msgid, sysid, compid: msgid == 253 and sysid == 1)
    assert [m.text for _, m in scan.records] == [f"tick {s}" for s in range(60)]
    assert scan.frames == 240


def test_every_cut_reads_the_records_before_it(tmp_path):
    data = _tlog(tmp_path / "a.tlog", seconds=3)
    whole = [_key(s, m) for s, m in scan_tlog(data, _everything).records]
    for cut in range(len(data)):
        scan = scan_tlog(data[:cut], _everything)
        got = [_key(s, m) for s, m in scan.records]
        assert got == whole[: len(got)]
        assert (scan.cut_at is not None) == (cut not in _record_ends(data)), cut


def _record_ends(data):
    ends, ofs = {0}, 0
    for _ in range(12):
        ofs += 8 + (12 + data[ofs + 9] if data[ofs + 8] == 0xFD else 8 + data[ofs + 9])
        ends.add(ofs)
    return ends


def test_random_damage_never_raises_and_never_invents_records(tmp_path):
    data = _tlog(tmp_path / "a.tlog", seconds=20)
    # Stamps have no checksum (a flipped stamp byte moves a record in time): compare contents.
    whole = {_key(0.0, m) for _, m in scan_tlog(data, _everything).records}
    rng = np.random.default_rng(5)
    for _ in range(200):
        cut = int(rng.integers(0, len(data) + 1))
        at = int(rng.integers(0, cut + 1))
        junk = rng.integers(0, 256, int(rng.integers(1, 60)), dtype=np.uint8).tobytes()
        damaged = bytearray(data[:at] + junk + data[at:cut])
        if rng.random() < 0.5 and len(damaged) > 10:  # and flip a byte somewhere
            damaged[int(rng.integers(0, len(damaged)))] ^= 0x5A
        scan = scan_tlog(bytes(damaged), _everything)
        assert {_key(0.0, m) for _, m in scan.records} <= whole
    # Damage in the middle loses only what it touched.
    scan = scan_tlog(data[:500] + b"\xfd\x30garbage" * 5 + data[500:], _everything)
    assert scan.skipped and len(scan.records) >= len(whole) - 1
