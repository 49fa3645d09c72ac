#!/usr/bin/env python3
"""Pack-only comparison on identical charts: our charts, packed again by xatlas and uvunwrap.

    python3 benches/pack_peers.py OURS.glb OUT_DIR --uv-sets 0[,0…] --eval-dir DIR
                                  [--resolution 1024] [--padding 2] [--bisect-steps 10] [--json]

Called by `cargo bench --bench pipeline -- FILES --pack-peers` (benches/pipeline.rs), which then
measures every GLB written here with `atlas_eval.py --input ORIGINAL`. Needs
`pip install xatlas uvunwrap numpy` and the evaluator's directory (`--eval-dir`) for its glTF
reader and writer.

Input: `OURS.glb`, texatlas's output. Triangle primitive i (in (mesh, primitive) order) has our
atlas in `TEXCOORD_k`, k = `--uv-sets`[i] (the report's `uv_set_per_primitive`). Its UV islands
are the charts. Every output below is one GLB with one mesh per input mesh, one primitive per
input triangle primitive (POSITION, TEXCOORD_0, indices), triangle i of the output being triangle i
of the input, written to OUT_DIR:

- `texatlas`: our UVs as they are (so that all outputs are read the same way).
- `xatlas-bisect`: `Atlas.add_uv_mesh` per primitive, then `generate` with `PackOptions`
  resolution, padding = ceil(padding / 2), `bilinear` off, other options at their defaults, and a
  fixed `texels_per_unit`. xatlas dilates both charts, so two charts end at least 2 · ceil(padding /
  2) texels apart, but 0 from the page edge (ours keeps the padding from the edge too). The density
  is bisected: the largest that gives one page with no chart scaled down (a fixed page scales down
  the charts larger than the page, so the density would no longer be uniform). Time: all packings
  of the bisection (`packings` of them).
- `xatlas-plain`: one `generate` with resolution and padding only. xatlas then picks the density
  for an assumed 75 % fill and lets the page grow past the resolution; the UVs are put unchanged
  (isotropically) into a square of the larger side, whose unused strip is empty (a note says so).
- `uvunwrap`: `uvunwrap.generate([Mesh(positions, indices, existing_uvs=uvs)…], page_size,
  padding)`, which keeps given UV islands as charts and packs them. Pages beyond the first are
  laid side by side, then put isotropically into one square (a note says so).

Times are the wall time of the packing calls only (`generate`; for the xatlas UV meshes it also
finds the islands, which is cheap beside packing), not the reads, copies and writes. Per output,
the spread of (output UV area / our UV area) over triangles is reported: 1 when the packer only
moved and turned our charts, above 1 when it scaled charts differently.

Printed (`--json`): {"input", "uv_area", "packers": [{"packer", "glb", "pack_s", "packings",
"page": [w, h], "pages", "area_scale_spread", "notes": […]}…]}.
"""

import argparse
import json
import math
import os
import sys
import time


def read_charts(atlas_eval, path, uv_sets):
    """[(mesh index, positions (V,3), uvs (V,2), triangles (T,3))] of every triangle primitive."""
    g = atlas_eval.Gltf(path)
    prims = []
    for mi, mesh in enumerate(g.meshes()):
        for prim in mesh.get("primitives", []):
            tri = g.triangles(prim)
            if tri is not None:
                prims.append((mi, prim, tri))
    if len(prims) != len(uv_sets):
        raise ValueError(f"{path} has {len(prims)} triangle primitives but {len(uv_sets)} UV sets were given "
                         "(pass the report's uv_set_per_primitive)")
    out = []
    for (mi, prim, tri), k in zip(prims, uv_sets):
        key = f"TEXCOORD_{k}"
        if key not in prim["attributes"]:
            raise ValueError(f"{path}: a triangle primitive of mesh {mi} has no {key}")
        out.append((mi, g.accessor(prim["attributes"]["POSITION"]), g.accessor(prim["attributes"][key])[:, :2], tri))
    return out


def tri_areas(uv, tri):
    a, b, c = uv[tri[:, 0]], uv[tri[:, 1]], uv[tri[:, 2]]
    return 0.5 * abs((b[:, 0] - a[:, 0]) * (c[:, 1] - a[:, 1]) - (c[:, 0] - a[:, 0]) * (b[:, 1] - a[:, 1]))


def area_scale_range(np, ours, packed):
    """(min, max) over the triangles of (packed UV area / our UV area), leaving out triangles below
    1/1000 of the mean area (their float32 UVs are too coarse for a ratio)."""
    num = np.concatenate([tri_areas(np.asarray(uv, np.float64), np.asarray(t, np.int64)) for uv, t in packed])
    den = np.concatenate([tri_areas(np.asarray(uv, np.float64), np.asarray(t, np.int64)) for _, _, uv, t in ours])
    keep = den >= 1e-3 * max(den.mean(), 1e-300)
    if not keep.any():
        return (float("nan"), float("nan"))
    r = num[keep] / den[keep]
    return (float(r.min()), float(r.max()))


