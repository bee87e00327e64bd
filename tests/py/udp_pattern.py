"""Send HEARTBEATs from several systems to mavterm with a known sequence pattern (pymavlink
encodes them), then check that mavterm's own heartbeat decodes in pymavlink.

Usage: udp_pattern.py PORT
Prints `ready` once pymavlink is loaded and the frames are made, then waits for a line on stdin
(mavterm holds the port) before it sends; at the end one JSON line: what was sent and what was
received back (mavterm's heartbeat, 1 Hz: waited for up to 30 s).
"""
import json
import os
import socket
import sys
import time

from pymavlink.dialects.v10 import ardupilotmega as v1
from pymavlink.dialects.v20 import ardupilotmega as v2

port = int(sys.argv[1])
sock = socket.socket(socket.AF_INET, socket.SOCK_DGRAM)
sock.settimeout(0.2)
dest = ("127.0.0.1", port)


def heartbeat(mod, mav, seq):
    mav.seq = seq
    msg = mod.MAVLink_heartbeat_message(
        mod.MAV_TYPE_QUADROTOR, mod.MAV_AUTOPILOT_ARDUPILOTMEGA,
        mod.MAV_MODE_FLAG_CUSTOM_MODE_ENABLED, 4, mod.MAV_STATE_STANDBY, 3)
    return msg.pack(mav)


# System 1 (MAVLink 2): 0..99 with 10, 11, 12 skipped (3 lost), 20 sent twice (1 duplicate),
# 30 and 31 swapped (1 reordered, no loss).
seq1 = [s for s in range(100) if s not in (10, 11, 12)]
i20 = seq1.index(20)
seq1.insert(i20 + 1, 20)
i30 = seq1.index(30)
seq1[i30], seq1[i30 + 1] = seq1[i30 + 1], seq1[i30]

# System 2 (MAVLink 1): 200..299 wrapping past 255, every 4th skipped, 250 repeated 3 times.
seq2 = []
for n in range(200, 300):
    s = n % 256
    if n % 4 == 3:
        continue
    seq2.append(s)
    if s == 250:
        seq2 += [250, 250]

# System 3 (MAVLink 2, signed): 20 frames, no loss.
seq3 = list(range(20))

m1 = v2.MAVLink(None, srcSystem=1, srcComponent=1)
m2 = v1.MAVLink(None, srcSystem=2, srcComponent=1)
m3 = v2.MAVLink(None, srcSystem=3, srcComponent=1)
m3.signing.secret_key = bytes(range(32))
m3.signing.link_id = 1
m3.signing.timestamp = 1000
m3.signing.sign_outgoing = True

frames = [heartbeat(v2, m1, s) for s in seq1]
frames += [heartbeat(v1, m2, s) for s in seq2]
frames += [heartbeat(v2, m3, s) for s in seq3]
print("ready", flush=True)
sys.stdin.readline()
# Interleave the systems as a router would.
for f in frames:
    sock.sendto(f, dest)
    time.sleep(0.002)

# mavterm replies to every UDP peer it heard: its GCS heartbeat must decode here.
parser = v2.MAVLink(None)
parser.robust_parsing = True
got = None
bad = 0
deadline = time.time() + 30
while time.time() < deadline and got is None:
    try:
        data, _ = sock.recvfrom(65536)
    except socket.timeout:
        continue
    for msg in parser.parse_buffer(data) or []:
        if msg.get_type() == "BAD_DATA":
            bad += 1
        elif msg.get_type() == "HEARTBEAT":
            got = {
                "sysid": msg.get_srcSystem(),
                "compid": msg.get_srcComponent(),
                "type": msg.type,
                "autopilot": msg.autopilot,
                "crc": msg.get_crc(),
                "version": 2 if msg.get_header().mlen and data[0] == 0xFD else 1,
            }

print(json.dumps({"sent": {"1": len(seq1), "2": len(seq2), "3": len(seq3)},
                  "heartbeat": got, "bad": bad}))
