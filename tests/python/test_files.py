"""jamflow's files in third-party readers (Debian's python3-ase and python3-mdanalysis): the
extended XYZ and H5MD files a run writes open as they are, with the run's positions and cell;
an interrupted and resumed run writes the same H5MD trajectory as an uninterrupted one; the run
file's units and a collected HDF5 table read with h5py as the guide says."""
import os
import signal
import subprocess
import sys
import threading
import time
import warnings

import h5py

import numpy as np
import pytest

import jamflow

SCENE = {
    "system": {"N": 40, "phi": 0.6, "seed": 2},
    "ensemble": {"kind": "constant_volume"},
    "shear": {"rate": 1e-2},
    "integrator": {"kind": "euler", "dt": 0.1},
    "run": {"t_eq": 0.0, "t_av": 20.0, "sample_every": 1.0, "blocks": 4},
    "output": {"trajectory_every": 5.0, "trajectory_format": "both"},
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
    # No box from XYZ (its reader ignores the Lattice): why the guide sends MDAnalysis users to
    # the H5MD file.
    assert u.dimensions is None


def test_mdanalysis_gets_the_box_from_the_h5md_file_as_the_guide_says(run_files):
    # docs/guide/files.md, "MDAnalysis and the box": the final XYZ as topology (names), the H5MD
    # file as trajectory (positions and box).
    mda = pytest.importorskip("MDAnalysis")
    folder, result = run_files
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        u = mda.Universe(str(folder / "r.final.xyz"), str(folder / "r.traj.h5md"),
                         convert_units=False)
    assert len(u.trajectory) == 5 and set(u.atoms.names) <= {"H", "He"}
    u.trajectory[-1]
    cell = result.final["cell"]
    lengths = np.linalg.norm(cell, axis=1)
    assert u.dimensions is not None
    assert np.allclose(u.dimensions[:3], lengths, rtol=1e-5)
    # gamma, the angle between a and b: the Lees-Edwards tilt.
    gamma = np.degrees(np.arccos(cell[0] @ cell[1] / (lengths[0] * lengths[1])))
    assert u.dimensions[5] == pytest.approx(gamma, abs=1e-3) and gamma < 90.0
    assert np.allclose(u.atoms.positions, result.final["positions"], atol=1e-4)


def test_h5md_layout(run_files):
    folder, result = run_files
    with h5py.File(folder / "r.traj.h5md") as f:
        assert list(f["h5md"].attrs["version"]) == [1, 1]
        assert "name" in f["h5md/author"].attrs and "name" in f["h5md/creator"].attrs
        box = f["particles/all/box"]
        assert box.attrs["dimension"] == 3
        assert [b.decode() if isinstance(b, bytes) else b for b in box.attrs["boundary"]] == \
            ["periodic"] * 3
        position = f["particles/all/position"]
        assert position["value"].shape == (5, 40, 3)
        assert list(position["step"][()]) == [0, 5, 10, 15, 20]
        assert list(position["time"][()]) == [0.0, 5.0, 10.0, 15.0, 20.0]
        assert np.array_equal(position["value"][-1], result.final["positions"])
        assert np.array_equal(box["edges/value"][-1], result.final["cell"])
        assert np.array_equal(f["particles/all/species"][()], result.final["species"])
        assert np.array_equal(f["particles/all/diameter"][()], result.final["diameters"])
        assert f["observables/strain/value"][-1] == result.final["strain"]
        # How the file was made: the run's scene and the replica's seed in /parameters.
        assert f["parameters"].attrs["scene"] == result.scene
        assert f["parameters"].attrs["seed"] == result.seed == 2
    # The XYZ trajectory holds the same frames.
    ase_io = pytest.importorskip("ase.io")
    frames = ase_io.read(folder / "r.traj.xyz", index=":")
    with h5py.File(folder / "r.traj.h5md") as f:
        for k, atoms in enumerate(frames):
            assert np.allclose(atoms.get_positions(),
                               f["particles/all/position/value"][k], rtol=0, atol=1e-12)


def test_mdanalysis_reads_the_h5md_trajectory(run_files):
    mda = pytest.importorskip("MDAnalysis")
    folder, result = run_files
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        u = mda.Universe.empty(40, trajectory=True)
        u.load_new(str(folder / "r.traj.h5md"), format="H5MD", convert_units=False)
    assert len(u.trajectory) == 5
    u.trajectory[-1]
    assert u.trajectory.ts.time == 20.0
    assert np.allclose(u.atoms.positions, result.final["positions"], atol=1e-4)
    # MDAnalysis box: lengths and angles of the sheared cell.
    cell = result.final["cell"]
    lengths = np.linalg.norm(cell, axis=1)
    assert np.allclose(u.trajectory.ts.dimensions[:3], lengths, rtol=1e-5)


def test_a_resumed_run_continues_the_h5md_trajectory(tmp_path):
    scene = jamflow.Scene(SCENE)
    scene.update({"system.N": 1000, "run.t_av": 4000.0, "output.trajectory_every": 100.0,
                  "output.trajectory_format": "h5md"})
    whole = jamflow.run(scene, out=tmp_path / "whole.h5")

    def interrupt():  # once the run has started (its first checkpoint), and a little later
        while not (tmp_path / "cut.h5.part").exists():
            time.sleep(0.01)
        time.sleep(0.2)
        os.kill(os.getpid(), signal.SIGINT)

    timer = threading.Thread(target=interrupt)
    timer.start()
    with pytest.raises(KeyboardInterrupt):
        jamflow.run(scene, out=tmp_path / "cut.h5")
    timer.join()
    assert (tmp_path / "cut.traj.h5md.part").exists()
    bin_ = os.environ.get("JAMFLOW_BIN", "jamflow")
    out = subprocess.run([bin_, "run", "--resume", str(tmp_path / "cut.h5.part"), "-q"],
                         capture_output=True, text=True, cwd=tmp_path)
    assert out.returncode == 0, out.stderr
    with h5py.File(tmp_path / "whole.traj.h5md") as a, h5py.File(tmp_path / "cut.traj.h5md") as b:
        for name in ("particles/all/position", "particles/all/box/edges", "observables/strain"):
            for part in ("step", "time", "value"):
                x, y = a[name][part][()], b[name][part][()]
                assert x.shape == y.shape and x.tobytes() == y.tobytes(), name + "/" + part
        with h5py.File(tmp_path / "cut.h5") as run_file:
            assert b["parameters"].attrs["scene"] == run_file.attrs["scene"]
    assert whole.timeseries["time"][-1] == 4000.0


def test_an_extended_run_continues_its_trajectories(tmp_path):
    longer = jamflow.Scene(SCENE)
    longer.set("run.t_av", 40.0)
    jamflow.run(longer, out=tmp_path / "long.h5")
    jamflow.run(SCENE, out=tmp_path / "ext.h5")
    bin_ = os.environ.get("JAMFLOW_BIN", "jamflow")
    out = subprocess.run([bin_, "run", "--extend", str(tmp_path / "ext.h5"), "--set",
                          "run.t_av=40", "-q"], capture_output=True, text=True, cwd=tmp_path)
    assert out.returncode == 0, out.stderr
    assert (tmp_path / "ext.traj.xyz").read_text() == (tmp_path / "long.traj.xyz").read_text()
    with h5py.File(tmp_path / "long.traj.h5md") as a, h5py.File(tmp_path / "ext.traj.h5md") as b:
        assert b["particles/all/position/value"].shape[0] == 9  # t = 0, 5, ..., 40
        for name in ("particles/all/position", "particles/all/box/edges", "observables/strain"):
            for part in ("step", "time", "value"):
                x, y = a[name][part][()], b[name][part][()]
                assert x.shape == y.shape and x.tobytes() == y.tobytes(), name + "/" + part


def test_run_file_units_read_as_the_guide_says(run_files):
    # docs/guide/files.md, "Units": a "unit" on every dataset, /summary/units for the numbers.
    folder, _ = run_files
    with h5py.File(folder / "r.h5") as f:
        assert f["timeseries/time"].attrs["unit"] == "tau_0"
        assert f["summary/units"].attrs["eta"] == "xi_s/a"
        datasets = []
        f.visititems(lambda name, obj: datasets.append(obj)
                     if isinstance(obj, h5py.Dataset) else None)
        assert datasets and all(d.attrs["unit"] for d in datasets)
        summary = f["summary"].attrs
        numbers = {k for k, v in summary.items() if not isinstance(v, str)}
        assert numbers and numbers == set(f["summary/units"].attrs)


def guide_table_snippet():
    """The Python block of docs/guide/sweeps.md that reads TABLE.h5 with pandas."""
    guide = os.path.join(os.path.dirname(__file__), "..", "..", "docs", "guide", "sweeps.md")
    text = open(guide, encoding="utf-8").read()
    blocks = [b.split("```", 1)[0] for b in text.split("```python\n")[1:]]
    [snippet] = [b for b in blocks if 'h5py.File("table.h5")' in b]
    return snippet


COLLECT_SWEEP = """
[sweep]
replicas = 1
[sweep.grid]
"shear.rate" = [1e-1, 1e-2]
[sweep.zip]
"integrator.kind" = ["euler", "respa"]
[scene.system]
N = 40
phi = 0.6
[scene.ensemble]
kind = "constant_volume"
[scene.shear]
rate = 1e-2
[scene.integrator]
kind = "euler"
dt = 0.1
[scene.run]
t_eq = 1.0
t_av = 4.0
sample_every = 1.0
blocks = 2
"""


def test_collected_hdf5_table_reads_as_the_csv_table(tmp_path, monkeypatch):
    # `jamflow sweep --collect table.h5`: every column, text ones included, is an array of the
    # table's length equal to the CSV column, and the guide's pandas line reads them all (run
    # here with a stand-in for pandas, which Debian's python3 lacks: DataFrame is the dict).
    (tmp_path / "two.toml").write_text(COLLECT_SWEEP)
    bin_ = os.environ.get("JAMFLOW_BIN", "jamflow")
    for args in (["-q", "-j", "2"], ["--collect", "table.csv"], ["--collect", "table.h5"]):
        out = subprocess.run([bin_, "sweep", "two.toml", *args], capture_output=True, text=True,
                             cwd=tmp_path)
        assert out.returncode == 0, out.stderr
    import csv
    with open(tmp_path / "table.csv", newline="") as f:
        rows = list(csv.DictReader(f))
    header = list(rows[0])
    assert len(rows) == 4
    import types
    monkeypatch.setitem(sys.modules, "pandas", types.SimpleNamespace(DataFrame=dict))
    monkeypatch.chdir(tmp_path)
    names = {}
    exec(guide_table_snippet(), names)
    table = names["table"]
    assert list(table) == header
    text = []
    for c in header:
        column = table[c]
        assert isinstance(column, np.ndarray) and column.shape == (len(rows),), c
        cells = [r[c] for r in rows]
        if column.dtype.kind == "f":
            expected = np.array([float(x) if x else np.nan for x in cells])
            assert column.tobytes() == expected.tobytes(), c
        else:
            text.append(c)
            assert all(isinstance(x, str) for x in column) and list(column) == cells, c
    assert text == ["point", "integrator.kind", "ensemble", "folder"]
    with h5py.File(tmp_path / "table.h5") as f:
        assert list(f["table"]) == header  # h5py lists the columns in the table's order
        assert f["table"].attrs["rows"] == len(rows)
