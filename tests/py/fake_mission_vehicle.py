#!/usr/bin/env python3
"""A pymavlink stand-in vehicle for the mission protocol (driven by tests/mission_profiles.rs).

It listens on TCP and serves the vehicle side of the MAVLink mission protocol
(https://mavlink.io/en/services/mission.html) for the mission list (mission_type 0):
MISSION_COUNT is answered with MISSION_REQUEST_INT for each item, then MISSION_ACK ACCEPTED;
MISSION_REQUEST_LIST with MISSION_COUNT and each requested item as MISSION_ITEM_INT.

  --autopilot ardupilot|generic
        ArduPilot reserves seq 0 for home: a fresh vehicle holds its home as item 0, and an upload
        is stored as sent (item 0 taken as home). A generic vehicle (HEARTBEAT autopilot GENERIC,
        as the protocol says) has no home item: every item is a mission item, seq from 0.
  --current-total N
        MISSION_CURRENT's `total` (0 = "not supported" in the spec), sent each second with seq 1.

Every upload received (a list of [seq, command, frame, current, x, y, z]) is written to --log-out,
and the seq of every MISSION_SET_CURRENT (or DO_SET_MISSION_CURRENT, param1) to --current-log.
"""
import argparse
import json
import os
import time

os.environ["MAVLINK20"] = "1"
from pymavlink import mavutil  # noqa: E402

mav = mavutil.mavlink

ap = argparse.ArgumentParser()
ap.add_argument("--port", type=int, required=True)
ap.add_argument("--autopilot", default="generic")
ap.add_argument("--current-total", type=int, default=-1)
ap.add_argument("--log-out", required=True)
ap.add_argument("--current-log", default="")
ap.add_argument("--duration", type=float, default=30.0)
args = ap.parse_args()

ARDUPILOT = args.autopilot == "ardupilot"
HOME = (-353632621, 1491652374, 584.0)


def item(seq, command, frame, x, y, z, current=0):
    return dict(seq=seq, command=command, frame=frame, current=current, x=x, y=y, z=z)


# A vehicle that already holds a mission: ArduPilot's home first.
if ARDUPILOT:
    stored = [item(0, 16, 0, *HOME)]
else:
    stored = []
stored += [
    item(len(stored), 16, 3, -353630821, 1491652374, 10.0),
    item(len(stored) + 1, 16, 3, -353630821, 1491654574, 12.0),
]
uploads = []
currents = []


def save(path, obj):
    tmp = path + ".tmp"
    with open(tmp, "w") as f:
        json.dump(obj, f)
    os.replace(tmp, path)


m = mavutil.mavlink_connection(f"tcpin:127.0.0.1:{args.port}", source_system=1, source_component=1)
print("listening", flush=True)

receiving = None  # (count, items so far)
end = time.time() + args.duration
next_hb = 0.0
while time.time() < end:
    now = time.time()
    if now >= next_hb:
        autopilot = mav.MAV_AUTOPILOT_ARDUPILOTMEGA if ARDUPILOT else mav.MAV_AUTOPILOT_GENERIC
        m.mav.heartbeat_send(mav.MAV_TYPE_QUADROTOR, autopilot, 81, 0, mav.MAV_STATE_STANDBY)
        if args.current_total >= 0:
            m.mav.mission_current_send(1, args.current_total, 2, 0)
        next_hb = now + 1.0
    msg = m.recv_match(blocking=True, timeout=0.05)
    if msg is None:
        continue
    kind = msg.get_type()
    if getattr(msg, "mission_type", 0) != 0:
        continue
    if kind == "MISSION_COUNT":
        receiving = (msg.count, [])
        if msg.count:
            m.mav.mission_request_int_send(255, msg.get_srcComponent(), 0, 0)
    elif kind in ("MISSION_ITEM_INT", "MISSION_ITEM") and receiving is not None:
        count, got = receiving
        if msg.seq != len(got):
            continue
        x, y = (msg.x, msg.y) if kind == "MISSION_ITEM_INT" else (int(msg.x * 1e7), int(msg.y * 1e7))
        got.append(item(msg.seq, msg.command, msg.frame, x, y, msg.z, msg.current))
        if len(got) < count:
            m.mav.mission_request_int_send(255, msg.get_srcComponent(), len(got), 0)
        else:
            stored = got
            uploads.append([[i["seq"], i["command"], i["frame"], i["current"], i["x"], i["y"], i["z"]] for i in got])
            tmp = args.log_out + ".tmp"
            with open(tmp, "w") as f:
                json.dump(uploads, f)
            os.replace(tmp, args.log_out)
            m.mav.mission_ack_send(255, msg.get_srcComponent(), mav.MAV_MISSION_ACCEPTED, 0)
            receiving = None
    elif kind == "MISSION_SET_CURRENT" or (kind == "COMMAND_LONG" and msg.command == 224) or (
        kind == "COMMAND_INT" and msg.command == 224
    ):
        seq = msg.seq if kind == "MISSION_SET_CURRENT" else int(msg.param1)
        currents.append(seq)
        if args.current_log:
            save(args.current_log, currents)
        if kind != "MISSION_SET_CURRENT":
            m.mav.command_ack_send(224, mav.MAV_RESULT_ACCEPTED)
        m.mav.mission_current_send(seq, max(args.current_total, 0), 2, 0)
    elif kind == "MISSION_REQUEST_LIST":
        m.mav.mission_count_send(255, msg.get_srcComponent(), len(stored), 0)
    elif kind in ("MISSION_REQUEST_INT", "MISSION_REQUEST"):
        if msg.seq < len(stored):
            i = stored[msg.seq]
            m.mav.mission_item_int_send(
                255, msg.get_srcComponent(), i["seq"], i["frame"], i["command"], i["current"], 1,
                0, 0, 0, 0, i["x"], i["y"], i["z"], 0
            )
