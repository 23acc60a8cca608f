#!/usr/bin/env python3
"""Writes the reference fixtures for plsr's calibrated cameras with lens
distortion (tests/fixtures/calibration/, apart from checkerboard/, which
scripts/calibration_checkerboard.py makes). Two independent peers provide
the references: OpenCV (Brown-Conrady with 4, 5, 8 and 12 coefficients and
the fisheye model) and COLMAP through pycolmap (its nine classic camera
models).

  opencv/<case>.yaml, opencv/<case>.json
      a camera written by cv::FileStorage with the keys of OpenCV's
      calibration sample: image_width, image_height, [fisheye_model: 1,]
      camera_matrix (3x3 double), distortion_coefficients (Nx1 double)
  opencv/<case>_points.json
      1000 world points, a pose (rvec, tvec: X_cam = R(rvec) X_world + tvec)
      and the points' pixels by cv2.projectPoints / cv2.fisheye.projectPoints
  opencv/ros_brown5.yaml
      brown5 as a ROS camera_info calibration file (plumb_bob)
  undistort/input.exr, undistort/<cam>.yaml, undistort/<cam>_map.exr,
  undistort/<cam>_opencv.exr
      a 96x64 test image, a distorted camera, OpenCV's undistortion map
      (R = map_x, G = map_y) and the image remapped through it
  colmap/{cameras,images,points3D,rigs,frames}.txt, colmap/expected.json
      a reconstruction written by pycolmap's own text writer, with one
      camera per model and two posed images each, and, per image, 50 world
      points with their pixels by pycolmap
  README.md
      what the files are, the versions that made them, the parameters

Made with OpenCV 5.1.0 (PyPI opencv-python-headless 5.1.0.95), pycolmap
4.2.1 (COLMAP 4.2.1), numpy 2.4.6 and OpenEXR 3.5.3 (Python bindings);
the script prints the versions it runs with and writes them into the README.
Run it from the repository's root:

    python3 -m venv /tmp/cv
    /tmp/cv/bin/pip install opencv-python-headless OpenEXR pycolmap numpy
    /tmp/cv/bin/python scripts/calibration_fixtures.py

Everything is deterministic: the random numbers come from numpy's
default_rng with fixed seeds. Every camera is checked to be invertible
(its distortion monotonic) over the whole image before anything is written,
and every written file is read back and checked at the end.
"""

import json
import os
import shutil
import sys

import cv2
import numpy as np
import OpenEXR
import pycolmap

ROOT = os.path.dirname(os.path.dirname(os.path.abspath(__file__)))
OUT = os.path.join(ROOT, "tests", "fixtures", "calibration")
SEED = 20250521
N_POINTS = 1000
TOLERANCE_PX = 0.05  # a kept point projects this close to its target pixel
DEPTH = (0.5, 20.0)  # metres, the camera-frame z of the generated points

# OpenCV's cameras. Pixel convention: the centre of the top-left pixel is (0, 0).
OPENCV_CASES = {
    "brown5": dict(
        width=640, height=480, fx=521.3, fy=519.8, cx=323.6, cy=237.2,
        # k1, k2, p1, p2, k3
        dist=[-0.25, 0.085, 0.0012, -0.0007, -0.012],
    ),
    "brown4": dict(
        width=800, height=600, fx=702.4, fy=700.9, cx=401.8, cy=297.3,
        # k1, k2, p1, p2
        dist=[-0.12, 0.031, -0.0009, 0.0014],
    ),
    "rational8": dict(
        # in the style of an Azure Kinect colour camera's factory calibration
        # (CALIB_RATIONAL_MODEL): large coefficients that mostly cancel
        width=1280, height=720, fx=606.2, fy=605.9, cx=638.4, cy=366.7,
        # k1, k2, p1, p2, k3, k4, k5, k6
        dist=[0.52, -2.61, 0.00064, -0.00033, 1.45, 0.41, -2.42, 1.38],
    ),
    "thinprism12": dict(
        # CALIB_RATIONAL_MODEL | CALIB_THIN_PRISM_MODEL
        width=1024, height=768, fx=880.5, fy=878.1, cx=515.2, cy=381.9,
        # k1, k2, p1, p2, k3, k4, k5, k6, s1, s2, s3, s4
        dist=[-0.18, 0.062, 0.0006, -0.0011, -0.0085, 0.021, -0.004, 0.0012,
              0.0011, -0.0002, -0.0008, 0.00015],
    ),
    "fisheye": dict(
        # cv::fisheye (Kannala-Brandt): theta_d = theta (1 + k1 theta^2 + ...
        # + k4 theta^8), nearly equidistant: a full-frame fisheye whose corners
        # are about 87 degrees off axis. The focal length is a little above the
        # shortest that cv2.fisheye.undistortPoints can invert over the whole
        # image (about 462 px): it clips theta_d (the distorted
        # radius over f) to pi/2, so pixels further than about f pi/2 from the
        # principal point cannot be undistorted by OpenCV (at fx = 330 that
        # would be the outer fifth of the image).
        width=1024, height=1024, fx=471.3, fy=470.8, cx=512.8, cy=510.9,
        # k1, k2, k3, k4
        dist=[0.0123, -0.0041, 0.0009, -0.00012],
        fisheye=True,
    ),
}

