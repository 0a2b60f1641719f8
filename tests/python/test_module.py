"""The Python module `jamflow`: scenes, errors as exceptions, runs against the command line's
HDF5 output bit for bit, simulations under a Python loop, interruption, sweeps and analyses.

Run by ctest (Python.Module) with PYTHONPATH set to the build folder and JAMFLOW_BIN naming the
command line binary.
"""
import os
import signal
import subprocess
import sys
import threading

import h5py
import numpy as np
import pytest

import jamflow

JAMFLOW_BIN = os.environ.get("JAMFLOW_BIN", "jamflow")

SMALL = {
    "system": {"N": 64, "phi": 0.62, "seed": 3},
    "ensemble": {"kind": "constant_volume"},
    "shear": {"rate": 1e-2},
    "integrator": {"kind": "euler", "dt": 0.1},
    "run": {"t_eq": 10.0, "t_av": 40.0, "sample_every": 1.0, "blocks": 4},
}

SMALL_TEXT = """
[system]
N = 64
phi = 0.62
seed = 3
[ensemble]
kind = "constant_volume"
[shear]
rate = 1e-2
[integrator]
kind = "euler"
dt = 0.1
[run]
t_eq = 10.0
t_av = 40.0
sample_every = 1.0
blocks = 4
"""


def same_bits(a, b):
    a, b = np.asarray(a), np.asarray(b)
    return a.shape == b.shape and a.dtype == b.dtype and a.tobytes() == b.tobytes()


def cli(*args, cwd=None):
    return subprocess.run([JAMFLOW_BIN, *args], capture_output=True, text=True, cwd=cwd)


# ---- scenes ---------------------------------------------------------------------------------


def test_scene_from_file_text_dict_and_default(tmp_path):
    path = tmp_path / "small.toml"
    path.write_text(SMALL_TEXT)
    from_file = jamflow.Scene(path)
    from_str_path = jamflow.Scene(str(path))
    from_text = jamflow.Scene(SMALL_TEXT)
    from_dict = jamflow.Scene(SMALL)
    assert from_file.text == from_str_path.text == from_text.text == from_dict.text
    assert from_dict.get("shear.rate") == 1e-2
    assert from_dict["system.N"] == 64
    assert from_dict.to_dict()["run"]["blocks"] == 4
    default = jamflow.Scene()
    assert default.get("system.N") == 1000
    assert "[system]" in str(default)


def test_scene_set_and_update():
    scene = jamflow.Scene(SMALL)
    scene.set("shear.rate", 1e-4)
    assert scene.get("shear.rate") == 1e-4
    scene.set("system.N", np.int64(100))  # numpy scalars are numbers
    assert scene.get("system.N") == 100
    # A kind that needs another key: both at once.
    scene.update({"ensemble.kind": "constant_pressure", "ensemble.pressure": 1e-3})
    assert scene.get("ensemble.pressure") == 1e-3
    with pytest.raises(jamflow.ConfigError):
        scene.set("ensemble.kind", "constant_volume")  # the pressure would be an unknown key
    assert scene.get("ensemble.kind") == "constant_pressure"  # unchanged


def test_errors_are_the_command_lines_one_line_messages(tmp_path):
    bad = dict(SMALL, system={"N": 64, "phi": 1.2})
    with pytest.raises(jamflow.ConfigError) as err:
        jamflow.Scene(bad)
    message = str(err.value)
    assert "\n" not in message
    assert "[system] phi" in message and "1.2" in message
    # The command line says the same about the same scene.
    path = tmp_path / "bad.toml"
    path.write_text(SMALL_TEXT.replace("phi = 0.62", "phi = 1.2"))
    out = cli("run", str(path), "-o", str(tmp_path / "x.h5"))
    assert out.returncode == 2
    assert out.stderr.strip() == "jamflow: error: " + message

    scene = jamflow.Scene(SMALL)
    with pytest.raises(ValueError, match=r"\[shear\] rate"):
        scene.set("shear.rate", -1.0)
    assert scene.get("shear.rate") == 1e-2
    with pytest.raises(jamflow.ConfigError, match="unknown|allowed"):
        scene.set("shear.speed", 1.0)
    with pytest.raises(jamflow.ConfigError, match="not a scene value"):
        scene.set("shear.rate", object())
    with pytest.raises(jamflow.ConfigError, match=r"\[output\] trajectory_format"):
        scene.set("output.trajectory_format", "pdb")
    scene.set("output.trajectory_every", 5.0)
    with pytest.raises(jamflow.ConfigError, match="needs an output file"):
        jamflow.run(scene)  # a trajectory, and nowhere to write it
    with pytest.raises(jamflow.InputFileError):
        jamflow.Scene(tmp_path / "missing.toml")
    assert issubclass(jamflow.InputFileError, OSError)


