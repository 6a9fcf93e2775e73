#!/usr/bin/env python3
"""Builds docs/studies/spmis_ablation.md from the jobs of scripts/spmis_ablation_study.sh's sweep
(out/spmis-ablation/runs/SEQ/CONFIG/seed-S).

Issue 39's ablation: stochastic pairwise MIS (restir-spmis, seed 004) against standard pairwise reuse
(restir-unbiased) at equal shifted candidates inside the revealed region, over the stochastic pass's cell-search
radius, canonical draws N_c and canonical pdf. Every number comes from the runs' metrics.csv and run.json; nothing
is typed by hand. Figures are means over seeds; the disoccluded region's errors carry their 95% interval over
seeds (Student t). The document's line "best stochastic configuration: NAME (SETTINGS)" gives SETTINGS as a JSON
object fragment, which scripts/regime_study.sh takes as SPMIS_SET.
"""
import math
import os
import platform
import statistics
import sys

sys.path.insert(0, os.path.dirname(os.path.abspath(__file__)))
from make_window_bars_study import load, mean, t975  # noqa: E402

# Frames since the reveal shown in the by-frame tables (those the run has, with a non-empty mask).
SINCE_REVEAL = (0, 1, 2, 3, 4, 6, 8, 12, 16)
# A frame is a reveal when this fraction of the pixels or more lies in the 4-frame disocclusion mask.
REVEAL_THRESHOLD = 0.01
# The settings the ablation varies: the best configuration's values of these are handed to the regime study.
ABLATED = ("spatial.cellSearchRadius", "spatial.canonicalDraws", "spatial.canonicalPdf")
# Per-pixel work counters of the spatial pass (absent in runs older than issue 39: shown as "—").
WORK = (("rays", "rays_per_pixel_spatial"), ("targets", "targets_per_pixel_spatial"),
        ("reads", "reservoir_reads_per_pixel_spatial"))


def num(row, column):
    v = row.get(column)
    return float(v) if v not in (None, "") else None


def mean_of(rows, column):
    xs = [num(r, column) for r in rows]
    xs = [x for x in xs if x is not None]
    return mean(xs) if xs else None


def recent_column(rows):
    return "disocc_recent_fraction" if rows and "disocc_recent_fraction" in rows[0] else "disocc_fraction"


def load_job(run_dir):
    """One job's run.json and metrics.csv, or None when the job has not written them (yet)."""
    if not (os.path.exists(os.path.join(run_dir, "metrics.csv")) and os.path.exists(os.path.join(run_dir, "run.json"))):
        return None
    run, rows = load(run_dir)
    if len(rows) < 2:
        return None
    parts = run_dir.rstrip("/").split("/")
    label = parts[-2] if parts[-1].startswith("seed-") and len(parts) > 1 else parts[-1]
    preset = list(run["presets"].keys())[0]
    overrides = dict(o.split("=", 1) for o in run.get("overrides", []))
    return {"label": label, "seed": run.get("seed"), "sequence": run["sequence"]["name"], "preset": preset,
            "overrides": overrides, "settings": run["presets"][preset].get("settings", {}),
            "resolution": run["resolution"], "frames": run["frames"], "rows": rows}


def find_reveal(rows):
    """The first frame after the run's first (which has no history) whose disocclusion mask covers at least
    REVEAL_THRESHOLD of the pixels; else the first with any; else None."""
    col = recent_column(rows)
    later = rows[1:]
    for cond in (lambda x: x >= REVEAL_THRESHOLD, lambda x: x > 0):
        for r in later:
            if cond(float(r[col])):
                return int(r["frame"]), col
    return None, col


def seed_summary(job, reveal):
    rows = job["rows"]
    col = recent_column(rows)
    later = rows[1:]
    post = [r for r in later if (reveal is None or int(r["frame"]) >= reveal) and float(r[col]) > 0]
    s = {"rc": mean_of(post, "relmse_corrected_disocc"), "flip": mean_of(post, "flip_disocc"),
         "relmse": mean_of(later, "relmse"), "failed": mean_of(post, "spatial_failed_fraction"),
         "ms": statistics.median(float(r["ms_frame"]) for r in later), "post_frames": len(post),
         "by_frame": {int(r["frame"]): (num(r, "relmse_corrected_disocc"), num(r, "flip_disocc"),
                                        float(r[col]) > 0) for r in later}}
    for key, column in WORK:
        s[key] = mean_of(post, column)
    return s


def interval(xs):
    """Mean and 95% Student-t half-width over seeds (None with one seed)."""
    xs = [x for x in xs if x is not None]
    if not xs:
        return None, None
    if len(xs) == 1:
        return xs[0], None
    n = len(xs)
    return mean(xs), t975(n - 1) * statistics.stdev(xs) / n ** 0.5