# COLMAP's cameras: model -> (width, height, params in COLMAP's order).
# Pixel convention: the centre of the top-left pixel is (0.5, 0.5).
COLMAP_CAMERAS = {
    "SIMPLE_PINHOLE": (640, 480, [612.4, 321.7, 238.4]),
    "PINHOLE": (800, 600, [712.5, 709.8, 398.2, 301.6]),
    "SIMPLE_RADIAL": (1024, 768, [860.3, 512.4, 383.1, -0.085]),
    "RADIAL": (1280, 720, [1050.2, 641.3, 358.9, -0.11, 0.042]),
    "OPENCV": (1280, 960, [1005.7, 1003.1, 642.9, 477.4, -0.22, 0.071, 0.0009, -0.0012]),
    "OPENCV_FISHEYE": (1280, 960, [560.3, 559.6, 641.8, 478.7, 0.031, -0.012, 0.0042, -0.0008]),
    "FULL_OPENCV": (1024, 576, [738.6, 737.9, 509.3, 290.2, 0.23, -0.11, 0.0004, -0.0006,
                                0.009, 0.57, -0.15, 0.021]),
    "SIMPLE_RADIAL_FISHEYE": (640, 480, [305.2, 320.6, 239.3, 0.021]),
    "RADIAL_FISHEYE": (960, 540, [401.7, 479.2, 271.4, 0.018, -0.0024]),
}
COLMAP_POINTS_PER_IMAGE = 50

UNDISTORT_SIZE = (96, 64)  # width, height
UNDISTORT_CAMERAS = {"brown": "brown5", "fisheye": "fisheye"}

# The iterative undistortion is run to convergence (OpenCV's default for
# cv2.undistortPoints is 5 iterations, not enough for the image corners).
UNDISTORT_CRITERIA = (cv2.TERM_CRITERIA_COUNT + cv2.TERM_CRITERIA_EPS, 200, 1e-12)
FISHEYE_CRITERIA = (cv2.TERM_CRITERIA_COUNT + cv2.TERM_CRITERIA_EPS, 100, 1e-14)


# ---------------------------------------------------------------- OpenCV --

def camera_matrix(c):
    return np.array([[c["fx"], 0.0, c["cx"]], [0.0, c["fy"], c["cy"]], [0.0, 0.0, 1.0]])


def dist_vector(c):
    return np.array(c["dist"], dtype=np.float64).reshape(-1, 1)


def cv_project(c, K, D, X, rvec=None, tvec=None):
    """OpenCV's projection of Nx3 points (world points with a pose, or
    camera-frame points without one) to Nx2 pixels."""
    X = np.ascontiguousarray(X, dtype=np.float64).reshape(-1, 1, 3)
    r = np.zeros((3, 1)) if rvec is None else np.asarray(rvec, np.float64).reshape(3, 1)
    t = np.zeros((3, 1)) if tvec is None else np.asarray(tvec, np.float64).reshape(3, 1)
    if c.get("fisheye"):
        uv, _ = cv2.fisheye.projectPoints(X, r, t, K, D)
    else:
        uv, _ = cv2.projectPoints(X, r, t, K, D)
    return uv.reshape(-1, 2)


def cv_unproject(c, K, D, uv):
    """OpenCV's undistortion of Nx2 pixels to Nx2 normalised coordinates (x/z, y/z)."""
    uv = np.ascontiguousarray(uv, dtype=np.float64).reshape(-1, 1, 2)
    if c.get("fisheye"):
        xy = cv2.fisheye.undistortPoints(uv, K, D, criteria=FISHEYE_CRITERIA)
    else:
        xy = cv2.undistortPoints(uv, K, D, criteria=UNDISTORT_CRITERIA)
    return xy.reshape(-1, 2)


def random_rotation(rng):
    """A uniformly distributed rotation as a 3x3 matrix."""
    q = rng.normal(size=4)
    w, x, y, z = q / np.linalg.norm(q)
    return np.array([
        [1 - 2 * (y * y + z * z), 2 * (x * y - z * w), 2 * (x * z + y * w)],
        [2 * (x * y + z * w), 1 - 2 * (x * x + z * z), 2 * (y * z - x * w)],
        [2 * (x * z - y * w), 2 * (y * z + x * w), 1 - 2 * (x * x + y * y)],
    ])


# ------------------------------------------------------- invertibility --

def boundary_pixels(w, h, step):
    xs = np.append(np.arange(0.0, w, step), w)
    ys = np.append(np.arange(0.0, h, step), h)
    return np.concatenate([
        np.stack([xs, np.zeros_like(xs)], 1), np.stack([xs, np.full_like(xs, h)], 1),
        np.stack([np.zeros_like(ys), ys], 1), np.stack([np.full_like(ys, w), ys], 1),
    ])


