#!/usr/bin/python3
"""Writes a markdown report with PNG plots for a locsim sweep folder (or a single run folder).

    tools/report.py DIR            (also: locsim report DIR)

Sweep folder: the summary table (and, over recorded logs, each configuration on each log), error
vs time per configuration (mean over seeds with its 95 %
band, kidnaps marked), each grid parameter's effect on the position error, and the CDFs of the
convergence and recovery steps. Run folder (of `run` or `replay`): its localizers' metrics and
error vs time; with several robots, each robot's and the localizers' error over all robots.
Calibration folder (of `calibrate`): the fitted noise models, with the detection errors per range
bin against the fitted bias and spread lines.
Uses Debian's python3-matplotlib; writes DIR/report.md and DIR/report/*.png.
"""
import argparse
import csv
import json
import math
import os
import sys
from collections import defaultdict

import matplotlib

matplotlib.use("Agg")
import matplotlib.pyplot as plt  # noqa: E402

COLORS = plt.rcParams["axes.prop_cycle"].by_key()["color"]


def read_tum(path):
    rows = {}
    with open(path) as f:
        for line in f:
            if line.startswith("#") or not line.strip():
                continue
            t, x, y, _z, _qx, _qy, qz, qw = map(float, line.split())
            rows[round(t, 4)] = (x, y, 2.0 * math.atan2(qz, qw))
    return rows


def kidnap_times(run_dir):
    path = os.path.join(run_dir, "events.csv")
    if not os.path.exists(path):
        return []
    with open(path, newline="") as f:
        return [float(r["t_s"]) for r in csv.DictReader(f) if r["kind"] == "kidnap"]


def error_series(run_dir, label):
    """(times, position errors) of one localizer in one run folder."""
    truth = read_tum(os.path.join(run_dir, "groundtruth.tum"))
    path = os.path.join(run_dir, label + ".tum")
    if not os.path.exists(path):
        return [], []
    estimate = read_tum(path)
    times = sorted(t for t in truth if t in estimate)
    return times, [math.hypot(estimate[t][0] - truth[t][0], estimate[t][1] - truth[t][1]) for t in times]


def t975(dof):
    table = [12.706, 4.303, 3.182, 2.776, 2.571, 2.447, 2.365, 2.306, 2.262, 2.228, 2.201, 2.179, 2.160,
             2.145, 2.131, 2.120, 2.110, 2.101, 2.093, 2.086, 2.080, 2.074, 2.069, 2.064, 2.060, 2.056,
             2.052, 2.048, 2.045, 2.042]
    return table[dof - 1] if 1 <= dof <= 30 else 1.96


def mark_kidnaps(ax, times):
    for k, t in enumerate(times):
        ax.axvline(t, color="#cc00cc", linestyle="--", linewidth=1, label="kidnap" if k == 0 else None)


def run_logs(root):
    """Each run's log.txt, relative to the sweep folder, as results.jsonl names it (the newest
    result of a run wins: a resume appends its retried runs' new results)."""
    logs = {}
    path = os.path.join(root, "results.jsonl")
    if os.path.exists(path):
        with open(path, encoding="utf-8", errors="replace") as f:
            for line in f:
                try:
                    result = json.loads(line)
                except ValueError:
                    continue  # a torn last line
                if "log" in result:
                    logs[result["id"]] = result["log"]
    return logs


def table_cell(text, limit=300):
    """`text` fit for a markdown table cell: no '|', at most `limit` characters (the log has it
    all)."""
    text = text.replace("|", "\\|")
    return text if len(text) <= limit else text[:limit] + " …"


def mean_ci(values):
    """'mean ± 95 % CI' of `values` (Student t), or '—' when there are none."""
    if not values:
        return "—"
    m = sum(values) / len(values)
    if len(values) < 2:
        return f"{m:.3f}"
    s = math.sqrt(sum((v - m) ** 2 for v in values) / (len(values) - 1))
    return f"{m:.3f} ± {t975(len(values) - 1) * s / math.sqrt(len(values)):.3f}"