def test_out_of_range_integers_and_unknown_analyses_are_config_errors(tmp_path):
    scene = jamflow.Scene()
    with pytest.raises(jamflow.ConfigError, match=r"system\.N = 10{30} is out of range"):
        scene.set("system.N", 10**30)  # was RuntimeError: Unable to cast
    with pytest.raises(jamflow.ConfigError, match="out of range"):
        scene.set("system.N", np.uint64(2**64 - 1))
    assert scene.get("system.N") == 1000
    data = tmp_path / "d.csv"
    data.write_text("N,imposed_pressure,shear_rate,phi,phi_err,mu,mu_err\n100,1e-4,1e-6,0.63,1e-4,0.2,0.01\n")
    with pytest.raises(jamflow.ConfigError, match="unknown analysis 'nonsense'; allowed"):
        jamflow.analyze("nonsense", data)


# ---- runs -----------------------------------------------------------------------------------


def test_run_equals_the_command_line_bit_for_bit(tmp_path):
    path = tmp_path / "small.toml"
    path.write_text(SMALL_TEXT)
    assert cli("run", str(path), "-o", str(tmp_path / "cli.h5"), "-q").returncode == 0
    result = jamflow.run(jamflow.Scene(path), out=tmp_path / "py.h5")
    assert result.file == str(tmp_path / "py.h5")
    assert result.status == "complete"
    in_memory = jamflow.run(SMALL)  # writes nothing
    assert in_memory.file is None
    with h5py.File(tmp_path / "cli.h5") as f, h5py.File(tmp_path / "py.h5") as g:
        assert g.attrs["scene"] == f.attrs["scene"].replace("cli.h5", "py.h5")
        for name, values in result.timeseries.items():
            assert same_bits(values, f["timeseries"][name][()]), name
            assert same_bits(in_memory.timeseries[name], values), name
        for name in ("positions", "diameters", "species", "cell"):
            assert same_bits(result.final[name], f["final"][name][()]), name
        assert result.final["strain"] == f["final"].attrs["strain"]
        # RunResult.summary is the file's /summary: the same keys, exactly.
        assert sorted(result.summary) == sorted(f["summary"].attrs)
        for name, value in f["summary"].attrs.items():
            if name in ("wall_seconds", "cpu_seconds"):
                continue
            mine = result.summary[name]
            if isinstance(mine, str):
                assert mine == (value.decode() if isinstance(value, bytes) else value), name
            else:
                assert same_bits(np.float64(mine), np.float64(value)), name
        for name in ("eta", "eta_err", "sigma_xy", "pressure", "phi", "verdict_steady"):
            assert name in result.summary
    # The two files are the same bits, dates and wall times aside.
    compare = os.environ.get("JAMFLOW_COMPARE")
    if compare:
        # The stored scenes differ in [output] file only.
        out = subprocess.run(["/usr/bin/python3", compare, "--ignore", "scene",
                              str(tmp_path / "cli.h5"), str(tmp_path / "py.h5")],
                             capture_output=True, text=True)
        assert out.returncode == 0, out.stdout + out.stderr
    # An existing output is refused, as on the command line.
    with pytest.raises(jamflow.ConfigError, match="exists"):
        jamflow.run(SMALL, out=tmp_path / "py.h5")
    jamflow.run(SMALL, out=tmp_path / "py.h5", force=True)


