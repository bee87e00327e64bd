#!/usr/bin/env python3
"""A pymavlink GCS against `mavterm sim` (started by tests/sim_pymavlink.rs).

Checks, in one session to keep wall time small: heartbeat; full parameter download; PARAM_SET
answered as ArduPilot does (PARAM_VALUE with index -1 = 65535 and the stored value) and a read by
name answered with index -1 too; AUTOPILOT_VERSION (ACK first) with the real ArduCopter's
capabilities, FTP among them, and an FTP open answered; SET_MESSAGE_INTERVAL(GLOBAL_POSITION_INT,
200 ms) measured at 5 Hz +- 10 %; GUIDED, arm (retrying while pre-arm checks refuse), NAV_TAKEOFF
to 10 m reached in the expected time. Exits non-zero with a message on the first failed check.

Rates and the climb are measured on the vehicle's own clock, the time_boot_ms of the messages
(as a log review would), never on this process's: a busy machine delays what we read, not what
the vehicle stamped. Time limits here only bound a wait for something that never comes; they
are far beyond what any load makes of them.
"""
import sys
import time

from pymavlink import mavutil

PORT = int(sys.argv[1])
m = mavutil.mavlink_connection(f"tcp:127.0.0.1:{PORT}", source_system=255, source_component=190)
mav = mavutil.mavlink


def fail(msg):
    print(f"FAIL: {msg}", flush=True)
    sys.exit(1)


def ok(msg):
    print(f"ok: {msg}", flush=True)


def ack(command, timeout=15.0):
    deadline = time.time() + timeout
    while time.time() < deadline:
        a = m.recv_match(type="COMMAND_ACK", blocking=True, timeout=deadline - time.time())
        if a is not None and a.command == command:
            if (a.target_system, a.target_component) != (255, 190):
                fail(f"ACK of {command} addressed to {a.target_system}:{a.target_component}")
            return a.result
    fail(f"no COMMAND_ACK for command {command}")


def command(cmd, *params):
    p = list(params) + [0.0] * (7 - len(params))
    m.mav.command_long_send(1, 1, cmd, 0, *p)
    return ack(cmd)


hb = m.wait_heartbeat(timeout=30)
if hb is None:
    fail("no heartbeat")
if hb.type != mav.MAV_TYPE_QUADROTOR or hb.autopilot != mav.MAV_AUTOPILOT_ARDUPILOTMEGA:
    fail(f"heartbeat type {hb.type} autopilot {hb.autopilot}")
if m.target_system != 1:
    fail(f"heartbeat from sysid {m.target_system}")
ok("heartbeat")

# Parameters: PARAM_REQUEST_LIST until every index arrived.
m.mav.param_request_list_send(1, 1)
seen = {}
count = None
deadline = time.time() + 120
while time.time() < deadline and (count is None or len(seen) < count):
    p = m.recv_match(type="PARAM_VALUE", blocking=True, timeout=1)
    if p is None:
        continue
    if p.param_index == 65535:
        # A value the vehicle saved on its own (a calibration at boot), not the list.
        continue
    count = p.param_count
    seen[p.param_index] = p.param_id
if count is None or len(seen) != count:
    fail(f"param list: got {len(seen)} of {count}")
if count != 1354 or set(seen) != set(range(count)):
    fail(f"param indices not 0..{count}")
ok(f"{count} params")


def param_value(name, timeout=15.0):
    deadline = time.time() + timeout
    while time.time() < deadline:
        p = m.recv_match(type="PARAM_VALUE", blocking=True, timeout=deadline - time.time())
        if p is not None and p.param_id == name:
            return p
    return None


# PARAM_SET: ArduPilot saves the value and notifies with PARAM_VALUE, param_index -1 (65535).
m.mav.param_set_send(1, 1, b"WPNAV_SPEED", 750.0, mav.MAV_PARAM_TYPE_REAL32)
p = param_value("WPNAV_SPEED")
if p is None:
    fail("no PARAM_VALUE after PARAM_SET")
