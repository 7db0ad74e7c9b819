"""A parameter sweep over a process pool: the drape's sag against its spring stiffness.

Each worker builds its own scene (scenes pickle, so they could be sent to
Dask or Ray workers as well) and runs it; the GIL is released during steps,
so a thread pool would also run in parallel. Prints, per stiffness, the
lowest point of the cloth at the end and the run's Newton and PCG counts.

    python examples/python/sweep_stiffness.py              # n = 16, 1 s, 4 stiffnesses
    python examples/python/sweep_stiffness.py --n 32 --workers 4
"""

import argparse
import os
from concurrent.futures import ProcessPoolExecutor

import hookean


def one_thread():
    """Each worker's kernels on one thread: the processes are the parallelism."""
    os.environ["RAYON_NUM_THREADS"] = "1"


def sag(scene):
    """The lowest z of the cloth at the scene's end, and the run's counters."""
    sim = scene.build()
    sim.run_until(scene.duration)
    return float(sim.positions[:, 2].min()), sim.stats


def main():
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--n", type=int, default=16, help="particles per side (default 16)")
    ap.add_argument("--duration", type=float, default=1.0, help="simulated seconds (default 1)")
    ap.add_argument("--workers", type=int, default=2, help="processes (default 2)")
    ap.add_argument("--stiffness", type=float, nargs="+", default=[1e3, 3e3, 1e4, 3e4],
                    help="structural spring stiffnesses, N/m")
    args = ap.parse_args()
    if args.workers < 1:
        ap.error("--workers must be at least 1")
    scenes = [hookean.cloth(n=args.n, stiffness=k, duration=args.duration) for k in args.stiffness]
    with ProcessPoolExecutor(max_workers=args.workers, initializer=one_thread) as pool:
        results = list(pool.map(sag, scenes))
    print(f"{'stiffness N/m':>14} {'lowest z m':>11} {'steps':>6} {'newton':>7} {'pcg':>6}")
    for k, (z, stats) in zip(args.stiffness, results):
        print(f"{k:14.3g} {z:11.4f} {stats['steps']:6d} {stats['newton_iterations']:7d} "
              f"{stats['linear_iterations']:6d}")


if __name__ == "__main__":
    main()
