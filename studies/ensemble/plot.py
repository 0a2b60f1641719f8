"""Ensemble comparison plot (the seed's Fig. 1): sigma_xy(t) and phi(t) at constant pressure
and at constant volume, every replica, against the accumulated strain gdot t.

usage: plot.py ensemble.h5 timeseries.png
"""
import sys

import h5py
import matplotlib
import numpy as np

matplotlib.use("Agg")
import matplotlib.pyplot as plt  # noqa: E402


def main(h5_path, png_path):
    with h5py.File(h5_path, "r") as f:
        gdot = float(f.attrs["shear_rate"])
        title = "N = %d, gdot = %.3g, P = %.3g (preset %s)" % (
            int(f.attrs["N"]), gdot, float(f.attrs["imposed_pressure"]), f.attrs["preset"])
        fig, (ax_s, ax_p) = plt.subplots(2, 1, figsize=(7.5, 6.5), sharex=True)
        styles = {
            "constant_pressure": dict(color="tab:green", marker="o", label="constant pressure"),
            "constant_volume": dict(color="tab:red", marker="s", label="constant volume"),
        }
        settled = []  # sigma_xy after the first 2% of each run, for the axis range
        for name, st in styles.items():
            reps = f[name]["replicas"]
            for k, key in enumerate(sorted(reps.keys(), key=int)):
                ts = reps[key]["timeseries"]
                strain = ts["time"][:] * gdot
                t_eq = float(ts.attrs["t_eq"]) * gdot
                alpha = 0.9 if k == 0 else 0.35
                every = max(1, len(strain) // 200)
                kw = dict(color=st["color"], alpha=alpha, lw=0.8, marker=st["marker"],
                          ms=2.5, markevery=every)
                lab = st["label"] if k == 0 else None
                sigma = ts["sigma_xy"][:]
                settled.append(sigma[len(sigma) // 50:])
                ax_s.plot(strain, sigma, label=lab, **kw)
                ax_p.plot(strain, ts["phi"][:], label=lab, **kw)
            for ax in (ax_s, ax_p):
                ax.axvline(t_eq, color=st["color"], ls="--", lw=0.8)
        # The first samples (relaxed start, dilated start) are far off the steady state: range
        # the stress axis on the rest so that the fluctuations the comparison is about show.
        lo, hi = np.percentile(np.concatenate(settled), [0.2, 99.8])
        pad = 0.15 * (hi - lo)
        ax_s.set_ylim(lo - pad, hi + pad)
        ax_s.set_ylabel(r"$\hat\sigma_{xy}$  [$\epsilon/a^3$]")
        ax_p.set_ylabel(r"$\hat\varphi$")
        ax_p.set_xlabel(r"strain $\dot\gamma t$ of each run (dashed: end of its equilibration)")
        ax_s.legend(loc="best", fontsize=8)
        ax_s.set_title(title, fontsize=9)
        tab = f["table"].attrs
        ax_p.text(0.02, 0.04,
                  "block std of eta NV/NP = %.3g (seed ~5); std of phi over runs (NP) = %.2g"
                  % (tab["eta_block_std_ratio_nv_over_np"], tab["phi_spread_np"]),
                  transform=ax_p.transAxes, fontsize=8)
        fig.tight_layout()
        fig.savefig(png_path, dpi=120)


if __name__ == "__main__":
    if len(sys.argv) != 3:
        sys.exit(__doc__)
    main(sys.argv[1], sys.argv[2])
