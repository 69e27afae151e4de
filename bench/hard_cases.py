#!/usr/bin/env python3
"""Stability on hard cases: runs every scene of config/hard/ under every integrator and
substep through the offline runner and judges each run.

    bench/hard_cases.py [--build DIR] [--short] [--out DIR] [--jobs N] [--readme FILE]
                        [--make-inputs] [--scenes a,b] [--integrators a,b] [--steps 0.001,...]
                        [--hair-contact] [--follow-ratio K]

Criteria (each run; a run passes when it meets all five):
  finite   every value stayed finite: JSON `finite`, `nonfinite_values` = 0, every energy finite,
           and the runner exited 0.
  strain   edge strain after limiting, `max_strain`, within the scene's strain limit + 1 %
           (relative: <= 1.01 x solver.stretch.strain_limit). `max_strain_before_limit` is reported.
  contact  penetration after the first solver step within the collision offset of the surface:
           `max_head_penetration_after_first_step_m` <= solver.collision.offset_m (1 mm) and
           `max_obstacle_penetration_after_first_step_m` <= solver.obstacle.offset_m (5 mm). The
           collision keeps particles the offset outside the surface; the criterion lets a particle
           lose at most that cushion. Frame 0 is not judged: some scenes start inside on purpose.
  energy   E_peak <= E_0 + E_in + slack, with E the runner's total energy (kinetic + gravity +
           stretch + bend + core) of the simulated strands per frame (`energy_simulated`: every
           strand, or with --follow-ratio the guides: followers are placed, not integrated),
           E_peak its largest value after frame 0, and
             E_in  = 1/2 M v_peak^2 + rigid_potential_rise_simulated_max_j: what the motion can
                     put in, all three `*_simulated` keys of the same strands.
                     M is the hair's mass; v_peak (`head_peak_reach_speed_m_s`) the fastest a
                     point of a strand can move when carried rigidly by the head in any shape,
                     |v_origin| + |omega| (|root - origin| + strand length), over the frames (the
                     head's frame-to-frame motion: a teleport counts as a one-frame move); the
                     second term is the largest rise of the groom's gravitational energy when it
                     is carried rigidly by the head.
             slack = 0.1 E_in + 0.01 M g0 L (10 % of the input, plus 1 % of the hair's weight
                     energy over a strand length, g0 = 9.81 m/s^2, L = 0.25 m).
           In scenes whose saturation changes during the run the wet curl force (eqs. 6-9), which is
           not part of E, does work on the hair; there only the final energy is judged, after the
           hair is dry again: E_final <= E_0 + E_in + slack. In the three scenes that start inside
           the head, an obstacle or (with hair contact) each other (`# energy-reference:
           first-step` in the scene) the first step's push-out adds energy by design; there E_0
           is the energy after the first step. With hair contact on, E includes the contact's
           penalty.
  repairs  no strand was repaired (JSON `repairs` = 0). A repair is the solver restoring a strand
           that went non-finite or past 3x the strain limit; the tables give the count.

The runs start from the package folder (scene paths are relative to it); the `command` column of
the CSV reproduces a run from there. A substep longer than the runner's 1/60 s frame needs a longer frame: at 1/30 s the runner is
given `--set run.frame_s=1/30` (one substep per frame), else the frame is 1/60 s.

Writes OUT/hard_cases.csv and the table of OUT/hard_cases.md (OUT defaults to docs/; only the part
between its hard_cases markers is replaced, the prose around it stays). The explicit integrator
is reported at every step and not asserted: a requested step past its stability bound runs at the
bound (docs/physics.md §2.9), so its columns are the requested substep, not the one used.
Python 3 standard library only.
"""
import argparse
import concurrent.futures
import csv
import json
import math
import os
import re
import shlex
import struct
import shutil
import subprocess
import sys
import tempfile
import time

HERE = os.path.dirname(os.path.abspath(__file__))
PKG = os.path.dirname(HERE)
HARD = os.path.join(PKG, "config", "hard")

SCENES = ["spin_stop", "shake_4hz", "teleport_1m", "saturation_switch", "inside_head",
          "inside_obstacle", "tight_curls", "straight", "particles_128", "zero_gravity",
          "thin_sheet", "coincident_strands"]
