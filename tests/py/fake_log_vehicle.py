#!/usr/bin/env python3
"""A pymavlink stand-in vehicle serving one onboard log (driven by tests/logs.rs).

It listens on TCP, sends ArduPilot heartbeats, and answers the log protocol as ArduPilot's
AP_Logger_MAVLinkLogTransfer.cpp does: LOG_REQUEST_LIST with LOG_ENTRY (ids 1..n, num_logs,
last_log_num = the last id listed), LOG_REQUEST_DATA with 90-byte LOG_DATA from ofs until
count bytes (a short chunk at the end of the log), a request that comes while one is being
answered dropped, LOG_REQUEST_END ending it.

  --size N          bytes of the log (random, seeded); written to --served-out.
  --loss F          drop that fraction of the LOG_DATA sent (seeded).
  --outage-at B     once B bytes were sent, send nothing (not even heartbeats) for 3 s: the
                    link drops.
  --duration S      run at most S seconds; ends 1 s after LOG_REQUEST_END once the log was
                    served whole.

Every request is checked (target system and component, log id, offset and count within the
log, nothing asked after the log was whole and END came); what it saw is written to
--check-out as JSON: {"requests": [[id, ofs, count], ...], "ends": N, "errors": [...]}.
"""
import argparse
import json
import random
import time

from pymavlink import mavutil

mav = mavutil.mavlink

ap = argparse.ArgumentParser()
ap.add_argument("--port", type=int, required=True)
ap.add_argument("--size", type=int, default=40000)
ap.add_argument("--loss", type=float, default=0.0)
ap.add_argument("--seed", type=int, default=1)
ap.add_argument("--outage-at", type=int, default=-1)
ap.add_argument("--duration", type=float, default=60.0)
ap.add_argument("--served-out", required=True)
ap.add_argument("--check-out", required=True)
args = ap.parse_args()

rng = random.Random(args.seed)
log = bytes(rng.getrandbits(8) for _ in range(args.size))
with open(args.served_out, "wb") as f:
    f.write(log)
TIME_UTC = 1_764_000_000

m = mavutil.mavlink_connection(
    f"tcpin:127.0.0.1:{args.port}", source_system=1, source_component=1
)
print("listening", flush=True)

requests = []
errors = []
ends = 0
sent_bytes = 0
outage_until = None
outage_done = False
sending = None  # (ofs, remaining)
covered = set()  # chunk offsets served
end_after_whole = None
next_hb = 0.0
start = time.time()


def check(msg, what):
    if msg.target_system != 1 or msg.target_component != 1:
        errors.append(f"{what} to {msg.target_system}:{msg.target_component}")


while time.time() < start + args.duration:
    now = time.time()
    if outage_until is not None and now < outage_until:
        # The link is down: what comes is lost, nothing goes.
        m.recv_match(blocking=False)
        time.sleep(0.001)
        continue
    if now >= next_hb:
        m.mav.heartbeat_send(
            mav.MAV_TYPE_QUADROTOR, mav.MAV_AUTOPILOT_ARDUPILOTMEGA, 81, 0, mav.MAV_STATE_STANDBY
        )
        next_hb = now + 1.0
    msg = m.recv_match(blocking=False)
    while msg is not None:
        t = msg.get_type()
        if t == "LOG_REQUEST_LIST":
            check(msg, t)
            if sending is None:
                last = min(msg.end, 1)
                for i in range(max(msg.start, 1), last + 1):
                    m.mav.log_entry_send(i, 1, last, TIME_UTC, args.size)
        elif t == "LOG_REQUEST_DATA":
            check(msg, t)
            requests.append([msg.id, msg.ofs, msg.count])
            if msg.id != 1:
                errors.append(f"data of log {msg.id}")
            if msg.count == 0 or msg.ofs >= args.size:
                errors.append(f"request ofs {msg.ofs} count {msg.count} of a {args.size}-byte log")
            if end_after_whole is not None:
                errors.append(f"request ofs {msg.ofs} after the log was whole and END came")
            if sending is None and msg.id == 1 and msg.ofs < args.size:
                sending = (msg.ofs, min(msg.count, args.size - msg.ofs))
        elif t == "LOG_REQUEST_END":
            check(msg, t)
            ends += 1
            sending = None
            if len(covered) * 90 >= args.size and end_after_whole is None:
                end_after_whole = now
        msg = m.recv_match(blocking=False)
    if end_after_whole is not None and now > end_after_whole + 1.0:
        break
    # A few chunks a millisecond-ish: about 100 kB/s.
    for _ in range(2):
        if sending is None:
            break
        ofs, remaining = sending
        n = min(90, remaining)
        data = log[ofs : ofs + n]
        if args.outage_at >= 0 and not outage_done and sent_bytes >= args.outage_at:
            outage_done = True
            outage_until = now + 3.0
            sending = None
            break
        sent_bytes += n
        covered.add(ofs)
        if rng.random() >= args.loss:
            m.mav.log_data_send(1, ofs, n, list(data) + [0] * (90 - n))
        remaining -= n
        sending = None if remaining == 0 or n < 90 else (ofs + n, remaining)
    time.sleep(0.001)

with open(args.check_out, "w") as f:
    json.dump({"requests": requests, "ends": ends, "errors": errors}, f)
