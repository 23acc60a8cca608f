#!/usr/bin/env python3
"""Writes `MaterialExtensionSpheres.glb`, plsr's own test model for the
`KHR_materials_*` extensions plsr maps onto its principled models: six
spheres in a row (left to right), each with one extension:

    0  KHR_materials_ior 1.33 with KHR_materials_specular 0.5 (a grey dielectric)
    1  KHR_materials_transmission 1, thin-walled (no volume)
    2  KHR_materials_transmission 1 with KHR_materials_volume thickness 1 (a solid)
    3  KHR_materials_clearcoat 1, clearcoat roughness 0.05, over rough red
    4  KHR_materials_sheen colour (0.9, 0.3, 0.3), roughness 0.5, over dark blue
    5  none (the plain metallic-roughness reference, grey, roughness 0.5)

Released under CC0 1.0. Usage:
python3 scripts/make_material_extensions_test.py OUT.glb
"""

import math
import struct
import sys

from gltf_shrink import write_glb


def sphere(rings=24, segments=48):
    pos, nrm, idx = [], [], []
    for r in range(rings + 1):
        th = math.pi * r / rings
        for s in range(segments + 1):
            ph = 2 * math.pi * s / segments
            n = (math.sin(th) * math.cos(ph), math.cos(th), math.sin(th) * math.sin(ph))
            pos.append(tuple(0.5 * c for c in n))
            nrm.append(n)
    for r in range(rings):
        for s in range(segments):
            a = r * (segments + 1) + s
            b = a + segments + 1
            idx += [a, a + 1, b, a + 1, b + 1, b]
    return pos, nrm, idx


def main():
    if len(sys.argv) != 2:
        sys.exit(__doc__)
    pos, nrm, idx = sphere()
    blob = bytearray()
    views, accessors = [], []

    def add(data, kind, comp, count, target, extra=None):
        blob.extend(b"\0" * (-len(blob) % 4))
        views.append({"buffer": 0, "byteOffset": len(blob), "byteLength": len(data), "target": target})
        blob.extend(data)
        acc = {"bufferView": len(views) - 1, "componentType": comp, "count": count, "type": kind}
        acc.update(extra or {})
        accessors.append(acc)
        return len(accessors) - 1

    flat = lambda vs: [c for v in vs for c in v]
    a_pos = add(struct.pack(f"<{3*len(pos)}f", *flat(pos)), "VEC3", 5126, len(pos), 34962,
                {"min": [-0.5] * 3, "max": [0.5] * 3})
    a_nrm = add(struct.pack(f"<{3*len(nrm)}f", *flat(nrm)), "VEC3", 5126, len(nrm), 34962)
    a_idx = add(struct.pack(f"<{len(idx)}H", *idx), "SCALAR", 5123, len(idx), 34963)
    grey = {"baseColorFactor": [0.8, 0.8, 0.8, 1], "metallicFactor": 0.0, "roughnessFactor": 0.2}
    materials = [
        {"name": "ior_specular", "pbrMetallicRoughness": grey,
         "extensions": {"KHR_materials_ior": {"ior": 1.33},
                        "KHR_materials_specular": {"specularFactor": 0.5}}},
        {"name": "thin_glass", "pbrMetallicRoughness": {**grey, "baseColorFactor": [1, 1, 1, 1], "roughnessFactor": 0.05},
         "extensions": {"KHR_materials_transmission": {"transmissionFactor": 1.0}}},
        {"name": "solid_glass", "pbrMetallicRoughness": {**grey, "baseColorFactor": [1, 1, 1, 1], "roughnessFactor": 0.05},
         "extensions": {"KHR_materials_transmission": {"transmissionFactor": 1.0},
                        "KHR_materials_volume": {"thicknessFactor": 1.0}}},
        {"name": "clearcoat", "pbrMetallicRoughness": {"baseColorFactor": [0.7, 0.1, 0.1, 1], "metallicFactor": 0.0, "roughnessFactor": 0.6},
         "extensions": {"KHR_materials_clearcoat": {"clearcoatFactor": 1.0, "clearcoatRoughnessFactor": 0.05}}},
        {"name": "sheen", "pbrMetallicRoughness": {"baseColorFactor": [0.05, 0.05, 0.2, 1], "metallicFactor": 0.0, "roughnessFactor": 0.8},
         "extensions": {"KHR_materials_sheen": {"sheenColorFactor": [0.9, 0.3, 0.3], "sheenRoughnessFactor": 0.5}}},
        {"name": "plain", "pbrMetallicRoughness": {**grey, "roughnessFactor": 0.5}},
    ]
    meshes = [{"primitives": [{"attributes": {"POSITION": a_pos, "NORMAL": a_nrm}, "indices": a_idx, "material": i}]}
              for i in range(len(materials))]
    nodes = [{"mesh": i, "translation": [1.2 * (i - 2.5), 0.0, 0.0]} for i in range(len(materials))]
    used = sorted({e for m in materials for e in m.get("extensions", {})})
    doc = {
        "asset": {"version": "2.0", "generator": "plsr scripts/make_material_extensions_test.py"},
        "extensionsUsed": used,
        "scene": 0, "scenes": [{"nodes": list(range(len(nodes)))}],
        "nodes": nodes, "meshes": meshes, "materials": materials,
        "accessors": accessors, "bufferViews": views, "buffers": [{"byteLength": 0}],
    }
    blob.extend(b"\0" * (-len(blob) % 4))
    doc["buffers"][0]["byteLength"] = len(blob)
    write_glb(sys.argv[1], doc, bytes(blob))


if __name__ == "__main__":
    main()
