#!/usr/bin/python3
"""Writes a markdown report with PNG plots for a locsim sweep folder (or a single run folder).

    tools/report.py DIR            (also: locsim report DIR)
    tools/report.py --compare A B --out DIR [--labels NAME_A,NAME_B]   (also: locsim compare)

Sweep folder: the summary table (and, over recorded logs, each configuration on each log), error
vs time per configuration (mean over seeds with its 95 %
band, kidnaps marked), each grid parameter's effect on the position error, and the CDFs of the
convergence and recovery steps. Run folder (of `run` or `replay`): its localizers' metrics and
error vs time; with several robots, each robot's and the localizers' error over all robots.
Calibration folder (of `calibrate`): the fitted noise models, with the detection errors per range
bin against the fitted bias and spread lines.
Comparison of two sweeps (`--compare`): each configuration's position and heading RMS on both
side by side, the two rankings and how well they agree (Kendall's tau, Spearman's rho, the pairs
that flip and whether each flip is significant on both sides); writes DIR/compare.csv too.
Uses Debian's python3-matplotlib; writes DIR/report.md and DIR/report/*.png.
"""
import argparse
import contextlib
import csv
import errno
import math
import os
import statistics
import sys
import warnings
from collections import defaultdict

import locsim_path  # noqa: F401  (this tree's python/locsim first)
import matplotlib

matplotlib.use("Agg")
import matplotlib.pyplot as plt  # noqa: E402

import locsim  # noqa: E402

COLORS = plt.rcParams["axes.prop_cycle"].by_key()["color"]

# A character the font lacks is drawn as a box; matplotlib's warning would quote it on stderr.
warnings.filterwarnings("ignore", message=r"Glyph \d+ .*missing from", category=UserWarning)

# As the C++ side's (sim/common/errors.hpp): a quoted input is cut after this many bytes, a whole
# message after kMaxMessageBytes (its middle cut).
MAX_QUOTED_BYTES = 120
MAX_MESSAGE_BYTES = 8 << 10


class CannotWrite(Exception):
    """A report's file cannot be written (a read-only folder, a full disk): the message names it
    and the system's reason. Exit 1, `locsim: failure: ...`."""


class BadInput(Exception):
    """Input the user can fix; the message names the folder or file (and the line or key). Exit 2,
    `locsim: error: ...`."""


class WrongValue(Exception):
    """A value in a file is not of the type locsim writes there; contents_of adds the file."""


def escaped(text):
    """`text` (from a file or the command line) fit for a terminal, a table or a plot: control
    characters (newlines and ESC too), DEL, C1 controls and bytes that are not UTF-8 (decoded by
    Python as lone surrogates) as \\xNN, as the C++ side's quote_input writes them."""
    out = []
    for ch in str(text):
        code = ord(ch)
        if code < 0x20 or code == 0x7F:
            out.append(f"\\x{code:02x}")
        elif 0x80 <= code <= 0x9F:  # a C1 control: its two UTF-8 bytes
            out.append("".join(f"\\x{b:02x}" for b in ch.encode("utf-8")))
        elif 0xDC80 <= code <= 0xDCFF:  # a byte that is not UTF-8, as surrogateescape keeps it
            out.append(f"\\x{code - 0xDC00:02x}")
        elif 0xD800 <= code <= 0xDFFF:
            out.append(f"\\u{code:04x}")
        else:
            out.append(ch)
    return "".join(out)


def cut_bytes(text, limit):
    """(the longest start of `text` of at most `limit` UTF-8 bytes, how many bytes are left out)."""
    data = text.encode("utf-8")
    if len(data) <= limit:
        return text, 0
    head = data[:limit].decode("utf-8", errors="ignore")
    return head, len(data) - len(head.encode("utf-8"))


def quoted(text, limit=MAX_QUOTED_BYTES):
    """Untrusted text (a label, a name from a file) fit to stand in a message: escaped, in single
    quotes, cut after `limit` bytes with how many were left out."""
    head, left = cut_bytes(escaped(text), limit)
    return f"'{head}'" + (f" (and {left} bytes more)" if left else "")


