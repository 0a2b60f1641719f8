"""Figures 4-7 of Kawasaki et al., PRE 91, 012203 (2015), from the sidecar of
`jamflow analyze hard-sphere`:
  fig4: phi_J(N) - phi and mu - mu_J(N) vs J, envelope (filled) and fits;
  fig5: fitted parameters vs N with O(N) = O_inf + A N^-alpha (Table 2 dashed);
  fig6: finite-size effects and the scaling plots (scaling_phi, scaling_mu);
  fig7: eta/eta_0 = mu/J vs phi_J - phi with the law (eta) and its two parts.
"""
from common import colours, load_matplotlib, read_args

plt, np = load_matplotlib()
data, prefix = read_args()
sizes = data["sizes"]
IN_ENVELOPE = ("agrees", "above_agreement")
NAMES = ["phi_J", "b_phi", "C_phi", "mu_J", "b_mu", "C_mu"]


def arrays(s):
    return {k: np.asarray(s[k], dtype=float) for k in ("imposed_pressure", "J", "phi", "phi_err", "mu", "mu_err")}


def fig4():
    unfitted = data.get("unfitted", [])
    rows = len(sizes) + len(unfitted)
    if rows == 0:
        return
    fig, axes = plt.subplots(rows, 2, figsize=(9, 2.8 * rows), squeeze=False)
    for row, s in enumerate(unfitted, start=len(sizes)):
        # No fit: phi(J) and mu(J) themselves, filled where a point is in the envelope.
        a = arrays(s)
        env = np.array([st in IN_ENVELOPE for st in s["status"]])
        pressures = sorted(set(a["imposed_pressure"]))
        cols = colours(plt, len(pressures))
        for col, (name, label) in enumerate([("phi", r"$\varphi$"), ("mu", r"$\mu$")]):
            ax = axes[row][col]
            for p, c in zip(pressures, cols):
                sel = a["imposed_pressure"] == p
                labelled = False
                for mask, face in ((sel & env, c), (sel & ~env, "none")):
                    if mask.any():
                        ax.errorbar(a["J"][mask], a[name][mask], yerr=a[name + "_err"][mask],
                                    fmt="o-", ms=4, mfc=face, mec=c, color=c, lw=0.8,
                                    label=None if labelled else f"P={p:g}")
                        labelled = True
            ax.set_xscale("log")
            ax.set_xlabel(r"$J$")
            ax.set_ylabel(label)
            ax.set_title(f"N = {s['N']}: not fitted (filled = envelope)", fontsize=9)
            if col == 0:
                ax.legend(fontsize=7)
    for row, s in enumerate(sizes):
        a = arrays(s)
        par = {k: v[0] for k, v in s["params"].items()}
        env = np.array([st in IN_ENVELOPE for st in s["status"]])
        pressures = sorted(set(a["imposed_pressure"]))
        cols = colours(plt, len(pressures))
        jj = np.logspace(np.log10(a["J"].min()), np.log10(a["J"].max()), 100)
        for col, (yv, err, line, label) in enumerate([
            (par["phi_J"] - a["phi"], a["phi_err"], par["C_phi"] * jj ** par["b_phi"],
             r"$\varphi_J(N) - \varphi$"),
            (a["mu"] - par["mu_J"], a["mu_err"], par["C_mu"] * jj ** par["b_mu"],
             r"$\mu - \mu_J(N)$"),
        ]):
            ax = axes[row][col]
            for p, c in zip(pressures, cols):
                sel = (a["imposed_pressure"] == p) & (yv > 0)
                labelled = False
                for mask, face in ((sel & env, c), (sel & ~env, "none")):
                    if mask.any():
                        ax.errorbar(a["J"][mask], yv[mask], yerr=err[mask], fmt="o", ms=4,
                                    mfc=face, mec=c, ecolor=c, lw=0.8,
                                    label=None if labelled else f"P={p:g}")
                        labelled = True
            ax.plot(jj, line, "k-", lw=1)
            for jv in s["J_range"]:  # the paper's arrows: the envelope's J range
                ax.annotate("", xy=(jv, 0.03), xycoords=("data", "axes fraction"),
                            xytext=(jv, 0.25), textcoords=("data", "axes fraction"),
                            arrowprops=dict(arrowstyle="->", color="k"))
            ax.set_xscale("log")
            ax.set_yscale("log")
            ax.set_xlabel(r"$J$")
            ax.set_ylabel(label)
            ax.set_title(f"N = {s['N']}: filled = envelope, arrows = its J range", fontsize=9)
            if col == 0:
                ax.legend(fontsize=7, loc="upper left")
    fig.tight_layout()
    fig.savefig(prefix + "_fig4.png", dpi=110)
    plt.close(fig)


