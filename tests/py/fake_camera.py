#!/usr/bin/env python3
"""A pymavlink stand-in camera (driven by tests/camera_interop.rs).

Over UDP to mavterm (`--port P`, mavterm listening there): an ArduCopter autopilot heartbeat
(1:1) and a MAVLink camera (1:100, MAV_TYPE_CAMERA) that answers the Camera Protocol v2 the way
a camera does: MAV_CMD_REQUEST_MESSAGE for CAMERA_INFORMATION (with a flag bit newer than most
dialects), CAMERA_SETTINGS, STORAGE_INFORMATION, CAMERA_CAPTURE_STATUS and CAMERA_IMAGE_CAPTURED
(param2 = index); MAV_CMD_IMAGE_START_CAPTURE takes one image and announces it. Every
COMMAND_LONG to the camera is written to --log-out (JSON: [command, p1..p7]) after each one.

  --sysid N        the system's id (default 1).
  --alone          no autopilot: the camera is a stand-alone payload on its own system.
  --legacy         a camera of the older protocol: REQUEST_MESSAGE for CAMERA_SETTINGS (260) and
                   STORAGE_INFORMATION (261) DENIED; MAV_CMD_REQUEST_CAMERA_SETTINGS (522,
                   param1 = 1) and MAV_CMD_REQUEST_STORAGE_INFORMATION (525, param2 = 1)
                   answered with the message.
  --first-index N  image indices start at N (the spec says 0); an index never taken is DENIED.
"""
import argparse
import json
import os
import time

os.environ.setdefault("MAVLINK20", "1")
from pymavlink import mavutil  # noqa: E402
from pymavlink.dialects.v20 import ardupilotmega as mav  # noqa: E402

ap = argparse.ArgumentParser()
ap.add_argument("--port", type=int, required=True)
ap.add_argument("--log-out", required=True)
ap.add_argument("--duration", type=float, default=30.0)
ap.add_argument("--sysid", type=int, default=1)
ap.add_argument("--alone", action="store_true")
ap.add_argument("--legacy", action="store_true")
ap.add_argument("--first-index", type=int, default=0)
args = ap.parse_args()

conn = mavutil.mavlink_connection(
    "udpout:127.0.0.1:%d" % args.port, source_system=args.sysid, source_component=100,
    dialect="ardupilotmega",
)
cam = conn.mav
autopilot = mav.MAVLink(conn, srcSystem=args.sysid, srcComponent=1)
FLAGS = 1 | 2 | 4 | (1 << 16)
images = []
log = []


def save():
    tmp = args.log_out + ".tmp"
    with open(tmp, "w") as f:
        json.dump(log, f)
    os.replace(tmp, args.log_out)


def boot_ms():
    return int((time.time() - start) * 1000)


def captured(i):
    cam.camera_image_captured_send(
        boot_ms(), 1_700_000_000_000_000 + i, 1, -353632621, 1491652374, 600000, 16000,
        [1.0, 0.0, 0.0, 0.0], i, 1, b"IMG_%04d.JPG" % i)


def answer(m):
    p = [m.param1, m.param2, m.param3, m.param4, m.param5, m.param6, m.param7]
    log.append([m.command] + p)
    save()
    ok = mav.MAV_RESULT_ACCEPTED
    then = None
    if m.command == mav.MAV_CMD_REQUEST_MESSAGE:
        want = int(p[0])
        if want == 259:
            vendor = list(b"Gremsy".ljust(32, b"\0"))
            model = list(b"ZIO2".ljust(32, b"\0"))
            then = lambda: cam.camera_information_send(
                boot_ms(), vendor, model, 0x01020304, 4.5, 6.17, 4.55, 1920, 1080, 2,
                FLAGS, 0, b"")
        elif want in (260, 261) and args.legacy:
            ok = mav.MAV_RESULT_DENIED
        elif want == 260:
            then = lambda: cam.camera_settings_send(boot_ms(), 0, 0.0, 0.0)
        elif want == 261:
            then = lambda: cam.storage_information_send(
                boot_ms(), 1, 1, 2, 60000.0, 100.0, 59900.0, 90.0, 60.0)
        elif want == 262:
            then = lambda: cam.camera_capture_status_send(
                boot_ms(), 0, 0, 0.0, 0, 59900.0, len(images))  # how many taken
        elif want == 263 and int(p[1]) in images:
            then = lambda: captured(int(p[1]))
        elif want == 263:
            ok = mav.MAV_RESULT_DENIED
        else:
            ok = mav.MAV_RESULT_UNSUPPORTED
    elif m.command == 522 and args.legacy and int(p[0]) == 1:
        then = lambda: cam.camera_settings_send(boot_ms(), 0, 0.0, 0.0)
    elif m.command == 525 and args.legacy and int(p[1]) == 1:
        then = lambda: cam.storage_information_send(
            boot_ms(), 1, 1, 2, 60000.0, 100.0, 59900.0, 90.0, 60.0)
    elif m.command == mav.MAV_CMD_IMAGE_START_CAPTURE:
        images.append(len(images) + args.first_index)
        then = lambda: captured(images[-1])
    else:
        ok = mav.MAV_RESULT_UNSUPPORTED
    cam.command_ack_send(m.command, ok, 0, 0, m.get_srcSystem(), m.get_srcComponent())
    if then:
        then()


start = time.time()
save()
print("listening", flush=True)
next_hb = 0.0
while time.time() - start < args.duration:
    now = time.time()
    if now >= next_hb:
        next_hb = now + 1.0
        if not args.alone:
            autopilot.heartbeat_send(mav.MAV_TYPE_QUADROTOR, mav.MAV_AUTOPILOT_ARDUPILOTMEGA, 0, 0, 3)
        cam.heartbeat_send(mav.MAV_TYPE_CAMERA, mav.MAV_AUTOPILOT_INVALID, 0, 0, 4)
    m = conn.recv_match(blocking=True, timeout=0.05)
    if m is None:
        continue
    if m.get_type() == "COMMAND_LONG" and m.target_system == args.sysid and m.target_component == 100:
        answer(m)
