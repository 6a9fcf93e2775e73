#!/usr/bin/env python3
"""Builds docs/studies/regimes.md (and its SVG plot) from the jobs of scripts/regime_study.sh's sweep
(out/regime-study/runs/SEQ/CONFIG/seed-S).

Issue 20's question: below what contributing fraction, if any, does stochastic pairwise MIS (seed 004) beat
standard pairwise reuse at equal time in the disoccluded region? Every number comes from the runs' metrics.csv and
run.json; nothing is typed by hand. A sequence's contributing fraction is restir-unbiased (k = 5)'s
contrib_initial_disocc averaged over its post-reveal frames: the share of revealed pixels whose initial sample is
visible and nonzero (restir-unbiased's initial sampling traces visibility), seed 004's "reservoirs with a
contributing path" around a reveal. The error is relmse_corrected_disocc (the reference's own noise subtracted,
docs/metrics.md), since the regime sequences' references are noisy where little light arrives.

With `--study path_reuse` it builds docs/studies/path_reuse.md from scripts/path_reuse_study.sh's sweep instead
(issue 41: the same question for ReSTIR GI's reservoirs, whose samples are paths' secondary vertices): the
contributing fractions, duplicates and spatial work are the gi_* columns, and the two methods restir-gi-unbiased and
restir-gi-spmis (each over restir-unbiased's direct light).
"""
import math
import os
import statistics
import sys

sys.path.insert(0, os.path.dirname(os.path.abspath(__file__)))
from make_window_bars_study import combine, load, mean, summarize, t975  # noqa: E402


# What differs between the studies this script writes: the reservoirs' columns (the direct light's, or ReSTIR GI's
# gi_*), the methods' names, the title, the driver and the hand-written notes appended.
STUDIES = {
    "regimes": dict(prefix="", standard="restir-unbiased", stochastic="restir-spmis",
                    title="Stochastic pairwise MIS across regimes of contributing samples",
                    driver="scripts/regime_study.sh", notes="regime_study_notes.md",
                    contributes="whose initial sample is visible (its initial sampling traces visibility)",
                    paired=True, temporal=False,
                    paired_why="the two methods' runs of one seed draw the same initial reservoirs, from the same "
                               "random numbers, so what a seed's draws make of the error is common to both and "
                               "cancels"),
    "path_reuse": dict(prefix="gi_", standard="restir-gi-unbiased", stochastic="restir-gi-spmis",
                       title="Path reuse: stochastic pairwise MIS in seed 004's own regime (ReSTIR GI)",
                       driver="scripts/path_reuse_study.sh", notes="path_reuse_study_notes.md",
                       contributes="whose initial GI reservoir holds a secondary vertex that sends light towards "
                                   "it (the path's vertex x₂ is directly lit and in front of x₁)",
                       paired=True, temporal=True,
                       paired_why="the two methods' runs of one seed share their paths, direct light and initial "
                                  "reservoirs, so what a seed's paths make of the error, a firefly of an unshifted "
                                  "glossy path, is common to both and cancels"),
}
STUDY = STUDIES["regimes"]


def col(name):
    """A reservoir column of the chosen study (contrib_*, duplicate_fraction, the spatial pass's work)."""
    return STUDY["prefix"] + name


def post_reveal(rows, column):
    revealed = [r for r in rows[1:] if float(r["disocc_recent_fraction"]) > 0]
    return mean([float(r[column]) for r in revealed])


# Columns of issue 39 (absent in older runs: their figures are then None and print as "—"): the share of surface
# pixels whose spatial search found nothing to reuse, and the spatial pass's work per pixel (shadow rays, target
# function evaluations, reservoir reads), over the same frames as ms/frame (every frame but the first), so that a
# reader can re-price the equal-time verdict for a machine with other costs (a GPU, where the cell pass is a
# parallel sort).
OPTIONAL = (("failed", "spatial_failed_fraction"), ("rays_sp", "rays_per_pixel_spatial"),
            ("targets_sp", "targets_per_pixel_spatial"), ("reads_sp", "reservoir_reads_per_pixel_spatial"))


def optional_mean(rows, column):
    column = col(column)
    if not rows or column not in rows[0]:
        return None
    return mean([float(r[column]) for r in rows[1:]])


def opt(v, digits):
    return "—" if v is None else f"{v:.{digits}f}"