def check_invertible(name, w, h, f, c, project, unproject):
    """Checks numerically that a camera's projection is one-to-one over the
    image [0, w] x [0, h]: every pixel of a grid and of the border
    unprojects to a ray (z > 0) that projects back onto it; along the ray
    from the optical axis to each border pixel's ray the distorted radius
    grows strictly; and the projection's Jacobian determinant with respect
    to the normalised coordinates (x/z, y/z) is positive everywhere on those
    rays. `project` maps Nx3 camera-frame points to Nx2 pixels, `unproject`
    Nx2 pixels to Nx2 normalised coordinates; f = (fx, fy), c = (cx, cy).
    Returns the worst round trip (px) and the corners' angle off axis (deg)."""
    gx, gy = np.meshgrid(np.linspace(0, w, 65), np.linspace(0, h, 49))
    border = boundary_pixels(w, h, 1.0)
    pix = np.concatenate([np.stack([gx.ravel(), gy.ravel()], 1), border])
    xy = unproject(pix)
    rays = np.concatenate([xy, np.ones((len(xy), 1))], 1)
    back = project(rays)
    round_trip = np.max(np.abs(back - pix))
    assert np.all(np.isfinite(xy)) and round_trip < 1e-6, (name, round_trip)

    # rays from the axis out to the border, sampled in angle off axis
    xy_b = unproject(boundary_pixels(w, h, 2.0))
    alpha_max = np.arctan(np.hypot(xy_b[:, 0], xy_b[:, 1]))
    phi = np.arctan2(xy_b[:, 1], xy_b[:, 0])
    t = np.linspace(0.0, 1.0, 301)[1:]
    alpha = alpha_max[:, None] * t[None, :]
    r = np.tan(alpha)
    x, y = r * np.cos(phi)[:, None], r * np.sin(phi)[:, None]

    def proj_xy(x, y):
        p = project(np.stack([x.ravel(), y.ravel(), np.ones(x.size)], 1))
        return p.reshape(x.shape + (2,))

    p = proj_xy(x, y)
    rd = np.hypot((p[..., 0] - c[0]) / f[0], (p[..., 1] - c[1]) / f[1])
    steps = np.diff(np.concatenate([np.zeros((len(rd), 1)), rd], 1), axis=1)
    assert np.all(steps > 0), (name, "distorted radius not monotonic", steps.min())

    hstep = 1e-6 * (1.0 + r)
    dx = (proj_xy(x + hstep, y) - proj_xy(x - hstep, y)) / (2 * hstep[..., None])
    dy = (proj_xy(x, y + hstep) - proj_xy(x, y - hstep)) / (2 * hstep[..., None])
    det = dx[..., 0] * dy[..., 1] - dx[..., 1] * dy[..., 0]
    assert np.all(det > 0), (name, "Jacobian determinant", det.min())
    corner_deg = np.degrees(alpha_max.max())
    print(f"  {name}: invertible over {w}x{h}; round trip {round_trip:.1e} px, "
          f"widest ray {corner_deg:.2f} deg off axis, min det/(fx fy) "
          f"{det.min() / (f[0] * f[1]):.3g}")
    return round_trip, corner_deg


# ------------------------------------------------------------- writers --

def write_filestorage(path, width, height, K, D, fisheye):
    """The keys and order of OpenCV's camera calibration sample."""
    fs = cv2.FileStorage(path, cv2.FILE_STORAGE_WRITE)
    fs.write("image_width", int(width))
    fs.write("image_height", int(height))
    if fisheye:
        fs.write("fisheye_model", 1)
    fs.write("camera_matrix", K)
    fs.write("distortion_coefficients", D)
    fs.release()


def read_filestorage(path):
    fs = cv2.FileStorage(path, cv2.FILE_STORAGE_READ)
    assert fs.isOpened(), path
    out = dict(
        width=fs.getNode("image_width"), height=fs.getNode("image_height"),
        K=fs.getNode("camera_matrix").mat(), D=fs.getNode("distortion_coefficients").mat(),
    )
    assert out["width"].isInt() and out["height"].isInt()
    out["width"], out["height"] = int(out["width"].real()), int(out["height"].real())
    fm = fs.getNode("fisheye_model")
    out["fisheye"] = (not fm.empty()) and fm.isInt() and int(fm.real()) == 1
    fs.release()
    return out


def write_exr(path, r, g, b):
    header = {"compression": OpenEXR.ZIP_COMPRESSION, "type": OpenEXR.scanlineimage}
    channels = {k: np.ascontiguousarray(v, dtype=np.float32) for k, v in (("R", r), ("G", g), ("B", b))}
    with OpenEXR.File(header, channels) as f:
        f.write(path)


def read_exr(path):
    with OpenEXR.File(path, separate_channels=True) as f:
        ch = f.channels()
        assert sorted(ch) == ["B", "G", "R"], (path, sorted(ch))
        for v in ch.values():
            assert v.type() == OpenEXR.FLOAT, (path, v.type())
        return np.stack([np.array(ch[k].pixels) for k in "RGB"], -1)


def dump_json(path, obj):
    with open(path, "w") as f:
        json.dump(obj, f, separators=(",", ":"))
        f.write("\n")


# --------------------------------------------------------- OpenCV cases --

def make_points(name, c, rng):
    """1000 world points and their pixels by OpenCV, see the docstring."""
    K, D, w, h = camera_matrix(c), dist_vector(c), c["width"], c["height"]
    rvec = cv2.Rodrigues(random_rotation(rng))[0].ravel()
    tvec = rng.uniform(-2.0, 2.0, 3)
    R = cv2.Rodrigues(rvec)[0]
    objs, pixels, drawn, failed = [], [], 0, 0
    while len(objs) < N_POINTS:
        target = rng.uniform([0.0, 0.0], [w, h], size=(400, 2))
        z = rng.uniform(*DEPTH, 400)
        drawn += len(target)
        xy = cv_unproject(c, K, D, target)
        cam = np.concatenate([xy * z[:, None], z[:, None]], 1)
        world = (cam - tvec) @ R  # R^T (X_cam - t)
        uv = cv_project(c, K, D, world, rvec, tvec)
        ok = (np.all(np.isfinite(uv), 1) & np.all(np.isfinite(world), 1)
              & (uv[:, 0] >= 0) & (uv[:, 0] <= w) & (uv[:, 1] >= 0) & (uv[:, 1] <= h)
              & (np.max(np.abs(uv - target), 1) < TOLERANCE_PX))
        failed += int(np.sum(~ok))
        objs.extend(world[ok].tolist())
        pixels.extend(uv[ok].tolist())
    objs, pixels = objs[:N_POINTS], pixels[:N_POINTS]
    err = np.max(np.abs(np.array(pixels) - cv_project(c, K, D, np.array(objs), rvec, tvec)))
    assert err == 0.0, (name, err)
    print(f"  {name}: {N_POINTS} points ({drawn} drawn, {failed} dropped)")
    return dict(rvec=rvec.tolist(), tvec=tvec.tolist(), object_points=objs, image_points=pixels)


