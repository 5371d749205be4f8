#!/usr/bin/env python3
"""The ground truth cross-checked by an independent tracer: Intel Embree 4 (`embreex` on PyPI).

For each case (a scene, hard and area lights), this runs `shadowlab reference` and `shadowlab
export` on the same scene, reads the surface points the truth used (`positions.f32`,
`geometric_normals.f32`), traces the same shadow rays with Embree in robust mode and asserts:

* hard lights (`--emitter-scale 0`): no pixel differs, except rays that pass within a tolerance of
  a triangle edge. Such a ray's answer is decided by float rounding in either tracer (two
  watertight tests may round a ray that grazes a shared edge or a silhouette to different sides),
  so a difference there is explained, not a defect. A differing pixel counts as explained when
  re-tracing it in Embree with the light moved by DELTA (1e-5 of the scene's diagonal, the size of
  the truth's own ray offset; six directions perpendicular to the ray) flips the answer at least
  once. Every other difference fails the check.
* area lights: the truth (256 stratified samples) against an independent Embree estimate
  (1024 uniform random samples of the emitter, numpy's generator) on the relevant pixels:
  RMSE <= 1.2 x the Monte-Carlo noise floor, the floor estimated from two seeds of each estimator
  (sqrt(s_truth^2 + s_embree^2), s = RMSE between its two seeds / sqrt 2), and
  |mean difference| < 3 standard errors (no bias).

Prints the figures per case. `--bench` measures shadow rays per second per thread of both tracers
on the same rays instead (the README's speed table).

Usage: python3 scripts/embree_check.py --shadowlab target/debug/shadowlab [--size 128x96] [--bench]
"""

import argparse
import json
import math
import os
import subprocess
import sys
import tempfile
import time

import numpy as np

try:
    from embreex import rtcore_scene as rtcs
    from embreex.mesh_construction import TriangleMesh
except ImportError:  # pragma: no cover - reported to the caller
    sys.exit("embree_check: the `embreex` package is missing: pip install embreex numpy")

FLT_EPSILON = np.float32(np.finfo(np.float32).eps)
HERE = os.path.dirname(os.path.abspath(__file__))
REPO = os.path.dirname(HERE)
ASSETS = os.path.join(REPO, "..", "shared", "assets")

# (label, scene, extra arguments, emitter scale of the area-light run). One built-in scene, one
# real model, one open non-manifold mesh. Sibenik's default sun (0.27°) leaves one penumbra pixel
# at 128x96: its area run widens the sun tenfold.
CASES = [
    ("room (built-in)", "room", [], 1),
    ("bunny-plane (Stanford bunny, rect light)", os.path.join(REPO, "scenes", "bunny-plane.toml"), [], 1),
    ("sibenik (open, non-manifold)", os.path.join(ASSETS, "sibenik", "sibenik.obj"), [], 10),
]

AREA_SAMPLES = 1024
# The bound of the issue: RMSE within 1.2x the noise floor.
NOISE_FACTOR = 1.2
# |mean difference| below this many standard errors.
BIAS_SIGMAS = 3.0
# A light's own RMSE bound needs this many penumbra pixels (0 < V < 1 in the truth): the noise
# floor is estimated from the pixels, and with n of them the ratio RMSE / floor scatters by about
# 1/sqrt(n) (6 pixels: ±40%, measured 1.23-1.31 on the room's reading lamp with no bias, its
# worst pixels within the seeds' own spread). Below it the light counts in the case's pooled bound
# (all its area lights' relevant pixels together) only.
MIN_PENUMBRA = 100
# Light displacement that decides "passes within a tolerance of an edge", in scene diagonals: the
# truth's own ray offset (EPSILON_SCALE, DESIGN.md §3) is 1e-5 of the diagonal.
DELTA_SCALE = 1e-5


def run(cmd):
    out = subprocess.run(cmd, capture_output=True, text=True)
    if out.returncode != 0:
        sys.exit(f"embree_check: {' '.join(cmd)} failed:\n{out.stderr}")
    return out.stdout


def read_f32(path, channels):
    meta = json.load(open(path[:-4] + ".json"))
    data = np.fromfile(path, dtype="<f4")
    return data.reshape(meta["height"] * meta["width"], channels) if channels > 1 else data


