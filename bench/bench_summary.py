#!/usr/bin/env python3
"""Summarises what wet_curly_hair_bench wrote (docs/performance.md).

    bench/bench_summary.py [DIR]        DIR defaults to docs/bench; writes DIR/summary.md

From work_precision.csv: for each scene and error budget (RMS particle error / strand length),
the cheapest stable setting of each integrator that meets it, and which integrator wins (the
ratio of its cost to the runner-up's, both measured in the same run). From scaling.csv: the
cost per particle-substep against the strand count, its spread (largest / smallest over the
counts), the gain of a second thread, and the real-time factors at 1,000 and 10,000 strands,
measured at the scaling substep and derived for the cheapest setting that met 1 % on every
scene (cost per particle-substep x particles / substep; said so in the table). From gating.csv:
dry against wet and an out-of-reach obstacle against none. Writes DIR/defaults.txt: the
integrator and substep the package's defaults must be (the cheapest mean cost among the settings
that met 1 % on every scene; test_config holds SolverConfig's defaults to it). Python 3 standard
library only.
"""
import csv
import os
import sys

BUDGETS = [0.01, 0.003]


def rows(path):
    with open(path) as f:
        return list(csv.DictReader(f))


def fmt(v, digits=3):
    return ("%." + str(digits) + "g") % v


def cheapest(points, budget):
    ok = [p for p in points if p["stable"] == "1" and float(p["rms_error"]) <= budget]
    return min(ok, key=lambda p: float(p["wall_s_per_sim_s"])) if ok else None


def work_precision(out, wp):
    scenes = []
    for r in wp:
        if r["scene"] not in scenes:
            scenes.append(r["scene"])
    integrators = []
    for r in wp:
        if r["integrator"] not in integrators:
            integrators.append(r["integrator"])
    out.append("## Cheapest stable setting per error budget\n")
    out.append("Cost: wall seconds per simulated second (median of the runs, %s strands as run). "
               "Error: RMS over the output frames / strand length. `-`: no stable setting of "
               "that integrator met the budget.\n" % "the benchmark's")
    for budget in BUDGETS:
        out.append("\n### RMS error at most %g %%\n" % (100 * budget))
        out.append("| scene | " + " | ".join(integrators) + " | wins | ratio to the next |")
        out.append("|---|" + "---|" * (len(integrators) + 2))
        for s in scenes:
            cells, best = [], []
            for m in integrators:
                p = cheapest([r for r in wp if r["scene"] == s and r["integrator"] == m], budget)
                if p:
                    cells.append("%s s: %s s/s (%.2g %%)" % (fmt(float(p["substep_s"])),
                                                        fmt(float(p["wall_s_per_sim_s"])),
                                                        100 * float(p["rms_error"])))
                    best.append((float(p["wall_s_per_sim_s"]), m))
                else:
                    cells.append("-")
            best.sort()
            wins = best[0][1] if best else "-"
            ratio = fmt(best[1][0] / best[0][0], 2) + "x" if len(best) > 1 else "-"
            out.append("| %s | %s | %s | %s |" % (s, " | ".join(cells), wins, ratio))
    # One setting for every scene: per integrator, the largest substep that met 1 % everywhere.
    out.append("\n### One setting for every scene at 1 %\n")
    out.append("| integrator | largest substep meeting 1 % on every scene, s | worst RMS there | "
               "mean cost there, s/s |")
    out.append("|---|---|---|---|")
    common = {}
    for m in integrators:
        steps = sorted({float(r["substep_s"]) for r in wp if r["integrator"] == m})
        good = None
        for h in steps:
            pts = [r for r in wp if r["integrator"] == m and float(r["substep_s"]) == h]
            if len(pts) == len(scenes) and all(p["stable"] == "1" and
                                               float(p["rms_error"]) <= 0.01 for p in pts):
                good = (h, max(float(p["rms_error"]) for p in pts),
                        sum(float(p["wall_s_per_sim_s"]) for p in pts) / len(pts))
        if good:
            common[m] = good
            out.append("| %s | %s | %.2g %% | %s |" % (m, fmt(good[0]), 100 * good[1], fmt(good[2])))
        else:
            out.append("| %s | none | - | - |" % m)
    return common


