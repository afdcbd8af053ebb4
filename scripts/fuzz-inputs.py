#!/usr/bin/env python3
"""Seeded mutation fuzzing of the built tools on rawlogs and maps (doc/reliability.md, "Fuzzing the tools").

Usage: python3 scripts/fuzz-inputs.py [--build build] [--rawlog-mutants 2000] [--map-mutants 2000] [--seed 1]
                                      [--jobs 2] [--timeout 60] [--work DIR] [--crash-file FILE] [--json REPORT]

Makes a small valid rawlog (slam-synth: the room, 160x120, with depth, normals and labels) and a map (slam-run on a
rendered room clip), then mutates each: half of the mutants in the file's bytes (the gzip CRC-32 then fails, or the
header breaks), half in the decompressed archive, compressed again (valid checksums: the archive's own sizes and
counts reach the readers). Mutations: 1-4 XORed bytes, a cut, zeros to the end, a zeroed range, inserted or deleted
bytes, a 32-bit field set to a large value. Each mutant is given to one tool in turn (every rawlog-reading tool, every
map-reading subcommand; slam-run --map-in for one map mutant in ten), under a time limit. slam-run and bench-slam run
without place recognition (no trained vocabulary needed).

Every run is one of:
  read       exit code 0
  refused    exit code 1 and one line on stderr, `<tool>: error: <message>`, the message naming the file
  bad-error  a non-zero exit code with more than one line, or a line that does not name the file
  crash      ended by a signal (SIGSEGV, SIGABRT, ...) or exit code >= 128
  hang       still running at --timeout seconds (then killed)
The crash file (--crash-file, default ../shared/repro/rawlog_depth_size_segfault/min.rawlog when present) is run
through every rawlog tool first. Exit code 0 when there is no crash, hang or bad-error; 1 otherwise. The same seed
gives the same mutants.
"""
import argparse
import concurrent.futures
import gzip
import json
import os
import random
import shutil
import signal
import struct
import subprocess
import sys
import tempfile
import time

ROOT = os.path.dirname(os.path.dirname(os.path.abspath(__file__)))
CONFIG = os.path.join(ROOT, "config", "slam", "synthetic.ini")
# Without place recognition: the runs are about reading inputs, and need no trained vocabulary.
NO_PLACES = ["--set", "Places.vocabulary=", "--set", "LoopClosing.enabled=false"]


def mutate(data: bytes, rng: random.Random):
    s = bytearray(data)
    kind = rng.randrange(7)
    pos = lambda n: rng.randrange(max(n, 1))
    if kind == 0:
        what = "xor"
        for _ in range(rng.randint(1, 4)):
            at = pos(len(s))
            s[at] ^= rng.randint(1, 255)
            what += f" @{at}"
    elif kind == 1:
        at = pos(len(s))
        del s[at:]
        what = f"cut @{at}"
    elif kind == 2:
        at = pos(len(s))
        s[at:] = bytes(len(s) - at)
        what = f"zeros from @{at}"
    elif kind == 3:
        at = pos(len(s))
        n = min(len(s) - at, rng.randint(1, 64))
        s[at:at + n] = bytes(n)
        what = f"zero {n} @{at}"
    elif kind == 4:
        at = pos(len(s) + 1)
        n = rng.randint(1, 16)
        s[at:at] = bytes(rng.randrange(256) for _ in range(n))
        what = f"insert {n} @{at}"
    elif kind == 5:
        at = pos(len(s))
        n = min(len(s) - at, rng.randint(1, 16))
        del s[at:at + n]
        what = f"delete {n} @{at}"
    else:  # a size or count field made large: what crashed MRPT's readers
        at = pos(max(len(s) - 4, 1))
        value = rng.choice([0xFEFEFEFE, 0x80000000, 0x7FFFFFFF, 65536, 1 << 20, rng.randrange(1 << 32)])
        s[at:at + 4] = struct.pack("<I", value)
        what = f"u32 {value:#x} @{at}"
    return bytes(s), what


def run(cmd, path, timeout):
    """Runs one tool; returns (class, detail)."""
    start = time.monotonic()
    try:
        p = subprocess.run(cmd, stdin=subprocess.DEVNULL, stdout=subprocess.DEVNULL, stderr=subprocess.PIPE,
                           timeout=timeout, start_new_session=True)
    except subprocess.TimeoutExpired as e:
        return "hang", f"still running after {timeout} s"
    err = p.stderr.decode("utf-8", "replace")
    lines = [l for l in err.split("\n") if l.strip()]
    tool = os.path.basename(cmd[0])
    if p.returncode < 0 or p.returncode >= 128:
        sig = -p.returncode if p.returncode < 0 else p.returncode - 128
        return "crash", f"signal {sig}: {err[-300:]}"
    if p.returncode == 0:
        return "read", ""
    # OpenCV and MRPT warnings ("[ WARN:...]", "[CObservation3DRangeScan] Warning") are not errors; the error line
    # is the tool's own.
    # Progress and warning lines of the tool itself (`<tool>: ...`) and OpenCV's / MRPT's warnings are no error
    # output; anything else (a second error line, an exception banner) is.
    errors = [l for l in lines if l.startswith(tool + ": error: ")]
    others = [l for l in lines if not l.startswith(tool + ": ") and "WARN" not in l and "Warning" not in l]
    if len(errors) == 1 and not others and path in errors[0]:
        return "refused", errors[0]
    return "bad-error", f"exit {p.returncode}: {err[-500:]}"


