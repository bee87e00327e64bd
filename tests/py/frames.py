"""pymavlink as the reference for frames, both ways.

Usage: frames.py decode   < lines of hex frames   -> one JSON object per line
       frames.py encode   < one JSON request per line -> one line of hex per request

decode: each frame is parsed by pymavlink (CRC checked; a bad frame prints {"error": ...}); the
output holds the header (seq, sysid, compid, msgid, name) and every field of the message.
encode: {"sysid", "compid", "seq", "v1": bool, "msg": "HEARTBEAT", "fields": {...}} packed by
pymavlink with its own CRC.
"""
import json
import sys

from pymavlink.dialects.v20 import ardupilotmega as v2
from pymavlink.dialects.v10 import ardupilotmega as v1


def decode(line):
    data = bytes.fromhex(line)
    mav = v2.MAVLink(None)
    mav.robust_parsing = False
    try:
        msgs = mav.parse_buffer(data) or []
    except Exception as e:  # bad CRC, bad length
        return {"error": str(e)}
    if len(msgs) != 1:
        return {"error": "expected one frame, got %d" % len(msgs)}
    m = msgs[0]
    if m.get_type() == "BAD_DATA":
        return {"error": "bad data: %s" % m.reason}
    out = {
        "seq": m.get_seq(),
        "sysid": m.get_srcSystem(),
        "compid": m.get_srcComponent(),
        "msgid": m.get_msgId(),
        "name": m.get_type(),
    }
    for k, v in m.to_dict().items():
        if k == "mavpackettype":
            continue
        if isinstance(v, (bytes, bytearray)):
            v = v.hex()
        if isinstance(v, float) and v != v:
            v = "nan"  # JSON has no NaN
        if isinstance(v, list):
            v = ["nan" if isinstance(x, float) and x != x else x for x in v]
        out[k] = v
    return out


def encode(req):
    mod = v1 if req.get("v1") else v2
    mav = mod.MAVLink(None, srcSystem=req["sysid"], srcComponent=req["compid"])
    mav.seq = req.get("seq", 0)
    cls = getattr(mod, "MAVLink_%s_message" % req["msg"].lower())
    fields = dict(req.get("fields", {}))
    for k, v in fields.items():
        if isinstance(v, str) and k in ("text", "param_id", "cam_definition_uri", "file_url", "name", "uri"):
            fields[k] = v.encode()
    msg = cls(**fields)
    return msg.pack(mav, force_mavlink1=bool(req.get("v1"))).hex()


def main():
    mode = sys.argv[1]
    for line in sys.stdin:
        line = line.strip()
        if not line:
            continue
        if mode == "decode":
            print(json.dumps(decode(line)))
        else:
            print(encode(json.loads(line)))


main()
