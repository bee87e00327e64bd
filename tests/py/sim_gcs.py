#!/usr/bin/env python3
"""A pymavlink GCS against `mavterm sim` (started by tests/sim_pymavlink.rs).

Checks, in one session to keep wall time small: heartbeat; full parameter download;
SET_MESSAGE_INTERVAL(GLOBAL_POSITION_INT, 200 ms) measured at 5 Hz +- 10 %; GUIDED, arm
(retrying while pre-arm checks refuse), NAV_TAKEOFF to 10 m reached in the expected time.
Exits non-zero with a message on the first failed check.
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


def ack(command, timeout=3.0):
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


hb = m.wait_heartbeat(timeout=5)
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
deadline = time.time() + 20
while time.time() < deadline and (count is None or len(seen) < count):
    p = m.recv_match(type="PARAM_VALUE", blocking=True, timeout=1)
    if p is None:
        continue
    count = p.param_count
    seen[p.param_index] = p.param_id
if count is None or len(seen) != count:
    fail(f"param list: got {len(seen)} of {count}")
if count != 1354 or set(seen) != set(range(count)):
    fail(f"param indices not 0..{count}")
ok(f"{count} params")

# GLOBAL_POSITION_INT at 200 ms.
r = command(mav.MAV_CMD_SET_MESSAGE_INTERVAL, 33, 200000)
if r != mav.MAV_RESULT_ACCEPTED:
    fail(f"SET_MESSAGE_INTERVAL result {r}")
m.recv_match(type="GLOBAL_POSITION_INT", blocking=True, timeout=2)
t0 = time.time()
n = 0
while time.time() - t0 < 4.0:
    if m.recv_match(type="GLOBAL_POSITION_INT", blocking=True, timeout=0.5) is not None:
        n += 1
rate = n / (time.time() - t0)
if not 4.5 <= rate <= 5.5:
    fail(f"GLOBAL_POSITION_INT at {rate:.2f} Hz, expected 5 +- 10 %")
ok(f"GLOBAL_POSITION_INT {rate:.2f} Hz")

# GUIDED, arm (pre-arm refuses until the position estimate), takeoff to 10 m.
r = command(mav.MAV_CMD_DO_SET_MODE, mav.MAV_MODE_FLAG_CUSTOM_MODE_ENABLED, 4)
if r != mav.MAV_RESULT_ACCEPTED:
    fail(f"GUIDED result {r}")
deadline = time.time() + 15
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
t0 = time.time()
reached = None
alt = 0.0
while time.time() - t0 < 12:
    g = m.recv_match(type="GLOBAL_POSITION_INT", blocking=True, timeout=1)
    if g is None:
        continue
    alt = g.relative_alt / 1000.0
    if alt > 10.5:
        fail(f"overshoot to {alt} m")
    if alt >= 9.5 and reached is None:
        reached = time.time() - t0
    if reached is not None and time.time() - t0 > reached + 1.0:
        break
if reached is None:
    fail(f"only reached {alt} m")
# 10 m at 1.5 m/s is 6.7 s.
if not 5.5 <= reached <= 8.5:
    fail(f"reached 9.5 m after {reached:.1f} s, expected about 6.3 s")
if abs(alt - 10.0) > 0.5:
    fail(f"settled at {alt} m")
hb = m.recv_match(type="HEARTBEAT", blocking=True, timeout=2)
if hb is None or not hb.base_mode & mav.MAV_MODE_FLAG_SAFETY_ARMED or hb.custom_mode != 4:
    fail(f"heartbeat after takeoff: {hb}")
ok(f"takeoff: 9.5 m after {reached:.1f} s, at {alt:.2f} m")
print("ALL OK", flush=True)
