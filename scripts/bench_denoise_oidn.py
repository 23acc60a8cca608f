#!/usr/bin/env python3
"""Peer denoiser for `plsr bench denoise`: Intel Open Image Denoise (PyPI's
`pyoidn`) on the same images plsr's denoiser is given.

    bench_denoise_oidn.py WIDTH HEIGHT COLOR.f32 [ALBEDO.f32 NORMAL.f32]
                          --output OUT.f32 [--threads N] [--repeats N]

Each image is raw little-endian float32 RGB rows, top row first. The RT
filter runs with `hdr`, quality "balanced" (OIDN's base network, the one
plsr runs) and noisy auxiliary images (`cleanAux` off), once untimed (the
device's start-up), then `--repeats` times; the fastest is its time. The
output of the last run is written to OUT.f32. The result is one line of
JSON on stdout:

  {"oidn": "2.5.1", "threads": 2, "seconds": [..], "best": ..}

Set-up: python3 -m venv VENV && VENV/bin/pip install pyoidn numpy
"""

import argparse
import json
import sys
import time


def main():
    ap = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    ap.add_argument("width", type=int)
    ap.add_argument("height", type=int)
    ap.add_argument("images", nargs="+", help="colour, then optionally albedo and normal")
    ap.add_argument("--output", required=True)
    ap.add_argument("--threads", type=int, default=0, help="0: all cores")
    ap.add_argument("--repeats", type=int, default=2)
    args = ap.parse_args()
    try:
        import numpy as np
        import pyoidn
    except ImportError as e:
        print(f"cannot load pyoidn: {e}", file=sys.stderr)
        sys.exit(2)

    shape = (args.height, args.width, 3)
    images = [np.fromfile(p, dtype="<f4").reshape(shape) for p in args.images]
    color = images[0]
    albedo = images[1] if len(images) > 1 else None
    normal = images[2] if len(images) > 2 else None
    out = np.zeros_like(color)

    device = pyoidn.Device(pyoidn.OIDN_DEVICE_TYPE_CPU)
    if args.threads > 0:
        device.set_int("numThreads", args.threads)
    device.commit()
    if device.get_error() is not None:
        raise SystemExit(f"OIDN device: {device.get_error()}")

    def run():
        flt = pyoidn.Filter(device, "RT")
        flt.set_image("color", color, pyoidn.OIDN_FORMAT_FLOAT3)
        if albedo is not None:
            flt.set_image("albedo", albedo, pyoidn.OIDN_FORMAT_FLOAT3)
        if normal is not None:
            flt.set_image("normal", normal, pyoidn.OIDN_FORMAT_FLOAT3)
        flt.set_image("output", out, pyoidn.OIDN_FORMAT_FLOAT3)
        flt.set_bool("hdr", True)
        flt.set_int("quality", pyoidn.OIDN_QUALITY_BALANCED)
        start = time.perf_counter()
        flt.commit()
        flt.execute()
        seconds = time.perf_counter() - start
        error = device.get_error()
        flt.release()
        if error is not None:
            raise SystemExit(f"OIDN: {error}")
        return seconds

    run()
    times = [run() for _ in range(max(1, args.repeats))]
    out.astype("<f4").tofile(args.output)
    threads = device.get_int("numThreads") if hasattr(device, "get_int") else args.threads
    try:
        from importlib.metadata import version
        oidn_version = version("pyoidn")
    except Exception:  # noqa: BLE001 - the version is only printed
        oidn_version = "?"
    print(json.dumps({"oidn": oidn_version, "threads": threads,
                      "seconds": times, "best": min(times)}))


if __name__ == "__main__":
    main()
