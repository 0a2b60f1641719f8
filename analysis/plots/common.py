"""Shared helpers of the analysis plot scripts (matplotlib, Agg backend).

Each script is run as `python SCRIPT SIDECAR.json PREFIX` by `jamflow analyze`
and writes PREFIX_figN.png. Exit status 3 means matplotlib is unavailable.
"""
import json
import sys


def load_matplotlib():
    try:
        import matplotlib
        matplotlib.use("Agg")
        import matplotlib.pyplot as plt
        import numpy as np
    except ImportError as exc:  # the C++ side turns status 3 into a warning
        print(f"plot: {exc}", file=sys.stderr)
        sys.exit(3)
    return plt, np


def read_args():
    if len(sys.argv) != 3:
        print(f"usage: {sys.argv[0]} SIDECAR.json PREFIX", file=sys.stderr)
        sys.exit(2)
    with open(sys.argv[1]) as f:
        return json.load(f), sys.argv[2]


def colours(plt, n):
    cmap = plt.get_cmap("viridis")
    return [cmap(0.85 * i / max(n - 1, 1)) for i in range(n)]