INTEGRATORS = ["explicit", "backward_euler", "midpoint", "theta"]
STEPS = [("1/5000", 1.0 / 5000), ("1/1000", 1.0 / 1000), ("1/240", 1.0 / 240), ("1/60", 1.0 / 60),
         ("1/30", 1.0 / 30)]
SHORT_SCENES = ["spin_stop", "shake_4hz", "teleport_1m", "saturation_switch"]
SHORT_INTEGRATORS = ["explicit", "backward_euler", "theta"]
SHORT_STEPS = ["1/1000", "1/60"]
FRAME_S = 1.0 / 60
G0, L0 = 9.81, 0.25


def find_tool(build, name):
    for root, _dirs, files in os.walk(build):
        if name in files:
            path = os.path.join(root, name)
            if os.access(path, os.X_OK):
                return path
    return None


def expected_stable(integrator, step_s):
    # The explicit integrator refuses a step past its stability bound (2.3e-4 s at 32 particles
    # with the default springs, less at finer strands; those cells read "refused"), and its
    # cells are reported, not asserted: the 4 Hz shake blows it up through the strain limiter
    # at steps within the bound (docs/hard_cases.md).
    return integrator != "explicit"


# ---- inputs: the thin OctoMap sheet and the groom with coincident strands -------------------

def read_hair(path):
    """Cem Yuksel's .hair: header, optional segments array, points. Returns a list of strands
    (lists of (x, y, z))."""
    with open(path, "rb") as f:
        data = f.read()
    if data[:4] != b"HAIR":
        raise ValueError(path + ": not a .hair file")
    strands, points, flags, default_segments = struct.unpack_from("<4I", data, 4)
    offset = 128
    if flags & 1:
        segments = list(struct.unpack_from("<%dH" % strands, data, offset))
        offset += 2 * strands
    else:
        segments = [default_segments] * strands
    xyz = struct.unpack_from("<%df" % (3 * points), data, offset)
    out, k = [], 0
    for seg in segments:
        out.append([tuple(xyz[3 * (k + i):3 * (k + i) + 3]) for i in range(seg + 1)])
        k += seg + 1
    return out


def write_hair(path, strands, info=b"wet_curly_hair hard case"):
    points = sum(len(s) for s in strands)
    header = b"HAIR" + struct.pack("<4I", len(strands), points, 0x3, 0)
    header += struct.pack("<ff3f", 1.0, 0.0, 0.5, 0.5, 0.5)
    header += info[:88].ljust(88, b"\0")
    assert len(header) == 128
    body = struct.pack("<%dH" % len(strands), *[len(s) - 1 for s in strands])
    flat = [c for s in strands for p in s for c in p]
    body += struct.pack("<%df" % len(flat), *flat)
    with open(path, "wb") as f:
        f.write(header + body)


def make_inputs(build, force):
    run = find_tool(build, "wet_curly_hair_run")
    octo = find_tool(build, "wet_curly_hair_make_octomap")
    sheet = os.path.join(HARD, "thin_sheet.bt")
    if force or not os.path.exists(sheet):
        if not octo:
            sys.exit("hard_cases: wet_curly_hair_make_octomap not found under " + build)
        subprocess.check_call([octo, sheet, "0.005", "box:x=0.2225,y=0,z=0.1,hx=0.001,hy=0.25,hz=0.25"])
    hair = os.path.join(HARD, "coincident.hair")
    if force or not os.path.exists(hair):
        tmp = os.path.join(HARD, ".groom_tmp")
        empty = os.path.join(tmp, "empty.yaml")
        os.makedirs(tmp, exist_ok=True)
        with open(empty, "w") as f:
            f.write("{}\n")
        subprocess.check_call([run, "--scene", empty, "--strands", "12", "--seconds", "0",
                               "--saturation", "0,0", "--hair-frames", tmp],
                              stdout=subprocess.DEVNULL)
        strands = read_hair(os.path.join(tmp, "frame_00000.hair"))
        write_hair(hair, [s for s in strands for _ in range(2)],
                   b"12 generated curly strands, each twice")
        for name in os.listdir(tmp):
            os.remove(os.path.join(tmp, name))
        os.rmdir(tmp)


# ---- one run ----------------------------------------------------------------------------------