def ros_yaml(name, c):
    """A ROS camera_info calibration file as camera_calibration writes it.
    Its projection matrix is the rectified camera: OpenCV's optimal new camera
    matrix with alpha 0 (what camera_calibration puts there for a monocular
    camera), rounded to 5 decimals as camera_calibration prints it."""
    K, D = camera_matrix(c), dist_vector(c)
    P, _ = cv2.getOptimalNewCameraMatrix(K, D, (c["width"], c["height"]), 0.0)
    P = np.round(np.concatenate([P, np.zeros((3, 1))], 1), 5)

    def fmt(values):
        return "[" + ", ".join(repr(float(v)) for v in values) + "]"

    return "\n".join([
        f"image_width: {c['width']}",
        f"image_height: {c['height']}",
        f"camera_name: {name}",
        "camera_matrix:",
        "  rows: 3",
        "  cols: 3",
        f"  data: {fmt(K.ravel())}",
        "distortion_model: plumb_bob",
        "distortion_coefficients:",
        "  rows: 1",
        f"  cols: {len(c['dist'])}",
        f"  data: {fmt(c['dist'])}",
        "rectification_matrix:",
        "  rows: 3",
        "  cols: 3",
        f"  data: {fmt(np.eye(3).ravel())}",
        "projection_matrix:",
        "  rows: 3",
        "  cols: 4",
        f"  data: {fmt(P.ravel())}",
        "",
    ]), P


def parse_ros_yaml(text):
    """Just enough of YAML for the file above (no PyYAML in the venv)."""
    out, key = {}, None
    for line in text.splitlines():
        if not line.strip():
            continue
        k, _, v = line.strip().partition(":")
        v = v.strip()
        if line.startswith("  "):
            out[key][k] = json.loads(v) if v.startswith("[") else int(v)
        elif v:
            out[k] = int(v) if v.isdigit() else v
        else:
            key = k
            out[key] = {}
    return out


def opencv_fixtures(summary):
    d = os.path.join(OUT, "opencv")
    os.makedirs(d)
    print("OpenCV cameras:")
    for i, (name, c) in enumerate(OPENCV_CASES.items()):
        K, D = camera_matrix(c), dist_vector(c)
        assert K[0, 1] == 0.0
        rt, deg = check_invertible(name, c["width"], c["height"], (c["fx"], c["fy"]), (c["cx"], c["cy"]),
                                   lambda X, c=c, K=K, D=D: cv_project(c, K, D, X),
                                   lambda uv, c=c, K=K, D=D: cv_unproject(c, K, D, uv))
        c["round_trip"], c["widest_deg"] = rt, deg
        for ext in ("yaml", "json"):
            write_filestorage(os.path.join(d, f"{name}.{ext}"), c["width"], c["height"], K, D, c.get("fisheye"))
        pts = make_points(name, c, np.random.default_rng([SEED, i]))
        c["rvec"], c["tvec"] = pts["rvec"], pts["tvec"]
        dump_json(os.path.join(d, f"{name}_points.json"), pts)

    text, P = ros_yaml("brown5", OPENCV_CASES["brown5"])
    OPENCV_CASES["brown5"]["ros_P"] = P
    with open(os.path.join(d, "ros_brown5.yaml"), "w") as f:
        f.write(text)

    # read everything back
    for name, c in OPENCV_CASES.items():
        with open(os.path.join(d, f"{name}_points.json")) as f:
            pts = json.load(f)
        assert len(pts["object_points"]) == len(pts["image_points"]) == N_POINTS
        for ext in ("yaml", "json"):
            fs = read_filestorage(os.path.join(d, f"{name}.{ext}"))
            assert (fs["width"], fs["height"]) == (c["width"], c["height"])
            assert fs["fisheye"] == bool(c.get("fisheye"))
            assert fs["K"].dtype == np.float64 and fs["D"].dtype == np.float64
            assert np.array_equal(fs["K"], camera_matrix(c)), (name, ext)
            assert fs["D"].shape == (len(c["dist"]), 1) and np.array_equal(fs["D"], dist_vector(c)), (name, ext)
            uv = cv_project(c, fs["K"], fs["D"], np.array(pts["object_points"]), pts["rvec"], pts["tvec"])
            diff = np.max(np.abs(uv - np.array(pts["image_points"])))
            summary.append((f"opencv/{name}.{ext} reprojection", diff))
            assert diff == 0.0
    with open(os.path.join(d, "ros_brown5.yaml")) as f:
        ros = parse_ros_yaml(f.read())
    c = OPENCV_CASES["brown5"]
    assert ros["distortion_model"] == "plumb_bob" and ros["camera_name"] == "brown5"
    assert (ros["image_width"], ros["image_height"]) == (c["width"], c["height"])
    assert ros["camera_matrix"]["data"] == camera_matrix(c).ravel().tolist()
    assert ros["distortion_coefficients"]["data"] == c["dist"]
    assert ros["projection_matrix"]["data"] == c["ros_P"].ravel().tolist()
    with open(os.path.join(d, "brown5_points.json")) as f:
        pts = json.load(f)
    uv = cv_project(c, np.array(ros["camera_matrix"]["data"]).reshape(3, 3),
                    np.array(ros["distortion_coefficients"]["data"]), np.array(pts["object_points"]),
                    pts["rvec"], pts["tvec"])
    summary.append(("opencv/ros_brown5.yaml reprojection", np.max(np.abs(uv - np.array(pts["image_points"])))))


# ------------------------------------------------------------ undistort --

def test_image():
    """96x64 RGB: a smooth colour gradient under a grid of 1-pixel lines
    every 8 pixels (columns and rows 3, 11, ..., 91)."""
    w, h = UNDISTORT_SIZE
    y, x = np.mgrid[0:h, 0:w].astype(np.float64)
    r = 0.1 + 0.8 * x / (w - 1)
    g = 0.1 + 0.8 * y / (h - 1)
    b = 0.5 + 0.3 * np.sin(2 * np.pi * (x / w + 0.5 * y / h))
    lines = (x % 8 == 3) | (y % 8 == 3)
    img = np.stack([r, g, b], -1)
    img[lines] = (1.0, 1.0, 1.0)
    return img.astype(np.float32)