if (p.param_index, p.param_value, p.param_count) != (65535, 750.0, 1354):
    fail(f"PARAM_SET echo {p}")
# An integer parameter is stored as AP_Param::set_float does: 7.7 becomes 7.
m.mav.param_set_send(1, 1, b"DISARM_DELAY", 7.7, mav.MAV_PARAM_TYPE_REAL32)
p = param_value("DISARM_DELAY")
if p is None or (p.param_index, p.param_value, p.param_type) != (65535, 7.0, mav.MAV_PARAM_TYPE_INT8):
    fail(f"PARAM_SET DISARM_DELAY echo {p}")
# A read by name is answered with the index asked for: -1.
m.mav.param_request_read_send(1, 1, b"WPNAV_SPEED", -1)
p = param_value("WPNAV_SPEED")
if p is None or (p.param_index, p.param_value) != (65535, 750.0):
    fail(f"PARAM_REQUEST_READ by name: {p}")
ok("PARAM_SET echo with index 65535")

# AUTOPILOT_VERSION: COMMAND_ACK first, then the message.
m.mav.command_long_send(1, 1, mav.MAV_CMD_REQUEST_MESSAGE, 0, 148, 0, 0, 0, 0, 0, 0)
first = m.recv_match(type=["COMMAND_ACK", "AUTOPILOT_VERSION"], blocking=True, timeout=15)
if first is None or first.get_type() != "COMMAND_ACK" or first.result != mav.MAV_RESULT_ACCEPTED:
    fail(f"REQUEST_MESSAGE 148: {first}")
av = m.recv_match(type="AUTOPILOT_VERSION", blocking=True, timeout=15)
if av is None:
    fail("no AUTOPILOT_VERSION")
# The real ArduCopter 4.x announces exactly these bits (tests/data/copter-flight.vehicle.tlog).
if av.capabilities != 64495 or not av.capabilities & mav.MAV_PROTOCOL_CAPABILITY_FTP:
    fail(f"capabilities {av.capabilities}")
# 4.7.0 dev (FIRMWARE_VERSION_TYPE_DEV), as the captured ArduCopter V4.7.0-dev says.
if av.flight_sw_version != 0x04070000:
    fail(f"flight_sw_version {av.flight_sw_version:#x}")

# FTP is there: an open of the parameter file is acknowledged (then closed again).
def ftp(seq, opcode, data=b"", size=None, session=9):
    payload = bytearray(251)
    payload[0:2] = seq.to_bytes(2, "little")
    payload[2] = session
    payload[3] = opcode
    payload[4] = len(data) if size is None else size
    payload[12:12 + len(data)] = data
    m.mav.file_transfer_protocol_send(0, 1, 1, list(payload))


ftp(0, 4, b"@PARAM/param.pck")
r = m.recv_match(type="FILE_TRANSFER_PROTOCOL", blocking=True, timeout=15)
if r is None or r.payload[3] != 128 or r.payload[5] != 4:
    fail(f"FTP open: {r}")
ftp(2, 1)
r = m.recv_match(type="FILE_TRANSFER_PROTOCOL", blocking=True, timeout=15)
if r is None or r.payload[3] != 128 or r.payload[5] != 1:
    fail(f"FTP terminate: {r}")
ok("AUTOPILOT_VERSION and FTP")

# GLOBAL_POSITION_INT at 200 ms.
r = command(mav.MAV_CMD_SET_MESSAGE_INTERVAL, 33, 200000)
if r != mav.MAV_RESULT_ACCEPTED:
    fail(f"SET_MESSAGE_INTERVAL result {r}")
# 4 s of them on the vehicle's clock (20 at 5 Hz), counted from the first one at the new rate:
# the one after the ACK may still be of the old schedule.
m.recv_match(type="GLOBAL_POSITION_INT", blocking=True, timeout=15)
stamps = []
deadline = time.time() + 60
while time.time() < deadline and (len(stamps) < 2 or stamps[-1] - stamps[0] < 4000):
    g = m.recv_match(type="GLOBAL_POSITION_INT", blocking=True, timeout=1)
    if g is not None:
        stamps.append(g.time_boot_ms)
