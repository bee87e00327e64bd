#!/usr/bin/env python3
"""A pymavlink stand-in vehicle for the parameter protocol (driven by tests/params_interop.rs).

It listens on TCP, sends heartbeats as ArduPilot or PX4, and answers PARAM_REQUEST_LIST,
PARAM_REQUEST_READ and PARAM_SET the way the MAVLink parameter protocol and the autopilots
describe, with deliberate trouble:

  --autopilot ardupilot|px4|generic
                              ArduPilot: values C-cast into the float, PARAM_SET echoed with
                              index 65535. PX4: INT32 values bytewise in the float, PARAM_SET
                              echoed with the parameter's index. generic: a vehicle of another
                              stack (HEARTBEAT autopilot GENERIC) that follows the parameter
                              protocol's default, bytewise, with INT32 values no float holds
                              C-cast (-1, 2^24+1, INT32_MAX, INT32_MIN), echoed with the index.
  --heartbeat ardupilot|px4   the HEARTBEAT's autopilot, when it should differ.
  --caps N                    answer REQUEST_MESSAGE(AUTOPILOT_VERSION) with these capability
                              bits (-1: never answer it).
  --ftp none|nak|late-ack     FILE_TRANSFER_PROTOCOL: never answered; NAK FileNotFound; or
                              OpenFileRO ACKed (session 3) only 0.5 s after it came, once the
                              GCS should have given MAVFTP up. Every FTP request received is
                              logged to --ftp-log as [seq, session, opcode].
  --count-change K            the set grows by K parameters half-way through the list, and every
                              PARAM_VALUE after that carries the new count.
  --dup N                     the first N list entries are sent twice.
  --loss F --seed S           drop that fraction of the PARAM_VALUEs sent (seeded).
  --change NAME=VALUE         once the list has been sent, change NAME as another GCS would, and
                              send the unsolicited PARAM_VALUE (index 65535).
  --set echo|lose-first|refuse|silent|nudge
                              PARAM_SET: echo the new value; set it but lose the first echo of
                              each name; keep the old value and echo it; never answer; set it
                              and echo a float one bit off the one received.

The final table (name -> [value, MAV_PARAM_TYPE]) is written to --table-out after every change,
and the PARAM_SETs received (name -> count) to --log-out.
"""
import argparse
import json
import os
import random
import struct
import time

from pymavlink import mavutil

mav = mavutil.mavlink

ap = argparse.ArgumentParser()
ap.add_argument("--port", type=int, required=True)
ap.add_argument("--autopilot", default="ardupilot")
ap.add_argument("--heartbeat", default="", help="autopilot in HEARTBEAT (default: --autopilot)")
ap.add_argument("--caps", type=int, default=-1)
ap.add_argument("--ftp", default="none")
ap.add_argument("--count-change", type=int, default=0)
ap.add_argument("--dup", type=int, default=0)
ap.add_argument("--loss", type=float, default=0.0)
ap.add_argument("--seed", type=int, default=1)
ap.add_argument("--change", default="")
ap.add_argument("--set", default="echo")
ap.add_argument("--table-out", required=True)
ap.add_argument("--log-out", default="")
ap.add_argument("--ftp-log", default="")
ap.add_argument("--duration", type=float, default=60.0)
args = ap.parse_args()

PX4 = args.autopilot == "px4"
GENERIC = args.autopilot == "generic"
BYTEWISE = PX4 or GENERIC
rng = random.Random(args.seed)

INT8, INT16, INT32, REAL32 = 2, 4, 6, 9