def scaled_camera_matrix(c, w, h):
    """K for the same lens at another resolution, OpenCV's convention:
    f' = f s, c' = (c + 0.5) s - 0.5."""
    sx, sy = w / c["width"], h / c["height"]
    return np.array([
        [c["fx"] * sx, 0.0, (c["cx"] + 0.5) * sx - 0.5],
        [0.0, c["fy"] * sy, (c["cy"] + 0.5) * sy - 0.5],
        [0.0, 0.0, 1.0],
    ])


def undistort_maps(K, D, fisheye):
    size = UNDISTORT_SIZE
    if fisheye:
        return cv2.fisheye.initUndistortRectifyMap(K, D, np.eye(3), K, size, cv2.CV_32FC1)
    return cv2.initUndistortRectifyMap(K, D, None, K, size, cv2.CV_32FC1)


def remap(img, mx, my):
    return cv2.remap(img, mx, my, cv2.INTER_LINEAR, borderMode=cv2.BORDER_CONSTANT, borderValue=0)


def exact_bilinear(img, mx, my):
    """Bilinear interpolation in float64 without OpenCV's 1/32-pixel
    quantisation of the weights; samples outside the image are 0."""
    h, w = img.shape[:2]
    x0, y0 = np.floor(mx).astype(int), np.floor(my).astype(int)
    fx, fy = (mx - x0)[..., None], (my - y0)[..., None]
    pad = np.zeros((h + 4, w + 4, img.shape[2]))
    pad[2:-2, 2:-2] = img
    xi, yi = np.clip(x0, -2, w), np.clip(y0, -2, h)
    far = (x0 < -2) | (x0 > w) | (y0 < -2) | (y0 > h)

    def at(dy, dx):
        return pad[yi + 2 + dy, xi + 2 + dx]

    out = ((1 - fy) * ((1 - fx) * at(0, 0) + fx * at(0, 1))
           + fy * ((1 - fx) * at(1, 0) + fx * at(1, 1)))
    out[far] = 0
    return out


def undistort_fixtures(summary):
    d = os.path.join(OUT, "undistort")
    os.makedirs(d)
    w, h = UNDISTORT_SIZE
    img = test_image()
    write_exr(os.path.join(d, "input.exr"), img[..., 0], img[..., 1], img[..., 2])
    print("Undistortion:")
    for cam, case in UNDISTORT_CAMERAS.items():
        c = OPENCV_CASES[case]
        fisheye = bool(c.get("fisheye"))
        K, D = scaled_camera_matrix(c, w, h), dist_vector(c)
        write_filestorage(os.path.join(d, f"{cam}.yaml"), w, h, K, D, fisheye)
        mx, my = undistort_maps(K, D, fisheye)
        assert mx.dtype == np.float32 and mx.shape == (h, w)
        write_exr(os.path.join(d, f"{cam}_map.exr"), mx, my, np.zeros_like(mx))
        out = remap(img, mx, my)
        write_exr(os.path.join(d, f"{cam}_opencv.exr"), out[..., 0], out[..., 1], out[..., 2])

        # read back, recompute from the file's camera
        fs = read_filestorage(os.path.join(d, f"{cam}.yaml"))
        assert fs["fisheye"] == fisheye and (fs["width"], fs["height"]) == (w, h)
        assert np.array_equal(fs["K"], K) and np.array_equal(fs["D"], D)
        mx2, my2 = undistort_maps(fs["K"], fs["D"], fisheye)
        m = read_exr(os.path.join(d, f"{cam}_map.exr"))
        src = read_exr(os.path.join(d, "input.exr"))
        ref = read_exr(os.path.join(d, f"{cam}_opencv.exr"))
        assert np.array_equal(src, img)
        assert np.array_equal(m[..., 0], mx2) and np.array_equal(m[..., 1], my2) and not m[..., 2].any()
        assert np.array_equal(ref, remap(src, mx2, my2))
        # what the map is: each output pixel's ray, distorted, in pixels
        yy, xx = np.mgrid[0:h, 0:w].astype(np.float64)
        rays = np.stack([(xx - K[0, 2]) / K[0, 0], (yy - K[1, 2]) / K[1, 1], np.ones_like(xx)], -1)
        proj = cv_project(c, K, D, rays.reshape(-1, 3)).reshape(h, w, 2)
        map_err = np.max(np.abs(proj - m[..., :2]))
        whole = cv2.fisheye.undistortImage(img, K, D, Knew=K) if fisheye else cv2.undistort(img, K, D)
        inside = (mx >= 0) & (mx <= w - 1) & (my >= 0) & (my <= h - 1)
        exact = exact_bilinear(img.astype(np.float64), mx.astype(np.float64), my.astype(np.float64))
        summary.append((f"undistort/{cam}_map.exr vs projectPoints of the pixels' rays (px)", map_err))
        summary.append((f"undistort/{cam}_opencv.exr vs cv2.{'fisheye.undistortImage' if fisheye else 'undistort'}",
                        np.max(np.abs(whole - out))))
        summary.append((f"undistort/{cam}_opencv.exr vs float64 bilinear", np.max(np.abs(exact - out))))
        c["undistort_K"] = K
        c["undistort_stats"] = dict(
            map_range=(float(mx.min()), float(mx.max()), float(my.min()), float(my.max())),
            outside=int(np.sum(~inside)),
            exact_diff=float(np.max(np.abs(exact - out))),
            whole_diff=float(np.max(np.abs(whole - out))),
            whole_name="cv2.fisheye.undistortImage(input, K, D, Knew=K)" if fisheye else "cv2.undistort(input, K, D)",
        )
        print(f"  {cam}: map x in [{mx.min():.3f}, {mx.max():.3f}], y in [{my.min():.3f}, {my.max():.3f}]")