def test_run_with_replicas(tmp_path):
    # At constant pressure, whose summary has the ensemble's own keys.
    scene = jamflow.Scene(SMALL_TEXT.replace('kind = "constant_volume"',
                                             'kind = "constant_pressure"\npressure = 1e-2'))
    scene.set("run.replicas", 2)
    result = jamflow.run(scene, out=tmp_path / "two.h5")
    with h5py.File(tmp_path / "two.h5") as f:
        assert sorted(result.summary) == sorted(f["summary"].attrs)
        for k in range(2):
            assert sorted(result.replicas[k].summary) == sorted(f[f"replicas/{k}/summary"].attrs)
        for name in ("imposed_pressure", "xi_V", "cpu_seconds_total", "eta_replica_err"):
            assert result.summary[name] == f["summary"].attrs[name], name
    assert len(result.replicas) == 2
    assert result.replicas[0].seed == 3 and result.replicas[1].seed == 4
    assert result.summary["replicas"] == 2
    assert "eta_replica_err" in result.summary
    assert same_bits(result.timeseries["sigma_xy"], result.replicas[0].timeseries["sigma_xy"])
    # The former names of the imposed pressure and the shear rate still index the summary, with
    # a DeprecationWarning, and are not keys.
    for former, current in (("pressure_imposed", "imposed_pressure"), ("P", "imposed_pressure"),
                            ("gdot", "shear_rate")):
        with pytest.warns(DeprecationWarning, match=f"'{former}' is deprecated; use '{current}'"):
            assert result.summary[former] == result.summary[current]
        assert former not in result.summary
    with pytest.raises(KeyError):
        result.summary["no_such_key"]


# ---- simulations ----------------------------------------------------------------------------


def test_simulation_follows_the_run_bit_for_bit():
    result = jamflow.run(SMALL)
    sim = jamflow.Simulation(SMALL)
    assert sim.n == 64 and sim.time == 0.0
    sigma = [sim.observables["sigma_xy"]]
    for k in range(1, 51):
        sim.advance(1.0)
        sigma.append(sim.observables["sigma_xy"])
    assert sim.time == 50.0
    assert same_bits(np.array(sigma), result.timeseries["sigma_xy"])
    assert same_bits(sim.positions, result.final["positions"])
    assert sim.observables["strain"] == result.final["strain"]


def test_simulation_arrays_and_a_shear_rate_ramp():
    sim = jamflow.Simulation(SMALL, seed=5)
    positions, forces = sim.positions, sim.forces
    assert positions.shape == (64, 3) and forces.shape == (64, 3)
    # Pair forces: no net force on the system.
    assert np.abs(forces.sum(axis=0)).max() < 1e-12 * max(1.0, np.abs(forces).max() * 64)
    positions[:] = 0.0  # a copy: the simulation is untouched
    assert np.abs(sim.positions).max() > 0.0
    strains = []
    for rate in (1e-2, 3e-3, 1e-3):
        sim.shear_rate = rate
        before = sim.observables["strain"]
        sim.advance(5.0)
        strains.append(sim.observables["strain"] - before)
    assert np.allclose(strains, [5e-2, 1.5e-2, 5e-3], rtol=1e-9)
    with pytest.raises(jamflow.ConfigError, match=r"\[shear\] rate"):
        sim.shear_rate = -1.0
    with pytest.raises(jamflow.ConfigError):
        sim.advance_to(1.0)  # in the past
    assert sim.statistics["force_evaluations"] > 0


def test_a_step_that_shears_by_more_than_a_cell_runs():
    # gdot dt = 5: the cell is remapped several times per step (this crashed the interpreter).
    sim = jamflow.Simulation(SMALL, seed=5)
    sim.shear_rate = 50.0
    sim.advance(3.0)
    assert sim.observables["strain"] == pytest.approx(150.0, rel=1e-9)
    assert np.isfinite(sim.forces).all()
    scene = jamflow.Scene(SMALL)
    scene.update({"shear.rate": 20.0, "run.t_eq": 0.0, "run.t_av": 4.0})
    result = jamflow.run(scene)
    assert result.summary["verdict_stable"].startswith("fail")
    # A strain whose fraction round-off has lost: a failed run, raised, not a crash.
    sim.shear_rate = 1e100
    with pytest.raises(jamflow.IntegrationError, match="tilt"):
        sim.advance(1.0)


# ---- interruption ---------------------------------------------------------------------------


def long_scene():
    scene = jamflow.Scene(SMALL)
    scene.update({"system.N": 500, "run.t_eq": 0.0, "run.t_av": 1e6, "run.sample_every": 1.0})
    return scene


