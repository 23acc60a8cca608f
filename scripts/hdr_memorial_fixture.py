#!/usr/bin/env python3
"""Writes the downscaled copy of Paul Debevec's Memorial Church stack that
`make test` merges (tests/data/realworld/hdr/memorial/).

    python3 scripts/hdr_memorial_fixture.py SRC_DIR [OUT_DIR]

SRC_DIR holds memorial0061.png … memorial0076.png (16 exposures, 512×768,
32 s … 1/1024 s) and memorial.hdr, Debevec's radiance map of them. Each
bracket is halved by decimation, the
radiance map likewise: every second pixel of every second row, so each pixel
of the copy is a pixel of the real stack, with its pedestal, noise,
registration border and scanner's response, at a quarter of the size.
(Averaging codes would mix the two sides of every window's edge into
values no exposure of the scene gives.) Needs
numpy and opencv-python-headless. Files are written under a temporary name
and renamed.
"""
import os
import sys

import cv2
import numpy as np

TIMES = ["32", "16", "8", "4", "2", "1", "1/2", "1/4", "1/8", "1/16", "1/32",
         "1/64", "1/128", "1/256", "1/512", "1/1024"]


def halve(a):
    return np.ascontiguousarray(a[0::2, 0::2])


def read_radiance(path):
    """Reads a Radiance file whose header may start with lines before
    `#?RADIANCE` (Debevec's starts with a VIEW= line), through OpenCV."""
    data = open(path, "rb").read()
    start = data.find(b"#?")
    if start < 0:
        sys.exit(f"{path}: no #? magic line")
    tmp = path + ".tmp.hdr" if os.access(os.path.dirname(path) or ".", os.W_OK) else "/tmp/memorial-ref.hdr"
    with open(tmp, "wb") as f:
        f.write(data[start:])
    img = cv2.imread(tmp, cv2.IMREAD_UNCHANGED)
    os.remove(tmp)
    if img is None:
        sys.exit(f"{path}: OpenCV cannot read it")
    return img


def write(path, img):
    tmp = path + ".part" + os.path.splitext(path)[1]
    if not cv2.imwrite(tmp, img):
        sys.exit(f"{tmp}: cannot write")
    os.replace(tmp, path)


def main():
    if len(sys.argv) not in (2, 3):
        sys.exit(__doc__)
    src = sys.argv[1]
    out = sys.argv[2] if len(sys.argv) == 3 else os.path.join(
        os.path.dirname(__file__), "..", "tests", "data", "realworld", "hdr", "memorial")
    os.makedirs(out, exist_ok=True)
    for n in range(61, 77):
        name = f"memorial{n:04d}.png"
        img = cv2.imread(os.path.join(src, name), cv2.IMREAD_COLOR)
        if img is None:
            sys.exit(f"{src}/{name}: cannot read")
        write(os.path.join(out, name), halve(img))
    ref = halve(read_radiance(os.path.join(src, "memorial.hdr")))
    write(os.path.join(out, "memorial.hdr"), ref)
    with open(os.path.join(out, "shutter_times.txt"), "w") as f:
        f.write("\n".join(TIMES) + "\n")


if __name__ == "__main__":
    main()