def write_glb(GltfBuilder, np, path, parts):
    """parts: [(mesh index, positions, uvs, triangles)] in primitive order."""
    b = GltfBuilder()
    by_mesh = {}
    for mi, pos, uv, tri in parts:
        attrs = {"POSITION": b.add_accessor(np.asarray(pos, np.float64), 5126, target=34962, minmax=True),
                 "TEXCOORD_0": b.add_accessor(np.asarray(uv, np.float64), 5126, target=34962)}
        ind = b.add_accessor(np.asarray(tri, np.int64).reshape(-1), 5125, target=34963)
        by_mesh.setdefault(mi, []).append({"attributes": attrs, "indices": ind, "mode": 4})
    for mi in sorted(by_mesh):
        b.add_mesh(by_mesh[mi])
    b.write_glb(path)


def xatlas_pack(xatlas, np, charts, resolution, padding, texels_per_unit):
    """One xatlas packing of our charts. Returns (seconds, atlas, [(positions, uvs in texels, tris)])."""
    atlas = xatlas.Atlas()
    for _, _, uv, tri in charts:
        atlas.add_uv_mesh(np.ascontiguousarray(uv, np.float32), np.ascontiguousarray(tri, np.uint32))
    po = xatlas.PackOptions()
    po.resolution = int(resolution)
    po.padding = int(math.ceil(padding / 2))
    po.bilinear = False
    if texels_per_unit is not None:
        po.texels_per_unit = float(texels_per_unit)
    t0 = time.perf_counter()
    atlas.generate(pack_options=po)
    dt = time.perf_counter() - t0
    w, h = int(atlas.width), int(atlas.height)
    out = []
    for i, (_, pos, _, _) in enumerate(charts):
        vmap, idx, uvs = atlas[i]
        texels = np.asarray(uvs, np.float64) * np.array([w, h], np.float64)
        out.append((pos[np.asarray(vmap, np.int64)], texels, np.asarray(idx, np.int64).reshape(-1, 3)))
    return dt, atlas, out


