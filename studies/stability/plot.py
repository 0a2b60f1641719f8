"""Stability study plots from stability.h5 (studies/stability).

usage: plot.py stability.h5 OUT_DIR
Writes stability_map.png (verdict per case against dt / tolerance, one panel per integrator
family) and stability_diagnostics.png (energy balance and force step correlation against dt
for explicit Euler).
"""
import sys

import h5py
import matplotlib

matplotlib.use("Agg")
import matplotlib.pyplot as plt  # noqa: E402
import numpy as np  # noqa: E402

COLORS = {"stable": "tab:green", "oscillating": "tab:orange", "diverged": "tab:red",
          "incomplete": "tab:purple", "not steady": "tab:olive", "correlated": "tab:cyan",
          "not available": "lightgrey"}


def text(v):
    return v.decode() if isinstance(v, bytes) else str(v)


def load(path):
    cases = []
    with h5py.File(path, "r") as f:
        for key in sorted(f["cases"].keys()):
            g = f["cases"][key]
            runs = []
            if "runs" in g:
                for rk in sorted(g["runs"].keys()):
                    a = g["runs"][rk].attrs
                    runs.append({k: (text(a[k]) if isinstance(a[k], (bytes, str)) else a[k])
                                 for k in a.keys()})
            cases.append({"name": text(g.attrs["name"]), "runs": runs})
    return cases


def main():
    path, out = sys.argv[1], sys.argv[2]
    cases = load(path)
    families = [("euler", "step", "Euler: dt"), ("respa", "step", "RESPA: outer dt"),
                ("cvode", "tolerance", "CVODE: rtol")]
    fig, axes = plt.subplots(1, 3, figsize=(15, 0.45 * len(cases) + 2.0), sharey=True)
    for ax, (fam, key, label) in zip(axes, families):
        for yi, c in enumerate(cases):
            for r in c["runs"]:
                if r.get("family") != fam:
                    continue
                x = float(r.get(key, 0.0))
                if x <= 0:
                    continue
                v = r.get("verdict", "not available")
                marker = "s" if int(r.get("laned", 0)) else "o"
                # Several RESPA splittings at one dt: offset them slightly.
                off = 0.0
                if fam == "respa":
                    s = r.get("setting", "")
                    off = 0.18 if "piston" in s else (-0.18 if "heun" in s else 0.0)
                ax.scatter([x], [yi + off], c=COLORS.get(v, "k"), marker=marker, s=60,
                           edgecolors="k", linewidths=0.4)
        ax.set_xscale("log")
        ax.set_xlabel(label)
        ax.grid(alpha=0.3)
    axes[0].set_yticks(range(len(cases)))
    axes[0].set_yticklabels([c["name"] for c in cases])
    axes[0].invert_yaxis()
    handles = [plt.Line2D([], [], marker="o", ls="", color=c, markeredgecolor="k", label=k)
               for k, c in COLORS.items()]
    handles.append(plt.Line2D([], [], marker="s", ls="", color="w", markeredgecolor="k",
                              label="lanes"))
    axes[2].legend(handles=handles, loc="best", fontsize=8)
    fig.suptitle("Stable / oscillating / diverged map")
    fig.tight_layout()
    fig.savefig(f"{out}/stability_map.png", dpi=110)
    plt.close(fig)

    fig, (a1, a2) = plt.subplots(1, 2, figsize=(13, 5))
    cmap = plt.get_cmap("tab20")
    for ci, c in enumerate(cases):
        pts = sorted((float(r["step"]), float(r.get("balance_ratio", np.nan)),
                      float(r.get("force_correlation", np.nan)))
                     for r in c["runs"]
                     if r.get("family") == "euler" and r.get("verdict") in ("stable", "oscillating"))
        if not pts:
            continue
        dt, eb, fc = map(np.array, zip(*pts))
        a1.plot(dt, np.abs(eb), "o-", ms=4, color=cmap(ci % 20), label=c["name"])
        a2.plot(dt, fc, "o-", ms=4, color=cmap(ci % 20), label=c["name"])
    a1.axhspan(0.95, 1.05, color="tab:green", alpha=0.15)
    a1.set_xscale("log")
    a1.set_yscale("log")
    a1.set_xlabel("Euler dt")
    a1.set_ylabel("energy balance <σ γ̇ V> / <D + D_piston> (drift corrected)")
    a2.axhline(0.9, color="k", ls="--", lw=0.8)
    a2.set_xscale("log")
    a2.set_xlabel("Euler dt")
    a2.set_ylabel("force step correlation c (1: smooth, -1: period 2)")
    a2.legend(fontsize=7, ncol=2)
    for a in (a1, a2):
        a.grid(alpha=0.3)
    fig.suptitle("Stability diagnostics (diverged runs omitted)")
    fig.tight_layout()
    fig.savefig(f"{out}/stability_diagnostics.png", dpi=110)
    plt.close(fig)


if __name__ == "__main__":
    main()