def interrupt_soon(seconds=0.5):
    timer = threading.Timer(seconds, os.kill, (os.getpid(), signal.SIGINT))
    timer.start()
    return timer


def test_ctrl_c_stops_a_run_and_keeps_its_checkpoint(tmp_path):
    out = tmp_path / "long.h5"
    timer = interrupt_soon()
    with pytest.raises(KeyboardInterrupt):
        jamflow.run(long_scene(), out=out)
    timer.join()
    assert not out.exists()
    with h5py.File(str(out) + ".part") as f:
        status = f.attrs["status"]
        status = status.decode() if isinstance(status, bytes) else status
        assert status.startswith("interrupted at t =")
        assert len(f["timeseries"]["time"]) >= 1


def test_ctrl_c_stops_a_simulation_which_then_goes_on():
    sim = jamflow.Simulation(long_scene())
    timer = interrupt_soon()
    with pytest.raises(KeyboardInterrupt):
        sim.advance(1e6)
    timer.join()
    stopped = sim.time
    assert 0.0 < stopped < 1e6
    sim.advance_to(stopped + 1.0)
    assert sim.time == stopped + 1.0


# ---- sweeps and analyses --------------------------------------------------------------------

SWEEP = """
[sweep]
replicas = 1
[sweep.grid]
"shear.rate" = [1e-1, 1e-2]
[scene.system]
N = 64
phi = 0.62
[scene.ensemble]
kind = "constant_volume"
[scene.shear]
rate = 1e-2
[scene.integrator]
kind = "euler"
dt = 0.1
[scene.run]
t_eq = 5.0
t_av = 20.0
sample_every = 1.0
blocks = 4
"""


COMPARE = """
reference = "euler-0.05"
replicas = 2
observables = ["sigma_xy", "pressure"]
[base.system]
N = 64
phi = 0.60
seed = 1
[base.ensemble]
kind = "constant_volume"
[base.shear]
rate = 1e-2
[base.integrator]
kind = "euler"
dt = 0.05
[base.run]
t_eq = 0.0
t_av = 100.0
[prepare]
t = 100.0
[run]
t_eq = 20.0
t_av = 60.0
sample_every = 1.0
[[setting]]
label = "euler-0.05"
[[setting]]
label = "rkc"
integrator = { kind = "rkc" }
[[setting]]
label = "euler-1"
integrator.dt = 1.0
"""


def test_compare_runs_the_command_and_returns_its_table(tmp_path):
    path = tmp_path / "small.toml"
    path.write_text(COMPARE)
    table = jamflow.compare(path, jobs=2, plots=False)
    # One row per setting, in the file's order; Euler at dt = 1 (past its stability limit)
    # is flagged unstable and not recommended.
    assert list(table["setting"]) == ["euler-0.05", "rkc", "euler-1"]
    stable = dict(zip(table["setting"], table["stable"]))
    assert stable["euler-1"] == 0 and stable["euler-0.05"] == 1
    assert table["recommended"][list(table["setting"]).index("euler-1")] == 0
    out = tmp_path / "small.compare"
    assert (out / "report.md").is_file() and (out / "compare.h5").is_file()
    # A rerun reads the finished runs back: the same table, no run redone.
    runs = sorted((out / "settings").rglob("r0.h5"))
    stamps = [r.stat().st_mtime_ns for r in runs]
    again = jamflow.compare(path, plots=False)
    assert list(again["setting"]) == list(table["setting"])
    assert [r.stat().st_mtime_ns for r in runs] == stamps
    # A bad compare file is the command's one-line error, before anything runs.
    bad = tmp_path / "bad.toml"
    bad.write_text(COMPARE.replace('reference = "euler-0.05"', 'reference = "nope"'))
    with pytest.raises(jamflow.ConfigError, match="reference"):
        jamflow.compare(bad, out=tmp_path / "bad.out")
    assert not (tmp_path / "bad.out").exists()