def per_log_lines(results, configs):
    """An experiment over recorded logs (`logs:`): each configuration on each log, over the
    localizers' seeds; the summary above pools the logs."""
    logs = list(dict.fromkeys(r["log"] for r in results if r.get("log")))
    if not logs:
        return []
    lines = ["## Per log", "",
             "Each configuration on each recorded log, over its seeds: position and heading RMS, "
             "mean ± 95 % confidence interval over the runs that finished (ok).", "",
             "| config | log | runs | ok | position RMS [m] | heading RMS [deg] |",
             "|---|---|---|---|---|---|"]
    for config in configs:
        for log in logs:
            rows = [r for r in results if r["config"] == config and r.get("log") == log]
            if not rows:
                continue
            ok = [r for r in rows if r["status"] == "ok"]
            position = [float(r["position_rms_m"]) for r in ok if r["position_rms_m"]]
            heading = [float(r["heading_rms_deg"]) for r in ok if r["heading_rms_deg"]]
            lines.append(f"| {config} | {log} | {len(rows)} | {len(ok)} | {mean_ci(position)} | "
                         f"{mean_ci(heading)} |")
    return lines + [""]


def sweep_report(root, out_dir):
    with open(os.path.join(root, "sweep.json")) as f:
        header = json.load(f)
    with open(os.path.join(root, "results.csv"), newline="") as f:
        results = list(csv.DictReader(f))
    configs = list(dict.fromkeys(r["config"] for r in results))
    lines = [f"# {header['experiment']}: sweep report", "",
             f"Experiment file `{header['file']}`, {header['runs']} runs "
             f"({len(results)} present). Generated by `tools/report.py` from `results.csv`.", ""]
    with open(os.path.join(root, "summary.md")) as f:
        lines += ["## Summary", "", f.read(), ""]
    lines += per_log_lines(results, configs)
    statuses = defaultdict(int)
    for r in results:
        statuses[r["status"]] += 1
    lines += ["Run outcomes: " + ", ".join(f"{k} {v}" for k, v in sorted(statuses.items())) + ".", ""]
    not_ok = [r for r in results if r["status"] != "ok"]
    if not_ok:
        logs = run_logs(root)
        lines += ["| run | status | reason | log |", "|---|---|---|---|"]
        for r in not_ok[:50]:
            log = logs.get(r["id"], f"runs/{r['id']}/log.txt")
            # A merged sweep has no run folders: its logs are in the shards' folders.
            link = f"[log.txt]({log})" if os.path.exists(os.path.join(root, log)) else f"`{log}`"
            lines.append(f"| {r['id']} | {r['status']} | {table_cell(r['reason'])} | {link} |")
        if len(not_ok) > 50:
            lines.append(f"\n{len(not_ok) - 50} more in `results.csv`.")
        lines.append("")

    # Error vs time: mean over seeds per configuration, with a 95 % band.
    fig, ax = plt.subplots(figsize=(10, 5))
    kidnaps = []
    for i, config in enumerate(configs):
        per_time = defaultdict(list)
        for r in results:
            if r["config"] != config or r["status"] != "ok":
                continue
            run_dir = os.path.join(root, "runs", r["id"])  # LABEL/seed-N or LABEL/LOG/seed-N
            if not kidnaps:
                kidnaps = kidnap_times(run_dir)
            for t, e in zip(*error_series(run_dir, config)):
                per_time[t].append(e)
        if not per_time:
            continue
        times = sorted(per_time)
        mean = [sum(per_time[t]) / len(per_time[t]) for t in times]
        half = []
        for t, m in zip(times, mean):
            v = per_time[t]
            s = math.sqrt(sum((x - m) ** 2 for x in v) / (len(v) - 1)) if len(v) > 1 else 0.0
            half.append(t975(len(v) - 1) * s / math.sqrt(len(v)) if len(v) > 1 else 0.0)
        color = COLORS[i % len(COLORS)]
        ax.plot(times, mean, color=color, label=config)
        ax.fill_between(times, [m - h for m, h in zip(mean, half)], [m + h for m, h in zip(mean, half)],
                        color=color, alpha=0.2, linewidth=0)
    mark_kidnaps(ax, kidnaps)
    ax.set_xlabel("time [s]")
    ax.set_ylabel("position error [m]")
    ax.set_yscale("log")
    ax.set_title("Position error over time (mean over seeds, 95 % band)")
    ax.legend(fontsize=8)
    ax.grid(alpha=0.3)
    fig.tight_layout()
    fig.savefig(os.path.join(out_dir, "error_vs_time.png"), dpi=100)
    plt.close(fig)
    lines += ["## Error over time", "", "![position error over time](report/error_vs_time.png)", ""]

    # Each grid parameter's effect: position RMS (mean +- CI) against its value.
    by_param = defaultdict(lambda: defaultdict(list))
    for r in results:
        if r["status"] != "ok" or "-" not in r["config"]:
            continue
        base, *settings = r["config"].split("-")
        for setting in settings:
            if "=" in setting:
                key, value = setting.split("=", 1)
                try:
                    by_param[(base, key)][float(value)].append(float(r["position_rms_m"]))
                except ValueError:
                    pass
    for (base, key), values in by_param.items():
        xs = sorted(values)
        means = [sum(values[x]) / len(values[x]) for x in xs]
        cis = []
        for x, m in zip(xs, means):
            v = values[x]
            s = math.sqrt(sum((e - m) ** 2 for e in v) / (len(v) - 1)) if len(v) > 1 else 0.0
            cis.append(t975(len(v) - 1) * s / math.sqrt(len(v)) if len(v) > 1 else 0.0)
        fig, ax = plt.subplots(figsize=(6, 4))
        ax.errorbar(xs, means, yerr=cis, marker="o", capsize=4)
        if xs[0] > 0 and xs[-1] / xs[0] >= 20:  # a sweep over orders of magnitude (particles)
            ax.set_xscale("log")
        ax.set_xlabel(key)
        ax.set_ylabel("position RMS [m]")
        ax.set_title(f"{base}: position RMS against {key}")
        ax.grid(alpha=0.3)
        fig.tight_layout()
        name = f"param_{base}_{key}.png".replace("/", "_")
        fig.savefig(os.path.join(out_dir, name), dpi=100)
        plt.close(fig)
        lines += [f"## {base}: {key}", "", f"![{key}](report/{name})", ""]

    # CDFs of convergence and recovery, in steps (perception updates, the papers' unit).
    fig, axes = plt.subplots(1, 2, figsize=(11, 4))
    for i, config in enumerate(configs):
        rows = [r for r in results if r["config"] == config]
        converged = sorted(float(r["converged_steps"]) for r in rows if r["converged_steps"])
        recoveries = []
        for r in rows:
            for value in filter(None, r["recovery_steps"].split(";")):
                recoveries.append(math.inf if value == "never" else float(value))
        for ax, values, total in ((axes[0], converged, len(rows)), (axes[1], sorted(recoveries), len(recoveries))):
            finite = [v for v in values if math.isfinite(v)]
            if total and finite:
                ax.step(finite, [(k + 1) / total for k in range(len(finite))], where="post",
                        color=COLORS[i % len(COLORS)], label=config)
    for ax, title in ((axes[0], "convergence time"), (axes[1], "recovery time after a kidnap")):
        ax.set_xlabel("steps (perception updates)")
        ax.set_ylabel("fraction of runs")
        ax.set_ylim(0, 1.02)
        ax.set_title(f"CDF of {title} (never: stays below 1)")
        ax.grid(alpha=0.3)
        if ax.get_legend_handles_labels()[0]:
            ax.legend(fontsize=8)
        else:
            ax.text(0.5, 0.5, "no run got there", ha="center", va="center", transform=ax.transAxes)
    fig.tight_layout()
    fig.savefig(os.path.join(out_dir, "cdf.png"), dpi=100)
    plt.close(fig)
    lines += ["## Convergence and recovery", "", "![CDFs](report/cdf.png)", ""]
    return lines


