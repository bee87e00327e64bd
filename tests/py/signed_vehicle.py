"""A vehicle that signs, over UDP, with pymavlink: it sends mavterm a known pattern of signed,
tampered, wrongly signed, replayed and unsigned frames, and checks mavterm's own frames with the
same key.

Usage: signed_vehicle.py PORT KEYHEX [future]
With `future`, the first frame is signed with the right key but timestamp 2^48-1 (the end of
the field: a vehicle whose clock jumped), and the pattern follows at the wall clock.

Prints `ready` once pymavlink is loaded, then waits for a line on stdin (mavterm is up) before it
sends; at the end one JSON line: what was sent, and pymavlink's reading of every frame mavterm
sent back. It listens until it has heard at least three of mavterm's frames after its pattern
(mavterm's heartbeat is 1 Hz), within 20 s.
"""
import json
import socket
import struct
import sys
import time

from pymavlink.dialects.v20 import ardupilotmega as v2

port = int(sys.argv[1])
key = bytes.fromhex(sys.argv[2])
dest = ("127.0.0.1", port)
sock = socket.socket(socket.AF_INET, socket.SOCK_DGRAM)
sock.settimeout(0.05)

EPOCH = 1420070400


def now_ts():
    return int((time.time() - EPOCH) * 100000)


def signer(secret, sysid, link_id):
    mav = v2.MAVLink(None, srcSystem=sysid, srcComponent=1)
    if secret is not None:
        mav.signing.secret_key = secret
        mav.signing.link_id = link_id
        mav.signing.timestamp = now_ts()
        mav.signing.sign_outgoing = True
    return mav


def heartbeat(mav, custom_mode=4):
    msg = v2.MAVLink_heartbeat_message(
        v2.MAV_TYPE_QUADROTOR, v2.MAV_AUTOPILOT_ARDUPILOTMEGA,
        v2.MAV_MODE_FLAG_CUSTOM_MODE_ENABLED, custom_mode, v2.MAV_STATE_STANDBY, 3)
    frame = msg.pack(mav)
    mav.seq = (mav.seq + 1) % 256
    return frame


def tamper(frame):
    """Change the custom mode after signing and make the CRC right again."""
    f = bytearray(frame)
    f[10] ^= 0x01
    end = len(f) - 13
    crc = v2.x25crc(f[1:end - 2])
    crc.accumulate(struct.pack("B", v2.MAVLink_heartbeat_message.crc_extra))
    f[end - 2:end] = struct.pack("<H", crc.crc)
    return bytes(f)


good = signer(key, 1, 0)
wrong = signer(bytes(range(32)), 1, 0)
unsigned = signer(None, 2, 0)
radio = v2.MAVLink(None, srcSystem=51, srcComponent=68)

# mavterm's frames, read by a pymavlink that holds our key.
reader = v2.MAVLink(None)
reader.robust_parsing = False
reader.signing.secret_key = key
back = []


def receive(until):
    while time.time() < until:
        try:
            data, _ = sock.recvfrom(65536)
        except socket.timeout:
            continue
        try:
            msgs = reader.parse_buffer(data) or []
        except Exception as e:  # a refused signature raises
            back.append({"error": str(e)})
            continue
        for m in msgs:
            if m.get_type() == "BAD_DATA":
                back.append({"error": "bad data: %s" % m.reason})
                continue
            buf = m.get_msgbuf()
            back.append({
                "name": m.get_type(),
                "sysid": m.get_srcSystem(),
                "signed": bool(buf[2] & 1),
                "sig_ok": m.get_signed(),
                "link_id": buf[-13],
                "timestamp": int.from_bytes(buf[-12:-6], "little"),
            })


sent = {"good": 0, "tampered": 0, "wrong_key": 0, "replayed": 0, "unsigned": 0, "radio": 0,
        "future": 0}
print("ready", flush=True)
sys.stdin.readline()
start = now_ts()
# Signed from now on: the wait for mavterm is not in the timestamps.
good.signing.timestamp = start
wrong.signing.timestamp = start
if len(sys.argv) > 3 and sys.argv[3] == "future":
    end_of_time = signer(key, 1, 0)
    end_of_time.signing.timestamp = (1 << 48) - 1
    sock.sendto(heartbeat(end_of_time, 6), dest)
    sent["future"] += 1
first = None
for i in range(10):
    f = heartbeat(good)
    first = first or f
    sock.sendto(f, dest)
    sent["good"] += 1
    if i in (3, 6):
        sock.sendto(tamper(heartbeat(good, 6)), dest)
        sent["tampered"] += 1
    if i in (4, 7):
        sock.sendto(heartbeat(wrong, 6), dest)
        sent["wrong_key"] += 1
    if i == 8:
        sock.sendto(first, dest)
        sent["replayed"] += 1
    if i < 3:
        sock.sendto(heartbeat(unsigned), dest)
        sent["unsigned"] += 1
    if i < 2:
        sock.sendto(v2.MAVLink_radio_status_message(100, 90, 80, 20, 25, 0, 0).pack(radio), dest)
        sent["radio"] += 1
    receive(time.time() + 0.15)
heard = len(back)
deadline = time.time() + 20
while len(back) < heard + 3 and time.time() < deadline:
    receive(time.time() + 0.1)

print(json.dumps({"sent": sent, "back": back, "start_ts": start, "end_ts": now_ts(), "summary": {
    "goodsig": reader.signing.goodsig_count, "badsig": reader.signing.badsig_count}}))
