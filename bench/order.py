#!/usr/bin/env python3
"""The functions an ordinary session runs, for the linker to place together.

Runs each given mavterm binary in a terminal on one simulated ArduCopter (as bench/vehicles.py
does: start-up, the vehicle streaming at its default rates, the Overview drawn, help opened)
under valgrind's callgrind, and writes the linker names of the functions that ran, one a line,
to assets/symbol-order.txt. build.rs hands that list to lld (--symbol-ordering-file) when it
links the binary of an optimised build: the kernel maps code 64 KiB around each page first run,
so code run at idle spread over the whole binary keeps most of it resident.

Names carry a hash of the toolchain, the crate versions and the build profile: make the list
again after any of those changes (a name not found only leaves that function where it was).
Usage: python3 bench/order.py [--binary target/dist/mavterm ...] [--seconds 60]
"""

import argparse
import os
import re
import subprocess
import sys
import tempfile

ROOT = os.path.dirname(os.path.dirname(os.path.abspath(__file__)))


def ran(out_dir):
    """Function names (as the linker knows them) in the callgrind files of `out_dir`."""
    names = set()
    for f in os.listdir(out_dir):
        ids = {}
        with open(os.path.join(out_dir, f), errors="replace") as fh:
            for line in fh:
                m = re.match(r"c?fn=\((\d+)\)(?: (.*))?", line)
                if not m:
                    continue
                if m.group(2):
                    ids[m.group(1)] = m.group(2).strip()
                name = ids.get(m.group(1))
                if name and re.match(r"^[A-Za-z_][\w$.]*$", name):
                    names.add(name)
    return names


def main():
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("--binary", action="append",
                    help="a mavterm binary (repeatable; default target/dist/mavterm and "
                         "target/release/mavterm, those that exist)")
    ap.add_argument("--seconds", type=float, default=60.0,
                    help="how long each runs under valgrind (about 50 times slower)")
    ap.add_argument("--out", default=os.path.join(ROOT, "assets/symbol-order.txt"))
    args = ap.parse_args()
    binaries = args.binary or [
        b for b in (os.path.join(ROOT, "target/dist/mavterm"),
                    os.path.join(ROOT, "target/release/mavterm"))
        if os.path.exists(b)
    ]
    if not binaries:
        sys.exit("no binary: build with `cargo build --profile dist` first")
    names = set()
    for binary in binaries:
        with tempfile.TemporaryDirectory() as tmp:
            wrapper = os.path.join(tmp, "mavterm")
            out_dir = os.path.join(tmp, "out")
            os.mkdir(out_dir)
            with open(wrapper, "w") as w:
                w.write("#!/bin/sh\nexec valgrind --tool=callgrind --demangle=no "
                        f"--callgrind-out-file={out_dir}/cg.%p "
                        f"{os.path.abspath(binary)} \"$@\"\n")
            os.chmod(wrapper, 0o755)
            subprocess.run([sys.executable, os.path.join(ROOT, "bench/vehicles.py"),
                            "--counts", "1", "--warmup", str(args.seconds), "--measure", "5",
                            "--size", "80x24", "--binary", wrapper],
                           check=True, stdout=subprocess.DEVNULL)
            found = ran(out_dir)
            print(f"{binary}: {len(found)} functions ran", file=sys.stderr)
            names |= found
    with open(args.out, "w") as f:
        f.write("".join(n + "\n" for n in sorted(names)))
    print(f"{args.out}: {len(names)} names", file=sys.stderr)


if __name__ == "__main__":
    main()