def load_obj(path):
    """Corners of every triangle, in file order (the export writes three `v` per `f`)."""
    verts = []
    faces = []
    with open(path) as f:
        for line in f:
            if line.startswith("v "):
                verts.append(line.split()[1:4])
            elif line.startswith("f "):
                faces.append(line.split()[1:4])
    v = np.array(verts, dtype=np.float32)  # parsed from the shortest round-trip text: exact
    idx = np.array(faces, dtype=np.int64) - 1
    return v[idx]


class Embree:
    def __init__(self, triangles):
        self.scene = rtcs.EmbreeScene(robust=True)
        self.empty = len(triangles) == 0
        if not self.empty:
            TriangleMesh(self.scene, np.ascontiguousarray(triangles, dtype=np.float32))

    def visible(self, origins, dirs, tmax):
        """True where nothing lies on the ray within (0, tmax)."""
        if self.empty or len(origins) == 0:
            return np.ones(len(origins), dtype=bool)
        res = self.scene.run(
            np.ascontiguousarray(origins, dtype=np.float32),
            np.ascontiguousarray(dirs, dtype=np.float32),
            dists=np.ascontiguousarray(tmax, dtype=np.float32),
            query="OCCLUDED",
        )
        return np.asarray(res) == -1


def epsilon(p, desc):
    off = desc["ray_offset"]
    mag = np.abs(p).max(axis=1).astype(np.float32)
    return np.maximum(np.float32(off["scale"]) * np.float32(max(off["scene_diagonal"], 1e-6)),
                      np.float32(off["ulps"]) * FLT_EPSILON * mag).astype(np.float32)


def basis(axis):
    """Two unit vectors perpendicular to each row of `axis`."""
    helper = np.where(np.abs(axis[:, :1]) > 0.9, np.array([[0, 1, 0]]), np.array([[1, 0, 0]]))
    t = np.cross(axis, helper)
    t /= np.linalg.norm(t, axis=1, keepdims=True)
    return t, np.cross(axis, t)


def target_rays(origin, n, light, u=None):
    """Shadow rays from `origin` to one emitter sample each: the light's centre (u is None) or a
    uniform sample of the emitter for the 2-vectors `u` in [0,1)^2 (DESIGN.md §3's measures).
    Returns directions, tmax and whether the sample is above the tangent plane."""
    m = len(origin)
    kind = light["type"]
    if kind == "directional":
        d = -np.array(light["direction"], dtype=np.float64)
        d /= np.linalg.norm(d)
        dirs = np.repeat(d[None, :], m, axis=0)
        if u is not None and light["angular_radius"] > 0:
            cos_max = math.cos(light["angular_radius"])
            cos_t = 1.0 - u[:, 0] * (1.0 - cos_max)  # uniform over the cone's solid angle
            sin_t = np.sqrt(np.maximum(0.0, 1.0 - cos_t**2))
            phi = 2 * math.pi * u[:, 1]
            t, b = basis(dirs)
            dirs = dirs * cos_t[:, None] + (t * np.cos(phi)[:, None] + b * np.sin(phi)[:, None]) * sin_t[:, None]
        tmax = np.full(m, np.inf)
    else:
        centre = np.array(light["position"], dtype=np.float64)
        q = np.repeat(centre[None, :], m, axis=0)
        if u is not None and kind == "rect":
            tan, bit = np.array(light["tangent"]), np.array(light["bitangent"])
            q = q + (u[:, :1] - 0.5) * light["width"] * tan + (u[:, 1:] - 0.5) * light["height"] * bit
        elif u is not None and light.get("radius", 0) > 0:
            axis = centre - origin
            axis /= np.maximum(np.linalg.norm(axis, axis=1, keepdims=True), 1e-30)
            t, b = basis(axis)
            r = light["radius"] * np.sqrt(u[:, 0])  # uniform over the disk
            phi = 2 * math.pi * u[:, 1]
            q = q + t * (r * np.cos(phi))[:, None] + b * (r * np.sin(phi))[:, None]
        d = q - origin
        length = np.linalg.norm(d, axis=1)
        dirs = d / np.maximum(length, 1e-30)[:, None]
        tmax = length
    above = np.einsum("ij,ij->i", dirs, n) > 0
    return dirs, tmax, above