def scaling(out, sc, common):
    out.append("\n## Scaling (full wet model, obstacle in reach, cohesion display pass off)\n")
    settings = []
    for r in sc:
        key = (r["integrator"], r["substep_s"])
        if key not in settings:
            settings.append(key)
    paired = bool(sc) and "relative_to_1000" in sc[0]
    out.append("| integrator | substep, s | threads | ns per particle-substep, 100 -> 10,000 "
               "strands | spread | %sreal-time factor 1,000 / 10,000 strands |" %
               ("paired spread | " if paired else ""))
    out.append("|---|---|---|---|---|%s---|" % ("---|" if paired else ""))
    ns_at = {}
    for m, h in settings:
        for t in ("1", "2"):
            pts = sorted([r for r in sc if r["integrator"] == m and r["substep_s"] == h and
                          r["threads"] == t], key=lambda r: int(r["strands"]))
            if not pts:
                continue
            ns = [float(p["ns_per_particle_substep"]) for p in pts]
            rtf = {int(p["strands"]): float(p["realtime_factor"]) for p in pts}
            for p in pts:
                ns_at[(m, t, int(p["strands"]))] = float(p["ns_per_particle_substep"])
            # Paired: each point's cost over the 1,000-strand point's, median of the ratios
            # within each round (the bench interleaves the strand counts in rounds).
            rel = [float(p["relative_to_1000"]) for p in pts] if paired else []
            out.append("| %s | %s | %s | %s | %.2fx | %s%s / %s |" % (
                m, fmt(float(h)), t, ", ".join("%.0f" % v for v in ns), max(ns) / min(ns),
                ("%.2fx | " % (max(rel) / min(rel))) if paired else "",
                fmt(rtf.get(1000, float("nan"))), fmt(rtf.get(10000, float("nan")))))
    out.append("\nSecond thread (cost with 1 thread / cost with 2), per strand count:\n")
    for m, h in settings:
        gains = []
        for n in sorted({int(r["strands"]) for r in sc}):
            a, b = ns_at.get((m, "1", n)), ns_at.get((m, "2", n))
            if a and b:
                gains.append("%d: %.2fx" % (n, a / b))
        out.append("- %s %s s: %s" % (m, fmt(float(h)), ", ".join(gains)))
    # Derived: the real-time factor at the 1 % setting, from the measured cost per
    # particle-substep of the same integrator (the cost per particle-substep barely depends on
    # the substep; the work-precision runs show cost proportional to 1 / substep).
    out.append("\nDerived, at the largest substep meeting 1 % on every scene (cost per "
               "particle-substep measured above x 32 particles x strands / substep):\n")
    out.append("| integrator | substep, s | threads | real-time factor 1,000 strands | 10,000 strands |")
    out.append("|---|---|---|---|---|")
    for m, (h, _, _) in common.items():
        for t in ("1", "2"):
            r1, r2 = ns_at.get((m, t, 1000)), ns_at.get((m, t, 10000))
            if not r1:
                continue
            f = lambda ns, n: 1.0 / (ns * 1e-9 * 32 * n / h)
            out.append("| %s | %s | %s | %s | %s |" % (m, fmt(h), t, fmt(f(r1, 1000)),
                                                     fmt(f(r2, 10000)) if r2 else "-"))


