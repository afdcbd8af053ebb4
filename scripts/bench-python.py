#!/usr/bin/env python3
"""Whole-process time of SLAM driven from Python against slam-run on the same rawlog (doc/python.md, "Speed").

    /usr/bin/python3 scripts/bench-python.py [--runs 5] [--rawlog R] [--work DIR] [--build build] [--set S.k=v ...]

Runs `slam-run --config C --rawlog R --out DIR -q` and `python3 examples/python/run_rawlog.py C R --out DIR` in
alternating order (slam-run first in even rounds, Python first in odd ones), each as a whole process: wall time from
start to exit, CPU time (user + system, every thread) and peak memory from the kernel's accounting. Checks after
every round that both wrote the same trajectory.txt bytes. Without --rawlog it renders the 300-frame room sequence
once into --work. A benchmark, not a test: it asserts nothing about speed.
"""
import argparse
import json
import os
import pathlib
import statistics
import subprocess
import sys
import time

ROOT = pathlib.Path(__file__).resolve().parents[1]


def timed(command, env=None):
    """(wall s, cpu s, peak RSS MiB) of one process."""
    start = time.monotonic()
    p = subprocess.Popen(command, stdout=subprocess.DEVNULL, stderr=subprocess.PIPE, env=env)
    _, status, usage = os.wait4(p.pid, 0)
    wall = time.monotonic() - start
    err = p.stderr.read().decode()
    p.stderr.close()
    if os.waitstatus_to_exitcode(status) != 0:
        sys.exit(f"bench-python: {' '.join(map(str, command))} failed:\n{err}")
    return wall, usage.ru_utime + usage.ru_stime, usage.ru_maxrss / 1024.0


def spread(values):
    return f"{min(values):7.2f} {statistics.median(values):7.2f} {max(values):7.2f}"


def main():
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--runs", type=int, default=5, help="rounds (each runs both once)")
    parser.add_argument("--rawlog", help="rawlog to run on (default: the room sequence, rendered into --work)")
    parser.add_argument("--config", default=str(ROOT / "config/slam/synthetic.ini"))
    parser.add_argument("--set", action="append", default=[], help="Section.key=value for both")
    parser.add_argument("--work", default="/tmp/priorslam-bench-python")
    parser.add_argument("--build", default=str(ROOT / "build"))
    parser.add_argument("--python", default=sys.executable, help="interpreter of the Python runs")
    parser.add_argument("--json", help="write the samples and the summary here")
    args = parser.parse_args()

    work = pathlib.Path(args.work)
    build = pathlib.Path(args.build).resolve()
    rawlog = args.rawlog
    if not rawlog:
        rawlog = work / "data" / "room.rawlog"
        if not rawlog.exists():
            subprocess.run([build / "bin" / "slam-synth", "--scenario", "room", "--out", work / "data", "--quiet"],
                           check=True)
    sets = [a for s in args.set for a in ("--set", s)]
    env = dict(os.environ, PYTHONPATH=str(build / "python"))
    commands = {
        "slam-run": [build / "bin" / "slam-run", "--config", args.config, "--rawlog", rawlog, "--out",
                     work / "slam-run", "-q", *sets],
        "python": [args.python, ROOT / "examples/python/run_rawlog.py", args.config, rawlog, "--out", work / "python",
                   *sets],
    }
    samples = {name: [] for name in commands}
    for k in range(args.runs):
        order = ["slam-run", "python"] if k % 2 == 0 else ["python", "slam-run"]
        for name in order:
            samples[name].append(timed(commands[name], env))
        same = (work / "slam-run/trajectory.txt").read_bytes() == (work / "python/trajectory.txt").read_bytes()
        if not same:
            sys.exit(f"bench-python: round {k + 1}: the trajectories differ")
        w = {n: samples[n][-1][0] for n in samples}
        print(f"round {k + 1}: slam-run {w['slam-run']:.2f} s, python {w['python']:.2f} s, trajectories identical",
              flush=True)

    print(f"\n{args.runs} rounds on {rawlog} (min median max)")
    print(f"{'':10s} {'wall [s]':>23s} {'cpu [s]':>23s} {'peak [MiB]':>23s}")
    for name, s in samples.items():
        print(f"{name:10s} {spread([x[0] for x in s])} {spread([x[1] for x in s])} {spread([x[2] for x in s])}")
    ratios = [p[0] / r[0] for p, r in zip(samples["python"], samples["slam-run"])]
    cpu_ratios = [p[1] / r[1] for p, r in zip(samples["python"], samples["slam-run"])]
    med = statistics.median(x[0] for x in samples["python"]) / statistics.median(x[0] for x in samples["slam-run"])
    print(f"python / slam-run wall, round by round: {spread(ratios)}; of the medians: {med:.3f}")
    print(f"python / slam-run cpu,  round by round: {spread(cpu_ratios)}")
    if args.json:
        pathlib.Path(args.json).write_text(json.dumps(
            {"rawlog": str(rawlog), "samples": {n: [dict(zip(("wall", "cpu", "peak_mib"), x)) for x in s]
                                                for n, s in samples.items()},
             "wall_ratios": ratios, "cpu_ratios": cpu_ratios, "median_wall_ratio": med}, indent=1) + "\n")


if __name__ == "__main__":
    main()
