"""Read a telemetry log with pymavlink, as MAVExplorer and mavlogdump do.

Usage: read_tlog.py FILE -> one JSON object per message, in file order:
{"t_us": pymavlink's _timestamp in µs (rounded), "type": name, "sysid", "compid", "seq",
 "hex": the frame's bytes (get_msgbuf)}. BAD_DATA shows as such (a log pymavlink cannot read).
"""
import json
import os
import sys

os.environ.setdefault("MAVLINK20", "1")
from pymavlink import mavutil  # noqa: E402

log = mavutil.mavlink_connection(sys.argv[1], dialect="ardupilotmega")
while True:
    m = log.recv_msg()
    if m is None:
        break
    out = {"t_us": round(m._timestamp * 1e6), "type": m.get_type()}
    if m.get_type() != "BAD_DATA":
        out.update(
            sysid=m.get_srcSystem(),
            compid=m.get_srcComponent(),
            seq=m.get_seq(),
            hex=bytes(m.get_msgbuf()).hex(),
        )
    print(json.dumps(out))