def builtin(out, b):
    """The built-in scene exactly as shipped (the defaults, every hardware thread): its real-time
    factor, the median of the runs and their range."""
    if not b:
        return
    r = b[0]
    out.append("\n## Built-in scene at the defaults\n")
    out.append("| strands | integrator, substep | threads | lanes | cohesion | real-time factor "
               "(median of %s runs of %s s) | range |" % (r["runs"], r["sim_s"]))
    out.append("|---|---|---|---|---|---|---|")
    out.append("| %s | %s, %s s | %s | %s | %s | %.2f | %.2f to %.2f |" % (
        r["strands"], r["integrator"], r["substep_s"], r["threads"], r["lane_layout"],
        r["cohesion"], float(r["realtime_factor"]), float(r["realtime_factor_min"]),
        float(r["realtime_factor_max"])))


def target(out, t):
    """The headline target scene measured on itself: cost and error per candidate setting, the
    error over the horizon where the reference converged (and over the whole run); first the
    dynamics alone, then the full wet model with its per-frame cohesion display pass (errors of
    the output positions p^w against the reference's, exact cohesion)."""
    check = [r for r in t if r["integrator"] == "reference_check"]
    check_out = [r for r in t if r["integrator"] == "reference_check_output"]
    runs = [r for r in t if not r["integrator"].startswith("reference_check")]
    if not runs:
        return
    n = runs[0]["strands"]
    out.append("\n## Target scene: %s strands x 32, full wet model + obstacle, %s threads\n"
               % (n, runs[0]["threads"]))
    horizon = None
    if check:
        c = check[0]
        horizon = c.get("horizon_s")
        out.append("Reference: %s s. Over the whole run it differs from the check by RMS %s, max %s "
                   "of the strand length; it converges (per-frame RMS <= 0.1 %%) over the first %s s, "
                   "where the difference is RMS %s, max %s. Errors below are over that horizon "
                   "(whole run in brackets).\n" % (
                       c["substep_s"], fmt(float(c.get("rms_error_whole_run") or c["rms_error"])),
                       fmt(float(c.get("max_error_whole_run") or c["max_error"])),
                       horizon or "?", fmt(float(c["rms_error"])), fmt(float(c["max_error"]))))
    if check_out:
        c = check_out[0]
        out.append("The reference runs the full model with the exact cohesion evaluation; its output "
                   "positions p^w differ from the check's by RMS %s, max %s over the horizon.\n"
                   % (fmt(float(c["rms_error"])), fmt(float(c["max_error"]))))
    pct = lambda v: "%.2f %%" % (100 * float(v)) if v else "-"

    def table(rows, title):
        out.append(title)
        out.append("| integrator | substep, s | strands in lanes | cohesion display pass | cost, s/s "
                   "| real-time factor | RMS error | max error | stable |")
        out.append("|---|---|---|---|---|---|---|---|---|")
        best = None
        for r in rows:
            rms = float(r["rms_error"]) if r["rms_error"] else None
            whole_rms, whole_max = r.get("rms_error_whole_run"), r.get("max_error_whole_run")
            out.append("| %s | %s | %s | %s | %s | %s | %s | %s | %s |" % (
                r["integrator"], fmt(float(r["substep_s"])),
                "yes" if r["strand_lanes"] == "1" else "no", r["cohesion"],
                fmt(float(r["wall_s_per_sim_s"])), fmt(float(r["realtime_factor"])),
                pct(r["rms_error"]) + (" (%s)" % pct(whole_rms) if whole_rms else ""),
                pct(r["max_error"]) + (" (%s)" % pct(whole_max) if whole_max else ""),
                "yes" if r["stable"] == "1" else "no"))
            if rms is not None and rms <= 0.01 and r["stable"] == "1":
                if best is None or float(r["realtime_factor"]) > float(best["realtime_factor"]):
                    best = r
        if best:
            out.append("\nFastest stable setting within 1 %% RMS: %s at %s s, cohesion %s, "
                       "real-time factor %s (RMS %.2f %%).\n" % (
                           best["integrator"], fmt(float(best["substep_s"])), best["cohesion"],
                           fmt(float(best["realtime_factor"])), 100 * float(best["rms_error"])))
        else:
            out.append("\nNo stable setting within 1 % RMS.\n")

    table([r for r in runs if r["cohesion"] == "off"],
          "Dynamics alone (cohesion display pass off), errors of the simulated positions:\n")
    full = [r for r in runs if r["cohesion"] != "off"]
    if full:
        table(full, "Full wet model: the dynamics plus the per-frame cohesion display pass (exact, "
              "or the lattice at 4, 3, 2 nodes per radius, in float; grid4_double: in double), "
              "errors of the output positions p^w:\n")
    shape_table(out, [r for r in t if r.get("tip_height_w1_m")])


