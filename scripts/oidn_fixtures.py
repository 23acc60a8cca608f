#!/usr/bin/env python3
"""Writes the small reference images plsr's denoiser is tested against
(crates/denoise/tests/data/): a synthetic noisy image with its albedo and
normal, and Intel Open Image Denoise's RT filter's output for it in each
mode plsr ships weights for, made by OIDN 2.5.1 through PyPI's `pyoidn`.

    python3 -m venv /tmp/oidn && /tmp/oidn/bin/pip install pyoidn==2.5.1.0 numpy
    /tmp/oidn/bin/python scripts/oidn_fixtures.py

The image is 37×29 pixels, so the network's padding to multiples of 16 is
exercised. Quality is "balanced": it picks the base network in every mode
(OIDN's "high" takes a large network for clean auxiliaries, which plsr
does not ship). Images are PFM files (three float32 channels, rows bottom
to top); `inputs.txt` lists what each output was made from.
"""
import os

import numpy as np
import pyoidn

ROOT = os.path.dirname(os.path.dirname(os.path.abspath(__file__)))
OUT = os.path.join(ROOT, "crates", "denoise", "tests", "data")
W, H = 37, 29


def write_pfm(name, a):
    with open(os.path.join(OUT, name), "wb") as f:
        f.write(b"PF\n%d %d\n-1.0\n" % (W, H))
        np.ascontiguousarray(a[::-1], dtype="<f4").tofile(f)


def scene():
    """A lit sphere in front of a wall, with Monte Carlo-like noise: colour
    (HDR, a highlight above 1), albedo and camera-space normals."""
    rng = np.random.default_rng(53)
    y, x = np.mgrid[0:H, 0:W].astype(np.float32)
    u, v = (x + 0.5) / W * 2 - 1, (y + 0.5) / H * 2 - 1
    r2 = (u / 0.6) ** 2 + (v / 0.75) ** 2
    inside = r2 < 1
    nz = np.sqrt(np.clip(1 - r2, 0, 1))
    normal = np.where(inside[..., None], np.dstack([u / 0.6, -v / 0.75, nz]), [0, 0, 1]).astype(np.float32)
    albedo = np.where(inside[..., None], [0.8, 0.3, 0.2], [0.5, 0.55, 0.6]).astype(np.float32)
    light = np.array([0.4, 0.6, 0.7], np.float32)
    shade = np.clip((normal * light).sum(-1), 0, None)[..., None]
    clean = albedo * (0.2 + 3.0 * shade ** 4)
    noise = rng.gamma(0.6, 1 / 0.6, size=(H, W, 3)).astype(np.float32)
    color = (clean * noise).astype(np.float32)
    return color, albedo, normal


def run(color, albedo=None, normal=None, hdr=True, clean=False):
    return pyoidn.denoise(color, albedo=albedo, normal=normal, hdr=hdr, clean_aux=clean,
                          quality="balanced")


def prefilter(image, which):
    """OIDN's prefilter of an auxiliary layer: the RT filter given only
    that layer (quality balanced takes the base network, rt_alb/rt_nrm)."""
    out = np.zeros_like(image)
    dev = pyoidn.Device(pyoidn.OIDN_DEVICE_TYPE_CPU)
    dev.commit()
    flt = pyoidn.Filter(dev, "RT")
    flt.set_image(which, image, pyoidn.OIDN_FORMAT_FLOAT3)
    flt.set_image("output", out, pyoidn.OIDN_FORMAT_FLOAT3)
    flt.set_int("quality", pyoidn.OIDN_QUALITY_BALANCED)
    flt.commit()
    assert dev.get_error() is None, dev.get_error()
    flt.execute()
    assert dev.get_error() is None, dev.get_error()
    flt.release()
    dev.release()
    return out


def main():
    os.makedirs(OUT, exist_ok=True)
    color, albedo, normal = scene()
    ldr = np.clip(color / 4, 0, 1).astype(np.float32)
    write_pfm("color.pfm", color)
    write_pfm("ldr.pfm", ldr)
    write_pfm("albedo.pfm", albedo)
    write_pfm("normal.pfm", normal)
    rng = np.random.default_rng(54)
    noisy_albedo = np.clip(albedo + rng.normal(0, 0.15, albedo.shape), 0, 1).astype(np.float32)
    noisy_normal = np.clip(normal + rng.normal(0, 0.3, normal.shape), -1, 1).astype(np.float32)
    write_pfm("noisy_albedo.pfm", noisy_albedo)
    write_pfm("noisy_normal.pfm", noisy_normal)
    cases = {
        "rt_hdr.pfm": run(color),
        "rt_hdr_alb.pfm": run(color, albedo),
        "rt_hdr_alb_nrm.pfm": run(color, albedo, normal),
        "rt_hdr_calb_cnrm.pfm": run(color, albedo, normal, clean=True),
        "rt_ldr_alb_nrm.pfm": run(ldr, albedo, normal, hdr=False),
        "rt_alb.pfm": prefilter(noisy_albedo, "albedo"),
        "rt_nrm.pfm": prefilter(noisy_normal, "normal"),
    }
    for name, image in cases.items():
        write_pfm(name, image)
    with open(os.path.join(OUT, "inputs.txt"), "w") as f:
        f.write("Made by scripts/oidn_fixtures.py with OIDN 2.5.1 (pyoidn 2.5.1.0), quality balanced.\n")
        f.write("rt_hdr: color.pfm, hdr\nrt_hdr_alb: color, albedo, hdr\n")
        f.write("rt_hdr_alb_nrm: color, albedo, normal, hdr\n")
        f.write("rt_hdr_calb_cnrm: color, albedo, normal, hdr, cleanAux\n")
        f.write("rt_ldr_alb_nrm: ldr.pfm, albedo, normal (LDR)\n")
        f.write("rt_alb: noisy_albedo.pfm alone (the albedo prefilter)\n")
        f.write("rt_nrm: noisy_normal.pfm alone (the normal prefilter)\n")
    print("wrote", sorted(os.listdir(OUT)))


if __name__ == "__main__":
    main()
