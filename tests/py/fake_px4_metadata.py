#!/usr/bin/env python3
"""A pymavlink stand-in PX4 for the component metadata protocol (driven by
tests/px4_meta_fetch.rs).

It listens on TCP and sends HEARTBEATs as PX4 (autopilot 12, quadrotor). It answers:
- PARAM_REQUEST_LIST / PARAM_REQUEST_READ with a few PX4 parameters (INT32 bytewise);
- MAV_CMD_REQUEST_MESSAGE(397, COMPONENT_METADATA) as PX4's streams/COMPONENT_METADATA.hpp
  does: the message (uri mftp://etc/extras/component_general.json.xz, file_crc --crc), then the
  ACK ACCEPTED. pymavlink 2.4.50 has no COMPONENT_METADATA: the frame is built here (MAVLink 2,
  CRC_EXTRA 182 from common.xml). With --metadata unsupported every REQUEST_MESSAGE of 397 or
  395 is ACKed UNSUPPORTED; with --metadata silent nothing answers them.
- FILE_TRANSFER_PROTOCOL as PX4's src/modules/mavlink/mavlink_ftp.cpp: one session; OpenFileRO
  (size in the ACK, NAK NoSessionsAvailable while one is open, FileNotFound for a missing
  file); ReadFile (NAK EOF past the end); BurstReadFile streamed in chunks of --chunk bytes
  ending with burst_complete, and a NAK EOF at the end; TerminateSession (NAK InvalidSession
  when none is open); ResetSessions; a request numbered right after the last (small) answer
  gets that answer again. --drop K drops the K-th data packet of the first burst of each file.
  Files: --general and --params are served as etc/extras/component_general.json.xz and
  etc/extras/parameters.json.xz (--no-params: the latter is missing).

Every request received is checked as PX4 would need it (targets 1:1, network 0, sequence numbers
never reused, opcodes of a read only, sizes, sessions); what is wrong goes into "errors". The log
(--log-out, JSON, rewritten after each request) holds "requests" (REQUEST_MESSAGE param1s),
"opens" (paths opened), "ftp" ([seq, opcode, session, offset, size]) and "errors".
"""
import argparse
import json
import os
import struct
import time

os.environ.setdefault("MAVLINK20", "1")
from pymavlink import mavutil  # noqa: E402
from pymavlink.generator.mavcrc import x25crc  # noqa: E402

mav = mavutil.mavlink

ap = argparse.ArgumentParser()
ap.add_argument("--port", type=int, required=True)
ap.add_argument("--general", required=True)
ap.add_argument("--params", required=True)
ap.add_argument("--no-params", action="store_true")
ap.add_argument("--crc", type=int, required=True)
ap.add_argument("--metadata", default="yes")
ap.add_argument("--chunk", type=int, default=35000)
ap.add_argument("--drop", type=int, default=0)
ap.add_argument("--log-out", required=True)
ap.add_argument("--duration", type=float, default=60.0)
args = ap.parse_args()

FILES = {"etc/extras/component_general.json.xz": open(args.general, "rb").read()}
if not args.no_params:
    FILES["etc/extras/parameters.json.xz"] = open(args.params, "rb").read()

INT32, REAL32 = 6, 9
PARAMS = [
    ("MC_ROLL_P", 6.5, REAL32),
    ("MPC_XY_VEL_MAX", 12.0, REAL32),
    ("COM_RC_IN_MODE", 3, INT32),
    ("SDLOG_PROFILE", 3, INT32),
]

# FTP opcodes and NAK codes (MAVLink FTP spec).
TERMINATE, RESET, OPEN_RO, READ, BURST = 1, 2, 4, 5, 15
ACK, NAK = 128, 129
E_FAIL, E_INVALID_SESSION, E_NO_SESSIONS, E_EOF, E_UNKNOWN, E_NOT_FOUND = 1, 4, 5, 6, 7, 10
DATA_LEN = 239

log = {"requests": [], "opens": [], "ftp": [], "errors": []}


def save():
    tmp = args.log_out + ".tmp"
    with open(tmp, "w") as f:
        json.dump(log, f)
    os.replace(tmp, args.log_out)


save()
m = mavutil.mavlink_connection(f"tcpin:127.0.0.1:{args.port}", source_system=1, source_component=1)
print("listening", flush=True)


