#!/usr/bin/env python3
"""Writes the seed corpus of each fuzz target into fuzz/seeds/TARGET/.

The seeds are small valid inputs from the repository's own test data and
assets (tests/data keeps their licences), rewritten where a target needs
it: scene files point at the fuzz work folder's fixtures (mesh.obj,
tex.png, sky.exr, lights.toml), inputs holding two files are joined with a
NUL byte, and the targets that take a leading selector byte get one. Run
it from the repository root after `cargo build` (it calls target/debug/plsr
for a farm plan and reads images with Python's standard library only):

    python3 scripts/fuzz_seeds.py
"""
import glob
import json
import os
import re
import shutil
import struct
import subprocess
import sys
import tempfile
import tomllib
import zlib

ROOT = os.path.dirname(os.path.dirname(os.path.abspath(__file__)))
SEEDS = os.path.join(ROOT, "fuzz", "seeds")
MAX_BYTES = 16 * 1024


def put(target, name, data):
    d = os.path.join(SEEDS, target)
    os.makedirs(d, exist_ok=True)
    with open(os.path.join(d, name), "wb") as f:
        f.write(data)


def small(paths):
    return [p for p in sorted(paths) if os.path.getsize(p) <= MAX_BYTES]


def read(p):
    with open(p, "rb") as f:
        return f.read()


def fixture_names(text):
    """Points a scene's file references at the fuzz fixtures."""
    def sub(m):
        key, value = m.group(1), m.group(2)
        ext = value.rsplit(".", 1)[-1].lower()
        new = {"obj": "mesh.obj", "png": "tex.png", "jpg": "tex.png", "exr": "sky.exr",
               "hdr": "sky.exr", "toml": "lights.toml", "csv": "response.csv"}.get(ext, value)
        return f'{key} = "{new}"'
    return re.sub(r'(\w+) = "([^"]+\.[A-Za-z]+)"', sub, text)


def scenes():
    files = small(glob.glob(f"{ROOT}/assets/scenes/**/*.toml", recursive=True)
                  + glob.glob(f"{ROOT}/tests/data/*.toml")
                  + glob.glob(f"{ROOT}/examples/**/*.toml", recursive=True))
    for p in files:
        text = read(p).decode()
        if "[camera]" not in text and "[[shapes]]" not in text:
            continue
        name = os.path.basename(p)
        seed = fixture_names(text)
        put("scene_toml", name, seed.encode())
        try:
            doc = tomllib.loads(seed)
        except tomllib.TOMLDecodeError:
            continue
        put("scene_json", name.replace(".toml", ".json"), json.dumps(doc, indent=1).encode())


def mitsuba():
    for p in small(glob.glob(f"{ROOT}/tests/data/**/*.xml", recursive=True)):
        text = read(p)
        if b"<scene" in text:
            put("mitsuba_xml", os.path.basename(p), text)


def gltf():
    for p in small(glob.glob(f"{ROOT}/tests/data/**/*.glb", recursive=True)):
        put("gltf", os.path.basename(p), read(p))
    # A JSON glTF with its buffer after a NUL byte: one triangle.
    positions = struct.pack("<9f", 0, 0, 0, 1, 0, 0, 0, 1, 0)
    doc = {
        "asset": {"version": "2.0"},
        "scene": 0,
        "scenes": [{"nodes": [0, 1]}],
        "nodes": [{"mesh": 0}, {"camera": 0, "translation": [0, 0, 3]}],
        "cameras": [{"type": "perspective", "perspective": {"yfov": 0.8, "znear": 0.1}}],
        "meshes": [{"primitives": [{"attributes": {"POSITION": 0}, "material": 0}]}],
        "materials": [{"pbrMetallicRoughness": {"baseColorFactor": [0.8, 0.2, 0.2, 1]},
                       "emissiveFactor": [1, 1, 1]}],
        "accessors": [{"bufferView": 0, "componentType": 5126, "count": 3, "type": "VEC3",
                       "min": [0, 0, 0], "max": [1, 1, 0]}],
        "bufferViews": [{"buffer": 0, "byteLength": 36}],
        "buffers": [{"uri": "buf.bin", "byteLength": 36}],
    }
    put("gltf", "triangle.gltf", json.dumps(doc).encode() + b"\0" + positions)


