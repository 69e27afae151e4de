#!/usr/bin/env python3
"""What `config/scenes/dense_10k.yaml`'s substep costs in accuracy (docs/followers.md, "10,000
strands"): the scene's 10,000 output strands (100 simulated guides, the others placed from them)
run at several midpoint substeps and compared with the same scene at a reference substep 8 times
smaller than the finest, itself checked against one 16 times smaller.

    bench/dense_10k_substep_error.py [--build _build] [--seconds 1] [--stride 2] [--no-obstacle]

Prints, per substep, the RMS and max distance of the output positions (x, not the cohesion
display positions) from the reference's over every --stride-th output frame, in % of the mean
strand length, over the first 0.25 and 0.5 s and the whole run, and the runner's real-time
factor of the run (2 threads, the CPU named). Over a whole second the reference does not
converge (strands that pass the sphere on one side or the other, each dragging its followers):
its own check says how far a comparison means anything. --no-obstacle runs the scene without
its sphere (solver.obstacle.enabled false), where the reference converges.
"""
import argparse
import json
import os
import subprocess
import sys
import tempfile

sys.path.insert(0, os.path.dirname(os.path.abspath(__file__)))
from hair_contact_error import error  # noqa: E402
from hard_cases import read_hair  # noqa: E402

SCENE = os.path.join(os.path.dirname(os.path.abspath(__file__)), "..", "config", "scenes",
                     "dense_10k.yaml")


def run(binary, out_dir, substep, args):
    """One runner run of the scene at `substep`; returns its frames' strands, its RTF and the CPU
    the runner named (its JSON's `cpu`: name, family, model, avx512f)."""
    frames = os.path.join(out_dir, "substep_%g" % substep)
    os.makedirs(frames, exist_ok=True)
    extra = ["--set", "solver.obstacle.enabled=false"] if args.no_obstacle else []
    subprocess.run([binary, "--scene", SCENE, "--seconds", str(args.seconds), "--threads", "2",
                    "--substep", str(substep), "--no-measure", "--hair-frames", frames,
                    "--hair-stride", str(args.stride), "--json", frames + ".json"] + extra,
                   check=True, stdout=subprocess.DEVNULL)
    names = sorted(f for f in os.listdir(frames) if f.endswith(".hair"))
    summary = json.load(open(frames + ".json"))
    return ([read_hair(os.path.join(frames, n)) for n in names], summary["realtime_factor"],
            summary["cpu"])


def main():
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("--build", default="_build")
    ap.add_argument("--seconds", type=float, default=1.0)
    ap.add_argument("--stride", type=int, default=2)
    ap.add_argument("--no-obstacle", action="store_true")
    args = ap.parse_args()
    binary = os.path.join(args.build, "devel/lib/wet_curly_hair/wet_curly_hair_run")
    substeps = [5e-4, 1.0 / 360.0]  # the solver's default, and the scene's
    with tempfile.TemporaryDirectory() as tmp:
        fine = min(substeps) / 8
        ref, _, _ = run(binary, tmp, fine, args)
        check, _, _ = run(binary, tmp, fine / 2, args)
        horizons = sorted(set(t for t in [0.25, 0.5, args.seconds] if t <= args.seconds))

        def errors(frames):
            # Frame k of a run is output frame k * stride, at k * stride / 60 s.
            text = []
            for t in horizons:
                rms, worst = error(frames, ref, int(round(t * 60.0 / args.stride)) + 1)
                text.append("%g s: RMS %.3f %%, max %.2f %%" % (t, rms, worst))
            return "; ".join(text)

        print("reference %.4g s against %.4g s: %s (of the strand length)"
              % (fine, fine / 2, errors(check)))
        for h in substeps:
            frames, rtf, cpu = run(binary, tmp, h, args)
            print("midpoint %.4g s (%d substeps per frame): %s; RTF %.2f (%s)"
                  % (h, round((1.0 / 60.0) / h), errors(frames), rtf, cpu))


if __name__ == "__main__":
    main()
