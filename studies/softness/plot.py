"""Softness (alpha_r) study plots from softness.h5 (studies/softness).

usage: plot.py softness.h5 OUT_DIR
softness_dt.png: largest stable and accurate Euler dt against alpha_r (both ends of the
overlap range); softness_pscan.png: mu and phi against P per alpha_r and J, P* marked;
softness_cost.png: particle-steps per particle (and CPU s for N = 1000) to reach strain 1 in
the hard-sphere limit against alpha_r.
"""
import sys

import h5py
import matplotlib

matplotlib.use("Agg")
import matplotlib.pyplot as plt  # noqa: E402
import numpy as np  # noqa: E402


def text(v):
    return v.decode() if isinstance(v, bytes) else str(v)


def main():
    path, out = sys.argv[1], sys.argv[2]
    alphas = []
    with h5py.File(path, "r") as f:
        for key in sorted(f["alphas"].keys()):
            g = f["alphas"][key]
            a = {"alpha": float(g.attrs["alpha"]), "dt_max": float(g.attrs["dt_max"]),
                 "hi": float(g.attrs["dt_max_hi"]), "lo": float(g.attrs["dt_max_lo"]),
                 "pscan": {}}
            for jk in g["pscan"].keys():
                pg = g["pscan"][jk]
                runs = []
                for rk in sorted(pg["runs"].keys()):
                    ra = pg["runs"][rk].attrs
                    runs.append({"P": float(ra["pressure"]), "verdict": text(ra["verdict"]),
                                 "mu": float(ra.get("summary_mu", np.nan)),
                                 "mu_err": float(ra.get("summary_mu_err", np.nan)),
                                 "phi": float(ra.get("summary_phi", np.nan)),
                                 "phi_err": float(ra.get("summary_phi_err", np.nan))})
                a["pscan"][float(pg.attrs["J"])] = {
                    "runs": runs, "p_star": float(pg.attrs["p_star"]),
                    "steps": float(pg.attrs["steps_per_particle"]),
                    "cpu": float(pg.attrs["cpu_seconds_N1000"]),
                    "lower": int(pg.attrs["cost_lower_bound"])}
            alphas.append(a)
    alphas.sort(key=lambda a: a["alpha"])
    al = np.array([a["alpha"] for a in alphas])

    fig, ax = plt.subplots(figsize=(6, 4.5))
    ax.plot(al, [a["hi"] for a in alphas], "s--", label="largest δ (highest P)")
    ax.plot(al, [a["lo"] for a in alphas], "o--", label="smallest δ (lowest P)")
    ax.plot(al, [a["dt_max"] for a in alphas], "k-", lw=2, label="dt_max (min of both)")
    ax.set_yscale("log")
    ax.set_xlabel("α_r")
    ax.set_ylabel("largest stable and accurate Euler dt")
    ax.grid(alpha=0.3, which="both")
    ax.legend()
    fig.tight_layout()
    fig.savefig(f"{out}/softness_dt.png", dpi=110)
    plt.close(fig)

    js = sorted({j for a in alphas for j in a["pscan"]}, reverse=True)
    fig, axes = plt.subplots(2, len(js), figsize=(6 * len(js), 8), squeeze=False)
    cmap = plt.get_cmap("viridis")
    for c, j in enumerate(js):
        for ai, a in enumerate(alphas):
            if j not in a["pscan"]:
                continue
            s = a["pscan"][j]
            ok = [r for r in s["runs"] if r["verdict"] == "stable"]
            if not ok:
                continue
            color = cmap(ai / max(1, len(alphas) - 1))
            P = np.array([r["P"] for r in ok])
            for row, key in ((0, "mu"), (1, "phi")):
                y = np.array([r[key] for r in ok])
                e = np.array([r[key + "_err"] for r in ok])
                axes[row][c].errorbar(P, y, yerr=e, fmt="o-", color=color, ms=4, capsize=2,
                                      label=f"α_r = {a['alpha']:g}")
                if np.isfinite(s["p_star"]):
                    axes[row][c].axvline(s["p_star"], color=color, ls=":", lw=1)
        for row, lab in ((0, "μ = σ_xy / P"), (1, "φ")):
            axes[row][c].set_xscale("log")
            axes[row][c].set_xlabel("P")
            axes[row][c].set_ylabel(lab)
            axes[row][c].set_title(f"J = {j:g} (dotted: P*)")
            axes[row][c].grid(alpha=0.3)
        axes[0][c].legend(fontsize=7)
    fig.tight_layout()
    fig.savefig(f"{out}/softness_pscan.png", dpi=110)
    plt.close(fig)

    fig, (a1, a2) = plt.subplots(1, 2, figsize=(12, 4.5))
    for j in js:
        st = np.array([a["pscan"].get(j, {}).get("steps", np.nan) for a in alphas])
        cpu = np.array([a["pscan"].get(j, {}).get("cpu", np.nan) for a in alphas])
        low = np.array([a["pscan"].get(j, {}).get("lower", 0) for a in alphas], dtype=bool)
        line, = a1.plot(al, st, "o-", label=f"J = {j:g}")
        a1.plot(al[low], st[low], "^", color=line.get_color(), ms=10, mfc="none")
        a2.plot(al, cpu, "o-", color=line.get_color(), label=f"J = {j:g}")
    a1.axvspan(1.75, 2.0, color="grey", alpha=0.2, label="seed's optimum")
    a2.axvspan(1.75, 2.0, color="grey", alpha=0.2)
    for a, lab in ((a1, "particle-steps per particle to strain 1"), (a2, "CPU s (N = 1000)")):
        a.set_yscale("log")
        a.set_xlabel("α_r")
        a.set_ylabel(lab)
        a.grid(alpha=0.3, which="both")
        a.legend(fontsize=8)
    a1.set_title("open triangles: lower bounds (no stable dt in scan)", fontsize=9)
    fig.tight_layout()
    fig.savefig(f"{out}/softness_cost.png", dpi=110)
    plt.close(fig)


if __name__ == "__main__":
    main()