def printable(message, limit=MAX_MESSAGE_BYTES):
    """A whole message fit for stderr: escaped, its middle cut past `limit` bytes (the start names
    the file and line, the end often says why)."""
    text = escaped(message)
    if len(text.encode("utf-8")) <= limit:
        return text
    head, _ = cut_bytes(text, limit // 2)
    tail = text.encode("utf-8")[-(limit // 8):].decode("utf-8", errors="ignore")
    cut = len(text.encode("utf-8")) - len(head.encode("utf-8")) - len(tail.encode("utf-8"))
    return f"{head} [... {cut} bytes cut ...] {tail}"


def read_json_object(path):
    """The JSON object in `path`; BadInput names the file (with the line and column of what is not
    JSON) when it cannot be read or is not a JSON object."""
    try:
        value = locsim.io.read_json(path)
    except OSError as error:
        raise BadInput(f"{path}: cannot read it: {error.strerror or error}") from None
    except ValueError as error:  # locsim.io.FormatError: the file, line and column
        raise BadInput(str(error)) from None
    if not isinstance(value, dict):
        raise BadInput(f"{path}: not a JSON object (not as locsim writes it)")
    return value


def read_text(path):
    """A text file's contents; BadInput names the file when it cannot be read or is not UTF-8."""
    try:
        with open(path, encoding="utf-8") as f:
            return f.read()
    except OSError as error:
        raise BadInput(f"{path}: cannot read it: {error.strerror or error}") from None
    except UnicodeDecodeError as error:
        raise BadInput(f"{path}: not UTF-8 (byte 0x{error.object[error.start]:02x} at byte "
                       f"{error.start})") from None


@contextlib.contextmanager
def contents_of(path):
    """Turns what reading a file's values raises (a key missing, a value of another type) into
    BadInput naming `path`; errors that name their own file (BadInput, locsim.io.FormatError, an
    OSError) pass unchanged."""
    try:
        yield
    except (BadInput, CannotWrite, locsim.io.FormatError, OSError):
        raise
    except WrongValue as error:
        raise BadInput(f"{path}: {error}") from None
    except KeyError as error:
        key = error.args[0] if error.args else "?"
        raise BadInput(f"{path}: no key {quoted(key)} where locsim writes one") from None
    except (TypeError, ValueError, IndexError, AttributeError, ZeroDivisionError):
        raise BadInput(f"{path}: a value is missing or of another type than locsim writes") from None


def save_figure(fig, path):
    """Writes `fig` as a PNG to `path` through a temporary file (a failed write leaves no half
    image), and closes it."""
    try:
        replace_with(path, lambda temporary: fig.savefig(temporary, format="png", dpi=100))
    except OSError as error:
        raise CannotWrite(f"cannot write {path}: {error.strerror or error}") from None
    finally:
        plt.close(fig)


def kidnap_times(run_dir):
    return [e["t_s"] for e in locsim.read_events(os.path.join(run_dir, "events.csv")) if e["kind"] == "kidnap"]


def error_series(run_dir, label):
    """(times, position errors) of one localizer in one run folder (empty if it wrote no
    estimate)."""
    e = locsim.error_arrays(run_dir, label)
    return e["t_s"].tolist(), e["position_error_m"].tolist()


def mark_kidnaps(ax, times):
    for k, t in enumerate(times):
        ax.axvline(t, color="#cc00cc", linestyle="--", linewidth=1, label="kidnap" if k == 0 else None)


def run_logs(root):
    """Each run's log.txt, relative to the sweep folder, as results.jsonl names it (the newest
    result of a run wins: a resume appends its retried runs' new results)."""
    path = os.path.join(root, "results.jsonl")
    if not os.path.exists(path):
        return {}
    try:
        records = locsim.io.read_jsonl(path)
    except OSError as error:
        raise BadInput(f"{path}: cannot read it: {error.strerror or error}") from None
    return {r["id"]: r["log"] for r in records
            if isinstance(r.get("id"), str) and isinstance(r.get("log"), str)}


def run_folder(root, run_id, logs):
    """A run's folder: its log's, as results.jsonl names it, else runs/ID (LABEL/seed-N or
    LABEL/LOG/seed-N)."""
    return os.path.join(root, os.path.dirname(logs[run_id])) if run_id in logs else os.path.join(root, "runs", run_id)


def table_cell(text, limit=300):
    """`text` fit for a markdown table cell: no '|', no control characters (as \\xNN), at most
    `limit` characters (the log has it all)."""
    text = escaped(text).replace("|", "\\|")
    return text if len(text) <= limit else text[:limit] + " …"


def mean_half_width(values):
    """(mean, half-width of its 95 % CI, Student t) of `values`; the half-width is None for fewer
    than two values (no spread to judge), the mean None for none."""
    a = locsim.aggregate(values)
    if a.n == 0:
        return None, None
    return a.mean, (a.ci95 if a.n > 1 else None)


def mean_ci(values):
    """'mean ± 95 % CI' of `values` (Student t), or '—' when there are none."""
    m, half = mean_half_width(values)
    if m is None:
        return "—"
    if half is None:
        return f"{m:.3f}"
    return f"{m:.3f} ± {half:.3f}"


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
            lines.append(f"| {table_cell(config)} | {table_cell(log)} | {len(rows)} | {len(ok)} | "
                         f"{mean_ci(position)} | {mean_ci(heading)} |")
    return lines + [""]


# The columns of a sweep's results.csv that the report reads.
RESULT_COLUMNS = ("id", "config", "status", "reason", "position_rms_m", "heading_rms_deg",
                  "converged_steps", "recovery_steps")


def read_results(path):
    """results.csv's rows as dicts of strings, each with the columns the report reads, `config`
    escaped (it names plots and table rows) and the numbers of a finished run checked; BadInput
    names the file and line."""
    rows = []
    try:
        with open(path, newline="", encoding="utf-8") as f:
            reader = csv.DictReader(f)
            columns = reader.fieldnames or []
            missing = [c for c in RESULT_COLUMNS if c not in columns]
            if missing:
                raise BadInput(f"{path}:1: no column {', '.join(missing)} (not a sweep's results)")
            for row in reader:
                line = reader.line_num
                # DictReader files surplus fields under None and fills missing ones with None.
                if None in row or None in row.values():
                    raise BadInput(f"{path}:{line}: not as many fields as the header's {len(columns)}")
                if not row["id"] or not row["config"] or not row["status"]:
                    raise BadInput(f"{path}:{line}: empty id, config or status")
                for column in ("position_rms_m", "heading_rms_deg", "converged_steps"):
                    # The errors of a run that did not finish are not used (nor checked); the
                    # convergence CDF counts every run.
                    if column == "converged_steps" or row["status"] == "ok":
                        text = row[column]
                        try:
                            value = float(text) if text else 0.0
                        except ValueError:
                            value = math.nan
                        if not (math.isfinite(value) and value >= 0):
                            raise BadInput(f"{path}:{line}: {column} {quoted(text)} is not a "
                                           "number >= 0")
                for value in filter(None, row["recovery_steps"].split(";")):
                    try:
                        ok = value == "never" or float(value) >= 0
                    except ValueError:
                        ok = False
                    if not ok:
                        raise BadInput(f"{path}:{line}: recovery_steps {quoted(row['recovery_steps'])}"
                                       " is not a list of numbers >= 0 or 'never' (';' between)")
                # The label as written names the runs' files; escaped, it names plots and rows.
                row["label"], row["config"] = row["config"], escaped(row["config"])
                rows.append(row)
    except OSError as error:
        raise BadInput(f"{path}: cannot read it: {error.strerror or error}") from None
    except UnicodeDecodeError as error:
        raise BadInput(f"{path}: not UTF-8 (byte 0x{error.object[error.start]:02x})") from None
    except csv.Error as error:
        raise BadInput(f"{path}: not a CSV file ({error})") from None
    return rows


def sweep_report(root, out_dir):
    sweep_json = os.path.join(root, "sweep.json")
    header = read_json_object(sweep_json)
    for key in ("experiment", "file", "runs"):
        if key not in header:
            raise BadInput(f"{sweep_json}: no key '{key}' (not a sweep's)")
    results_csv = os.path.join(root, "results.csv")
    results = read_results(results_csv)
    configs = list(dict.fromkeys(r["config"] for r in results))
    lines = [f"# {escaped(header['experiment'])}: sweep report", "",
             f"Experiment file `{escaped(header['file'])}`, {escaped(header['runs'])} runs "
             f"({len(results)} present). Generated by `tools/report.py` from `results.csv`.", ""]
    lines += ["## Summary", "", read_text(os.path.join(root, "summary.md")), ""]
    lines += per_log_lines(results, configs)
    statuses = defaultdict(int)
    for r in results:
        statuses[r["status"]] += 1
    lines += ["Run outcomes: " + ", ".join(f"{escaped(k)} {v}" for k, v in sorted(statuses.items())) +
              ".", ""]
    not_ok = [r for r in results if r["status"] != "ok"]
    if not_ok:
        logs = run_logs(root)
        lines += ["| run | status | reason | log |", "|---|---|---|---|"]
        for r in not_ok[:50]:
            log = logs.get(r["id"], f"runs/{r['id']}/log.txt")
            # A merged sweep has no run folders: its logs are in the shards' folders.
            link = f"[log.txt]({escaped(log)})" if os.path.exists(os.path.join(root, log)) \
                else f"`{escaped(log)}`"
            lines.append(f"| {table_cell(r['id'])} | {table_cell(r['status'])} | "
                         f"{table_cell(r['reason'])} | {link} |")
        if len(not_ok) > 50:
            lines.append(f"\n{len(not_ok) - 50} more in `results.csv`.")
        lines.append("")

    # Error vs time: mean over seeds per configuration, with a 95 % band.
    fig, ax = plt.subplots(figsize=(10, 5))
    kidnaps = []
    logs = run_logs(root)
    for i, config in enumerate(configs):
        per_time = defaultdict(list)
        for r in results:
            if r["config"] != config or r["status"] != "ok":
                continue
            run_dir = run_folder(root, r["id"], logs)
            if not kidnaps:
                kidnaps = kidnap_times(run_dir)
            for t, e in zip(*error_series(run_dir, r["label"])):
                per_time[t].append(e)
        if not per_time:
            continue
        times = sorted(per_time)
        stats = [locsim.aggregate(per_time[t]) for t in times]
        mean, half = [a.mean for a in stats], [a.ci95 for a in stats]
        color = COLORS[i % len(COLORS)]
        ax.plot(times, mean, color=color, label=config)
        ax.fill_between(times, [m - h for m, h in zip(mean, half)], [m + h for m, h in zip(mean, half)],
                        color=color, alpha=0.2, linewidth=0)
    # A suite's worlds each kidnap at their own times: one run's would mislead.
    several_worlds = len({r.get("world", "") for r in results}) > 1
    if not several_worlds:
        mark_kidnaps(ax, kidnaps)
    ax.set_xlabel("time [s]")
    ax.set_ylabel("position error [m]")
    ax.set_yscale("log")
    ax.set_title("Position error over time (mean over " +
                 ("worlds and seeds; each world kidnaps at its own times)" if several_worlds
                  else "seeds, 95 % band)"))
    ax.legend(fontsize=8)
    ax.grid(alpha=0.3)
    fig.tight_layout()
    save_figure(fig, os.path.join(out_dir, "error_vs_time.png"))
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
        stats = [locsim.aggregate(values[x]) for x in xs]
        means, cis = [a.mean for a in stats], [a.ci95 for a in stats]
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
        save_figure(fig, os.path.join(out_dir, name))
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
    save_figure(fig, os.path.join(out_dir, "cdf.png"))
    lines += ["## Convergence and recovery", "", "![CDFs](report/cdf.png)", ""]
    return lines


def number(value, spec):
    """`value` formatted by `spec`, or '—' for null (no samples: JSON has no NaN). A value of
    another type raises (contents_of names the file)."""
    if value is None:
        return "—"
    if isinstance(value, bool) or not isinstance(value, (int, float)):
        raise WrongValue(f"{quoted(value, 60)} (a {type(value).__name__}) where locsim writes a number")
    return format(value, spec)


def localizer_rows(metrics):
    """Table rows of a metrics.json's localizers (one robot's)."""
    rows = []
    for l in metrics["localizers"]:
        segments = "; ".join(f"{number(s['from_s'], '.0f')}-{number(s['to_s'], '.0f')} s: "
                             f"{number(s['position_error_m']['rms'], '.3f')}, "
                             f"{'never' if s['recovery_s'] is None else number(s['recovery_s'], '.1f')}"
                             for s in l["segments"])
        rows.append(f"{table_cell(l['label'])} | {table_cell(l['status'])} | "
                    f"{number(l['position_error_m']['rms'], '.3f')} | "
                    f"{number(l['position_error_m']['max'], '.3f')} | "
                    f"{number(l['heading_error_deg']['rms'], '.2f')} | "
                    f"{consistency_cell(l)} | {segments} |")
    return rows


def consistency_cell(localizer):
    """'0.93, 3.4': the share of samples with the truth in the 95 % ellipse and the median NEES
    (0.95 and about 2.4, the chi-square median with 3 degrees of freedom, when the covariance is
    honest); '—' without a positive definite covariance."""
    c = localizer.get("consistency")
    return "—" if not c else f"{number(c['inside_95_ellipse'], '.2f')}, {number(c['nees_median'], '.3g')}"


def landmark_map_lines(metrics, robot=None):
    mapping = [l for l in metrics["localizers"] if "landmark_map" in l]
    if not mapping:
        return []
    lines = ["", "Landmark maps (SLAM filters; matched to the true landmarks within "
             f"{number(mapping[0]['landmark_map']['gate_m'], 'g')} m)" +
             (f", robot {escaped(robot)}" if robot else "") + ":", "",
             "| localizer | mapped | matched | error RMS [m] | max [m] | spurious | missed of observed |",
             "|---|---|---|---|---|---|---|"]
    for l in mapping:
        m = l["landmark_map"]
        rms, top = m["error_m"]["rms"], m["error_m"]["max"]
        lines.append(f"| {table_cell(l['label'])} | {number(m['mapped'], 'd')} | "
                     f"{number(m['matched'], 'd')} | {number(rms, '.3f')} | {number(top, '.3f')} | "
                     f"{number(m['spurious'], 'd')} | {number(m['missed'], 'd')} of "
                     f"{number(m['observed'], 'd')} |")
    return lines


def plot_errors(ax, run_dir, metrics):
    for i, l in enumerate(metrics["localizers"]):
        times, errors = error_series(run_dir, l["label"])
        ax.plot(times, errors, color=COLORS[i % len(COLORS)], label=escaped(l["label"]))
    ax.set_yscale("log")
    ax.set_ylabel("position error [m]")
    ax.legend(fontsize=8)
    ax.grid(alpha=0.3)


def pooled_rms(parts):
    """RMS over every sample of several robots from (samples, rms) pairs; None without samples."""
    parts = [(samples, rms) for samples, rms in parts if samples and rms is not None]
    n = sum(samples for samples, _ in parts)
    return math.sqrt(sum(samples * rms * rms for samples, rms in parts) / n) if n else None


def check_finished(path, run):
    """BadInput unless run.json (`run`, read from `path`) is a finished run's: status "completed",
    or "interrupted" (Ctrl-C: its files hold the run so far), or none (a folder of an older
    locsim). A run still running, or killed before it could say how it ended, says "running"; one
    that failed says "failed" and, in "error", why."""
    status = run.get("status", "completed")
    if status in ("completed", "interrupted"):
        return
    error = run.get("error")
    why = f": {quoted(error)}" if isinstance(error, str) and error else ""
    if status == "running":
        raise BadInput(f"{path}: the run did not finish: status 'running' (it is still running, or "
                       f"it was killed before it could write how it ended){why}")
    if status == "failed":
        raise BadInput(f"{path}: the run did not finish: status 'failed'{why or ' (no error given)'}")
    raise BadInput(f"{path}: 'status': {quoted(status)} is not a status locsim writes (completed, "
                   f"interrupted, failed or running){why}")


def load_metrics(path):
    """A metrics.json, its values checked by making the report's rows of it (BadInput names the
    file and the missing key)."""
    metrics = read_json_object(path)
    with contents_of(path):
        if not isinstance(metrics["localizers"], list) or \
                not all(isinstance(l, dict) and isinstance(l["label"], str) for l in metrics["localizers"]):
            raise WrongValue("'localizers' is not a list of localizers, each with its label")
        localizer_rows(metrics)
        landmark_map_lines(metrics)
    return metrics


def run_report(root, out_dir):
    run_json = os.path.join(root, "run.json")
    run = read_json_object(run_json)
    check_finished(run_json, run)
    with contents_of(run_json):
        lines = [f"# Run report: {escaped(run['config']['world']['name'])} / "
                 f"{escaped(run['config']['scenario']['name'])}, seed {escaped(run['seed'])}", ""]
        if run.get("source") == "replay":
            lines += [f"Replay of `{escaped(run.get('log_file', ''))}`.", ""]
        if run.get("status") == "interrupted":
            lines += [f"Interrupted (Ctrl-C) after {escaped(run.get('simulated_s', '?'))} simulated "
                      "seconds: the numbers cover the run up to there.", ""]
        # A run of several robots keeps each robot's files in its own folder (run.json's robots).
        robots = run.get("robots", [])
        if not isinstance(robots, list):
            raise WrongValue("'robots' is not a list")
        folders = [(r["name"], os.path.join(root, r["folder"])) for r in robots if r.get("folder")]
    header = ("| localizer | status | position RMS [m] | max [m] | heading RMS [deg] | "
              "in 95 % ellipse, median NEES (0.95, 2.37: honest) | per segment (RMS m, recovery s) |")
    if len(folders) < 2:
        metrics_path = os.path.join(root, "metrics.json")
        if not os.path.exists(metrics_path):
            return lines + ["No localizers ran (run with --localizer)."]
        metrics = load_metrics(metrics_path)
        lines += [header, "|---|---|---|---|---|---|---|"]
        lines += ["| " + row for row in localizer_rows(metrics)]
        lines += landmark_map_lines(metrics)
        fig, ax = plt.subplots(figsize=(10, 4.5))
        plot_errors(ax, root, metrics)
        mark_kidnaps(ax, kidnap_times(root))
        ax.set_xlabel("time [s]")
        fig.tight_layout()
        save_figure(fig, os.path.join(out_dir, "error_vs_time.png"))
        return lines + ["", "![position error over time](report/error_vs_time.png)", ""]

    robots = []
    for name, folder in folders:
        path = os.path.join(folder, "metrics.json")
        if os.path.exists(path):
            metrics = load_metrics(path)
            with contents_of(path):  # the values pooled over the robots below
                for l in metrics["localizers"]:
                    for value in (l["samples"], l["position_error_m"]["rms"],
                                  l["position_error_m"]["max"], l["heading_error_deg"]["rms"]):
                        number(value, "g")
                    if not isinstance(l["samples"], int) or l["samples"] < 0:
                        raise WrongValue(f"'samples' {quoted(l['samples'], 60)} is not a count")
            robots.append((escaped(name), folder, metrics))
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
        maxima = [l["position_error_m"]["max"] for l in ls if l["position_error_m"]["max"] is not None]
        lines.append(f"| {table_cell(label)} | {len(ok)} of {len(ls)} | {sum(l['samples'] for l in ls)} | "
                     f"{number(position, '.3f')} | {number(max(maxima) if maxima else None, '.3f')} | "
                     f"{number(heading, '.2f')} |")
    lines += ["", "Per robot:", "", "| robot " + header, "|---|---|---|---|---|---|---|---|"]
    for name, _folder, metrics in robots:
        lines += [f"| {table_cell(name)} | " + row for row in localizer_rows(metrics)]
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
    save_figure(fig, os.path.join(out_dir, "error_vs_time.png"))
    return lines + ["", "![position error over time, per robot](report/error_vs_time.png)", ""]


def calibration_report(root, out_dir):
    path = os.path.join(root, "calibration.json")
    cal = read_json_object(path)
    with contents_of(path):
        return calibration_lines(cal, out_dir)


def calibration_lines(cal, out_dir):
    lines = ["# Calibration report", "", "Measured against the ground truth of:", ""]
    lines += [f"- `{escaped(source)}`" for source in cal["sources"]]
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
        if "command_response" in motion:
            c = motion["command_response"]
            share, gain_only = c["residual_variance_share"], c["gain_only_residual_variance_share"]
            verdict = ("the odometry leads the motion: the twin's robots get this response"
                       if c["leads"] else "the odometry does not lead the motion: nothing written")
            lines += ["", f"Command response ({c['seconds']:.0f} s of reported velocity with a true one): dead time "
                      f"{c['dead_time_s']:.3g} s, time constants {c['time_constant_v_s']:.3g} s (v) and "
                      f"{c['time_constant_omega_s']:.3g} s (ω), gains {c['gain_v']:.4g} (v) and {c['gain_omega']:.4g} (ω). "
                      f"It leaves {share['v']:.3g} (v) and {share['omega']:.3g} (ω) of the error variance about the "
                      f"reported velocity, a gain alone {gain_only['v']:.3g} and {gain_only['omega']:.3g}; {verdict}"
                      + (f"; beyond it the motion adds k {c['k_left']:.4g}, {c['k_right']:.4g} m^1/2." if "k_left" in c else ".")]
        if "side_slip" in motion:
            d = motion["side_slip"]
            kept = d["crab_angle_deg"] != 0 or d["cornering_compliance_s"] != 0 or d["wander_k"] > 0
            lines += ["", f"The body off its heading ({d['windows']} windows of 1-8 s, {d['distance_m']:.0f} m, from the "
                      f"truth alone): crab {d['crab_angle_deg']:.3g} deg ({d['crab_log_likelihood_gain']:.0f} nats), "
                      f"cornering compliance {d['cornering_compliance_s']:.3g} s "
                      f"({d['cornering_log_likelihood_gain']:.0f} nats), wander k {d['wander_k']:.3g} m^1/2 over "
                      f"{d['wander_correlation_s']:.3g} s ({d['wander_log_likelihood_gain']:.0f} nats); the truth's own "
                      f"noise {d['truth_noise_m']:.2g} m"
                      + (f", {d['dropped_windows']} windows dropped as its jumps" if d["dropped_windows"] else "")
                      + ("; the twin's robots get this side slip." if kept else "; no part kept: nothing written.")]
    for camera in cal.get("cameras", []):
        name = escaped(camera["camera"])
        rb, rs, rr = camera["range_bias"], camera["range_spread"], camera["range_rms"]
        lines += ["", f"## {name}", "",
                  f"{camera['detections']} detections of landmarks in {camera['readings']} readings; "
                  f"{camera['false_detections']} false ({camera['false_per_reading']:.3f} per reading)"
                  + (f"; missed {camera['missed']} of {camera['visible']} visible ({camera['miss_probability']:.3f})"
                     if "miss_probability" in camera else "") + ".",
                  "", f"Range bias {rb['m']:.4g} m + {rb['per_m']:.4g} r, spread {rs['m']:.4g} m + {rs['per_m']:.4g} r "
                  f"(about zero: {rr['m']:.4g} m + {rr['per_m']:.4g} r); bearing bias "
                  f"{math.degrees(camera['bearing_bias_rad']):.3f} deg, spread {math.degrees(camera['bearing_spread_rad']):.3f} deg."]
        if "detection_decay" in camera:
            decay = camera["detection_decay"]
            lines += ["", f"The chance of a detection falls with range: missed {decay['miss_probability_at_zero']:.3f} "
                      f"at zero range, the chance falling by e every {decay['decay_m']:.3g} m "
                      f"({decay['gain_nats']:.0f} nats better than a constant chance"
                      + ("; each logged frame weighed given a detection in it" if decay["conditioned_on_a_detection"] else "")
                      + ")."]
        if "range_models" in camera:
            models = camera["range_models"]
            depth = models["depth"]
            lines += ["", f"Range model chosen: {models['chosen']} (residual rms {models['distance']['residual_rms_m']:.4g} m "
                      f"as distance, {depth['residual_rms_m']:.4g} m as depth x = r cos(bearing)); as depth: bias "
                      f"{depth['bias']['m']:.4g} m + {depth['bias']['per_m']:.4g} x, spread {depth['spread']['m']:.4g} m "
                      f"+ {depth['spread']['per_m']:.4g} x."]
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
        image = f"{name}_errors.png".replace("/", "_")
        save_figure(fig, os.path.join(out_dir, image))
        lines += ["", f"![{name} errors against range](report/{image})"]
    lines += ranging_lines(cal.get("ranging"), out_dir)
    lines += laser_lines(cal.get("laser"))
    return lines + recordings_lines(cal) + [""]


def ranging_lines(ranging, out_dir):
    """The ranges to beacons (calibration.hpp RangingCalibration): the bias line, the spread, the
    outliers, each beacon's mean residual, and a plot of the residuals per range bin."""
    if not ranging:
        return []
    rb = ranging["range_bias"]
    lines = ["", "## Ranges to beacons", "",
             f"{ranging['ranges']} ranges in {ranging['readings']} readings "
             f"({ranging['ranges_per_reading']:.3f} per reading and receiver, {ranging['beacons']} beacons); "
             f"{ranging['long_outliers']} long and {ranging['short_outliers']} short outliers "
             f"({ranging['outlier_share']:.3%}).", "",
             f"Range bias {rb['m']:.4g} m + {rb['per_m']:.4g} d, spread {ranging['spread_m']:.4g} m about it "
             f"(rms about zero {ranging['rms_m']:.4g} m)"
             + (f"; the long outliers' excess {ranging['outlier_excess']['min_m']:.3g} m and more, mean "
                f"{ranging['outlier_excess']['mean_m']:.3g} m" if "outlier_excess" in ranging else "")
             + (f"; errors correlated over {ranging['noise_correlation']['tau_s']:.3g} s"
                if ranging.get("noise_correlation", {}).get("tau_s") else "; errors independent"
                if "noise_correlation" in ranging else "") + "."]
    if ranging["by_beacon"]:
        lines += ["", "| beacon | inliers | mean residual [m] | spread [m] |", "|---|---|---|---|"]
        lines += [f"| {b['id']} | {b['inliers']} | {b['mean_residual_m']:+.4f} | {b['spread_m']:.4f} |"
                  for b in ranging["by_beacon"]]
    bins = ranging["bins"]
    if bins:
        fig, ax = plt.subplots(figsize=(6, 3.5))
        ax.errorbar([b["range_m"] for b in bins], [b["mean_residual_m"] for b in bins],
                    yerr=[b["spread_m"] for b in bins], fmt="o", color=COLORS[0],
                    label="bins: mean ± std about the bias line")
        ax.axhline(0.0, color=COLORS[1], label="the bias line")
        ax.set_xlabel("true range [m]")
        ax.set_ylabel("measured − bias line [m]")
        ax.legend(fontsize=7)
        fig.tight_layout()
        save_figure(fig, os.path.join(out_dir, "ranging_errors.png"))
        lines += ["", "![range errors against range](report/ranging_errors.png)"]
    return lines


def laser_lines(laser):
    """The laser's beam model (calibration.hpp LaserCalibration): each branch's share, the hits'
    noise and mean error."""
    if not laser:
        return []
    return ["", "## Laser", "",
            f"{laser['beams']} beams of {laser['scans']} scans, {laser['beams_mapped']} with a mapped "
            f"wall within {laser['max_range_m']:.4g} m (EM, {laser['iterations']} iterations, "
            f"{laser['log_likelihood_per_beam']:.4g} nats per beam).", "",
            "| branch | share | its parameter |", "|---|---|---|",
            f"| hit | {1 - laser['p_short'] - laser['p_max'] - laser['p_random']:.4f} | "
            f"noise {laser['sigma_m']:.4g} m (mean error {laser['hit_bias_m']:+.4f} m) |",
            f"| short (unmapped) | {laser['p_short']:.4f} | rate {laser['lambda_short']:.4g} /m |",
            f"| at the maximum range | {laser['p_max']:.4f} | |",
            f"| random | {laser['p_random']:.4f} | |"]


def recordings_lines(cal):
    """calibrate's check across recordings (several logs): the widest spreads and, per localizer,
    the RMS of every recording with every recording's calibration (calibration_check.hpp)."""
    recordings = cal.get("recordings")
    if not recordings:
        return []
    names = [r["name"] for r in recordings]
    lines = ["", f"## Across {len(names)} recordings", "",
             "Each recording calibrated alone: " + ", ".join(f"`{escaped(n)}`" for n in names) + "."]
    transfer = cal.get("transfer")
    flag = transfer["flag_above"] if transfer else 0.25
    wide = sorted((p for p in cal.get("spread", []) if p["relative_spread"] > flag),
                  key=lambda p: -p["relative_spread"])
    if wide:
        lines += ["", f"Values spread beyond {flag:.0%} of the pooled one:", "",
                  "| parameter | group | " + " | ".join(escaped(n) for n in names) + " | pooled | spread |",
                  "|---|---|" + "---|" * len(names) + "---|---|"]
        for p in wide:
            key = (p["plugin"] + "." if p["plugin"] else "") + p["key"]
            values = " | ".join("" if v is None else f"{v:.4g}" for v in p["values"])
            pooled = "" if p["pooled"] is None else f"{p['pooled']:.4g}"
            lines.append(f"| {escaped(key)} | {escaped(p['group'])} | {values} | {pooled} | {p['relative_spread']:.0%} |")
    if not transfer:
        return lines
    for localizer in transfer["localizers"]:
        lines += ["", f"### {escaped(localizer)}: position RMS [m] on each recording (columns) with each "
                  "calibration (rows), change against the recording's own (**bold**: flagged)", "",
                  "| calibration | " + " | ".join(escaped(n) for n in names) + " |",
                  "|---|" + "---|" * len(names)]
        rows = {}
        for c in transfer["cells"]:
            if c["localizer"] != localizer:
                continue
            text = "–" if c["position_rms_m"] is None else f"{c['position_rms_m']:.3f}"
            if c["change"] is not None and c["from"] != c["on"]:
                text += f" ({c['change']:+.0%})"
            rows.setdefault(c["from"], []).append(f"**{text}**" if c["flagged"] else text)
        for source, cells in rows.items():
            lines.append(f"| {escaped(source)} | " + " | ".join(cells) + " |")
    if transfer["flags"]:
        lines += ["", f"Flagged (RMS moved by more than {flag:.0%}):", ""]
        lines += [f"- {escaped(line)}" for line in transfer["flags"]]
    else:
        lines += ["", f"No calibration moves a localizer's RMS on another recording by more than {flag:.0%}."]
    return lines


def read_compared_sweep(root):
    """(sweep.json, results.csv's rows) of the sweep folder `root`, each row with its config,
    status and position and heading RMS (floats, or None when empty); BadInput names what is
    wrong."""
    if not os.path.isdir(root):
        raise BadInput(f"{root}: no such folder" if not os.path.exists(root) else f"{root}: not a folder")
    for name in ("sweep.json", "results.csv"):
        if not os.path.isfile(os.path.join(root, name)):
            raise BadInput(f"{root} is not a sweep folder (no {name}; `locsim sweep` writes one)")
    path = os.path.join(root, "sweep.json")
    header = read_json_object(path)
    for key in ("experiment", "file"):
        if not isinstance(header.get(key), str):
            raise BadInput(f"{path}: key '{key}' is missing or not a string")
    path = os.path.join(root, "results.csv")
    rows = []
    try:
        with open(path, newline="", encoding="utf-8") as f:
            reader = csv.DictReader(f)
            columns = reader.fieldnames or []
            missing = [c for c in ("config", "status", "position_rms_m", "heading_rms_deg")
                       if c not in columns]
            if missing:
                raise BadInput(f"{path}:1: no column {', '.join(missing)} (not a sweep's results)")
            for row in reader:
                line = reader.line_num
                # DictReader files surplus fields under None and fills missing ones with None.
                if None in row or None in row.values():
                    raise BadInput(f"{path}:{line}: not as many fields as the header's "
                                   f"{len(columns)}")
                if not row["config"] or not row["status"]:
                    raise BadInput(f"{path}:{line}: empty config or status")
                values = {}
                for column in ("position_rms_m", "heading_rms_deg"):
                    # Only a finished run's values are used (and checked): whatever a run that did
                    # not finish left in them does not stop the comparison.
                    text = row[column] if row["status"] == "ok" else ""
                    try:
                        value = float(text) if text else None
                    except ValueError:
                        value = math.nan
                    if value is not None and not (math.isfinite(value) and value >= 0):
                        raise BadInput(f"{path}:{line}: {column} {quoted(text)} is not a number >= 0")
                    values[column] = value
                # The configuration names table rows, plot ticks and compare.csv's rows: escaped.
                rows.append({"config": escaped(row["config"]), "status": row["status"],
                             "position": values["position_rms_m"],
                             "heading": values["heading_rms_deg"]})
    except OSError as error:
        raise BadInput(f"{path}: cannot read it: {error.strerror or error}") from None
    except UnicodeDecodeError as error:
        raise BadInput(f"{path}: not UTF-8 (byte 0x{error.object[error.start]:02x})") from None
    except csv.Error as error:  # a broken quote
        raise BadInput(f"{path}:{reader.line_num}: not a CSV file ({error})") from None
    if not rows:
        raise BadInput(f"{path}: no runs")
    return header, rows


def side_stats(rows):
    """Per configuration, in order of first appearance: its runs, the ok ones, and the ok runs'
    position and heading RMS (a run that did not finish counts in runs, not in the means, as in
    sweep_report)."""
    stats = {}
    for r in rows:
        s = stats.setdefault(r["config"], {"runs": 0, "ok": 0, "position": [], "heading": []})
        s["runs"] += 1
        if r["status"] == "ok":
            s["ok"] += 1
            for key in ("position", "heading"):
                if r[key] is not None:
                    s[key].append(r[key])
    for s in stats.values():
        for key in ("position", "heading"):
            values = s[key]
            s[key + "_mean"], s[key + "_half"] = mean_half_width(values)
            s[key + "_median"] = statistics.median(values) if values else None
    return stats


def compared_key(mean):
    """A mean as rankings compare it: rounded well below the CSV's 6 decimals, so that the same
    values summed in another order tie instead of ranking on float noise."""
    return round(mean, 9)


def competition_ranks(means):
    """{config: rank} by mean, 1 = smallest; ties share the best of their ranks (1, 2, 2, 4)."""
    keys = {c: compared_key(m) for c, m in means.items()}
    return {c: 1 + sum(1 for other in keys.values() if other < k) for c, k in keys.items()}


def average_ranks(means):
    """{config: rank} by mean with ties sharing the mean of their ranks (1, 2.5, 2.5, 4): the ranks
    Spearman's rho correlates."""
    keys = {c: compared_key(m) for c, m in means.items()}
    return {c: rank + (sum(1 for other in keys.values() if other == keys[c]) - 1) / 2
            for c, rank in competition_ranks(means).items()}


def separated(mean1, half1, mean2, half2):
    """Whether two means' 95 % intervals do not overlap (a conservative test of a difference);
    never with a single run (no interval)."""
    return half1 is not None and half2 is not None and abs(mean1 - mean2) > half1 + half2


def rank_agreement(configs, a, b, key):
    """Kendall's tau-b, Spearman's rho and the pairs of `configs` ranked by a[c][key + '_mean']
    and by b[...]: counts of concordant, discordant and tied pairs, and each discordant pair as
    (better on A, better on B)."""
    ma = {c: a[c][key + "_mean"] for c in configs}
    mb = {c: b[c][key + "_mean"] for c in configs}
    concordant, discordant, tied_a, tied_b, flips = 0, 0, 0, 0, []
    for i, first in enumerate(configs):
        for second in configs[i + 1:]:
            da = (compared_key(ma[first]) > compared_key(ma[second])) - \
                (compared_key(ma[first]) < compared_key(ma[second]))
            db = (compared_key(mb[first]) > compared_key(mb[second])) - \
                (compared_key(mb[first]) < compared_key(mb[second]))
            tied_a += da == 0
            tied_b += db == 0
            if da * db > 0:
                concordant += 1
            elif da * db < 0:
                discordant += 1
                flips.append((first, second) if da < 0 else (second, first))
    pairs = len(configs) * (len(configs) - 1) // 2
    # tau-b: ties on either side shrink the denominator; undefined when one side ties all pairs.
    denominator = math.sqrt((pairs - tied_a) * (pairs - tied_b))
    tau = (concordant - discordant) / denominator if denominator > 0 else None
    ra, rb = average_ranks(ma), average_ranks(mb)
    rho = None
    if len(configs) > 1:
        mean_rank = (len(configs) + 1) / 2  # the same on both sides, ties or not
        sa = sum((ra[c] - mean_rank) ** 2 for c in configs)
        sb = sum((rb[c] - mean_rank) ** 2 for c in configs)
        if sa > 0 and sb > 0:
            rho = sum((ra[c] - mean_rank) * (rb[c] - mean_rank) for c in configs) / math.sqrt(sa * sb)
    return {"pairs": pairs, "concordant": concordant, "discordant": discordant,
            "tied": pairs - concordant - discordant, "tau": tau, "rho": rho, "flips": flips}


def flip_lines(agreement, a, b, labels, key, unit):
    """Each discordant pair in words, with whether its difference is significant on each side;
    and the pairs that flip significantly on both."""
    lines, substantial = [], []

    def side(stats, better, worse, label):
        s1, s2 = stats[better], stats[worse]
        m1, h1, m2, h2 = s1[key + "_mean"], s1[key + "_half"], s2[key + "_mean"], s2[key + "_half"]
        if h1 is None or h2 is None:
            verdict = "one run: no interval"
        elif separated(m1, h1, m2, h2):
            verdict = "significant"
        else:
            verdict = "within noise: the 95 % intervals overlap"
        return f"on {label} {better} < {worse} ({m1:.3f} vs {m2:.3f} {unit}, {verdict})", \
            verdict == "significant"

    for better_a, better_b in agreement["flips"]:
        text_a, sig_a = side(a, better_a, better_b, labels[0])
        text_b, sig_b = side(b, better_b, better_a, labels[1])
        if sig_a and sig_b:
            substantial.append(f"{better_a}/{better_b}")
            verdict = "significant on both sides: a disagreement of substance"
        else:
            noisy = [label for label, sig in zip(labels, (sig_a, sig_b)) if not sig]
            verdict = f"within noise on {' and '.join(noisy)}: not a disagreement of substance"
        lines.append(f"- {text_a}; {text_b}. {verdict[0].upper() + verdict[1:]}.")
    return lines, substantial


def agreement_sentence(agreement, substantial):
    """'The rankings agree on N of M pairs (Kendall tau ..., Spearman rho ...); K flips are
    significant on both sides: ...'."""
    if agreement["pairs"] == 0:
        return "One configuration in common: there is no ranking to compare."

    def number(value):
        return "undefined: one side ties every pair" if value is None else f"{value:.3f}"

    text = (f"agree on {agreement['concordant']} of {agreement['pairs']} pairs (Kendall tau "
            f"{number(agreement['tau'])}, Spearman rho {number(agreement['rho'])})")
    if agreement["tied"]:
        text += f", {agreement['tied']} tied on one side or both"
    flips = agreement["discordant"]
    if flips == 0:
        return text + "; no pair flips."
    k = len(substantial)
    if flips == 1:
        text += f"; the one flip is {'' if k else 'not '}significant on both sides"
    else:
        text += f"; {k} of the {flips} flips {'is' if k == 1 else 'are'} significant on both sides"
    return text + (": " + ", ".join(substantial) + "." if k else ".")


def ranking_text(means):
    """'a < b = c < d': configurations from the smallest mean up, '=' between ties."""
    order = sorted(means, key=lambda c: (compared_key(means[c]), c))
    text = table_cell(order[0])
    for previous, c in zip(order, order[1:]):
        text += (" = " if compared_key(means[previous]) == compared_key(means[c]) else " < ") + table_cell(c)
    return text


def compare_labels(a, b, labels):
    """The two sides' names: --labels NAME_A,NAME_B, or the folders' base names (the paths as given
    when these are the same)."""
    if labels is not None:
        # Names for tables and plots: a control character (ESC, a newline) would reach report.md
        # and the terminal, a byte that is not UTF-8 could not be written.
        if escaped(labels) != labels:
            raise BadInput(f"--labels: the names may not hold control characters or bytes that are "
                           f"not UTF-8, got {quoted(labels)}")
        parts = labels.split(",")
        if len(parts) != 2 or not all(p.strip() for p in parts):
            raise BadInput(f"--labels: expected NAME_A,NAME_B, got {quoted(labels)}")
        parts = [p.strip() for p in parts]
        if parts[0] == parts[1]:
            raise BadInput(f"--labels: the two names are the same ({quoted(parts[0])})")
        return parts
    # The folders' names, escaped as any name from outside.
    names = [escaped(os.path.basename(os.path.abspath(p))) for p in (a, b)]
    if names[0] == names[1]:
        names = [escaped(os.path.normpath(p)) for p in (a, b)]
    if names[0] == names[1]:
        names = [names[0] + " (A)", names[1] + " (B)"]
    return names


def check_compare_out(out_dir):
    """Refuses an --out whose report.md is not an earlier comparison's: that report would be lost."""
    if os.path.exists(out_dir) and not os.path.isdir(out_dir):
        raise BadInput(f"--out {out_dir}: not a folder")
    for marker, kind in (("sweep.json", "sweep"), ("run.json", "run"), ("calibration.json", "calibration")):
        if os.path.exists(os.path.join(out_dir, marker)):
            raise BadInput(f"--out {out_dir}: a {kind} folder (its own report.md would be replaced); "
                           "choose a new folder")
    if os.path.exists(os.path.join(out_dir, "report.md")) and \
            not os.path.exists(os.path.join(out_dir, "compare.csv")):
        raise BadInput(f"--out {out_dir}: holds a report.md that is not a comparison's; choose a new "
                       "folder")


def make_folder(path):
    """Makes the folder `path` (and its parents): BadInput when a file is in the way, CannotWrite
    when the system refuses (a read-only folder, a full disk)."""
    try:
        os.makedirs(path, exist_ok=True)
    except (FileExistsError, NotADirectoryError):
        raise BadInput(f"{path}: a file is in the way (not a folder)") from None
    except OSError as error:
        raise CannotWrite(f"cannot write {path}: {error.strerror or error}") from None


def replace_with(path, write):
    """Writes `path` through a temporary file renamed over it: an interrupted write leaves the old
    file whole."""
    temporary = path + ".tmp"
    try:
        write(temporary)
        os.replace(temporary, path)
    except BaseException:
        try:
            os.remove(temporary)
        except OSError:
            pass
        raise


def plot_compare(path, configs, a, b, labels):
    fig, axes = plt.subplots(1, 2, figsize=(max(8, 1.6 * len(configs) + 4), 4.5))
    x = list(range(len(configs)))
    for ax, key, unit in ((axes[0], "position", "m"), (axes[1], "heading", "deg")):
        means = []
        for k, (stats, label) in enumerate(((a, labels[0]), (b, labels[1]))):
            xs, ys, errors = [], [], []
            for i, c in enumerate(configs):
                s = stats.get(c)
                if s is None or s[key + "_mean"] is None:
                    continue
                xs.append(i + (k - 0.5) * 0.3)
                ys.append(s[key + "_mean"])
                errors.append(s[key + "_half"] or 0.0)
            means += ys
            ax.errorbar(xs, ys, yerr=errors, fmt="os"[k], capsize=4, color=COLORS[k], label=label,
                        linestyle="none")
        positive = [m for m in means if m > 0]
        if positive and max(positive) / min(positive) > 10:
            ax.set_yscale("log")
        ax.set_xticks(x)
        ax.set_xticklabels(configs, rotation=30, ha="right", fontsize=8)
        ax.set_xlim(-0.5, len(configs) - 0.5)
        ax.set_ylabel(f"{key} RMS [{unit}]")
        ax.set_title(f"{key.capitalize()} RMS: mean and 95 % CI over the runs", fontsize=9)
        ax.grid(alpha=0.3)
        ax.legend(fontsize=8)
    fig.tight_layout()
    save_figure(fig, path)


def compare_report(a, b, labels, out_dir):
    """Writes out_dir/report.md, compare.csv and report/compare.png: the configurations of the
    sweeps `a` and `b` side by side, their two rankings by mean position (and heading) RMS and how
    well these agree. Everything is read and checked before anything is written, report.md
    last."""
    labels = compare_labels(a, b, labels)
    check_compare_out(out_dir)
    header_a, rows_a = read_compared_sweep(a)
    header_b, rows_b = read_compared_sweep(b)
    sa, sb = side_stats(rows_a), side_stats(rows_b)
    common = [c for c in sa if c in sb]
    if not common:
        raise BadInput(f"{a} and {b} have no configuration in common ({a}: {', '.join(sa)}; "
                       f"{b}: {', '.join(sb)})")

    def ranked(key):
        # The rank statistics take the configurations with a mean on both sides only.
        configs = [c for c in common if sa[c][key + "_mean"] is not None
                   and sb[c][key + "_mean"] is not None]
        return sorted(configs, key=lambda c: (compared_key(sa[c][key + "_mean"]), c))

    position, heading = ranked("position"), ranked("heading")
    order = position + [c for c in sa if c not in position] + \
        [c for c in sb if c not in sa and c not in position]
    ranks = {}
    for key, configs in (("position", position), ("heading", heading)):
        for side, stats in (("a", sa), ("b", sb)):
            ranks[key, side] = competition_ranks({c: stats[c][key + "_mean"] for c in configs})
    agreements = {"position": rank_agreement(position, sa, sb, "position") if position else None,
                  "heading": rank_agreement(heading, sa, sb, "heading") if heading else None}

    def number(value, digits=3):
        return "—" if value is None else f"{value:.{digits}f}"

    def csv_number(value):
        return "" if value is None else f"{value:.6f}"

    def ratio(key, c):
        if c not in sa or c not in sb:
            return None
        ma, mb = sa[c][key + "_mean"], sb[c][key + "_mean"]
        return mb / ma if ma and mb is not None else None

    la, lb = (table_cell(label, 60) for label in labels)
    lines = [f"# Comparison: {la} and {lb}", ""]
    if agreements["position"] is None:
        lines += ["No configuration in common has a finished run on both sides: there is no "
                  "ranking to compare.", ""]
        position_flips, substantial = [], []
    else:
        position_flips, substantial = flip_lines(agreements["position"], sa, sb, labels, "position", "m")
        lines += ["By mean position RMS, the rankings " +
                  agreement_sentence(agreements["position"], substantial), ""]
        for label, stats in ((la, sa), (lb, sb)):
            lines.append(f"- Ranking on {label}: "
                         f"{ranking_text({c: stats[c]['position_mean'] for c in position})}.")
        lines.append("")
    for label, root, header, rows in ((la, a, header_a, rows_a), (lb, b, header_b, rows_b)):
        lines.append(f"- {label}: `{escaped(root)}`, experiment {table_cell(header['experiment'], 100)} "
                     f"(`{escaped(header['file'])}`), {len(rows)} runs.")
    only = [c for c in order if c not in common]
    lines += ["", f"{len(common)} configurations in common"
              + (f"; {len(only)} in only one sweep ({', '.join(only)}): listed with '—', left out of "
                 "the ranks and the rank statistics." if only else "."),
              "Generated by `tools/report.py --compare` from the two `results.csv`; the numbers are "
              "in `compare.csv`.", "",
              "## Position RMS", "",
              "Per configuration: runs that finished (ok) of all, the position RMS over the finished "
              "runs as mean ± 95 % confidence interval (Student t) and median, and the rank by mean "
              "among the configurations with finished runs on both sides (1 = best; ties share a "
              "rank).", "",
              f"| config | {la} ok/runs | {la} position RMS [m] | {la} median | {la} rank | "
              f"{lb} ok/runs | {lb} position RMS [m] | {lb} median | {lb} rank | {lb}/{la} |",
              "|---|---|---|---|---|---|---|---|---|---|"]
    for c in order:
        cells = [table_cell(c)]
        for side, stats in (("a", sa), ("b", sb)):
            s = stats.get(c)
            if s is None:
                cells += ["—"] * 4
                continue
            rank = ranks["position", side].get(c)
            cells += [f"{s['ok']}/{s['runs']}", mean_ci(s["position"]), number(s["position_median"]),
                      "—" if rank is None else str(rank)]
        cells.append(number(ratio("position", c), 2))
        lines.append("| " + " | ".join(cells) + " |")
    lines.append("")
    if position_flips:
        lines += [f"The pairs ranked the other way round on {lb} (significant: the two means' 95 % "
                  "intervals do not overlap; a flip within noise on either side is not a "
                  "disagreement of substance):", ""] + position_flips + [""]

    lines += ["## Heading RMS", "",
              f"| config | {la} heading RMS [deg] | {la} rank | {lb} heading RMS [deg] | {lb} rank | "
              f"{lb}/{la} |", "|---|---|---|---|---|---|"]
    for c in order:
        cells = [table_cell(c)]
        for side, stats in (("a", sa), ("b", sb)):
            s = stats.get(c)
            rank = ranks["heading", side].get(c)
            cells += ["—" if s is None else mean_ci(s["heading"]), "—" if rank is None else str(rank)]
        cells.append(number(ratio("heading", c), 2))
        lines.append("| " + " | ".join(cells) + " |")
    lines.append("")
    if agreements["heading"] is not None:
        heading_flips, heading_substantial = flip_lines(agreements["heading"], sa, sb, labels,
                                                        "heading", "deg")
        lines += ["By mean heading RMS, the rankings " +
                  agreement_sentence(agreements["heading"], heading_substantial), ""]
        lines += heading_flips + ([""] if heading_flips else [])
    lines += ["## Plot", "", "![position and heading RMS per configuration](report/compare.png)", ""]

    # compare.csv: the table's numbers in full (a_ is the first folder, b_ the second).
    columns = ["config"]
    for side in ("a", "b"):
        columns += [f"{side}_runs", f"{side}_ok"]
        for key, unit in (("position", "m"), ("heading", "deg")):
            columns += [f"{side}_{key}_mean_{unit}", f"{side}_{key}_ci_{unit}",
                        f"{side}_{key}_median_{unit}", f"{side}_{key}_rank"]
    columns += ["position_ratio_b_over_a", "heading_ratio_b_over_a"]
    records = []
    for c in order:
        record = [c]
        for side, stats in (("a", sa), ("b", sb)):
            s = stats.get(c)
            record += ["", ""] if s is None else [s["runs"], s["ok"]]
            for key in ("position", "heading"):
                if s is None:
                    record += [""] * 4
                    continue
                rank = ranks[key, side].get(c)
                record += [csv_number(s[key + "_mean"]), csv_number(s[key + "_half"]),
                           csv_number(s[key + "_median"]), "" if rank is None else rank]
        record += [csv_number(ratio(key, c)) for key in ("position", "heading")]
        records.append(record)

    def write_csv(path):
        with open(path, "w", newline="", encoding="utf-8") as f:
            writer = csv.writer(f, lineterminator="\n")
            writer.writerow(columns)
            writer.writerows(records)

    def write_markdown(path):
        with open(path, "w", encoding="utf-8") as f:
            f.write("\n".join(lines) + "\n")

    folder = os.path.join(out_dir, "report")
    make_folder(folder)
    plot_compare(os.path.join(folder, "compare.png"), order, sa, sb, labels)
    for name, write in (("compare.csv", write_csv), ("report.md", write_markdown)):
        path = os.path.join(out_dir, name)
        try:
            replace_with(path, write)
        except OSError as error:
            raise CannotWrite(f"cannot write {path}: {error.strerror or error}") from None


class Parser(argparse.ArgumentParser):
    """argparse, its complaints as locsim's: `locsim: error: report: ...`, exit 2."""

    def error(self, message):
        print(f"locsim: error: report: {printable(message)}", file=sys.stderr)
        sys.exit(2)


def as_given(argv):
    """The arguments with the values that begin with '-' kept as values: `locsim report DIR` passes
    DIR alone, `locsim compare` --out OUT and --labels NAMES after their options."""
    if len(argv) == 1 and argv[0] not in ("-h", "--help"):
        return ["--", argv[0]]
    out, i = [], 0
    while i < len(argv):
        if argv[i] in ("--out", "--labels") and i + 1 < len(argv):
            out.append(f"{argv[i]}={argv[i + 1]}")
            i += 2
        else:
            out.append(argv[i])
            i += 1
    return out


def complain(kind, command, message):
    """Prints `locsim: KIND: COMMAND: MESSAGE` to stderr, made printable (no control characters, at
    most MAX_MESSAGE_BYTES), as the C++ side's messages are."""
    print(f"locsim: {kind}: {command}: {printable(message)}", file=sys.stderr)


# The errors of a full or broken disk: the system's fault, not the input's (exit 1).
SYSTEM_ERRNOS = {errno.ENOSPC, errno.EDQUOT, errno.EIO, errno.ENOMEM}


def report(root):
    """`locsim report ROOT`: writes ROOT/report.md and ROOT/report/*.png. BadInput when ROOT is not
    a sweep, run or calibration folder or a file in it cannot be used; CannotWrite when the report
    cannot be written."""
    if not os.path.isdir(root):
        raise BadInput(f"{root}: no such folder" if not os.path.exists(root) else
                       f"{root}: not a folder")
    out_dir = os.path.join(root, "report")
    if os.path.exists(os.path.join(root, "sweep.json")):
        make_lines = sweep_report
    elif os.path.exists(os.path.join(root, "run.json")):
        make_lines = run_report
    elif os.path.exists(os.path.join(root, "calibration.json")):
        make_lines = calibration_report
    else:
        raise BadInput(f"{root} is neither a sweep, a run nor a calibration folder (no sweep.json, "
                       "run.json or calibration.json)")
    report_md = os.path.join(root, "report.md")
    make_folder(out_dir)
    try:
        lines = make_lines(root, out_dir)
    except locsim.io.FormatError as error:  # a run's .tum, events.csv, results.jsonl
        raise BadInput(str(error)) from None
    except OSError as error:  # writes raise CannotWrite: this is a file that cannot be read
        if error.errno in SYSTEM_ERRNOS:
            raise CannotWrite(f"cannot read {error.filename or root}: {error.strerror or error}") from None
        raise BadInput(f"{error.filename or root}: cannot read it: {error.strerror or error}") from None

    def write_markdown(path):
        with open(path, "w", encoding="utf-8") as f:
            f.write("\n".join(lines) + "\n")

    try:
        replace_with(report_md, write_markdown)
    except OSError as error:
        raise CannotWrite(f"cannot write {report_md}: {error.strerror or error}") from None
    return report_md


def main(argv=None):
    parser = Parser(description=__doc__.split("\n")[0])
    parser.add_argument("dir", nargs="?", help="a sweep, run or calibration folder")
    parser.add_argument("--compare", nargs=2, metavar=("A", "B"),
                        help="compare two sweep folders' configurations (with --out)")
    parser.add_argument("--out", help="--compare: the folder for report.md, compare.csv, report/")
    parser.add_argument("--labels", help="--compare: the two sweeps' names, as NAME_A,NAME_B "
                        "(default: the folders' base names)")
    args = parser.parse_args(as_given(sys.argv[1:] if argv is None else argv))
    if args.compare:
        if args.dir is not None or args.out is None:
            parser.error("--compare A B takes --out DIR and no other folder")
    elif args.dir is None:
        parser.error("give a folder, or --compare A B --out DIR")
    elif args.out is not None or args.labels is not None:
        parser.error("--out and --labels go with --compare")
    command = "compare" if args.compare else "report"
    try:
        if args.compare:
            compare_report(args.compare[0], args.compare[1], args.labels, args.out)
            written = os.path.join(args.out, "report.md")
        else:
            written = report(args.dir)
    except BadInput as error:
        complain("error", command, str(error))
        return 2
    except CannotWrite as error:
        complain("failure", command, str(error))
        return 1
    except KeyboardInterrupt:
        complain("failure", command, "interrupted; a report.md of before is left whole")
        return 130
    except MemoryError:
        complain("failure", command, "out of memory")
        return 1
    except Exception as error:  # a bug of this script: still no traceback, but what and where
        where = error.__traceback__
        while where.tb_next is not None:
            where = where.tb_next
        complain("failure", command, f"internal error, please report it: {type(error).__name__} at "
                 f"{os.path.basename(where.tb_frame.f_code.co_filename)}:{where.tb_lineno}: {error}")
        return 1
    print(f"{command}: wrote {printable(written)}")
    return 0


if __name__ == "__main__":
    sys.exit(main())
