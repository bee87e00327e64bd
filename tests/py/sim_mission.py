#!/usr/bin/env python3
"""A pymavlink GCS uploading and downloading missions with `mavterm sim` (tests/sim_pymavlink.rs).

The mission protocol as an independent implementation speaks it, over TCP in real time:
- a mission (home, takeoff, three waypoints, RTL) built with pymavlink's `mavwp.MAVWPLoader` is
  uploaded with MISSION_COUNT / MISSION_ITEM_INT; every request must be a MISSION_REQUEST (as
  ArduCopter asks), the ACK ACCEPTED; MISSION_REQUEST_LIST / MISSION_REQUEST_INT bring back the
  same items (item 0 reads as home, frames come back without _INT, as ArduCopter stores them);
- a 4-vertex inclusion fence and a rally point do the same round trip (mission_type 1 and 2);
- MISSION_CURRENT carries total and mission_state (MAVLink 2 extensions);
- an old-style MISSION_REQUEST is answered with a MISSION_ITEM whose lat/lon are degrees.
Exits non-zero with a message on the first failed check; prints ALL OK at the end.
"""
import os
import sys
import time

# Mission types other than the mission need MAVLink 2 (mission_type is an extension field).
os.environ["MAVLINK20"] = "1"
from pymavlink import mavutil, mavwp  # noqa: E402

PORT = int(sys.argv[1])
m = mavutil.mavlink_connection(f"tcp:127.0.0.1:{PORT}", source_system=255, source_component=190)
mav = mavutil.mavlink


def fail(msg):
    print(f"FAIL: {msg}", flush=True)
    sys.exit(1)


def ok(msg):
    print(f"ok: {msg}", flush=True)


REQ_TYPES = ["MISSION_REQUEST", "MISSION_REQUEST_INT", "MISSION_ACK"]


def upload(items, mission_type):
    """Send COUNT, answer each request, return the ACK result and the request types seen."""
    m.mav.mission_count_send(1, 1, len(items), mission_type)
    kinds = set()
    deadline = time.time() + 10
    while time.time() < deadline:
        r = m.recv_match(type=REQ_TYPES, blocking=True, timeout=deadline - time.time())
        if r is None:
            break
        if r.mission_type != mission_type:
            continue
        if r.get_type() == "MISSION_ACK":
            return r.type, kinds
        kinds.add(r.get_type())
        it = items[r.seq]
        m.mav.mission_item_int_send(
            1, 1, r.seq, it.frame, it.command, 0, it.autocontinue,
            it.param1, it.param2, it.param3, it.param4, it.x, it.y, it.z, mission_type)
    fail(f"upload of type {mission_type}: no MISSION_ACK")


def download(mission_type):
    m.mav.mission_request_list_send(1, 1, mission_type)
    c = m.recv_match(type="MISSION_COUNT", blocking=True, timeout=3)
    if c is None or c.mission_type != mission_type:
        fail(f"no MISSION_COUNT for type {mission_type}")
    got = []
    for seq in range(c.count):
        m.mav.mission_request_int_send(1, 1, seq, mission_type)
        it = m.recv_match(type="MISSION_ITEM_INT", blocking=True, timeout=3)
        if it is None or it.seq != seq or it.mission_type != mission_type:
            fail(f"type {mission_type}: no MISSION_ITEM_INT {seq} ({it})")
        if (it.target_system, it.target_component) != (255, 190):
            fail(f"item addressed to {it.target_system}:{it.target_component}")
        got.append(it)
    m.mav.mission_ack_send(1, 1, mav.MAV_MISSION_ACCEPTED, mission_type)
    return got


def item(seq, frame, command, params, lat, lon, alt, mission_type=0):
    return mav.MAVLink_mission_item_int_message(
        1, 1, seq, frame, command, 0, 1, *params, int(lat * 1e7), int(lon * 1e7), alt, mission_type)


hb = m.wait_heartbeat(timeout=5)
if hb is None:
    fail("no heartbeat")
ok("heartbeat")

# Home (a placeholder the vehicle replaces with its home), takeoff, three waypoints, RTL.
HOME = (-35.3632621, 149.1652374)
wp = mavwp.MAVWPLoader(target_system=1, target_component=1)
REL = mav.MAV_FRAME_GLOBAL_RELATIVE_ALT_INT
wp.add(item(0, mav.MAV_FRAME_GLOBAL_INT, mav.MAV_CMD_NAV_WAYPOINT, (0, 0, 0, 0), *HOME, 584))
wp.add(item(1, REL, mav.MAV_CMD_NAV_TAKEOFF, (0, 0, 0, 0), 0, 0, 15))
for i, (dn, de, alt) in enumerate([(0.0004, 0, 20), (0.0004, 0.0005, 25), (0, 0.0005, 20)]):
    wp.add(item(2 + i, REL, mav.MAV_CMD_NAV_WAYPOINT, (i, 0, 0, 0), HOME[0] + dn, HOME[1] + de, alt))
