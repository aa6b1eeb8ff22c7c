#!/usr/bin/python3
"""Puts the ASRL paper's published figures (SPEC section 2) next to ours, from the four sweeps of
worlds/asrl/experiments, and writes OUT/README.md with OUT/figures/*.png.

    tools/paper004_compare.py --tracking runs/asrl_tracking --global runs/asrl_global \\
        --kidnap runs/asrl_kidnap --sample-count runs/asrl_sample_count --out docs/reports/asrl

Every figure is computed here from the sweeps' results.csv and trajectories; the paper's are
quoted from SPEC.md. "Steps" are perception updates (camera frames with a detection).
"""
import argparse
import csv
import json
import math
import os
import statistics
import sys

sys.path.insert(0, os.path.dirname(os.path.abspath(__file__)))
from report import COLORS, plt  # noqa: E402

import locsim  # noqa: E402  (report put this tree's python/locsim first)
from locsim import mean_ci  # noqa: E402  (the sweep reports' Student t, so the CIs agree)

# Paper 004, Table 1: mean error (x, y in mm, theta in deg) per particle count.
PAPER_TABLE1 = {
    100: ((71.25, 52.17, 3.85), (42.49, 44.44, 2.49)),
    200: ((84.01, 54.70, 5.17), (49.09, 49.86, 4.44)),
    400: ((73.25, 42.83, 4.90), (26.97, 28.18, 1.95)),
    500: ((50.78, 63.48, 4.46), (44.55, 44.74, 2.49)),
    1000: ((53.40, 40.82, 3.28), (48.72, 40.52, 2.54)),
    1500: ((42.98, 45.13, 2.51), (40.88, 49.14, 4.27)),
    2000: ((56.84, 44.57, 3.50), (49.74, 44.65, 2.84)),
    5000: ((50.25, 43.90, 2.33), (46.94, 27.51, 2.52)),
    10000: ((55.75, 40.12, 3.49), (46.42, 45.44, 4.14)),
}


def results(sweep):
    with open(os.path.join(sweep, "results.csv"), newline="") as f:
        return list(csv.DictReader(f))


def configs(rows):
    return list(dict.fromkeys(r["config"] for r in rows))


def run_dir(sweep, row):
    return os.path.join(sweep, "runs", row["config"], f"seed-{row['seed']}")


def errors(sweep, row):
    """[(t, |dx|, |dy|, |dtheta| deg)] of one run's estimate against the truth."""
    e = locsim.error_arrays(run_dir(sweep, row), row["config"])
    return list(zip(e["t_s"], abs(e["dx_m"]), abs(e["dy_m"]), abs(e["heading_error_rad"]) * 180 / math.pi))


def fmt(m, ci, scale=1.0, digits=1):
    if math.isnan(m):
        return "–"
    return f"{m * scale:.{digits}f} ± {ci * scale:.{digits}f}" if not math.isnan(ci) else f"{m * scale:.{digits}f}"


def median(values):
    values = [v for v in values if v is not None]
    return statistics.median(values) if values else math.nan


def quartiles(values):
    values = sorted(values)
    if len(values) < 2:
        return (values[0], values[0]) if values else (math.nan, math.nan)
    q = statistics.quantiles(values, n=4)
    return q[0], q[2]


def save(fig, figures, name, alt, lines):
    """Writes the figure to figures/NAME and links it in the report."""
    fig.tight_layout()
    fig.savefig(os.path.join(figures, name), dpi=100)
    plt.close(fig)
    lines += ["", f"![{alt}](figures/{name})", ""]


def tracking_section(sweep, lines):
    rows = results(sweep)
    lines += ["## 4.1 Tracking (200 particles, known start)", "",
              "Published: estimate and truth nearly coincide, **max error 50 mm and 5°**.", "",
              "| filter | runs ok | max position error [mm], median (IQR) | max heading error [deg], median (IQR) | position RMS [mm], mean ± 95 % CI |",
              "|---|---|---|---|---|"]
    for config in configs(rows):
        ok = [r for r in rows if r["config"] == config and r["status"] == "ok"]
        pmax = [1000 * float(r["position_max_m"]) for r in ok]
        hmax = [float(r["heading_max_deg"]) for r in ok]
        q1, q3 = quartiles(pmax)
        h1, h3 = quartiles(hmax)
        lines.append(f"| {config} | {len(ok)}/{sum(r['config'] == config for r in rows)} | "
                     f"{median(pmax):.0f} ({q1:.0f}–{q3:.0f}) | {median(hmax):.1f} ({h1:.1f}–{h3:.1f}) | "
                     f"{fmt(*mean_ci([float(r['position_rms_m']) for r in ok]), 1000, 0)} |")
    lines.append("")


