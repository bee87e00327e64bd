#!/usr/bin/env python3
"""Time to a complete parameter set: MAVProxy vs mavterm, against `mavterm sim --listen` over TCP.

For every scenario (a set of `mavterm sim` options) and every run, a fresh simulator is started on
a free loopback port, then one tool downloads the whole parameter set and is timed from its process
start to completion:

* MAVProxy: until it prints `Received N parameters (ftp)` (MAVFTP `@PARAM/param.pck`) or
  `Received N parameters` (PARAM_REQUEST_LIST), N being the expected count. See
  MAVProxy/modules/mavproxy_param.py, `ParamState.ftp_callback` and `handle_mavlink_packet`.
* mavterm: `mavterm --link tcp:127.0.0.1:PORT --headless --params-out FILE` until it exits 0;
  FILE must then hold the expected number of parameters.

A run that does not finish within --timeout seconds is a stall; one that ends badly (non-zero
exit, wrong count, early exit) is a failure. Every child (simulator, MAVProxy, mavterm) runs in its
own process group and is killed on the way out, also on Ctrl-C, SIGTERM and timeouts.

Standard library only. See bench/README.md.
"""

import argparse
import atexit
import json
import os
import queue
import re
import signal
import socket
import statistics
import subprocess
import sys
import tempfile
import threading
import time

REPO = os.path.dirname(os.path.dirname(os.path.abspath(__file__)))

DEFAULT_SCENARIOS = [
    ("clean", ""),
    ("loss20-s7", "loss=0.2&seed=7"),
    ("loss20-s11", "loss=0.2&seed=11"),
    ("loss20-s23", "loss=0.2&seed=23"),
]

# MAVProxy's completion lines (mavproxy_param.py): ftp_callback prints the first, the
# PARAM_VALUE handler the second once len(mav_param_set) == param_count.
RE_MP_DONE = re.compile(r"Received (\d+) parameters( \(ftp\))?")
RE_MP_SAVED = re.compile(r"Saved (\d+) parameters to (.+)$")
RE_MP_HEARTBEAT = re.compile(r"Detected vehicle \d+:\d+ on link")

# ---------------------------------------------------------------------------------------------
# Child processes: always cleaned up.

_children = []  # live subprocess.Popen objects, each the leader of its own process group
_children_lock = threading.Lock()


def spawn(argv, **kw):
    """Start argv in a new process group and remember it for cleanup."""
    p = subprocess.Popen(argv, start_new_session=True, stdin=subprocess.DEVNULL, **kw)
    with _children_lock:
        _children.append(p)
    return p


def kill(p, grace=2.0):
    """SIGTERM the process group, then SIGKILL after `grace` seconds; reap it."""
    if p is None:
        return
    try:
        if p.poll() is None:
            try:
                os.killpg(p.pid, signal.SIGTERM)
            except ProcessLookupError:
                pass
            try:
                p.wait(timeout=grace)
            except subprocess.TimeoutExpired:
                pass
        # Whatever is left in the group (helpers, or a leader that ignored SIGTERM).
        try:
            os.killpg(p.pid, signal.SIGKILL)
        except (ProcessLookupError, PermissionError):
            pass
        try:
            p.wait(timeout=5)
        except subprocess.TimeoutExpired:
            pass
    finally:
        with _children_lock:
            if p in _children:
                _children.remove(p)


def kill_all():
    with _children_lock:
        live = list(_children)
    for p in live:
        kill(p, grace=0.5)


def _on_signal(signum, _frame):
    # Turn SIGTERM/SIGHUP into an exception so every `finally` runs.
    raise KeyboardInterrupt(f"signal {signum}")


atexit.register(kill_all)

# ---------------------------------------------------------------------------------------------
# Simulator.


def free_port():
    with socket.socket(socket.AF_INET, socket.SOCK_STREAM) as s:
        s.bind(("127.0.0.1", 0))
        return s.getsockname()[1]


class SimError(Exception):
    pass


