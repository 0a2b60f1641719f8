"""Figure 9 of Kawasaki et al., PRE 91, 012203 (2015), from the sidecar of
`jamflow analyze olsson-teitel`: sigma/|dphi|^alpha vs gdot/|dphi|^(alpha+beta)
at the given (--at) and at the optimal parameters (PREFIX_fig9.png). Filled:
phi > phi_J (G+), open: phi < phi_J (G-); colour = curve.
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