if len(stamps) < 2:
    fail(f"GLOBAL_POSITION_INT: {len(stamps)} in a minute")
if any(b <= a for a, b in zip(stamps, stamps[1:])):
    fail(f"GLOBAL_POSITION_INT time_boot_ms not increasing: {stamps}")
rate = (len(stamps) - 1) * 1000.0 / (stamps[-1] - stamps[0])
if not 4.5 <= rate <= 5.5:
    fail(f"GLOBAL_POSITION_INT at {rate:.2f} Hz of its time_boot_ms, expected 5 +- 10 %: {stamps}")
ok(f"GLOBAL_POSITION_INT {rate:.2f} Hz")

# GUIDED, arm (pre-arm refuses until the position estimate), takeoff to 10 m.
r = command(mav.MAV_CMD_DO_SET_MODE, mav.MAV_MODE_FLAG_CUSTOM_MODE_ENABLED, 4)
if r != mav.MAV_RESULT_ACCEPTED:
    fail(f"GUIDED result {r}")
deadline = time.time() + 60
while True:
    r = command(mav.MAV_CMD_COMPONENT_ARM_DISARM, 1)
    if r == mav.MAV_RESULT_ACCEPTED:
        break
    if r != mav.MAV_RESULT_FAILED or time.time() > deadline:
        fail(f"arm result {r}")
    time.sleep(0.5)
ok("armed")
r = command(mav.MAV_CMD_NAV_TAKEOFF, 0, 0, 0, 0, 0, 0, 10)
if r != mav.MAV_RESULT_ACCEPTED:
    fail(f"takeoff result {r}")
# The climb on the vehicle's clock (its time_boot_ms): the mean climb rate from its first report
# at 1 m to its first at 9 m, and the time from its first report off the ground to its first at
# 9.5 m; then a second more of its time to settle. (Our own latency in sending the takeoff is not
# the vehicle's, so the climb is timed from the vehicle's first report in the air.)
first_up = None  # (time_boot_ms, alt)
at_1 = None
at_9 = None
reached = None
alt = 0.0
deadline = time.time() + 120
while time.time() < deadline:
    g = m.recv_match(type="GLOBAL_POSITION_INT", blocking=True, timeout=1)
    if g is None:
        continue
    alt = g.relative_alt / 1000.0
    t = g.time_boot_ms
    if alt > 10.5:
        fail(f"overshoot to {alt} m")
    if first_up is None and alt > 0.05:
        first_up = (t, alt)
    if at_1 is None and alt >= 1.0:
        at_1 = (t, alt)
    if at_9 is None and alt >= 9.0:
        at_9 = (t, alt)
    if alt >= 9.5 and reached is None:
        reached = (t - first_up[0]) / 1000.0
        reached_at = t
    if reached is not None and t - reached_at > 1000:
        break
if reached is None or at_1 is None or at_9 is None:
    fail(f"only reached {alt} m")
rate = (at_9[1] - at_1[1]) * 1000.0 / (at_9[0] - at_1[0])
# The sim climbs at 1.5 m/s (10 m in 6.7 s).
if not 1.35 <= rate <= 1.65:
    fail(f"climbed at {rate:.2f} m/s of its time_boot_ms from 1 m to 9 m, expected 1.5")
if not first_up[1] < 1.0 or not 5.5 <= reached <= 7.5:
    fail(f"9.5 m {reached:.1f} s of its time after {first_up[1]} m, expected about 6.2 s")
if abs(alt - 10.0) > 0.5:
    fail(f"settled at {alt} m")
hb = m.recv_match(type="HEARTBEAT", blocking=True, timeout=15)
if hb is None or not hb.base_mode & mav.MAV_MODE_FLAG_SAFETY_ARMED or hb.custom_mode != 4:
    fail(f"heartbeat after takeoff: {hb}")
ok(f"takeoff: {rate:.2f} m/s, 9.5 m {reached:.1f} s after leaving the ground, at {alt:.2f} m")
print("ALL OK", flush=True)