def table(n, offset=0):
    """n parameters with values that tell the encodings apart."""
    out = []
    if GENERIC and offset == 0:
        out = [
            ("INT_MINUS1", -1, INT32),
            ("INT_BIG", 2**24 + 1, INT32),
            ("INT_MAX", 2**31 - 1, INT32),
            ("INT_NEG_BIG", -(2**31), INT32),
            ("INT_ONE", 1, INT32),
            ("FLT_HALF", 0.5, REAL32),
        ]
        n = 0
    for i in range(offset, offset + n):
        if PX4:
            # PX4 has INT32 and FLOAT only; INT32 values beyond 2^24 and negatives (-1 is a NaN
            # pattern bytewise) only survive a bytewise reading.
            if i % 2 == 0:
                v = [0, 1, -1, 123456789, -5, 16777217, 2**31 - 1, 7][i % 8]
                out.append((f"PX_I{i:03d}", v, INT32))
            else:
                out.append((f"PX_F{i:03d}", struct.unpack("<f", struct.pack("<f", 0.1 * i))[0], REAL32))
        else:
            kind = i % 4
            if kind == 0:
                out.append((f"AP_I8_{i:03d}", [-1, 0, 5, 127][i % 3], INT8))
            elif kind == 1:
                out.append((f"AP_I16_{i:03d}", [1500, -300, 0][i % 3], INT16))
            elif kind == 2:
                out.append((f"AP_I32_{i:03d}", [100000, -2, 16777216][i % 3], INT32))
            else:
                out.append((f"AP_F_{i:03d}", struct.unpack("<f", struct.pack("<f", 0.3 * i))[0], REAL32))
    return out


params = table(200)
by_name = {p[0]: i for i, p in enumerate(params)}
set_log = {}
ftp_log = []
late_open = None  # (due time, seq, sysid, compid) of an OpenFileRO to ACK late


def save(path, obj):
    tmp = path + ".tmp"
    with open(tmp, "w") as f:
        json.dump(obj, f)
    os.replace(tmp, path)


def save_table():
    save(args.table_out, {n: [v, t] for (n, v, t) in params})


save_table()

m = mavutil.mavlink_connection(
    f"tcpin:127.0.0.1:{args.port}", source_system=1, source_component=1
)
print("listening", flush=True)


def wire_float(v, t):
    if BYTEWISE and t == INT32:
        return struct.unpack("<f", struct.pack("<i", int(v)))[0]
    return float(v)


def send_value(i, index=None, lossy=True, nudge=False):
    name, v, t = params[i]
    if lossy and args.loss > 0 and rng.random() < args.loss:
        return
    f = wire_float(v, t)
    if nudge:
        f = struct.unpack("<f", struct.pack("<I", struct.unpack("<I", struct.pack("<f", f))[0] + 1))[0]
    m.mav.param_value_send(
        name.encode(), f, t, len(params), i if index is None else index
    )


def heartbeat():
    if (args.heartbeat or args.autopilot) == "px4":
        m.mav.heartbeat_send(mav.MAV_TYPE_QUADROTOR, mav.MAV_AUTOPILOT_PX4, 81, 0, mav.MAV_STATE_STANDBY)
    elif (args.heartbeat or args.autopilot) == "generic":
        m.mav.heartbeat_send(mav.MAV_TYPE_QUADROTOR, mav.MAV_AUTOPILOT_GENERIC, 81, 0, mav.MAV_STATE_STANDBY)
    else:
        m.mav.heartbeat_send(mav.MAV_TYPE_QUADROTOR, mav.MAV_AUTOPILOT_ARDUPILOTMEGA, 81, 0, mav.MAV_STATE_STANDBY)


