"""Great-circle truth for tests/map.rs, independent of mavterm's code: for each JSON line
{"a": [lat, lon], "b": [lat, lon]} the haversine distance (metres, sphere of 6371 km) and the
initial bearing (degrees, 0..360) from a to b, as the textbook (Sinnott 1984; Williams'
Aviation Formulary) gives them, one JSON line each."""
import json
import math
import sys

R = 6371000.0

for line in sys.stdin:
    q = json.loads(line)
    (la1, lo1), (la2, lo2) = q["a"], q["b"]
    p1, p2 = math.radians(la1), math.radians(la2)
    dp = p2 - p1
    dl = math.radians(lo2 - lo1)
    h = math.sin(dp / 2) ** 2 + math.cos(p1) * math.cos(p2) * math.sin(dl / 2) ** 2
    d = 2 * R * math.asin(min(1.0, math.sqrt(h)))
    y = math.sin(dl) * math.cos(p2)
    x = math.cos(p1) * math.sin(p2) - math.sin(p1) * math.cos(p2) * math.cos(dl)
    b = math.degrees(math.atan2(y, x)) % 360.0
    print(json.dumps({"d": d, "b": b}))
