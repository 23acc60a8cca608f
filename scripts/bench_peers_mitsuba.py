#!/usr/bin/env python3
"""Peer renderer for `plsr bench peers`: Mitsuba 3 on the same scenes.

`plsr bench peers` writes each scene twice, in plsr's format and as Mitsuba 3
XML (the meshes as shared OBJ files, the environment as a shared EXR), and
starts this script with a JSON job list:

  {"threads": 2, "scenes": [{"name": "cornell", "xml": ".../cornell.xml",
   "spp": 64, "image": ".../cornell.mitsuba.f32"}, ...]}

For each scene it loads the XML, renders once at the job's spp to compile
Dr.Jit's kernels (untimed), then renders `--repeats` more times with other
seeds and keeps the fastest; every timed render's image is written, one
after the other, as raw little-endian float32 RGB rows (top row first) to the
job's `image` path (plsr scores each against its reference and averages). Progress goes to
stderr; the result is one line of JSON on stdout:

  {"mitsuba_version": "3.x", "variant": "llvm_ad_rgb",
   "scenes": [{"name": ..., "seconds": ..., "width": ..., "height": ...}]}

Exits 2 if Mitsuba or the variant cannot be loaded.

Setup (Debian 12):

  pip install --break-system-packages mitsuba
  apt-get install -y libllvm19

The llvm_* variants need LLVM 19 (Dr.Jit aborts with LLVM 15 on path-tracing
kernels): unless DRJIT_LIBLLVM_PATH is set, this script points it at a
libLLVM.so.19* in /usr/lib, /usr/lib/* or /usr/lib/llvm-19/lib.
"""

import argparse
import glob
import json
import os
import sys
import time


def find_llvm19():
    if os.environ.get("DRJIT_LIBLLVM_PATH"):
        return
    for pattern in ("/usr/lib/libLLVM.so.19*", "/usr/lib/*/libLLVM.so.19*",
                    "/usr/lib/llvm-19/lib/libLLVM.so*", "/usr/lib/*/libLLVM-19.so"):
        hits = sorted(glob.glob(pattern))
        if hits:
            os.environ["DRJIT_LIBLLVM_PATH"] = hits[0]
            return


def raw_tracing(mi, dr, np, scene, count):
    """Closest-hit throughput (Mrays/s) for `count` incoherent random rays,
    as `plsr bench peers` measures Embree's: origins uniform in the scene's
    bounding box, directions uniform on the sphere. Mitsuba's
    `ray_intersect_preliminary` (the hit alone) and `ray_intersect` (with
    the surface interaction); kernels compiled by an untimed pass, then the
    best of two."""
    bbox = scene.bbox()
    lo, hi = np.array(bbox.min), np.array(bbox.max)
    rng = np.random.default_rng(12345)
    o = lo + (hi - lo) * rng.random((count, 3))
    u = rng.random((count, 2))
    z = 1.0 - 2.0 * u[:, 0]
    r = np.sqrt(np.maximum(0.0, 1.0 - z * z))
    phi = 2.0 * np.pi * u[:, 1]
    d = np.stack([r * np.cos(phi), r * np.sin(phi), z], axis=1)
    f = lambda a: mi.Float(np.ascontiguousarray(a, dtype=np.float32))
    rays = mi.Ray3f(mi.Point3f(f(o[:, 0]), f(o[:, 1]), f(o[:, 2])),
                    mi.Vector3f(f(d[:, 0]), f(d[:, 1]), f(d[:, 2])))
    dr.eval(rays.o, rays.d)
    dr.sync_thread()
    out = {}
    for key, query in (("raw_mrays_preliminary", scene.ray_intersect_preliminary),
                       ("raw_mrays", scene.ray_intersect)):
        best = float("inf")
        for _ in range(3):
            t = time.perf_counter()
            hit = query(rays)
            dr.eval(hit.t)
            dr.sync_thread()
            best = min(best, time.perf_counter() - t)
        out[key] = count / best / 1e6
    return out


def main():
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("jobs", help="the JSON job list plsr wrote")
    ap.add_argument("--variant", default="llvm_ad_rgb")
    ap.add_argument("--repeats", type=int, default=2)
    args = ap.parse_args()
    with open(args.jobs) as f:
        jobs = json.load(f)

    find_llvm19()
    try:
        import mitsuba as mi
        import drjit as dr
        import numpy as np
        mi.set_variant(args.variant)
    except Exception as e:  # noqa: BLE001 - any import failure means "no peer"
        print(f"cannot load Mitsuba 3 ({args.variant}): {e}", file=sys.stderr)
        sys.exit(2)
    threads = jobs.get("threads")
    if threads:
        dr.set_thread_count(int(threads))

    results = []
    for job in jobs["scenes"]:
        name, spp = job["name"], int(job["spp"])
        print(f"mitsuba: {name}: loading", file=sys.stderr)
        scene = mi.load_file(job["xml"])
        print(f"mitsuba: {name}: warm-up render at {spp} spp", file=sys.stderr)
        image = scene.integrator().render(scene, seed=1000, spp=spp)
        dr.eval(image)
        dr.sync_thread()
        best = float("inf")
        frames = []
        for r in range(max(1, args.repeats)):
            t = time.perf_counter()
            image = scene.integrator().render(scene, seed=r + 1, spp=spp)
            dr.eval(image)
            dr.sync_thread()
            best = min(best, time.perf_counter() - t)
            frames.append(np.array(image, dtype=np.float32)[:, :, :3].astype("<f4"))
        height, width = frames[0].shape[0], frames[0].shape[1]
        np.concatenate([f.ravel() for f in frames]).tofile(job["image"])
        print(f"mitsuba: {name}: {best:.3f} s", file=sys.stderr)
        result = {"name": name, "seconds": best, "width": width, "height": height}
        if job.get("raw_rays"):
            result.update(raw_tracing(mi, dr, np, scene, int(job["raw_rays"])))
            print(f"mitsuba: {name}: raw tracing {result}", file=sys.stderr)
        results.append(result)
    print(json.dumps({"mitsuba_version": mi.__version__, "variant": args.variant,
                      "scenes": results}))


if __name__ == "__main__":
    main()