def send_raw(msgid, crc_extra, payload):
    """A MAVLink 2 frame pymavlink cannot make (trailing zeros cut, as MAVLink 2 sends)."""
    while len(payload) > 1 and payload[-1] == 0:
        payload = payload[:-1]
    seq = m.mav.seq
    m.mav.seq = (seq + 1) % 256
    head = struct.pack("<BBBBBBB", 0xFD, len(payload), 0, 0, seq, 1, 1) + struct.pack("<I", msgid)[:3]
    crc = x25crc(head[1:] + payload)
    crc.accumulate(bytes([crc_extra]))
    m.write(head + payload + struct.pack("<H", crc.crc))


def component_metadata():
    uri = b"mftp://etc/extras/component_general.json.xz"
    send_raw(397, 182, struct.pack("<II100s", int(time.time() * 1000) & 0xFFFFFFFF, args.crc, uri))


def send_value(i):
    name, v, t = PARAMS[i]
    f = struct.unpack("<f", struct.pack("<i", int(v)))[0] if t == INT32 else float(v)
    m.mav.param_value_send(name.encode(), f, t, len(PARAMS), i)


# The one session of mavlink_ftp.cpp.
session = {"file": None, "stream": None}
last_reply = None  # (its seq, payload) when small, as _reply keeps it
last_seq = None
drops = {}


def ftp_send(sysid, compid, p):
    global last_reply
    p = bytes(p)
    if p[4] <= 4:
        last_reply = (struct.unpack("<H", p[0:2])[0], p)
    m.mav.file_transfer_protocol_send(0, sysid, compid, list(p))


def reply(req, opcode, data=b"", session_id=None, offset=None, burst_complete=0):
    seq = (struct.unpack("<H", req[0:2])[0] + 1) & 0xFFFF
    p = bytearray(251)
    p[0:2] = struct.pack("<H", seq)
    p[2] = req[2] if session_id is None else session_id
    p[3] = opcode
    p[4] = len(data)
    p[5] = req[3]
    p[6] = burst_complete
    p[8:12] = req[8:12] if offset is None else struct.pack("<I", offset)
    p[12:12 + len(data)] = data
    return p


def on_ftp(msg):
    global last_seq
    sysid, compid = msg.get_srcSystem(), msg.get_srcComponent()
    p = bytes(msg.payload)
    seq, sess, op, size = struct.unpack("<H", p[0:2])[0], p[2], p[3], p[4]
    offset = struct.unpack("<I", p[8:12])[0]
    log["ftp"].append([seq, op, sess, offset, size])
    if msg.target_system != 1 or msg.target_component != 1 or msg.target_network != 0:
        log["errors"].append(f"FTP to {msg.target_network}/{msg.target_system}:{msg.target_component}")
    if last_seq is not None and not 0 < (seq - last_seq) & 0xFFFF < 0x8000:
        log["errors"].append(f"FTP seq {seq} after {last_seq}: reused or gone back")
    if op not in (TERMINATE, RESET, OPEN_RO, READ, BURST):
        log["errors"].append(f"FTP opcode {op}: not a read")
    if size > DATA_LEN:
        log["errors"].append(f"FTP size {size}")
    if op in (READ, BURST) and size != DATA_LEN:
        log["errors"].append(f"FTP read of {size} bytes, not a whole block")
    if op in (READ, BURST, TERMINATE) and sess != 0:
        log["errors"].append(f"FTP session {sess}: PX4 has session 0 only")
    # mavlink_ftp.cpp: a resent request gets the last answer again.
    if last_reply is not None and (seq + 1) & 0xFFFF == last_reply[0]:
        log["errors"].append(f"FTP seq {seq} collides with the last answer: PX4 would resend it")
        m.mav.file_transfer_protocol_send(0, sysid, compid, list(last_reply[1]))
        last_seq = seq
        save()
        return
    last_seq = seq
    data = p[12:12 + size]
    if op == TERMINATE:
        if session["file"] is None or sess != 0:
            ftp_send(sysid, compid, reply(p, NAK, bytes([E_INVALID_SESSION])))
        else:
            session["file"] = None
            session["stream"] = None
            ftp_send(sysid, compid, reply(p, ACK))
    elif op == RESET:
        session["file"] = None
        session["stream"] = None
        ftp_send(sysid, compid, reply(p, ACK))
    elif op == OPEN_RO:
        path = data.split(b"\0")[0].decode(errors="replace")
        if b"\0" in data:
            log["errors"].append("FTP open path holds a NUL")
        log["opens"].append(path)
        if session["file"] is not None:
            ftp_send(sysid, compid, reply(p, NAK, bytes([E_NO_SESSIONS])))
        elif path not in FILES:
            ftp_send(sysid, compid, reply(p, NAK, bytes([E_NOT_FOUND])))
        else:
            session["file"] = FILES[path]
            session["path"] = path
            ftp_send(sysid, compid, reply(p, ACK, struct.pack("<I", len(FILES[path])), session_id=0))
    elif op == READ:
        f = session["file"]
        if f is None or sess != 0:
            ftp_send(sysid, compid, reply(p, NAK, bytes([E_INVALID_SESSION])))
        elif offset >= len(f):
            ftp_send(sysid, compid, reply(p, NAK, bytes([E_EOF])))
        else:
            ftp_send(sysid, compid, reply(p, ACK, f[offset:offset + DATA_LEN]))
    elif op == BURST:
        if session["file"] is None:
            ftp_send(sysid, compid, reply(p, NAK, bytes([E_INVALID_SESSION])))
        else:
            session["stream"] = {"offset": offset, "seq": (seq + 1) & 0xFFFF, "sent": 0,
                                 "to": (sysid, compid), "req": p}
    else:
        ftp_send(sysid, compid, reply(p, NAK, bytes([E_UNKNOWN])))
    save()


