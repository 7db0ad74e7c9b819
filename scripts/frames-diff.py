"""Compares the OBJ frames of two runs (frames-ab.sh's comparator).

usage: python3 scripts/frames-diff.py RUN_A RUN_B NAME

Prints one CSV line: NAME, the number of frames, how many are
byte-identical, the largest vertex-coordinate difference (m), the largest
distance between a vertex and its counterpart (m) over all frames, and the
mean of those distances in the last frame (m).
"""
import math
import pathlib
import sys

a_dir, b_dir, name = pathlib.Path(sys.argv[1]), pathlib.Path(sys.argv[2]), sys.argv[3]
frames = sorted(p.name for p in a_dir.glob("frame-*.obj"))
assert frames == sorted(p.name for p in b_dir.glob("frame-*.obj")), "frame lists differ"


def vertices(text):
    return [tuple(map(float, line.split()[1:4])) for line in text.splitlines() if line.startswith("v ")]


same, coord, dist, last_mean = 0, 0.0, 0.0, 0.0
for f in frames:
    a, b = (a_dir / f).read_bytes(), (b_dir / f).read_bytes()
    if a == b:
        same += 1
        last_mean = 0.0
        continue
    va, vb = vertices(a.decode()), vertices(b.decode())
    d = [math.dist(p, q) for p, q in zip(va, vb)]
    coord = max(coord, max(max(abs(x - y) for x, y in zip(p, q)) for p, q in zip(va, vb)))
    dist = max(dist, max(d))
    last_mean = sum(d) / len(d)
print(f"{name},{len(frames)},{same},{coord:.3e},{dist:.3e},{last_mean:.3e}")
