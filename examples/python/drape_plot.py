"""The drape plotted with matplotlib: the cloth's mesh at four times, from Python.

    pip install matplotlib
    python examples/python/drape_plot.py                 # writes out/python/drape.png
    python examples/python/drape_plot.py --n 32 --out my.png

The picture is replaced when it was written by this example (its PNG text
chunk says so); any other file at the path is kept unless --force.
"""

import argparse
import os
import pathlib
import sys

import matplotlib

matplotlib.use("Agg")
import matplotlib.pyplot as plt  # noqa: E402
from PIL import Image  # noqa: E402  (matplotlib's own dependency)

import hookean  # noqa: E402

MARK = ("Software", "hookean examples/python/drape_plot.py")


def ours(path):
    """Whether the file at ``path`` is a picture this example wrote."""
    try:
        with Image.open(path) as im:
            return im.info.get(MARK[0]) == MARK[1]
    except OSError:
        return False


def main():
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--n", type=int, default=24, help="particles per side (default 24)")
    ap.add_argument("--out", type=pathlib.Path, default=pathlib.Path("out/python/drape.png"))
    ap.add_argument("--force", action="store_true", help="replace any file at --out")
    args = ap.parse_args()
    if args.out.exists() and not (args.force or ours(args.out)):
        sys.exit(f"drape_plot.py: {args.out} exists and was not written by this example "
                 "(--force replaces it)")
    n = args.n
    sim = hookean.cloth(n=n, duration=2.0).build()
    fig = plt.figure(figsize=(12, 3.4))
    for k, t in enumerate((0.0, 0.25, 0.5, 2.0)):
        if t > 0:
            sim.run_until(t)
        x = sim.positions.reshape(n, n, 3)
        ax = fig.add_subplot(1, 4, k + 1, projection="3d")
        ax.plot_wireframe(x[..., 0], x[..., 1], x[..., 2], linewidth=0.4, color="tab:blue")
        ax.set(title=f"t = {t:g} s", xlim=(-0.1, 1.1), ylim=(-0.1, 1.1), zlim=(-1.1, 0.1))
        ax.set_box_aspect((1.2, 1.2, 1.2))
    fig.tight_layout()
    args.out.parent.mkdir(parents=True, exist_ok=True)
    tmp = args.out.with_name(args.out.name + ".partial")
    fig.savefig(tmp, dpi=100, format="png", metadata=dict([MARK]))
    os.replace(tmp, args.out)
    print(f"drape_plot.py: wrote {args.out} (lowest point {sim.positions[:, 2].min():.3f} m "
          f"at t = {sim.t:g} s)")


if __name__ == "__main__":
    main()
