"""jamflow's files in third-party readers (Debian's python3-ase and python3-mdanalysis): the
extended XYZ a run writes opens as it is, with the run's positions and cell."""
import warnings


import numpy as np
import pytest

import jamflow

SCENE = {
    "system": {"N": 40, "phi": 0.6, "seed": 2},
    "ensemble": {"kind": "constant_volume"},
    "shear": {"rate": 1e-2},
    "integrator": {"kind": "euler", "dt": 0.1},
    "run": {"t_eq": 0.0, "t_av": 20.0, "sample_every": 1.0, "blocks": 4},
    "output": {"trajectory_every": 5.0},
}


@pytest.fixture(scope="module")
def run_files(tmp_path_factory):
    folder = tmp_path_factory.mktemp("files")
    result = jamflow.run(SCENE, out=folder / "r.h5")
    return folder, result


def test_ase_reads_the_final_configuration_and_the_trajectory(run_files):
    ase_io = pytest.importorskip("ase.io")
    folder, result = run_files
    atoms = ase_io.read(folder / "r.final.xyz")
    assert len(atoms) == 40
    assert set(atoms.get_chemical_symbols()) <= {"H", "He"}
    small = np.array(atoms.get_chemical_symbols()) == "H"
    assert np.array_equal(small, result.final["species"] == 0)
    assert np.allclose(atoms.get_positions(), result.final["positions"], rtol=0, atol=1e-12)
    assert np.allclose(np.asarray(atoms.get_cell()), result.final["cell"], rtol=0, atol=1e-12)
    assert np.allclose(atoms.arrays["radius"], result.final["diameters"] / 2)
    assert all(atoms.get_pbc())
    frames = ase_io.read(folder / "r.traj.xyz", index=":")
    assert len(frames) == 5  # t = 0, 5, 10, 15, 20
    assert np.allclose(frames[-1].get_positions(), result.final["positions"], atol=1e-12)


def test_mdanalysis_reads_the_trajectory(run_files):
    mda = pytest.importorskip("MDAnalysis")
    folder, result = run_files
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        u = mda.Universe(str(folder / "r.traj.xyz"), format="XYZ")
    assert len(u.atoms) == 40
    assert len(u.trajectory) == 5
    assert set(u.atoms.names) <= {"H", "He"}
    u.trajectory[-1]
    assert np.allclose(u.atoms.positions, result.final["positions"], atol=1e-4)