def hard_visibility(tracer, origin, n, eps, light, shift=None):
    lit = dict(light)
    if shift is not None and "position" in lit:
        lit["position"] = (np.array(lit["position"]) + shift).tolist()
    dirs, tmax, above = target_rays(origin, n, lit)
    if shift is not None and light["type"] == "directional":
        dirs = dirs + shift
        dirs /= np.linalg.norm(dirs, axis=1, keepdims=True)
        above = np.einsum("ij,ij->i", dirs, n) > 0
    # The truth traces to |q - origin| - eps (a point emitter) and calls a sample within eps lit.
    close = tmax <= eps
    vis = tracer.visible(origin, dirs, np.where(np.isinf(tmax), np.float32(3.0e38), tmax - eps))
    return np.where(close, True, above & vis)


def area_estimate(tracer, origin, n, eps, light, seed, samples):
    rng = np.random.default_rng(seed)
    hits = np.zeros(len(origin))
    for _ in range(samples):
        u = rng.random((len(origin), 2))
        dirs, tmax, above = target_rays(origin, n, light, u)
        close = tmax <= eps
        vis = tracer.visible(origin, dirs, np.where(np.isinf(tmax), np.float32(3.0e38), tmax - eps))
        hits += np.where(close, True, above & vis)
    return hits / samples


def prepare(binary, scene, size, work, emitter_scale, seed=1, extra=()):
    ref = os.path.join(work, f"ref-{emitter_scale}-{seed}")
    common = ["--scene", scene, "--size", size, "--emitter-scale", str(emitter_scale), *extra]
    run([binary, "reference", *common, "--seed", str(seed), "--out", ref])
    geometry = os.path.join(work, f"scene-{emitter_scale}.obj")
    if not os.path.exists(geometry):
        run([binary, "export", *common, "--out", geometry])
    return ref, geometry


def load_case(ref, geometry):
    desc = json.load(open(geometry[:-4] + ".json"))
    info = json.load(open(os.path.join(ref, "reference.json")))
    tris = load_obj(geometry)
    keep = np.zeros(len(tris), dtype=bool)
    for inst in desc["instances"]:
        if inst["casts_shadows"]:
            keep[inst["first_triangle"]:inst["first_triangle"] + inst["triangles"]] = True
    positions = read_f32(os.path.join(ref, "positions.f32"), 3)
    normals = read_f32(os.path.join(ref, "geometric_normals.f32"), 3)
    lights = {l["index"]: l for l in desc["lights"]}
    return desc, info, tris[keep], positions, normals, lights


def origins(desc, positions, normals, mask):
    p = positions[mask].astype(np.float32)
    n = normals[mask].astype(np.float32)
    eps = epsilon(p, desc)
    return (p + n * eps[:, None]).astype(np.float32), n.astype(np.float64), eps


def check_hard(binary, label, scene, size, work, extra):
    ref, geometry = prepare(binary, scene, size, work, 0, extra=extra)
    desc, info, tris, positions, normals, lights = load_case(ref, geometry)
    tracer = Embree(tris)
    delta = DELTA_SCALE * desc["ray_offset"]["scene_diagonal"]
    failures = []
    for entry in info["lights"]:
        truth = read_f32(os.path.join(ref, entry["f32"]), 1)
        mask = ~np.isnan(truth)
        origin, n, eps = origins(desc, positions, normals, mask)
        light = lights[entry["index"]]
        ours = hard_visibility(tracer, origin, n, eps, light)
        theirs = truth[mask] > 0.5
        differ = np.nonzero(ours != theirs)[0]
        explained = 0
        for i in differ:
            o, nn, e = origin[i:i + 1], n[i:i + 1], eps[i:i + 1]
            d, _, _ = target_rays(o, nn, light)
            t, b = basis(d)
            shifts = [s * delta for s in (t[0], -t[0], b[0], -b[0], (t[0] + b[0]) / 2**0.5, -(t[0] + b[0]) / 2**0.5)]
            if any(hard_visibility(tracer, o, nn, e, light, shift=s)[0] != ours[i] for s in shifts):
                explained += 1
        unexplained = len(differ) - explained
        print(f"  hard  {entry['name']:<16} {mask.sum():>7} pixels, {len(differ)} differ, "
              f"{explained} within {delta:.2g} m of an edge, {unexplained} unexplained")
        if unexplained:
            failures.append(f"{label}: {entry['name']}: {unexplained} unexplained hard differences")
    return failures


