#!/usr/bin/env python3
"""Filters the denoiser's render fixtures (tests/fixtures/denoise/) with
Intel Open Image Denoise 2.5.1 (PyPI's `pyoidn`), the reference plsr's
denoiser is tested against (`renders_are_denoised_as_oidn_denoises_them` in
tests/it/denoising.rs).

Two steps make the fixtures:

    cargo test --test it write_denoise_fixtures -- --ignored
    python3 -m venv /tmp/oidn && /tmp/oidn/bin/pip install pyoidn==2.5.1.0 numpy
    /tmp/oidn/bin/python scripts/oidn_render_fixtures.py

The first renders each case of `cases.txt` (scenes, spp and sizes in the
test) and writes the colour, albedo and normal exactly as plsr's denoiser
is given them, as gzipped half floats (RGB rows from the top). This script
filters each with OIDN's RT filter: HDR, quality "balanced" (the base
network plsr runs), noisy guides (cleanAux off), on the same half-float
values read back as float32, and writes NAME.oidn.f16.gz beside them.
"""
import gzip
import os

import numpy as np
import pyoidn

ROOT = os.path.dirname(os.path.dirname(os.path.abspath(__file__)))
DIR = os.path.join(ROOT, "tests", "fixtures", "denoise")


def read(name, what, w, h):
    with gzip.open(os.path.join(DIR, f"{name}.{what}.f16.gz"), "rb") as f:
        data = np.frombuffer(f.read(), dtype="<f2")
    return np.ascontiguousarray(data.astype(np.float32).reshape(h, w, 3))


def main():
    with open(os.path.join(DIR, "cases.txt")) as f:
        cases = [line.split() for line in f if line.strip()]
    for name, w, h in cases:
        w, h = int(w), int(h)
        color, albedo, normal = (read(name, k, w, h) for k in ("color", "albedo", "normal"))
        out = pyoidn.denoise(color, albedo=albedo, normal=normal, hdr=True, clean_aux=False,
                             quality="balanced")
        data = gzip.compress(np.ascontiguousarray(out, dtype="<f2").tobytes(), compresslevel=9,
                             mtime=0)
        with open(os.path.join(DIR, f"{name}.oidn.f16.gz"), "wb") as f:
            f.write(data)
        print(f"{name}: {w}x{h}, mean {color.mean():.4f} -> {out.mean():.4f}")


if __name__ == "__main__":
    main()
