"""Euler angles to a MAVLink attitude quaternion, as pymavlink's quaternion.py (_euler_to_q):
Tait-Bryan ZYX, [w, x, y, z].

Usage: euler_to_q.py < lines "ROLL PITCH YAW" in degrees -> one JSON list [w, x, y, z] per line.
"""
import json
import math
import sys

for line in sys.stdin:
    if not line.strip():
        continue
    roll, pitch, yaw = (math.radians(float(v)) for v in line.split())
    c1, s1 = math.cos(roll / 2), math.sin(roll / 2)
    c2, s2 = math.cos(pitch / 2), math.sin(pitch / 2)
    c3, s3 = math.cos(yaw / 2), math.sin(yaw / 2)
    q = [
        c1 * c2 * c3 + s1 * s2 * s3,
        s1 * c2 * c3 - c1 * s2 * s3,
        c1 * s2 * c3 + s1 * c2 * s3,
        c1 * c2 * s3 - s1 * s2 * c3,
    ]
    print(json.dumps(q))
