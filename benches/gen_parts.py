#!/usr/bin/env python3
"""Generated multi-part assets for the packing benchmarks: many small low-poly parts in one mesh.

    python3 benches/gen_parts.py OUT_DIR [--eval-dir ../shared/eval] [--set default|large|long]

Writes one GLB per asset to OUT_DIR (one triangle primitive, POSITION and indices only), the same
bytes for the same arguments. Each part is placed at a random position and rotation in a 20 m cube:
- `parts_box_N_S`: N boxes of random proportions (each 12 triangles);
- `parts_cyl_N_S`: N closed cylinders of 6 to 16 sides;
- `parts_rock_N_S`: N rocks (icospheres of 1 or 2 subdivisions, radii perturbed by 25 %);
- `parts_mixed_N_S`: boxes, cylinders and rocks in turn;
- `parts_mixed_N_S_degenerate`: the same, plus two zero-area faces per degenerate pick (a repeated
  vertex, and three collinear vertices whose middle one is new), as game assets carry them.

`--set default` writes the 16 assets of 20 to 400 parts measured in docs/benchmarks.md (2026-12-06,
sixth); `--set large` adds 1,500 boxes and 1,200 mixed parts (about 3,000 charts each). `--set long`
writes only long parts, whose strips are longer than the page at a dense packing (2026-12-06,
seventh): `long_tube` (15 m, 8 sides, 10 rings), `long_tubes_3` (10 to 16 m),
`long_tubes_3_one_ring` and `long_plank_one_ring` (one triangle spans the whole length),
`long_plank` (20 × 1 × 0.2 m, 10 segments), `long_plank_boxes` (with 5 unit cubes), `long_rails`
(two 30 m rails and 30 posts) and `long_mixed_S` (12 random tubes, planks and boxes, 5 to 30 m). Needs numpy
and the evaluator's directory (`--eval-dir`, default `$TEXATLAS_EVAL_DIR`, else `../shared/eval`; a
relative path not found from the working directory is taken from the repository root) for its glTF
writer.
"""
import argparse
import os
import sys


def box(np, centre, size, rot):
    corners = np.array([[x, y, z] for x in (-1, 1) for y in (-1, 1) for z in (-1, 1)], float)
    faces = [(0, 1, 3), (0, 3, 2), (4, 6, 7), (4, 7, 5), (0, 4, 5), (0, 5, 1),
             (2, 3, 7), (2, 7, 6), (0, 2, 6), (0, 6, 4), (1, 5, 7), (1, 7, 3)]
    return (corners * size / 2) @ rot.T + centre, np.array(faces)


def cylinder(np, centre, radius, height, sides, rot):
    points = [[0, -height / 2, 0], [0, height / 2, 0]]
    for i in range(sides):
        a = 2 * np.pi * i / sides
        points += [[radius * np.cos(a), -height / 2, radius * np.sin(a)],
                   [radius * np.cos(a), height / 2, radius * np.sin(a)]]
    faces = []
    for i in range(sides):
        a0, a1 = 2 + 2 * i, 2 + 2 * ((i + 1) % sides)
        faces += [(0, a1, a0), (1, a0 + 1, a1 + 1), (a0, a1, a1 + 1), (a0, a1 + 1, a0 + 1)]
    return np.array(points) @ rot.T + centre, np.array(faces)


def icosphere(np, subdivisions):
    t = (1 + 5 ** 0.5) / 2
    points = [[-1, t, 0], [1, t, 0], [-1, -t, 0], [1, -t, 0], [0, -1, t], [0, 1, t],
              [0, -1, -t], [0, 1, -t], [t, 0, -1], [t, 0, 1], [-t, 0, -1], [-t, 0, 1]]
    faces = [(0, 11, 5), (0, 5, 1), (0, 1, 7), (0, 7, 10), (0, 10, 11), (1, 5, 9), (5, 11, 4),
             (11, 10, 2), (10, 7, 6), (7, 1, 8), (3, 9, 4), (3, 4, 2), (3, 2, 6), (3, 6, 8),
             (3, 8, 9), (4, 9, 5), (2, 4, 11), (6, 2, 10), (8, 6, 7), (9, 8, 1)]
    points = [np.array(p) / np.linalg.norm(p) for p in points]
    for _ in range(subdivisions):
        middle = {}

        def mid(a, b):
            key = (min(a, b), max(a, b))
            if key not in middle:
                q = points[a] + points[b]
                points.append(q / np.linalg.norm(q))
                middle[key] = len(points) - 1
            return middle[key]

        finer = []
        for a, b, c in faces:
            ab, bc, ca = mid(a, b), mid(b, c), mid(c, a)
            finer += [(a, ab, ca), (b, bc, ab), (c, ca, bc), (ab, bc, ca)]
        faces = finer
    return np.array(points), np.array(faces)


