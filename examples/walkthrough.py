#!/usr/bin/python3
# %% [markdown]
# # A walk-through of jamflow in Python
#
# A notebook in percent format: each `# %%` is a cell (Jupyter with jupytext, VS Code and
# Spyder run them one by one); `/usr/bin/python3 examples/walkthrough.py [OUTDIR]` runs them
# all. Systems are tiny (N = 64) so that it ends in seconds.

# %%
import pathlib
import sys

import h5py
import matplotlib
import numpy as np

matplotlib.use("Agg")
import matplotlib.pyplot as plt  # noqa: E402

import jamflow  # noqa: E402

out = pathlib.Path(sys.argv[1] if len(sys.argv) > 1 and not sys.argv[1].startswith("-")
                   else "walkthrough.out")
out.mkdir(parents=True, exist_ok=True)

# %% [markdown]
# ## Scenes
# A scene comes from a TOML file, TOML text or a dict, and is checked as `jamflow run` checks
# it: a bad value is a `jamflow.ConfigError` (a `ValueError`) with the command line's one-line
# message.

# %%
scene = jamflow.Scene({
    "system": {"N": 64, "phi": 0.62},
    "ensemble": {"kind": "constant_volume"},
    "shear": {"rate": 1e-2},
    "integrator": {"kind": "euler", "dt": 0.1},
    "run": {"t_eq": 100.0, "t_av": 200.0, "sample_every": 1.0, "blocks": 4},
})
try:
    scene.set("system.phi", 1.5)
except jamflow.ConfigError as e:
    print("refused:", e)

# %% [markdown]
# ## One state point
# `jamflow.run` runs the scene through the same driver as `jamflow run`; with `out=` it writes
# the same HDF5 file (and the XYZ files beside it).

# %%
result = jamflow.run(scene, out=out / "one.h5", force=True)
print({k: result.summary[k] for k in ("phi", "pressure", "sigma_xy", "eta", "eta_err")})
print("verdicts:", result.summary["verdict_steady"], result.summary["verdict_stable"])

# %% [markdown]
# ## Your own protocol: a shear-rate ramp
# `jamflow.Simulation` advances the scene's system under a Python loop. Here the rate steps
# down and the stress is averaged over the second half of each stage.

# %%
sim = jamflow.Simulation(scene)
ramp = []
for rate in (3e-2, 1e-2, 3e-3):
    sim.shear_rate = rate
    sim.advance(20.0)
    stress = []
    for _ in range(20):
        sim.advance(1.0)
        stress.append(sim.observables["sigma_xy"])
    ramp.append((rate, np.mean(stress)))
    print(f"gdot = {rate:g}: <sigma_xy> = {np.mean(stress):.4g}")
forces = sim.forces  # N x 3 numpy array (a copy)
print("largest force:", np.abs(forces).max())

# %% [markdown]
# ## A small sweep
# A sweep file varies scene keys; `jamflow.sweep` runs its points (two at a time here) and
# returns the collected table as numpy arrays.

# %%
(out / "base.toml").write_text(scene.text)
(out / "phi.toml").write_text("""
[sweep]
scene = "base.toml"
[sweep.grid]
"system.phi" = [0.6, 0.64]
""")
table = jamflow.sweep(out / "phi.toml", out=out / "phi.sweep", jobs=2)
print(dict(zip(table["point"], table["pressure"])))

# %% [markdown]
# ## Reading the files with h5py

# %%
with h5py.File(out / "one.h5") as f:
    t = f["timeseries/time"][()]
    sigma = f["timeseries/sigma_xy"][()]
    t_eq = f["timeseries"].attrs["t_eq"]
    positions = f["final/positions"][()]
print(f"{len(t)} samples, t_eq = {t_eq}, final positions {positions.shape}")

# %% [markdown]
# ## A plot

# %%
fig, (a, b) = plt.subplots(1, 2, figsize=(8, 3.2))
a.plot(t, sigma)
a.axvline(t_eq, color="grey", ls=":")
a.set(xlabel="time", ylabel="sigma_xy", title="one state point")
rates, stresses = zip(*ramp)
b.loglog(rates, stresses, "o-")
b.set(xlabel="shear rate", ylabel="<sigma_xy>", title="ramp")
fig.tight_layout()
fig.savefig(out / "walkthrough.png", dpi=80)
print("wrote", out / "walkthrough.png")
