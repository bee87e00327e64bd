"""pymavlink as the reference for MAVLink 2 signing, both ways.

Usage:
  signing.py verify KEY       < lines of hex frames -> one JSON object per frame, then a summary
  signing.py sign KEY LINK TS < one JSON request per line -> one line of hex per request
  signing.py passphrase TEXT  -> the key MAVProxy makes of a passphrase, as hex

KEY is 64 hex digits, or "none" (verify without a key: signatures are not checked).

verify: one MAVLink object with `signing.secret_key` set reads every frame in turn (so its stream
timestamps carry over, as on a link); a frame it refuses prints {"error": ...}; a good one its
header, signature fields and message fields. The last line is {"summary": {...}} with pymavlink's
own counters (sig_count, goodsig_count, badsig_count, reject_count).

sign: requests as frames.py's encode ({"sysid", "compid", "seq", "msg", "fields"}), packed by a
MAVLink object signing with KEY, link id LINK and first timestamp TS (pymavlink adds one per
frame); "ts" in a request sets the timestamp for that frame; "tamper": true changes the first
payload byte after signing and fixes the CRC (pymavlink's x25crc), so only the signature can
tell.
"""
import hashlib
import json
import struct
import sys


def key_arg(s):
    return None if s == "none" else bytes.fromhex(s)


def verify(key):
    from pymavlink.dialects.v20 import ardupilotmega as v2
    mav = v2.MAVLink(None)
    mav.robust_parsing = False
    if key is not None:
        mav.signing.secret_key = key
    for line in sys.stdin:
        line = line.strip()
        if not line:
            continue
        data = bytes.fromhex(line)
        try:
            msgs = mav.parse_buffer(data) or []
        except Exception as e:  # bad CRC, bad signature
            print(json.dumps({"error": str(e)}))
            continue
        if len(msgs) != 1:
            print(json.dumps({"error": "expected one frame, got %d" % len(msgs)}))
            continue
        m = msgs[0]
        if m.get_type() == "BAD_DATA":
            print(json.dumps({"error": "bad data: %s" % m.reason}))
            continue
        buf = m.get_msgbuf()
        signed = buf[0] == 0xFD and buf[2] & 0x01 != 0
        out = {
            "name": m.get_type(),
            "seq": m.get_seq(),
            "sysid": m.get_srcSystem(),
            "compid": m.get_srcComponent(),
            "signed": signed,
            # pymavlink checked the signature with the key and found it good
            "sig_ok": m.get_signed(),
        }
        if signed:
            out["link_id"] = buf[-13]
            out["timestamp"] = int.from_bytes(buf[-12:-6], "little")
        for k, v in m.to_dict().items():
            if k == "mavpackettype":
                continue
            if isinstance(v, (bytes, bytearray)):
                v = v.hex()
            out[k] = v
        print(json.dumps(out))
    s = mav.signing
    print(json.dumps({"summary": {
        "sig_count": s.sig_count,
        "goodsig_count": s.goodsig_count,
        "badsig_count": s.badsig_count,
        "reject_count": s.reject_count,
    }}))


def sign(key, link_id, ts):
    from pymavlink.dialects.v20 import ardupilotmega as v2
    mav = v2.MAVLink(None)
    mav.signing.secret_key = key
    mav.signing.link_id = link_id
    mav.signing.timestamp = ts
    mav.signing.sign_outgoing = True
    for line in sys.stdin:
        line = line.strip()
        if not line:
            continue
        req = json.loads(line)
        mav.srcSystem = req["sysid"]
        mav.srcComponent = req["compid"]
        mav.seq = req.get("seq", 0)
        if "ts" in req:
            mav.signing.timestamp = req["ts"]
        cls = getattr(v2, "MAVLink_%s_message" % req["msg"].lower())
        fields = dict(req.get("fields", {}))
        for k, v in fields.items():
            if isinstance(v, str) and k in ("text", "param_id"):
                fields[k] = v.encode()
        frame = bytearray(cls(**fields).pack(mav))
        if req.get("tamper"):
            frame[10] ^= 0x01
            end = len(frame) - 13
            crc = v2.x25crc(frame[1:end - 2])
            crc.accumulate(struct.pack("B", cls.crc_extra))
            frame[end - 2:end] = struct.pack("<H", crc.crc)
        print(frame.hex())


def main():
    mode = sys.argv[1]
    if mode == "verify":
        verify(key_arg(sys.argv[2]))
    elif mode == "sign":
        sign(key_arg(sys.argv[2]), int(sys.argv[3]), int(sys.argv[4]))
    elif mode == "passphrase":
        # MAVProxy's passphrase_to_key.
        print(hashlib.sha256(sys.argv[2].encode("utf-8")).digest().hex())
    else:
        sys.exit("unknown mode %s" % mode)


main()
