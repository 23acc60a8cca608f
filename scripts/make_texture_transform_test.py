#!/usr/bin/env python3
"""Writes `TextureTransformQuads.glb`, plsr's own test model for
`KHR_texture_transform` (no Khronos sample model of it is vendored): four
unit quads in a 2 × 2 grid facing +z, each with the same 64 × 64 texture of
four coloured quadrants (red, green, blue, white) and a repeating sampler,
under a different transform:

    top left      none (the reference)
    top right     offset (0.5, 0.25)
    bottom left   rotation π/6 about the UV origin, scale (1.5, 1.5)
    bottom right  scale (2, 2), offset (−0.25, 0), reading TEXCOORD_1
                  (whose coordinates are TEXCOORD_0 mirrored in u)

Blender's importer (Khronos') turns each into a Mapping node; the fixture
test compares plsr's render with Blender's. Released under CC0 1.0.

Usage: python3 scripts/make_texture_transform_test.py OUT.glb  (needs Pillow)
"""

import io
import math
import struct
import sys

from gltf_shrink import write_glb


def texture_png():
    from PIL import Image

    colours = [(220, 30, 30), (30, 200, 40), (40, 60, 230), (240, 240, 240)]
    im = Image.new("RGB", (64, 64))
    px = im.load()
    for y in range(64):
        for x in range(64):
            px[x, y] = colours[(y >= 32) * 2 + (x >= 32)]
    out = io.BytesIO()
    im.save(out, "PNG")
    return out.getvalue()


def main():
    if len(sys.argv) != 2:
        sys.exit(__doc__)
    # One quad, two triangles, counter-clockwise seen from +z.
    positions = [(-0.5, -0.5, 0), (0.5, -0.5, 0), (0.5, 0.5, 0), (-0.5, 0.5, 0)]
    normals = [(0, 0, 1)] * 4
    uv0 = [(0, 1), (1, 1), (1, 0), (0, 0)]
    uv1 = [(1 - u, v) for u, v in uv0]
    indices = [0, 1, 2, 0, 2, 3]
    blob = bytearray()

    def view(data, target=None):
        blob.extend(b"\0" * (-len(blob) % 4))
        v = {"buffer": 0, "byteOffset": len(blob), "byteLength": len(data)}
        if target:
            v["target"] = target
        blob.extend(data)
        views.append(v)
        return len(views) - 1

    views, accessors = [], []

    def accessor(values, kind, comp, target, minmax=False):
        fmt = {5126: "f", 5123: "H"}[comp]
        flat = [c for v in values for c in (v if isinstance(v, tuple) else (v,))]
        acc = {
            "bufferView": view(struct.pack(f"<{len(flat)}{fmt}", *flat), target),
            "componentType": comp,
            "count": len(values),
            "type": kind,
        }
        if minmax:
            acc["min"] = [min(v[i] for v in values) for i in range(3)]
            acc["max"] = [max(v[i] for v in values) for i in range(3)]
        accessors.append(acc)
        return len(accessors) - 1

    a_pos = accessor(positions, "VEC3", 5126, 34962, minmax=True)
    a_nrm = accessor(normals, "VEC3", 5126, 34962)
    a_uv0 = accessor(uv0, "VEC2", 5126, 34962)
    a_uv1 = accessor(uv1, "VEC2", 5126, 34962)
    a_idx = accessor(indices, "SCALAR", 5123, 34963)
    png = view(texture_png())
    transforms = [
        None,
        {"offset": [0.5, 0.25]},
        {"rotation": math.pi / 6, "scale": [1.5, 1.5]},
        {"scale": [2.0, 2.0], "offset": [-0.25, 0.0], "texCoord": 1},
    ]
    materials = []
    for i, t in enumerate(transforms):
        info = {"index": 0}
        if t is not None:
            info["extensions"] = {"KHR_texture_transform": t}
        materials.append(
            {
                "name": f"quad{i}",
                "pbrMetallicRoughness": {
                    "baseColorTexture": info,
                    "metallicFactor": 0.0,
                    "roughnessFactor": 1.0,
                },
            }
        )
    meshes = [
        {
            "primitives": [
                {
                    "attributes": {
                        "POSITION": a_pos,
                        "NORMAL": a_nrm,
                        "TEXCOORD_0": a_uv0,
                        "TEXCOORD_1": a_uv1,
                    },
                    "indices": a_idx,
                    "material": i,
                }
            ]
        }
        for i in range(4)
    ]
    places = [(-0.55, 0.55), (0.55, 0.55), (-0.55, -0.55), (0.55, -0.55)]
    nodes = [{"mesh": i, "translation": [x, y, 0.0]} for i, (x, y) in enumerate(places)]
    doc = {
        "asset": {"version": "2.0", "generator": "plsr scripts/make_texture_transform_test.py"},
        "extensionsUsed": ["KHR_texture_transform"],
        "scene": 0,
        "scenes": [{"nodes": [0, 1, 2, 3]}],
        "nodes": nodes,
        "meshes": meshes,
        "materials": materials,
        "textures": [{"source": 0, "sampler": 0}],
        "samplers": [{"magFilter": 9728, "minFilter": 9728, "wrapS": 10497, "wrapT": 10497}],
        "images": [{"bufferView": png, "mimeType": "image/png"}],
        "accessors": accessors,
        "bufferViews": views,
        "buffers": [{"byteLength": 0}],
    }
    blob.extend(b"\0" * (-len(blob) % 4))
    doc["buffers"][0]["byteLength"] = len(blob)
    write_glb(sys.argv[1], doc, bytes(blob))


if __name__ == "__main__":
    main()
