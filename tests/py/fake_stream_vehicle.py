#!/usr/bin/env python3
"""A pymavlink stand-in vehicle for telemetry stream requests (driven by tests/streams_interop.rs).

One vehicle (1:1) listening on one or more TCP ports, each its own MAVLink channel with its own
stream rates, as ArduPilot keeps them per serial port. It sends heartbeats as ArduPilot or PX4,
takes REQUEST_DATA_STREAM and MAV_CMD_SET_MESSAGE_INTERVAL the way the options say, and then
really sends what it was asked, at the interval asked, on the port it was asked on:

  --port P (repeatable)       listen on each (one client each).
  --autopilot ardupilot|px4   the HEARTBEAT's autopilot.
  --groups honour|ignore      REQUEST_DATA_STREAM: set the group's messages to its rate, or
                              ignore it (a port with NOSTREAMOVERRIDE; PX4 always ignores it).
  --intervals honour|deny|silent
                              SET_MESSAGE_INTERVAL: ACCEPTED and sent at the interval; DENIED;
                              never answered.
  --ack-delay S               answer SET_MESSAGE_INTERVAL S seconds late.
  --reboot-at T               at T seconds: reboot. Boot time starts again (SYSTEM_TIME goes
                              back); the stream rates of the groups stay (as ArduPilot's saved
                              SRn_ rates do), intervals set by SET_MESSAGE_INTERVAL are lost.
  --fade-at T --fade-for D    at T seconds, send nothing at all for D seconds, then carry on.

Written to --log-out (JSON) every half second and when it ends: per port, every message id
received, the stream requests received with their time ([t, "group", id, hz] and [t, "interval",
msgid, hz]), and how many SET_MESSAGE_INTERVALs came while another still waited for its answer
("overlaps"), and the wall-clock times (time.time()) of its sends of each message in the last 12 s
("sent": {msgid: [t, ...]}), for the test to know what rate really came. When a file
LOG-OUT.flush appears (the test writes it once mavterm has exited), what
mavterm sent is read to the end of the sockets and the log written with "flushed" set to that
file's text: the test waits for that, not for a time.
"""
import argparse
import collections
import json
import os
import time

from pymavlink import mavutil

mav = mavutil.mavlink

ap = argparse.ArgumentParser()
ap.add_argument("--port", type=int, action="append", required=True)
ap.add_argument("--autopilot", default="ardupilot")
ap.add_argument("--groups", default="honour")
ap.add_argument("--intervals", default="honour")
ap.add_argument("--ack-delay", type=float, default=0.0)
ap.add_argument("--reboot-at", type=float, default=-1.0)
ap.add_argument("--fade-at", type=float, default=-1.0)
ap.add_argument("--fade-for", type=float, default=0.0)
ap.add_argument("--log-out", required=True)
ap.add_argument("--duration", type=float, default=60.0)
args = ap.parse_args()

PX4 = args.autopilot == "px4"

# ArduCopter's groups, by the messages this stand-in can send (GCS_Mavlink.cpp STREAM_*_msgs).
GROUPS = {
    1: [27, 29],  # RAW_SENSORS: RAW_IMU, SCALED_PRESSURE
    2: [1, 24, 42, 62],  # EXTENDED_STATUS: SYS_STATUS, GPS_RAW_INT, MISSION_CURRENT, NAV_CONTROLLER_OUTPUT
    3: [36, 65],  # RC_CHANNELS: SERVO_OUTPUT_RAW, RC_CHANNELS
    6: [33, 32],  # POSITION: GLOBAL_POSITION_INT, LOCAL_POSITION_NED
    10: [30],  # EXTRA1: ATTITUDE
    11: [74],  # EXTRA2: VFR_HUD
    12: [2, 147, 193],  # EXTRA3: SYSTEM_TIME, BATTERY_STATUS, EKF_STATUS_REPORT
}
SENDABLE = {m for ms in GROUPS.values() for m in ms}

start = time.time()
boot = start


def boot_ms():
    return int((time.time() - boot) * 1000) & 0xFFFFFFFF


