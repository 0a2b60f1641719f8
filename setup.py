"""`pip install .`: setuptools drives CMake.

build_ext configures and builds the `jamflow` binary and the Python module with CMake (in
build-pip/cmake), or reuses a configured build folder named by the environment variable
JAMFLOW_CMAKE_BUILD_DIR (whose build tree was configured with the default prefix layout, so that
the module finds the binary at ../../../bin), installs them with `cmake --install` into
build-pip/stage, and takes from there the module (into site-packages), the binaries (into the
environment's bin/) and the plot scripts (into its share/jamflow/), where the module and the
binaries find each other and their plot scripts relative to themselves. With
JAMFLOW_CMAKE_INSTALL_AS_BUILT=1 as well, the reused folder is installed as it is, not built
first (the test suite's pip test: building there would relink binaries that other tests run).
"""
import glob
import os
import shutil
import subprocess
import sys
import sysconfig

from setuptools import Extension, setup
from setuptools.command.build_ext import build_ext

HERE = os.path.dirname(os.path.abspath(__file__))
BUILD_BASE = "build-pip"
STAGE = os.path.join(BUILD_BASE, "stage")
# Where the module is installed inside the stage, as in a virtual environment.
PY_DIR = "lib/python{}.{}/site-packages".format(*sys.version_info[:2])


class CMakeBuild(build_ext):
    def build_extension(self, ext):
        reuse = os.environ.get("JAMFLOW_CMAKE_BUILD_DIR")
        build_dir = os.path.abspath(reuse or os.path.join(BUILD_BASE, "cmake"))
        if not reuse:
            subprocess.check_call(
                ["cmake", "-S", HERE, "-B", build_dir, "-DCMAKE_BUILD_TYPE=Release",
                 "-DJAMFLOW_TESTS=OFF", f"-DPython_EXECUTABLE={sys.executable}",
                 f"-DJAMFLOW_PYTHON_INSTALL_DIR={PY_DIR}"])
        if not (reuse and os.environ.get("JAMFLOW_CMAKE_INSTALL_AS_BUILT") == "1"):
            jobs = str(os.cpu_count() or 1)
            subprocess.check_call(["cmake", "--build", build_dir, "-j", jobs, "--target",
                                   "jamflow", "jamflow-analyze", "jamflow_python"])
        stage = os.path.abspath(STAGE)
        shutil.rmtree(stage, ignore_errors=True)
        subprocess.check_call(["cmake", "--install", build_dir, "--prefix", stage],
                              stdout=subprocess.DEVNULL)
        suffix = sysconfig.get_config_var("EXT_SUFFIX")
        modules = glob.glob(os.path.join(stage, "lib", "**", "jamflow" + suffix), recursive=True)
        if len(modules) != 1:
            raise RuntimeError(f"expected one jamflow{suffix} under {stage}, found {modules}")
        target = self.get_ext_fullpath(ext.name)
        os.makedirs(os.path.dirname(target), exist_ok=True)
        shutil.copy2(modules[0], target)


def data_files():
    """The binaries (built into the stage) and the plot scripts, relative to the prefix."""
    files = [("bin", [os.path.join(STAGE, "bin", "jamflow"),
                      os.path.join(STAGE, "bin", "jamflow-analyze")]),
             ("share/jamflow/analysis/plots", sorted(glob.glob("analysis/plots/*.py")))]
    for script in sorted(glob.glob("studies/*/plot.py")):
        files.append((f"share/jamflow/{os.path.dirname(script)}", [script]))
    return files


setup(
    ext_modules=[Extension("jamflow", sources=[])],
    cmdclass={"build_ext": CMakeBuild},
    data_files=data_files(),
    options={"build": {"build_base": BUILD_BASE}},
    zip_safe=False,
)