def obj():
    mtls = {os.path.basename(p): read(p) for p in glob.glob(f"{ROOT}/assets/**/*.mtl", recursive=True)}
    for p in small(glob.glob(f"{ROOT}/assets/**/*.obj", recursive=True)
                   + glob.glob(f"{ROOT}/tests/data/**/*.obj", recursive=True))[:16]:
        text = read(p)
        m = re.search(rb"mtllib\s+(\S+)", text)
        mtl = mtls.get(m.group(1).decode(), b"") if m else b"newmtl a\nKd 0.5 0.5 0.5\n"
        text = re.sub(rb"mtllib\s+\S+", b"mtllib m2.mtl", text)
        put("obj_mtl", os.path.basename(p), text + b"\0" + mtl)


def ply():
    for p in small(glob.glob(f"{ROOT}/tests/data/**/*.ply", recursive=True)
                   + glob.glob(f"{ROOT}/assets/**/*.ply", recursive=True)):
        put("ply", os.path.basename(p), read(p))
    quad = ("ply\nformat binary_little_endian 1.0\nelement vertex 4\nproperty float x\n"
            "property float y\nproperty float z\nproperty float nx\nproperty float ny\n"
            "property float nz\nproperty float u\nproperty float v\nelement face 1\n"
            "property list uchar int vertex_indices\nend_header\n").encode()
    for x, y in [(0, 0), (1, 0), (1, 1), (0, 1)]:
        quad += struct.pack("<8f", x, y, 0, 0, 0, 1, x, y)
    quad += struct.pack("<B4i", 4, 0, 1, 2, 3)
    put("ply", "quad-binary.ply", quad)


def serialized():
    """Mitsuba's format: per shape a u16 identifier 0x041C, a u16 version
    and a zlib stream of flags, name (v4), counts and arrays; then the
    shapes' offsets and their count."""
    def shape(version, double, normals, uvs):
        flags = (0x2000 if double else 0x1000) | (1 if normals else 0) | (2 if uvs else 0)
        real = "d" if double else "f"
        body = struct.pack("<I", flags)
        if version == 4:
            body += b"quad\0"
        body += struct.pack("<QQ", 4, 2)
        body += struct.pack(f"<12{real}", 0, 0, 0, 1, 0, 0, 1, 1, 0, 0, 1, 0)
        if normals:
            body += struct.pack(f"<12{real}", *([0, 0, 1] * 4))
        if uvs:
            body += struct.pack(f"<8{real}", 0, 0, 1, 0, 1, 1, 0, 1)
        body += struct.pack("<6I", 0, 1, 2, 0, 2, 3)
        return struct.pack("<HH", 0x041C, version) + zlib.compress(body)

    for version in (3, 4):
        for double in (False, True):
            shapes = [shape(version, double, True, True), shape(version, double, False, False)]
            out, offsets = b"", []
            for s in shapes:
                offsets.append(len(out))
                out += s
            for o in offsets:
                out += struct.pack("<I" if version == 3 else "<Q", o)
            out += struct.pack("<I", len(shapes))
            put("mitsuba_serialized", f"v{version}-{'double' if double else 'single'}.serialized",
                b"\x00" + out)


def pls():
    text = read(f"{ROOT}/assets/lights/paper.toml")
    put("pls", "paper.toml", b"\x00" + text)
    put("pls", "paper.json", b"\x01" + json.dumps(tomllib.loads(text.decode())).encode())


def response():
    for p in small(glob.glob(f"{ROOT}/assets/**/*.csv", recursive=True)):
        put("response_csv", os.path.basename(p), read(p))
    rows = "".join(f"{(i / 255) ** 2.2:.6e},{(i / 255) ** 2.0:.6e},{(i / 255) ** 2.4:.6e}\n"
                   for i in range(256))
    put("response_csv", "gamma.csv", rows.encode())


def calibration():
    """OpenCV, ROS and COLMAP calibrations (a model: cameras.txt, NUL, images.txt)."""
    base = f"{ROOT}/tests/fixtures/calibration"
    for p in sorted(glob.glob(f"{base}/opencv/*.yaml") + glob.glob(f"{base}/opencv/*.json")):
        if not p.endswith("_points.json"):
            put("calibration", os.path.basename(p), read(p))
    put("calibration", "checkerboard.yaml", read(f"{base}/checkerboard/calibration.yaml"))
    put("calibration", "colmap.model",
        read(f"{base}/colmap/cameras.txt") + b"\x00" + read(f"{base}/colmap/images.txt")[:8192])


