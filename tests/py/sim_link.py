#!/usr/bin/env python3
"""pymavlink against `mavterm sim` started with options (tests/sim_pymavlink.rs).

`sim_link.py MODE PORT`:
- `ftp_off` (server `ftp=0`, a firmware without MAVFTP): FILE_TRANSFER_PROTOCOL requests get
  no answer at all, while other requests do; AUTOPILOT_VERSION lacks
  MAV_PROTOCOL_CAPABILITY_FTP (32).
- `slow_list` (server `baud=57600`): the full PARAM_REQUEST_LIST download of 1,354 parameters
  takes at least the time ArduPilot's bandwidth share allows; prints the time it took.
Exits non-zero with a message on the first failed check; prints ALL OK at the end.
"""
import sys
import time

from pymavlink import mavutil

MODE = sys.argv[1]
PORT = int(sys.argv[2])
m = mavutil.mavlink_connection(f"tcp:127.0.0.1:{PORT}", source_system=255, source_component=190)
mav = mavutil.mavlink


def fail(msg):
    print(f"FAIL: {msg}", flush=True)
    sys.exit(1)


def ok(msg):
    print(f"ok: {msg}", flush=True)


if m.wait_heartbeat(timeout=5) is None:
    fail("no heartbeat")


def ftp(seq, opcode, data=b"", session=9):
    payload = bytearray(251)
    payload[0:2] = seq.to_bytes(2, "little")
    payload[2] = session
    payload[3] = opcode
    payload[4] = len(data)
    payload[12:12 + len(data)] = data
    m.mav.file_transfer_protocol_send(0, 1, 1, list(payload))


if MODE == "ftp_off":
    # OpenFileRO, ResetSessions, a retry, a ListDirectory: nothing comes back.
    ftp(0, 4, b"@PARAM/param.pck")
    ftp(2, 2)
    ftp(0, 4, b"@PARAM/param.pck")
    ftp(4, 3, b"/")
    deadline = time.time() + 3
    while time.time() < deadline:
        r = m.recv_match(type=["FILE_TRANSFER_PROTOCOL", "STATUSTEXT"], blocking=True,
                         timeout=deadline - time.time())
        if r is None:
            continue
        if r.get_type() == "FILE_TRANSFER_PROTOCOL" or "FTP" in r.text:
            fail(f"a build without MAVFTP answered: {r}")
    ok("no answer to FTP in 3 s")
    m.mav.command_long_send(1, 1, mav.MAV_CMD_REQUEST_MESSAGE, 0, 148, 0, 0, 0, 0, 0, 0)
    ack = m.recv_match(type="COMMAND_ACK", blocking=True, timeout=15)
    if ack is None or ack.command != mav.MAV_CMD_REQUEST_MESSAGE or ack.result != 0:
        fail(f"REQUEST_MESSAGE 148: {ack}")
    av = m.recv_match(type="AUTOPILOT_VERSION", blocking=True, timeout=15)
    if av is None:
        fail("no AUTOPILOT_VERSION")
    if av.capabilities & mav.MAV_PROTOCOL_CAPABILITY_FTP:
        fail(f"capabilities {av.capabilities} announce FTP")
    if not av.capabilities & mav.MAV_PROTOCOL_CAPABILITY_MAVLINK2:
        fail(f"capabilities {av.capabilities}")
    ok(f"AUTOPILOT_VERSION capabilities {av.capabilities} without FTP")
elif MODE == "slow_list":
    t0 = time.time()
    m.mav.param_request_list_send(1, 1)
    seen = set()
    count = None
    last = t0
    deadline = t0 + 150
    while time.time() < deadline and (count is None or len(seen) < count):
        p = m.recv_match(type="PARAM_VALUE", blocking=True, timeout=1)
        if p is None:
            continue
        if p.param_index == 65535:
            # A value the vehicle saved on its own (a calibration at boot), not the list.
            continue
        count = p.param_count
        seen.add(p.param_index)
        last = time.time()
    took = last - t0
    if count != 1354 or seen != set(range(1354)):
        fail(f"got {len(seen)} of {count} in {took:.1f} s")
    print(f"took {took:.2f}", flush=True)
    ok(f"1354 params in {took:.1f} s")
else:
    fail(f"unknown mode {MODE}")
print("ALL OK", flush=True)