def fig5():
    if not sizes:
        return
    ns = np.array([s["N"] for s in sizes], dtype=float)
    nn = np.logspace(np.log10(ns.min()) - 0.2, np.log10(ns.max()) + 0.5, 100)
    fig, axes = plt.subplots(2, 3, figsize=(11, 6))
    for ax, name in zip(axes.flat, NAMES):
        v = np.array([s["params"][name][0] for s in sizes])
        e = np.array([s["params"][name][1] for s in sizes])
        ax.errorbar(ns, v, yerr=e, fmt="o", color="C0")
        ex = data["extrapolated"].get(name)
        resolved = data.get("extrapolation_resolved", {}).get(name, True)
        if ex is not None and len(ex) == 3:
            inf, a, alpha = ex
            ax.plot(nn, inf + a * nn ** -alpha, "C0-" if resolved else "C0--",
                    label="fit" if resolved else "fit, not resolved (A_O not distinct from 0)")
            ax.axhline(inf, color="C0", lw=0.6, ls=":")
        elif ex is not None:  # exponent not resolved: only O_inf
            ax.axhline(ex[0], color="C0", lw=1, ls=":", label=r"$O_\infty$ only (A, alpha not resolved)")
        inf, a, alpha = data["table2"][name]
        ax.plot(nn, inf + a * nn ** -alpha, "k--", lw=0.8, label="Table 2")
        ax.set_xscale("log")
        ax.set_xlabel(r"$N$")
        ax.set_ylabel(name)
        ax.legend(fontsize=7)
    fig.tight_layout()
    fig.savefig(prefix + "_fig5.png", dpi=110)
    plt.close(fig)


