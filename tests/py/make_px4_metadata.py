#!/usr/bin/env python3
"""Write PX4-style component metadata files into OUTDIR, as PX4's build makes them
(src/lib/parameters/px4params/jsonout.py, src/lib/component_information/
generate_component_general.py): parameters.json (+ .xz) and component_general.json (+ .xz),
compressed with Python's lzma (xz container, preset 9, as PX4 does).

  --param-uri URI       the parameter entry's uri (default mftp://etc/extras/parameters.json.xz)
  --fallback URI        its uriFallback (default: empty)
  --pad N               add N more parameters (PAD_0000...), for a file of several bursts

Prints the CRC32 of component_general.json (MAVLink's, as generate_crc.py computes it) on stdout.
"""
import argparse
import json
import lzma
import os

ap = argparse.ArgumentParser()
ap.add_argument("outdir")
ap.add_argument("--param-uri", default="mftp://etc/extras/parameters.json.xz")
ap.add_argument("--fallback", default="")
ap.add_argument("--pad", type=int, default=0)
args = ap.parse_args()

params = [
    {
        "name": "MC_ROLL_P",
        "type": "Float",
        "default": 6.5,
        "group": "Multicopter Attitude Control",
        "category": "Standard",
        "shortDesc": "Roll P gain",
        "longDesc": "Roll proportional gain, i.e. desired angular speed in rad/s for error 1 rad.",
        "min": 0.0,
        "max": 12.0,
        "decimalPlaces": 2,
        "increment": 0.1,
    },
    {
        "name": "MPC_XY_VEL_MAX",
        "type": "Float",
        "default": 12.0,
        "group": "Multicopter Position Control",
        "category": "Standard",
        "shortDesc": "Maximum horizontal velocity",
        "longDesc": "Absolute maximum for all velocity controlled modes.",
        "units": "m/s",
        "min": 0.0,
        "max": 20.0,
        "decimalPlaces": 1,
        "increment": 1.0,
    },
    {
        "name": "COM_RC_IN_MODE",
        "type": "Int32",
        "default": 3,
        "group": "Commander",
        "category": "Standard",
        "shortDesc": "RC control input mode",
        "min": 0,
        "max": 4,
        "values": [
            {"value": 0, "description": "RC Transmitter only"},
            {"value": 1, "description": "Joystick only"},
            {"value": 2, "description": "RC and Joystick with fallback"},
            {"value": 3, "description": "RC or Joystick keep first"},
            {"value": 4, "description": "Stick input disabled"},
        ],
    },
    {
        "name": "SDLOG_PROFILE",
        "type": "Int32",
        "default": 1,
        "group": "SD Logging",
        "category": "Standard",
        "shortDesc": "Logging topic profile (integer bitmask)",
        "rebootRequired": True,
        "min": 0,
        "max": 4095,
        "bitmask": [
            {"index": 0, "description": "Default set (general log analysis)"},
            {"index": 1, "description": "Estimator replay (EKF2)"},
            {"index": 2, "description": "Thermal calibration"},
        ],
    },
    {
        # PX4's jsonout.py writes numbers of the other types as strings.
        "name": "UAVCAN_NODE_ID",
        "type": "Uint8",
        "default": "1",
        "group": "UAVCAN",
        "category": "System",
        "shortDesc": "UAVCAN Node ID",
        "min": "1",
        "max": "125",
    },
]
for i in range(args.pad):
    params.append(
        {
            "name": f"PAD_{i:04d}",
            "type": "Int32",
            "default": i,
            "group": "Padding",
            "category": "Developer",
            "shortDesc": f"Padding parameter {i} with a description long enough to make the file grow",
            "longDesc": " ".join(f"word{(i * 7 + k) % 977}" for k in range(40)),
            "min": 0,
            "max": 100000,
        }
    )

doc = {"version": 1, "parameters": params}


def write(name, text):
    path = os.path.join(args.outdir, name)
    with open(path, "w") as f:
        f.write(text)
    with lzma.open(path + ".xz", "wt", preset=9) as f:
        f.write(text)


write("parameters.json", json.dumps(doc, indent=2, sort_keys=True))


def crc32(data, crc=0):
    # MAVLink's CRC32 as generate_crc.py computes it (table of 0xEDB88320, no final xor).
    table = []
    for i in range(256):
        k = i
        for _ in range(8):
            k = (k >> 1) ^ 0xEDB88320 if k & 1 else k >> 1
        table.append(k)
    for b in data:
        crc = (crc >> 8) ^ table[(crc & 0xFF) ^ b]
    return crc


with open(os.path.join(args.outdir, "parameters.json.xz"), "rb") as f:
    param_crc = crc32(f.read())
general = {
    "version": 1,
    "metadataTypes": [
        {"type": 1, "uri": args.param_uri, "fileCrc": param_crc, "uriFallback": args.fallback},
        {"type": 4, "uri": "mftp://etc/extras/all_events.json.xz", "fileCrc": 1, "uriFallback": ""},
    ],
}
text = json.dumps(general)
write("component_general.json", text)
print(crc32(text.encode()))
