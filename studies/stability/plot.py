"""Stability study plots from the comparison's table (studies/stability).

usage: plot.py OUT/table.csv OUT_DIR
Writes stability_map.png (each case's verdict against the step or tolerance, one panel per
integrator family; the class of the diagnostic window, the `window` column) and
stability_diagnostics.png (energy balance and force step correlation against explicit Euler's
step, diverged runs left out).
"""
import csv
import sys

import matplotlib

matplotlib.use("Agg")
import matplotlib.pyplot as plt  # noqa: E402
import numpy as np  # noqa: E402

COLORS = {"stable": "tab:green", "oscillating": "tab:orange", "diverged": "tab:red",
          "incomplete": "tab:purple", "not steady": "tab:olive", "correlated": "tab:cyan",
          "not available": "lightgrey"}


def number(v):
    try:
        return float(v)
    except (TypeError, ValueError):
        return float("nan")


def window_class(cell):
    """'oscillating × 1' -> ('oscillating', False); 'stable; lanes × 1' -> ('stable', True)."""
    first = (cell or "not available").split(" × ")[0]
    return first.replace("; lanes", "").strip(), "lanes" in first


def load(path):
    cases = {}
    with open(path, newline="") as f:
        for row in csv.DictReader(f):
            cases.setdefault(row.get("case", ""), []).append(row)
    return list(cases.items())


def main():
    path, out = sys.argv[1], sys.argv[2]
    cases = load(path)
    families = [("euler", "dt", "Euler: dt"), ("respa", "dt", "RESPA: outer dt"),
                ("cvode", "rtol", "CVODE: rtol"), ("rkc", "rtol", "RKC: rtol")]
    present = [f for f in families if any(r["integrator"] == f[0] for _, rows in cases for r in rows)]
    fig, axes = plt.subplots(1, len(present), figsize=(5 * len(present), 0.45 * len(cases) + 2.0),
                             sharey=True, squeeze=False)
    axes = axes[0]
    for ax, (fam, key, label) in zip(axes, present):
        for yi, (name, rows) in enumerate(cases):
            for r in rows:
                x = number(r.get(key))
                if r["integrator"] != fam or not x > 0:
                    continue
                verdict, lanes = window_class(r.get("window"))
                # Several RESPA splittings at one dt: offset them slightly.
                s = r["setting"]
                off = (0.18 if "piston" in s else (-0.18 if "heun" in s else 0.0)) \
                    if fam == "respa" else 0.0
                ax.scatter([x], [yi + off], c=COLORS.get(verdict, "k"), marker="s" if lanes else "o",
                           s=60, edgecolors="k", linewidths=0.4)
        ax.set_xscale("log")
        ax.set_xlabel(label)
        ax.grid(alpha=0.3)
    axes[0].set_yticks(range(len(cases)))
    axes[0].set_yticklabels([name for name, _ in cases])
    axes[0].invert_yaxis()
    handles = [plt.Line2D([], [], marker="o", ls="", color=c, markeredgecolor="k", label=k)
               for k, c in COLORS.items()]
    handles.append(plt.Line2D([], [], marker="s", ls="", color="w", markeredgecolor="k",
                              label="lanes"))
    axes[-1].legend(handles=handles, loc="best", fontsize=8)
    fig.suptitle("Stable / oscillating / diverged map")
    fig.tight_layout()
    fig.savefig(f"{out}/stability_map.png", dpi=110)
    plt.close(fig)

    fig, (a1, a2) = plt.subplots(1, 2, figsize=(13, 5))
    cmap = plt.get_cmap("tab20")
    for ci, (name, rows) in enumerate(cases):
        pts = sorted((number(r["dt"]), number(r["energy_balance"]),
                      number(r["force_step_correlation"]))
                     for r in rows if r["integrator"] == "euler"
                     and window_class(r.get("window"))[0] not in ("diverged", "not available"))
        pts = [p for p in pts if np.isfinite(p[1])]
        if not pts:
            continue
        dt, eb, fc = map(np.array, zip(*pts))
        a1.plot(dt, np.abs(eb), "o-", ms=4, color=cmap(ci % 20), label=name)
        a2.plot(dt, fc, "o-", ms=4, color=cmap(ci % 20), label=name)
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