def fig6():
    ex = data["extrapolated"]
    # Needs A and alpha of phi_J and mu_J, and the N -> infinity b and C.
    if not all(k in ex for k in NAMES) or len(ex["phi_J"]) != 3 or len(ex["mu_J"]) != 3:
        return False
    resolved = data.get("extrapolation_resolved", {})
    if not (resolved.get("phi_J", True) and resolved.get("mu_J", True)):
        return False
    fig, axes = plt.subplots(2, 2, figsize=(10, 8))
    cols = colours(plt, len(sizes))
    specs = [("phi", "phi_J", "b_phi", "C_phi", -1.0), ("mu", "mu_J", "b_mu", "C_mu", 1.0)]
    for row, (obs, o_name, b_name, c_name, sign) in enumerate(specs):
        o_inf, a_o, alpha_o = ex[o_name]
        b, c = ex[b_name][0], ex[c_name][0]
        ax_raw, ax_scaled = axes[row]
        for s, col in zip(sizes, cols):
            a = arrays(s)
            env = np.array([st in IN_ENVELOPE for st in s["status"]])
            n = s["N"]
            dist = sign * (a[obs] - o_inf)  # phi_J(inf) - phi, mu - mu_J(inf)
            ok = env & (dist > 0)
            ax_raw.plot(a["J"][ok], dist[ok], "o", ms=4, color=col, label=f"N={n}")
            jj = np.logspace(np.log10(a["J"][env].min()), np.log10(a["J"][env].max()), 80)
            # phi_J(inf) - phi = C J^b - A N^-alpha; mu - mu_J(inf) = C J^b + A N^-alpha
            model = c * jj ** b + sign * a_o * n ** -alpha_o
            good = model > 0
            ax_raw.plot(jj[good], model[good], "-", color=col, lw=0.8)
            xs = a["J"][env] * n ** (alpha_o / b)
            ys = (a[obs][env] - o_inf) / (a_o * n ** -alpha_o)
            ax_scaled.plot(xs, np.abs(ys), "o", ms=4, color=col, label=f"N={n}")
        xx = np.logspace(-4, 6, 200)
        # (O - O_inf)/(A N^-alpha) = 1 + sign (C/A) (J N^(alpha/b))^b   (scaling_phi/mu)
        ax_scaled.plot(xx, np.abs(1 + sign * (c / a_o) * xx ** b), "k-", lw=1)
        ax_raw.set(xscale="log", yscale="log", xlabel=r"$J$",
                   ylabel=r"$\varphi_J(\infty) - \varphi$" if obs == "phi" else r"$\mu - \mu_J(\infty)$")
        ax_scaled.set(xscale="log", yscale="log", xlabel=r"$J N^{\alpha_O / b}$",
                      ylabel=r"$|O - O_J(\infty)| / |A_O N^{-\alpha_O}|$")
        quality = data.get("collapse", {}).get(obs)
        if quality is not None:
            s_value, s_err = quality["S"]
            ax_scaled.set_title(f"collapse quality S = {s_value:.2g} +- {s_err:.2g} "
                                "(S ~ 1: within errors)", fontsize=9)
        ax_raw.legend(fontsize=7)
    fig.tight_layout()
    fig.savefig(prefix + "_fig6.png", dpi=110)
    plt.close(fig)
    return True


def fig7():
    if "viscosity" not in data:
        return
    phi_j, b_phi, c_phi, mu_j, b_mu, c_mu = data["viscosity"]["params"]
    fig, ax = plt.subplots(figsize=(6, 4.5))
    cols = colours(plt, len(sizes))
    for s, col in zip(sizes, cols):
        a = arrays(s)
        env = np.array([st in IN_ENVELOPE for st in s["status"]])
        d = phi_j - a["phi"]
        ok = env & (d > 0)
        ax.plot(d[ok], a["mu"][ok] / a["J"][ok], "o", ms=4, color=col, label=f"N={s['N']}")
    dd = np.logspace(-4, np.log10(0.3), 200)
    r = c_phi / dd
    part1 = mu_j * r ** (1 / b_phi)
    part2 = c_mu * r ** ((1 - b_mu) / b_phi)
    ax.plot(dd, part1 + part2, "k-", label=r"Eq. (eta), " + data["viscosity"]["source"])
    ax.plot(dd, part1, "r--", lw=0.8, label=rf"$\propto \Delta\varphi^{{-{1 / b_phi:.2f}}}$")
    ax.plot(dd, part2, "b--", lw=0.8, label=rf"$\propto \Delta\varphi^{{-{(1 - b_mu) / b_phi:.2f}}}$")
    w0, w1 = data["viscosity"]["window"]
    ax.axvspan(phi_j - w1, phi_j - w0, color="0.9", zorder=0, label="exponent window")
    ax.set(xscale="log", yscale="log", xlabel=r"$\varphi_J - \varphi$", ylabel=r"$\eta / \eta_0$",
           title="hard-sphere envelope points; phi_J and Eq. (eta): " + data["viscosity"]["source"])
    ax.legend(fontsize=7)
    fig.tight_layout()
    fig.savefig(prefix + "_fig7.png", dpi=110)
    plt.close(fig)


fig4()
fig5()
if not fig6():
    print("plot: fig6 skipped (no N -> infinity extrapolation)")
fig7()
