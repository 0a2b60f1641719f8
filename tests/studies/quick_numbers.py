"""The quick presets' numbers against the committed ones (tests/studies/data/quick/<study>/).

Run with the portable force kernel (JAMFLOW_KERNEL=portable: the same machine code on every
x86-64 machine), a quick preset gives the same bits wherever it runs, so its tables and its
analysis must equal the committed ones exactly: a change that moves any number (a port of the
studies, a scene built differently, an analysis changed) fails here, and is then either a bug or
a deliberate change whose commit regenerates the references (scripts/quick-reference.sh) and
says why. The cost columns (wall and CPU seconds, where the run's folder is) are not compared.

A study's HDF5 file is compared through a digest (FILE.h5.digest.json): every attribute and
dataset by path, numbers and text as they are, arrays by a SHA-256 of their bytes, less the
names of cost, provenance and places (seconds, CPU, kernel, host, version, git commit, file and folder
paths, and the scene text, which holds the start file's path), and less the parts a study
chooses by measured CPU time (DEPENDS_ON_TIMING), which differ from run to run.

usage: quick_numbers.py REFERENCE_DIR OUTPUT_DIR FILE...   (FILE: a table .csv, analysis.json,
                                                           or STUDY.h5.digest.json)
       quick_numbers.py --digest FILE.h5 OUT.json          (write a digest)
       quick_numbers.py --store FILE OUT                   (a table or JSON as a reference:
                                                           without the cost columns, inputs)
"""
import csv
import hashlib
import json
import re
import sys

COST = {"wall_seconds", "cpu_seconds", "cpu_from_wall", "folder"}
NOT_NUMBERS = re.compile(
    r"seconds|wall|cpu|elapsed|kernel|host|date|version|git|commit|file|init|path|folder|^scene$",
    re.I)
# What a study chooses by measured CPU time (the cheapest setting), and all that follows from
# the choice: the timestep study's accuracy targets, the softness study's chosen integrator and
# its pressure scans, a comparison's recommendation.
DEPENDS_ON_TIMING = {
    "timestep.h5": re.compile(r"^targets/"),
    "softness.h5": re.compile(r"candidates/c\d+@chosen$|/pscan/|^alphas/a\d+@integrator"),
    "compare.h5": re.compile(r"^@recommended$"),
}


def digest(path):
    import h5py
    import numpy as np
    skip = DEPENDS_ON_TIMING.get(path.rsplit("/", 1)[-1])
    out = {}

    def value(v):
        a = np.asarray(v)
        if a.dtype.kind in "SOU":
            if a.ndim == 0:
                x = a[()]
                return x.decode() if isinstance(x, bytes) else str(x)
            return [x.decode() if isinstance(x, bytes) else str(x) for x in a.ravel()]
        if a.ndim == 0:
            return a.item()
        return "sha256:%s %s %s" % (hashlib.sha256(np.ascontiguousarray(a).tobytes()).hexdigest(),
                                    a.dtype.str, list(a.shape))

    def add(name, obj):
        for k, v in obj.attrs.items():
            key = name + "@" + k
            if not NOT_NUMBERS.search(k) and not (skip and skip.search(key)):
                out[key] = value(v)
        if isinstance(obj, h5py.Dataset) and not NOT_NUMBERS.search(name.split("/")[-1]) \
                and not (skip and skip.search(name)):
            out[name] = value(obj[()])

    with h5py.File(path, "r") as h:
        add("", h)
        h.visititems(add)
    return {k: v if not isinstance(v, float) or v == v else "nan" for k, v in out.items()}


def table(path):
    with open(path, newline="") as f:
        rows = list(csv.DictReader(f))
    return [{k: v for k, v in r.items() if k not in COST} for r in rows]



def first_difference(a, b, where=""):
    if type(a) is not type(b):
        return f"{where}: {a!r} != {b!r}"
    if isinstance(a, dict):
        for k in sorted(set(a) | set(b)):
            if k not in a or k not in b:
                return f"{where}/{k}: only in {'the reference' if k in a else 'this run'}"
            d = first_difference(a[k], b[k], f"{where}/{k}")
            if d:
                return d
        return None
    if isinstance(a, list):
        if len(a) != len(b):
            return f"{where}: {len(a)} entries in the reference, {len(b)} here"
        for i, (x, y) in enumerate(zip(a, b)):
            d = first_difference(x, y, f"{where}[{i}]")
            if d:
                return d
        return None
    return None if a == b else f"{where}: reference {a!r}, this run {b!r}"


def main():
    if sys.argv[1] == "--digest":
        with open(sys.argv[3], "w") as f:
            json.dump(digest(sys.argv[2]), f, indent=0, sort_keys=True)
            f.write("\n")
        return
    if sys.argv[1] == "--store":  # a reference copy without what is not compared
        src, dst = sys.argv[2], sys.argv[3]
        if src.endswith(".csv"):
            with open(src, newline="") as f:
                rows = list(csv.reader(f))
            keep = [i for i, c in enumerate(rows[0]) if c not in COST]
            with open(dst, "w", newline="") as f:
                w = csv.writer(f, lineterminator="\n")
                for r in rows:
                    w.writerow([r[i] for i in keep])
        else:
            j = json.load(open(src))
            j.pop("inputs", None)
            with open(dst, "w") as f:
                json.dump(j, f, indent=1, sort_keys=True)
                f.write("\n")
        return
    ref_dir, out_dir, files = sys.argv[1], sys.argv[2], sys.argv[3:]
    failed = False
    for name in files:
        ref, out = f"{ref_dir}/{name}", f"{out_dir}/{name}"
        if name.endswith(".csv"):
            a, b = table(ref), table(out)
        elif name.endswith(".digest.json"):
            a, b = json.load(open(ref)), digest(out[: -len(".digest.json")])
        else:
            a, b = (json.load(open(p)) for p in (ref, out))
            for j in (a, b):
                j.pop("inputs", None)
        d = first_difference(a, b)
        if d:
            print(f"{name} differs from {ref}: {d}")
            failed = True
    sys.exit(1 if failed else 0)


if __name__ == "__main__":
    main()