def regime_summary(run_dir):
    s = summarize(run_dir)
    _, rows = load(run_dir)
    s["seed"] = os.path.basename(run_dir.rstrip("/"))
    s["relmse_c_disocc"] = post_reveal(rows, "relmse_corrected_disocc")
    s["contrib_initial_disocc"] = post_reveal(rows, col("contrib_initial_disocc"))
    s["contrib_spatial_disocc"] = post_reveal(rows, col("contrib_spatial_disocc"))
    s["contrib_temporal_disocc"] = (post_reveal(rows, col("contrib_temporal_disocc"))
                                    if col("contrib_temporal_disocc") in rows[0] else None)
    s["contrib_shaded"] = mean([float(r[col("contrib_shaded")]) for r in rows])
    s["ref_stderr"] = mean([float(r["reference_rel_stderr"]) for r in rows])
    s["duplicates"] = mean([float(r[col("duplicate_fraction")]) for r in rows])
    s["flip_disocc"] = post_reveal(rows, "flip_disocc")
    for key, column in OPTIONAL:
        s[key] = optional_mean(rows, column)
    return s


def combine_regime(seeds):
    out = combine(seeds)
    for k in ("relmse_c_disocc", "contrib_initial_disocc", "contrib_spatial_disocc", "contrib_shaded",
              "ref_stderr", "duplicates", "flip_disocc"):
        out[k] = mean([s[k] for s in seeds])
    temporal = [s["contrib_temporal_disocc"] for s in seeds if s["contrib_temporal_disocc"] is not None]
    out["contrib_temporal_disocc"] = mean(temporal) if temporal else None
    for k, _ in OPTIONAL:
        xs = [s[k] for s in seeds if s[k] is not None]
        out[k] = mean(xs) if xs else None
    out["per_seed"] = {s["seed"]: s["relmse_c_disocc"] for s in seeds}
    out["per_seed_flip"] = {s["seed"]: s["flip_disocc"] for s in seeds}
    n = len(seeds)
    # 95% half-width over seeds (Student t), as make_window_bars_study.combine gives relmse_disocc's.
    out["relmse_c_disocc_ci"] = (t975(n - 1) * statistics.stdev([s["relmse_c_disocc"] for s in seeds]) / n ** 0.5
                                 if n > 1 else None)
    out["flip_disocc_ci"] = (t975(n - 1) * statistics.stdev([s["flip_disocc"] for s in seeds]) / n ** 0.5
                             if n > 1 else None)
    return out


def err(r, key="relmse_c_disocc"):
    ci = r.get(key + "_ci")
    return f"{r[key]:.4f}" + (f" ± {ci:.4f}" if ci is not None else "")


def paired_resolved(a, b, key):
    """Whether the per-seed differences of a and b in `key` ("per_seed" or "per_seed_flip") have a 95% Student t
    interval that excludes 0; None with fewer than two common seeds."""
    seeds = sorted(set(a[key]) & set(b[key]))
    if len(seeds) < 2:
        return None
    d = [a[key][k] - b[key][k] for k in seeds]
    return abs(mean(d)) > t975(len(d) - 1) * statistics.stdev(d) / len(d) ** 0.5


def resolved(a, b):
    """Whether configurations a and b differ in relmse_c_disocc beyond the seeds' 95% intervals: None with one seed.
    Unpaired, where the two intervals combined are exceeded; paired (STUDY["paired"], STUDY["paired_why"]), where
    the per-seed differences' Student t interval excludes 0."""
    if STUDY["paired"]:
        return paired_resolved(a, b, "per_seed")
    ca, cb = a.get("relmse_c_disocc_ci"), b.get("relmse_c_disocc_ci")
    if ca is None or cb is None:
        return None
    return abs(a["relmse_c_disocc"] - b["relmse_c_disocc"]) > math.hypot(ca, cb)


def pairings(rows):
    """Each stochastic-pairwise configuration against the standard reuse (restir-unbiased) configuration with the
    lowest disoccluded error among those at most 5% slower than it (as docs/studies/window_bars.md pairs them)."""
    pairs = []
    for sp in sorted((r for r in rows if r["label"].startswith("spmis-")), key=lambda r: r["ms"]):
        rivals = [r for r in rows if r["label"].startswith("unbiased-") and r["ms"] <= 1.05 * sp["ms"]]
        if rivals:
            best = min(rivals, key=lambda r: r["relmse_c_disocc"])
            change = 100 * (sp["relmse_c_disocc"] - best["relmse_c_disocc"]) / abs(best["relmse_c_disocc"])
            pairs.append((sp, best, change))
    return pairs