def global_section(sweep, lines, figures):
    rows = results(sweep)
    lines += ["## 4.2 Global localization (uniform start)", "",
              "Published: with ≥ 400 particles the pose is found in **4–10 steps**, with 200 in "
              "**30–50**; the error starts near 500 mm / 20° and, after about 7 steps, stays within "
              "100 mm / 10°. Converged here: error below 0.1 m and 10° for 5 consecutive steps.", "",
              "| filter | runs | converged | within 10 steps | steps to converge, median (IQR) | error after convergence: position [mm], heading [deg] |",
              "|---|---|---|---|---|---|"]
    fig, ax = plt.subplots(figsize=(8, 4))
    names = configs(rows)
    data = []
    for config in names:
        mine = [r for r in rows if r["config"] == config]
        steps = [int(r["converged_steps"]) for r in mine if r["converged_steps"]]
        q1, q3 = quartiles(steps) if steps else (math.nan, math.nan)
        after_p, after_h = [], []
        for r in mine:
            if r["status"] != "ok" or not r["converged_s"]:
                continue
            e = [s for s in errors(sweep, r) if s[0] >= float(r["converged_s"])]
            if e:
                after_p.append(statistics.fmean(math.hypot(s[1], s[2]) for s in e))
                after_h.append(statistics.fmean(s[3] for s in e))
        lines.append(f"| {config} | {len(mine)} | {len(steps)} | {sum(s <= 10 for s in steps)} | "
                     f"{median(steps):.0f} ({q1:.0f}–{q3:.0f}) | {fmt(*mean_ci(after_p), 1000, 0)}, "
                     f"{fmt(*mean_ci(after_h), 1, 2)} |")
        data.append(steps or [math.nan])
    ax.boxplot(data, labels=names, vert=False)
    ax.axvspan(4, 10, color="green", alpha=0.15, label="paper, ≥ 400 particles")
    ax.axvspan(30, 50, color="orange", alpha=0.15, label="paper, 200 particles")
    ax.set_xlabel("steps to converge")
    ax.set_title("Global localization: steps to converge over 20 seeds")
    ax.legend(fontsize=8)
    ax.grid(alpha=0.3)
    save(fig, figures, "global_steps.png", "steps to converge", lines)


def kidnap_section(sweep, lines, figures):
    rows = results(sweep)
    lines += ["## 4.3 Kidnapping (400 particles, carried twice)", "",
              "Published: recovery in **about 10–20 steps**, depending on whether a landmark is in "
              "view on landing; after recovery, error **< 50 mm and 5°**. A → B lands with the red "
              "landmark in view, C → D with none. Steps are counted from the landing.", "",
              "| filter | recovered A → B | steps, median (IQR) | recovered C → D | steps, median (IQR) | error after recovery: position [mm], heading [deg] |",
              "|---|---|---|---|---|---|"]
    names = configs(rows)
    per_kidnap = {c: ([], []) for c in names}
    for config in names:
        mine = [r for r in rows if r["config"] == config and r["status"] == "ok"]
        cells = []
        after_p, after_h = [], []
        for k in range(2):
            steps = []
            for r in mine:
                value = r["recovery_steps"].split(";")[k]
                if value != "never":
                    steps.append(int(value))
            per_kidnap[config][k].extend(steps)
            q1, q3 = quartiles(steps) if steps else (math.nan, math.nan)
            cells += [f"{len(steps)}/{len(mine)}",
                      f"{median(steps):.0f} ({q1:.0f}–{q3:.0f})" if steps else "never"]
        for r in mine:
            # Each kidnap's segment (from the landing), from its recovery on.
            with open(os.path.join(run_dir(sweep, r), "metrics.json")) as f:
                segments = json.load(f)["localizers"][0]["segments"][1:]
            e = [s for s in errors(sweep, r)
                 for seg in segments if seg["recovery_s"] is not None and
                 seg["from_s"] + seg["recovery_s"] <= s[0] <= seg["to_s"]]
            if e:
                after_p.append(statistics.fmean(math.hypot(s[1], s[2]) for s in e))
                after_h.append(statistics.fmean(s[3] for s in e))
        lines.append(f"| {config} | " + " | ".join(cells) +
                     f" | {fmt(*mean_ci(after_p), 1000, 0)}, {fmt(*mean_ci(after_h), 1, 2)} |")
    fig, axes = plt.subplots(1, 2, figsize=(11, 4), sharey=True)
    for k, (ax, title) in enumerate(zip(axes, ("A → B (landmark in view)", "C → D (none in view)"))):
        ax.boxplot([per_kidnap[c][k] or [math.nan] for c in names], labels=names, vert=False)
        ax.axvspan(10, 20, color="green", alpha=0.15, label="paper: 10–20 steps")
        ax.set_xlabel("steps to recover (recovered runs)")
        ax.set_title(title)
        ax.grid(alpha=0.3)
        ax.legend(fontsize=8)
    save(fig, figures, "kidnap_steps.png", "steps to recover", lines)


