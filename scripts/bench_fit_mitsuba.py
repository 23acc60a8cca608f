#!/usr/bin/env python3
"""Peer benchmark for `plsr bench fit`: the same material fit in Mitsuba 3.

Mirrors assets/scenes/fit-room/fit-room.toml in Mitsuba 3 and fits its ten
material parameters (floor base_color and roughness; back, left and right
reflectance; box base_color and roughness; ball base_color, roughness and
metallic) to a target photo with the `prb` integrator (path replay
backpropagation), an MSE loss and Adam (lr 0.05), starting from the scene's
guesses. It measures

  render_seconds         a plain primal render with the `path` integrator at
                         the same spp and depth (best of 3, after a warm-up);
  seconds_per_iteration  the mean time of one fitting iteration (render,
                         dr.backward, Adam step, clamping, params.update)
                         over the timed iterations, after --warmup untimed
                         ones (the first iterations JIT-compile kernels).

loss_first is the loss of the first (warm-up) iteration, loss_last that of
the last. Progress goes to stderr; the result is one line of JSON on stdout.
Variants without AD (--variant scalar_rgb) time the render only and report
null for the fit. Exits 2 if Mitsuba or the variant cannot be loaded.

Setup (Debian 12):

  pip install --break-system-packages mitsuba
  apt-get install -y libllvm19

The llvm_* variants need LLVM 19 (Dr.Jit aborts with LLVM 15): unless
DRJIT_LIBLLVM_PATH is set, this script points it at a libLLVM.so.19* in
/usr/lib, /usr/lib/* or /usr/lib/llvm-19/lib.

Run:

  python3 scripts/bench_fit_mitsuba.py --iterations 10 --threads 2
  python3 scripts/bench_fit_mitsuba.py --photo other.exr --spp 16
"""

import argparse
import glob
import json
import os
import sys
import time
from pathlib import Path

SCENE_DIR = Path(__file__).resolve().parent.parent / "assets/scenes/fit-room"

# plsr's max_depth counts scattering events; Mitsuba's counts path segments
# including the camera ray, hence + 1. Russian roulette: Mitsuba's default
# rr_depth = 5 is kept; with max_depth 5 it never triggers, which is fine.
PLSR_MAX_DEPTH = 4
MAX_DEPTH = PLSR_MAX_DEPTH + 1

# The guesses in fit-room.toml, the fit's starting point.
GUESSES = {
    "floor": {"type": "principled", "base_color": [0.5, 0.5, 0.5],
              "roughness": 0.6, "metallic": 0.0, "specular": 0.5},
    "back": {"type": "diffuse", "reflectance": [0.5, 0.5, 0.5]},
    "left": {"type": "diffuse", "reflectance": [0.5, 0.5, 0.5]},
    "right": {"type": "diffuse", "reflectance": [0.5, 0.5, 0.5]},
    "box": {"type": "principled", "base_color": [0.5, 0.5, 0.5],
            "roughness": 0.5, "metallic": 0.0},
    "ball": {"type": "principled", "base_color": [0.5, 0.5, 0.5],
             "roughness": 0.5, "metallic": 0.5},
}

# (material, parameter, lower bound, upper bound) for the fitted parameters.
FITTED = [
    ("floor", "base_color", 0.0, 1.0),
    ("floor", "roughness", 0.01, 1.0),
    ("back", "reflectance", 0.0, 1.0),
    ("left", "reflectance", 0.0, 1.0),
    ("right", "reflectance", 0.0, 1.0),
    ("box", "base_color", 0.0, 1.0),
    ("box", "roughness", 0.01, 1.0),
    ("ball", "base_color", 0.0, 1.0),
    ("ball", "roughness", 0.01, 1.0),
    ("ball", "metallic", 0.0, 1.0),
]

# Rectangles of fit-room.toml: (name, material, scale, rotation, translation),
# rotation as (axis, degrees) or None.
RECTANGLES = [
    ("floor", "floor", [2, 2, 2], None, [0, 0, 0]),
    ("back", "back", [2, 2, 2], ([1, 0, 0], 90), [0, 2, 1.2]),
    ("left", "left", [2, 2, 2], ([0, 1, 0], 90), [-2, 0, 1.2]),
    ("right", "right", [2, 2, 2], ([0, 1, 0], -90), [2, 0, 1.2]),
    ("box_top", "box", [0.4, 0.4, 0.4], None, [-0.6, 0.5, 0.8]),
    ("box_front", "box", [0.4, 0.4, 1], ([1, 0, 0], -90), [-0.6, 0.1, 0.4]),
    ("box_side", "box", [0.4, 0.4, 1], ([0, 1, 0], 90), [-0.2, 0.5, 0.4]),
]


