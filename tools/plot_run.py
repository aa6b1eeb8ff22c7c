#!/usr/bin/python3
"""Plots a locsim run folder: the world from run.json, each robot's true path from
groundtruth.tum (broken where it was kidnapped), its wheel odometry from readings/encoders.csv, each localizer's estimate (LABEL.tum),
kidnaps as arrows and collisions as crosses.

    tools/plot_run.py RUN_DIR [--out FILE.png]

Uses Debian's python3-matplotlib (installed by tools/setup).
"""
import argparse
import csv
import json
import math
import os
import sys

import locsim_path  # noqa: F401  (this tree's python/locsim first)
import matplotlib

matplotlib.use("Agg")  # no display needed
import matplotlib.patches as patches  # noqa: E402
import matplotlib.pyplot as plt  # noqa: E402

import locsim  # noqa: E402

NAMED = {"red": (230, 25, 25), "green": (20, 170, 40), "blue": (30, 80, 230),
         "yellow": (240, 210, 20), "cyan": (20, 200, 220), "magenta": (220, 40, 200),
         "orange": (255, 130, 0), "purple": (120, 40, 170), "white": (245, 245, 245),
         "black": (20, 20, 20), "pink": (255, 140, 180), "brown": (130, 80, 30)}
PATH_COLORS = ["#1f77b4", "#d62728", "#2ca02c", "#9467bd", "#ff7f0e", "#8c564b"]


def rgb(color):
    values = NAMED.get(color, (128, 128, 128)) if isinstance(color, str) else color
    return tuple(v / 255.0 for v in values)


def draw_world(ax, world):
    for region in world["floor"]["regions"]:
        mu = region["friction"]
        shade = plt.cm.coolwarm_r(min(mu, 1.2) / 1.2)
        ax.add_patch(patches.Polygon(region["polygon"], closed=True, facecolor=shade, alpha=0.35,
                                     edgecolor="none"))
        cx = sum(p[0] for p in region["polygon"]) / len(region["polygon"])
        cy = sum(p[1] for p in region["polygon"]) / len(region["polygon"])
        ax.text(cx, cy, f"{region['name']}\nμ={mu:.2g}", ha="center", va="center", fontsize=7,
                color="#333333")
    if "map" in world:
        try:
            from PIL import Image
            image = Image.open(world["map"]["image"])
            res = world["map"]["resolution"]
            ox, oy, _ = world["map"]["origin"]
            w, h = image.size
            ax.imshow(image, cmap="gray", extent=(ox, ox + w * res, oy, oy + h * res), zorder=0)
        except (ImportError, OSError) as error:
            print(f"plot_run: map image not drawn: {error}", file=sys.stderr)
    for wall in world["walls"]:
        xs = [p[0] for p in wall["points"]]
        ys = [p[1] for p in wall["points"]]
        if wall["closed"]:
            xs.append(xs[0])
            ys.append(ys[0])
        ax.plot(xs, ys, color="#222222", linewidth=2.5, solid_capstyle="round")
    for box in world["boxes"]:
        (cx, cy), (w, h), angle = box["center"], box["size"], box["angle"]
        c, s = math.cos(angle), math.sin(angle)
        corner = (cx - c * w / 2 + s * h / 2, cy - s * w / 2 - c * h / 2)
        ax.add_patch(patches.Rectangle(corner, w, h, angle=math.degrees(angle), color="#555555"))
    for circle in world["circles"]:
        ax.add_patch(patches.Circle(circle["center"], circle["radius_m"], color="#555555"))
    for polygon in world["polygons"]:
        ax.add_patch(patches.Polygon(polygon["points"], closed=True, color="#555555"))
    for mover in world["movers"]:
        xs = [p[0] for p in mover["path"]]
        ys = [p[1] for p in mover["path"]]
        ax.plot(xs, ys, linestyle=":", color="#888888", linewidth=1)
        ax.text(xs[0], ys[0], mover["name"], fontsize=7, color="#666666")
    for landmark in world["landmarks"]:
        ax.add_patch(patches.Circle(landmark["position"], max(landmark["radius_m"], 0.08),
                                    facecolor=rgb(landmark["color"]), edgecolor="black", zorder=5))
    for beacon in world["beacons"]:
        ax.plot(*beacon["position"], marker="^", color="#444444", markersize=6, zorder=5)


