#!/usr/bin/env python3
"""CPU and memory of one mavterm with many simulated vehicles.

For each vehicle count (default 1, 10, 100, 250) this starts `mavterm sim --listen
tcp:127.0.0.1:PORT --vehicles N` (default rates), then one mavterm on `--link
tcp:127.0.0.1:PORT`: the terminal UI under a pseudo-terminal (200x60 unless --size; its output
read and thrown away, as a terminal would), or `--headless` with --mode headless. After a warm-up
it samples the client's /proc/PID/stat (utime + stime) and VmRSS over the measuring window and
prints, per count: % of one core, RSS at the end and its peak (MB), and the sim's own CPU. The
client records its telemetry log as it does by default (HOME is a temp dir, so the log lands
there). Needs only the Python 3 standard library and a release build:

    cargo build --release --bin mavterm
    python3 bench/vehicles.py                       # 1, 10, 100, 250; 20 s warm-up, 60 s
    python3 bench/vehicles.py --counts 1 --warmup 60 --measure 120   # idle cost, one vehicle
    python3 bench/vehicles.py --counts 1 --client-arg=--no-tlog      # without the telemetry log

Every simulated vehicle streams from boot at --sr Hz a stream group (`sim --options sr=N`,
ArduPilot with its SRn_ rates set; 0 leaves the streams to what mavterm asks for, which it does
for the first vehicles only). In TUI mode, after the measuring window, `?` is pressed and the
time until the help's title is on the terminal is printed (key ms): the UI answering a key.
"""

import argparse
import os
import pty
import re
import signal
import socket
import struct
import subprocess
import sys
import tempfile
import threading
import time

ROOT = os.path.dirname(os.path.dirname(os.path.abspath(__file__)))
TICK = os.sysconf("SC_CLK_TCK")


def free_port():
    s = socket.socket()
    s.bind(("127.0.0.1", 0))
    port = s.getsockname()[1]
    s.close()
    return port


def cpu_ticks(pid):
    with open(f"/proc/{pid}/stat") as f:
        fields = f.read().rsplit(")", 1)[1].split()
    return int(fields[11]) + int(fields[12])  # utime, stime


def rss_kb(pid):
    with open(f"/proc/{pid}/status") as f:
        for line in f:
            if line.startswith("VmRSS:"):
                return int(line.split()[1])
    return 0


def mappings(pid):
    """RSS by mapping (the file's name, or [heap], [stack], anon), kB, largest first."""
    out = {}
    name = None
    try:
        with open(f"/proc/{pid}/smaps") as f:
            for line in f:
                head = line.split()
                if re.match(r"^[0-9a-f]+-[0-9a-f]+ ", line):
                    name = head[5] if len(head) > 5 else "anon"
                elif head and head[0] == "Rss:":
                    out[name] = out.get(name, 0) + int(head[1])
    except OSError:
        pass
    return sorted(out.items(), key=lambda kv: -kv[1])


def memory(pid):
    """RSS split: anonymous (heap, stacks) and file-backed (the binary's pages, libraries), kB;
    and the thread count."""
    out = {}
    try:
        with open(f"/proc/{pid}/smaps_rollup") as f:
            for line in f:
                k, _, v = line.partition(":")
                if k in ("Rss", "Anonymous", "Shared_Clean", "Private_Clean"):
                    out[k] = int(v.split()[0])
        with open(f"/proc/{pid}/status") as f:
            for line in f:
                if line.startswith("Threads:"):
                    out["threads"] = int(line.split()[1])
    except OSError:
        pass
    return out


def wait_port(port, timeout=10.0):
    end = time.time() + timeout
    while time.time() < end:
        try:
            socket.create_connection(("127.0.0.1", port), 0.2).close()
            return True
        except OSError:
            time.sleep(0.05)
    return False


def start_tui(cmd, env, size):
    pid, fd = pty.fork()
    if pid == 0:
        os.execvpe(cmd[0], cmd, env)
    import fcntl
    import termios

    cols, rows = size
    fcntl.ioctl(fd, termios.TIOCSWINSZ, struct.pack("HHHH", rows, cols, 0, 0))
    os.kill(pid, signal.SIGWINCH)

    seen = {"buf": b""}
    lock = threading.Lock()

    def drain():
        while True:
            try:
                data = os.read(fd, 65536)
            except OSError:
                return
            if not data:
                return
            with lock:
                seen["buf"] = (seen["buf"] + data)[-65536:]

    def key_ms(key, marker, timeout=5.0):
        """Press `key`; milliseconds until `marker` is on the terminal (None: not seen)."""
        with lock:
            seen["buf"] = b""
        t0 = time.time()
        os.write(fd, key)
        while time.time() - t0 < timeout:
            with lock:
                if marker in seen["buf"]:
                    return 1000.0 * (time.time() - t0)
            time.sleep(0.001)
        return None

    threading.Thread(target=drain, daemon=True).start()
    return pid, fd, key_ms


