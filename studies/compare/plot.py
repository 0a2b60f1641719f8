"""Work-precision plots of a comparison (`jamflow compare`) from its table.csv.

usage: plot.py table.csv OUT_DIR [compare.h5]
One figure per observable, work_precision_<observable>.png: |difference from the reference|
against CPU seconds per particle and tau_0, log-log, with the difference's error bar. Filled
markers: stable settings; crosses: unstable ones; dashed line: the floor (the reference's own
error), below which differences are not resolved. With compare.h5, also timeseries.png: each
observable against time, every replica of every setting (a colour per setting), the averaging
window after the dotted line of each setting's t_eq.
"""
import csv
import sys

import matplotlib

matplotlib.use("Agg")
import matplotlib.pyplot as plt  # noqa: E402
import numpy as np  # noqa: E402


def number(text):
    try:
        return float(text)
    except ValueError:
        return float("nan")


def main(table, out_dir):
    with open(table, newline="") as f:
        rows = list(csv.DictReader(f))
    observables = [c[: -len("_diff_source")] for c in rows[0] if c.endswith("_diff_source")]
    for obs in observables:
        fig, ax = plt.subplots(figsize=(6, 4.5))
        floor = float("nan")
        for r in rows:
            if int(r["reference"]):
                floor = number(r[obs + "_floor"])
                continue
            cost = number(r["cpu_per_particle_tau"])
            diff = abs(number(r[obs + "_diff"]))
            err = number(r[obs + "_diff_err"])
            # A difference of exactly 0 (the same trajectory) has no place on a log axis.
            if not (np.isfinite(cost) and cost > 0 and np.isfinite(diff) and diff > 0):
                continue
            stable = int(r["stable"])
            shown = diff
            ax.errorbar(cost, shown, yerr=[[min(err, 0.999 * shown) if np.isfinite(err) else 0],
                                           [err if np.isfinite(err) else 0]],
                        marker="o" if stable else "x", ms=7, capsize=3, linestyle="none",
                        label=r["setting"] + ("" if stable else " (unstable)"))
        if np.isfinite(floor) and floor > 0:
            ax.axhline(floor, linestyle="--", color="grey", label="floor (reference error)")
        ax.set_xscale("log")
        ax.set_yscale("log")
        ax.set_xlabel("CPU s per particle and tau_0")
        ax.set_ylabel("|%s - reference|" % obs)
        ax.set_title("work-precision: %s" % obs)
        ax.legend(fontsize=7)
        fig.tight_layout()
        fig.savefig("%s/work_precision_%s.png" % (out_dir, obs), dpi=120)
        plt.close(fig)


def timeseries(h5_path, out_dir):
    import h5py
    with h5py.File(h5_path, "r") as f:
        settings = sorted(f["settings"].items(), key=lambda kv: int(kv[1].attrs["index"]))
        observables = [o for o in settings[0][1].keys() if o != "replicas"]
        fig, axes = plt.subplots(len(observables), 1, figsize=(7.5, 2.4 * len(observables) + 0.8),
                                 sharex=True, squeeze=False)
        settled = {obs: [] for obs in observables}  # after the first 2% of each run: the range
        for i, (label, g) in enumerate(settings):
            colour = "C%d" % (i % 10)
            reps = g["replicas"] if "replicas" in g else {}
            for k, key in enumerate(sorted(reps.keys(), key=int)):
                r = reps[key]
                t = r["time"][()]
                for ax, obs in zip(axes[:, 0], observables):
                    y = r[obs][()]
                    ax.plot(t, y, color=colour, lw=0.6, alpha=0.8,
                            label=label if k == 0 else None)
                    if len(t):
                        settled[obs].extend(y[t > 0.02 * t[-1]])
                if k == 0:
                    for ax in axes[:, 0]:
                        ax.axvline(float(r.attrs["t_eq"]), color=colour, ls=":", lw=0.8)
        for ax, obs in zip(axes[:, 0], observables):
            ax.set_ylabel(obs)
            y = np.asarray(settled[obs], dtype=float)
            y = y[np.isfinite(y)]
            if y.size:
                lo, hi = y.min(), y.max()
                pad = 0.1 * (hi - lo) if hi > lo else max(abs(hi), 1e-300) * 1e-3
                ax.set_ylim(lo - pad, hi + pad)
        axes[0, 0].legend(fontsize=7)
        axes[-1, 0].set_xlabel("time since the start of the run (tau_0)")
        fig.tight_layout()
        fig.savefig("%s/timeseries.png" % out_dir, dpi=120)
        plt.close(fig)


if __name__ == "__main__":
    main(sys.argv[1], sys.argv[2])
    if len(sys.argv) > 3:
        timeseries(sys.argv[3], sys.argv[2])
