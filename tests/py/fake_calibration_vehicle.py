#!/usr/bin/env python3
"""A pymavlink stand-in ArduCopter for calibrations (driven by tests/calibration.rs).

Over UDP to mavterm (`--port P`, mavterm listening there), as 1:1 (ArduCopter quadrotor,
disarmed), it plays ArduPilot's own sequences (GCS_Common.cpp, AP_AccelCal.cpp,
AP_Compass_Calibration.cpp): the ACK as the handler returns, its texts after it.

- PREFLIGHT_CALIBRATION param5 = 1: ACCEPTED; then, per position, COMMAND_LONG
  MAV_CMD_ACCELCAL_VEHICLE_POS (param1 = position, to 0:0) every second, and `Place vehicle ...
  and press any key.` once until the GCS first answers with ACCELCAL_VEHICLE_POS
  (AP_AccelCal::gcs_vehicle_position clears _use_gcs_snoop); the GCS's ACCELCAL_VEHICLE_POS
  with the position asked: ACCEPTED (sampled 0.3 s later, then the next position), any other:
  FAILED. After the sixth: `Calibration successful` and ACCELCAL_VEHICLE_POS_SUCCESS
  (16777215) every second.
- DO_START_MAG_CAL: ACCEPTED; MAG_CAL_PROGRESS of compass 0 (4 Hz) to 100 % in 3 s; then
  MAG_CAL_REPORT (2 Hz) until DO_ACCEPT_MAG_CAL (ACCEPTED if successful, else FAILED) or
  DO_CANCEL_MAG_CAL (ACCEPTED; the calibration stops, nothing more is sent of it).
- PREFLIGHT_REBOOT_SHUTDOWN param1 = 1: ACCEPTED, then silent for 1.5 s, then up again with its
  boot time from 0 (SYSTEM_TIME, sent every second, goes back) and its calibrations forgotten.

Every COMMAND_LONG received is written to --log-out (JSON: [command, p1..p7, confirmation]).

  --lose-start-ack   the ACK of a calibration's start never leaves (a lost "started").
  --refuse-mag       DO_START_MAG_CAL: FAILED, then `Compass cal requires GPS lock`.
  --mag-bad-radius   the compass ends in MAG_CAL_FAILED_RADIUS (7), fitness 45.2.
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
ap.add_argument("--lose-start-ack", action="store_true")
ap.add_argument("--refuse-mag", action="store_true")
ap.add_argument("--mag-bad-radius", action="store_true")
args = ap.parse_args()

conn = mavutil.mavlink_connection(
    "udpout:127.0.0.1:%d" % args.port, source_system=1, source_component=1,
    dialect="ardupilotmega",
)
m = conn.mav
log = []
start = time.time()
POS_SUCCESS = 16777215
WORDS = {1: "level", 2: "on its LEFT side", 3: "on its RIGHT side", 4: "nose DOWN",
         5: "nose UP", 6: "on its BACK"}
accel = None  # {"step": n, "sampling_until": t or None, "last_req": t}
accel_done = None  # time of the last SUCCESS report
mag = None  # {"start": t, "accepted": bool}
later = []  # (time, fn): texts queued by a handler, sent after its ACK
boot = start  # SYSTEM_TIME's time_boot_ms counts from here
down_until = 0.0  # rebooting: nothing is sent before then


def save():
    tmp = args.log_out + ".tmp"
    with open(tmp, "w") as f:
        json.dump(log, f)
    os.replace(tmp, args.log_out)


def text(sev, s):
    later.append((time.time() + 0.02, lambda: m.statustext_send(sev, s.encode())))


def ack(cmd, result, to):
    m.command_ack_send(cmd, result, 0, 0, to[0], to[1])


def position(p):
    m.command_long_send(0, 0, mav.MAV_CMD_ACCELCAL_VEHICLE_POS, 0, float(p), 0, 0, 0, 0, 0, 0)


def handle(msg):
    global accel, accel_done, mag, boot, down_until
    p = [msg.param1, msg.param2, msg.param3, msg.param4, msg.param5, msg.param6, msg.param7]
    log.append([msg.command] + p + [msg.confirmation])
    save()
    to = (msg.get_srcSystem(), msg.get_srcComponent())
    c = msg.command
    if c == mav.MAV_CMD_PREFLIGHT_CALIBRATION and p[4] == 1:
        if not args.lose_start_ack:
            ack(c, mav.MAV_RESULT_ACCEPTED, to)
        if accel is None:
            accel = {"step": 0, "sampling_until": None, "last_req": 0.0, "snoop": True}
    elif c == mav.MAV_CMD_ACCELCAL_VEHICLE_POS:
        ok = (accel is not None and accel["sampling_until"] is None
              and accel["step"] >= 1 and int(p[0]) == accel["step"])
        ack(c, mav.MAV_RESULT_ACCEPTED if ok else mav.MAV_RESULT_FAILED, to)
        if accel is not None:
            accel["snoop"] = False  # answered by command: no more texts asking
        if ok:
            accel["sampling_until"] = time.time() + 0.3
    elif c == mav.MAV_CMD_DO_START_MAG_CAL:
        if args.refuse_mag:
            ack(c, mav.MAV_RESULT_FAILED, to)
            text(mav.MAV_SEVERITY_ERROR, "Compass cal requires GPS lock")
            return
        if not args.lose_start_ack:
            ack(c, mav.MAV_RESULT_ACCEPTED, to)
        mag = {"start": time.time(), "accepted": False}
    elif c == mav.MAV_CMD_DO_ACCEPT_MAG_CAL:
        good = mag is not None and not args.mag_bad_radius
        ack(c, mav.MAV_RESULT_ACCEPTED if good else mav.MAV_RESULT_FAILED, to)
        if mag is not None:
            mag["accepted"] = True
    elif c == mav.MAV_CMD_DO_CANCEL_MAG_CAL:
        ack(c, mav.MAV_RESULT_ACCEPTED, to)
        mag = None
    elif c == mav.MAV_CMD_PREFLIGHT_REBOOT_SHUTDOWN and p[0] == 1:
        ack(c, mav.MAV_RESULT_ACCEPTED, to)
        # The ACK leaves, then the board resets: silent a moment, then up from boot time 0.
        down_until = time.time() + 1.5
        boot = down_until
        accel = None
        accel_done = None
        mag = None
    else:
        ack(c, mav.MAV_RESULT_ACCEPTED, to)


def tick(now):
    global accel, accel_done
    if accel is not None:
        if accel["sampling_until"] is not None and now >= accel["sampling_until"]:
            accel["sampling_until"] = None
            if accel["step"] == 6:
                accel = None
                m.statustext_send(mav.MAV_SEVERITY_CRITICAL, b"Calibration successful")
                accel_done = now
                position(POS_SUCCESS)
                return
            accel["step"] += 1
            if accel["snoop"]:
                m.statustext_send(
                    mav.MAV_SEVERITY_CRITICAL,
                    ("Place vehicle %s and press any key." % WORDS[accel["step"]]).encode())
        if accel["step"] == 0:
            accel["step"] = 1
            m.statustext_send(mav.MAV_SEVERITY_CRITICAL, b"Place vehicle level and press any key.")
        if accel["sampling_until"] is None and now - accel["last_req"] > 1.0:
            accel["last_req"] = now
            position(accel["step"])
    elif accel_done is not None and now - accel_done > 1.0:
        accel_done = now
        position(POS_SUCCESS)


print("listening", flush=True)
last_hb = 0.0
last_mag = 0.0
while time.time() - start < args.duration:
    now = time.time()
    if now < down_until:
        # Rebooting: deaf and dumb.
        conn.recv_match(blocking=True, timeout=0.02)
        continue
    if now - last_hb >= 1.0:
        last_hb = now
        m.heartbeat_send(mav.MAV_TYPE_QUADROTOR, mav.MAV_AUTOPILOT_ARDUPILOTMEGA,
                         mav.MAV_MODE_FLAG_CUSTOM_MODE_ENABLED, 0, mav.MAV_STATE_STANDBY)
        m.system_time_send(int(now * 1e6), int((now - boot) * 1000) & 0xFFFFFFFF)
    for (t, fn) in [x for x in later if x[0] <= now]:
        fn()
    later = [x for x in later if x[0] > now]
    tick(now)
    if mag is not None and not mag["accepted"] and now - last_mag >= 0.25:
        last_mag = now
        pct = min(100, int((now - mag["start"]) / 3.0 * 100))
        if pct < 100:
            m.mag_cal_progress_send(0, 1, mav.MAG_CAL_RUNNING_STEP_TWO if pct > 33
                                    else mav.MAG_CAL_RUNNING_STEP_ONE, 1, pct,
                                    [0] * 10, 0, 0, 0)
        else:
            status = mav.MAG_CAL_FAILED_RADIUS if args.mag_bad_radius else mav.MAG_CAL_SUCCESS
            fitness = 45.2 if args.mag_bad_radius else 4.1
            m.mag_cal_report_send(0, 1, status, 0, fitness, 30.0, -20.0, 55.0,
                                  1.0, 1.0, 1.0, 0.0, 0.0, 0.0, 0.9, 0, 0, 1.0)
    msg = conn.recv_match(blocking=True, timeout=0.02)
    if msg is None or msg.get_srcSystem() == 1:
        continue
    if msg.get_type() == "COMMAND_LONG" and msg.target_system == 1:
        handle(msg)
