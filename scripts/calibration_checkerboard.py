#!/usr/bin/env python3
"""Renders a chessboard through a known distorted lens with plsr, then lets
OpenCV find its corners and calibrate the camera, as a user would with real
photos. Writes the fixture of the test `checkerboard_renders_calibrate_to_the_true_camera`
(tests/it/calibration.rs):

  tests/fixtures/calibration/checkerboard/calibration.yaml
      OpenCV's calibration (cv::FileStorage: image size, camera_matrix,
      distortion_coefficients, extrinsic_parameters, avg_reprojection_error)
  tests/fixtures/calibration/checkerboard/views.json
      the true camera (intrinsics, coefficients, each view's pose) and, per
      view, the corners OpenCV detected (pixels, OpenCV's convention)

Run from the repository's root with OpenCV (PyPI opencv-python-headless)
and OpenEXR installed, after `cargo build --release -p plsr-cli`:

  python3 scripts/calibration_checkerboard.py [--plsr target/release/plsr]

The board lies in the world's z = 0 plane with its inner corners at
(i*SQUARE, j*SQUARE, 0), so OpenCV's board frame is the world frame and its
extrinsics are the views' world-to-camera poses.
"""

import argparse
import json
import os
import subprocess
import sys
import tempfile

import cv2
import numpy as np
import OpenEXR

PATTERN = (9, 6)  # inner corners
SQUARE = 0.1  # metres
WIDTH, HEIGHT = 1280, 960
K_TRUE = dict(fx=905.0, fy=903.5, cx=645.3, cy=478.1)
D_TRUE = [-0.28, 0.11, 0.0008, -0.0005, -0.02]
SPP = 16

OUT = os.path.join("tests", "fixtures", "calibration", "checkerboard")


def views():
    """Camera positions above the board, each looking at a point on it."""
    rng = np.random.default_rng(54)
    centre = np.array([4 * SQUARE, 2.5 * SQUARE, 0.0])
    out = []
    for i in range(14):
        tilt = np.radians(rng.uniform(0, 38))
        azimuth = rng.uniform(0, 2 * np.pi)
        dist = rng.uniform(0.75, 1.05)
        offset = np.array([np.sin(tilt) * np.cos(azimuth), np.sin(tilt) * np.sin(azimuth), np.cos(tilt)])
        target = centre + np.array([rng.uniform(-0.12, 0.12), rng.uniform(-0.1, 0.1), 0.0])
        roll = rng.uniform(-0.4, 0.4)
        up = np.array([np.sin(roll), np.cos(roll), 0.0])
        out.append(dict(position=(target + dist * offset).tolist(), look_at=target.tolist(), up=up.tolist()))
    return out


def scene_text(view):
    m = SQUARE
    # The board: 10 x 7 squares from (-m, -m) to (9m, 6m); a white margin
    # 2 squares wide just behind it.
    board_centre = (4 * m, 2.5 * m)
    return f"""
[camera]
type = "calibrated"
position = {view['position']}
look_at = {view['look_at']}
up = {view['up']}
resolution = [{WIDTH}, {HEIGHT}]
fx = {K_TRUE['fx']}
fy = {K_TRUE['fy']}
cx = {K_TRUE['cx']}
cy = {K_TRUE['cy']}
distortion = "brown_conrady"
coefficients = {D_TRUE}

[render]
spp = {SPP}
max_depth = 1

[environment]
radiance = [1, 1, 1]

[[materials]]
name = "board"
type = "diffuse"
base_color_map = {{ checkerboard = [[0.03, 0.03, 0.03], [0.85, 0.85, 0.85]], to_uv = [[5, 0, 0], [0, 3.5, 0]] }}

[[materials]]
name = "margin"
type = "diffuse"
reflectance = [0.85, 0.85, 0.85]

[[shapes]]
type = "rectangle"
transform = {{ scale = [{5 * m}, {3.5 * m}, 1], translate = [{board_centre[0]}, {board_centre[1]}, 0] }}
material = "board"

[[shapes]]
type = "rectangle"
transform = {{ scale = [{7 * m}, {5.5 * m}, 1], translate = [{board_centre[0]}, {board_centre[1]}, -0.002] }}
material = "margin"
"""


def read_grey(path):
    # plsr's EXR: the colour as the interleaved "RGBA" channel group.
    rgba = np.asarray(OpenEXR.File(path).channels()["RGBA"].pixels, dtype=np.float32)
    grey = rgba[..., :3].mean(axis=2)
    return np.clip(grey * 255.0 + 0.5, 0, 255).astype(np.uint8)