wp.add(item(5, mav.MAV_FRAME_GLOBAL, mav.MAV_CMD_NAV_RETURN_TO_LAUNCH, (0, 0, 0, 0), 0, 0, 0))
items = [wp.wp(i) for i in range(wp.count())]

result, kinds = upload(items, mav.MAV_MISSION_TYPE_MISSION)
if result != mav.MAV_MISSION_ACCEPTED:
    fail(f"mission upload ACK {result}")
if kinds != {"MISSION_REQUEST"}:
    fail(f"the vehicle asked with {kinds}, ArduCopter asks with MISSION_REQUEST")
ok("mission uploaded (asked with MISSION_REQUEST)")

back = download(mav.MAV_MISSION_TYPE_MISSION)
if len(back) != len(items):
    fail(f"downloaded {len(back)} items, uploaded {len(items)}")
if back[0].command != mav.MAV_CMD_NAV_WAYPOINT or back[0].frame != mav.MAV_FRAME_GLOBAL:
    fail(f"item 0 is not home: {back[0]}")
for up, down in zip(items[1:], back[1:]):
    want_frame = {mav.MAV_FRAME_GLOBAL_RELATIVE_ALT_INT: mav.MAV_FRAME_GLOBAL_RELATIVE_ALT,
                  mav.MAV_FRAME_GLOBAL_INT: mav.MAV_FRAME_GLOBAL}.get(up.frame, up.frame)
    if (down.command, down.x, down.y, down.z, down.param1, down.frame) != \
            (up.command, up.x, up.y, up.z, up.param1, want_frame):
        fail(f"item {up.seq}: sent {up} got {down}")
ok("mission downloaded equal")

# MISSION_CURRENT with the MAVLink 2 extensions: 5 items besides home, not started, not AUTO.
m.mav.command_long_send(1, 1, mav.MAV_CMD_SET_MESSAGE_INTERVAL, 0, 42, 200000, 0, 0, 0, 0, 0)
cur = m.recv_match(type="MISSION_CURRENT", blocking=True, timeout=3)
if cur is None or (cur.seq, cur.total, cur.mission_state, cur.mission_mode) != (0, 5, 2, 0):
    fail(f"MISSION_CURRENT {cur}")
ok("MISSION_CURRENT total 5, NOT_STARTED")

# Old-style request: MISSION_ITEM with degrees.
m.mav.mission_request_send(1, 1, 2, mav.MAV_MISSION_TYPE_MISSION)
old = m.recv_match(type="MISSION_ITEM", blocking=True, timeout=3)
if old is None or old.seq != 2 or abs(old.x - (HOME[0] + 0.0004)) > 1e-5:
    fail(f"MISSION_REQUEST answer {old}")
ok("MISSION_REQUEST answered with MISSION_ITEM")

fence = [item(i, mav.MAV_FRAME_GLOBAL, mav.MAV_CMD_NAV_FENCE_POLYGON_VERTEX_INCLUSION,
              (4, 0, 0, 0), lat, lon, 0, mav.MAV_MISSION_TYPE_FENCE)
         for i, (lat, lon) in enumerate([(-35.3650576, 149.1630269), (-35.3605660, 149.1630269),
                                         (-35.3605660, 149.1685346), (-35.3650576, 149.1685346)])]
result, _ = upload(fence, mav.MAV_MISSION_TYPE_FENCE)
if result != mav.MAV_MISSION_ACCEPTED:
    fail(f"fence upload ACK {result}")
back = download(mav.MAV_MISSION_TYPE_FENCE)
if [(b.command, b.param1, b.x, b.y) for b in back] != [(f.command, f.param1, f.x, f.y) for f in fence]:
    fail(f"fence back {back}")
ok("fence round trip")

rally = [item(0, REL, mav.MAV_CMD_NAV_RALLY_POINT, (0, 0, 0, 0), -35.3635304, 149.1654503, 15,
              mav.MAV_MISSION_TYPE_RALLY)]
result, _ = upload(rally, mav.MAV_MISSION_TYPE_RALLY)
if result != mav.MAV_MISSION_ACCEPTED:
    fail(f"rally upload ACK {result}")
back = download(mav.MAV_MISSION_TYPE_RALLY)
if len(back) != 1 or (back[0].x, back[0].y, back[0].z) != (rally[0].x, rally[0].y, 15):
    fail(f"rally back {back}")
ok("rally round trip")

print("ALL OK", flush=True)