# --------------------------------------------------------------- COLMAP --

def colmap_pose(rng):
    """A random cam_from_world: a uniform rotation, and a translation."""
    q = rng.normal(size=4)
    q /= np.linalg.norm(q)
    if q[0] < 0:
        q = -q
    w, x, y, z = q
    return pycolmap.Rigid3d(pycolmap.Rotation3d(np.array([x, y, z, w])), rng.uniform(-3.0, 3.0, 3))


def colmap_fixtures(summary):
    d = os.path.join(OUT, "colmap")
    os.makedirs(d)
    rec = pycolmap.Reconstruction()
    rng = np.random.default_rng([SEED, 100])
    print("COLMAP cameras:")
    image_id = 0
    for camera_id, (model, (w, h, params)) in enumerate(COLMAP_CAMERAS.items(), start=1):
        cam = pycolmap.Camera.create_from_model_name(camera_id, model, params[0], w, h)
        cam.params = np.array(params, dtype=np.float64)
        assert cam.verify_params() and cam.model_name == model and list(cam.params) == params
        check_invertible(model, w, h, (cam.focal_length_x, cam.focal_length_y),
                         (cam.principal_point_x, cam.principal_point_y),
                         lambda X, cam=cam: cam.img_from_cam(np.ascontiguousarray(X)),
                         lambda uv, cam=cam: cam.cam_from_img(np.ascontiguousarray(uv)))
        rec.add_camera_with_trivial_rig(cam)
        for i in range(2):
            image_id += 1
            image = pycolmap.Image(name=f"img_{model}_{i}.jpg", camera_id=camera_id, image_id=image_id)
            rec.add_image_with_trivial_frame(image, colmap_pose(rng))
    assert rec.is_valid()

    expected = []
    for image_id in sorted(rec.images):
        image = rec.image(image_id)
        cam = image.camera
        cam_from_world = image.cam_from_world()
        world_from_cam = cam_from_world.inverse()
        points, pixels = [], []
        while len(points) < COLMAP_POINTS_PER_IMAGE:
            target = rng.uniform([0.0, 0.0], [cam.width, cam.height])
            z = rng.uniform(*DEPTH)
            xy = cam.cam_from_img(target)
            if xy is None:
                continue
            X = world_from_cam * np.array([xy[0] * z, xy[1] * z, z])
            uv = cam.img_from_cam(cam_from_world * X)
            if uv is None or not (0 <= uv[0] <= cam.width and 0 <= uv[1] <= cam.height):
                continue
            if np.max(np.abs(uv - target)) >= TOLERANCE_PX or (cam_from_world * X)[2] <= 0:
                continue
            assert np.array_equal(uv, image.project_point(X))
            points.append(X.tolist())
            pixels.append(uv.tolist())
        expected.append(dict(name=image.name, camera_model=cam.model_name, points=points, pixels=pixels))

    rec.write_text(d)
    dump_json(os.path.join(d, "expected.json"), dict(images=expected))

    # read back with pycolmap and reproject
    back = pycolmap.Reconstruction()
    back.read_text(d)
    with open(os.path.join(d, "expected.json")) as f:
        exp = json.load(f)
    worst = 0.0
    for e in exp["images"]:
        image = back.find_image_with_name(e["name"])
        assert image.camera.model_name == e["camera_model"]
        orig = rec.find_image_with_name(e["name"])
        assert np.array_equal(image.camera.params, orig.camera.params)
        assert np.array_equal(image.cam_from_world().matrix(), orig.cam_from_world().matrix())
        for X, uv in zip(e["points"], e["pixels"]):
            p = image.camera.img_from_cam(image.cam_from_world() * np.array(X))
            worst = max(worst, float(np.max(np.abs(p - np.array(uv)))))
    summary.append(("colmap/*.txt read back, reprojection of expected.json", worst))
    assert worst == 0.0
    return rec


# --------------------------------------------------------------- README --

def fmt_list(v):
    return "[" + ", ".join(repr(float(x)) for x in v) + "]"


DIST_NAMES = {
    4: "k1, k2, p1, p2",
    5: "k1, k2, p1, p2, k3",
    8: "k1, k2, p1, p2, k3, k4, k5, k6",
    12: "k1, k2, p1, p2, k3, k4, k5, k6, s1, s2, s3, s4",
}