def svg(points, path):
    """Equal-time change of the disoccluded error (%) against the contributing fraction, one mark per pairing."""
    w, h, left, bottom, top, right = 640, 360, 70, 50, 30, 20
    xs = [p[0] for p in points]
    ys = [p[1] for p in points]
    ylo, yhi = min(ys + [-10.0]), max(ys + [10.0])
    pad = 0.08 * (yhi - ylo)
    ylo, yhi = ylo - pad, yhi + pad
    X = lambda x: left + x * (w - left - right)
    Y = lambda y: top + (yhi - y) / (yhi - ylo) * (h - top - bottom)
    out = [f'<svg xmlns="http://www.w3.org/2000/svg" width="{w}" height="{h}" font-family="sans-serif" '
           f'font-size="12">', f'<rect width="{w}" height="{h}" fill="white"/>']
    out.append(f'<line x1="{X(0)}" y1="{Y(0):.1f}" x2="{X(1)}" y2="{Y(0):.1f}" stroke="#888" '
               'stroke-dasharray="4 3"/>')
    out.append(f'<line x1="{X(0)}" y1="{Y(ylo):.1f}" x2="{X(0)}" y2="{Y(yhi):.1f}" stroke="black"/>')
    out.append(f'<line x1="{X(0)}" y1="{Y(ylo):.1f}" x2="{X(1)}" y2="{Y(ylo):.1f}" stroke="black"/>')
    for t in range(0, 11, 2):
        x = t / 10
        out.append(f'<text x="{X(x):.1f}" y="{Y(ylo) + 16:.1f}" text-anchor="middle">{x:.1f}</text>')
    step = 10 ** math.floor(math.log10(max(1e-9, (yhi - ylo) / 4)))
    for m in (1, 2, 5, 10):
        if (yhi - ylo) / (m * step) <= 6:
            step *= m
            break
    y = math.ceil(ylo / step) * step
    while y <= yhi:
        out.append(f'<text x="{X(0) - 6:.1f}" y="{Y(y) + 4:.1f}" text-anchor="end">{y:+.0f}%</text>')
        y += step
    out.append(f'<text x="{(X(0) + X(1)) / 2:.1f}" y="{h - 10}" text-anchor="middle">contributing fraction around '
               f'reveals ({STUDY["standard"]} {col("contrib_initial_disocc")})</text>')
    out.append(f'<text x="14" y="{(Y(ylo) + Y(yhi)) / 2:.1f}" text-anchor="middle" transform="rotate(-90 14 '
               f'{(Y(ylo) + Y(yhi)) / 2:.1f})">spmis vs unbiased at equal time, disocc. error</text>')
    for x, y, label in points:
        colour = "#1a7f37" if y < 0 else "#c0392b"
        out.append(f'<circle cx="{X(x):.1f}" cy="{Y(y):.1f}" r="4" fill="{colour}"><title>{label}: {y:+.1f}%'
                   '</title></circle>')
    out.append(f'<text x="{X(1) - 4}" y="{top - 10}" text-anchor="end">below the dashed line: stochastic pairwise '
               'MIS has the lower error</text>')
    out.append("</svg>")
    with open(path + ".tmp", "w") as f:
        f.write("\n".join(out) + "\n")
    os.replace(path + ".tmp", path)


