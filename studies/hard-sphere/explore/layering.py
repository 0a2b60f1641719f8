#!/usr/bin/env python3
"""Shear-induced layering: the largest S(k) = |sum_j exp(i k r_j)|^2 / N along each axis (k = 2 pi n / L,
n = 1..24) of each replica's final configuration in a sweep point's folder. A disordered packing gives
about 3 (the largest of 24 exponential draws); layers perpendicular to an axis give tens or more
along it.

usage: /usr/bin/python3 layering.py POINT_FOLDER...   (folders holding r0.h5, r1.h5, ...)
"""
import glob
import sys

import h5py
import numpy as np

for d in sys.argv[1:]:
    out = []
    for h in sorted(glob.glob(d + '/r*.h5')):
        with h5py.File(h, 'r') as f:
            pos = f['final/positions'][()]
            L = np.diag(f['final/cell'][()])
        res = []
        for ax in range(3):
            s = [abs(np.exp(2j * np.pi * n / L[ax] * pos[:, ax]).sum()) ** 2 / len(pos)
                 for n in range(1, 25)]
            res.append(round(max(s), 1))
        out.append(res)
    print(d.split('/')[-1], 'S_max (x, y, z) per replica:', out)
