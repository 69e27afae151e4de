#!/usr/bin/env python3
"""The error of hair contact's split (docs/hair_contact.md): the contact forces are evaluated
once per substep and enter each strand's implicit solve with the other strand held, so the step
is first order in the contact. Measured as the position error over the whole run against a
reference fine in time (the same split at a 16 times smaller substep, itself checked against
one 32 times smaller), contact on and off, midpoint at 5e-4 s and a half and a quarter of it.

    bench/hair_contact_error.py [--build _build] [--out docs/bench] [--seconds 1]

Writes OUT/hair_contact_error.csv: per motion, contact and substep the RMS and max particle
distance from the reference over every output frame, in % of the strand length, and a shape
statistic that does not depend on which strand ends up over which: the groom's volume (mean
particle distance from the head over the run) relative to the reference's, in %.
"""
import argparse
import json
import math
import os
import subprocess
import sys
import tempfile

sys.path.insert(0, os.path.dirname(os.path.abspath(__file__)))
from hard_cases import read_hair  # noqa: E402


def run(binary, out_dir, motion, contact, substep, seconds):
    """One runner run, every frame written; returns the frames' strands."""
    frames = os.path.join(out_dir, "%s_%s_%g" % (motion, contact, substep))
    os.makedirs(frames, exist_ok=True)
    subprocess.run([binary, "--seconds", str(seconds), "--motion", motion,
                    "--saturation", "0.8,0.8", "--threads", "1", "--hair-contact", contact,
                    "--substep", str(substep), "--no-crossings", "--no-tangles",
                    "--no-clump-distance", "--hair-frames", frames,
                    "--json", frames + ".json"], check=True, stdout=subprocess.DEVNULL)
    names = sorted(f for f in os.listdir(frames) if f.endswith(".hair"))
    summary = json.load(open(frames + ".json"))
    return [read_hair(os.path.join(frames, n)) for n in names], summary


def error(a, b, frames=None):
    """RMS and max particle distance between two runs over their first `frames` frames (None:
    all), in % of the mean strand length (measured on the first frame of b)."""
    lengths = [sum(math.dist(s[i], s[i + 1]) for i in range(len(s) - 1)) for s in b[0]]
    length = sum(lengths) / len(lengths)
    total, count, worst = 0.0, 0, 0.0
    for fa, fb in list(zip(a, b))[:frames]:
        for sa, sb in zip(fa, fb):
            for pa, pb in zip(sa, sb):
                d = math.dist(pa, pb)
                total += d * d
                count += 1
                worst = max(worst, d)
    return 100.0 * math.sqrt(total / count) / length, 100.0 * worst / length


def main():
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("--build", default="_build")
    ap.add_argument("--out", default="docs/bench")
    ap.add_argument("--seconds", type=float, default=1.0)
    args = ap.parse_args()
    binary = os.path.join(args.build, "devel/lib/wet_curly_hair/wet_curly_hair_run")
    base = 5e-4  # the largest substep measured (midpoint), then a half and a quarter of it
    substeps = [base, base / 2, base / 4]
    rows = []
    cpu = "unknown CPU"
    with tempfile.TemporaryDirectory() as tmp:
        for motion in ["nod", "shake"]:
            for contact in ["off", "on"]:
                ref, ref_summary = run(binary, tmp, motion, contact, base / 16, args.seconds)
                check, check_summary = run(binary, tmp, motion, contact, base / 32,
                                           args.seconds)
                rms, worst = error(ref, check)
                volume = ref_summary["mean_head_distance_run_m"]
                cpu = ref_summary["cpu"]  # the runner's: name, family, model, avx512f
                rows.append([motion, contact, "reference_check", base / 16, rms, worst,
                             100.0 * (check_summary["mean_head_distance_run_m"] / volume - 1.0),
                             check_summary.get("hair_contacts", 0)])
                print("%-6s contact %-3s reference %.3g s vs %.3g s: RMS %.3f %%, max %.3f %%"
                      % (motion, contact, base / 16, base / 32, rms, worst), flush=True)
                for h in substeps:
                    frames, summary = run(binary, tmp, motion, contact, h, args.seconds)
                    rms, worst = error(frames, ref)
                    rows.append([motion, contact, "midpoint", h, rms, worst,
                                 100.0 * (summary["mean_head_distance_run_m"] / volume - 1.0),
                                 summary.get("hair_contacts", 0)])
                    print("%-6s contact %-3s midpoint %.3g s: RMS %.3f %%, max %.3f %%"
                          % (motion, contact, h, rms, worst), flush=True)
    os.makedirs(args.out, exist_ok=True)
    with open(os.path.join(args.out, "hair_contact_error.csv"), "w") as f:
        f.write("# %s, 1 thread, %g s, built-in groom 200 x 32, saturation 0.8; error against "
                "the run at 1/16 of 5e-4 s, over every frame\n" % (cpu, args.seconds))
        f.write("motion,contact,setting,substep_s,rms_error_pct,max_error_pct,"
                "head_distance_difference_pct,hair_contacts_end\n")
        for r in rows:
            f.write(",".join(("%.4g" % v) if isinstance(v, float) else str(v) for v in r) + "\n")


if __name__ == "__main__":
    main()