def run(ours_path, out_dir, uv_sets, eval_dir, resolution=1024, padding=2, bisect_steps=10):
    sys.path.insert(0, os.path.abspath(eval_dir))
    import numpy as np
    import atlas_eval
    from gltf_write import GltfBuilder

    charts = read_charts(atlas_eval, ours_path, uv_sets)
    stem = os.path.basename(ours_path)
    stem = stem[: -len(".glb")] if stem.endswith(".glb") else stem
    os.makedirs(out_dir, exist_ok=True)
    uv_area = float(sum(tri_areas(np.asarray(uv, np.float64), np.asarray(t, np.int64)).sum() for _, _, uv, t in charts))
    if not uv_area > 0:
        raise ValueError(f"{ours_path}: the UV set has no area")
    results = []

    def emit(packer, parts_texels, side, pack_s, packings, page, pages, notes):
        """parts_texels: [(positions, uvs in texels, triangles)]; UVs are divided by `side`."""
        glb = os.path.join(out_dir, f"{stem}.pack-{packer}.glb")
        parts = [(mi, pos, uv / side, tri) for (mi, _, _, _), (pos, uv, tri) in zip(charts, parts_texels)]
        write_glb(GltfBuilder, np, glb, parts)
        lo, hi = area_scale_range(np, charts, [(uv, tri) for _, _, uv, tri in parts])
        results.append({"packer": packer, "glb": glb, "pack_s": pack_s, "packings": packings,
                        "page": page, "pages": pages,
                        "area_scale_spread": hi / lo if lo > 0 else None, "notes": notes})

    # Ours, as written.
    emit("texatlas", [(pos, np.asarray(uv, np.float64), tri) for _, pos, uv, tri in charts], 1.0,
         None, None, [resolution, resolution], 1, [])

    # xatlas, fixed page, bisected density.
    import xatlas

    def fits(tpu):
        dt, atlas, out = xatlas_pack(xatlas, np, charts, resolution, padding, tpu)
        lo, _ = area_scale_range(np, charts, [(uv, tri) for _, uv, tri in out])
        ok = int(atlas.atlas_count) == 1 and lo >= 0.99 * tpu * tpu
        return dt, ok, atlas, out

    hi = resolution / math.sqrt(uv_area)  # packing efficiency 1
    lo = hi / 2
    total_s, packings, best = 0.0, 0, None
    for _ in range(8):
        dt, ok, atlas, out = fits(lo)
        total_s, packings = total_s + dt, packings + 1
        if ok:
            best = (lo, atlas, out)
            break
        hi, lo = lo, lo / 2
    if best is None:
        raise RuntimeError(f"xatlas: no density down to {lo:.4g} texels per UV unit fits one page")
    for _ in range(bisect_steps):
        mid = 0.5 * (best[0] + hi)
        dt, ok, atlas, out = fits(mid)
        total_s, packings = total_s + dt, packings + 1
        if ok:
            best = (mid, atlas, out)
        else:
            hi = mid
    tpu, atlas, out = best
    emit("xatlas-bisect", out, float(resolution), total_s, packings, [int(atlas.width), int(atlas.height)], 1,
         [f"{packings} packings, {total_s / packings:.3g} s each; best {tpu:.5g} texels/UV unit; "
          f"xatlas padding {int(math.ceil(padding / 2))} (gap ≥ {2 * int(math.ceil(padding / 2))} between charts, "
          "0 from the edge)"])

    # xatlas, one call with the resolution only.
    dt, atlas, out = xatlas_pack(xatlas, np, charts, resolution, padding, None)
    w, h = int(atlas.width), int(atlas.height)
    notes = [f"one call; xatlas padding {int(math.ceil(padding / 2))} (0 from the edge)"]
    if int(atlas.atlas_count) != 1:
        notes.append(f"{int(atlas.atlas_count)} pages; only the UVs as returned are measured")
    if max(w, h) != resolution or w != h:
        notes.append(f"page grew to {w}×{h}: UVs put into a {max(w, h)}² square, measured at {resolution} px")
    emit("xatlas-plain", out, float(max(w, h, 1)), dt, 1, [w, h], int(atlas.atlas_count), notes)

    # uvunwrap, our islands as existing UVs.
    import uvunwrap

    meshes = [uvunwrap.Mesh(np.ascontiguousarray(pos, np.float32).reshape(-1).tolist(),
                            np.ascontiguousarray(tri, np.uint32).reshape(-1).tolist(),
                            existing_uvs=np.ascontiguousarray(uv, np.float32).reshape(-1).tolist())
              for _, pos, uv, tri in charts]
    t0 = time.perf_counter()
    result = uvunwrap.generate(meshes, page_size=int(resolution), padding=int(padding))
    dt = time.perf_counter() - t0
    w, h, pages = int(result.width), int(result.height), int(result.page_count)
    out = []
    for (_, pos, _, _), om in zip(charts, result.meshes):
        uv = np.asarray(om.uv, np.float64).reshape(-1, 2).copy()
        page = np.maximum(np.asarray(om.page, np.int64), 0)
        uv[:, 0] = uv[:, 0] * w + page * w
        uv[:, 1] = uv[:, 1] * h
        out.append((pos[np.asarray(om.xref, np.int64)], uv, np.asarray(om.indices, np.int64).reshape(-1, 3)))
    side = max(w * pages, h, 1)
    notes = [f"padding {int(padding)}"]
    if pages != 1 or side != resolution:
        notes.append(f"{pages} pages of {w}×{h} side by side, put into a {side}² square, measured at {resolution} px")
    emit("uvunwrap", out, float(side), dt, 1, [w, h], pages, notes)
    return {"input": os.path.basename(ours_path), "uv_area": uv_area, "packers": results}


def main(argv=None):
    ap = argparse.ArgumentParser(description="Pack texatlas's charts again with xatlas and uvunwrap; write GLBs.")
    ap.add_argument("ours", help="texatlas's output GLB")
    ap.add_argument("out_dir")
    ap.add_argument("--uv-sets", required=True, help="TEXCOORD index per triangle primitive, comma-separated")
    ap.add_argument("--eval-dir", required=True, help="directory of atlas_eval.py and gltf_write.py")
    ap.add_argument("--resolution", type=int, default=1024)
    ap.add_argument("--padding", type=int, default=2)
    ap.add_argument("--bisect-steps", type=int, default=10)
    ap.add_argument("--json", action="store_true")
    a = ap.parse_args(argv)
    try:
        uv_sets = [int(k) for k in a.uv_sets.split(",") if k.strip()]
        r = run(a.ours, a.out_dir, uv_sets, a.eval_dir, a.resolution, a.padding, a.bisect_steps)
    except (ValueError, RuntimeError, OSError) as e:
        print(f"pack_peers: error: {e}", file=sys.stderr)
        return 2
    if a.json:
        print(json.dumps(r, indent=1))
    else:
        for p in r["packers"]:
            print(p)
    return 0


if __name__ == "__main__":
    sys.exit(main())