def fail(message):
    print(f"bench_fit_mitsuba: {message}", file=sys.stderr)
    sys.exit(2)


def parse_args():
    p = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    p.add_argument("--photo", type=Path, default=SCENE_DIR / "photo.exr",
                   help="target: linear float EXR, 400x300 RGB "
                        "(default: the fit-room photo)")
    p.add_argument("--iterations", type=int, default=10,
                   help="timed iterations (default 10)")
    p.add_argument("--warmup", type=int, default=2,
                   help="untimed iterations first (default 2)")
    p.add_argument("--spp", type=int, default=16)
    p.add_argument("--threads", type=int,
                   help="Dr.Jit CPU threads (default: Dr.Jit's choice)")
    p.add_argument("--variant", default="llvm_ad_rgb",
                   help="Mitsuba variant (default llvm_ad_rgb)")
    args = p.parse_args()
    if args.iterations < 1 or args.warmup < 0:
        p.error("--iterations must be at least 1, --warmup at least 0")
    return args


def import_mitsuba(variant):
    """Imports and returns (mitsuba, drjit) with `variant` set, or exits 2."""
    if "DRJIT_LIBLLVM_PATH" not in os.environ:
        # Not "**": /usr/lib holds symlink cycles (llvm-*/build).
        found = sorted(glob.glob("/usr/lib/libLLVM.so.19*")
                       + glob.glob("/usr/lib/*/libLLVM.so.19*")
                       + glob.glob("/usr/lib/llvm-19/lib/libLLVM.so.19*"))
        if found:
            os.environ["DRJIT_LIBLLVM_PATH"] = found[0]
    try:
        import drjit as dr
        import mitsuba as mi
    except ImportError as e:
        fail(f"cannot import mitsuba: {e}")
    try:
        mi.set_variant(variant)
    except Exception as e:  # Mitsuba raises ImportError or RuntimeError.
        fail(f"cannot set variant {variant}: {e}".replace("\n", " "))
    return mi, dr


def bsdf(m):
    """A two-sided Mitsuba bsdf for one plsr material."""
    if m["type"] == "diffuse":
        inner = {"type": "diffuse",
                 "reflectance": {"type": "rgb", "value": m["reflectance"]}}
    else:
        inner = {
            "type": "principled",
            "base_color": {"type": "rgb", "value": m["base_color"]},
            "roughness": m["roughness"],
            "metallic": m["metallic"],
            "specular": m.get("specular", 0.5),
            "anisotropic": m.get("anisotropic", 0.0),
            "spec_tint": m.get("spec_tint", 0.0),
            "spec_trans": 0.0,
            "sheen": 0.0,
            "clearcoat": 0.0,
        }
    return {"type": "twosided", "bsdf": inner}


def rectangle(mi, material, scale, rotation, translation):
    to_world = mi.ScalarTransform4f().translate(translation)
    if rotation is not None:
        to_world = to_world.rotate(*rotation)
    return {"type": "rectangle", "to_world": to_world.scale(scale),
            "bsdf": {"type": "ref", "id": material}}


def scene_dict(mi, materials):
    """fit-room.toml as a Mitsuba scene dict, with `materials` by name."""
    # Materials first: mi.traverse names a parameter by the first path that
    # reaches it, and these names are the ones param_key expects.
    scene = {name: bsdf(material) for name, material in materials.items()}
    scene |= {
        "type": "scene",
        "integrator": {"type": "path", "max_depth": MAX_DEPTH},
        "camera": {
            "type": "perspective",
            "fov_axis": "y",
            "fov": 50,
            "to_world": mi.ScalarTransform4f().look_at(
                origin=[0.3, -3.6, 2.1], target=[0, 0.3, 0.7], up=[0, 0, 1]),
            "film": {"type": "hdrfilm", "width": 400, "height": 300,
                     "pixel_format": "rgb", "rfilter": {"type": "box"}},
        },
        "ball_shape": {"type": "sphere", "center": [0.7, 0.2, 0.45],
                       "radius": 0.45, "bsdf": {"type": "ref", "id": "ball"}},
        "light_1": {"type": "point", "position": [1.0, -1.2, 2.2],
                    "intensity": {"type": "rgb", "value": [6, 6, 6]}},
        "light_2": {"type": "point", "position": [-1.2, -0.5, 2.0],
                    "intensity": {"type": "rgb", "value": [3, 2.8, 2.5]}},
    }
    for name, material, *placement in RECTANGLES:
        scene[f"{name}_shape"] = rectangle(mi, material, *placement)
    return scene