def send(m, msgid):
    """Send message `msgid` on connection `m`."""
    t = boot_ms()
    s = m.mav
    if msgid == 1:
        s.sys_status_send(0, 0, 0, 150, 12000, 500, 80, 0, 0, 0, 0, 0, 0)
    elif msgid == 2:
        s.system_time_send(0, t)
    elif msgid == 24:
        s.gps_raw_int_send(t * 1000, 3, 0, 0, 0, 100, 100, 0, 0, 10)
    elif msgid == 27:
        s.raw_imu_send(t * 1000, 0, 0, -1000, 0, 0, 0, 200, 50, -400)
    elif msgid == 29:
        s.scaled_pressure_send(t, 1013.0, 0.0, 2500)
    elif msgid == 30:
        s.attitude_send(t, 0.0, 0.0, 0.0, 0.0, 0.0, 0.0)
    elif msgid == 32:
        s.local_position_ned_send(t, 0, 0, 0, 0, 0, 0)
    elif msgid == 33:
        s.global_position_int_send(t, 0, 0, 0, 0, 0, 0, 0, 0)
    elif msgid == 36:
        s.servo_output_raw_send(t * 1000, 0, *([1000] * 8))
    elif msgid == 42:
        s.mission_current_send(0)
    elif msgid == 62:
        s.nav_controller_output_send(0, 0, 0, 0, 0, 0, 0, 0)
    elif msgid == 65:
        s.rc_channels_send(t, 8, *([1500] * 18), 255)
    elif msgid == 74:
        s.vfr_hud_send(0, 0, 0, 0, 0, 0)
    elif msgid == 147:
        s.battery_status_send(0, 0, 0, 2500, [12000] + [65535] * 9, 500, 100, 100, 80)
    elif msgid == 193:
        s.ekf_status_report_send(0x1FF, 0.1, 0.1, 0.1, 0.1, 0.1)


class Port:
    def __init__(self, port):
        self.port = port
        self.m = mavutil.mavlink_connection(
            f"tcpin:127.0.0.1:{port}", source_system=1, source_component=1
        )
        self.group_rates = {}  # group -> Hz (saved, as SRn_)
        self.intervals = {}  # msgid -> seconds (SET_MESSAGE_INTERVAL)
        self.next = {}  # msgid -> next send time
        self.received = set()
        self.requests = []
        self.overlaps = 0
        self.acks = []  # (due, result)
        self.sent = {}  # msgid -> deque of send times (time.time())

    def interval(self, msgid):
        if msgid in self.intervals:
            return self.intervals[msgid]
        for g, ms in GROUPS.items():
            hz = self.group_rates.get(g, 0)
            if msgid in ms and hz > 0:
                return 1.0 / hz
        return None


ports = [Port(p) for p in args.port]
print("listening", flush=True)


flushed = None  # the last flush asked and done


def log():
    out = {
        str(p.port): {
            "received": sorted(p.received),
            "requests": p.requests,
            "overlaps": p.overlaps,
            "sent": {str(m): list(ts) for m, ts in p.sent.items()},
        }
        for p in ports
    }
    out["flushed"] = flushed
    tmp = args.log_out + ".tmp"
    with open(tmp, "w") as f:
        json.dump(out, f)
    os.replace(tmp, args.log_out)


def heartbeat(p):
    autopilot = mav.MAV_AUTOPILOT_PX4 if PX4 else mav.MAV_AUTOPILOT_ARDUPILOTMEGA
    p.m.mav.heartbeat_send(mav.MAV_TYPE_QUADROTOR, autopilot, 81, 0, mav.MAV_STATE_STANDBY)


