#!/usr/bin/python3
"""Figures of `rollstep report` (called by it; Debian's /usr/bin/python3 + python3-matplotlib).

Usage: figures.py FIGURES_JSON
FIGURES_JSON (written by the report) names the output folder, each run (its log.csv and
mpc.csv, pass/fail, traverse window, joint limits) and which runs feed which figure. Writes
fig2.png, fig4.png, fig6.png, fig8.png and map.png (top views of the perceived map, its
regions and the planned footholds, from a run's map log) into the output folder for the figures that have at
least one run with a log; a failed run is drawn as far as its log goes and labelled FAILED.
Only the standard library and matplotlib; plots only what the logs hold.
"""
import csv
import json
import math
import os
import sys

import matplotlib

matplotlib.use("Agg")
import matplotlib.pyplot as plt  # noqa: E402


def legs_of(columns):
    """The robot's legs in the log's order: the names of its contact_<leg>[0/1] columns."""
    return [k[len("contact_"):-len("[0/1]")] for k in columns
            if k.startswith("contact_") and k.endswith("[0/1]")]


def joints_of(columns, leg):
    """A leg's joints in the log's order, with their units: (name, unit) of its q_<joint>[unit]
    columns (a joint is named <leg>_<something>)."""
    out = []
    for k in columns:
        if k.startswith("q_%s_" % leg) and k.endswith("]") and "[" in k:
            name, unit = k[2:-1].split("[", 1)
            out.append((name, unit))
    return out


def traverse_legs(run, columns):
    """The legs the traverse window is defined on (the report names them), else the log's
    first and last legs."""
    if run.get("traverse_legs"):
        return run["traverse_legs"][0], run["traverse_legs"][1]
    legs = legs_of(columns)
    return legs[0], legs[-1]


def read_csv(path):
    """Columns by name; cells that are not numbers become NaN."""
    with open(path, newline="") as f:
        rows = list(csv.reader(f))
    if not rows:
        return {}
    names = rows[0]
    cols = {n: [] for n in names}
    for row in rows[1:]:
        if len(row) != len(names):
            continue
        for n, v in zip(names, row):
            try:
                cols[n].append(float(v))
            except ValueError:
                cols[n].append(float("nan"))
    return cols


def local_vz(c):
    out = []
    for w, x, y, z, vx, vy, vz in zip(c["base_qw[-]"], c["base_qx[-]"], c["base_qy[-]"],
                                      c["base_qz[-]"], c["base_vx[m/s]"], c["base_vy[m/s]"],
                                      c["base_vz[m/s]"]):
        n2 = w * w + x * x + y * y + z * z
        s = 2.0 / n2 if n2 > 0 else 0.0
        out.append(s * (x * z + w * y) * vx + s * (y * z - w * x) * vy +
                   (1.0 - s * (x * x + y * y)) * vz)
    return out


def local_vx(c):
    out = []
    for w, x, y, z, vx, vy, vz in zip(c["base_qw[-]"], c["base_qx[-]"], c["base_qy[-]"],
                                      c["base_qz[-]"], c["base_vx[m/s]"], c["base_vy[m/s]"],
                                      c["base_vz[m/s]"]):
        n2 = w * w + x * x + y * y + z * z
        s = 2.0 / n2 if n2 > 0 else 0.0
        out.append((1.0 - s * (y * y + z * z)) * vx + s * (x * y + w * z) * vy +
                   s * (x * z - w * y) * vz)
    return out


def label(run):
    return run["title"] + ("" if run["passed"] else " (FAILED)")


def shade(ax, run, color):
    if run.get("window"):
        ax.axvspan(run["window"][0], run["window"][1], color=color, alpha=0.08)


def fig2(spec, runs, out):
    runs = [r for r in runs if r["log"]]
    if not runs:
        return False
    fig, axes = plt.subplots(4, 1, figsize=(9, 9), sharex=True)
    climb = descent = None
    for k, run in enumerate(runs):
        c = read_csv(run["log"])
        t = c["time[s]"]
        color = "C%d" % k
        climb, descent = traverse_legs(run, c)
        axes[0].plot(t, local_vz(c), color=color, lw=0.9, label=label(run))
        axes[1].plot(t, c["base_wy[rad/s]"], color=color, lw=0.9)
        axes[2].plot(t, c["foot_z_%s[m]" % climb], color=color, lw=0.9)
        axes[3].plot(t, c["foot_z_%s[m]" % descent], color=color, lw=0.9)
        for ax in axes:
            shade(ax, run, color)
    axes[0].set_ylabel("base local v_z [m/s]")
    axes[1].set_ylabel("base local w_y [rad/s]")
    axes[2].set_ylabel("%s wheel height [m]" % climb)
    axes[3].set_ylabel("%s wheel height [m]" % descent)
    axes[3].set_xlabel("time [s]")
    axes[0].legend(loc="upper right", fontsize=8)
    for ax in axes:
        ax.grid(alpha=0.3)
    fig.suptitle("%s: base motion and %s/%s wheel heights (shaded: traverse window)"
                 % (runs[0].get("scene") or "step", climb, descent))
    fig.tight_layout()
    fig.savefig(os.path.join(out, "fig2.png"), dpi=90)
    plt.close(fig)
    return True


