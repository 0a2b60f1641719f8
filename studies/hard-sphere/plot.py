"""Flow curves of the hard-sphere study (the seed's Figs. 2-3), from the collected sweep table:
sigma_xy, phi and eta against gdot for each pressure, and mu(J), phi(J) for every pressure.
Points whose verdicts failed (not steady or not stable in some replica) are drawn hollow: the
analysis leaves them out.

usage: plot.py table.csv flow_curves.png
"""
import csv
import sys

import matplotlib
import numpy as np

matplotlib.use("Agg")
import matplotlib.pyplot as plt  # noqa: E402


def number(text):
    return float(text) if text not in ("", None) else np.nan


def main(table_path, png_path):
    with open(table_path, newline="") as f:
        rows = list(csv.DictReader(f))
    if not rows:
        raise SystemExit("no rows in " + table_path)
    sizes = sorted({int(r["N"]) for r in rows})
    pressures = sorted({number(r["imposed_pressure"]) for r in rows}, reverse=True)
    colors = plt.cm.viridis(np.linspace(0.0, 0.9, max(len(pressures), 2)))
    markers = "osD^v<>ph*"
    fig, axes = plt.subplots(2, 3, figsize=(13, 7.5))
    (ax_s, ax_p, ax_e), (ax_mu, ax_phi, ax_off) = axes
    ax_off.axis("off")
    for ni, n in enumerate(sizes):
        for pi, p in enumerate(pressures):
            pts = [r for r in rows if int(r["N"]) == n and number(r["imposed_pressure"]) == p]
            if not pts:
                continue
            pts.sort(key=lambda r: number(r["shear_rate"]))
            g = np.array([number(r["shear_rate"]) for r in pts])
            j = np.array([number(r["J"]) for r in pts])
            ok = np.array([r["steady"] != "0" and r["stable"] != "0" for r in pts])
            label = "P = %.0e" % p + ("" if len(sizes) == 1 else ", N = %d" % n)
            for ax, x, key in ((ax_s, g, "sigma_xy"), (ax_p, g, "phi"), (ax_e, g, "eta"),
                               (ax_mu, j, "mu"), (ax_phi, j, "phi")):
                y = np.array([number(r[key]) for r in pts])
                e = np.array([number(r[key + "_err"]) for r in pts])
                kw = dict(color=colors[pi], marker=markers[ni % len(markers)], ms=5)
                ax.plot(x, y, "-", color=colors[pi], lw=0.8, alpha=0.6)
                ax.errorbar(x[ok], y[ok], yerr=e[ok], ls="none", label=label, **kw)
                if (~ok).any():
                    ax.errorbar(x[~ok], y[~ok], yerr=e[~ok], ls="none", mfc="none", **kw)
    for ax, ylabel in ((ax_s, r"$\sigma_{xy}$"), (ax_p, r"$\varphi$"), (ax_e, r"$\eta/\eta_0$")):
        ax.set_xscale("log")
        ax.set_xlabel(r"$\dot\gamma$")
        ax.set_ylabel(ylabel)
    ax_s.set_yscale("log")
    ax_e.set_yscale("log")
    for ax, ylabel in ((ax_mu, r"$\mu = \sigma_{xy}/P$"), (ax_phi, r"$\varphi$")):
        ax.set_xscale("log")
        ax.set_xlabel(r"$J = \dot\gamma \eta_0 / P$")
        ax.set_ylabel(ylabel)
    ax_s.legend(fontsize=8)
    ax_off.text(0.0, 0.9, "hollow: not steady or not stable\n(left out of the fits)\n"
                "lines join the points of one pressure", va="top", fontsize=10)
    fig.suptitle("Hard-sphere study: flow curves and granular rheology (cf. the seed's Figs. 2-3)")
    fig.tight_layout()
    fig.savefig(png_path, dpi=110)


if __name__ == "__main__":
    if len(sys.argv) != 3:
        raise SystemExit(__doc__)
    main(sys.argv[1], sys.argv[2])