def localizer_rows(metrics):
    """Table rows of a metrics.json's localizers (one robot's)."""
    rows = []
    for l in metrics["localizers"]:
        segments = "; ".join(f"{s['from_s']:.0f}-{s['to_s']:.0f} s: {s['position_error_m']['rms']:.3f}, "
                             f"{'never' if s['recovery_s'] is None else format(s['recovery_s'], '.1f')}"
                             for s in l["segments"])
        rows.append(f"{l['label']} | {l['status']} | {l['position_error_m']['rms']:.3f} | "
                    f"{l['position_error_m']['max']:.3f} | {l['heading_error_deg']['rms']:.2f} | {segments} |")
    return rows


def landmark_map_lines(metrics, robot=None):
    mapping = [l for l in metrics["localizers"] if "landmark_map" in l]
    if not mapping:
        return []
    lines = ["", "Landmark maps (SLAM filters; matched to the true landmarks within "
             f"{mapping[0]['landmark_map']['gate_m']:g} m)" + (f", robot {robot}" if robot else "") + ":", "",
             "| localizer | mapped | matched | error RMS [m] | max [m] | spurious | missed of observed |",
             "|---|---|---|---|---|---|---|"]
    for l in mapping:
        m = l["landmark_map"]
        rms, top = m["error_m"]["rms"], m["error_m"]["max"]
        lines.append(f"| {l['label']} | {m['mapped']} | {m['matched']} | "
                     f"{'—' if rms is None else format(rms, '.3f')} | "
                     f"{'—' if top is None else format(top, '.3f')} | {m['spurious']} | "
                     f"{m['missed']} of {m['observed']} |")
    return lines