def fig4(spec, runs, out):
    runs = [r for r in runs if r["log"]]
    if not runs:
        return False
    run = runs[0]
    c = read_csv(run["log"])
    t = c["time[s]"]
    fig, axes = plt.subplots(4, 1, figsize=(9, 11), sharex=True)
    axes[0].plot(t, local_vx(c), lw=0.9, label="v_x (local)")
    axes[0].plot(t, local_vz(c), lw=0.9, label="v_z (local)")
    axes[0].set_ylabel("base velocity [m/s]")
    axes[0].legend(loc="upper right", fontsize=8)
    # Each leg's first joint (the hip) and last joint (the knee), named from the log.
    units = [set(), set()]
    for k, leg in enumerate(legs_of(c)):
        color = "C%d" % k
        joints = joints_of(c, leg)
        for row, (name, unit) in ((1, joints[0]), (2, joints[-1])) if joints else ():
            units[row - 1].add(unit)
            axes[row].plot(t, c["q_%s[%s]" % (name, unit)], color=color, lw=0.9, label=leg)
            if name in run["limits"]:
                lo, hi = run["limits"][name]
                axes[row].axhline(lo, color=color, ls="--", lw=0.7)
                axes[row].axhline(hi, color=color, ls="--", lw=0.7)
        axes[3].plot(t, c["foot_z_%s[m]" % leg], color=color, lw=0.9, label=leg)
    axes[1].set_ylabel("hip positions [%s]" % " or ".join(sorted(units[0])))
    axes[2].set_ylabel("knee positions [%s]" % " or ".join(sorted(units[1])))
    axes[3].set_ylabel("wheel heights [m]")
    axes[3].set_xlabel("time [s]")
    axes[1].legend(loc="upper right", fontsize=7, ncol=6)
    for ax in axes:
        ax.grid(alpha=0.3)
        shade(ax, run, "C7")
    fig.suptitle(label(run) + ": limits dashed")
    fig.tight_layout()
    fig.savefig(os.path.join(out, "fig4.png"), dpi=90)
    plt.close(fig)
    return True


def fig6(spec, runs, machine, out):
    runs = [r for r in runs if r["mpc"]]
    if not runs:
        return False
    fig, ax = plt.subplots(1, 1, figsize=(9, 4))
    for k, run in enumerate(runs):
        c = read_csv(run["mpc"])
        # The first row is the initial converging solve, not an update.
        t, ms = c["time[s]"][1:], c["solve_time[ms]"][1:]
        if not ms:
            continue
        mean = sum(ms) / len(ms)
        ax.plot(t, ms, ".", ms=3, color="C%d" % k,
                label="%s: mean %.1f ms, max %.1f ms (%d updates)" % (label(run), mean, max(ms), len(ms)))
    ax.set_xlabel("time [s]")
    ax.set_ylabel("MPC update time [ms] (wall clock)")
    ax.set_title(machine, fontsize=8)
    ax.grid(alpha=0.3)
    ax.legend(loc="upper right", fontsize=8)
    fig.tight_layout()
    fig.savefig(os.path.join(out, "fig6.png"), dpi=90)
    plt.close(fig)
    return True


def fig8_joints(run, columns):
    """The joints figure 8 shows for a run: the climbing leg's last joint (the knee) and the
    first leg's first joint (the hip), from its log (Tachyon 3: MF_knee and LF_hip, the
    paper's figure)."""
    climb, _ = traverse_legs(run, columns)
    return joints_of(columns, climb)[-1:] + joints_of(columns, legs_of(columns)[0])[:1]


