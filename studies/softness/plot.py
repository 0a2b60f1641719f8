"""Softness (alpha_r) study plots from OUT_DIR/softness.h5 (studies/softness).

usage: plot.py OUT_DIR/table.csv OUT_DIR   (the comparison's plot-script arguments; the study's
conclusions are in softness.h5 beside the table)
softness_dt.png: measured cost per tau_0 per particle of every stable and accurate integrator
setting against alpha_r (the chosen one marked), and Euler's largest step;
softness_pscan.png: mu and phi against P per alpha_r and J, the common P -> 0 reference as a
band, P* marked; softness_cost.png: CPU seconds (N of the preset, and N = 1000) and particle
force evaluations per particle to reach strain 1 at P* against alpha_r.
"""
import os
import sys

import h5py
import matplotlib

matplotlib.use("Agg")
import matplotlib.pyplot as plt  # noqa: E402
import numpy as np  # noqa: E402


def text(v):
    return v.decode() if isinstance(v, bytes) else str(v)


def main():
    out = sys.argv[2]
    path = os.path.join(os.path.dirname(os.path.abspath(sys.argv[1])), "softness.h5")
    alphas = []
    refs = {}
    with h5py.File(path, "r") as f:
        n = int(f.attrs["N"])
        if "reference" in f:
            for jk in f["reference"].keys():
                ra = f["reference"][jk].attrs
                refs[float(ra["J"])] = {"usable": int(ra["usable"]),
                                        "mu": float(ra["mu"]), "mu_err": float(ra["mu_err"]),
                                        "phi": float(ra["phi"]), "phi_err": float(ra["phi_err"])}
        for key in sorted(f["alphas"].keys()):
            g = f["alphas"][key]
            a = {"alpha": float(g.attrs["alpha"]), "euler": float(g.attrs["euler_dt_max"]),
                 "integrator": text(g.attrs["integrator"]),
                 "verified": int(g.attrs["integrator_verified"]), "cands": [], "pscan": {}}
            if "candidates" in g:
                for ck in sorted(g["candidates"].keys(), key=lambda k: int(k[1:])):
                    ca = g["candidates"][ck].attrs
                    a["cands"].append({"label": text(ca["setting"]), "ok": int(ca["ok"]),
                                       "cost": float(ca["seconds_per_tau_particle"]),
                                       "chosen": int(ca["chosen"])})
            if "pscan" in g:
                for jk in g["pscan"].keys():
                    pg = g["pscan"][jk]
                    runs = []
                    for rk in sorted(pg["runs"].keys()):
                        ra = pg["runs"][rk].attrs
                        runs.append({"P": float(ra["imposed_pressure"]), "verdict": text(ra["verdict"]),
                                     "mu": float(ra.get("summary_mu", np.nan)),
                                     "mu_err": float(ra.get("summary_mu_err", np.nan)),
                                     "phi": float(ra.get("summary_phi", np.nan)),
                                     "phi_err": float(ra.get("summary_phi_err", np.nan))})
                    a["pscan"][float(pg.attrs["J"])] = {
                        "runs": runs, "p_star": float(pg.attrs["p_star"]),
                        "cpu": float(pg.attrs["cpu_seconds_N"]),
                        "cpu1000": float(pg.attrs["cpu_seconds_N1000"]),
                        "evals": float(pg.attrs["evaluations_per_particle"])}
            alphas.append(a)
    alphas.sort(key=lambda a: a["alpha"])
    al = np.array([a["alpha"] for a in alphas])

    fig, (a1, a2) = plt.subplots(1, 2, figsize=(12, 4.5))
    markers = {"euler": "o", "respa": "s", "cvode": "^", "rkc": "D"}
    for a in alphas:
        for c in a["cands"]:
            if not c["ok"] or not np.isfinite(c["cost"]):
                continue
            fam = c["label"].split("-")[0]
            a1.plot(a["alpha"], 1e6 * c["cost"], markers.get(fam, "x"),
                    color="C3" if c["chosen"] else "grey", mfc="none" if not c["chosen"] else None)
    for fam, m in markers.items():
        a1.plot([], [], m, color="grey", mfc="none", label=fam)
    a1.plot([], [], "o", color="C3", label="chosen")
    a1.set_yscale("log")
    a1.set_xlabel("α_r")
    a1.set_ylabel("μs per τ0 per particle (stable, accurate)")
    a1.grid(alpha=0.3, which="both")
    a1.legend(fontsize=8)
    a2.plot(al, [a["euler"] for a in alphas], "k-o")
    a2.set_yscale("log")
    a2.set_xlabel("α_r")
    a2.set_ylabel("largest stable and accurate Euler dt")
    a2.grid(alpha=0.3, which="both")
    fig.tight_layout()
    fig.savefig(f"{out}/softness_dt.png", dpi=110)
    plt.close(fig)

    js = sorted({j for a in alphas for j in a["pscan"]} | set(refs), reverse=True)
    fig, axes = plt.subplots(2, max(1, len(js)), figsize=(6 * max(1, len(js)), 8), squeeze=False)
    cmap = plt.get_cmap("viridis")
    for c, j in enumerate(js):
        ref = refs.get(j)
        for row, key in ((0, "mu"), (1, "phi")):
            if ref and ref["usable"]:
                axes[row][c].axhspan(ref[key] - 2 * ref[key + "_err"],
                                     ref[key] + 2 * ref[key + "_err"], color="grey", alpha=0.3,
                                     label="common reference ± 2σ" if row == 0 else None)
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
    for j in [j for j in js if any(j in a["pscan"] for a in alphas)]:
        cpu = np.array([a["pscan"].get(j, {}).get("cpu", np.nan) for a in alphas])
        ev = np.array([a["pscan"].get(j, {}).get("evals", np.nan) for a in alphas])
        unver = np.array([not a["verified"] for a in alphas], dtype=bool)
        line, = a1.plot(al, cpu, "o-", label=f"J = {j:g}")
        a1.plot(al[unver], cpu[unver], "^", color=line.get_color(), ms=10, mfc="none")
        a2.plot(al, ev, "o-", color=line.get_color(), label=f"J = {j:g}")
    for a in (a1, a2):
        a.axvspan(1.75, 2.0, color="grey", alpha=0.2, label="seed's optimum")
    for a, lab in ((a1, f"CPU s to strain 1 at P* (N = {n})"),
                   (a2, "force evaluations per particle to strain 1")):
        a.set_yscale("log")
        a.set_xlabel("α_r")
        a.set_ylabel(lab)
        a.grid(alpha=0.3, which="both")
        a.legend(fontsize=8)
    a1.set_title("open triangles: integrator not verified", fontsize=9)
    fig.tight_layout()
    fig.savefig(f"{out}/softness_cost.png", dpi=110)
    plt.close(fig)


if __name__ == "__main__":
    main()
