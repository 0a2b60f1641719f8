"""The quick presets' numbers against the committed ones (tests/studies/data/quick/<study>/).

Run with the portable force kernel (JAMFLOW_KERNEL=portable: the same machine code on every
x86-64 machine), a quick preset gives the same bits wherever it runs, so its tables and its
analysis must equal the committed ones exactly: a change that moves any number (a port of the
studies, a scene built differently, an analysis changed) fails here, and is then either a bug or
a deliberate change whose commit regenerates the references (scripts/quick-reference.sh) and
says why. The cost columns (wall and CPU seconds, where the run's folder is) are not compared.

usage: quick_numbers.py REFERENCE_DIR OUTPUT_DIR FILE...   (FILE: a table .csv or analysis.json)
"""
import csv
import json
import sys

COST = {"wall_seconds", "cpu_seconds", "cpu_from_wall", "folder"}


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
    ref_dir, out_dir, files = sys.argv[1], sys.argv[2], sys.argv[3:]
    failed = False
    for name in files:
        ref, out = f"{ref_dir}/{name}", f"{out_dir}/{name}"
        if name.endswith(".csv"):
            a, b = table(ref), table(out)
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
