#!/usr/bin/python3
"""jamflow from Python in one page: one state point, a small sweep, the files read back with
h5py, and a flow curve plotted.

    PYTHONPATH=build /usr/bin/python3 examples/quickstart.py [OUTDIR]

Everything goes to OUTDIR (default: quickstart.out). The systems are tiny (N = 64) so that the
script finishes in seconds; for real state points take N >= 1000 and longer windows.
"""
import pathlib
import sys

import h5py
import matplotlib

matplotlib.use("Agg")
import matplotlib.pyplot as plt  # noqa: E402

import jamflow  # noqa: E402

out = pathlib.Path(sys.argv[1] if len(sys.argv) > 1 else "quickstart.out")
out.mkdir(parents=True, exist_ok=True)

# 1. One state point: the default scene, made small and short.
scene = jamflow.Scene()
scene.update({"system.N": 64, "shear.rate": 1e-2, "run.t_eq": 100.0, "run.t_av": 200.0,
              "run.blocks": 4})
result = jamflow.run(scene, out=out / "point.h5", force=True)
s = result.summary
print(f"eta = {s['eta']:.4g} +- {s['eta_err']:.2g}, phi = {s['phi']:.4f}, "
      f"steady: {s['verdict_steady']}")

# 2. A small sweep over the shear rate (each point runs as `jamflow run`; reruns keep
#    finished points).
sweep_file = out / "rates.toml"
sweep_file.write_text("""
[sweep]
scene = "base.toml"
[sweep.grid]
"shear.rate" = [3e-2, 1e-2, 3e-3]
""")
(out / "base.toml").write_text(scene.text)
table = jamflow.sweep(sweep_file, out=out / "rates.sweep", jobs=2)
for point, rate, eta in zip(table["point"], table["shear_rate"], table["eta"]):
    print(f"{point}: shear_rate = {rate:g}, eta = {eta:.4g}")

# 3. The run file with h5py: the same numbers as the result in memory.
with h5py.File(out / "point.h5") as f:
    sigma = f["timeseries/sigma_xy"][()]
    assert (sigma == result.timeseries["sigma_xy"]).all()
    print("file summary eta =", f["summary"].attrs["eta"])

# 4. A plot: the flow curve of the sweep and the stress of the single run.
fig, (left, right) = plt.subplots(1, 2, figsize=(8, 3.2))
left.errorbar(table["shear_rate"], table["eta"], yerr=table["eta_err"], marker="o")
left.set(xscale="log", yscale="log", xlabel="shear rate", ylabel="eta")
right.plot(result.timeseries["time"], result.timeseries["sigma_xy"])
right.set(xlabel="time", ylabel="sigma_xy")
fig.tight_layout()
fig.savefig(out / "quickstart.png", dpi=80)
print("wrote", out / "quickstart.png")