def start_sim(mavterm, options, workdir):
    """Start `mavterm sim --listen tcp:127.0.0.1:PORT` and wait until it accepts connections."""
    for _attempt in range(5):
        port = free_port()
        log_path = os.path.join(workdir, f"sim-{port}.log")
        log = open(log_path, "wb")
        argv = [mavterm, "sim", "--listen", f"tcp:127.0.0.1:{port}"]
        if options:
            argv += ["--options", options]
        p = spawn(argv, stdout=log, stderr=subprocess.STDOUT)
        log.close()
        deadline = time.monotonic() + 15
        while time.monotonic() < deadline:
            if p.poll() is not None:
                break
            try:
                # A probe connection; the sim forgets a client whose socket has closed.
                with socket.create_connection(("127.0.0.1", port), timeout=0.2):
                    pass
                return p, port, log_path
            except OSError:
                time.sleep(0.05)
        kill(p)
        text = read_tail(log_path).split("Stack backtrace:")[0]
        if "Address already in use" in text:
            continue  # lost the race for the port: try another
        raise SimError(f"sim did not come up ({' '.join(argv)}): {text.strip() or 'no output'}")
    raise SimError("sim: no free port after 5 attempts")


def read_tail(path, limit=4000):
    try:
        with open(path, "rb") as f:
            data = f.read()
    except OSError:
        return ""
    return data[-limit:].decode("utf-8", "replace")


# ---------------------------------------------------------------------------------------------
# One run of each tool. Each returns a dict: status ok|stall|fail, secs, detail.


def run_mavproxy(args, port, workdir):
    """MAVProxy, non-interactive, offline, state in a temp dir, only the ftp and param modules."""
    state = tempfile.mkdtemp(prefix="mavproxy-", dir=workdir)
    argv = [
        args.mavproxy,
        "--master", f"tcp:127.0.0.1:{port}",
        "--non-interactive",
        "--default-modules", args.mavproxy_modules,
        "--state-basedir", state,
        "--aircraft", "bench",
    ]
    cmds = []
    if args.mavproxy_no_ftp:
        cmds.append("set param_ftp 0")
    if args.mavproxy_ftp_debug:
        cmds.append(f"ftp set debug {args.mavproxy_ftp_debug}")
    if cmds:
        argv += ["--cmd", ";".join(cmds)]
    env = dict(os.environ)
    env["PYTHONUNBUFFERED"] = "1"
    env["HOME"] = state  # no ~/.mavinit.scr, ~/.mavproxy/ of the user's
    env.pop("DISPLAY", None)
    env["MPLBACKEND"] = "Agg"
    log_path = os.path.join(workdir, f"mavproxy-{port}.log")
    lines = queue.Queue()
    t0 = time.monotonic()
    p = spawn(argv, stdout=subprocess.PIPE, stderr=subprocess.STDOUT, cwd=state, env=env)

    def reader():
        with open(log_path, "w") as log:
            for raw in iter(p.stdout.readline, b""):
                t = time.monotonic() - t0
                line = raw.decode("utf-8", "replace").rstrip("\r\n")
                log.write(f"{t:8.3f} {line}\n")
                log.flush()
                lines.put((t, line))
        lines.put((time.monotonic() - t0, None))

    th = threading.Thread(target=reader, daemon=True)
    th.start()
    res = {"status": "stall", "secs": None, "detail": "", "log": log_path}
    try:
        deadline = t0 + args.timeout
        while True:
            left = deadline - time.monotonic()
            if left <= 0:
                res.update(status="stall", secs=args.timeout,
                           detail=f"no complete set within {args.timeout:g}s")
                break
            try:
                t, line = lines.get(timeout=min(left, 0.5))
            except queue.Empty:
                continue
            if line is None:
                res.update(status="fail", secs=t,
                           detail=f"mavproxy exited (rc={p.wait()}) before a complete set")
                break
            if RE_MP_HEARTBEAT.search(line) and "heartbeat" not in res:
                res["heartbeat"] = t
            m = RE_MP_DONE.search(line)
            if m:
                n = int(m.group(1))
                res["via"] = "ftp" if m.group(2) else "list"
                if n != args.expect:
                    res.update(status="fail", secs=t,
                               detail=f"MAVProxy received {n} parameters, expected {args.expect}")
                else:
                    res.update(status="ok", secs=t)
                # Not timed: wait briefly for the saved mav.parm, to check the count independently.
                wait_until = time.monotonic() + 3
                while time.monotonic() < wait_until:
                    try:
                        _, line = lines.get(timeout=0.2)
                    except queue.Empty:
                        continue
                    if line is None:
                        break
                    s = RE_MP_SAVED.search(line)
                    if s:
                        names = count_param_file(s.group(2).strip())
                        res["file_params"] = names
                        if res["status"] == "ok" and names != args.expect:
                            res.update(status="fail",
                                       detail=f"mav.parm has {names} parameters, expected {args.expect}")
                        break
                break
    finally:
        kill(p)
        th.join(timeout=5)
    if res["status"] != "ok":
        res["tail"] = read_tail(log_path, 3000)
    return res