def fig8(spec, runs, out):
    runs = [r for r in runs if r["log"]]
    if not runs:
        return False
    logs = [read_csv(run["log"]) for run in runs]
    joints = [fig8_joints(run, c) for run, c in zip(runs, logs)]
    rows = max(len(j) for j in joints)
    if rows == 0:
        return False
    # Rows share their axis only when every run shows the same joints (one robot).
    same = all(j == joints[0] for j in joints)
    fig, axes = plt.subplots(rows, len(runs), figsize=(5 * len(runs), 6), squeeze=False,
                             sharey="row" if same else False)
    for col, (run, c) in enumerate(zip(runs, logs)):
        t = c["time[s]"]
        for row, (joint, unit) in enumerate(joints[col]):
            ax = axes[row][col]
            ax.plot(t, c["cmd_%s[%s]" % (joint, unit)], lw=0.9, label="target (command)")
            ax.plot(t, c["q_%s[%s]" % (joint, unit)], lw=0.9, label="actual")
            ax.set_ylabel("%s [%s]" % (joint, unit))
            ax.grid(alpha=0.3)
            if row == 0:
                ax.set_title(label(run), fontsize=9)
                ax.legend(loc="upper right", fontsize=8)
        axes[-1][col].set_xlabel("time [s]")
    fig.tight_layout()
    fig.savefig(os.path.join(out, "fig8.png"), dpi=90)
    plt.close(fig)
    return True


def read_npy_f32(path):
    """A 2-D float32 .npy (version 1.0, C order) as a list of rows; the standard library only."""
    import struct
    with open(path, "rb") as f:
        data = f.read()
    if data[:6] != b"\x93NUMPY":
        raise ValueError("%s: not a .npy file" % path)
    n = struct.unpack("<H", data[8:10])[0]
    header = data[10:10 + n].decode("latin1")
    if "'<f4'" not in header or "True" in header:
        raise ValueError("%s: expected little-endian float32 in C order" % path)
    shape = tuple(int(x) for x in header.split("(")[1].split(")")[0].split(",") if x.strip())
    values = struct.unpack("<%df" % (shape[0] * shape[1]), data[10 + n:10 + n + 4 * shape[0] * shape[1]])
    return [list(values[r * shape[1]:(r + 1) * shape[1]]) for r in range(shape[0])]


def top_view(ax, map_dir, snapshot, maps, regions, footholds, vmin, vmax):
    """One snapshot: the map as an image, the regions' outlines, the footholds, the base."""
    row = maps[snapshot]
    heights = read_npy_f32(os.path.join(map_dir, row["heights_file"]))
    x0, y0 = float(row["origin_x[m]"]), float(row["origin_y[m]"])
    size = int(row["size[-]"]) * float(row["resolution[m]"])
    image = ax.imshow(heights, origin="lower", extent=[x0, x0 + size, y0, y0 + size], cmap="viridis",
                      vmin=vmin, vmax=vmax, interpolation="nearest")
    for poly in regions.get(snapshot, {}).values():
        xs = [p[0] for p in poly] + [poly[0][0]]
        ys = [p[1] for p in poly] + [poly[0][1]]
        ax.plot(xs, ys, "-", color="white", lw=0.8)
    feet = footholds.get(snapshot, [])
    if feet:
        ax.plot([p[0] for p in feet], [p[1] for p in feet], "x", color="red", ms=4, mew=1.0)
    bx, by, yaw = float(row["base_x[m]"]), float(row["base_y[m]"]), float(row["base_yaw[rad]"])
    ax.plot([bx], [by], "o", color="orange", ms=4)
    ax.plot([bx, bx + 0.3 * math.cos(yaw)], [by, by + 0.3 * math.sin(yaw)], "-", color="orange")
    ax.set_title("t = %.1f s: %s regions, %s" % (float(row["time[s]"]), row["regions[-]"],
                                                 row["status"]), fontsize=8)
    ax.set_xlabel("x [m]")
    ax.set_ylabel("y [m]")
    ax.set_aspect("equal")
    return image