def readme(versions, rec):
    L = []
    L += [
        "# Calibrated-camera reference fixtures",
        "",
        "Generated by `scripts/calibration_fixtures.py` (run from the repository's root:",
        "`python scripts/calibration_fixtures.py`, in a venv with opencv-python-headless,",
        "OpenEXR and pycolmap; see its docstring), except `checkerboard/`, which",
        "`scripts/calibration_checkerboard.py` makes. Made with:",
        "",
    ]
    L += [f"- {k} {v}" for k, v in versions.items()]
    L += [
        "",
        "These files are plsr's own generated data, under the same licence as the",
        "project. The values come from OpenCV and COLMAP (pycolmap) running on",
        "parameters chosen by the script; no third-party data is included.",
        "",
        "All random numbers come from numpy's `default_rng` with fixed seeds, so a",
        "rerun with the same versions reproduces the files. Every camera was checked",
        "numerically to be invertible over its whole image (pixel -> ray -> pixel round",
        "trip < 1e-6 px on a grid and the whole border, the distorted radius strictly",
        "increasing along every ray from the axis to the border, and a positive",
        "Jacobian determinant on those rays).",
        "",
        "## Pixel conventions",
        "",
        "- OpenCV (`opencv/`, `undistort/`): the centre of the top-left pixel is **(0, 0)**;",
        "  the image spans [-0.5, W - 0.5] x [-0.5, H - 0.5].",
        "- COLMAP (`colmap/`): the centre of the top-left pixel is **(0.5, 0.5)**; the",
        "  image spans [0, W] x [0, H].",
        "",
        "## `opencv/`",
        "",
        "- `<case>.yaml`, `<case>.json`: written by `cv::FileStorage` (its YAML and JSON",
        "  writers), with the keys of OpenCV's calibration sample: `image_width`,",
        "  `image_height`, `fisheye_model: 1` (fisheye case only, an int, before the",
        "  matrices), `camera_matrix` (3x3, `dt: d`), `distortion_coefficients` (Nx1,",
        "  `dt: d`). Numbers are printed with 17 significant digits (`%.17g`), so the",
        "  doubles round-trip exactly, e.g. 521.3 is written `521.29999999999995`; the",
        "  YAML writes zero as `0.` and the JSON as `0.0`. OpenCV 5 starts the YAML",
        "  with `%YAML 1.2` and `---` (OpenCV 4 writes `%YAML:1.0`).",
        "- `<case>_points.json`: `rvec`, `tvec` (X_cam = R(rvec) X_world + tvec,",
        "  R by Rodrigues' formula), `object_points` (1000 world points, metres) and",
        "  `image_points`: their pixels by `cv2.projectPoints` (`cv2.fisheye.projectPoints`",
        "  for the fisheye case) with the camera above. The points were made in the",
        "  camera frame: a target pixel uniform over [0, W] x [0, H], undistorted by",
        "  `cv2.undistortPoints` / `cv2.fisheye.undistortPoints` (iterated to",
        "  convergence) to a ray, a depth z uniform in [0.5, 20] m; then moved to the",
        "  world frame. Only points whose projection lies in [0, W] x [0, H] and",
        f"  within {TOLERANCE_PX} px of the target pixel were kept (none was dropped). Note",
        "  that [0, W] x [0, H] is the image shifted by half a pixel in OpenCV's",
        "  convention. Floats are full float64 (Python's shortest round-trip repr).",
        "- `ros_brown5.yaml`: the brown5 camera as a ROS camera_info calibration file",
        "  (the layout ROS's camera_calibration writes; plumb_bob). `camera_matrix`",
        "  and `distortion_coefficients` are brown5's exact values; the",
        "  `rectification_matrix` is the identity; the `projection_matrix` is the",
        "  rectified camera, `cv2.getOptimalNewCameraMatrix(K, D, size, alpha=0)`",
        "  rounded to 5 decimals, with a zero fourth column (it is not K: a reader",
        "  must take the distorted camera from `camera_matrix`).",
        "",
        "### Cases",
        "",
        "| case | size | fx | fy | cx | cy | distortion_coefficients | widest ray off axis |",
        "|---|---|---|---|---|---|---|---|",
    ]
    for name, c in OPENCV_CASES.items():
        L.append(f"| {name} | {c['width']}x{c['height']} | {c['fx']!r} | {c['fy']!r} | {c['cx']!r} | "
                 f"{c['cy']!r} | {fmt_list(c['dist'])} | {c['widest_deg']:.2f} deg |")
    L += [""]
    for name, c in OPENCV_CASES.items():
        order = "k1, k2, k3, k4 of cv::fisheye" if c.get("fisheye") else DIST_NAMES[len(c["dist"])]
        L.append(f"- {name}: coefficients ({order}); skew 0; pose rvec = {fmt_list(c['rvec'])}, "
                 f"tvec = {fmt_list(c['tvec'])}")
    L += [
        f"- ros_brown5.yaml projection_matrix: {fmt_list(OPENCV_CASES['brown5']['ros_P'].ravel())}",
        "",
        "The fisheye case is a full-frame fisheye, nearly equidistant, with the",
        "image's corners about 87 degrees off axis. Its focal length (about 471 px",
        "for 1024 px) is just above the shortest (about 462 px) for which",
        "`cv2.fisheye.undistortPoints` can invert the whole image: it clips theta_d (the",
        "distorted radius r_d / f) to pi/2, so pixels further than about f pi/2 from",
        "the principal point come back wrong (with fx = 330 the outer fifth of the",
        "image would). `cv2.fisheye.projectPoints` and",
        "`cv2.fisheye.initUndistortRectifyMap` have no such limit.",
        "",
        "## `undistort/`",
        "",
        "- `input.exr`: 96x64 float32 RGB test image: R = 0.1 + 0.8 x/95,",
        "  G = 0.1 + 0.8 y/63, B = 0.5 + 0.3 sin(2 pi (x/96 + y/128)), with 1-pixel",
        "  white (1, 1, 1) lines in columns and rows 3, 11, 19, ... (every 8 pixels).",
        "- `<cam>.yaml`: the distorted camera (cv::FileStorage as above) at 96x64: the",
        "  OpenCV case's coefficients, K scaled by sx = 96/W, sy = 64/H with OpenCV's",
        "  convention fx' = fx sx, cx' = (cx + 0.5) sx - 0.5 (likewise y). For the",
        "  fisheye (1024x1024) the scaling is anisotropic, so its fx' and fy' differ.",
        "- `<cam>_map.exr`: R = map_x, G = map_y, B = 0 (float32): for each pixel of the",
        "  undistorted image (camera matrix K, no distortion), the position in the",
        "  distorted input to sample, OpenCV pixels. From",
        "  `cv2.initUndistortRectifyMap(K, D, None, K, (96, 64), cv2.CV_32FC1)`, the",
        "  fisheye one from `cv2.fisheye.initUndistortRectifyMap(K, D, I, K, ...)`.",
        "  OpenCV computes the map in double and stores it as float32.",
        "- `<cam>_opencv.exr`: `cv2.remap(input, map_x, map_y, cv2.INTER_LINEAR,",
        "  borderMode=cv2.BORDER_CONSTANT, borderValue=0)`. For a float32 image and",
        "  CV_32FC1 maps this OpenCV's remap is a plain bilinear interpolation: it",
        "  matches a float64 bilinear interpolation (zero outside the image) to float32",
        "  rounding. `cv2.undistort` and `cv2.fisheye.undistortImage` are not quite",
        "  this: they remap through fixed-point CV_16SC2 maps, which quantise the",
        "  sample position to 1/32 pixel (INTER_TAB_SIZE), and differ from these files",
        "  by the amounts below. With K as the new camera matrix every output pixel of",
        "  both cameras samples inside the input, so the border value is never used.",
        "- EXRs: scanline, ZIP compression, channels R, G, B of type FLOAT.",
        "",
    ]
    for cam, case in UNDISTORT_CAMERAS.items():
        c = OPENCV_CASES[case]
        K, s = c["undistort_K"], c["undistort_stats"]
        L.append(f"- {cam} (from {case}): fx = {float(K[0, 0])!r}, fy = {float(K[1, 1])!r}, "
                 f"cx = {float(K[0, 2])!r}, cy = {float(K[1, 2])!r}, distortion {fmt_list(c['dist'])}; map_x in "
                 f"[{s['map_range'][0]:.4f}, {s['map_range'][1]:.4f}], map_y in "
                 f"[{s['map_range'][2]:.4f}, {s['map_range'][3]:.4f}]; {s['outside']} pixels sample "
                 f"outside [0, 95] x [0, 63]; max difference from a float64 bilinear interpolation "
                 f"{s['exact_diff']:.2g}, from `{s['whole_name']}` {s['whole_diff']:.2g}")
    L += [
        "",
        "## `colmap/`",
        "",
        "- `cameras.txt`, `images.txt`, `points3D.txt`, `rigs.txt`, `frames.txt`: one",
        "  reconstruction in COLMAP's text format, written by pycolmap's",
        "  `Reconstruction.write_text`. One camera per model (each with a trivial rig",
        "  and each image with a trivial frame, which COLMAP >= 3.12 requires and",
        "  writes to rigs.txt and frames.txt), two images per camera named",
        "  `img_<MODEL>_<i>.jpg` with random poses (cam_from_world; images.txt holds",
        "  QW QX QY QZ TX TY TZ of cam_from_world). No 3D points and no 2D points: the",
        "  writer accepts an empty set, so every image's second line is empty.",
        "- `expected.json`: `{\"images\": [{\"name\", \"camera_model\", \"points\", \"pixels\"}]}`;",
        f"  per image {COLMAP_POINTS_PER_IMAGE} world points in front of the camera and their",
        "  pixels (COLMAP's convention) by pycolmap:",
        "  `image.camera.img_from_cam(image.cam_from_world() * X)` (equal to",
        "  `image.project_point(X)`). Made like the OpenCV points: a target pixel",
        "  uniform over the image, `camera.cam_from_img` to a ray, z uniform in",
        f"  [0.5, 20] m; kept if the projection is inside the image and within {TOLERANCE_PX} px",
        "  of the target.",
        "",
        "| camera_id | model | size | params (COLMAP's order) |",
        "|---|---|---|---|",
    ]
    for camera_id in sorted(rec.cameras):
        cam = rec.camera(camera_id)
        L.append(f"| {camera_id} | {cam.model_name} | {cam.width}x{cam.height} | "
                 f"{cam.params_info}: {fmt_list(cam.params)} |")
    L += ["", "Images (cam_from_world as quaternion xyzw and translation):", ""]
    for image_id in sorted(rec.images):
        im = rec.image(image_id)
        T = im.cam_from_world()
        L.append(f"- {image_id} `{im.name}` (camera {im.camera_id}): q_xyzw = {fmt_list(T.rotation.quat)}, "
                 f"t = {fmt_list(T.translation)}")
    L.append("")
    return "\n".join(L)