def combine(jobs, reveal):
    seeds = [seed_summary(j, reveal) for j in jobs]
    c = {"label": jobs[0]["label"], "preset": jobs[0]["preset"], "overrides": jobs[0]["overrides"],
         "settings": jobs[0]["settings"], "seeds": len(seeds), "seed_rows": seeds}
    c["rc"], c["rc_ci"] = interval([s["rc"] for s in seeds])
    c["flip"], c["flip_ci"] = interval([s["flip"] for s in seeds])
    for k in ("relmse", "failed", "ms") + tuple(k for k, _ in WORK):
        xs = [s[k] for s in seeds if s[k] is not None]
        c[k] = mean(xs) if xs else None
    return c


def fmt(v, ci=None, digits=4):
    if v is None:
        return "—"
    return f"{v:.{digits}f}" + (f" ± {ci:.{digits}f}" if ci is not None else "")


def resolved(a, b, key):
    ca, cb = a.get(key + "_ci"), b.get(key + "_ci")
    if ca is None or cb is None or a[key] is None or b[key] is None:
        return None
    return abs(a[key] - b[key]) > math.hypot(ca, cb)


def change(a, b, key):
    if a[key] is None or b[key] is None or b[key] == 0:
        return float("nan")
    return 100 * (a[key] - b[key]) / abs(b[key])


def setting(c, key):
    v = c["overrides"].get(key, c["settings"].get(key))
    return None if v is None else str(v)


def json_value(v):
    if v in ("true", "false"):
        return v
    try:
        float(v)
        return v
    except ValueError:
        return '"' + v.replace('"', '\\"') + '"'


def fragment(c):
    return ", ".join(f'"{k}": {json_value(setting(c, k))}' for k in ABLATED if setting(c, k) is not None)


def is_baseline(c):
    return c["label"].startswith("unbiased-") or c["preset"] == "restir-unbiased"


def equal_candidates(c, base):
    """A stochastic configuration is at equal candidates in the revealed region when its draws there equal the
    baseline's neighbours there (without the settings in run.json, by name: every spmis-* but spmis-old)."""
    if is_baseline(c):
        return False
    draws, neighbours = setting(c, "spatial.disocclusionDraws"), setting(base, "spatial.disocclusionNeighbours")
    if draws is not None and neighbours is not None:
        return float(draws) == float(neighbours)
    return c["label"] != "spmis-old"


def by_frame_table(configs, reveal, base, which, title):
    present = []
    for k in SINCE_REVEAL:
        f = reveal + k
        b = [s["by_frame"].get(f) for s in base["seed_rows"]]
        if b and all(x is not None and x[2] for x in b):
            present.append(k)
    if not present:
        return ""
    idx = 0 if which == "rc" else 1
    cells = {}
    for c in configs:
        for k in present:
            vals = [s["by_frame"].get(reveal + k) for s in c["seed_rows"]]
            cells[c["label"], k] = interval([v[idx] for v in vals if v is not None])
    best = {k: min((cells[c["label"], k][0] for c in configs if cells[c["label"], k][0] is not None),
                   default=None) for k in present}
    out = [f"**{title}**\n", "| config | " + " | ".join(f"+{k}" for k in present) + " |",
           "| --- |" + " --- |" * len(present)]
    for c in configs:
        row = []
        for k in present:
            m, ci = cells[c["label"], k]
            text = fmt(m, ci)
            row.append(f"**{text}**" if m is not None and m == best[k] else text)
        out.append(f"| {c['label']} | " + " | ".join(row) + " |")
    return "\n".join(out) + "\n"