def count_param_file(path):
    """Distinct parameter names in a params file: NAME VALUE / NAME,VALUE lines, or JSON."""
    try:
        with open(path, "r", encoding="utf-8", errors="replace") as f:
            text = f.read()
    except OSError:
        return -1
    stripped = text.lstrip()
    if stripped.startswith("{") or stripped.startswith("["):
        try:
            doc = json.loads(text)
        except ValueError:
            doc = None
        if isinstance(doc, dict):
            for key in ("params", "parameters"):
                if isinstance(doc.get(key), (dict, list)):
                    doc = doc[key]
                    break
        if isinstance(doc, dict):
            return len(doc)
        if isinstance(doc, list):
            names = set()
            for e in doc:
                if isinstance(e, dict):
                    names.add(e.get("name") or e.get("id") or e.get("param_id"))
            names.discard(None)
            return len(names) if names else len(doc)
    names = set()
    for line in text.splitlines():
        line = line.split("#", 1)[0].strip()
        if not line:
            continue
        name = re.split(r"[\s,=\t]+", line, maxsplit=1)[0]
        # QGC-style "sysid compid NAME VALUE TYPE" lines: take the name column.
        cols = line.split()
        if len(cols) >= 4 and cols[0].isdigit() and cols[1].isdigit():
            name = cols[2]
        if re.fullmatch(r"[A-Za-z][A-Za-z0-9_]*", name):
            names.add(name)
    return len(names)


class Unsupported(Exception):
    pass


def run_mavterm(args, port, workdir):
    """mavterm --headless --params-out FILE, timed to exit 0; FILE must hold the expected set."""
    out = os.path.join(workdir, f"params-{port}.out")
    err_path = os.path.join(workdir, f"mavterm-{port}.log")
    argv = [args.mavterm_client or args.mavterm, "--link", f"tcp:127.0.0.1:{port}", "--headless", "--params-out", out]
    argv += args.mavterm_arg
    res = {"status": "stall", "secs": None, "detail": "", "log": err_path}
    with open(err_path, "wb") as err:
        t0 = time.monotonic()
        p = spawn(argv, stdout=err, stderr=subprocess.STDOUT, cwd=workdir)
        try:
            try:
                rc = p.wait(timeout=args.timeout)
                secs = time.monotonic() - t0
            except subprocess.TimeoutExpired:
                res.update(status="stall", secs=args.timeout,
                           detail=f"still running after {args.timeout:g}s")
                rc = None
        finally:
            kill(p)
    if rc is not None:
        text = read_tail(err_path)
        if rc != 0:
            res.update(status="fail", secs=secs, detail=f"exit {rc}")
            if rc == 2 and ("unexpected argument" in text or "unrecognized" in text):
                res["tail"] = text
                raise Unsupported(
                    "this mavterm has no `--headless --params-out` yet "
                    f"({' '.join(argv)} exited 2):\n{text.strip()}")
        else:
            n = count_param_file(out)
            res["file_params"] = n
            if n != args.expect:
                res.update(status="fail", secs=secs,
                           detail=f"{out} has {n} parameters, expected {args.expect}"
                           if n >= 0 else f"exit 0 but no {out}")
            else:
                res.update(status="ok", secs=secs)
    if res["status"] != "ok":
        res["tail"] = read_tail(err_path, 3000)
    return res


# ---------------------------------------------------------------------------------------------
# Table.


def summarize(runs, timeout):
    """(median, max) over the runs that ended (ok) or stalled (counted at the timeout)."""
    vals = [r["secs"] for r in runs if r["status"] in ("ok", "stall")]
    if not vals:
        return None, None, False
    stalled = any(r["status"] == "stall" for r in runs)
    return statistics.median(vals), max(vals), stalled


def fmt_run(r):
    if r["status"] == "ok":
        return f"{r['secs']:.2f}"
    if r["status"] == "stall":
        return f">{r['secs']:g}"
    return "FAIL"


def fmt_stat(v, stalled, timeout):
    if v is None:
        return "-"
    if stalled and v >= timeout:
        return f">{v:g}"
    return f"{v:.2f}"