def table1_section(sweep, lines, figures):
    rows = results(sweep)
    by = {}  # (filter, particles) -> per-seed (x mm, y mm, theta deg) after convergence
    steps = {}
    for r in rows:
        name, _, count = r["config"].partition("-particles=")
        key = (name, int(count))
        by.setdefault(key, [])
        steps.setdefault(key, [])
        if r["status"] != "ok" or not r["converged_s"]:
            continue
        steps[key].append(int(r["converged_steps"]))
        e = [s for s in errors(sweep, r) if s[0] >= float(r["converged_s"])]
        if e:
            by[key].append(tuple(1000 * statistics.fmean(s[i] for s in e) if i < 3 else
                                 statistics.fmean(s[i] for s in e) for i in (1, 2, 3)))
    counts = sorted({k[1] for k in by})
    lines += ["## 4.4 ASRL against SRL: Table 1", "",
              "Global localization, the same 20 recorded seeds for every configuration. Ours: mean "
              "absolute error per axis over the steps after convergence, mean ± 95 % CI over seeds "
              "(converged runs); the paper's single run per configuration beside it.", "",
              "| particles | SRL x [mm] | paper | SRL y [mm] | paper | SRL θ [deg] | paper | ASRL x [mm] | paper | ASRL y [mm] | paper | ASRL θ [deg] | paper | converged SRL / ASRL | steps SRL / ASRL, median |",
              "|---|---|---|---|---|---|---|---|---|---|---|---|---|---|---|"]
    for n in counts:
        cells = [str(n)]
        for f, name in enumerate(("srl", "asrl")):
            values = by.get((name, n), [])
            paper = PAPER_TABLE1.get(n, (("–",) * 3, ("–",) * 3))[f]
            for i in range(3):
                cells += [fmt(*mean_ci([v[i] for v in values]), 1, 1 if i < 2 else 2), str(paper[i])]
        cells.append(f"{len(steps.get(('srl', n), []))} / {len(steps.get(('asrl', n), []))}")
        cells.append(f"{median(steps.get(('srl', n), [])):.0f} / {median(steps.get(('asrl', n), [])):.0f}")
        lines.append("| " + " | ".join(cells) + " |")
    lines.append("")
    fig, axes = plt.subplots(1, 2, figsize=(12, 4.5))
    for f, name in enumerate(("srl", "asrl")):
        color = COLORS[f]
        pos = [mean_ci([math.hypot(v[0], v[1]) for v in by.get((name, n), [])]) for n in counts]
        axes[0].errorbar(counts, [p[0] for p in pos], yerr=[p[1] for p in pos], marker="o", capsize=3,
                         color=color, label=f"{name.upper()} (ours, 20 seeds)")
        axes[0].plot(list(PAPER_TABLE1), [math.hypot(*PAPER_TABLE1[n][f][:2]) for n in PAPER_TABLE1],
                     linestyle=":", marker="x", color=color, label=f"{name.upper()} (paper, one run)")
        hd = [mean_ci([v[2] for v in by.get((name, n), [])]) for n in counts]
        axes[1].errorbar(counts, [p[0] for p in hd], yerr=[p[1] for p in hd], marker="o", capsize=3,
                         color=color, label=f"{name.upper()} (ours)")
        axes[1].plot(list(PAPER_TABLE1), [PAPER_TABLE1[n][f][2] for n in PAPER_TABLE1], linestyle=":",
                     marker="x", color=color, label=f"{name.upper()} (paper)")
    axes[0].set_ylabel("hypot(mean |x|, mean |y|) after convergence [mm]")
    axes[1].set_ylabel("mean |θ| error after convergence [deg]")
    for ax in axes:
        ax.set_xscale("log")
        ax.set_xlabel("particles")
        ax.grid(alpha=0.3)
        ax.legend(fontsize=8)
    fig.suptitle("Error against particle count, ASRL and SRL (Table 1)")
    save(fig, figures, "table1.png", "error against particle count", lines)


def main():
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--tracking", required=True)
    parser.add_argument("--global", dest="global_", required=True)
    parser.add_argument("--kidnap", required=True)
    parser.add_argument("--sample-count", required=True)
    parser.add_argument("--out", required=True)
    parser.add_argument("--preamble", help="markdown file put before the generated sections")
    args = parser.parse_args()
    figures = os.path.join(args.out, "figures")
    os.makedirs(figures, exist_ok=True)
    lines = []
    if args.preamble:
        with open(args.preamble) as f:
            lines += [f.read().rstrip(), ""]
    tracking_section(args.tracking, lines)
    global_section(args.global_, lines, figures)
    kidnap_section(args.kidnap, lines, figures)
    table1_section(args.sample_count, lines, figures)
    with open(os.path.join(args.out, "README.md"), "w") as f:
        f.write("\n".join(lines) + "\n")
    print(f"wrote {os.path.join(args.out, 'README.md')}")


if __name__ == "__main__":
    main()