def main():
    cv2.setNumThreads(1)
    versions = {
        "OpenCV": cv2.__version__,
        "pycolmap": f"{pycolmap.__version__} ({pycolmap.COLMAP_version})",
        "numpy": np.__version__,
        "OpenEXR (Python)": getattr(OpenEXR, "__version__", "?"),
        "Python": sys.version.split()[0],
    }
    for k, v in versions.items():
        print(f"{k}: {v}")
    keep = {"checkerboard"}
    if os.path.isdir(OUT):
        for entry in ("opencv", "undistort", "colmap", "README.md"):
            p = os.path.join(OUT, entry)
            if os.path.isdir(p):
                shutil.rmtree(p)
            elif os.path.exists(p):
                os.remove(p)
    os.makedirs(OUT, exist_ok=True)
    summary = []
    opencv_fixtures(summary)
    undistort_fixtures(summary)
    rec = colmap_fixtures(summary)
    with open(os.path.join(OUT, "README.md"), "w") as f:
        f.write(readme(versions, rec))

    print("\nChecks (max |difference|):")
    for what, v in summary:
        print(f"  {what}: {v:.3g}")
    print("\nFiles:")
    total = 0
    for dirpath, dirnames, filenames in sorted(os.walk(OUT)):
        dirnames.sort()
        if os.path.relpath(dirpath, OUT).split(os.sep)[0] in keep:
            continue
        for fn in sorted(filenames):
            p = os.path.join(dirpath, fn)
            total += os.path.getsize(p)
            print(f"  {os.path.relpath(p, ROOT)}: {os.path.getsize(p)} bytes")
    print(f"  total: {total} bytes")
    assert total < 1_500_000


if __name__ == "__main__":
    main()