def check_area(binary, label, scene, size, work, extra, scale):
    ref1, geometry = prepare(binary, scene, size, work, scale, seed=1, extra=extra)
    ref2, _ = prepare(binary, scene, size, work, scale, seed=2, extra=extra)
    desc, info, tris, positions, normals, lights = load_case(ref1, geometry)
    tracer = Embree(tris)
    failures = []
    pooled = {"diff2": 0.0, "truth2": 0.0, "embree2": 0.0, "n": 0}
    for entry in info["lights"]:
        light = lights[entry["index"]]
        if light["emitter"].startswith("hard"):
            continue
        t1 = read_f32(os.path.join(ref1, entry["f32"]), 1)
        t2 = read_f32(os.path.join(ref2, entry["f32"]), 1)
        mask = ~np.isnan(t1)
        if mask.sum() == 0:
            continue
        origin, n, eps = origins(desc, positions, normals, mask)
        e1 = area_estimate(tracer, origin, n, eps, light, 11, AREA_SAMPLES)
        e2 = area_estimate(tracer, origin, n, eps, light, 12, AREA_SAMPLES)
        a, b = t1[mask].astype(np.float64), t2[mask].astype(np.float64)
        penumbra = int(((a > 0) & (a < 1)).sum())
        s_truth = math.sqrt(np.mean((a - b) ** 2) / 2)
        s_embree = math.sqrt(np.mean((e1 - e2) ** 2) / 2)
        floor = math.sqrt(s_truth**2 + s_embree**2)
        diff = a - e1
        rmse = math.sqrt(np.mean(diff**2))
        pooled["diff2"] += float(np.sum(diff**2))
        pooled["truth2"] += float(np.sum((a - b) ** 2)) / 2
        pooled["embree2"] += float(np.sum((e1 - e2) ** 2)) / 2
        pooled["n"] += len(diff)
        se = diff.std(ddof=1) / math.sqrt(len(diff)) if len(diff) > 1 else 0.0
        mean = diff.mean()
        own_bound = penumbra >= MIN_PENUMBRA
        ok_rmse = not own_bound or rmse <= NOISE_FACTOR * floor + 1e-12
        ok_bias = abs(mean) <= BIAS_SIGMAS * se + 1e-12
        print(f"  area  {entry['name']:<16} {mask.sum():>7} pixels ({penumbra} penumbra), RMSE {rmse:.5f} vs noise "
              f"floor {floor:.5f} (truth {s_truth:.5f}, embree {s_embree:.5f}): {rmse / floor if floor else 0:.2f}x"
              f"{'' if own_bound else ' (pooled only)'}; mean diff {mean:+.5f} = {abs(mean) / se if se else 0:.2f} SE")
        if not ok_rmse:
            failures.append(f"{label}: {entry['name']}: RMSE {rmse:.5f} > {NOISE_FACTOR} x floor {floor:.5f}")
        if not ok_bias:
            failures.append(f"{label}: {entry['name']}: mean difference {mean:+.5f} beyond {BIAS_SIGMAS} SE ({se:.5f})")
    if pooled["n"]:
        rmse = math.sqrt(pooled["diff2"] / pooled["n"])
        floor = math.sqrt((pooled["truth2"] + pooled["embree2"]) / pooled["n"])
        print(f"  area  all lights       {pooled['n']:>7} pixels, RMSE {rmse:.5f} vs noise floor {floor:.5f}: "
              f"{rmse / floor if floor else 0:.2f}x")
        if rmse > NOISE_FACTOR * floor + 1e-12:
            failures.append(f"{label}: all area lights: RMSE {rmse:.5f} > {NOISE_FACTOR} x floor {floor:.5f}")
    return failures


# The speed benchmark's scenes: a real model under a rect light, and a generated scene of about
# 500K triangles (an 800 m terrain on a 450² grid, its trees and cabins) under the real sun.
BENCH = [
    ("bunny-plane, rect light", os.path.join(REPO, "scenes", "bunny-plane.toml"), 1),
    ("terrain:grid=450 (511K triangles), sun 0.27°", "terrain:grid=450,sun=0.27", 1),
]