def param_key(material, name):
    """The mi.traverse key of a material parameter (twosided's brdf_0)."""
    return f"{material}.brdf_0.{name}.value"


def load_target(mi, path):
    bitmap = mi.Bitmap(str(path)).convert(
        mi.Bitmap.PixelFormat.RGB, mi.Struct.Type.Float32, False)
    target = mi.TensorXf(bitmap)
    if target.shape != (300, 400, 3):
        fail(f"{path}: expected 400x300 RGB, got shape {target.shape}")
    return target


def force(dr, *values):
    dr.eval(*values)
    dr.sync_thread()


def time_render(mi, dr, scene, spp):
    """Best of 3 primal renders with the scene's `path` integrator, after a
    warm-up render."""
    times = []
    for seed in range(4):
        start = time.perf_counter()
        force(dr, mi.render(scene, spp=spp, seed=seed))
        times.append(time.perf_counter() - start)
    return min(times[1:])


def fit(mi, dr, scene, target, spp, warmup, iterations):
    """Runs the fit; returns (mean seconds per timed iteration, losses)."""
    params = mi.traverse(scene)
    keys = [param_key(m, n) for m, n, _, _ in FITTED]
    params.keep(keys)
    prb = mi.load_dict({"type": "prb", "max_depth": MAX_DEPTH})
    opt = mi.ad.Adam(lr=0.05)
    for key in keys:
        opt[key] = params[key]
    params.update(opt)

    losses, seconds = [], 0.0
    for i in range(warmup + iterations):
        start = time.perf_counter()
        image = mi.render(scene, params, integrator=prb, spp=spp, seed=i,
                          seed_grad=i + 100000)
        loss = dr.mean(dr.square(image - target), axis=None)
        dr.backward(loss)
        opt.step()
        for key, (_, _, lo, hi) in zip(keys, FITTED):
            opt[key] = dr.clip(opt[key], lo, hi)
        params.update(opt)
        force(dr, loss, *[opt[key] for key in keys])
        if i >= warmup:
            seconds += time.perf_counter() - start
        losses.append(loss.array[0])
        print(f"iteration {i}: loss {losses[-1]:.6g}", file=sys.stderr)
    return seconds / iterations, losses


def main():
    args = parse_args()
    mi, dr = import_mitsuba(args.variant)
    # Load before setting the thread count: with one thread (no workers),
    # Mitsuba 3.9's EXR reading hangs.
    target = load_target(mi, args.photo)
    if args.threads is not None:
        dr.set_thread_count(args.threads)
    # optimize=False: otherwise Mitsuba merges objects with equal properties,
    # and the three walls, whose guesses are equal, would share one bsdf.
    scene = mi.load_dict(scene_dict(mi, GUESSES), optimize=False)
    render_seconds = time_render(mi, dr, scene, args.spp)
    print(f"render: {render_seconds:.4f} s", file=sys.stderr)
    if "_ad_" in mi.variant():
        per_iteration, losses = fit(mi, dr, scene, target, args.spp,
                                    args.warmup, args.iterations)
    else:
        print(f"{mi.variant()} cannot differentiate: no fit, render time only",
              file=sys.stderr)
        per_iteration, losses = None, [None]
    print(json.dumps({
        "variant": mi.variant(),
        "mitsuba_version": mi.__version__,
        "seconds_per_iteration": per_iteration,
        "render_seconds": render_seconds,
        "iterations": args.iterations,
        "spp": args.spp,
        "threads": dr.thread_count(),
        "loss_first": losses[0],
        "loss_last": losses[-1],
    }))


if __name__ == "__main__":
    main()
