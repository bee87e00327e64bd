#!/usr/bin/env python3
"""Onboard log download rate against the link's capacity, on the simulator (virtual clock).

For each scenario, `mavterm --link "sim://?OPTIONS" --headless --logs-out TMP` downloads the
newest log; mavterm prints, on stderr, `log N: BYTES bytes in SECS s = RATE B/s (R requests,
T retries)` (virtual seconds, from the download's start to the file renamed), `links carried
B B/s while downloading` and `listed N logs in SECS s`. The capacity of a `baud=B` link is B/10
bytes a second (a UART: 10 bits a byte); LOG_DATA carries 90 bytes of log in 109 on the wire
(MAVLink 2), so at most 82.6 % of it can be log, less what the telemetry streams take. Prints
one line per scenario: the rate and its fraction of the capacity, how full the link was
(`link`: what mavterm heard; lost frames are not heard), the rest of what it carried (`other`:
the telemetry, and chunks heard twice), the log's share of what that rest left free (`of free`:
90/109 at most), retries;
then the time to list 100 logs. The vehicle itself sends at most one LOG_DATA a 400 Hz loop on
a UART (ArduPilot, no flow control): 36,000 B/s, the bound at 921600 baud. Standard library
only; `cargo build --bin mavterm` first (or --mavterm PATH).
"""

import argparse
import os
import re
import subprocess
import sys
import tempfile

REPO = os.path.dirname(os.path.dirname(os.path.abspath(__file__)))

SCENARIOS = [
    ("57600 baud, 0 % loss", "baud=57600&log_size=200000"),
    ("57600 baud, 20 % loss", "baud=57600&loss=0.2&seed=7&log_size=200000"),
    ("921600 baud, 0 % loss", "baud=921600&log_size=2000000"),
    ("921600 baud, 20 % loss", "baud=921600&loss=0.2&seed=7&log_size=2000000"),
]


def run(mavterm, options, extra=()):
    with tempfile.TemporaryDirectory() as d:
        p = subprocess.run(
            [mavterm, "--link", f"sim://?{options}", "--headless", "--logs-out", d, *extra],
            capture_output=True,
            text=True,
            timeout=600,
        )
        return p.returncode, p.stderr


def main():
    ap = argparse.ArgumentParser()
    ap.add_argument("--mavterm", default=os.path.join(REPO, "target", "debug", "mavterm"))
    a = ap.parse_args()
    ok = True
    print(
        f"{'scenario':<24} {'bytes':>9} {'secs':>8} {'B/s':>8} {'capacity':>9} {'of cap':>7}"
        f" {'link':>6} {'other':>10} {'of free':>8} {'retries':>8}"
    )
    for name, options in SCENARIOS:
        code, err = run(a.mavterm, options)
        m = re.search(r"log \d+: (\d+) bytes in ([\d.]+) s = (\d+) B/s \((\d+) requests, (\d+) retries\)", err)
        baud = int(re.search(r"baud=(\d+)", options).group(1))
        cap = baud / 10
        if code != 0 or not m:
            ok = False
            print(f"{name:<24} FAILED: {err.strip().splitlines()[-1:]}")
            continue
        b, secs, rate, _req, retries = m.groups()
        c = re.search(r"links carried (\d+) B/s while downloading", err)
        carried = int(c.group(1)) if c else float("nan")
        wire = int(rate) * 109 / 90
        other = max(carried - wire, 0)
        free = cap - other
        print(
            f"{name:<24} {b:>9} {float(secs):>8.1f} {rate:>8} {cap:>9.0f} {int(rate) / cap:>6.1%}"
            f" {carried / cap:>5.0%} {other:>8.0f}/s {int(rate) / free:>7.1%} {retries:>8}"
        )
    code, err = run(a.mavterm, "baud=57600&logs=100&log_size=1000", ["--log-ids", "1"])
    m = re.search(r"listed (\d+) logs in ([\d.]+) s \((\d+) requests, (\d+) again\)", err)
    if code != 0 or not m:
        ok = False
        print("list of 100 logs: FAILED")
    else:
        print(f"list of {m.group(1)} logs at 57600 baud: {m.group(2)} s ({m.group(3)} requests)")
    code, err = run(a.mavterm, "baud=57600&loss=0.2&seed=7&logs=100&log_size=1000", ["--log-ids", "1"])
    m = re.search(r"listed (\d+) logs in ([\d.]+) s \((\d+) requests, (\d+) again\)", err)
    if code == 0 and m:
        print(f"list of {m.group(1)} logs at 57600 baud, 20 % loss: {m.group(2)} s ({m.group(3)} requests, {m.group(4)} again)")
    else:
        ok = False
        print("list of 100 logs at 20 % loss: FAILED")
    sys.exit(0 if ok else 1)


if __name__ == "__main__":
    main()
