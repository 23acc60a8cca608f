#!/usr/bin/env python3
"""Makes the image pairs of tests/fixtures/metrics/ and their reference
scores from the metrics' reference implementations, once; `tests/metrics.rs`
checks plsr's scores against them.

The pairs are crops of docs/img/compositing.png (a photo of a room, the
mask of a virtual ball, and the composite with the ball) and distortions of
the photo crop: noise, blur, darkening, a shift, JPEG compression.

References (PyPI): pyiqa 0.1.16 for CW-SSIM (`cw_ssim`: level 4, 8
orientations, K = 0, the grey of YIQ's Y rounded to 0-255, its port of the
authors' MATLAB `cwssim_index`), SSIM (`ssim`, Y channel) and PSNR (`psnr`,
RGB). Run it in a virtual environment that has them:

    python3 -m venv /tmp/refenv
    /tmp/refenv/bin/pip install numpy pillow torch pyiqa
    /tmp/refenv/bin/python scripts/metrics_reference.py

It rewrites tests/fixtures/metrics/*.png and reference.json.
"""
import io
import json
import pathlib

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

    def tensor(name):
        # Read back from the PNG: the scores are of the files as stored.
        x = np.asarray(Image.open(OUT / f"{name}.png").convert("RGB")).astype(np.float64) / 255
        return torch.from_numpy(x).permute(2, 0, 1)[None].to(torch.float64)

    table = []
    for ref, test in pairs:
        row = {"reference": f"{ref}.png", "test": f"{test}.png"}
        for key, m in metrics.items():
            if key == "psnr" and ref == test:
                continue  # pyiqa's eps makes it 80 dB; plsr says infinite
            row[key] = float(m(tensor(test), tensor(ref)).item())
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
                },
                "pairs": table,
            },
            indent=2,
        )
        + "\n"
    )


if __name__ == "__main__":
    main()