def stream():
    """mavlink_ftp.cpp's send(): a few packets of the burst each loop."""
    s = session["stream"]
    f = session["file"]
    for _ in range(8):
        if s is None:
            return
        p = bytearray(251)
        p[0:2] = struct.pack("<H", s["seq"])
        s["seq"] = (s["seq"] + 1) & 0xFFFF
        p[3] = ACK
        p[5] = BURST
        p[8:12] = struct.pack("<I", s["offset"])
        if s["offset"] >= len(f):
            p[3] = NAK
            p[4] = 1
            p[12] = E_EOF
            session["stream"] = None
            ftp_send(*s["to"], p)
            return
        chunk = f[s["offset"]:s["offset"] + DATA_LEN]
        p[4] = len(chunk)
        p[12:12 + len(chunk)] = chunk
        s["offset"] += len(chunk)
        s["sent"] += len(chunk)
        if s["sent"] > args.chunk:
            p[6] = 1
            session["stream"] = None
        path = session["path"]
        n = drops.get(path, 0) + 1
        drops[path] = n
        if not (args.drop and n == args.drop):
            ftp_send(*s["to"], p)
        if session["stream"] is None:
            return


end = time.time() + args.duration
next_hb = 0.0
listing = None
while time.time() < end:
    now = time.time()
    if now >= next_hb:
        m.mav.heartbeat_send(mav.MAV_TYPE_QUADROTOR, mav.MAV_AUTOPILOT_PX4, 81, 0, mav.MAV_STATE_STANDBY)
        next_hb = now + 1.0
    if listing is not None:
        send_value(listing)
        listing = listing + 1 if listing + 1 < len(PARAMS) else None
    if session["stream"] is not None:
        stream()
    msg = m.recv_match(blocking=True, timeout=0.005)
    if msg is None:
        continue
    kind = msg.get_type()
    if kind == "PARAM_REQUEST_LIST":
        listing = 0
    elif kind == "PARAM_REQUEST_READ":
        names = [p[0] for p in PARAMS]
        i = msg.param_index if msg.param_index >= 0 else (names.index(msg.param_id) if msg.param_id in names else None)
        if i is not None and i < len(PARAMS):
            send_value(i)
    elif kind == "COMMAND_LONG" and msg.command == mav.MAV_CMD_REQUEST_MESSAGE:
        which = int(msg.param1)
        if which in (395, 397):
            log["requests"].append(which)
            if (msg.target_system, msg.target_component) != (1, 1):
                log["errors"].append(f"REQUEST_MESSAGE to {msg.target_system}:{msg.target_component}")
            save()
            if args.metadata == "yes" and which == 397:
                component_metadata()
                m.mav.command_ack_send(msg.command, mav.MAV_RESULT_ACCEPTED)
            elif args.metadata == "unsupported" or (args.metadata == "yes" and which == 395):
                m.mav.command_ack_send(msg.command, mav.MAV_RESULT_UNSUPPORTED)
    elif kind == "FILE_TRANSFER_PROTOCOL":
        on_ftp(msg)