def scene_settings(run, scene_path):
    """Strain limit and collision offsets from the runner's --print-scene of the scene."""
    text = subprocess.check_output([run, "--scene", scene_path, "--print-scene"], cwd=PKG,
                                   universal_newlines=True)
    path, values = [], {}
    for line in text.splitlines():
        body = line.split("#", 1)[0].rstrip()
        if not body.strip() or body.strip().startswith("-"):
            continue
        indent = (len(body) - len(body.lstrip())) // 2
        key, _, value = body.strip().partition(":")
        path = path[:indent] + [key]
        if value.strip():
            values[".".join(path)] = value.strip()
    return {"strain_limit": float(values["solver.stretch.strain_limit"]),
            "head_offset": float(values["solver.collision.offset_m"]),
            "obstacle_offset": float(values["solver.obstacle.offset_m"])}


def scene_directive(scene_path, name):
    """The text after `# NAME:` in the scene's comments ("" when absent)."""
    with open(scene_path) as f:
        for line in f:
            if line.startswith("# %s:" % name):
                return line.split(":", 1)[1].strip()
    return ""


def runner_args(scene_path):
    return shlex.split(scene_directive(scene_path, "runner-args"))


def judge(d, rc, settings, saturation_changes, from_first_step):
    row = {}
    # The energy criterion judges the simulated strands (every strand, or the guides with
    # followers): a follower is placed from its guides, not integrated, so its springs hold the
    # energy of an interpolated shape that no force relaxes, and no solver step made it. Every
    # other criterion judges every strand. The energy of all strands is reported (energy_all_*).
    energy = d.get("energy_simulated") or []
    energy_all = d.get("energy") or []
    finite = (rc == 0 and bool(d.get("finite")) and d.get("nonfinite_values", 1) == 0 and
              all(math.isfinite(e) for e in energy + energy_all) and len(energy) > 1)
    e0 = energy[0] if energy else float("nan")
    e_peak = max(energy[1:]) if len(energy) > 1 else float("nan")
    e_final = energy[-1] if energy else float("nan")
    mass = d.get("hair_mass_simulated_kg", 0.0)
    e_in = 0.5 * mass * d.get("head_peak_reach_speed_simulated_m_s", 0.0) ** 2 + \
        d.get("rigid_potential_rise_simulated_max_j", 0.0)
    slack = 0.1 * e_in + 0.01 * mass * G0 * L0
    if from_first_step and len(energy) > 1:
        e0 = energy[1]
    bound = e0 + e_in + slack
    judged = e_final if saturation_changes else e_peak
    strain_ok = d.get("max_strain", float("inf")) <= 1.01 * settings["strain_limit"]
    head_pen = d.get("max_head_penetration_after_first_step_m", float("inf"))
    obst_pen = d.get("max_obstacle_penetration_after_first_step_m", float("inf"))
    contact_ok = head_pen <= settings["head_offset"] and obst_pen <= settings["obstacle_offset"]
    energy_ok = math.isfinite(judged) and judged <= bound
    repairs = d.get("repairs", -1)
    failed = [name for name, ok in [("finite", finite), ("strain", strain_ok),
                                    ("contact", contact_ok), ("energy", energy_ok),
                                    ("repairs", repairs == 0)] if not ok]
    row.update({
        "finite": finite, "repairs": repairs,
        "max_strain": d.get("max_strain"), "max_strain_before_limit": d.get("max_strain_before_limit"),
        "strain_limit": settings["strain_limit"],
        "head_penetration_after_first_step_m": head_pen,
        "head_tolerance_m": settings["head_offset"],
        "obstacle_penetration_after_first_step_m": obst_pen,
        "obstacle_tolerance_m": settings["obstacle_offset"],
        "max_penetration_m_any_frame": d.get("max_penetration_m"),
        "energy_initial_j": e0, "energy_peak_j": e_peak, "energy_final_j": e_final,
        "energy_input_j": e_in, "energy_bound_j": bound,
        "energy_all_initial_j": energy_all[0] if energy_all else float("nan"),
        "energy_all_peak_j": max(energy_all[1:]) if len(energy_all) > 1 else float("nan"),
        "energy_judged": ("final" if saturation_changes else "peak") + (
            " vs first step" if from_first_step else ""),
        "max_speed_m_s": max(d.get("max_speed_m_s") or [float("nan")]),
        "wall_s": d.get("wall_s"), "realtime_factor": d.get("realtime_factor"),
        "failed": " ".join(failed), "status": "stable" if not failed else "fails",
    })
    return row


