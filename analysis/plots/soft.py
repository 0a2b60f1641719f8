"""Figure 8 of Kawasaki et al., PRE 91, 012203 (2015), from the sidecar of
`jamflow analyze soft`, one file per N (PREFIX_fig8_N<N>.png):
  (a) phi_J(P) - phi vs J, line C_phi J^b_phi          (phi_scale)
  (b) mu - mu_J(P) vs J, line C_mu J^b_mu              (mu_scale)
  (c) phi_J(P) vs P, line phi_J(0) + c_phi P^x          (phi_P)
  (d) mu_J(P) vs P, line mu_J(0) - c_mu P^y             (mu_P)
"""
from common import colours, load_matplotlib, read_args

plt, np = load_matplotlib()
data, prefix = read_args()

for s in data["sizes"]:
    P = np.asarray(s["P"])
    J = np.asarray(s["J"])
    phi = np.asarray(s["phi"])
    mu = np.asarray(s["mu"])
    c_phi, b_phi, c_mu, b_mu = s["shape"]
    pressures = np.asarray(s["pressures"])
    phi_j = dict(zip(pressures, s["phi_J"]))
    mu_j = dict(zip(pressures, s["mu_J"]))
    cols = colours(plt, len(pressures))
    fig, axes = plt.subplots(2, 2, figsize=(10, 8))
    jj = np.logspace(np.log10(J.min()), np.log10(J.max()), 100)
    for p, c in zip(pressures, cols):
        sel = P == p
        d_phi = phi_j[p] - phi[sel]
        d_mu = mu[sel] - mu_j[p]
        ok = d_phi > 0
        axes[0][0].errorbar(J[sel][ok], d_phi[ok], yerr=np.asarray(s["phi_err"])[sel][ok], fmt="o",
                            ms=4, color=c, label=f"P={p:g}")
        ok = d_mu > 0
        axes[0][1].errorbar(J[sel][ok], d_mu[ok], yerr=np.asarray(s["mu_err"])[sel][ok], fmt="o",
                            ms=4, color=c, label=f"P={p:g}")
    axes[0][0].plot(jj, c_phi * jj ** b_phi, "k-")
    axes[0][1].plot(jj, c_mu * jj ** b_mu, "k-")
    axes[0][0].set(xscale="log", yscale="log", xlabel=r"$J$", ylabel=r"$\varphi_J(P) - \varphi$",
                   title="(a)")
    axes[0][1].set(xscale="log", yscale="log", xlabel=r"$J$", ylabel=r"$\mu - \mu_J(P)$",
                   title="(b)")
    axes[0][0].legend(fontsize=7)
    pp = np.logspace(np.log10(pressures.min()) - 0.3, np.log10(pressures.max()) + 0.3, 100)
    a0, c, x = s["phi_fit"]
    axes[1][0].errorbar(pressures, s["phi_J"], yerr=s["phi_J_err"], fmt="o", color="C0")
    axes[1][0].plot(pp, a0 + c * pp ** x, "k-", label=rf"$x = {x:.3f}$")
    axes[1][0].set(xscale="log", xlabel=r"$P$", ylabel=r"$\varphi_J(P)$", title="(c)")
    a0, c, y = s["mu_fit"]
    axes[1][1].errorbar(pressures, s["mu_J"], yerr=s["mu_J_err"], fmt="o", color="C0")
    axes[1][1].plot(pp, a0 - c * pp ** y, "k-", label=rf"$y = {y:.3f}$")
    axes[1][1].set(xscale="log", xlabel=r"$P$", ylabel=r"$\mu_J(P)$", title="(d)")
    for ax in axes[1]:
        ax.legend(fontsize=8)
    fig.suptitle(f"Soft granular rheology, N = {s['N']}")
    fig.tight_layout()
    fig.savefig(f"{prefix}_fig8_N{s['N']}.png", dpi=110)
    plt.close(fig)
