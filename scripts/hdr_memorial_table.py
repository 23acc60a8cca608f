#!/usr/bin/env python3
"""Regenerates docs/hdr.md's Memorial table: plsr's merges of Paul Debevec's
Memorial Church stack (default, Robertson, without black levels, deghosted)
and OpenCV's Debevec and Robertson merges, each against Debevec's own
radiance map, as log2-RMSE after one global scale over every pixel, the
brightest 1 % and the darkest 10 % of the map's luminance (the measure of
plsr-hdr's reference.rs), with each merge's wall time.

Needs Python 3 with numpy and opencv-python-headless, and a built plsr:

    python3 scripts/hdr_memorial_table.py [STACK_DIR] [--plsr target/release/plsr]

STACK_DIR holds memorial0061.png … memorial0076.png, shutter_times.txt
(longest first) and memorial.hdr; by default the halved copy in
tests/data/realworld/hdr/memorial/.
"""
import argparse
import os
import subprocess
import sys
import tempfile
import time

import cv2
import numpy as np

ROOT = os.path.dirname(os.path.dirname(os.path.abspath(__file__)))


def errors(merged, reference):
    """log2-RMSE (all, brightest 1 %, darkest 10 %) after the mean log offset."""
    lum = reference @ np.array([0.2126, 0.7152, 0.0722])
    valid = (reference > 0).all(axis=2)
    m = np.where(merged > 0, merged, 1e-12)
    d = np.log2(m) - np.log2(np.where(reference > 0, reference, 1.0))
    d = d - d[valid].mean()
    hi, lo = np.quantile(lum, 0.99), np.quantile(lum, 0.10)

    def rmse(sel):
        return float(np.sqrt((d[sel & valid] ** 2).mean()))

    return rmse(np.ones_like(valid)), rmse(lum >= hi), rmse(lum <= lo)


def parse_time(text):
    """`1/1024`, `0.5` or `32` seconds."""
    num, _, den = text.partition("/")
    return float(num) / float(den) if den else float(num)


def read_rgb(path):
    img = cv2.imread(path, cv2.IMREAD_UNCHANGED)
    if img is None and path.endswith(".hdr"):
        # Debevec's map has header lines before Radiance's `#?` magic,
        # which OpenCV refuses: read it from the magic on.
        data = open(path, "rb").read()
        with tempfile.NamedTemporaryFile(suffix=".hdr") as f:
            f.write(data[data.find(b"#?"):])
            f.flush()
            img = cv2.imread(f.name, cv2.IMREAD_UNCHANGED)
    if img is None:
        sys.exit(f"cannot read {path}")
    return img[:, :, ::-1].astype(np.float64)


def main():
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("stack", nargs="?",
                    default=os.path.join(ROOT, "tests/data/realworld/hdr/memorial"))
    ap.add_argument("--plsr", default=os.path.join(ROOT, "target/release/plsr"))
    a = ap.parse_args()
    files = [os.path.join(a.stack, f"memorial{n:04d}.png") for n in range(61, 77)]
    times_text = [l.strip() for l in open(os.path.join(a.stack, "shutter_times.txt")) if l.strip()]
    times = [parse_time(t) for t in times_text]
    reference = read_rgb(os.path.join(a.stack, "memorial.hdr"))
    rows = []
    with tempfile.TemporaryDirectory() as tmp:
        variants = [
            ("plsr, default", []),
            ("plsr `--response robertson`", ["--response", "robertson"]),
            ("plsr `--black-level 0`", ["--black-level", "0"]),
            ("plsr `--deghost`", ["--deghost"]),
        ]
        for name, extra in variants:
            out = os.path.join(tmp, "m.tif")
            t0 = time.time()
            subprocess.run([a.plsr, "hdr", "merge", *files, "-o", out, "-q",
                            "--exposures", ",".join(times_text), *extra],
                           check=True, stderr=subprocess.DEVNULL)
            rows.append((name, errors(read_rgb(out), reference), time.time() - t0))
        images = [cv2.imread(f) for f in files]
        t = np.array(times, dtype=np.float32)
        for name, calibrate, merge in [
            ("OpenCV `CalibrateDebevec` + `MergeDebevec`",
             cv2.createCalibrateDebevec(), cv2.createMergeDebevec()),
            ("OpenCV `CalibrateRobertson` + `MergeRobertson`",
             cv2.createCalibrateRobertson(), cv2.createMergeRobertson()),
        ]:
            t0 = time.time()
            curve = calibrate.process(images, t)
            merged = merge.process(images, t, curve)
            rows.append((name, errors(merged[:, :, ::-1].astype(np.float64), reference),
                         time.time() - t0))
    print(f"Memorial stack {reference.shape[1]}×{reference.shape[0]}, OpenCV {cv2.__version__}")
    print("| method | all pixels | brightest 1 % | darkest 10 % | s |")
    print("| --- | --- | --- | --- | --- |")
    for name, (e_all, e_hi, e_lo), s in rows:
        print(f"| {name} | {e_all:.3f} | {e_hi:.3f} | {e_lo:.3f} | {s:.2f} |")


if __name__ == "__main__":
    main()