def plot_errors(ax, run_dir, metrics):
    for i, l in enumerate(metrics["localizers"]):
        times, errors = error_series(run_dir, l["label"])
        ax.plot(times, errors, color=COLORS[i % len(COLORS)], label=l["label"])
    ax.set_yscale("log")
    ax.set_ylabel("position error [m]")
    ax.legend(fontsize=8)
    ax.grid(alpha=0.3)


def pooled_rms(parts):
    """RMS over every sample of several robots from (samples, rms) pairs; None without samples."""
    n = sum(samples for samples, _ in parts)
    return math.sqrt(sum(samples * rms * rms for samples, rms in parts) / n) if n else None


def run_report(root, out_dir):
    with open(os.path.join(root, "run.json")) as f:
        run = json.load(f)
    lines = [f"# Run report: {run['config']['world']['name']} / {run['config']['scenario']['name']}, "
             f"seed {run['seed']}", ""]
    if run.get("source") == "replay":
        lines += [f"Replay of `{run.get('log_file', '')}`.", ""]
    header = "| localizer | status | position RMS [m] | max [m] | heading RMS [deg] | per segment (RMS m, recovery s) |"
    # A run of several robots keeps each robot's files in its own folder (run.json's robots).
    folders = [(r["name"], os.path.join(root, r["folder"])) for r in run.get("robots", []) if r.get("folder")]
    if len(folders) < 2:
        metrics_path = os.path.join(root, "metrics.json")
        if not os.path.exists(metrics_path):
            return lines + ["No localizers ran (run with --localizer)."]
        with open(metrics_path) as f:
            metrics = json.load(f)
        lines += [header, "|---|---|---|---|---|---|"]
        lines += ["| " + row for row in localizer_rows(metrics)]
        lines += landmark_map_lines(metrics)
        fig, ax = plt.subplots(figsize=(10, 4.5))
        plot_errors(ax, root, metrics)
        mark_kidnaps(ax, kidnap_times(root))
        ax.set_xlabel("time [s]")
        fig.tight_layout()
        fig.savefig(os.path.join(out_dir, "error_vs_time.png"), dpi=100)
        plt.close(fig)
        return lines + ["", "![position error over time](report/error_vs_time.png)", ""]

    robots = []
    for name, folder in folders:
        path = os.path.join(folder, "metrics.json")
        if os.path.exists(path):
            with open(path) as f:
                robots.append((name, folder, json.load(f)))
    if not robots:
        return lines + ["No localizers ran (run with --localizer)."]
    # Over all robots: every true-pose sample of every robot counts once (a robot that was
    # tracked longer weighs more), as a filter's error on the whole dataset.
    by_label = defaultdict(list)
    for _name, _folder, metrics in robots:
        for l in metrics["localizers"]:
            by_label[l["label"]].append(l)
    lines += [f"{len(robots)} robots. Over all robots (RMS over every robot's samples; max of the robots' maxima):", "",
              "| localizer | robots ok | samples | position RMS [m] | max [m] | heading RMS [deg] |",
              "|---|---|---|---|---|---|"]
    for label, ls in by_label.items():
        ok = [l for l in ls if l["status"] == "ok"]
        position = pooled_rms([(l["samples"], l["position_error_m"]["rms"]) for l in ls])
        heading = pooled_rms([(l["samples"], l["heading_error_deg"]["rms"]) for l in ls])
        lines.append(f"| {label} | {len(ok)} of {len(ls)} | {sum(l['samples'] for l in ls)} | "
                     f"{'—' if position is None else format(position, '.3f')} | "
                     f"{max(l['position_error_m']['max'] for l in ls):.3f} | "
                     f"{'—' if heading is None else format(heading, '.2f')} |")
    lines += ["", "Per robot:", "", "| robot " + header, "|---|---|---|---|---|---|---|"]
    for name, _folder, metrics in robots:
        lines += [f"| {name} | " + row for row in localizer_rows(metrics)]
    for name, _folder, metrics in robots:
        lines += landmark_map_lines(metrics, name)
    fig, axes = plt.subplots(len(robots), 1, figsize=(10, 2.6 * len(robots)), sharex=True, squeeze=False)
    kidnaps = kidnap_times(root)
    for ax, (name, folder, metrics) in zip(axes[:, 0], robots):
        plot_errors(ax, folder, metrics)
        mark_kidnaps(ax, kidnaps)
        ax.set_title(name, fontsize=9)
    axes[-1, 0].set_xlabel("time [s]")
    fig.tight_layout()
    fig.savefig(os.path.join(out_dir, "error_vs_time.png"), dpi=100)
    plt.close(fig)
    return lines + ["", "![position error over time, per robot](report/error_vs_time.png)", ""]