def run(binary, n, args):
    port = free_port()
    tmp = tempfile.mkdtemp(prefix="mavterm-vehicles-")
    env = dict(os.environ, HOME=tmp, XDG_CONFIG_HOME=tmp, XDG_DATA_HOME=tmp,
               XDG_CACHE_HOME=tmp, TERM="xterm-256color")
    sim = subprocess.Popen(
        [binary, "sim", "--listen", f"tcp:127.0.0.1:{port}", "--vehicles", str(n),
         "--options", f"sr={args.sr}"],
        stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL, env=env,
        start_new_session=True)
    fd = None
    try:
        if not wait_port(port):
            raise RuntimeError("sim did not listen")
        link = f"tcp:127.0.0.1:{port}"
        key_ms = None
        if args.mode == "tui":
            pid, fd, key_ms = start_tui([binary, "--link", link] + args.client_arg, env,
                                        args.size)
        else:
            total = args.warmup + args.measure + 5
            p = subprocess.Popen(
                [binary, "--headless", "--link", link, "--duration", str(total)]
                + args.client_arg,
                stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL, env=env,
                start_new_session=True)
            pid = p.pid
        time.sleep(args.warmup)
        c0, s0, t0 = cpu_ticks(pid), cpu_ticks(sim.pid), time.time()
        peak = 0
        while time.time() - t0 < args.measure:
            time.sleep(1)
            peak = max(peak, rss_kb(pid))
        c1, s1, t1 = cpu_ticks(pid), cpu_ticks(sim.pid), time.time()
        rss = rss_kb(pid)
        mem = memory(pid)
        key = key_ms(b"?", b" Keys ") if key_ms else None
        if args.smaps:
            for name, kb in mappings(pid)[:8]:
                print(f"  {kb:>7} kB  {name}", file=sys.stderr)
        return {
            "key_ms": key,
            "vehicles": n,
            "cpu_pct": 100.0 * (c1 - c0) / TICK / (t1 - t0),
            "rss_mb": rss / 1024.0,
            "peak_mb": peak / 1024.0,
            "sim_cpu_pct": 100.0 * (s1 - s0) / TICK / (t1 - t0),
            "anon_mb": mem.get("Anonymous", 0) / 1024.0,
            "file_mb": (mem.get("Rss", 0) - mem.get("Anonymous", 0)) / 1024.0,
            "threads": mem.get("threads", 0),
        }
    finally:
        for p in [locals().get("pid")]:
            if p:
                try:
                    os.kill(p, signal.SIGTERM)
                    os.waitpid(p, 0)
                except (OSError, ChildProcessError):
                    pass
        if fd is not None:
            os.close(fd)
        os.killpg(sim.pid, signal.SIGTERM)
        sim.wait()


def main():
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("--binary", default=os.path.join(ROOT, "target/release/mavterm"))
    ap.add_argument("--smaps", action="store_true",
                    help="print the RSS of the largest mappings (stderr)")
    ap.add_argument("--counts", type=int, nargs="+", default=[1, 10, 100, 250])
    ap.add_argument("--warmup", type=float, default=20.0)
    ap.add_argument("--measure", type=float, default=60.0)
    ap.add_argument("--mode", choices=["tui", "headless"], default="tui")
    ap.add_argument("--sr", type=int, default=4,
                    help="each vehicle's stream rate from boot, Hz a group (0: as asked)")
    ap.add_argument("--client-arg", action="append", default=[],
                    help="an argument for the measured mavterm (repeatable)")
    ap.add_argument("--size", type=lambda s: tuple(int(x) for x in s.split("x")),
                    default=(200, 60))
    args = ap.parse_args()
    print(f"{'vehicles':>8} {'cpu %':>7} {'rss MB':>7} {'peak MB':>8} {'sim cpu %':>9} "
          f"{'key ms':>7} {'anon MB':>7} {'file MB':>7} {'threads':>7}")
    for n in args.counts:
        r = run(args.binary, n, args)
        key = "-" if r["key_ms"] is None else f"{r['key_ms']:.0f}"
        print(f"{r['vehicles']:>8} {r['cpu_pct']:>7.2f} {r['rss_mb']:>7.1f} "
              f"{r['peak_mb']:>8.1f} {r['sim_cpu_pct']:>9.2f} {key:>7} "
              f"{r['anon_mb']:>7.1f} {r['file_mb']:>7.1f} {r['threads']:>7}", flush=True)


if __name__ == "__main__":
    sys.exit(main())