def farm_plan():
    plsr = os.path.join(ROOT, "target", "debug", "plsr")
    scene = os.path.join(ROOT, "tests", "data", "cornell-64.toml")
    with tempfile.TemporaryDirectory() as d:
        for i, args in enumerate([["--parts", "4"], ["--parts", "3", "--spp", "12"]]):
            out = os.path.join(d, f"job{i}")
            r = subprocess.run([plsr, "farm", "slurm", scene, "-o", out, *args],
                               capture_output=True, text=True)
            if r.returncode != 0:
                sys.exit(f"plsr farm slurm failed: {r.stderr}")
            put("farm_plan", f"farm{i}.toml", read(os.path.join(out, "farm.toml")))


def images():
    for p in small(glob.glob(f"{ROOT}/tests/data/**/*.exr", recursive=True))[:4]:
        put("image", os.path.basename(p), b"\x00" + read(p))
    for p in small(glob.glob(f"{ROOT}/assets/**/*.png", recursive=True)
                   + glob.glob(f"{ROOT}/tests/data/**/*.png", recursive=True))[:6]:
        put("image", os.path.basename(p), b"\x02" + read(p))
    # Radiance HDR, flat and run-length encoded rows, 8×4 pixels.
    flat = b"#?RADIANCE\nFORMAT=32-bit_rle_rgbe\n\n-Y 4 +X 8\n" + b"".join(
        bytes([(i * 30) & 255, 128, 64, 129]) for i in range(32))
    put("image", "flat.hdr", b"\x01" + flat)
    width, rle = 16, b"#?RADIANCE\nFORMAT=32-bit_rle_rgbe\n\n-Y 2 +X 16\n"
    for _ in range(2):
        rle += bytes([2, 2, 0, width])
        for channel in range(4):
            rle += bytes([128 + width, 100 + channel])   # one run of 16 equal values
    put("image", "rle.hdr", b"\x01" + rle)
    # Small EXRs in every compression and a JPEG, written by OpenEXR's and
    # OpenCV's Python modules (PLSR_CV_PYTHON: a Python that has both).
    python = os.environ.get("PLSR_CV_PYTHON", "python3")
    with tempfile.TemporaryDirectory() as d:
        r = subprocess.run([python, "-c", PEER_IMAGES, d], capture_output=True, text=True)
        if r.returncode != 0:
            print(f"no EXR or JPEG seeds ({python}: {r.stderr.strip()[-200:]})")
        for name in sorted(os.listdir(d)):
            selector = b"\x03" if name.endswith(".jpg") else b"\x00"
            put("image", name, selector + read(os.path.join(d, name)))


PEER_IMAGES = """
import sys, cv2, numpy as np, OpenEXR, Imath
d = sys.argv[1]
grey = (np.indices((8, 8)).sum(0) % 2 * 255).astype(np.uint8)
cv2.imwrite(f"{d}/tiny.jpg", grey)
cv2.imwrite(f"{d}/tiny-colour.jpg", np.dstack([grey, grey // 2, 255 - grey]))
C = Imath.Compression
for name in ["NO", "RLE", "ZIPS", "ZIP", "PIZ", "PXR24", "B44", "B44A", "DWAA"]:
    for ptype, tag in [(Imath.PixelType.HALF, "half"), (Imath.PixelType.FLOAT, "float")]:
        h = OpenEXR.Header(8, 6)
        h["compression"] = Imath.Compression(getattr(C, name + "_COMPRESSION"))
        h["channels"] = {c: Imath.Channel(Imath.PixelType(ptype)) for c in "RGB"}
        dtype = np.float16 if tag == "half" else np.float32
        data = {c: (np.arange(48, dtype=np.float32).reshape(6, 8) * (i + 1) / 16).astype(dtype).tobytes()
                for i, c in enumerate("RGB")}
        f = OpenEXR.OutputFile(f"{d}/{name.lower()}-{tag}.exr", h)
        f.writePixels(data)
        f.close()
"""


def main():
    shutil.rmtree(SEEDS, ignore_errors=True)
    for make in (scenes, mitsuba, gltf, obj, ply, serialized, pls, response, calibration, farm_plan,
                 images):
        make()
    for t in sorted(os.listdir(SEEDS)):
        n = len(os.listdir(os.path.join(SEEDS, t)))
        print(f"{t}: {n} seeds")


if __name__ == "__main__":
    main()
