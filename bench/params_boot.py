#!/usr/bin/env python3
"""Time to a complete parameter set from a simulated ArduCopter that has just booted (issue 25).

For each loss level (default 0, 20 and 40 % of the vehicle's frames dropped) and each seed, runs

    mavterm --link 'sim://?loss=L&seed=S' --headless --params-out FILE

The link is only `sim://`, so the run is on mavterm's virtual clock: the simulator boots at 0,
mavterm starts the download on the first heartbeat it hears, and the time mavterm reports
("parameters N/N in X s by METHOD") is virtual time from the download's start, the same on any
machine and load. The wall-clock time of the whole process (start-up, simulation of the first
seconds, file write) is printed too, for information only.

The simulator's calibrations save new values during its first 1.5 s (and the compass declination
at its GPS fix, 4 s), as ArduCopter's do, so a download started at boot meets a
`param.pck?withdefaults=1` whose layout moves while it is read. A run counts as complete only
with exit 0 and FILE holding the expected count of distinct names; the method (MAVFTP or the
parameter protocol, after falling back) is shown for each run.

Standard library only. See bench/README.md.
"""

import argparse
import os
import re
import statistics
import subprocess
import sys
import tempfile
import time

REPO = os.path.dirname(os.path.dirname(os.path.abspath(__file__)))
RE_DONE = re.compile(r"parameters (\d+)/(\d+) in ([0-9.]+) s by (MAVFTP|parameter protocol)")
RE_LEFT = re.compile(r"MAVFTP left: (.*)\)$")


def names_in(path):
    """Distinct parameter names in a NAME VALUE / NAME,VALUE file."""
    names = set()
    with open(path) as f:
        for line in f:
            line = line.split("#")[0].replace(",", " ").split()
            if len(line) >= 2:
                names.add(line[0])
    return names


def run_once(binary, loss, seed, expect, timeout):
    query = "loss=%s&seed=%d" % (loss, seed)
    with tempfile.TemporaryDirectory() as tmp:
        out = os.path.join(tmp, "params.parm")
        argv = [binary, "--link", "sim://?" + query, "--headless", "--params-out", out]
        env = dict(os.environ, HOME=tmp)
        t0 = time.monotonic()
        try:
            p = subprocess.run(argv, capture_output=True, text=True, timeout=timeout, cwd=tmp,
                               env=env, stdin=subprocess.DEVNULL)
        except subprocess.TimeoutExpired:
            return {"query": query, "ok": False, "why": "timeout"}
        wall = time.monotonic() - t0
        lines = [l for l in p.stderr.splitlines() if RE_DONE.search(l)]
        if p.returncode != 0 or not lines:
            tail = p.stderr.strip().splitlines()[-1:] or ["no output"]
            return {"query": query, "ok": False, "why": "exit %d: %s" % (p.returncode, tail[0])}
        m = RE_DONE.search(lines[-1])
        got, total, secs, method = int(m.group(1)), int(m.group(2)), float(m.group(3)), m.group(4)
        left = RE_LEFT.search(lines[-1])
        n = len(names_in(out)) if os.path.exists(out) else 0
        ok = got == total == expect and n == expect
        return {"query": query, "ok": ok, "secs": secs, "wall": wall, "method": method,
                "left": left.group(1) if left else None,
                "why": None if ok else "%d/%d, %d names in the file" % (got, total, n)}


def main():
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--mavterm", default=os.path.join(REPO, "target", "release", "mavterm"),
                    help="binary (default target/release/mavterm, else target/debug/mavterm)")
    ap.add_argument("--loss", action="append", help="loss level, repeatable (default 0 0.2 0.4)")
    ap.add_argument("--seeds", type=int, default=10, help="seeds 1..N per level (default 10)")
    ap.add_argument("--expect", type=int, default=1354, help="parameters expected (default 1354)")
    ap.add_argument("--timeout", type=float, default=300, help="seconds a run may take (wall)")
    args = ap.parse_args()
    binary = os.path.abspath(args.mavterm)
    if not os.path.exists(binary):
        debug = os.path.join(REPO, "target", "debug", "mavterm")
        if binary.endswith(os.path.join("release", "mavterm")) and os.path.exists(debug):
            binary = debug
        else:
            sys.exit("no binary at %s: cargo build --release --bin mavterm" % binary)
    losses = args.loss or ["0", "0.2", "0.4"]
    print("binary: %s" % binary, file=sys.stderr)
    failed = 0
    rows = []
    for loss in losses:
        runs = []
        for seed in range(1, args.seeds + 1):
            r = run_once(binary, loss, seed, args.expect, args.timeout)
            runs.append(r)
            if r["ok"]:
                extra = "; MAVFTP left: %s" % r["left"] if r["left"] else ""
                print("  %-20s %6.2f s (virtual) by %s, %.2f s wall%s"
                      % (r["query"], r["secs"], r["method"], r["wall"], extra), file=sys.stderr)
            else:
                failed += 1
                print("  %-20s FAILED: %s" % (r["query"], r["why"]), file=sys.stderr)
        ok = [r for r in runs if r["ok"]]
        secs = [r["secs"] for r in ok]
        rows.append((loss, secs, sum(1 for r in ok if r["method"] == "MAVFTP"), len(runs) - len(ok),
                     statistics.median([r["wall"] for r in ok]) if ok else float("nan")))
    print("%-6s %8s %8s %8s %8s %6s %7s %10s" % ("loss", "median", "mean", "max", "min", "ftp", "failed",
                                                "wall med"))
    for loss, secs, ftp, bad, wall in rows:
        if secs:
            print("%-6s %8.2f %8.2f %8.2f %8.2f %3d/%-2d %7d %9.2fs" % (
                loss, statistics.median(secs), statistics.mean(secs), max(secs), min(secs), ftp,
                len(secs), bad, wall))
        else:
            print("%-6s %8s %8s %8s %8s %6s %7d" % (loss, "-", "-", "-", "-", "-", bad))
    print("(seconds of the virtual clock from the download's start; `ftp`: runs that ended by MAVFTP)")
    sys.exit(1 if failed else 0)


if __name__ == "__main__":
    main()