def rock(np, centre, size, rng, rot):
    points, faces = icosphere(np, int(rng.integers(1, 3)))
    points = points * (1 + 0.25 * rng.standard_normal((len(points), 1))) * size
    return points @ rot.T + centre, faces


def tube(np, centre, radius, length, sides, rings, rot):
    """A capped tube along y, `rings` rings of quads along its length."""
    points = []
    for j in range(rings + 1):
        for i in range(sides):
            a = 2 * np.pi * i / sides
            points.append([radius * np.cos(a), length * (j / rings - 0.5), radius * np.sin(a)])
    faces = []
    for j in range(rings):
        for i in range(sides):
            a, b = j * sides + i, j * sides + (i + 1) % sides
            faces += [(a, a + sides, b), (b, a + sides, b + sides)]
    n = len(points)
    points += [[0, -length / 2, 0], [0, length / 2, 0]]
    for i in range(sides):
        faces.append((n, i, (i + 1) % sides))
        faces.append((n + 1, rings * sides + (i + 1) % sides, rings * sides + i))
    return np.array(points, float) @ rot.T + centre, np.array(faces)


def plank(np, centre, length, width, thickness, segments, rot):
    """A box `length` long cut into `segments` rings of quads along its length."""
    ring = [(0, 0), (width, 0), (width, thickness), (0, thickness)]
    points = [[length * (j / segments - 0.5), y - width / 2, z - thickness / 2]
              for j in range(segments + 1) for (y, z) in ring]
    faces = []
    for j in range(segments):
        for i in range(4):
            a, b = j * 4 + i, j * 4 + (i + 1) % 4
            faces += [(a, b, a + 4), (b, b + 4, a + 4)]
    e = segments * 4
    faces += [(0, 2, 1), (0, 3, 2), (e, e + 1, e + 2), (e, e + 2, e + 3)]
    return np.array(points, float) @ rot.T + centre, np.array(faces)


def long_assets(np, write, out_dir):
    """Long parts: strips that at a dense packing are longer than the page."""
    eye = np.eye(3)

    def save(name, parts):
        points, faces, offset = [], [], 0
        for p, f in parts:
            points.append(p)
            faces.append(f + offset)
            offset += len(p)
        write(os.path.join(out_dir, name + ".glb"), np.vstack(points).astype(np.float32),
              np.vstack(faces).astype(np.uint32).ravel())

    save("long_tube", [tube(np, np.zeros(3), 0.3, 15, 8, 10, eye)])
    save("long_tubes_3", [tube(np, np.array([2.0 * i, 0, 0]), 0.3, 10 + 3 * i, 12, 8 + 2 * i, eye)
                          for i in range(3)])
    save("long_tubes_3_one_ring", [tube(np, np.array([2.0 * i, 0, 0]), 0.3, 10 + 3 * i, 12, 1, eye)
                                   for i in range(3)])
    save("long_plank", [plank(np, np.zeros(3), 20, 1, 0.2, 10, eye)])
    save("long_plank_one_ring", [plank(np, np.zeros(3), 20, 1, 0.2, 1, eye)])
    save("long_plank_boxes", [plank(np, np.zeros(3), 20, 1, 0.2, 10, eye)]
         + [box(np, np.array([0, 3 + 2.0 * i, 0]), np.ones(3), eye) for i in range(5)])
    save("long_rails", [plank(np, np.array([15, 0.15 + 2.0 * i, 0]), 30, 0.3, 0.3, 30, eye)
                        for i in range(2)]
         + [box(np, np.array([1.0 * i, 1, 0]), np.array([0.3, 2.2, 0.15]), eye) for i in range(30)])
    for seed in range(3):
        rng = np.random.default_rng(100 + seed)
        parts = []
        for k in range(12):
            centre, rot = rng.uniform(-10, 10, 3), rotation(np, rng)
            length = rng.uniform(5, 30)
            if k % 3 == 0:
                parts.append(tube(np, centre, rng.uniform(0.1, 0.5), length,
                                  int(rng.integers(6, 13)), max(1, int(length)), rot))
            elif k % 3 == 1:
                parts.append(plank(np, centre, length, rng.uniform(0.2, 1.5), rng.uniform(0.05, 0.4),
                                   max(1, int(length / 2)), rot))
            else:
                parts.append(box(np, centre, rng.uniform(0.3, 2, 3), rot))
        save(f"long_mixed_{seed}", parts)


