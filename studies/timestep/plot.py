"""Work-precision plots of the timestep study from timestep.h5 (studies/timestep).

usage: plot.py timestep.h5 OUT_DIR
One figure per observable (sigma_xy; phi or P_hat; energy-balance residual), one panel per
state point: error against CPU seconds, log-log, one curve per integrator (Euler, each RESPA
splitting, CVODE). Filled markers: stable runs; crosses: oscillating runs (not usable);
dashed line: twice the median statistical floor (differences below it are not resolved).
"""
import sys

import h5py
import matplotlib

matplotlib.use("Agg")
import matplotlib.pyplot as plt  # noqa: E402
import numpy as np  # noqa: E402


def text(v):
    return v.decode() if isinstance(v, bytes) else str(v)


def load(path):
    points = []
    with h5py.File(path, "r") as f:
        for key in sorted(f["points"].keys()):
            g = f["points"][key]
            runs = []
            if "runs" in g:
                for rk in sorted(g["runs"].keys()):
                    a = g["runs"][rk].attrs
                    runs.append({k: (text(a[k]) if isinstance(a[k], (bytes, str)) else a[k])
                                 for k in a.keys()})
            points.append({"name": text(g.attrs["name"]),
                           "cp": int(g.attrs["constant_pressure"]), "runs": runs})
    return points


def panel(ax, point, err_key, floor_key, ylabel):
    curves = {}
    floors = []
    for r in point["runs"]:
        if err_key not in r or int(r.get("is_reference", 0)):
            continue
        e, fl, cpu = float(r[err_key]), float(r[floor_key]), float(r["cpu_seconds"])
        if not np.isfinite(e) or cpu <= 0:
            continue
        v = r["verdict"]
        if v not in ("stable", "oscillating"):
            continue
        step, tol = float(r.get("step", 0.0)), float(r.get("tolerance", 0.0))
        order = -step if step > 0 else -tol
        curves.setdefault(r["curve"], []).append((cpu, max(e, 1e-12), v, r["setting"], order))
        if np.isfinite(fl):
            floors.append(fl)
    cmap = plt.get_cmap("tab10")
    for ci, (name, pts) in enumerate(sorted(curves.items())):
        pts.sort(key=lambda p: p[4])
        cpu = np.array([p[0] for p in pts])
        err = np.array([p[1] for p in pts])
        ok = np.array([p[2] == "stable" for p in pts])
        color = cmap(ci % 10)
        ax.plot(cpu, err, "-", color=color, lw=1, alpha=0.6)
        ax.plot(cpu[ok], err[ok], "o", color=color, ms=5, label=name)
        ax.plot(cpu[~ok], err[~ok], "x", color=color, ms=7)
        for p in pts:
            lab = p[3].split("=")[-1]
            ax.annotate(lab, (p[0], p[1]), fontsize=6, xytext=(2, 2),
                        textcoords="offset points", color=color)
    if floors:
        ax.axhline(2 * np.median(floors), color="k", ls="--", lw=0.8)
    ax.set_xscale("log")
    ax.set_yscale("log")
    ax.set_title(point["name"], fontsize=9)
    ax.set_xlabel("CPU s (1 thread)")
    ax.set_ylabel(ylabel)
    ax.grid(alpha=0.3, which="both")


def figure(points, out, fname, pick, title):
    n = len(points)
    cols = min(4, n)
    rows = (n + cols - 1) // cols
    fig, axes = plt.subplots(rows, cols, figsize=(4.2 * cols, 3.6 * rows), squeeze=False)
    for ax, p in zip(axes.flat, points):
        panel(ax, p, *pick(p))
    for ax in list(axes.flat)[n:]:
        ax.axis("off")
    axes.flat[0].legend(fontsize=7)
    fig.suptitle(title)
    fig.tight_layout()
    fig.savefig(f"{out}/{fname}", dpi=110)
    plt.close(fig)


def main():
    path, out = sys.argv[1], sys.argv[2]
    points = load(path)
    figure(points, out, "timestep_wp_sigma_xy.png",
           lambda p: ("err_sigma_xy", "floor_sigma_xy", "|Δσ_xy| / σ_ref"),
           "Work-precision: shear stress")
    figure(points, out, "timestep_wp_phi_pressure.png",
           lambda p: (("err_phi", "floor_phi", "|Δφ|") if p["cp"]
                      else ("err_pressure", "floor_pressure", "|ΔP̂| / P̂_ref")),
           "Work-precision: packing fraction (constant P) or pressure (constant V)")
    figure(points, out, "timestep_wp_balance.png",
           lambda p: ("err_balance", "floor_balance", "|energy balance − 1|"),
           "Work-precision: energy-balance residual")


if __name__ == "__main__":
    main()