def print_table(results, args, out=sys.stdout):
    rows = [("scenario", "tool", "runs (s)", "median", "max", "stalls", "fails")]
    ratios = []
    for scen, opts in args.scenarios:
        med = {}
        for tool in args.tools:
            runs = results.get((scen, tool))
            if runs is None:
                continue
            m, mx, stalled = summarize(runs, args.timeout)
            med[tool] = (m, stalled)
            rows.append((
                scen, tool, " ".join(fmt_run(r) for r in runs) or "-",
                fmt_stat(m, stalled, args.timeout), fmt_stat(mx, stalled, args.timeout),
                str(sum(r["status"] == "stall" for r in runs)),
                str(sum(r["status"] == "fail" for r in runs)),
            ))
        if "mavproxy" in med and "mavterm" in med and med["mavproxy"][0] and med["mavterm"][0]:
            r = med["mavterm"][0] / med["mavproxy"][0]
            approx = " (a median includes a stall)" if med["mavproxy"][1] or med["mavterm"][1] else ""
            ratios.append(f"{scen}: mavterm median / MAVProxy median = {r:.2f}{approx}")
    widths = [max(len(row[i]) for row in rows) for i in range(len(rows[0]))]
    for k, row in enumerate(rows):
        print("  ".join(c.ljust(w) for c, w in zip(row, widths)).rstrip(), file=out)
        if k == 0:
            print("  ".join("-" * w for w in widths), file=out)
    if ratios:
        print(file=out)
        for line in ratios:
            print(line, file=out)


# ---------------------------------------------------------------------------------------------


def parse_args(argv):
    ap = argparse.ArgumentParser(
        description="Time to a complete parameter set, MAVProxy vs mavterm, against "
                    "`mavterm sim --listen` over TCP.")
    ap.add_argument("--runs", type=int, default=5, help="runs per scenario and tool (default 5)")
    ap.add_argument("--timeout", type=float, default=120.0,
                    help="seconds before a run counts as a stall (default 120)")
    ap.add_argument("--tools", default="mavproxy,mavterm",
                    help="comma-separated: mavproxy, mavterm (default both)")
    ap.add_argument("--mavterm", default=os.path.join(REPO, "target", "release", "mavterm"),
                    help="mavterm binary, for the sim and the mavterm side "
                         "(default target/release/mavterm)")
    ap.add_argument("--mavterm-client", metavar="PATH",
                    help="mavterm binary for the mavterm side only (default: --mavterm)")
    ap.add_argument("--mavproxy",
                    default=os.path.join(REPO, "target", "bench-venv", "bin", "mavproxy.py"),
                    help="mavproxy.py (default target/bench-venv/bin/mavproxy.py)")
    ap.add_argument("--scenario", action="append", default=[], metavar="NAME:OPTIONS",
                    help="a scenario, repeatable, e.g. 'loss20-s7:loss=0.2&seed=7' or 'clean:'; "
                         "replaces the defaults (" +
                         ", ".join(f"{n}:{o}" for n, o in DEFAULT_SCENARIOS) + ")")
    ap.add_argument("--expect", type=int, default=1354,
                    help="parameters in a complete set (default 1354, the sim's ArduCopter)")
    ap.add_argument("--mavproxy-modules", default="ftp,param",
                    help="MAVProxy --default-modules (default ftp,param: no terrain, no GUI)")
    ap.add_argument("--mavproxy-no-ftp", action="store_true",
                    help="MAVProxy: `set param_ftp 0`, i.e. PARAM_REQUEST_LIST only")
    ap.add_argument("--mavproxy-ftp-debug", type=int, default=0,
                    help="MAVProxy: `ftp set debug N` (2 traces every FTP op); logs are kept "
                         "with --keep")
    ap.add_argument("--mavterm-arg", action="append", default=[],
                    help="extra argument for the mavterm side, repeatable")
    ap.add_argument("--keep", metavar="DIR",
                    help="keep logs and outputs in DIR (default: a temp dir, removed)")
    ap.add_argument("--json", metavar="FILE", help="also write every run's result to FILE")
    args = ap.parse_args(argv)
    args.tools = [t.strip() for t in args.tools.split(",") if t.strip()]
    for t in args.tools:
        if t not in ("mavproxy", "mavterm"):
            ap.error(f"--tools: unknown tool `{t}` (mavproxy, mavterm)")
    if args.runs < 1:
        ap.error("--runs must be at least 1")
    if args.scenario:
        args.scenarios = []
        for s in args.scenario:
            name, sep, opts = s.partition(":")
            if not sep or not name:
                ap.error(f"--scenario `{s}`: expected NAME:OPTIONS")
            args.scenarios.append((name, opts))
    else:
        args.scenarios = list(DEFAULT_SCENARIOS)
    if not os.access(args.mavterm, os.X_OK):
        ap.error(f"--mavterm {args.mavterm}: not an executable "
                 "(cargo build --release --bin mavterm)")
    if "mavproxy" in args.tools and not os.path.exists(args.mavproxy):
        ap.error(f"--mavproxy {args.mavproxy}: not found (see bench/README.md to install it)")
    return args


