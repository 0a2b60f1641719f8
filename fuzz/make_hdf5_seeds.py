#!/usr/bin/python3
"""Writes the HDF5 seed corpus of fuzz_hdf5 (fuzz/corpus/hdf5/): small run files with the
root and /summary attributes `jamflow analyze` reads (as `jamflow run` writes them), and a
few malformed variants. Run: /usr/bin/python3 fuzz/make_hdf5_seeds.py"""
import os
import h5py
import numpy as np

out = os.path.join(os.path.dirname(os.path.abspath(__file__)), "corpus", "hdf5")
os.makedirs(out, exist_ok=True)

NUMBERS = ["sigma_xy", "sigma_xy_err", "pressure", "pressure_err", "phi", "phi_err", "eta",
           "eta_err", "mu", "mu_err", "J", "energy_balance", "shear_rate", "alpha"]


def run_file(name, ensemble="constant_volume", tweak=None, vlen=True):
    with h5py.File(os.path.join(out, name), "w") as f:
        str_type = h5py.string_dtype() if vlen else None
        for k, v in [("scene", "[system]\nN = 8\n"), ("version", "0.1.0"),
                     ("git_commit", "abc"), ("created", "2026-01-01T00:00:00Z")]:
            if vlen:
                f.attrs.create(k, v, dtype=str_type)
            else:
                f.attrs.create(k, np.bytes_(v))
        s = f.create_group("summary")
        if vlen:
            s.attrs.create("ensemble", ensemble, dtype=str_type)
        else:
            s.attrs.create("ensemble", np.bytes_(ensemble))
        s.attrs.create("N", np.int64(8))
        for i, k in enumerate(NUMBERS):
            s.attrs.create(k, np.float64(0.1 + 0.01 * i))
        if ensemble == "constant_pressure":
            s.attrs.create("imposed_pressure", np.float64(1e-3))
        if tweak:
            tweak(f, s)


run_file("constant_volume.h5")
run_file("constant_pressure_fixed_strings.h5", "constant_pressure", vlen=False)
run_file("missing_phi.h5", tweak=lambda f, s: s.attrs.__delitem__("phi"))
run_file("int_as_float.h5", tweak=lambda f, s: s.attrs.create("N", np.float64(8.0)))
run_file("vector_number.h5", tweak=lambda f, s: s.attrs.create("mu", np.arange(3.0)))
run_file("string_array.h5", tweak=lambda f, s: s.attrs.create(
    "ensemble", ["constant_volume", "constant_pressure"], dtype=h5py.string_dtype()))
run_file("fixed_string_array.h5", tweak=lambda f, s: s.attrs.create(
    "ensemble", np.array([b"constant_volume", b"constant_volume"])))
with h5py.File(os.path.join(out, "no_summary.h5"), "w") as f:
    f.create_dataset("summary", data=np.arange(4))
