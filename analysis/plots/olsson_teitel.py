"""Figure 9 of Kawasaki et al., PRE 91, 012203 (2015), from the sidecar of
`jamflow analyze olsson-teitel`: sigma/|dphi|^alpha vs gdot/|dphi|^(alpha+beta)
at the given (--at) and at the optimal parameters (PREFIX_fig9.png). Filled:
phi > phi_J (G+), open: phi < phi_J (G-); colour = curve. With the soft granular rheology
fitted to the same points, also the flow curves sigma(gdot) with the law's lines
(PREFIX_flow.png).
"""
from common import colours, load_matplotlib, read_args

plt, np = load_matplotlib()
data, prefix = read_args()
sets = data["sets"]
cols = colours(plt, len(sets))
fig, axes = plt.subplots(1, 2, figsize=(11, 4.8))
for ax, key, title in ((axes[0], "at", "given"), (axes[1], "best", "optimal")):
    d = data[key]
    x, y = np.asarray(d["x"]), np.asarray(d["y"])
    branch, setix = np.asarray(d["branch"]), np.asarray(d["set"]).astype(int)
    for k in range(len(sets)):
        for b, face in ((1, cols[k]), (-1, "none")):
            sel = (setix == k) & (branch == b)
            if sel.any():
                ax.plot(x[sel], y[sel], "o", ms=3.5, mfc=face, mec=cols[k])
    q = d.get("quality")
    qtext = f"S = {q:.3g}" if q is not None else "S undefined"
    ax.set(xscale="log", yscale="log",
           xlabel=r"$\dot\gamma / |\varphi - \varphi_J|^{\alpha+\beta}$",
           ylabel=r"$\sigma_{xy} / |\varphi - \varphi_J|^{\alpha}$",
           title=f"{title}: $\\varphi_J$={d['phi_J']:.4f}, $\\alpha$={d['alpha']:.3f}, "
                 f"$\\beta$={d['beta']:.3f}, {qtext}")
    ax.title.set_fontsize(9)
fig.suptitle(f"Olsson–Teitel scaling, N = {data['N']} (filled: above $\\varphi_J$, open: below)",
             fontsize=10)
fig.tight_layout()
fig.savefig(prefix + "_fig9.png", dpi=110)
plt.close(fig)

flow = data.get("flow")
if flow is not None and "law_curves" in flow:
    phi, g = np.asarray(flow["phi"]), np.asarray(flow["shear_rate"])
    sig, sige = np.asarray(flow["sigma_xy"]), np.asarray(flow["sigma_xy_err"])
    phis = np.unique(phi)
    cols = colours(plt, len(phis))
    fig, ax = plt.subplots(figsize=(7, 5.5))
    for ph, c in zip(phis, cols):
        sel = phi == ph
        ax.errorbar(g[sel], sig[sel], yerr=sige[sel], fmt="o", ms=4, color=c,
                    label=rf"$\varphi$ = {ph:.4g}")
    for curve in flow["law_curves"]:
        k = int(np.argmin(np.abs(phis - curve["phi"])))
        ax.plot(curve["shear_rate"], curve["sigma"], "-", color=cols[k], lw=1)
    ax.set(xscale="log", yscale="log", xlabel=r"$\dot\gamma$", ylabel=r"$\sigma_{xy}$",
           title=f"Flow curves and the soft granular rheology fitted to them "
                 f"(quality {flow['soft_quality']:.3g})")
    ax.title.set_fontsize(9)
    ax.legend(fontsize=7, ncol=2)
    fig.tight_layout()
    fig.savefig(prefix + "_flow.png", dpi=110)
    plt.close(fig)