def main(argv=None):
    args = parse_args(argv)
    # Also when started where SIGINT is ignored (a background job of a script).
    signal.signal(signal.SIGINT, signal.default_int_handler)
    signal.signal(signal.SIGTERM, _on_signal)
    signal.signal(signal.SIGHUP, _on_signal)
    if args.keep:
        os.makedirs(args.keep, exist_ok=True)
        workdir, tmp = os.path.abspath(args.keep), None
    else:
        tmp = tempfile.TemporaryDirectory(prefix="params-race-")
        workdir = tmp.name
    results = {}
    unsupported = None
    interrupted = False
    try:
        for scen, opts in args.scenarios:
            for tool in args.tools:
                if tool == "mavterm" and unsupported:
                    continue
                runs = results.setdefault((scen, tool), [])
                for i in range(args.runs):
                    sim = None
                    try:
                        sim, port, sim_log = start_sim(args.mavterm, opts, workdir)
                        if tool == "mavproxy":
                            r = run_mavproxy(args, port, workdir)
                        else:
                            r = run_mavterm(args, port, workdir)
                        if sim.poll() is not None:
                            r.update(status="fail", detail=(r.get("detail") or "") +
                                     f"; the sim died: {read_tail(sim_log).strip()}")
                    except SimError as e:
                        # Deterministic (bad options, no binary): no use trying again.
                        runs.append({"status": "fail", "secs": None, "detail": str(e)})
                        print(f"[{scen}] {tool}: {e}", file=sys.stderr, flush=True)
                        break
                    except Unsupported as e:
                        unsupported = str(e)
                        print(f"[{scen}] mavterm: {e}", file=sys.stderr)
                        results.pop((scen, tool), None)
                        break
                    finally:
                        kill(sim)
                    runs.append(r)
                    extra = ""
                    if r.get("via"):
                        extra += f" via {r['via']}"
                    if r.get("file_params") is not None:
                        extra += f", {r['file_params']} in its file"
                    if r.get("heartbeat") is not None:
                        extra += f", heartbeat at {r['heartbeat']:.2f}s"
                    if r.get("detail"):
                        extra += f"; {r['detail']}"
                    print(f"[{scen}] {tool} run {i + 1}/{args.runs}: {fmt_run(r)}{extra}",
                          file=sys.stderr, flush=True)
                    if r["status"] != "ok" and r.get("tail"):
                        tail = "\n".join("    " + l for l in r["tail"].rstrip().splitlines()[-15:])
                        print(f"    last output ({r.get('log')}):\n{tail}",
                              file=sys.stderr, flush=True)
    except KeyboardInterrupt:
        interrupted = True
        print("\ninterrupted: cleaning up", file=sys.stderr)
    finally:
        kill_all()
    sys.stderr.flush()
    print()
    print(f"Time to a complete parameter set ({args.expect}), seconds from process start; "
          f"'>{args.timeout:g}' = stall (counted at the timeout), FAIL = ended without a "
          "complete set (left out of median/max).")
    print_table(results, args)
    if unsupported:
        print(f"\nmavterm side not run: {unsupported.splitlines()[0]}")
    if args.json:
        with open(args.json, "w") as f:
            json.dump([{"scenario": s, "options": dict(args.scenarios).get(s), "tool": t,
                        "runs": [{k: v for k, v in r.items() if k != "tail"} for r in rs]}
                       for (s, t), rs in results.items()], f, indent=2)
    sys.stdout.flush()
    if tmp is not None:
        tmp.cleanup()
    if interrupted:
        return 130
    bad = unsupported is not None or any(
        r["status"] != "ok" for rs in results.values() for r in rs)
    return 1 if bad else 0


if __name__ == "__main__":
    sys.exit(main())