def main(argv):
    global STUDY
    svg_path = None
    if argv[:1] == ["--study"]:
        STUDY, argv = STUDIES[argv[1]], argv[2:]
    if argv[:1] == ["--svg"]:
        svg_path, argv = argv[1], argv[2:]
    standard, stochastic = STUDY["standard"], STUDY["stochastic"]
    groups = {}
    for d in argv:
        s = regime_summary(d)
        groups.setdefault((s["sequence"], s["label"]), []).append(s)
    by_seq = {}
    for (seq, _), seeds in groups.items():
        by_seq.setdefault(seq, []).append(combine_regime(seeds))
    print(f"# {STUDY['title']}\n")
    print(f"Generated by `scripts/make_regime_study.py` from the runs of `{STUDY['driver']}`; do not edit by "
          "hand.\n")
    any_rows = next(iter(by_seq.values()))
    r0 = any_rows[0]
    seeds = max(r["seeds"] for rows in by_seq.values() for r in rows)
    print(f"Machine: {os.cpu_count()} cores. Each sequence at {r0['resolution'][0]}×{r0['resolution'][1]}, "
          f"frames {r0['frames'][0]}–{r0['frames'][1] - 1}, {seeds} seed(s) per configuration. Error: "
          "`relmse_corrected_disocc` (relMSE over the pixels revealed in the last 4 frames with the reference's own "
          "variance subtracted; docs/metrics.md) averaged over the frames with such pixels. Contributing fraction: "
          f"`{standard}` (k = 5)'s `{col('contrib_initial_disocc')}` over the same frames, the share of revealed "
          f"pixels {STUDY['contributes']}. ms/frame: median over frames, "
          "measured job after job on one machine, the two methods' configurations interleaved. `flip_disocc`: "
          "mean HDR-FLIP over the same pixels and frames (what tone mapping shows), ± its 95% interval over seeds. "
          f"Failed: `{col('spatial_failed_fraction')}`, the share of surface pixels per spatial iteration whose search found "
          "nothing to reuse. Equal work: the spatial pass's shadow rays, target-function evaluations and reservoir "
          "reads per pixel, over the frames ms/frame covers, to re-price the verdict for other hardware (on a GPU "
          "the stochastic pass's cell building is a parallel sort); — where the runs predate these counters.\n")
    print("| config | preset | settings |\n| --- | --- | --- |")
    for r in any_rows:
        print(f"| {r['label']} | `{r['preset']}` | {r['overrides']} |")
    print()
    points, summary = [], []
    for seq, rows in sorted(by_seq.items(), key=lambda kv: -next(
            (r["contrib_initial_disocc"] for r in kv[1] if r["label"] == "unbiased-k5"), 0.0)):
        by = {r["label"]: r for r in rows}
        base = by.get("unbiased-k5", rows[0])
        frac = base["contrib_initial_disocc"]
        print(f"## {seq}: contributing fraction {frac:.3f}\n")
        after_temporal = (f"After temporal reuse {base['contrib_temporal_disocc']:.3f} and after spatial reuse "
                          if STUDY["temporal"] and base["contrib_temporal_disocc"] is not None else
                          "After spatial reuse ")
        print(f"{after_temporal}{base['contrib_spatial_disocc']:.3f} of the revealed pixels hold a contributing "
              f"sample ({standard}, k = 5); over whole frames its shading reaches "
              f"{base['contrib_shaded']:.3f} of the pixels; the reference's mean relative standard error is "
              f"{base['ref_stderr']:.3f}.\n")
        print(f"| config | relmse_corrected_disocc | flip_disocc | relmse_disocc | relmse | {col('contrib_spatial_disocc')} | "
              "duplicates | failed | rays/px spatial | targets/px spatial | reservoir reads/px spatial | ms/frame |")
        print("| --- | --- | --- | --- | --- | --- | --- | --- | --- | --- | --- | --- |")
        for r in sorted(rows, key=lambda r: (r["preset"], r["ms"])):
            print(f"| {r['label']} | {err(r)} | {err(r, 'flip_disocc')} | {r['relmse_disocc']:.4f} | "
                  f"{r['relmse']:.4f} | {r['contrib_spatial_disocc']:.3f} | {r['duplicates']:.4f} | "
                  f"{opt(r['failed'], 3)} | {opt(r['rays_sp'], 2)} | {opt(r['targets_sp'], 1)} | "
                  f"{opt(r['reads_sp'], 1)} | {r['ms']:.0f} |")
        pairs = pairings(rows)
        print()
        if pairs:
            print(f"| {stochastic} | ms/frame | {standard} (best within 5% of its time) | ms/frame | change | "
                  "resolved by the seeds |")
            print("| --- | --- | --- | --- | --- | --- |")
            n_resolved = 0
            for a, b, change in pairs:
                r = resolved(a, b)
                res = "n/a (1 seed)" if r is None else "yes" if r else "no"
                n_resolved += res == "yes"
                print(f"| {a['label']} | {a['ms']:.0f} | {b['label']} | {b['ms']:.0f} | {change:+.1f}% | {res} |")
                points.append((frac, change, f"{seq} {a['label']} vs {b['label']}"))
            wins = sum(1 for _, _, c in pairs if c < 0)
            # With intervals, a sequence counts as a win or a loss only where a pairing is resolved.
            verdicts = []
            for a, b, change in pairs:
                r = resolved(a, b)
                if r is None or r:
                    verdicts.append("win" if change < 0 else "loss")
            summary.append((seq, frac, wins, len(pairs), min(c for _, _, c in pairs),
                            "win" if "win" in verdicts else "loss" if "loss" in verdicts else "tie"))
            print(f"\nAt equal time stochastic pairwise MIS has the lower disoccluded error in {wins} of "
                  f"{len(pairs)} pairings ({n_resolved} of them resolved by the seeds' 95% intervals).\n")
            if STUDY["paired"]:
                # What tone mapping shows: relMSE is carried by a few pixels' heavy tails, FLIP by every pixel.
                print("The same pairings by `flip_disocc` (paired over seeds the same way):\n")
                print("| pairing | flip_disocc | change | resolved by the seeds |\n| --- | --- | --- | --- |")
                for a, b, _ in pairs:
                    r = paired_resolved(a, b, "per_seed_flip")
                    fchange = 100 * (a["flip_disocc"] - b["flip_disocc"]) / b["flip_disocc"]
                    print(f"| {a['label']} vs {b['label']} | {a['flip_disocc']:.4f} vs {b['flip_disocc']:.4f} | "
                          f"{fchange:+.1f}% | {'n/a' if r is None else 'yes' if r else 'no'} |")
                print()
        else:
            print(f"No {standard} configuration is as fast as any {stochastic} one: no equal-time pairing.\n")
    print("## Crossover\n")
    print("| sequence | contributing fraction | spmis lower at equal time | best change | verdict |")
    print("| --- | --- | --- | --- | --- |")
    names = {"win": "spmis wins", "loss": "spmis loses", "tie": "not resolved"}
    for seq, frac, wins, n, best, verdict in summary:
        print(f"| {seq} | {frac:.3f} | {wins} of {n} | {best:+.1f}% | {names[verdict]} |")
    fmt = lambda xs: ", ".join(f"{s[0]} ({s[1]:.3f})" for s in xs)
    winners = [s for s in summary if s[5] == "win"]
    losers = [s for s in summary if s[5] == "loss"]
    ties = [s for s in summary if s[5] == "tie"]
    print()
    if STUDY["paired"]:
        print("A sequence's verdict: a win or a loss where at least one pairing's per-seed differences have a 95% "
              f"Student t interval that excludes 0 (paired: {STUDY['paired_why']}), otherwise not resolved.\n")
    else:
        print("A sequence's verdict: a win or a loss where at least one pairing's difference exceeds the two 95% "
              "intervals combined (with one seed, every pairing counts), otherwise not resolved.\n")
    if not winners:
        print(f"**Stochastic pairwise MIS never wins at equal time** over contributing fractions "
              f"{min(s[1] for s in summary):.3f}–{max(s[1] for s in summary):.3f}: it loses on {fmt(losers) or 'none'}"
              + (f"; not resolved on {fmt(ties)}" if ties else "") + ".\n")
    elif not losers:
        print(f"**Stochastic pairwise MIS wins at equal time** on {fmt(winners)}"
              + (f"; not resolved on {fmt(ties)}" if ties else "") + ".\n")
    else:
        below = max(s[1] for s in winners)
        above = min(s[1] for s in losers)
        if below < above:
            print(f"**Crossover: stochastic pairwise MIS wins at equal time where the contributing fraction is at "
                  f"most {below:.3f} and loses from {above:.3f} up.**\n")
        else:
            print(f"**No clean crossover**: it wins on {fmt(winners)} and loses on {fmt(losers)}.\n")
    if svg_path:
        svg(points, svg_path)
        print(f"![equal-time change against the contributing fraction]({os.path.basename(svg_path)})\n")
    notes = os.path.join(os.path.dirname(os.path.abspath(__file__)), STUDY["notes"])
    if os.path.exists(notes):
        with open(notes) as f:
            print(f.read().rstrip() + "\n")
    return 0


if __name__ == "__main__":
    sys.exit(main(sys.argv[1:]))
