#!/usr/bin/python3
"""Compares jamflow run files bit for bit: every dataset and every attribute, except the ones
that record when and how fast a run ran (created, wall_seconds, wall_seconds_total,
cpu_seconds, cpu_seconds_total).

usage: compare_runs.py [--ignore ATTR]... A.h5 B.h5 [A2.h5 B2.h5 ...]
exit 0 when every pair is the same bits
"""
import sys

import h5py
import numpy as np

SKIP_ATTRS = {"created", "wall_seconds", "wall_seconds_total", "cpu_seconds", "cpu_seconds_total"}


def attrs_equal(a, b, where, problems):
    keys = (set(a.attrs) | set(b.attrs)) - SKIP_ATTRS
    for k in sorted(keys):
        if k not in a.attrs or k not in b.attrs:
            problems.append(f"{where}: attribute {k} only in one file")
            continue
        x, y = a.attrs[k], b.attrs[k]
        if isinstance(x, (bytes, str)) or isinstance(y, (bytes, str)):
            same = x == y
        else:
            xa, ya = np.asarray(x), np.asarray(y)
            same = xa.shape == ya.shape and xa.tobytes() == ya.tobytes()
        if not same:
            problems.append(f"{where}: attribute {k}: {x!r} != {y!r}")


def compare(pa, pb):
    problems = []
    with h5py.File(pa, "r") as fa, h5py.File(pb, "r") as fb:
        attrs_equal(fa, fb, "/", problems)
        names_a, names_b = [], []
        fa.visit(names_a.append)
        fb.visit(names_b.append)
        if sorted(names_a) != sorted(names_b):
            problems.append(f"objects differ: {sorted(set(names_a) ^ set(names_b))}")
        for name in sorted(set(names_a) & set(names_b)):
            oa, ob = fa[name], fb[name]
            attrs_equal(oa, ob, name, problems)
            if isinstance(oa, h5py.Dataset):
                da, db = oa[()], ob[()]
                if da.dtype != db.dtype or da.shape != db.shape or da.tobytes() != db.tobytes():
                    problems.append(f"{name}: data differ")
    return problems


def main(argv):
    while argv and argv[0] == "--ignore":
        SKIP_ATTRS.add(argv[1])
        argv = argv[2:]
    if len(argv) < 2 or len(argv) % 2:
        print(__doc__, file=sys.stderr)
        return 2
    bad = 0
    for pa, pb in zip(argv[0::2], argv[1::2]):
        problems = compare(pa, pb)
        if problems:
            bad += 1
            print(f"DIFFER {pa} {pb}: " + "; ".join(problems[:5]))
        else:
            print(f"same   {pa} {pb}")
    return 1 if bad else 0


if __name__ == "__main__":
    sys.exit(main(sys.argv[1:]))