def rawlog_commands(build, rawlog, out):
    b = lambda t: os.path.join(build, "bin", t)
    return [
        [b("slam-run"), "--config", CONFIG, *NO_PLACES, "--rawlog", rawlog, "--out", os.path.join(out, "slam"), "-q"],
        [b("normal-priors"), rawlog, os.path.join(out, "n", "n.rawlog"), "-q"],
        [b("vocab-train"), "--rawlog", rawlog, "--out", os.path.join(out, "v.pvoc"), "-q", "--depth", "2"],
        [b("bench-slam"), "--config", CONFIG, *NO_PLACES, "--rawlog", rawlog],
        [b("manhattan-eval"), rawlog, "--json", os.path.join(out, "m.json")],
        [b("match-oracle"), rawlog, "--config", CONFIG],
    ]


def map_commands(build, mapfile, out, rawlog, k):
    b = lambda t: os.path.join(build, "bin", t)
    cmds = [
        [b("slam-map"), "info", mapfile],
        [b("slam-map"), "residuals", mapfile],
        [b("slam-map"), "export", mapfile, "--png", os.path.join(out, "top.png"), "--ply", os.path.join(out, "p.ply")],
    ]
    if k % 20 >= 18:  # one in ten, of both kinds
        return [b("slam-run"), "--config", CONFIG, *NO_PLACES, "--rawlog", rawlog, "--last", "4", "--map-in", mapfile,
                "--out", os.path.join(out, "slam"), "-q"]
    return cmds[(k // 2) % len(cmds)]


def copy_images(src_rawlog, dst_rawlog):
    src = os.path.splitext(src_rawlog)[0] + "_Images"
    dst = os.path.splitext(dst_rawlog)[0] + "_Images"
    if os.path.isdir(src) and not os.path.exists(dst):
        shutil.copytree(src, dst)
    gt = os.path.splitext(src_rawlog)[0] + "_groundtruth.txt"
    if os.path.exists(gt):
        shutil.copy(gt, os.path.splitext(dst_rawlog)[0] + "_groundtruth.txt")


def case(args, kind, k, base_file, base_raw, work, rawlog_for_maps):
    rng = random.Random(f"{args.seed}-{kind}-{k}")
    in_archive = k % 2 == 1  # odd cases: the decompressed archive, compressed again (valid CRC-32)
    data, what = mutate(base_raw if in_archive else base_file, rng)
    if in_archive:
        data = gzip.compress(data, compresslevel=1, mtime=0)
    folder = os.path.join(work, f"{kind}_{k:05d}")
    os.makedirs(folder, exist_ok=True)
    ext = ".rawlog" if kind == "rawlog" else ".slammap"
    path = os.path.join(folder, "m" + ext)
    with open(path, "wb") as f:
        f.write(data)
    if kind == "rawlog":
        copy_images(args.base_rawlog, path)
        cmds = rawlog_commands(args.build, path, os.path.join(folder, "out"))
        cmd = cmds[(k // 2) % len(cmds)]  # each tool gets mutants of both kinds
    else:
        cmd = map_commands(args.build, path, os.path.join(folder, "out"), rawlog_for_maps, k)
    cls, detail = run(cmd, path, args.timeout)
    temporaries = [os.path.join(d, n) for d, ds, fs in os.walk(folder) for n in ds + fs if ".tmp-" in n]
    if temporaries and cls in ("read", "refused"):
        cls, detail = "bad-error", f"left {temporaries[0]}"
    if cls in ("read", "refused"):
        shutil.rmtree(folder, ignore_errors=True)
    tool = os.path.basename(cmd[0])
    if tool == "slam-map":
        tool += " " + cmd[1]
    elif "--map-in" in cmd:
        tool += " --map-in"
    return {"kind": kind, "case": k, "archive": in_archive, "mutation": what, "tool": tool, "class": cls,
            "detail": detail}


def main():
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("--build", default=os.path.join(ROOT, "build"))
    ap.add_argument("--rawlog-mutants", type=int, default=2000)
    ap.add_argument("--map-mutants", type=int, default=2000)
    ap.add_argument("--seed", type=int, default=1)
    ap.add_argument("--jobs", type=int, default=2)
    ap.add_argument("--timeout", type=float, default=60)
    ap.add_argument("--work", default="")
    ap.add_argument("--crash-file", default=os.path.join(ROOT, "..", "shared", "repro", "rawlog_depth_size_segfault",
                                                         "min.rawlog"))
    ap.add_argument("--json", default="")
    args = ap.parse_args()
    args.build = os.path.abspath(args.build)
    for tool in ("slam-synth", "slam-run", "slam-map", "normal-priors", "vocab-train", "bench-slam", "manhattan-eval",
                 "match-oracle"):
        if not os.access(os.path.join(args.build, "bin", tool), os.X_OK):
            sys.exit(f"fuzz-inputs: error: {os.path.join(args.build, 'bin', tool)}: not built")
    work = args.work or tempfile.mkdtemp(prefix="pslam_fuzz_inputs_")
    os.makedirs(work, exist_ok=True)
    b = lambda t: os.path.join(args.build, "bin", t)
    t0 = time.monotonic()
    # The inputs: a small rawlog with every channel; a map from a clip that initializes.
    base = os.path.join(work, "base")
    subprocess.run([b("slam-synth"), "--scenario", "room", "--frames", "8", "--width", "160", "--height", "120",
                    "--seed", str(args.seed), "--out", base, "--name", "small"], check=True,
                   stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL)
    subprocess.run([b("slam-synth"), "--scenario", "room", "--frames", "40", "--seed", str(args.seed), "--out", base,
                    "--name", "clip"], check=True, stdout=subprocess.DEVNULL, stderr=subprocess.DEVNULL)
    subprocess.run([b("slam-run"), "--config", CONFIG, *NO_PLACES, "--rawlog", os.path.join(base, "clip.rawlog"), "--out",
                    os.path.join(base, "run"), "--seed", "1", "-q"], check=True, stdout=subprocess.DEVNULL)
    args.base_rawlog = os.path.join(base, "small.rawlog")
    base_map = os.path.join(base, "run", "map.slammap")
    results = []
    # The crash file first, through every rawlog tool.
    if os.path.exists(args.crash_file):
        folder = os.path.join(work, "crash_file")
        os.makedirs(folder, exist_ok=True)
        path = os.path.join(folder, "min.rawlog")
        shutil.copy(args.crash_file, path)
        copy_images(args.crash_file, path)
        for cmd in rawlog_commands(args.build, path, os.path.join(folder, "out")):
            cls, detail = run(cmd, path, args.timeout)
            results.append({"kind": "crash-file", "case": 0, "archive": True, "mutation": "repro", "tool":
                            os.path.basename(cmd[0]), "class": cls, "detail": detail})
    todo = []
    for kind, n, base_file in (("rawlog", args.rawlog_mutants, args.base_rawlog), ("map", args.map_mutants, base_map)):
        with open(base_file, "rb") as f:
            file_bytes = f.read()
        raw = gzip.decompress(file_bytes)
        todo += [(kind, k, file_bytes, raw) for k in range(n)]
    clip = os.path.join(base, "clip.rawlog")
    with concurrent.futures.ThreadPoolExecutor(max_workers=args.jobs) as pool:
        futures = [pool.submit(case, args, kind, k, fb, raw, work, clip) for kind, k, fb, raw in todo]
        for i, fut in enumerate(concurrent.futures.as_completed(futures)):
            results.append(fut.result())
            if (i + 1) % 200 == 0:
                print(f"fuzz-inputs: {i + 1}/{len(futures)} ({time.monotonic() - t0:.0f} s)", file=sys.stderr)
    results.sort(key=lambda r: (r["kind"], r["case"]))
    # Report: counts per input kind, mutation place and class; then every crash, hang and bad error.
    classes = ["read", "refused", "bad-error", "crash", "hang"]
    rows = {}
    for r in results:
        key = (r["kind"], "crash file" if r["kind"] == "crash-file" else
               "archive (valid gzip)" if r["archive"] else "gzip file")
        rows.setdefault(key, {c: 0 for c in classes})[r["class"]] += 1
    print(f"| input | mutated | runs | " + " | ".join(classes) + " |")
    print("|---|---|---|" + "---|" * len(classes))
    for (kind, where), counts in sorted(rows.items()):
        print(f"| {kind} | {where} | {sum(counts.values())} | " + " | ".join(str(counts[c]) for c in classes) + " |")
    print()
    tools = {}
    for r in results:
        tools.setdefault((r["kind"], r["tool"]), {c: 0 for c in classes})[r["class"]] += 1
    print(f"| input | tool | runs | " + " | ".join(classes) + " |")
    print("|---|---|---|" + "---|" * len(classes))
    for (kind, tool), counts in sorted(tools.items()):
        print(f"| {kind} | {tool} | {sum(counts.values())} | " + " | ".join(str(counts[c]) for c in classes) + " |")
    bad = [r for r in results if r["class"] in ("crash", "hang", "bad-error")]
    for r in bad:
        print(f"{r['class']}: {r['kind']} case {r['case']} ({r['mutation']}) {r['tool']}: {r['detail']}")
    print(f"fuzz-inputs: {len(results)} runs in {time.monotonic() - t0:.0f} s, seed {args.seed}; work folder {work}")
    if args.json:
        with open(args.json, "w") as f:
            json.dump({"seed": args.seed, "results": results}, f, indent=1)
    if not bad and not args.work:
        shutil.rmtree(work, ignore_errors=True)
    return 1 if bad else 0


if __name__ == "__main__":
    sys.exit(main())