listing = None  # next index of a running list
changed = False
end = time.time() + args.duration
next_hb = 0.0
while time.time() < end:
    now = time.time()
    if now >= next_hb:
        heartbeat()
        next_hb = now + 1.0
    # Stream the list a few at a time, like a paced autopilot.
    if listing is not None:
        for _ in range(10):
            if listing >= len(params):
                listing = None
                break
            if args.count_change and listing == 100 and len(params) == 200:
                params.extend(table(args.count_change, 200))
                by_name.update({p[0]: i for i, p in enumerate(params)})
                save_table()
            send_value(listing)
            if listing < args.dup:
                send_value(listing)
            listing += 1
        if listing is None and args.change and not changed:
            changed = True
            name, value = args.change.split("=")
            i = by_name[name]
            n, _, t = params[i]
            params[i] = (n, float(value) if t == REAL32 else int(value), t)
            save_table()
            send_value(i, index=65535, lossy=False)
    if late_open is not None and now >= late_open[0]:
        _, seq, sysid, compid = late_open
        late_open = None
        reply = bytearray(251)
        reply[0:2] = struct.pack("<H", (seq + 1) & 0xFFFF)
        reply[2] = 3  # session
        reply[3] = 128  # ACK
        reply[4] = 4
        reply[5] = 4  # OpenFileRO
        reply[12:16] = struct.pack("<I", 1000)
        m.mav.file_transfer_protocol_send(0, sysid, compid, list(reply))
    msg = m.recv_match(blocking=True, timeout=0.01)
    if msg is None:
        continue
    kind = msg.get_type()
    if os.environ.get("FAKE_DEBUG"): print("RX", msg, flush=True)
    if kind == "PARAM_REQUEST_LIST":
        listing = 0
    elif kind == "PARAM_REQUEST_READ":
        if msg.param_index >= 0:
            i = msg.param_index if msg.param_index < len(params) else None
        else:
            i = by_name.get(msg.param_id)
        if i is not None:
            send_value(i)
    elif kind == "PARAM_SET":
        name = msg.param_id
        set_log[name] = set_log.get(name, 0) + 1
        if args.log_out:
            save(args.log_out, set_log)
        i = by_name.get(name)
        if i is None or args.set == "silent":
            continue
        n, old, t = params[i]
        if t == REAL32:
            new = struct.unpack("<f", struct.pack("<f", msg.param_value))[0]
        elif BYTEWISE:
            new = struct.unpack("<i", struct.pack("<f", msg.param_value))[0]
        else:
            new = int(msg.param_value)
        if args.set != "refuse":
            params[i] = (n, new, t)
            save_table()
        if args.set == "lose-first" and set_log[name] == 1:
            continue
        send_value(i, index=i if BYTEWISE else 65535, lossy=False, nudge=args.set == "nudge")
    elif kind == "COMMAND_LONG" and msg.command == mav.MAV_CMD_REQUEST_MESSAGE and int(msg.param1) == 148:
        if args.caps >= 0:
            m.mav.command_ack_send(msg.command, mav.MAV_RESULT_ACCEPTED)
            m.mav.autopilot_version_send(args.caps, 0, 0, 0, 0, [0] * 8, [0] * 8, [0] * 8, 0, 0, 0)
    elif kind == "FILE_TRANSFER_PROTOCOL" and args.ftp == "late-ack":
        p = bytearray(msg.payload)
        seq = struct.unpack("<H", bytes(p[0:2]))[0]
        ftp_log.append([seq, p[2], p[3]])
        if args.ftp_log:
            save(args.ftp_log, ftp_log)
        if p[3] == 4 and late_open is None and not any(e[2] == 4 for e in ftp_log[:-1]):
            late_open = (time.time() + 0.5, seq, msg.get_srcSystem(), msg.get_srcComponent())
    elif kind == "FILE_TRANSFER_PROTOCOL" and args.ftp == "nak":
        p = bytearray(msg.payload)
        seq = struct.unpack("<H", bytes(p[0:2]))[0]
        req = p[3]
        reply = bytearray(251)
        reply[0:2] = struct.pack("<H", (seq + 1) & 0xFFFF)
        reply[2] = p[2]
        reply[3] = 129  # NAK
        reply[4] = 1
        reply[5] = req
        reply[12] = 10  # FileNotFound
        m.mav.file_transfer_protocol_send(0, msg.get_srcSystem(), msg.get_srcComponent(), list(reply))