def shape_table(out, rows):
    """The shape distributions pooled over the whole run against the reference's (Wasserstein-1
    and Kolmogorov-Smirnov, core/shape_stats.h): the reference check's row is the floor."""
    if not rows:
        return
    out.append("Shape distributions over the whole run (every output frame after the first) against "
               "the reference's: Wasserstein-1 distance (W1) of tip height, tip curl radius and "
               "clump distance, and the largest Kolmogorov-Smirnov statistic of the three. The "
               "reference checks' rows are the floor.\n")
    out.append("| integrator | substep | strands in lanes | cohesion | tip height W1, mm "
               "| curl radius W1, um | clump distance W1, um | largest KS |")
    out.append("|---|---|---|---|---|---|---|---|")
    for r in rows:
        ks = max(float(r[k + "_ks"]) for k in ("tip_height", "curl_radius", "clump_distance"))
        out.append("| %s | %s | %s | %s | %.3f | %.1f | %.1f | %.4f |" % (
            r["integrator"], r["substep_s"], "yes" if r["strand_lanes"] == "1" else "no",
            r["cohesion"], 1e3 * float(r["tip_height_w1_m"]), 1e6 * float(r["curl_radius_w1_m"]),
            1e6 * float(r["clump_distance_w1_m"]), ks))


def lanes(out, rows_):
    """Float or double: the target scene's dynamics in every lane layout, cost (and its ratio to
    double4, median of the ratios within one repeat) against the error, in one run."""
    if not rows_:
        return
    out.append("\n## Float or double: strand-lane layouts (target scene, dynamics alone, %s strands, "
               "%s threads)\n" % (rows_[0]["strands"], rows_[0]["threads"]))
    out.append("| integrator | substep, s | lane layout | cost, s/s | real-time factor "
               "| cost / double4 | RMS error | max error | stable |")
    out.append("|---|---|---|---|---|---|---|---|---|")
    for r in rows_:
        out.append("| %s | %s | %s | %s | %s | %s | %.3f %% | %.3f %% | %s |" % (
            r["integrator"], fmt(float(r["substep_s"])), r["lane_layout"],
            fmt(float(r["wall_s_per_sim_s"])), fmt(float(r["realtime_factor"])),
            fmt(float(r["cost_vs_double4"])), 100 * float(r["rms_error"]),
            100 * float(r["max_error"]), "yes" if r["stable"] == "1" else "no"))


def gating(out, g):
    out.append("\n## Model only what the scene needs (100 strands, nodding)\n")
    out.append("| integrator | variant | cost, s/s | / wet | / same without the obstacle |")
    out.append("|---|---|---|---|---|")
    for r in g:
        out.append("| %s | %s | %s | %s | %s |" % (r["integrator"], r["variant"],
                                                   fmt(float(r["wall_s_per_sim_s"])),
                                                   fmt(float(r["ratio_to_wet"])),
                                                   fmt(float(r["ratio_to_no_obstacle"]))))


# The cohesion evaluation's error against exact, at most this fraction of exact's RMS display
# displacement |p^w - p|: the bound test_cohesion holds the node volumes and "auto" to.
DISPLACEMENT_BUDGET = 0.2


def cohesion_rows(d):
    """cohesion.csv's rows; a file from before the lattice density was a candidate ran the
    lattice at 4 nodes per radius only, and had no output-position errors; one from before the
    sums convolved at the nodes were a candidate gathered them at every particle."""
    path = os.path.join(d, "cohesion.csv")
    if not os.path.exists(path):
        return []
    rs = rows(path)
    for r in rs:
        r["cells_per_radius"] = r.get("cells_per_radius") or "4"
        r["wet_sums"] = r.get("wet_sums") or "particles"
    return rs


