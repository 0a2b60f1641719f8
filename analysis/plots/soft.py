"""Figure 8 of Kawasaki et al., PRE 91, 012203 (2015), from the sidecar of
`jamflow analyze soft`, one file per N (PREFIX_fig8_N<N>.png):
  (a) phi_J(P) - phi vs J, line C_phi J^b_phi          (phi_scale)
  (b) mu - mu_J(P) vs J, line C_mu J^b_mu              (mu_scale)
  (c) phi_J(P) vs P, line phi_J(0) + c_phi P^x          (phi_P)
  (d) mu_J(P) vs P, line mu_J(0) - c_mu P^y             (mu_P)
and the same four panels for the joint fit over every pressure and J (PREFIX_fig8_joint_N<N>.png:
phi_J(P), mu_J(P) from the joint law; the points in (c), (d) are each pressure's mean of
phi + C_phi J^b_phi and mu - C_mu J^b_mu), and the yield stress against phi - phi_J0
(PREFIX_yield_N<N>.png) when constant-volume data were given.
"""
from common import colours, load_matplotlib, read_args

plt, np = load_matplotlib()
data, prefix = read_args()



def joint_figures(s):
    law = s["joint"]["law"]
    phi_j0, c_phi, x, C_phi, b_phi, mu_j0, c_mu, y, C_mu, b_mu = law
    P, J = np.asarray(s["imposed_pressure"]), np.asarray(s["J"])
    phi, mu = np.asarray(s["phi"]), np.asarray(s["mu"])
    phi_err, mu_err = np.asarray(s["phi_err"]), np.asarray(s["mu_err"])
    pressures = np.unique(P)
    cols = colours(plt, len(pressures))
    fig, axes = plt.subplots(2, 2, figsize=(10, 8))
    jj = np.logspace(np.log10(J.min()), np.log10(J.max()), 100)
    for p, c in zip(pressures, cols):
        sel = P == p
        d_phi = phi_j0 + c_phi * p ** x - phi[sel]
        d_mu = mu[sel] - (mu_j0 - c_mu * p ** y)
        ok = d_phi > 0
        axes[0][0].errorbar(J[sel][ok], d_phi[ok], yerr=phi_err[sel][ok], fmt="o", ms=4, color=c,
                            label=f"P={p:g}")
        ok = d_mu > 0
        axes[0][1].errorbar(J[sel][ok], d_mu[ok], yerr=mu_err[sel][ok], fmt="o", ms=4, color=c)
        w = 1 / phi_err[sel] ** 2
        pj = np.sum(w * (phi[sel] + C_phi * J[sel] ** b_phi)) / np.sum(w)
        axes[1][0].errorbar([p], [pj], yerr=[1 / np.sqrt(np.sum(w))], fmt="o", color=c)
        w = 1 / mu_err[sel] ** 2
        mj = np.sum(w * (mu[sel] - C_mu * J[sel] ** b_mu)) / np.sum(w)
        axes[1][1].errorbar([p], [mj], yerr=[1 / np.sqrt(np.sum(w))], fmt="o", color=c)
    err = s["joint"]["law_err"]
    # Beside each fitted value its bootstrap error and the paper's (Table 2 at N -> infinity).
    axes[0][0].plot(jj, C_phi * jj ** b_phi, "k-",
                    label=rf"$b_\varphi = {b_phi:.3f} \pm {err[4]:.3f}$ (paper 0.391), "
                          rf"$C_\varphi = {C_phi:.4f} \pm {err[3]:.4f}$ (0.0683; paper: N$\to\infty$)")
    axes[0][1].plot(jj, C_mu * jj ** b_mu, "k-",
                    label=rf"$b_\mu = {b_mu:.3f} \pm {err[9]:.3f}$ (paper 0.346), "
                          rf"$C_\mu = {C_mu:.3f} \pm {err[8]:.3f}$ (0.347; paper: N$\to\infty$)")
    axes[0][0].set(xscale="log", yscale="log", xlabel=r"$J$", ylabel=r"$\varphi_J(P) - \varphi$",
                   title="(a)")
    axes[0][1].set(xscale="log", yscale="log", xlabel=r"$J$", ylabel=r"$\mu - \mu_J(P)$",
                   title="(b)")
    pp = np.logspace(np.log10(pressures.min()) - 0.3, np.log10(pressures.max()) + 0.3, 100)
    axes[1][0].plot(pp, phi_j0 + c_phi * pp ** x, "k-",
                    label=rf"$x = {x:.3f} \pm {err[2]:.3f}$ (paper 0.75), "
                          rf"$\varphi_J(0) = {phi_j0:.4f} \pm {err[0]:.4f}$ (0.6474 at N$\to\infty$)")
    axes[1][1].plot(pp, mu_j0 - c_mu * pp ** y, "k-",
                    label=rf"$y = {y:.3f} \pm {err[7]:.3f}$ (paper 0.56), "
                          rf"$\mu_J(0) = {mu_j0:.3f} \pm {err[5]:.3f}$ (0.108 at N$\to\infty$)")
    axes[1][0].set(xscale="log", xlabel=r"$P$", ylabel=r"$\varphi_J(P)$", title="(c)")
    axes[1][1].set(xscale="log", xlabel=r"$P$", ylabel=r"$\mu_J(P)$", title="(d)")
    for ax in list(axes[0]) + list(axes[1]):
        ax.legend(fontsize=7)
    fig.suptitle(f"Soft granular rheology, joint fit over every P and J, N = {s['N']}")
    fig.tight_layout()
    fig.savefig(f"{prefix}_fig8_joint_N{s['N']}.png", dpi=110)
    plt.close(fig)
    yd = s["joint"].get("yield")
    if yd is None:
        return
    fig, ax = plt.subplots(figsize=(6.5, 5))
    d = np.asarray(s["joint"]["yield_curve_dphi"])
    sy = np.asarray(s["joint"]["yield_curve_sigma"])
    se = np.asarray(s["joint"]["yield_curve_sigma_err"])
    ok = sy > 0
    ax.plot(d[ok], sy[ok], "k-",
            label=rf"law $\sigma_Y$, $\alpha = 1/x = {1 / x:.2f} \pm {err[2] / x ** 2:.2f}$ (paper 1.33)")
    band = ok & (se < sy)  # a band wider than the value has no lower edge on a log axis
    ax.fill_between(d[band], sy[band] - se[band], sy[band] + se[band], color="0.8",
                    label="bootstrap band (where narrower than the value)")
    ymin, ymax = sy[ok].min() if ok.any() else 1e-6, sy[ok].max() if ok.any() else 1.0
    phis = np.asarray(yd["phi"])
    if len(phis):
        g = np.asarray(yd["shear_rate"])
        sig, sige = np.asarray(yd["sigma_xy"]), np.asarray(yd["sigma_xy_err"])
        rates = np.unique(g)
        rc = colours(plt, len(rates))
        for r, c in zip(rates, rc):
            sel = g == r
            ax.errorbar(phis[sel] - phi_j0, sig[sel], yerr=sige[sel], fmt="o", color=c,
                        label=rf"measured, $\dot\gamma$ = {r:.2g}")
            ax.plot(phis[sel] - phi_j0, np.asarray(yd["sigma_law"])[sel], "x", color=c)
        ymin, ymax = min(ymin, sig.min()), max(ymax, sig.max())
    ax.set_ylim(ymin / 3, ymax * 3)
    ax.set(xscale="log", yscale="log", xlabel=r"$\varphi - \varphi_J(0)$",
           ylabel=r"$\sigma_{xy}$, $\sigma_Y$",
           title=f"Yield stress, N = {s['N']} (x: the law at the measured rate)")
    ax.legend(fontsize=7)
    fig.tight_layout()
    fig.savefig(f"{prefix}_yield_N{s['N']}.png", dpi=110)
    plt.close(fig)


for s in data["sizes"]:
    if "joint" in s:
        joint_figures(s)
    if "shape" not in s:
        continue  # the per-pressure collapse was not done
    P = np.asarray(s["imposed_pressure"])
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
