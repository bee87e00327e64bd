"""Write a telemetry log with pymavlink, as MAVProxy writes one, and count it with pymavlink.

Usage: write_tlog.py PATH SECONDS

A copter (1:1) for SECONDS seconds from T0 = 1_700_000_000 s: HEARTBEAT and SYS_STATUS at 1 Hz,
ATTITUDE at 10 Hz, GLOBAL_POSITION_INT at 4 Hz, and one STATUSTEXT "five seconds in" at T0 + 5 s
exactly. Each record is the time (µs since the Unix epoch, 8 bytes big-endian) then the frame,
packed by pymavlink's own encoder through `mavutil.mavlogfile(PATH, write=True)` (its
sequence numbers, its CRCs).

The log is then read back with `mavutil.mavlink_connection(PATH)` (pymavlink's tlog reader) and
printed as JSON: {"frames": N, "types": {NAME: count}, "first_us": t, "last_us": t,
"statustext_us": t}.
"""
import json
import os
import struct
import sys

os.environ["MAVLINK20"] = "1"
from pymavlink import mavutil  # noqa: E402

T0 = 1_700_000_000 * 1_000_000


def write(path, seconds):
    # mavlink_connection(path, write=True) takes a path that does not exist yet for a serial
    # port: the log writer it would return for an existing one, made directly.
    out = mavutil.mavlogfile(path, write=True, source_system=1, source_component=1)
    mav = out.mav

    def record(t_us, msg):
        out.write(struct.pack(">Q", t_us) + msg.pack(mav))
        # What mav.send() does after packing: the next frame gets the next sequence number.
        mav.seq = (mav.seq + 1) % 256

    # Every 25 ms tick, in time order; messages due at the same tick in a fixed order.
    for tick in range(seconds * 40):
        t = T0 + tick * 25_000
        ms = tick * 25
        if tick % 40 == 0:
            record(t, mav.heartbeat_encode(
                mavutil.mavlink.MAV_TYPE_QUADROTOR,
                mavutil.mavlink.MAV_AUTOPILOT_ARDUPILOTMEGA,
                mavutil.mavlink.MAV_MODE_FLAG_CUSTOM_MODE_ENABLED, 0,
                mavutil.mavlink.MAV_STATE_STANDBY))
            record(t, mav.sys_status_encode(0, 0, 0, 500, 12000, -1, 90, 0, 0, 0, 0, 0, 0))
        if tick % 4 == 0:
            record(t, mav.attitude_encode(ms, 0.01 * tick, 0.0, 0.5, 0.0, 0.0, 0.0))
        if tick % 10 == 0:
            record(t, mav.global_position_int_encode(
                ms, -353632620, 1491652300, 584000, 1000 + tick, 0, 0, 0, 9000))
        if tick == 200:  # T0 + 5 s
            record(t, mav.statustext_encode(
                mavutil.mavlink.MAV_SEVERITY_INFO, b"five seconds in"))
    out.close()


def count(path):
    log = mavutil.mavlink_connection(path)
    types = {}
    frames = 0
    first = last = statustext = None
    while True:
        m = log.recv_match()
        if m is None:
            break
        if m.get_type() == "BAD_DATA":
            raise SystemExit("pymavlink could not read its own log: %s" % m)
        frames += 1
        types[m.get_type()] = types.get(m.get_type(), 0) + 1
        t = int(round(m._timestamp * 1e6))
        first = t if first is None else first
        last = t
        if m.get_type() == "STATUSTEXT":
            statustext = t
    return {
        "frames": frames,
        "types": types,
        "first_us": first,
        "last_us": last,
        "statustext_us": statustext,
    }


if __name__ == "__main__":
    path, seconds = sys.argv[1], int(sys.argv[2])
    write(path, seconds)
    print(json.dumps(count(path)))