def main():
    parser = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    parser.add_argument("run_dir")
    parser.add_argument("--out", help="PNG file (default: RUN_DIR/trajectory.png)")
    args = parser.parse_args()
    try:
        with open(os.path.join(args.run_dir, "run.json")) as f:
            run = json.load(f)
        events = locsim.read_events(os.path.join(args.run_dir, "events.csv"))
    except (OSError, json.JSONDecodeError) as error:
        print(f"plot_run: {args.run_dir} is not a readable run folder: {error}", file=sys.stderr)
        return 2

    world = run["config"]["world"]
    fig, ax = plt.subplots(figsize=(10.5, 7.5))
    draw_world(ax, world)
    for index, robot in enumerate(run["robots"]):
        color = PATH_COLORS[index % len(PATH_COLORS)]
        rows = locsim.read_tum(os.path.join(args.run_dir, robot["folder"], "groundtruth.tum"))
        put_downs = sorted(e["t_s"] for e in events
                           if e["kind"] == "put_down" and e["robot"] == robot["name"])
        segments, current = [], []
        for row in rows:
            while put_downs and row[0] >= put_downs[0] - 1e-9:
                put_downs.pop(0)
                if current:
                    segments.append(current)
                current = []
            current.append(row)
        if current:
            segments.append(current)
        for k, segment in enumerate(segments):
            ax.plot([r[1] for r in segment], [r[2] for r in segment], color=color, linewidth=1.4,
                    label=f"{robot['name']} true path" if k == 0 else None)
        encoders = os.path.join(args.run_dir, robot["folder"], "readings", "encoders.csv")
        if os.path.exists(encoders):
            with open(encoders, newline="") as f:
                odometry = [(float(r["odom_x_m"]), float(r["odom_y_m"])) for r in csv.DictReader(f)]
            ax.plot([p[0] for p in odometry], [p[1] for p in odometry], color=color, linewidth=1.0,
                    linestyle=(0, (4, 2)), alpha=0.7, label=f"{robot['name']} wheel odometry")
        estimate_styles = [("#ff7f0e", "-."), ("#2ca02c", "-"), ("#9467bd", ":"), ("#8c564b", "--")]
        for k, localizer in enumerate(l for l in run.get("localizers", []) if l["robot"] == robot["name"]):
            path = os.path.join(args.run_dir, robot["folder"], localizer["label"] + ".tum")
            if not os.path.exists(path):
                continue
            estimate = locsim.read_tum(path)
            style_color, style = estimate_styles[k % len(estimate_styles)]
            ax.plot([r[1] for r in estimate], [r[2] for r in estimate], color=style_color,
                    linestyle=style, linewidth=1.2, alpha=0.9,
                    label=f"{localizer['label']} estimate ({localizer['status']})")
        if len(rows):
            t, x, y, theta = rows[0]
            ax.plot(x, y, "o", color=color, markersize=7)
            ax.text(x, y - 0.35, "start", ha="center", fontsize=7, color=color)
            t, x, y, theta = rows[-1]
            ax.arrow(x, y, 0.3 * math.cos(theta), 0.3 * math.sin(theta), color=color,
                     head_width=0.12, length_includes_head=True, zorder=6)
        for event in events:
            if event["robot"] != robot["name"]:
                continue
            d = event["details"]
            if event["kind"] == "kidnap":
                kidnap_from = d["from"]
                kidnap_t = event["t_s"]
            elif event["kind"] == "put_down":
                to = d["to"]
                ax.annotate("", xy=to[:2], xytext=kidnap_from[:2],
                            arrowprops=dict(arrowstyle="->", color="#cc00cc", linestyle="--",
                                            linewidth=1.5, connectionstyle="arc3,rad=0.2"))
                ax.text((to[0] + kidnap_from[0]) / 2, (to[1] + kidnap_from[1]) / 2,
                        f"kidnap t={kidnap_t:g} s", color="#cc00cc", fontsize=8)
            elif event["kind"] == "collision":
                at = d["at"]
                ax.plot(at[0], at[1], "x", color="black", markersize=8, mew=2)
    ax.plot([], [], "x", color="black", mew=2, label="collision")
    ax.plot([], [], "--", color="#cc00cc", label="kidnap (carried)")
    ax.set_aspect("equal")
    ax.autoscale_view()
    ax.set_xlabel("x [m]")
    ax.set_ylabel("y [m]")
    scenario = run["config"]["scenario"]
    ax.set_title(f"{world['name']} / {scenario['name']}: seed {run['seed']}, "
                 f"{run['simulated_s']:.0f} s simulated")
    ax.legend(loc="upper left", bbox_to_anchor=(1.01, 1.0), fontsize=8, framealpha=0.9)
    ax.grid(alpha=0.2)
    out = args.out or os.path.join(args.run_dir, "trajectory.png")
    fig.tight_layout()
    fig.savefig(out, dpi=110, bbox_inches="tight")
    print(f"plot_run: wrote {out}")
    return 0


if __name__ == "__main__":
    sys.exit(main())