def main():
    ap = argparse.ArgumentParser()
    ap.add_argument("--plsr", default=os.path.join("target", "release", "plsr"))
    args = ap.parse_args()
    os.makedirs(OUT, exist_ok=True)
    K = np.array([[K_TRUE["fx"], 0, K_TRUE["cx"]], [0, K_TRUE["fy"], K_TRUE["cy"]], [0, 0, 1]], float)
    D = np.array(D_TRUE, float)
    board = np.zeros((PATTERN[0] * PATTERN[1], 3), np.float64)
    board[:, :2] = np.mgrid[0 : PATTERN[0], 0 : PATTERN[1]].T.reshape(-1, 2) * SQUARE
    objects, corners, kept = [], [], []
    with tempfile.TemporaryDirectory() as tmp:
        for i, view in enumerate(views()):
            scene = os.path.join(tmp, f"view{i}.toml")
            exr = os.path.join(tmp, f"view{i}.exr")
            with open(scene, "w") as f:
                f.write(scene_text(view))
            subprocess.run([args.plsr, "render", scene, "-o", exr, "-q"], check=True)
            grey = read_grey(exr)
            ok, c = cv2.findChessboardCorners(grey, PATTERN, flags=cv2.CALIB_CB_ADAPTIVE_THRESH)
            if not ok:
                print(f"view {i}: board not found, skipped", file=sys.stderr)
                continue
            c = cv2.cornerSubPix(
                grey, c, (7, 7), (-1, -1), (cv2.TERM_CRITERIA_EPS + cv2.TERM_CRITERIA_MAX_ITER, 100, 1e-4)
            ).reshape(-1, 2)
            # Order the detections as the board's corners: match each true
            # corner (projected with the true camera by OpenCV) to the nearest.
            position = np.array(view["position"])
            forward = np.array(view["look_at"]) - position
            forward /= np.linalg.norm(forward)
            right = np.cross(forward, np.array(view["up"]))
            right /= np.linalg.norm(right)
            down = np.cross(forward, right)
            R = np.stack([right, down, forward])  # world-to-camera rows
            t = -R @ position
            truth, _ = cv2.projectPoints(board, cv2.Rodrigues(R)[0], t, K, D)
            truth = truth.reshape(-1, 2)
            d = np.linalg.norm(truth[:, None, :] - c[None, :, :], axis=2)
            order = d.argmin(axis=1)
            if len(set(order.tolist())) != len(order) or d.min(axis=1).max() > 2.0:
                print(f"view {i}: detections do not match the board, skipped", file=sys.stderr)
                continue
            objects.append(board.astype(np.float32))
            corners.append(c[order].astype(np.float32))
            kept.append(dict(view=view, index=i, corners=c[order].tolist()))
            print(f"view {i}: {len(c)} corners, worst {d.min(axis=1).max():.3f} px from the true projection")
    rms, K_fit, D_fit, rvecs, tvecs = cv2.calibrateCamera(objects, corners, (WIDTH, HEIGHT), None, None)
    print(f"calibrated on {len(objects)} views: RMS {rms:.4f} px")
    print("K", K_fit.tolist())
    print("D", D_fit.ravel().tolist())
    fs = cv2.FileStorage(os.path.join(OUT, "calibration.yaml"), cv2.FILE_STORAGE_WRITE)
    fs.write("calibration_time", "made by scripts/calibration_checkerboard.py")
    fs.write("image_width", WIDTH)
    fs.write("image_height", HEIGHT)
    fs.write("board_width", PATTERN[0])
    fs.write("board_height", PATTERN[1])
    fs.write("square_size", SQUARE)
    fs.write("camera_matrix", K_fit)
    fs.write("distortion_coefficients", D_fit)
    fs.write("avg_reprojection_error", rms)
    fs.write("extrinsic_parameters", np.hstack([np.array(rvecs).reshape(-1, 3), np.array(tvecs).reshape(-1, 3)]))
    fs.release()
    with open(os.path.join(OUT, "views.json"), "w") as f:
        json.dump(
            dict(
                opencv_version=cv2.__version__,
                pattern=PATTERN,
                square=SQUARE,
                width=WIDTH,
                height=HEIGHT,
                intrinsics=K_TRUE,
                coefficients=D_TRUE,
                spp=SPP,
                views=kept,
            ),
            f,
        )


if __name__ == "__main__":
    main()
