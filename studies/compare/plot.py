"""Work-precision plots of a comparison (`jamflow compare`) from its table.csv.

usage: plot.py table.csv OUT_DIR
One figure per observable, work_precision_<observable>.png: |difference from the reference|
against CPU seconds per particle and tau_0, log-log, with the difference's error bar. Filled
markers: stable settings; crosses: unstable ones; dashed line: the floor (the reference's own
error), below which differences are not resolved.
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


if __name__ == "__main__":
    main(sys.argv[1], sys.argv[2])
