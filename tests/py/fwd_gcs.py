"""A pymavlink ground station on one of mavterm's `--out` outputs (started by tests/forward.rs).

Usage: fwd_gcs.py PORT. Listens on udpin:127.0.0.1:PORT as system 250, prints `listening`, then
takes every frame mavterm forwards. A heartbeat once a second, as a GCS does; on the first
heartbeat of system 1: a SETUP_SIGNING for it (mavterm must not pass it on) and COMMAND_LONG
DO_SET_MODE GUIDED (it must). Ends when a line comes on stdin (the test: mavterm has exited),
having read what is left on its socket, or after 120 s, and prints one JSON object: every frame received (hex, sysid, msgid), the frames sent, whether a
heartbeat of system 1 in GUIDED (custom mode 4) came after, and the ACK.
"""
import json
import os
import sys
import threading
import time

os.environ.setdefault("MAVLINK20", "1")
from pymavlink import mavutil  # noqa: E402

PORT = int(sys.argv[1])
m = mavutil.mavlink_connection(
    f"udpin:127.0.0.1:{PORT}", source_system=250, source_component=190, dialect="ardupilotmega"
)
mav = mavutil.mavlink
print("listening", flush=True)

received = []
sent = {}
bad = 0
guided_seen = False
ack = None
commanded = False
last_frame = time.time()
start = time.time()
next_hb = 0.0


def send(name, msg):
    m.mav.send(msg)
    sent[name] = bytes(msg.get_msgbuf()).hex()


ended = threading.Event()
threading.Thread(target=lambda: (sys.stdin.readline(), ended.set()), daemon=True).start()

while time.time() - start < 120:
    now = time.time()
    if ended.is_set():
        # mavterm has exited: what it sent is on our socket; read it to the end.
        msg = m.recv_match(blocking=False)
        if msg is None:
            break
    else:
        msg = None
    # Heartbeats once the first frame showed where mavterm is.
    if received and now >= next_hb and not ended.is_set():
        m.mav.heartbeat_send(mav.MAV_TYPE_GCS, mav.MAV_AUTOPILOT_INVALID, 0, 0, 0)
        next_hb = now + 1.0
    if msg is None:
        msg = m.recv_match(blocking=True, timeout=0.2)
    if msg is None:
        continue
    last_frame = time.time()
    if msg.get_type() == "BAD_DATA":
        bad += 1
        continue
    received.append(
        {
            "hex": bytes(msg.get_msgbuf()).hex(),
            "sysid": msg.get_srcSystem(),
            "msgid": msg.get_msgId(),
        }
    )
    if msg.get_srcSystem() != 1:
        continue
    if msg.get_type() == "HEARTBEAT":
        if not commanded:
            commanded = True
            send(
                "setup_signing",
                mav.MAVLink_setup_signing_message(1, 1, bytes([0x42] * 32), 1234567),
            )
            send(
                "command",
                mav.MAVLink_command_long_message(
                    1, 1, mav.MAV_CMD_DO_SET_MODE, 0, 1, 4, 0, 0, 0, 0, 0
                ),
            )
        elif msg.custom_mode == 4:
            guided_seen = True
    if msg.get_type() == "COMMAND_ACK" and msg.target_system == 250:
        ack = {"command": msg.command, "result": msg.result}

print(
    json.dumps(
        {"received": received, "sent": sent, "bad": bad, "guided_seen": guided_seen, "ack": ack}
    )
)
