#!/usr/bin/env python3
"""Mitsuba 3's own BSDF values, for plsr's tests to compare with.

Evaluates Mitsuba's `principled` BSDF (mitsuba.scalar_rgb) for a set of
parameter sets and pairs of directions, and writes f (without the cosine,
plsr's convention) and the sampling density of each pair as JSON:

    python3 scripts/mitsuba_bsdf_values.py -o tests/data/mitsuba_bsdf/principled.json

Directions are in the local shading frame (z the normal). plsr's `wo`
(towards the viewer) is Mitsuba's `si.wi`; plsr's `wi` (towards the light)
is Mitsuba's `wo`.
"""
import argparse
import json
import math

import mitsuba as mi

mi.set_variant("scalar_rgb")

# Parameter sets: each lobe on its own, then together, then transmission.
PARAMS = [
    {"base_color": [0.8, 0.5, 0.3], "roughness": 0.5, "sheen": 0.7, "sheen_tint": 0.5},
    {"base_color": [0.2, 0.4, 0.8], "roughness": 0.3, "clearcoat": 0.9, "clearcoat_gloss": 0.6},
    {"base_color": [0.6, 0.6, 0.2], "roughness": 0.7, "flatness": 0.8},
    {"base_color": [0.7, 0.3, 0.3], "roughness": 0.4, "metallic": 0.3, "spec_tint": 0.6,
     "sheen": 0.4, "clearcoat": 0.5, "flatness": 0.3, "anisotropic": 0.5},
    {"base_color": [0.9, 0.8, 0.6], "roughness": 0.35, "spec_trans": 0.7, "metallic": 0.1},
    {"base_color": [0.5, 0.9, 0.7], "roughness": 0.6, "spec_trans": 1.0, "eta": 1.33,
     "clearcoat": 0.3, "sheen": 0.5},
]


def unit(x, y, z):
    n = math.sqrt(x * x + y * y + z * z)
    return [x / n, y / n, z / n]


# (wo, wi) pairs: reflection above, transmission both ways, reflection inside.
PAIRS = [
    (unit(0.3, -0.2, 0.9), unit(-0.4, 0.1, 0.7)),
    (unit(0.3, -0.2, 0.9), unit(-0.3, 0.2, 0.93)),
    (unit(0.8, 0.1, 0.3), unit(-0.7, 0.2, 0.4)),
    (unit(0.1, 0.6, 0.5), unit(0.5, -0.5, 0.2)),
    (unit(0.0, 0.0, 1.0), unit(0.2, 0.1, 0.97)),
    (unit(0.3, -0.2, 0.9), unit(-0.2, 0.1, -0.95)),
    (unit(0.5, 0.3, 0.6), unit(-0.3, -0.2, -0.8)),
    (unit(0.2, 0.1, -0.9), unit(-0.3, 0.0, -0.8)),
    (unit(0.2, 0.1, -0.9), unit(-0.2, -0.1, 0.9)),
    (unit(0.6, 0.0, -0.5), unit(-0.5, 0.1, 0.7)),
]


def bsdf_of(params):
    d = {"type": "principled"}
    for k, v in params.items():
        d[k] = {"type": "rgb", "value": v} if isinstance(v, list) else v
    return mi.load_dict(d)


def main():
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("-o", "--output", required=True)
    args = ap.parse_args()
    ctx = mi.BSDFContext()
    cases = []
    for params in PARAMS:
        bsdf = bsdf_of(params)
        rows = []
        for wo, wi in PAIRS:
            si = mi.SurfaceInteraction3f()
            si.sh_frame = mi.Frame3f(mi.Vector3f(0, 0, 1))
            si.n = mi.Normal3f(0, 0, 1)
            si.wi = mi.Vector3f(wo)
            value = bsdf.eval(ctx, si, mi.Vector3f(wi))
            pdf = bsdf.pdf(ctx, si, mi.Vector3f(wi))
            f = [float(value[c]) / abs(wi[2]) for c in range(3)]
            rows.append({"wo": wo, "wi": wi, "f": f, "pdf": float(pdf)})
        cases.append({"params": params, "pairs": rows})
    with open(args.output, "w") as out:
        json.dump({"mitsuba": mi.__version__, "bsdf": "principled", "cases": cases}, out, indent=1)
        out.write("\n")


if __name__ == "__main__":
    main()