def handle(p, msg, now):
    kind = msg.get_type()
    if kind == "BAD_DATA":
        return
    p.received.add(msg.get_msgId())
    t = round(now - start, 3)
    if kind == "REQUEST_DATA_STREAM" and msg.target_system == 1:
        p.requests.append([t, "group", msg.req_stream_id, msg.req_message_rate])
        if PX4 or args.groups == "ignore":
            return
        hz = msg.req_message_rate if msg.start_stop == 1 else 0
        groups = list(GROUPS) if msg.req_stream_id == 0 else [msg.req_stream_id]
        for g in groups:
            p.group_rates[g] = hz
            # GCS_MAVLINK::initialise_message_intervals_for_stream: the group's rate replaces
            # any interval set for its messages.
            for m in GROUPS.get(g, []):
                p.intervals.pop(m, None)
                p.next[m] = now
    elif kind == "COMMAND_LONG" and msg.target_system == 1:
        if msg.command != mav.MAV_CMD_SET_MESSAGE_INTERVAL:
            return  # REQUEST_MESSAGE and the like: no answer, nothing to log
        msgid = int(msg.param1)
        interval_us = msg.param2
        hz = 1e6 / interval_us if interval_us > 0 else 0
        p.requests.append([t, "interval", msgid, round(hz, 3)])
        if p.acks:
            p.overlaps += 1
        if args.intervals == "silent":
            return
        result = mav.MAV_RESULT_ACCEPTED
        if args.intervals == "deny" or msgid not in SENDABLE:
            result = mav.MAV_RESULT_DENIED
        p.acks.append((now + args.ack_delay, result))
        if result == mav.MAV_RESULT_ACCEPTED:
            if interval_us > 0:
                p.intervals[msgid] = interval_us / 1e6
                p.next[msgid] = now
            elif interval_us < 0:
                p.intervals[msgid] = 1e9


def drain(p):
    """Handle what one more read of port `p` holds; False once nothing is left."""
    if p.m.port is None:
        return False
    try:
        data = p.m.port.recv(65536)
    except (BlockingIOError, InterruptedError):
        return False
    except OSError:
        return False
    if not data:
        return False
    for msg in p.m.mav.parse_buffer(data) or []:
        handle(p, msg, time.time())
    return True


end = start + args.duration
next_hb = 0.0
rebooted = False
last_log = 0.0
while time.time() < end:
    now = time.time()
    el = now - start
    if args.reboot_at >= 0 and not rebooted and el >= args.reboot_at:
        rebooted = True
        boot = now
        for p in ports:
            p.intervals.clear()
            for m in SENDABLE:
                p.next[m] = now
    fading = args.fade_at >= 0 and args.fade_at <= el < args.fade_at + args.fade_for
    for p in ports:
        while True:
            msg = p.m.recv_match(blocking=False)
            if msg is None:
                break
            handle(p, msg, now)
        if fading:
            continue
        for due, result in [a for a in p.acks if a[0] <= now]:
            p.m.mav.command_ack_send(mav.MAV_CMD_SET_MESSAGE_INTERVAL, result)
        p.acks = [a for a in p.acks if a[0] > now]
        for msgid in sorted(SENDABLE):
            iv = p.interval(msgid)
            if iv is None or iv >= 1e8:
                continue
            nxt = p.next.get(msgid, now)
            if nxt <= now:
                send(p.m, msgid)
                ts = p.sent.setdefault(msgid, collections.deque())
                ts.append(time.time())
                while ts and ts[0] < ts[-1] - 12.0:
                    ts.popleft()
                # Keep the schedule (no drift), but never burst after a stall.
                nxt += iv
                p.next[msgid] = nxt if nxt > now else now + iv
    if now >= next_hb:
        if not fading:
            for p in ports:
                heartbeat(p)
        next_hb = now + 1.0
    if now - last_log >= 0.5:
        log()
        last_log = now
    flush = args.log_out + ".flush"
    if os.path.exists(flush):
        with open(flush) as f:
            token = f.read().strip()
        os.remove(flush)
        flushed = token
        # mavterm has exited: all it sent is in our sockets. Read it all, then tell.
        for p in ports:
            while True:
                msg = p.m.recv_match(blocking=False)
                if msg is not None:
                    handle(p, msg, time.time())
                elif not drain(p):
                    break
        log()
    time.sleep(0.002)
log()