def cohesion_choice(rs):
    """The cheapest evaluation (summed cost over the strand counts) that meets the budgets at
    every strand count: its clump distance within 1 % of exact's (the look); its output
    positions within 1 % of the strand length RMS of exact's over the run (the chart's budget);
    and within a fifth of exact's RMS displacement |p^w - p| (DISPLACEMENT_BUDGET: 1 % of a 25 cm
    strand is about the whole clumping displacement, so the chart's budget alone barely holds
    the display pass). The last two are not checked on a file without their columns.
    (evaluation, lattice nodes per radius, where the lattice's sums ran) or None."""
    if not rs:
        return None
    exact = {r["strands"]: float(r["clump_distance_m"]) for r in rs if r["evaluation"] == "exact"}
    best = None
    def key_of(r):
        return (r["evaluation"], int(r["cells_per_radius"]), r["wet_sums"])
    for key in sorted({key_of(r) for r in rs}):
        pts = [r for r in rs if key_of(r) == key]
        ok = all(r["strands"] in exact and
                 abs(float(r["clump_distance_m"]) - exact[r["strands"]]) <= 0.01 * exact[r["strands"]]
                 and float(r.get("pw_rms_vs_exact_length") or 0.0) <= 0.01
                 and float(r.get("pw_rms_vs_exact_rel") or 0.0) <= DISPLACEMENT_BUDGET
                 for r in pts)
        if ok:
            cost = sum(float(r["us_per_wet_particle_frame"]) for r in pts)
            if best is None or cost < best[1]:
                best = (key, cost)
    return best[0] if best else None


def sums_cell(r):
    """Where a lattice row's sums ran: at the particles or the nodes, or "auto" and the lattice it
    resolved to (its row is that lattice's)."""
    if r["evaluation"] != "grid":
        return "-"
    if r["wet_sums"] == "auto":
        return "auto: %s" % (r.get("lattice") or "?")
    return "at the " + r["wet_sums"]


def cohesion(out, rs):
    out.append("\n## Cohesion display pass (fully wet, still head, 0.2 s)\n")
    out.append("CPU per wet particle-frame, clump distance, and the output positions' RMS distance "
               "from exact's over the run (relative to exact's RMS displacement |p^w - p| and to the "
               "strand length).\n")
    out.append("| strands | evaluation | nodes per radius | sums | us per wet particle-frame "
               "| clump distance, mm | p^w vs exact, mm | of the displacement | of the length |")
    out.append("|---|---|---|---|---|---|---|---|---|")
    for r in rs:
        err = r.get("pw_rms_vs_exact_m")  # absent from files written before the column
        out.append("| %s | %s | %s | %s | %s | %s | %s | %s | %s |" % (
            r["strands"], r["evaluation"],
            r["cells_per_radius"] if r["evaluation"] == "grid" else "-",
            sums_cell(r),
            fmt(float(r["us_per_wet_particle_frame"])), fmt(1e3 * float(r["clump_distance_m"]), 4),
            fmt(1e3 * float(err)) if err else "-",
            ("%.1f %%" % (100 * float(r["pw_rms_vs_exact_rel"]))) if err else "-",
            ("%.3f %%" % (100 * float(r["pw_rms_vs_exact_length"]))) if r.get("pw_rms_vs_exact_length") else "-"))
    choice = cohesion_choice(rs)
    if choice:
        out.append("\nChosen (clump distance within 1 %% of exact's, p^w within 1 %% of the "
                   "length and within %g %% of the displacement at every count, cheapest): %s%s.\n"
                   % (100 * DISPLACEMENT_BUDGET, choice[0], ", %d nodes per radius, sums %s" % (
                       choice[1], "auto" if choice[2] == "auto" else "at the " + choice[2])
                      if choice[0] == "grid" else ""))