def fig_map(spec, runs, out):
    """Top views of the perceived map (docs/PERCEPTION.md's map log) at three moments per run."""
    runs = [r for r in runs if r.get("map")]
    if not runs:
        return False
    fig, axes = plt.subplots(len(runs), 3, figsize=(15, 5 * len(runs)), squeeze=False)
    for row_index, run in enumerate(runs):
        map_dir = run["map"]
        with open(os.path.join(map_dir, "maps.csv"), newline="") as f:
            maps = list(csv.DictReader(f))
        regions, footholds = {}, {}
        with open(os.path.join(map_dir, "regions.csv"), newline="") as f:
            for r in csv.DictReader(f):
                regions.setdefault(int(r["snapshot[-]"]), {}).setdefault(int(r["region[-]"]), []).append(
                    (float(r["x[m]"]), float(r["y[m]"])))
        with open(os.path.join(map_dir, "footholds.csv"), newline="") as f:
            for r in csv.DictReader(f):
                footholds.setdefault(int(r["snapshot[-]"]), []).append((float(r["x[m]"]), float(r["y[m]"])))
        if not maps:
            continue
        picks = sorted(set([0, len(maps) // 2, len(maps) - 1]))
        # One colour scale per run: the heights of the snapshots drawn.
        values = []
        for k in picks:
            for line in read_npy_f32(os.path.join(map_dir, maps[k]["heights_file"])):
                values.extend(v for v in line if v == v)
        vmin, vmax = (min(values), max(values)) if values else (0.0, 1.0)
        image = None
        for col in range(3):
            ax = axes[row_index][col]
            if col < len(picks):
                image = top_view(ax, map_dir, picks[col], maps, regions, footholds, vmin, vmax)
            else:
                ax.axis("off")
        axes[row_index][0].annotate(label(run) + " (" + run.get("terrain", "") + ")", (0, 1.08),
                                    xycoords="axes fraction", fontsize=9)
        if image is not None:
            fig.colorbar(image, ax=list(axes[row_index]), label="height [m]", shrink=0.8)
    fig.savefig(os.path.join(out, "map.png"), dpi=80)
    plt.close(fig)
    return True


def fig_speed_sweep(spec, out):
    series = spec.get("speed_sweep") or []
    if not any(s["points"] for s in series):
        return False
    fig, axes = plt.subplots(3, 1, figsize=(7, 8), sharex=True)
    keys = [("traverse_time", "traverse time [s]"), ("mean_abs_vz", "mean |v_z| [m/s]"),
            ("mean_abs_wy", "mean |w_y| [rad/s]")]
    for k, s in enumerate(series):
        color = "C%d" % k
        for ax, (key, ylabel) in zip(axes, keys):
            ok = [(p["speed"], p[key]) for p in s["points"] if p["passed"] and p[key] is not None]
            if ok:
                ax.plot([x for x, _ in ok], [y for _, y in ok], "o-", color=color, lw=1.2, ms=4,
                        label=s["title"] if ax is axes[0] else None)
            # Failed runs: a cross at their value, or on the axis when they have none.
            bad = [(p["speed"], p[key] if p[key] is not None else 0.0)
                   for p in s["points"] if not p["passed"]]
            if bad:
                ax.plot([x for x, _ in bad], [y for _, y in bad], "x", color=color, ms=8, mew=2,
                        label=(s["title"] + " (failed)") if ax is axes[0] else None)
            ax.set_ylabel(ylabel)
            ax.grid(alpha=0.3)
    axes[-1].set_xlabel("commanded speed [m/s]")
    axes[0].legend(loc="upper right", fontsize=8)
    fig.suptitle("Speed sweep: Table 1 metrics against the commanded speed")
    fig.tight_layout()
    fig.savefig(os.path.join(out, "speed_sweep.png"), dpi=90)
    plt.close(fig)
    return True


def main():
    if len(sys.argv) != 2:
        sys.exit("usage: figures.py FIGURES_JSON")
    with open(sys.argv[1]) as f:
        spec = json.load(f)
    out = spec["out"]
    runs = spec["runs"]
    pick = lambda key: [runs[name] for name in spec["figures"].get(key, [])]  # noqa: E731
    made = []
    jobs = [("fig2", lambda: fig2(spec, pick("table1"), out)),
            ("fig4", lambda: fig4(spec, pick("fig4"), out)),
            ("fig6", lambda: fig6(spec, pick("fig6"), spec["machine"], out)),
            ("fig8", lambda: fig8(spec, pick("fig8"), out)),
            ("map", lambda: fig_map(spec, pick("map"), out)),
            ("speed_sweep", lambda: fig_speed_sweep(spec, out))]
    for name, job in jobs:
        # One figure's trouble (a log without a column) must not cost the others.
        try:
            if job():
                made.append(name + ".png")
        except Exception as e:  # noqa: BLE001
            print("%s: %s: %s" % (name, type(e).__name__, e), file=sys.stderr)
    print("figures.py: wrote " + (", ".join(made) if made else "nothing"))


if __name__ == "__main__":
    main()