def run_one(run, out_dir, scene, integrator, step_label, step_s, settings, timeout, contact=False,
            follow_ratio=1):
    scene_path = os.path.join("config", "hard", scene + ".yaml")
    extra = runner_args(os.path.join(PKG, scene_path))
    if follow_ratio > 1:
        # One strand in K simulated, the others followers placed from them (docs/followers.md):
        # every criterion is judged over all strands, the followers included.
        extra = extra + ["--follow-ratio", str(follow_ratio)]
    if contact:
        # The substep under test, not the contact's longest (solver.hair_contact.max_substep_s,
        # which would cut every longer step to 5e-4 s).
        extra = extra + ["--hair-contact", "on", "--set",
                         "solver.hair_contact.max_substep_s=%r" % step_s]
    frame = max(FRAME_S, step_s)
    tag = "%s__%s__%s" % (scene, integrator, step_label.replace("/", "_"))
    json_path = os.path.join(out_dir, tag + ".json")
    # --series-stride 1: the energy at every frame (the runner samples it by default); the
    # energy check judges its peak.
    cmd = [run, "--scene", scene_path, "--integrator", integrator, "--substep", repr(step_s),
           "--series-stride", "1", "--json", json_path] + extra
    if frame > FRAME_S:
        cmd += ["--set", "run.frame_s=%r" % frame]
    t0 = time.time()
    try:
        proc = subprocess.run(cmd, cwd=PKG, stdout=subprocess.DEVNULL, stderr=subprocess.PIPE,
                              universal_newlines=True, timeout=timeout)
        rc, err = proc.returncode, proc.stderr.strip()
    except subprocess.TimeoutExpired:
        rc, err = -1, "timeout after %d s" % timeout
    d = {}
    if rc in (0, 1) and os.path.exists(json_path):
        with open(json_path) as f:
            d = json.load(f)
    row = {"scene": scene, "integrator": integrator, "substep": step_label, "substep_s": step_s,
           "frame_s": frame, "expected_stable": expected_stable(integrator, step_s),
           "exit_code": rc, "command": " ".join(
               shlex.quote(c) for c in [os.path.basename(run)] + cmd[1:]
               if c != "--json" and not c.endswith(".json"))}
    from_first_step = scene_directive(os.path.join(PKG, scene_path), "energy-reference") == "first-step"
    row.update(judge(d, rc, settings, "--saturation-at" in extra, from_first_step))
    if rc not in (0, 1):
        last = err.splitlines()[-1] if err else ""
        row["failed"] = ("runner exit %d: %s" % (rc, last)).strip()
        row["status"] = "fails"
        bound = re.search(r"explicit integrator's stability bound for this groom, ([0-9.e+-]+) s", last)
        if bound:
            # Refused before running, with the bound named (checkExplicitSubstep).
            row["failed"] = "past the bound %s s" % bound.group(1)
            row["status"] = "refused"
    row["elapsed_s"] = round(time.time() - t0, 2)
    return row


# ---- tables ----------------------------------------------------------------------------------

COLUMNS = ["scene", "integrator", "substep", "substep_s", "frame_s", "expected_stable", "status",
           "failed", "exit_code", "finite", "repairs", "max_strain", "max_strain_before_limit",
           "strain_limit", "head_penetration_after_first_step_m", "head_tolerance_m",
           "obstacle_penetration_after_first_step_m", "obstacle_tolerance_m",
           "max_penetration_m_any_frame", "energy_initial_j", "energy_peak_j", "energy_final_j",
           "energy_input_j", "energy_bound_j", "energy_judged", "energy_all_initial_j",
           "energy_all_peak_j", "max_speed_m_s", "wall_s",
           "realtime_factor", "elapsed_s", "command"]


def cell(row):
    if row["status"] == "stable":
        text = "stable"
    elif row["status"] == "refused":
        text = "refused (%s)" % row["failed"]
    else:
        text = "**fails** " + row["failed"]
        if "repairs" in row["failed"].split():
            text += " (%s)" % row["repairs"]
    if not row["expected_stable"]:
        text += " (not asserted)" if row["status"] == "fails" else ""
    return text