# Costs closer than this (a ratio) are a tie: medians of 5 runs move by a few per cent between
# runs on the same machine, so the setting with the smaller worst error wins a tie.
COST_TIE = 1.05


def chosen_setting(common):
    """(method, (substep, worst error, mean cost)): the cheapest, or among those within COST_TIE
    of the cheapest, the one with the smallest worst error."""
    cheapest_cost = min(v[2] for v in common.values())
    tied = [kv for kv in common.items() if kv[1][2] <= COST_TIE * cheapest_cost]
    return min(tied, key=lambda kv: (kv[1][1], kv[1][2]))


def write_defaults(d, common):
    """The chosen setting: among the integrators with a substep meeting 1 % on every scene, the
    one of lowest mean cost there; the cohesion evaluation from cohesion_choice."""
    if not common:
        return
    method, (substep, worst, cost) = chosen_setting(common)
    evaluation = cohesion_choice(cohesion_rows(d))
    with open(os.path.join(d, "defaults.txt"), "w") as f:
        f.write("# Written by bench/bench_summary.py from work_precision.csv: the cheapest setting\n"
                "# (mean wall s per simulated s over the scenes) meeting 1 %% RMS of the strand\n"
                "# length over the whole run and stable (finite, no repair, strain before the\n"
                "# limit within twice it) on every benchmark scene (worst there %.2g %%,\n"
                "# mean cost %s s/s; costs within %g x of the cheapest are a tie, won by the\n"
                "# smaller worst error). test_config holds SolverConfig's defaults to it.\n"
                % (100 * worst, fmt(cost), COST_TIE))
        f.write("solver.integrator.method %s\n" % method)
        f.write("solver.integrator.substep_s %s\n" % fmt(substep))
        if evaluation:
            f.write("# From cohesion.csv: the cheapest evaluation whose clump distance is within\n"
                    "# 1 %% of exact's and whose output positions are within 1 %% of the strand\n"
                    "# length RMS of exact's and within %g %% of its RMS displacement, at every\n"
                    "# strand count measured.\n" % (100 * DISPLACEMENT_BUDGET))
            f.write("solver.cohesion.evaluation %s\n" % evaluation[0])
            if evaluation[0] == "grid":
                f.write("solver.cohesion.grid_cells_per_radius %d\n" % evaluation[1])
                f.write("solver.cohesion.grid_wet_sums %s\n" % evaluation[2])


def main():
    d = sys.argv[1] if len(sys.argv) > 1 else os.path.join(
        os.path.dirname(os.path.dirname(os.path.abspath(__file__))), "docs", "bench")
    out = ["# Benchmark summary\n", "Written by `bench/bench_summary.py` from the CSV files "
           "beside it (`scripts/bench`).\n"]
    common = {}
    if os.path.exists(os.path.join(d, "builtin.csv")):
        builtin(out, rows(os.path.join(d, "builtin.csv")))
    if os.path.exists(os.path.join(d, "work_precision.csv")):
        common = work_precision(out, rows(os.path.join(d, "work_precision.csv")))
        write_defaults(d, common)
    if os.path.exists(os.path.join(d, "scaling.csv")):
        scaling(out, rows(os.path.join(d, "scaling.csv")), common)
    if os.path.exists(os.path.join(d, "target.csv")):
        target(out, rows(os.path.join(d, "target.csv")))
    if os.path.exists(os.path.join(d, "lanes.csv")):
        lanes(out, rows(os.path.join(d, "lanes.csv")))
    if cohesion_rows(d):
        cohesion(out, cohesion_rows(d))
    if os.path.exists(os.path.join(d, "gating.csv")):
        gating(out, rows(os.path.join(d, "gating.csv")))
    text = "\n".join(out) + "\n"
    with open(os.path.join(d, "summary.md"), "w") as f:
        f.write(text)
    sys.stdout.write(text)


if __name__ == "__main__":
    main()