def bench(binary, size, samples):
    """Shadow rays per second per thread, the truth (1 and 2 threads) and Embree (one thread: the
    rays of the truth's surface points, as many per pixel, uniform samples), the same rays."""
    rows = []
    for label, scene, scale in BENCH:
        with tempfile.TemporaryDirectory() as work:
            truth = {}
            for threads in (1, 2):
                env = dict(os.environ, RAYON_NUM_THREADS=str(threads))
                ref = os.path.join(work, f"ref{threads}")
                cmd = [binary, "reference", "--scene", scene, "--size", size, "--samples", str(samples),
                       "--emitter-scale", str(scale), "--out", ref]
                out = subprocess.run(cmd, capture_output=True, text=True, env=env)
                if out.returncode != 0:
                    sys.exit(f"embree_check: {' '.join(cmd)} failed:\n{out.stderr}")
                info = json.load(open(os.path.join(ref, "reference.json")))
                # Tracing only (the BVH build is reported apart): rays over the lights' seconds.
                seconds = sum(l["seconds"] for l in info["lights"])
                truth[threads] = info["rays"] / seconds / threads
            geometry = os.path.join(work, "scene.obj")
            run([binary, "export", "--scene", scene, "--emitter-scale", str(scale), "--out", geometry])
            desc, info, tris, positions, normals, lights = load_case(os.path.join(work, "ref1"), geometry)
            tracer = Embree(tris)
            rays, seconds = 0, 0.0
            rng = np.random.default_rng(5)
            for entry in info["lights"]:
                light = lights[entry["index"]]
                truth_v = read_f32(os.path.join(work, "ref1", entry["f32"]), 1)
                mask = ~np.isnan(truth_v)
                origin, n, eps = origins(desc, positions, normals, mask)
                per_pixel = 1 if light["emitter"].startswith("hard") else samples
                for _ in range(per_pixel):
                    dirs, tmax, _ = target_rays(origin, n, light, rng.random((len(origin), 2)))
                    o = np.ascontiguousarray(origin, dtype=np.float32)
                    d = np.ascontiguousarray(dirs, dtype=np.float32)
                    t = np.ascontiguousarray(np.where(np.isinf(tmax), 3.0e38, tmax - eps), dtype=np.float32)
                    start = time.perf_counter()
                    tracer.scene.run(o, d, dists=t, query="OCCLUDED")
                    seconds += time.perf_counter() - start
                    rays += len(o)
            embree = rays / seconds
            rows.append((label, len(tris), truth[1], truth[2], embree))
            print(f"{label}: {len(tris)} triangles; M shadow rays/s per thread: truth {truth[1] / 1e6:.2f} (1 thread), "
                  f"{truth[2] / 1e6:.2f} (2 threads), Embree {embree / 1e6:.2f} (1 thread); truth / Embree per "
                  f"thread {truth[1] / embree:.2f} and {truth[2] / embree:.2f}")
    return rows


def main():
    ap = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    ap.add_argument("--shadowlab", default=os.path.join(REPO, "target", "release", "shadowlab"))
    ap.add_argument("--size", default="128x96")
    ap.add_argument("--only", help="run only the cases whose label contains this")
    ap.add_argument("--bench", action="store_true", help="measure both tracers' speed instead of checking")
    ap.add_argument("--samples", type=int, default=64, help="emitter samples per pixel in --bench")
    args = ap.parse_args()
    if args.bench:
        bench(args.shadowlab, args.size, args.samples)
        return
    failures = []
    start = time.time()
    for label, scene, extra, scale in CASES:
        if args.only and args.only not in label:
            continue
        if not scene.startswith(("room",)) and not os.path.exists(scene):
            failures.append(f"{label}: {scene} is missing")
            continue
        print(f"{label}:")
        with tempfile.TemporaryDirectory() as work:
            failures += check_hard(args.shadowlab, label, scene, args.size, work, extra)
            failures += check_area(args.shadowlab, label, scene, args.size, work, extra, scale)
    print(f"embree_check: {time.time() - start:.1f} s")
    if failures:
        print("FAILED:\n  " + "\n  ".join(failures))
        sys.exit(1)
    print("embree_check: the truth agrees with Embree")


if __name__ == "__main__":
    main()
