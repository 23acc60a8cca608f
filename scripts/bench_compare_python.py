#!/usr/bin/env python3
"""Peer benchmark for `plsr bench compare`: the reference implementations
of CW-SSIM (pyiqa's `cw_ssim`) and LPIPS (the `lpips` package, AlexNet
v0.1) scoring the same image pairs as plsr, on the CPU.

For each pair (REF TEST given as --pair REF TEST, repeatable) it loads the
PNGs once, then times each metric on the loaded images (best of --repeat
runs, after one warm-up run for the small images), and prints one line of
JSON on stdout: {"torch": version, "threads": n, "pairs": [{"reference":
..., "cwssim": value, "cwssim_seconds": s, "lpips": value,
"lpips_seconds": s}, ...]}. LPIPS's AlexNet gets random weights (the
`lpips` package would download the trained ones; the cost is the same);
its value is therefore not LPIPS and is reported as null.

Setup: pip install numpy pillow torch torchvision pyiqa lpips
"""
import argparse
import json
import sys
import time

import numpy as np
import torch
from PIL import Image

Image.MAX_IMAGE_PIXELS = None


def load(path):
    x = np.asarray(Image.open(path).convert("RGB")).astype(np.float32) / 255
    return torch.from_numpy(x).permute(2, 0, 1)[None].contiguous()


def best(fn, repeat, warm):
    if warm:
        fn()
    times = []
    value = None
    for _ in range(repeat):
        start = time.perf_counter()
        value = fn()
        times.append(time.perf_counter() - start)
    return value, min(times)


def main():
    p = argparse.ArgumentParser()
    p.add_argument("--pair", nargs=2, action="append", required=True)
    p.add_argument("--repeat", type=int, default=3)
    p.add_argument("--threads", type=int)
    a = p.parse_args()
    if a.threads:
        torch.set_num_threads(a.threads)
    import pyiqa
    import lpips

    cw = pyiqa.create_metric("cw_ssim", device="cpu", as_loss=False)
    net = lpips.LPIPS(net="alex", pnet_rand=True, verbose=False).eval()
    rows = []
    for ref, test in a.pair:
        x, y = load(ref), load(test)
        small = x.shape[2] * x.shape[3] < 4_000_000
        repeat = a.repeat if small else 1
        with torch.no_grad():
            c, tc = best(lambda: float(cw(y, x).item()), repeat, small)
            _, tl = best(lambda: float(net(y, x, normalize=True).item()), repeat, small)
        rows.append(
            {
                "reference": ref,
                "width": x.shape[3],
                "height": x.shape[2],
                "cwssim": c,
                "cwssim_seconds": tc,
                "lpips": None,
                "lpips_seconds": tl,
            }
        )
        print(rows[-1], file=sys.stderr)
    print(json.dumps({"torch": torch.__version__, "threads": torch.get_num_threads(), "pairs": rows}))


if __name__ == "__main__":
    main()
