#!/usr/bin/env python3
"""Reproduces the paper's comparisons (Kim 2023 Figs. 4-9 and eq. 13) through the offline runner.

Usage: bench/reproduce_paper.py BUILD_DIR [--short] [--out DIR] [--work DIR] [--no-strong]

Long form (default): writes DIR/paper.md (the tables of docs/paper.md), DIR/paper.json and contact-sheet
PNGs in DIR (default docs/img). --work DIR keeps the runs there and reuses any run whose JSON is
already there (resume an interrupted long form). --no-strong leaves out the 5x-strength
baselines (slow: they pile strands onto each other). Short form (--short, used by scripts/test): fewer strands and
seconds, no pictures, and asserts the direction of each effect; exits 1 when one fails.
"""
import json
import math
import os
import subprocess
import sys
import tempfile

ROOT = os.path.dirname(os.path.dirname(os.path.abspath(__file__)))


def main():
    args = sys.argv[1:]
    if not args or args[0].startswith("-"):
        print(__doc__)
        return 2
    build = args[0]
    short = "--short" in args
    out = args[args.index("--out") + 1] if "--out" in args else os.path.join(ROOT, "docs", "img")
    run = os.path.join(build, "devel", "lib", "wet_curly_hair", "wet_curly_hair_run")
    render = os.path.join(build, "devel", "lib", "wet_curly_hair", "wet_curly_hair_render")
    tmp = args[args.index("--work") + 1] if "--work" in args else tempfile.mkdtemp(prefix="wch_paper_")
    os.makedirs(tmp, exist_ok=True)
    strong = short or "--no-strong" not in args
    strands = "40" if short else "100"
    results = {}

    def runner(name, scene, *extra, frames_dir=None, seconds=None):
        cmd = [run, "--scene", os.path.join(ROOT, "config", "paper", scene), "--strands", strands,
               "--json", os.path.join(tmp, name + ".json")]
        if seconds is not None:
            cmd += ["--seconds", str(seconds)]
        if frames_dir:
            cmd += ["--hair-frames", frames_dir, "--hair-stride", "30"]
        cmd += list(extra)
        if not os.path.exists(os.path.join(tmp, name + ".json")):
            subprocess.run(cmd, check=True, stdout=subprocess.DEVNULL)
        with open(os.path.join(tmp, name + ".json")) as f:
            d = json.load(f)
        results[name] = {k: v for k, v in d.items() if not isinstance(v, list)}
        return d

    def sheet(name, frames_dir, *extra):
        if short or not os.path.exists(render):
            return
        files = sorted(os.path.join(frames_dir, f) for f in os.listdir(frames_dir))
        subprocess.run([render, "--sheet", str(min(4, len(files))), "--out",
                        os.path.join(out, name + ".png")] + list(extra) + files, check=True,
                       stdout=subprocess.DEVNULL)

    os.makedirs(out, exist_ok=True)
    lines = []
    checks = []

    # --- Curl exaggeration (Figs. 4, 8): tip curl radius/pitch dry vs wet, against the weight.
    curl_seconds = 1.5 if short else 3
    lines += ["### Curl exaggeration (Figs. 4, 8)", "",
              "Saturation ramp 0 at the roots to 1 at the tips; still head; wet helix r = 6 mm, "
              "rise 18 mm per turn; groom r = 10 mm, rise 30 mm.", "",
              "| case | curl weight W (N) | tip curl radius (mm) | tip rise per turn (mm) | max strain |",
              "|---|---|---|---|---|"]
    cases = [("dry", "0,0", 0.2)] + [("wet", "0,1", w) for w in ([0.2] if short else [0.04, 0.12, 0.2, 0.32])]
    if not short:
        cases.append(("wet literal eq. 9", "0,1", 0.2))
    for label, sat, w in cases:
        name = "curl_%s_%g%s" % (label.split()[0], w, "_literal" if "literal" in label else "")
        extra = ["--saturation", sat, "--set", "solver.curl.weight_n=%g" % w]
        if "literal" in label:
            extra += ["--set", "solver.curl.mode=literal"]
        frames = os.path.join(tmp, name) if (not short and w == 0.2) else None
        d = runner(name, "curl.yaml", *extra, frames_dir=frames, seconds=curl_seconds)
        lines.append("| %s | %g | %.2f | %.1f | %.3f |" % (label, w, 1e3 * d["curl_radius_tip_m"],
                                                      1e3 * d["curl_pitch_tip_m"], d["max_strain"]))
        if frames:
            sheet("curl_" + label.split()[0] + ("_literal" if "literal" in label else ""), frames, "--head")
    dry, wet = results["curl_dry_0.2"], results["curl_wet_0.2"]
    checks.append(("wet tips curl tighter (smaller radius)",
                   wet["curl_radius_tip_m"] < dry["curl_radius_tip_m"]))

    # --- Cohesion (Figs. 5-7): ours vs the force-based baselines, still and rotating.
    coh_seconds = 1.0 if short else 2
    lines += ["", "### Cohesion (Figs. 5-7)", "",
              "Saturation 0.5 at the roots to 1 at the tips. Clump distance: mean distance from a wet "
              "particle's output position to the nearest output position on another strand. Jitter: RMS "
              "second difference per frame of the output positions in the head frame. Tangles: segment "
              "pairs of different strands closer than 2 x 0.5 mm, on the output positions and on the "
              "simulated ones. Rotation: 1 rev/s about the vertical.", "",
              "| cohesion | motion | clump distance (mm) | jitter (mm) | tangles (output) | tangles (simulated) | wall s / sim s |",
              "|---|---|---|---|---|---|---|"]
    # Baselines at their default strength (calibrated to clump the still scene about as much as
    # ours) and 5x stronger.
    modes = [("off", []), ("ours", []), ("lin", []), ("kim", []),
             ("lin x5", ["--set", "solver.cohesion.lin_stiffness_n_per_m3=300"]),
             ("kim x5", ["--set", "solver.cohesion.kim_surface_tension=1.5"])]
    if not strong:
        modes = modes[:4]
    for mode, strength in modes:
        for motion in ["still", "spin:rate_hz=1"]:
            key = mode.replace(" ", "")
            name = "coh_%s_%s" % (key, motion.split(":")[0])
            frames = os.path.join(tmp, name) if (not short and motion != "still" and "x5" not in mode) else None
            d = runner(name, "cohesion.yaml", "--cohesion", mode.split()[0], "--motion", motion,
                       *strength, frames_dir=frames, seconds=coh_seconds)
            lines.append("| %s | %s | %.1f | %.2f | %d | %d | %.1f |" % (
                mode, "still" if motion == "still" else "spin 1 rev/s", 1e3 * d["clump_distance_m"],
                1e3 * d["jitter"], d["tangles"], d["tangles_sim"], d["wall_s"] / d["sim_s"]))
            if frames:
                sheet("cohesion_" + key + "_spin", frames, "--head")
    checks.append(("wet hair clumps with ours (clump distance below off)",
                   results["coh_ours_still"]["clump_distance_m"] < results["coh_off_still"]["clump_distance_m"]))
    checks.append(("ours leaves the simulation untouched (same simulated tangles as off)",
                   results["coh_ours_spin"]["tangles_sim"] == results["coh_off_spin"]["tangles_sim"]))
    for base in (["linx5", "kimx5"] if strong else []):
        checks.append(("strong %s tangles the simulated hair more than ours under rotation" % base,
                       results["coh_ours_spin"]["tangles_sim"] < results["coh_%s_spin" % base]["tangles_sim"]))
    # Recorded, not asserted: at equal clumping the paper's claim may or may not hold here.
    for base in ["lin", "kim"]:
        o, b = results["coh_ours_spin"], results["coh_%s_spin" % base]
        print("record: under rotation ours vs %s at default strength: jitter %.2f vs %.2f mm, "
              "simulated tangles %d vs %d" % (base, 1e3 * o["jitter"], 1e3 * b["jitter"],
                                               o["tangles_sim"], b["tangles_sim"]))

    # --- Adhesion (Fig. 9): contact time with the sphere, dry vs wet.
    lines += ["", "### Adhesion (Fig. 9)", "",
              "The head slides 0.3 m sideways under a sphere (r = 6 cm); the hair brushes past it. Contact: "
              "time a strand spends within the adhesion band (1 cm) of the sphere, summed over the strands "
              "(strand-seconds: how much hair the sphere holds, and for how long), with the number of strands "
              "that touched and their mean.", "",
              "| saturation | contact, strand-seconds | strands that touched | mean contact time (s) | "
              "particle-substeps pulled by adhesion | max strain | strand extension |",
              "|---|---|---|---|---|---|---|"]
    adh_seconds = 1.5 if short else 2.5
    for sat in ["0,0", "1,1"]:
        name = "adh_" + sat.replace(",", "_")
        frames = os.path.join(tmp, name) if not short else None
        d = runner(name, "adhesion.yaml", "--saturation", sat, frames_dir=frames, seconds=adh_seconds)
        lines.append("| %s | %.2f | %d | %.2f | %d | %.3f | %.4f |" % (
            "dry" if sat == "0,0" else "wet", d["obstacle_contact_strand_s"], d["obstacle_contact_strands"],
            d["obstacle_contact_s"], d["adhesion_active"], d["max_strain"], d["max_strand_extension"]))
        if frames:
            sheet("adhesion_" + ("dry" if sat == "0,0" else "wet"), frames, "--obstacle", "sphere:x=0,y=0.25,z=0.25,r=0.06")
    # The sum, not the mean over the strands that touched: a dry strand that rests on the sphere
    # under gravity alone makes a large mean of few strands (the per-length long form: dry 1.22 s
    # over its touching strands against wet 0.51 s).
    checks.append(("wet hair stays on the sphere longer (strand-seconds)",
                   results["adh_1_1"]["obstacle_contact_strand_s"] >
                   results["adh_0_0"]["obstacle_contact_strand_s"]))

    # --- Stiffness (eq. 13): kinetic energy decay after the head stops, dry vs wet.
    lines += ["", "### Stiffness (eq. 13)", "",
              "Head spins at 1 rev/s and stops dead at 1 s. Decay rate of the kinetic energy over "
              "[1.5 s, end], from a log-linear fit. Eq. 13 makes the wet hair's velocity decay faster by "
              "-ln(gamma0)/dt_ref = 1.0 /s: free motion would lose kinetic energy 2.0 /s faster; hair "
              "that swings stores half its energy in the springs on average, so its energy envelope "
              "decays about 1.0 /s faster.", "",
              "| saturation | kinetic energy decay (1/s) |", "|---|---|"]
    rates = {}
    for sat in ["0,0", "1,1"]:
        name = "stiff_" + sat.replace(",", "_")
        # Every frame's energy (the runner samples every 6th by default): the fit reads the series.
        d = runner(name, "stiffness.yaml", "--saturation", sat, "--series-stride", "1",
                   seconds=2.5 if short else 3)
        t, ke = d["time_s"], d["kinetic_energy"]
        pts = [(ti, math.log(k)) for ti, k in zip(t, ke) if ti >= 1.5 and k > 0]
        n = len(pts)
        mt = sum(p[0] for p in pts) / n
        ml = sum(p[1] for p in pts) / n
        slope = sum((p[0] - mt) * (p[1] - ml) for p in pts) / sum((p[0] - mt) ** 2 for p in pts)
        rates[sat] = -slope
        lines.append("| %s | %.2f |" % ("dry" if sat == "0,0" else "wet", -slope))
    diff = rates["1,1"] - rates["0,0"]
    lines.append("")
    lines.append("Wet minus dry: %.2f /s (eq. 13 alone: 1.0 /s for a swinging strand, 2.0 /s for free motion)." % diff)
    checks.append(("wet hair loses kinetic energy faster (eq. 13)", diff > 0.0))

    with open(os.path.join(out if not short else tmp, "paper.md"), "w") as f:
        f.write("\n".join(lines) + "\n")
    with open(os.path.join(out if not short else tmp, "paper.json"), "w") as f:
        json.dump(results, f, indent=1)
    print("\n".join(lines))
    print()
    failed = 0
    for text, ok in checks:
        print(("PASS " if ok else "FAIL ") + text)
        failed += 0 if ok else 1
    print("%d passed, %d failed" % (len(checks) - failed, failed))
    return 1 if failed else 0


if __name__ == "__main__":
    sys.exit(main())