def test_sweep_returns_the_collected_table(tmp_path):
    path = tmp_path / "two.toml"
    path.write_text(SWEEP)
    points = jamflow.sweep_points(path)
    assert [p["values"]["shear.rate"] for p in points] == [1e-1, 1e-2]
    table = jamflow.sweep(path, out=tmp_path / "two.sweep", jobs=2)
    assert len(table["point"]) == 2
    assert isinstance(table["eta"], np.ndarray) and np.all(np.isfinite(table["eta"]))
    assert same_bits(table["shear_rate"], np.array([1e-1, 1e-2]))
    assert list(table["status"]) == ["complete", "complete"]
    # Each point is the run of its scene.
    one = jamflow.run(points[1]["scene"])
    assert np.isclose(table["eta"][1], one.summary["eta"], rtol=1e-12)
    # The argument's former name still works (the finished points are kept, not rerun).
    again = jamflow.sweep(path=path, out=tmp_path / "two.sweep")
    assert same_bits(again["eta"], table["eta"])
    # A bad point is the command line's one-line error.
    path.write_text(SWEEP.replace("phi = 0.62", "phi = 2.0"))
    with pytest.raises(jamflow.ConfigError, match=r"phi"):
        jamflow.sweep(path, out=tmp_path / "bad.sweep")


# At constant pressure: a piston friction of 1e-6 collapses the cell in the first steps, a
# failed run (status "failed at t = ...") within a fraction of a second.
PISTON = dict(SMALL, ensemble={"kind": "constant_pressure", "pressure": 1e-2, "xi_V": 1.0},
              run={"t_eq": 2.0, "t_av": 8.0, "sample_every": 1.0, "blocks": 2})


def test_sweep_of_a_scene_and_a_grid_returns_every_point_failed_ones_too(tmp_path):
    rates = np.logspace(-2, -1, 2)  # numpy values are scene values
    grid = {"ensemble.xi_V": [1.0, 1e-6], "shear.rate": rates}
    out = tmp_path / "grid.sweep"
    with pytest.warns(RuntimeWarning, match="2 of 4 points did not finish") as caught:
        table = jamflow.sweep(jamflow.Scene(PISTON), out, grid=grid, jobs=2)
    assert all(len(column) == 4 for column in table.values())
    # The first key varies slowest; the varied keys are columns, the numpy values exactly, and the
    # shear rate is the one column shear_rate (no second column "shear.rate").
    assert same_bits(table["shear_rate"], np.concatenate([rates, rates]))
    assert "shear.rate" not in table and "gdot" not in table
    with pytest.warns(DeprecationWarning, match="'gdot' is deprecated; use 'shear_rate'"):
        assert same_bits(table["gdot"], table["shear_rate"])
    assert same_bits(table["ensemble.xi_V"], np.array([1.0, 1.0, 1e-6, 1e-6]))
    status = table["status"]
    assert list(status[:2]) == ["complete", "complete"]
    assert all(s.startswith("failed at t = ") for s in status[2:]), status
    assert np.all(np.isfinite(table["eta"][:2])) and np.all(np.isnan(table["eta"][2:]))
    assert np.all(np.isnan(table["replicas"][2:]))
    assert same_bits(table["shear_rate"][2:], rates)  # the scene's columns, failed or not
    message = str(caught[0].message)
    for name in table["point"][2:]:
        assert name in message
    # The folder column is absolute; the manifest names no sweep file (there is none).
    folder = table["folder"][0]
    assert os.path.isabs(folder) and os.path.exists(os.path.join(folder, "r0.h5"))
    import tomllib
    manifest = tomllib.loads((out / "manifest.toml").read_text())
    assert "file" not in manifest["sweep"] and manifest["sweep"]["points"] == 4
    # strict: the failed points raise, naming them (the finished ones are not rerun).
    with pytest.raises(jamflow.IntegrationError, match="did not finish") as err:
        jamflow.sweep(PISTON, out, grid=grid, strict=True)
    assert table["point"][2] in str(err.value)
    # The same grid from a sweep file gives the same points.
    sweep_file = tmp_path / "same.toml"
    sweep_file.write_text('[sweep]\n[sweep.grid]\n"ensemble.xi_V" = [1.0, 1e-6]\n'
                          f'"shear.rate" = [{rates[0]!r}, {rates[1]!r}]\n'
                          '[scene]\n' + jamflow.Scene(PISTON).text.replace("[", "[scene."))
    assert [p["name"] for p in jamflow.sweep_points(sweep_file)] == list(table["point"])


