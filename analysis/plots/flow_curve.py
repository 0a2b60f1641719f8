"""Flow curves and viscosity divergence from the sidecar of `jamflow analyze flow-curve`:
sigma_xy(gdot) with the power-law (dashed) and Herschel-Bulkley (solid) fits
(PREFIX_flow.png; open symbols: runs whose verdicts failed, included with --include-failed),
and eta against phi_c - phi with the fitted divergence (PREFIX_eta.png).
"""
from common import colours, load_matplotlib, read_args

plt, np = load_matplotlib()
data, prefix = read_args()
curves = data["curves"]
cols = colours(plt, len(curves))
fig, ax = plt.subplots(figsize=(7, 5.5))
for c, col in zip(curves, cols):
    g, s, e = (np.asarray(c[k]) for k in ("shear_rate", "sigma_xy", "sigma_xy_err"))
    failed = np.asarray(c["failed"]) > 0.5
    ax.errorbar(g[~failed], s[~failed], yerr=e[~failed], fmt="o", ms=4, color=col,
                label=c["curve"])
    if failed.any():
        ax.errorbar(g[failed], s[failed], yerr=e[failed], fmt="o", ms=4, mfc="none",
                    color=col, label=c["curve"] + " (verdicts failed)")
    for key, style in (("power_law", "--"), ("herschel_bulkley", "-")):
        if key in c:
            ax.plot(c[key]["shear_rate"], c[key]["sigma_xy"], style, color=col, lw=1)
ax.set(xscale="log", yscale="log", xlabel=r"$\dot\gamma$", ylabel=r"$\sigma_{xy}$",
       title="Flow curves: power law (dashed), Herschel-Bulkley (solid)")
ax.legend(fontsize=7)
fig.tight_layout()
fig.savefig(prefix + "_flow.png", dpi=110)
plt.close(fig)

divs = data["divergences"]
if divs:
    cols = colours(plt, len(divs))
    fig, ax = plt.subplots(figsize=(7, 5.5))
    for d, col in zip(divs, cols):
        gap = d["phi_c"] - np.asarray(d["phi"])
        ax.errorbar(gap, d["eta"], yerr=d["eta_err"], fmt="o", ms=4, color=col,
                    label=f"{d['group']}: $\\varphi_c$ = {d['phi_c']:.4f}, "
                          f"$\\beta$ = {d['beta']:.3g}")
        x = np.geomspace(gap.min(), gap.max(), 60)
        ax.plot(x, np.exp(d["ln_eta0"]) * x ** (-d["beta"]), "-", color=col, lw=1)
    ax.set(xscale="log", yscale="log", xlabel=r"$\varphi_c - \varphi$",
           ylabel=r"$\eta = \sigma_{xy}/\dot\gamma$", title="Viscosity divergence")
    ax.legend(fontsize=7)
    fig.tight_layout()
    fig.savefig(prefix + "_eta.png", dpi=110)
    plt.close(fig)
