"""common.py - what every part shares: the notes of what was skipped, optional modules, running a
command, number formatting."""

import importlib
import subprocess
import time


notes = []  # what was skipped and why, printed at the end and kept in results.json


def note(msg):
    notes.append(msg)
    print("NOTE: " + msg, flush=True)


def optional(module, debian):
    """The module, or None with a note naming the Debian package that provides it."""
    try:
        return importlib.import_module(module)
    except ImportError:
        note(f"{module} is not installed (Debian package {debian}): the parts that need it are "
             "SKIPPED")
        return None


def run(cmd, log):
    """Runs cmd; its stderr goes to the log file; returns (stdout, stderr, seconds)."""
    t = time.perf_counter()
    p = subprocess.run(cmd, capture_output=True, text=True)
    dt = time.perf_counter() - t
    with open(log, "a") as f:
        f.write("$ " + " ".join(cmd) + f"\n# exit {p.returncode}, {dt:.3f} s\n" + p.stderr)
    if p.returncode != 0:
        raise RuntimeError(f"{' '.join(cmd)} failed (exit {p.returncode}):\n{p.stderr[-2000:]}")
    return p.stdout, p.stderr, dt


def mb(b):
    return b / 1e6


def fmt(v, spec):
    return "n/a" if v is None or v == "" else format(v, spec)