def calibration_report(root, out_dir):
    with open(os.path.join(root, "calibration.json")) as f:
        cal = json.load(f)
    lines = ["# Calibration report", "", "Measured against the ground truth of:", ""]
    lines += [f"- `{source}`" for source in cal["sources"]]
    motion = cal.get("motion")
    if motion:
        lines += ["", f"## Motion ({motion['intervals']} intervals between perception steps, mean "
                  f"{motion['mean_interval_s']:.3f} s and {motion['mean_travel_m']:.3f} m)", "",
                  "| model | alpha1 | alpha2 | alpha3 | alpha4 | floor [m] | floor [deg] | log-likelihood per interval |",
                  "|---|---|---|---|---|---|---|---|"]
        models = motion["odometry_model"]
        for name in ("standard_deviation_form", "variance_form"):
            m = models[name]
            chosen = " (chosen)" if models["chosen"] == name else ""
            lines.append(f"| odometry, {name.replace('_', ' ')}{chosen} | {m['alpha1']:.4g} | {m['alpha2']:.4g} | "
                         f"{m['alpha3']:.4g} | {m['alpha4']:.4g} | {m['floor_position_m']:.3g} | "
                         f"{math.degrees(m['floor_heading_rad']):.3g} | {m['log_likelihood']:.3f} |")
        w = motion["wheel_model"]
        lines += ["", f"Wheel model (ekf_landmarks): k_left {w['k_left']:.4g}, k_right {w['k_right']:.4g} m^1/2, "
                  f"floor {w['floor_position_m']:.3g} m and {math.degrees(w['floor_heading_rad']):.3g} deg; "
                  f"mean NEES {w['mean_nees']:.2f} (3 when the covariance fits the errors)."]
        if "velocity_model" in motion:
            v = motion["velocity_model"]
            lines += ["", f"Velocity model (Thrun table 5.3, {v['intervals']} intervals): variance of v = "
                      f"{v['alpha1']:.4g} v² + {v['alpha2']:.4g} ω², of ω = {v['alpha3']:.4g} v² + {v['alpha4']:.4g} ω²."]
    for camera in cal.get("cameras", []):
        name = camera["camera"]
        rb, rs, rr = camera["range_bias"], camera["range_spread"], camera["range_rms"]
        lines += ["", f"## {name}", "",
                  f"{camera['detections']} detections of landmarks in {camera['readings']} readings; "
                  f"{camera['false_detections']} false ({camera['false_per_reading']:.3f} per reading)"
                  + (f"; missed {camera['missed']} of {camera['visible']} visible ({camera['miss_probability']:.3f})"
                     if "miss_probability" in camera else "") + ".",
                  "", f"Range bias {rb['m']:.4g} m + {rb['per_m']:.4g} r, spread {rs['m']:.4g} m + {rs['per_m']:.4g} r "
                  f"(about zero: {rr['m']:.4g} m + {rr['per_m']:.4g} r); bearing bias "
                  f"{math.degrees(camera['bearing_bias_rad']):.3f} deg, spread {math.degrees(camera['bearing_spread_rad']):.3f} deg."]
        bins = camera["bins"]
        if not bins:
            continue
        r = [b["range_m"] for b in bins]
        fig, (ax1, ax2) = plt.subplots(1, 2, figsize=(11, 3.8))
        ax1.errorbar(r, [b["range_error_mean_m"] for b in bins], yerr=[b["range_error_std_m"] for b in bins],
                     fmt="o", color=COLORS[0], label="bins: mean ± std")
        grid = [min(r) * i / 50 + max(r) * (50 - i) / 50 for i in range(51)]
        bias = [rb["m"] + rb["per_m"] * x for x in grid]
        ax1.plot(grid, bias, color=COLORS[1], label="fitted bias")
        ax1.plot(grid, [b + rs["m"] + rs["per_m"] * x for b, x in zip(bias, grid)], "--", color=COLORS[1],
                 label="bias ± fitted spread")
        ax1.plot(grid, [b - rs["m"] - rs["per_m"] * x for b, x in zip(bias, grid)], "--", color=COLORS[1])
        ax1.plot(grid, [rr["m"] + rr["per_m"] * x for x in grid], ":", color=COLORS[2], label="± spread about zero")
        ax1.plot(grid, [-rr["m"] - rr["per_m"] * x for x in grid], ":", color=COLORS[2])
        ax1.set_xlabel("true range [m]")
        ax1.set_ylabel("measured − true range [m]")
        ax1.legend(fontsize=7)
        ax2.errorbar(r, [math.degrees(b["bearing_error_mean_rad"]) for b in bins],
                     yerr=[math.degrees(b["bearing_error_std_rad"]) for b in bins], fmt="o", color=COLORS[0])
        bb, bs = math.degrees(camera["bearing_bias_rad"]), math.degrees(camera["bearing_spread_rad"])
        for y, style in ((bb, "-"), (bb + bs, "--"), (bb - bs, "--")):
            ax2.axhline(y, linestyle=style, color=COLORS[1])
        ax2.set_xlabel("true range [m]")
        ax2.set_ylabel("measured − true bearing [deg]")
        fig.suptitle(f"{name}: detection errors per range bin (inliers) and the fits", fontsize=9)
        fig.tight_layout()
        fig.savefig(os.path.join(out_dir, f"{name}_errors.png"), dpi=100)
        plt.close(fig)
        lines += ["", f"![{name} errors against range](report/{name}_errors.png)"]
    return lines + [""]


def main():
    parser = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    parser.add_argument("dir")
    args = parser.parse_args()
    root = args.dir
    out_dir = os.path.join(root, "report")
    os.makedirs(out_dir, exist_ok=True)
    try:
        if os.path.exists(os.path.join(root, "sweep.json")):
            lines = sweep_report(root, out_dir)
        elif os.path.exists(os.path.join(root, "run.json")):
            lines = run_report(root, out_dir)
        elif os.path.exists(os.path.join(root, "calibration.json")):
            lines = calibration_report(root, out_dir)
        else:
            print(f"report: {root} is neither a sweep, a run nor a calibration folder", file=sys.stderr)
            return 2
    except (OSError, ValueError, KeyError) as error:
        print(f"report: cannot read {root}: {error}", file=sys.stderr)
        return 2
    with open(os.path.join(root, "report.md"), "w") as f:
        f.write("\n".join(lines) + "\n")
    print(f"report: wrote {os.path.join(root, 'report.md')}")
    return 0


if __name__ == "__main__":
    sys.exit(main())
