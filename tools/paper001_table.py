#!/usr/bin/python3
"""Paper 001's comparison from a sweep of worlds/fastslam/experiments/*.yaml (markdown).

  tools/paper001_table.py runs/paper001            # one row per configuration
  tools/paper001_table.py runs/paper001 --seeds    # and the diversity per seed (the paper's table)
  tools/paper001_table.py runs/paper001 --paired fastslam_afsa   # each filter against one, per seed

Per configuration over its seeds (mean ± 95 % CI over the runs, Student t; for the position
also the median, after ';'): the position and heading RMS
against the ground truth, the landmark map's error (RMS over the true landmarks matched within
1 m) and its spurious and missed landmarks, the mean effective particle number N_eff and the
mean particle diversity (the filters' own diagnostics: averaged over every camera update), and
the wall time per run. The paper's figure is beside each where it has one (SPEC section 3).
--paired LABEL: every configuration against LABEL on the same seeds (the same readings): the mean
of the per-seed differences (other - LABEL) of the position and landmark RMS with its 95 % CI,
and on how many seeds LABEL was better. Pairing removes the seed-to-seed spread that the
unpaired CIs carry.
"""
import json
import math
import statistics
import sys

import locsim_path  # noqa: F401,E402  (this tree's python/locsim first)
import locsim  # noqa: E402  (the sweep reports' Student t, so the CIs agree)

# Paper 001 (decoded, SPEC section 3): PSO-PF -> AFSA + directed resampling, 10 particles.
PAPER = {
    "pso_pf": {"position": 0.41, "heading": 0.0034, "landmark": 0.037, "diversity": 0.336},
    "fastslam_afsa": {"position": 0.034, "heading": 0.003, "landmark": 0.0035, "n_eff": 4.616,
                      "diversity": 0.978},
}


def mean_ci(values, digits=3):
    if not values:
        return "–"
    mean, ci = locsim.mean_ci(values)
    return f"{mean:.{digits}f} ± {ci:.{digits}f}"


def main():
    sweep = sys.argv[1]
    rows = [json.loads(line) for line in open(f"{sweep}/results.jsonl")]
    rows.sort(key=lambda r: r["index"])
    configs = list(dict.fromkeys(r["config"] for r in rows))
    print("| filter | position RMS [m] | heading RMS [rad] | landmark RMS [m] | spurious | missed "
          "| mean N_eff | diversity [0–3] | wall per run [s] | runs ok |")
    print("|---|---|---|---|---|---|---|---|---|---|")
    for config in configs:
        runs = [r for r in rows if r["config"] == config]
        ok = [r for r in runs if r["status"] == "ok"]
        metrics = [r["metrics"] for r in ok]
        maps = [m["landmark_map"] for m in metrics if "landmark_map" in m]
        column = {
            "position": [m["position_error_m"]["rms"] for m in metrics],
            "heading": [math.radians(m["heading_error_deg"]["rms"]) for m in metrics],
            "landmark": [lm["error_m"]["rms"] for lm in maps if lm["matched"] > 0],
            "spurious": [lm["spurious"] for lm in maps],
            "missed": [lm["missed"] for lm in maps],
            "n_eff": [m["diagnostics"]["mean_n_eff"] for m in metrics if "mean_n_eff" in m.get("diagnostics", {})],
            "diversity": [m["diagnostics"]["mean_diversity"] for m in metrics
                          if "mean_diversity" in m.get("diagnostics", {})],
            "wall": [r["timing"]["wall_s"] for r in ok],
        }
        digits = {"heading": 4, "spurious": 1, "missed": 1, "n_eff": 2, "wall": 1}
        base = config.split("-")[0]
        cells = []
        for key in ("position", "heading", "landmark", "spurious", "missed", "n_eff", "diversity", "wall"):
            cell = mean_ci(column[key], digits.get(key, 3))
            if key == "position" and column[key]:
                cell += f"; {statistics.median(column[key]):.3f}"
            if key in PAPER.get(base, {}):
                cell += f" (paper {PAPER[base][key]:g})"
            cells.append(cell)
        print(f"| {config} | " + " | ".join(cells) + f" | {len(ok)} of {len(runs)} |")
    if "--seeds" in sys.argv:
        print()
        print("Mean particle diversity per seed (the paper's table of 10 runs):")
        print()
        print("| filter | " + " | ".join(f"seed {r['seed']}" for r in rows if r["config"] == configs[0]) + " |")
        print("|---|" + "---|" * len([r for r in rows if r["config"] == configs[0]]))
        for config in configs:
            values = [r["metrics"].get("diagnostics", {}).get("mean_diversity", float("nan"))
                      if r["status"] == "ok" else float("nan") for r in rows if r["config"] == config]
            if all(math.isnan(v) for v in values):
                continue  # no particles
            print(f"| {config} | " + " | ".join(f"{v:.2f}" for v in values) + " |")
    if "--paired" in sys.argv:
        paired(rows, sys.argv[sys.argv.index("--paired") + 1])


def paired(rows, reference):
    by = {}
    for r in rows:
        if r["status"] == "ok" and "landmark_map" in r["metrics"]:
            by.setdefault(r["config"], {})[r["seed"]] = r["metrics"]
    if reference not in by:
        sys.exit(f"no SLAM configuration '{reference}' in the sweep")
    print()
    print(f"Paired against {reference} (other − {reference}, mean ± 95 % CI over the seeds both finished):")
    print()
    print(f"| filter | Δ position RMS [m] | {reference} better | Δ landmark RMS [m] | {reference} better | seeds |")
    print("|---|---|---|---|---|---|")
    for config, runs in by.items():
        if config == reference:
            continue
        seeds = sorted(set(runs) & set(by[reference]))
        dp = [runs[k]["position_error_m"]["rms"] - by[reference][k]["position_error_m"]["rms"] for k in seeds]
        dl = [runs[k]["landmark_map"]["error_m"]["rms"] - by[reference][k]["landmark_map"]["error_m"]["rms"]
              for k in seeds]
        print(f"| {config} | {mean_ci(dp, 4)} | {sum(d > 0 for d in dp)} of {len(seeds)} | "
              f"{mean_ci(dl, 4)} | {sum(d > 0 for d in dl)} of {len(seeds)} | {len(seeds)} |")


if __name__ == "__main__":
    main()