def test_sweep_of_a_grid_without_out_uses_a_fresh_temporary_folder(tmp_path, monkeypatch):
    # tempfile's folder is this test's own, so nothing outside it is touched.
    import tempfile
    monkeypatch.setattr(tempfile, "tempdir", str(tmp_path))
    table = jamflow.sweep(SMALL, grid={"shear.rate": [1e-2]}, replicas=2)
    folder = table["folder"][0]  # <sweep folder>/points/<point>
    sweep_folder = os.path.dirname(os.path.dirname(folder))
    assert os.path.dirname(sweep_folder) == str(tmp_path)
    assert os.path.basename(sweep_folder).startswith("jamflow-sweep-")
    assert list(table["status"]) == ["complete"] and table["replicas"][0] == 2
    assert os.path.exists(os.path.join(folder, "r1.h5"))


def test_sweep_arguments_are_checked():
    with pytest.raises(jamflow.ConfigError, match="needs grid"):
        jamflow.sweep(SMALL)
    with pytest.raises(jamflow.ConfigError, match="not a dict"):
        jamflow.sweep(SMALL, grid=[1e-2])
    with pytest.raises(jamflow.ConfigError, match="not a list"):
        jamflow.sweep(SMALL, grid={"shear.rate": 1e-2})
    with pytest.raises(jamflow.ConfigError, match="appears twice"):
        jamflow.sweep(SMALL, grid={"shear.rate": [1e-2, 1e-2]})
    with pytest.raises(jamflow.ConfigError, match="replicas = 0"):
        jamflow.sweep(SMALL, grid={"shear.rate": [1e-2]}, replicas=0)
    with pytest.raises(jamflow.ConfigError, match="with grid= only"):
        jamflow.sweep("any.toml", replicas=2)


def test_numpy_scalars_and_arrays_are_scene_values():
    scene = jamflow.Scene(SMALL)
    scene.set("shear.rate", np.float32(0.5))
    assert scene.get("shear.rate") == 0.5
    scene.set("shear.rate", np.array(2e-3))  # a 0-d array
    assert scene.get("shear.rate") == 2e-3
    scene.set("system.N", np.int32(80))
    assert scene.get("system.N") == 80 and type(scene.get("system.N")) is int
    scene.set("run.round_sample_every", np.bool_(True))  # a boolean, not the integer 1
    assert scene.get("run.round_sample_every") is True
    scene.update({"shear.rate": np.float64(1e-3), "system.seed": np.uint8(7)})
    assert scene.get("system.seed") == 7


def test_analyze_returns_plain_objects_and_raises_one_line_errors(tmp_path):
    # Pure hard-sphere data at two pressures: phi = phi_J - C J^b, mu = mu_J + C J^b.
    rows = ["N,imposed_pressure,shear_rate,phi,phi_err,mu,mu_err"]
    for p in (1e-4, 1e-5):
        for j in np.logspace(-5, -1, 9):
            phi, mu = 0.645 - 0.4 * j**0.38, 0.1 + 1.1 * j**0.36
            rows.append(f"1000,{p!r},{j * p!r},{phi!r},{1e-4!r},{mu!r},{1e-3!r}")
    data = tmp_path / "granular.csv"
    data.write_text("\n".join(rows) + "\n")
    result = jamflow.analyze("hard-sphere", data)
    assert isinstance(result, dict)
    assert jamflow.analyze_hard_sphere([data], envelope_z=2) == \
        jamflow.analyze("hard-sphere", data, envelope_z=2)
    text = repr(result)
    assert "phi_J" in text or "phi_j" in text
    with pytest.raises(jamflow.ConfigError) as err:
        jamflow.analyze("hard-sphere", tmp_path / "missing.csv")
    assert "\n" not in str(err.value) and "missing.csv" in str(err.value)