def markdown(rows, scenes, integrators, steps, command):
    by = {(r["scene"], r["integrator"], r["substep"]): r for r in rows}
    lines = ["| scene | integrator | " + " | ".join(s for s in steps) + " |",
             "|---|---|" + "---|" * len(steps)]
    for sc in scenes:
        for integ in integrators:
            cells = [cell(by[(sc, integ, st)]) if (sc, integ, st) in by else "" for st in steps]
            lines.append("| %s | %s | %s |" % (sc, integ, " | ".join(cells)))
    expected = [r for r in rows if r["expected_stable"]]
    bad = [r for r in expected if r["status"] != "stable"]
    other = [r for r in rows if not r["expected_stable"]]
    summary = ["%d runs: %d of the %d asserted (the implicit methods at every step) pass every "
               "criterion; of the %d explicit runs (not asserted), %d were refused as past the "
               "stability bound, %d pass and %d fail." % (
                   len(rows), len(expected) - len(bad), len(expected), len(other),
                   sum(r["status"] == "refused" for r in other),
                   sum(r["status"] == "stable" for r in other),
                   sum(r["status"] == "fails" for r in other))]
    if bad:
        summary.append("Expected stable but failed: " + "; ".join(
            "%s %s %s (%s)" % (r["scene"], r["integrator"], r["substep"], r["failed"]) for r in bad) + ".")
    worst = max(rows, key=lambda r: r["max_strain_before_limit"] or 0.0)
    summary.append("Largest strain before limiting: %.3g (%s, %s, %s); after limiting, at most %.4g." % (
        worst["max_strain_before_limit"] or 0.0, worst["scene"], worst["integrator"], worst["substep"],
        max((r["max_strain"] or 0.0) for r in rows)))
    reps = [r for r in rows if isinstance(r["repairs"], int) and r["repairs"] > 0]
    summary.append("Runs with repairs: %s." % (", ".join(
        "%s %s %s: %d" % (r["scene"], r["integrator"], r["substep"], r["repairs"]) for r in reps)
        if reps else "none"))
    return "\n".join(
        ["Cells: `stable` = passes all five criteria (finite, strain, contact, energy, repairs); "
         "otherwise the criteria it fails (repairs with their count). `(not asserted)` marks the "
         "explicit integrator; `refused` an explicit step past the groom's stability bound, which "
         "the runner refuses with the bound named instead of running (2.3e-4 s at 32 particles "
         "with the default springs, less at finer strands; physics.md §2.9).", ""] + lines + [""] +
        ["- " + s for s in summary] + ["", "Command: `%s`" % command, ""])


def replace_between_markers(path, md):
    """Replaces the text between the hard_cases markers of the file at path with md. Returns False,
    changing nothing, when the file does not exist or lacks the markers."""
    begin, end = "<!-- hard_cases:begin -->", "<!-- hard_cases:end -->"
    if not os.path.exists(path):
        return False
    with open(path) as f:
        text = f.read()
    if begin not in text or end not in text:
        return False
    head, rest = text.split(begin, 1)
    with open(path, "w") as f:
        f.write(head + begin + "\n" + md + end + rest.split(end, 1)[1])
    return True


