#!/usr/bin/env python3
"""The README's 10,000-strand speed targets, measured: each runner command several times, the
commands taking turns so that a machine that drifts moves them alike.

  bench/targets_10k.py [--build _build] [--runs 5] [--threads 2] [--strands 10000]
                       [--seconds 1] [--out DIR]

Target 3 (every strand simulated, theta at 1/240 s, no display pass) and target 1 (the defaults
with --follow-ratio 10) run through wet_curly_hair_run with --no-measure, as in the README. Prints,
per target, the median real-time factor, the range over the runs and the stages' CPU seconds of
the median run, with the CPU as the runner names it (its JSON's `cpu`: name, family, model,
avx512f), the lanes the build chose for it (`lane_layout`, `cohesion_float_lanes`) and the
lattice the defaults ran on the groom (`cohesion`, `cohesion_wet_sums`), and the ratio of the
two targets' medians; writes OUT/targets_10k.csv (every run). The node's target has its own
script (bench/node_10k.sh), since it needs a ROS graph.
"""
import argparse
import json
import os
import statistics
import subprocess
import tempfile

SPHERE_THETA = "sphere:x=-0.18,y=0.15,z=-0.05,r=0.05"
SPHERE_DEFAULTS = "sphere:x=-0.16,y=0,z=-0.05,r=0.05"


def commands(args):
    """The README's two runner commands, by target name."""
    common = ["--strands", str(args.strands), "--seconds", str(args.seconds), "--threads",
              str(args.threads), "--no-measure"]
    return {
        "simulated_theta_240": common + [
            "--integrator", "theta", "--substep", "0.0041666667", "--cohesion", "off",
            "--saturation", "0.5,0.5", "--obstacle", SPHERE_THETA,
            "--motion", "linear:speed_m_s=0.3,axis_x=0,axis_y=1,axis_z=0"],
        "defaults_follow_ratio_10": common + [
            "--follow-ratio", "10", "--obstacle", SPHERE_DEFAULTS],
    }


def run(binary, argv, tmp):
    """One runner run; returns its JSON summary."""
    out = os.path.join(tmp, "run.json")
    subprocess.run([binary] + argv + ["--json", out], check=True, stdout=subprocess.DEVNULL)
    with open(out) as f:
        return json.load(f)


def main():
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("--build", default="_build")
    ap.add_argument("--runs", type=int, default=5)
    ap.add_argument("--threads", type=int, default=2)
    ap.add_argument("--strands", type=int, default=10000)
    ap.add_argument("--seconds", type=float, default=1.0)
    ap.add_argument("--out", default="targets_10k_out")
    args = ap.parse_args()
    if args.runs < 1 or args.threads < 1 or args.strands < 1 or not args.seconds > 0:
        ap.error("--runs, --threads and --strands must be at least 1, --seconds above 0")
    binary = os.path.join(args.build, "devel/lib/wet_curly_hair/wet_curly_hair_run")
    targets = commands(args)
    runs = {name: [] for name in targets}
    with tempfile.TemporaryDirectory() as tmp:
        for k in range(args.runs):
            for name, argv in targets.items():
                summary = run(binary, argv, tmp)
                runs[name].append(summary)
                print("run %d %-25s RTF %.3f" % (k + 1, name, summary["realtime_factor"]),
                      flush=True)
    cpu = next(iter(runs.values()))[0]["cpu"]
    # The build's choices for this CPU: the strand lanes and the lattice's float lanes; and the
    # lattice the defaults ran on this groom (grid_wet_sums "auto" resolved).
    layout = runs["defaults_follow_ratio_10"][0]
    print("\n%s, %d threads, %d strands, %g s, %d runs each; lanes %s, lattice floats %s; "
          "cohesion %s, sums at the %s" %
          (cpu, args.threads, args.strands, args.seconds, args.runs, layout.get("lane_layout"),
           layout.get("cohesion_float_lanes"), layout.get("cohesion"),
           layout.get("cohesion_wet_sums")))
    for name, summaries in runs.items():
        rtf = sorted(s["realtime_factor"] for s in summaries)
        median_run = min(summaries, key=lambda s: abs(s["realtime_factor"] - statistics.median(rtf)))
        stages = ", ".join("%s %.2f" % (stage, v["cpu_s"])
                           for stage, v in median_run["stages"].items() if v["cpu_s"] >= 0.05)
        print("%-25s RTF median %.3f (%.3f-%.3f); the median run's stages, CPU s: %s" %
              (name, statistics.median(rtf), rtf[0], rtf[-1], stages))
    # K = 10 as a share of the dynamics alone: the targets take turns, so a drift of the
    # machine's speed over the script's runs moves both alike; a change from one run to the next
    # does not cancel (on the fifth-generation EPYC the ratio moved 0.63-0.78 between runs of the
    # script minutes apart).
    medians = {name: statistics.median(s["realtime_factor"] for s in summaries)
               for name, summaries in runs.items()}
    print("defaults_follow_ratio_10 / simulated_theta_240: %.2f (the medians' ratio)" %
          (medians["defaults_follow_ratio_10"] / medians["simulated_theta_240"]))
    os.makedirs(args.out, exist_ok=True)
    with open(os.path.join(args.out, "targets_10k.csv"), "w") as f:
        f.write("# %s, %d threads, %d strands, %g s\n" % (cpu, args.threads, args.strands,
                                                         args.seconds))
        f.write("target,run,realtime_factor,wall_s\n")
        for name, summaries in runs.items():
            for k, s in enumerate(summaries):
                f.write("%s,%d,%.4f,%.3f\n" % (name, k + 1, s["realtime_factor"], s["wall_s"]))


if __name__ == "__main__":
    main()