def rotation(np, rng):
    q, _ = np.linalg.qr(rng.standard_normal((3, 3)))
    return q * np.sign(np.linalg.det(q))


def asset(np, write, out_dir, kind, parts, seed, degenerate=0):
    rng = np.random.default_rng(seed)
    all_points, all_faces, offset = [], [], 0
    for k in range(parts):
        centre = rng.uniform(-10, 10, 3)
        rot = rotation(np, rng)
        size = rng.uniform(0.2, 3)
        shape = kind if kind != "mixed" else ("box", "cyl", "rock")[k % 3]
        if shape == "box":
            points, faces = box(np, centre, size * rng.uniform(0.2, 1.5, 3), rot)
        elif shape == "cyl":
            points, faces = cylinder(np, centre, size / 3, size * rng.uniform(0.5, 4),
                                     int(rng.integers(6, 17)), rot)
        else:
            points, faces = rock(np, centre, size, rng, rot)
        all_points.append(points)
        all_faces.append(faces + offset)
        offset += len(points)
    points, faces = np.vstack(all_points), np.vstack(all_faces)
    extra = []
    for _ in range(degenerate):
        a, b, _c = faces[int(rng.integers(0, len(faces)))]
        extra.append((a, a, b))
        points = np.vstack([points, (points[a] + points[b]) / 2])
        extra.append((a, b, len(points) - 1))
    if extra:
        faces = np.vstack([faces, np.array(extra)])
    name = f"parts_{kind}_{parts}_{seed}{'_degenerate' if degenerate else ''}.glb"
    write(os.path.join(out_dir, name), points.astype(np.float32), faces.astype(np.uint32).ravel())


def eval_dir_of(given):
    """The directory holding the evaluator's `gltf_write.py`: `given`, or when it is relative
    and not found from the working directory, `given` from the repository root (so that the
    default `../shared/eval` works from any directory). Exits with a message naming the paths
    tried when neither holds it."""
    tried = [os.path.abspath(given)]
    if not os.path.isabs(given):
        root = os.path.dirname(os.path.dirname(os.path.abspath(__file__)))
        tried.append(os.path.normpath(os.path.join(root, given)))
    for d in tried:
        if os.path.isfile(os.path.join(d, "gltf_write.py")):
            return d
    sys.exit(
        "gen_parts.py: no gltf_write.py in "
        + " or ".join(tried)
        + ": pass --eval-dir DIR (the evaluator's directory) or set TEXATLAS_EVAL_DIR"
    )


def main():
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("out_dir")
    ap.add_argument("--eval-dir", default=os.environ.get("TEXATLAS_EVAL_DIR", "../shared/eval"))
    ap.add_argument("--set", choices=["default", "large", "long"], default="default")
    a = ap.parse_args()
    sys.path.insert(0, eval_dir_of(a.eval_dir))
    import numpy as np
    from gltf_write import write_simple_glb

    os.makedirs(a.out_dir, exist_ok=True)
    if a.set == "long":
        long_assets(np, write_simple_glb, a.out_dir)
        return 0
    for seed in range(3):
        asset(np, write_simple_glb, a.out_dir, "box", 40, seed)
        asset(np, write_simple_glb, a.out_dir, "cyl", 30, seed)
        asset(np, write_simple_glb, a.out_dir, "rock", 20, seed)
        asset(np, write_simple_glb, a.out_dir, "mixed", 150, seed)
        asset(np, write_simple_glb, a.out_dir, "mixed", 60, seed, degenerate=10)
    asset(np, write_simple_glb, a.out_dir, "mixed", 400, 7)
    if a.set == "large":
        asset(np, write_simple_glb, a.out_dir, "box", 1500, 11)
        asset(np, write_simple_glb, a.out_dir, "mixed", 1200, 12)
    return 0


if __name__ == "__main__":
    sys.exit(main())