def main():
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--build", default=os.path.join(PKG, "_build"), help="build folder holding the runner")
    ap.add_argument("--short", action="store_true", help="the subset run as a ctest")
    ap.add_argument("--out", default=os.path.join(PKG, "docs"), help="folder for the CSV and markdown")
    ap.add_argument("--jobs", type=int, default=1, help="runs in parallel (default 1)")
    ap.add_argument("--timeout", type=int, default=900, help="seconds per run")
    ap.add_argument("--readme", help="also replace the table between the hard_cases markers of this file")
    ap.add_argument("--make-inputs", action="store_true", help="remake config/hard/*.bt and .hair")
    ap.add_argument("--work", help="keep each run's JSON here (default: a temporary folder, removed)")
    ap.add_argument("--scenes"), ap.add_argument("--integrators"), ap.add_argument("--steps")
    ap.add_argument("--hair-contact", action="store_true",
                    help="every run with hair-hair contact on (writes hard_cases_contact.*)")
    ap.add_argument("--follow-ratio", type=int, default=1,
                    help="every run with one strand in K simulated and the rest followers "
                         "(K > 1 writes hard_cases_followers.*)")
    args = ap.parse_args()
    if args.follow_ratio < 1:
        sys.exit("hard_cases: --follow-ratio must be at least 1, got %d" % args.follow_ratio)
    run = find_tool(args.build, "wet_curly_hair_run")
    if not run:
        sys.exit("hard_cases: wet_curly_hair_run not found under " + args.build)
    make_inputs(args.build, args.make_inputs)
    scenes = SHORT_SCENES if args.short else SCENES
    integrators = SHORT_INTEGRATORS if args.short else INTEGRATORS
    step_labels = SHORT_STEPS if args.short else [s for s, _ in STEPS]
    if args.scenes:
        scenes = args.scenes.split(",")
    if args.integrators:
        integrators = args.integrators.split(",")
    if args.steps:
        step_labels = args.steps.split(",")
    steps = [(s, v) for s, v in STEPS if s in step_labels]
    os.makedirs(args.out, exist_ok=True)
    work = args.work or tempfile.mkdtemp(prefix="hard_cases_")
    os.makedirs(work, exist_ok=True)
    settings = {sc: scene_settings(run, os.path.join("config", "hard", sc + ".yaml")) for sc in scenes}
    jobs = [(sc, integ, lbl, val) for sc in scenes for integ in integrators for lbl, val in steps]
    rows = []
    t0 = time.time()
    with concurrent.futures.ThreadPoolExecutor(max_workers=max(1, args.jobs)) as pool:
        futures = [pool.submit(run_one, run, work, sc, integ, lbl, val, settings[sc], args.timeout,
                               args.hair_contact, args.follow_ratio)
                   for sc, integ, lbl, val in jobs]
        for fut in concurrent.futures.as_completed(futures):
            r = fut.result()
            rows.append(r)
            print("%-20s %-15s %-7s %-7s %s" % (r["scene"], r["integrator"], r["substep"], r["status"],
                                               r["failed"]), flush=True)
    order = {j[:3]: k for k, j in enumerate(jobs)}
    rows.sort(key=lambda r: order[(r["scene"], r["integrator"], r["substep"])])
    name = "hard_cases_short" if args.short else "hard_cases"
    if args.hair_contact:
        name += "_contact"
    if args.follow_ratio > 1:
        name += "_followers"
    with open(os.path.join(args.out, name + ".csv"), "w", newline="") as f:
        w = csv.DictWriter(f, fieldnames=COLUMNS, extrasaction="ignore")
        w.writeheader()
        w.writerows(rows)
    command = "bench/hard_cases.py --build _build --jobs 2" + (" --short" if args.short else "") + \
        (" --hair-contact" if args.hair_contact else "") + \
        (" --follow-ratio %d" % args.follow_ratio if args.follow_ratio > 1 else "") + "".join(
            " --%s %s" % (name, value) for name, value in
            [("scenes", args.scenes), ("integrators", args.integrators), ("steps", args.steps)]
            if value)
    md = ("Written by `bench/hard_cases.py`; raw figures in [%s.csv](%s.csv). Total wall time %.0f s."
          "\n\n" % (name, name, time.time() - t0) + markdown(rows, scenes, integrators,
                                                         [s for s, _ in steps], command))
    # OUT/NAME.md: docs/hard_cases.md holds the criteria and what the table says around the
    # markers, so only the table between them is replaced; a file without markers is written whole.
    md_path = os.path.join(args.out, name + ".md")
    if not replace_between_markers(md_path, md):
        with open(md_path, "w") as f:
            f.write("# Stability on hard cases\n\nCriteria: docs/hard_cases.md and the docstring of "
                    "`bench/hard_cases.py`.\n\n" + md)
    if args.readme and not replace_between_markers(args.readme, md):
        print("hard_cases: %s has no hard_cases markers; not changed" % args.readme)
    if not args.work:
        shutil.rmtree(work, ignore_errors=True)
    bad = [r for r in rows if r["expected_stable"] and r["status"] != "stable"]
    print("%d runs in %.0f s; expected stable: %d passed, %d failed" % (
        len(rows), time.time() - t0, sum(r["expected_stable"] for r in rows) - len(bad), len(bad)))
    return 1 if bad else 0


if __name__ == "__main__":
    sys.exit(main())
