#!/usr/bin/env python3
"""Two builds of the runner on one command, taking turns: the paired comparison behind the
"paired" figures of docs/performance.md, on a shared machine whose speed drifts.

  bench/paired_runs.py --baseline BUILD_A [--build BUILD_B] [--pairs 6] [--out DIR] -- RUNNER_ARGS

Runs BUILD_B's and BUILD_A's wet_curly_hair_run (under devel/lib/wet_curly_hair/) on the same
arguments (with --json added), the order alternating from pair to pair so that neither side
always runs first. Prints, per side, the median real-time factor and its range and the median of
each stage's CPU seconds; then the ratio build / baseline of each pair and their median, the
figure a change is judged by (a drift of the machine moves both runs of a pair alike). Both
sides must report the same CPU (the runner JSON's `cpu`). Writes OUT/paired_runs.csv (every run)
when --out is given.
"""
import argparse
import json
import os
import statistics
import subprocess
import sys
import tempfile

SIDES = ("baseline", "build")


def runner(build):
    return os.path.join(build, "devel/lib/wet_curly_hair/wet_curly_hair_run")


class RunnerError(Exception):
    pass


def run(binary, argv, tmp):
    """One runner run; returns its JSON summary, or raises RunnerError with what it said."""
    out = os.path.join(tmp, "run.json")
    done = subprocess.run([binary] + argv + ["--json", out], stdout=subprocess.DEVNULL,
                          stderr=subprocess.PIPE, text=True)
    if done.returncode != 0:
        raise RunnerError("%s exited %d: %s" % (binary, done.returncode,
                                                done.stderr.strip()[-300:]))
    with open(out) as f:
        return json.load(f)


def describe(side, summaries):
    """A side's median real-time factor, its range, and its stages' median CPU seconds."""
    rtf = sorted(s["realtime_factor"] for s in summaries)
    names = [n for n in summaries[0]["stages"]
             if any(s["stages"][n]["cpu_s"] > 0 for s in summaries)]
    stages = ", ".join("%s %.3f" % (n, statistics.median(s["stages"][n]["cpu_s"] for s in summaries))
                       for n in names)
    return "%-8s RTF median %.4f (%.4f-%.4f); stages, median CPU s: %s" % (
        side, statistics.median(rtf), rtf[0], rtf[-1], stages)


def main():
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("--baseline", required=True, help="the build directory compared against")
    ap.add_argument("--build", default="_build", help="the build directory under test")
    ap.add_argument("--pairs", type=int, default=6)
    ap.add_argument("--out", default="")
    ap.add_argument("runner_args", nargs=argparse.REMAINDER,
                    help="-- then the runner's arguments")
    args = ap.parse_args()
    argv = args.runner_args[1:] if args.runner_args[:1] == ["--"] else args.runner_args
    if args.pairs < 1:
        ap.error("--pairs must be at least 1")
    if not argv:
        ap.error("give the runner's arguments after --")
    binaries = {"baseline": runner(args.baseline), "build": runner(args.build)}
    for side, binary in binaries.items():
        if not os.access(binary, os.X_OK):
            ap.error("no runner for --%s: %s" % (side, binary))
    runs = {side: [] for side in SIDES}
    with tempfile.TemporaryDirectory() as tmp:
        for k in range(args.pairs):
            order = SIDES if k % 2 == 0 else tuple(reversed(SIDES))
            for side in order:
                try:
                    runs[side].append(run(binaries[side], argv, tmp))
                except RunnerError as e:
                    print("paired_runs.py: the %s's runner failed: %s" % (side, e),
                          file=sys.stderr)
                    return 2
            print("pair %d: baseline %.4f, build %.4f" % (
                k + 1, runs["baseline"][-1]["realtime_factor"],
                runs["build"][-1]["realtime_factor"]), flush=True)
    cpus = {side: runs[side][0]["cpu"] for side in SIDES}
    if cpus["baseline"] != cpus["build"]:
        print("the two sides ran on different CPUs: %s" % cpus, file=sys.stderr)
        return 1
    print("\n%s, %d pairs taking turns: %s" % (cpus["build"], args.pairs, " ".join(argv)))
    for side in SIDES:
        print(describe(side, runs[side]))
    ratios = [b["realtime_factor"] / a["realtime_factor"]
              for a, b in zip(runs["baseline"], runs["build"])]
    print("build / baseline, RTF per pair: %s; median %.3fx (%.3f-%.3f)" % (
        " ".join("%.3f" % r for r in ratios), statistics.median(ratios), min(ratios),
        max(ratios)))
    if args.out:
        os.makedirs(args.out, exist_ok=True)
        with open(os.path.join(args.out, "paired_runs.csv"), "w") as f:
            f.write("# %s; %s\n" % (cpus["build"], " ".join(argv)))
            f.write("pair,side,realtime_factor,wall_s\n")
            for side in SIDES:
                for k, s in enumerate(runs[side]):
                    f.write("%d,%s,%.4f,%.3f\n" % (k + 1, side, s["realtime_factor"], s["wall_s"]))
    return 0


if __name__ == "__main__":
    sys.exit(main())