def main(argv):
    jobs, missing = {}, 0
    for d in argv:
        j = load_job(d)
        if j is None:
            missing += 1
            continue
        jobs.setdefault(j["sequence"], {}).setdefault(j["label"], []).append(j)
    if not jobs:
        print("make_spmis_ablation_study: no complete job among the directories given", file=sys.stderr)
        return 1
    print("# Stochastic pairwise MIS at equal candidates in the revealed region: the ablation\n")
    print("Generated by `scripts/make_spmis_ablation_study.py` from the runs of `scripts/spmis_ablation_study.sh`; do "
          "not edit by hand.\n")
    first = next(iter(jobs.values()))
    j0 = next(iter(first.values()))[0]
    seeds = max(len(v) for seq in jobs.values() for v in seq.values())
    print(f"Machine: {platform.machine()}, {os.cpu_count()} cores. Each sequence at {j0['resolution'][0]}×"
          f"{j0['resolution'][1]}, frames {j0['frames'][0]}–{j0['frames'][1] - 1}, {seeds} seed(s) per "
          "configuration" + (f"; {missing} job(s) missing or incomplete, left out" if missing else "") + ".\n")
    print("Issue 39's fair comparison: `restir-unbiased` (standard pairwise spatial reuse over k random neighbours) "
          "against `restir-spmis` (seed 004's stochastic pairwise MIS over N draws from confident cells) with the "
          "same number of shifted candidates where temporal reuse failed, the pixels the error is measured on: "
          "10 neighbours (`spatial.disocclusionNeighbours`) against 10 draws (`spatial.disocclusionDraws`). "
          "Elsewhere the baselines take 5 or 10 neighbours and the stochastic pass 5 draws. The stochastic grid "
          "varies the cell search's start radius (`spatial.cellSearchRadius`, in image heights: r1080 = 30/1080, "
          "the paper's 30 px at 1080p, 10 px at these 360 rows; r360 = 30/360, the old 30 px here), the canonical "
          "draws N_c (`spatial.canonicalDraws`) and their pdf (`spatial.canonicalPdf`: uniform, P_c = 1/M as in "
          "the paper, or confidence, P_c ∝ c_i); `spmis-old` is the stochastic pass as the earlier studies "
          "(regimes.md, window_bars.md) ran it, without the boost.\n")
    print("**Reading the columns.** Errors over the pixels revealed in the last 4 frames (docs/metrics.md): "
          "`relmse_corrected_disocc` (relMSE with the reference's own noise subtracted; signed) and `flip_disocc` "
          "(mean HDR-FLIP, what the eye sees after tone mapping), each averaged over the post-reveal frames (from "
          "the reveal on, every frame whose mask is not empty), then over seeds, ± the 95% Student-t half-width "
          "over seeds. `relmse`: whole image, mean over every frame but the run's first. Failed: "
          "`spatial_failed_fraction`, the share of surface pixels per spatial iteration that found nothing to "
          "reuse. Work per pixel of the spatial pass (rays, target-function evaluations, reservoir reads), over "
          "the post-reveal frames: the equal-work figures, to re-price the verdict for another machine. ms/frame: "
          "median over frames of the estimator's time, mean over seeds; the jobs ran one after another in the "
          "configurations' order, which alternates the methods where it can.\n")
    print(f"**The reveal.** Detected per sequence from the first baseline's first seed: the first frame after the "
          f"run's first whose 4-frame disocclusion mask (`disocc_recent_fraction`) covers at least "
          f"{100 * REVEAL_THRESHOLD:.0f}% of the pixels (else the first with any revealed pixel). The mask depends "
          "on the geometry only, so it is the same for every configuration and seed. The by-frame tables show "
          "frames +0 (the reveal) to +16 after it, those the run has with a non-empty mask; the lowest mean per "
          "column is in bold.\n")
    print("| config | preset | settings |\n| --- | --- | --- |")
    for c in first.values():
        sets = " ".join(f"{k}={v}" for k, v in c[0]["overrides"].items()) or "(preset defaults)"
        print(f"| {c[0]['label']} | `{c[0]['preset']}` | {sets} |")
    print()

    ranks, ratios, seqnames = {}, {}, []
    for seq, labels in jobs.items():
        base_label = "unbiased-k5x10" if "unbiased-k5x10" in labels else next(
            (lab for lab, js in labels.items() if is_baseline({"label": lab, "preset": js[0]["preset"]})),
            next(iter(labels)))
        reveal, col = find_reveal(labels[base_label][0]["rows"])
        configs = [combine(js, reveal) for js in labels.values()]
        by = {c["label"]: c for c in configs}
        base = by[base_label]
        r0 = labels[base_label][0]
        print(f"## {seq}\n")
        if reveal is None:
            print("No frame of the run has revealed pixels: no post-reveal figures.\n")
            continue
        share = next(float(r[col]) for r in r0["rows"] if int(r["frame"]) == reveal)
        after = [r for r in r0["rows"] if int(r["frame"]) >= reveal]
        steady = all(float(r[col]) > 0 for r in after)
        print(f"Reveal: frame {reveal} ({100 * share:.1f}% of the pixels in the 4-frame mask, `{col}` of "
              f"{base_label}, seed {r0['seed']}); {base['seed_rows'][0]['post_frames']} post-reveal frames."
              + (" The mask stays non-empty to the end of the run: pixels are revealed frame after frame, so a "
                 "later frame's mask holds the pixels revealed in its own last 4 frames, not those of the reveal "
                 "frame (with a continuous reveal, as the window bars' pan, the frames since the reveal count from "
                 "the first)." if steady else "") + "\n")
        print("**(a) Post-reveal means**\n")
        print("| config | relmse_corrected_disocc | flip_disocc | relmse | failed | rays/px | targets/px | "
              "reservoir reads/px | ms/frame |")
        print("| --- | --- | --- | --- | --- | --- | --- | --- | --- |")
        for c in configs:
            print(f"| {c['label']} | {fmt(c['rc'], c['rc_ci'])} | {fmt(c['flip'], c['flip_ci'])} | "
                  f"{fmt(c['relmse'])} | {fmt(c['failed'], digits=3)} | {fmt(c['rays'], digits=2)} | "
                  f"{fmt(c['targets'], digits=1)} | {fmt(c['reads'], digits=1)} | {fmt(c['ms'], digits=0)} |")
        print()
        print(by_frame_table(configs, reveal, base, "rc", "(b) relmse_corrected_disocc by frame since the reveal"))
        print(by_frame_table(configs, reveal, base, "flip", "(b′) flip_disocc by frame since the reveal"))
        baselines = [c for c in configs if is_baseline(c) and c["rc"] is not None]
        grid = [c for c in configs if equal_candidates(c, base) and c["rc"] is not None]
        if not baselines or not grid:
            print("No baseline or no stochastic configuration at equal candidates: no verdict.\n")
            continue
        bb = min(baselines, key=lambda c: c["rc"])
        ordered = sorted(grid, key=lambda c: c["rc"])
        bs = ordered[0]
        seqnames.append(seq)
        for i, c in enumerate(ordered):
            ranks.setdefault(c["label"], {})[seq] = i + 1
        for c in configs:
            if not is_baseline(c) and c["rc"] is not None:
                ratios.setdefault(c["label"], {})[seq] = c["rc"] / abs(bb["rc"]) if bb["rc"] else float("nan")
        words = []
        for key, name in (("rc", "relmse_corrected_disocc"), ("flip", "flip_disocc")):
            if bs[key] is None or bb[key] is None:
                continue
            res = resolved(bs, bb, key)
            beats = bs[key] < bb[key]
            how = ("n/a: one seed" if res is None else "resolved by the seeds' 95% intervals" if res
                   else "not resolved by the seeds' 95% intervals")
            words.append(f"{name} {fmt(bs[key], bs[key + '_ci'])} against {fmt(bb[key], bb[key + '_ci'])} "
                         f"({change(bs, bb, key):+.1f}%: {'lower' if beats else 'not lower'}, {how})")
        win = bs["rc"] < bb["rc"]
        res = resolved(bs, bb, "rc")
        verdict = "is not told apart from" if res is False else "beats" if win else "loses to"
        line = (f"**Verdict on {seq}:** the best stochastic configuration, {bs['label']}, {verdict} the best "
                f"baseline, {bb['label']}: " + "; ".join(words) + ".")
        print(line + "\n")

    if seqnames:
        common = [lab for lab, r in ranks.items() if all(s in r for s in seqnames)]
        if common:
            key = lambda lab: (mean([ranks[lab][s] for s in seqnames]), mean([ratios[lab][s] for s in seqnames]))
            common.sort(key=key)
            print("## Overall\n")
            print("Rank of each stochastic configuration at equal candidates by `relmse_corrected_disocc` (1: "
                  "lowest) per sequence, and its error over the best baseline's; the best is the lowest mean rank "
                  "(ties: the lowest mean ratio).\n")
            print("| config | " + " | ".join(f"rank on {s}" for s in seqnames) + " | mean rank | " +
                  " | ".join(f"÷ best baseline on {s}" for s in seqnames) + " |")
            print("| --- |" + " --- |" * (2 * len(seqnames) + 1))
            for lab in common:
                print(f"| {lab} | " + " | ".join(str(ranks[lab][s]) for s in seqnames) +
                      f" | {key(lab)[0]:.1f} | " + " | ".join(f"{ratios[lab][s]:.3f}" for s in seqnames) + " |")
            for lab, r in ratios.items():  # the stochastic configurations not at equal candidates (spmis-old)
                if lab not in ranks:
                    print(f"| {lab} (not at equal candidates) | " + " | ".join("—" for _ in seqnames) + " | — | " +
                          " | ".join(f"{r[s]:.3f}" if s in r else "—" for s in seqnames) + " |")
            print()
            best = common[0]
            c = next(js[0] for seq in jobs.values() for lab, js in seq.items() if lab == best)
            # The line scripts/regime_study.sh reads (SPMIS_SET=ablation): keep its form.
            print(f"best stochastic configuration: {best} ({fragment(c)})\n")
    notes = os.path.join(os.path.dirname(os.path.abspath(__file__)), "spmis_ablation_notes.md")
    if os.path.exists(notes):
        with open(notes) as f:
            print(f.read().rstrip() + "\n")
    return 0


if __name__ == "__main__":
    sys.exit(main(sys.argv[1:]))