def test_analyze_flow_curve_fits_one_curve_and_marks_failed_rows(tmp_path):
    # One constant-volume curve sigma = sigma_y + K gdot^n, exact, the second row not steady.
    rows = ["N,phi,shear_rate,sigma_xy,sigma_xy_err,replicas,steady,stable,decorrelated"]
    for i, g in enumerate(np.logspace(-6, -2, 6)):
        s = 0.01 + 0.5 * g**0.5
        rows.append(f"1000,0.66,{g!r},{s!r},{0.01 * s!r},1,{0 if i == 1 else 1},1,1")
    data = tmp_path / "curve.csv"
    data.write_text("\n".join(rows) + "\n")
    result = jamflow.analyze_flow_curve(data)
    curve = result["curves"][0]
    assert len(curve["points"]) == 5 and len(result["left_out_for_verdicts"]) == 1
    hb = curve["herschel_bulkley"]["parameters"]
    assert abs(hb["sigma_y"]["value"] - 0.01) < 1e-6 and hb["sigma_y"]["error"] > 0
    marked = jamflow.analyze("flow-curve", data, include_failed=True)["curves"][0]["points"]
    assert [p["verdicts_failed"] for p in marked] == [False, True, False, False, False, False]


def _doc_text(obj):
    """The docstring without pybind11's signature line(s)."""
    doc = getattr(obj, "__doc__", None) or ""
    lines = [l for l in doc.strip().splitlines() if l.strip()]
    name = getattr(obj, "__name__", "")
    return "\n".join(l for l in lines if not (name and l.startswith(name + "(")))


def test_every_public_member_has_a_docstring():
    missing = []
    for name in dir(jamflow):
        if name.startswith("_"):
            continue
        obj = getattr(jamflow, name)
        if not callable(obj):
            continue  # data (default_scene): described in the module's docstring
        if not _doc_text(obj):
            missing.append(name)
        if isinstance(obj, type):
            for member, value in vars(obj).items():
                if member.startswith("_"):
                    continue
                if isinstance(value, staticmethod):
                    value = value.__func__
                if not _doc_text(value):
                    missing.append(f"{name}.{member}")
    assert not missing, "public members without a docstring: " + ", ".join(missing)
    assert "default_scene" in jamflow.__doc__


AUTO_SCENE = """
[system]
N = 100
phi = 0.6
[ensemble]
kind = "constant_volume"
[shear]
rate = 1e-2
[integrator]
kind = "euler"
dt = 0.1
[run]
t_eq = "auto"
t_av = 20
sample_every = 0.1
"""


def test_progress_goes_to_a_python_callback():
    # t_eq = "auto": the run's length (the transient found plus t_av = 20) grows as it goes.
    reports = []
    jamflow.run(jamflow.Scene(AUTO_SCENE), progress=reports.append)
    assert reports, "no progress reported"
    assert all(set(r) == {"label", "time", "total", "fraction", "elapsed", "eta", "extra",
                          "finished"} for r in reports)
    times = [r["time"] for r in reports]
    assert times == sorted(times)
    assert all(r["time"] <= r["total"] and 0.0 <= r["fraction"] <= 1.0 for r in reports)
    last = reports[-1]
    assert last["finished"] and last["fraction"] == 1.0 and last["time"] == last["total"]
    assert last["total"] > 20.0, last  # beyond the first estimate, t_av
    assert [r["finished"] for r in reports].count(True) == 1


def test_progress_true_shows_tqdm_or_a_line_on_sys_stderr(monkeypatch, capsys):
    pytest.importorskip("tqdm")
    scene = jamflow.Scene(AUTO_SCENE)
    jamflow.run(scene, progress=True)
    err = capsys.readouterr().err
    assert "100%|" in err and "t = " in err, err  # a tqdm bar, at 100 % at the end
    # Without tqdm: a line on sys.stderr (which Jupyter shows), ending at 100 %.
    monkeypatch.setitem(sys.modules, "tqdm", None)
    monkeypatch.setitem(sys.modules, "tqdm.auto", None)
    jamflow.run(scene, progress=True)
    err = capsys.readouterr().err
    assert "|" not in err and err.endswith("\n"), err
    assert err.rstrip("\n").split("\r")[-1].split("%")[0].endswith("100.0"), err


def test_an_exception_in_the_progress_callback_stops_the_run():
    calls = []

    def fail(report):
        calls.append(report)
        raise RuntimeError("enough")

    scene = jamflow.Scene(AUTO_SCENE)
    scene.set("run.t_eq", 0.0)
    scene.set("run.t_av", 1e5)  # 1e6 steps: minutes, unless stopped
    with pytest.raises(RuntimeError, match="enough"):
        jamflow.run(scene, progress=fail)
    assert len(calls) == 1
    with pytest.raises(jamflow.ConfigError, match="progress"):
        jamflow.run(scene, progress="yes")
