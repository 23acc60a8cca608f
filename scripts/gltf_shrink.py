#!/usr/bin/env python3
"""Makes a small copy of a binary glTF (.glb) for the test suite: every
embedded image is scaled down to at most --max-size texels on its longer side
(Lanczos) and re-encoded in its own format (PNG stays PNG, JPEG stays JPEG at
quality 90); geometry, materials, samplers and every other byte stay as they
are. The binary chunk is rebuilt with each buffer view 4-byte aligned and the
views' offsets and the buffer's length updated.

Usage:

    python3 scripts/gltf_shrink.py IN.glb OUT.glb [--max-size 128]

Needs Pillow. Images referenced by URI (not embedded) are left alone.
"""

import io
import json
import os
import struct
import sys

GLB_MAGIC = 0x46546C67
CHUNK_JSON = 0x4E4F534A
CHUNK_BIN = 0x004E4942


def read_glb(path):
    data = open(path, "rb").read()
    magic, version, length = struct.unpack_from("<III", data, 0)
    if magic != GLB_MAGIC or version != 2 or length != len(data):
        sys.exit(f"{path}: not a glTF 2.0 binary (or its length field is wrong)")
    offset, doc, binary = 12, None, b""
    while offset < length:
        size, kind = struct.unpack_from("<II", data, offset)
        chunk = data[offset + 8 : offset + 8 + size]
        if kind == CHUNK_JSON:
            doc = json.loads(chunk)
        elif kind == CHUNK_BIN:
            binary = chunk
        offset += 8 + size
    if doc is None:
        sys.exit(f"{path}: no JSON chunk")
    return doc, binary


def write_glb(path, doc, binary):
    """Writes next to `path`, then renames: an interrupted run leaves no
    half file."""
    text = json.dumps(doc, separators=(",", ":")).encode()
    text += b" " * (-len(text) % 4)
    binary += b"\0" * (-len(binary) % 4)
    total = 12 + 8 + len(text) + (8 + len(binary) if binary else 0)
    partial = f"{path}.partial"
    with open(partial, "wb") as f:
        f.write(struct.pack("<III", GLB_MAGIC, 2, total))
        f.write(struct.pack("<II", len(text), CHUNK_JSON) + text)
        if binary:
            f.write(struct.pack("<II", len(binary), CHUNK_BIN) + binary)
    os.replace(partial, path)


def shrink(image_bytes, max_size):
    from PIL import Image

    im = Image.open(io.BytesIO(image_bytes))
    fmt = im.format
    scale = max_size / max(im.size)
    if scale < 1.0:
        size = (max(1, round(im.width * scale)), max(1, round(im.height * scale)))
        im = im.resize(size, Image.LANCZOS)
    out = io.BytesIO()
    if fmt == "JPEG":
        im.convert("RGB").save(out, "JPEG", quality=90)
    else:
        im.save(out, "PNG", optimize=True)
    return out.getvalue()


def main():
    args = sys.argv[1:]
    max_size = 128
    if "--max-size" in args:
        i = args.index("--max-size")
        max_size = int(args[i + 1])
        del args[i : i + 2]
    if len(args) != 2:
        sys.exit(__doc__)
    src, dst = args
    if os.path.exists(dst) and os.path.samefile(src, dst):
        sys.exit(f"{dst}: is the input; write the small copy elsewhere")
    doc, binary = read_glb(src)
    views = doc.get("bufferViews", [])
    image_views = {im["bufferView"] for im in doc.get("images", []) if "bufferView" in im}
    rebuilt = bytearray()
    for i, view in enumerate(views):
        if view.get("buffer", 0) != 0:
            sys.exit(f"{src}: bufferViews[{i}] names a buffer other than the GLB's own")
        start = view.get("byteOffset", 0)
        chunk = binary[start : start + view["byteLength"]]
        if i in image_views:
            chunk = shrink(chunk, max_size)
        rebuilt += b"\0" * (-len(rebuilt) % 4)
        view["byteOffset"] = len(rebuilt)
        view["byteLength"] = len(chunk)
        rebuilt += chunk
    if doc.get("buffers"):
        doc["buffers"][0]["byteLength"] = len(rebuilt)
    doc.setdefault("asset", {})["extras"] = {
        "plsr": f"images scaled to at most {max_size} texels by scripts/gltf_shrink.py"
    }
    write_glb(dst, doc, bytes(rebuilt))
    print(f"{src} → {dst}: {len(binary)} → {len(rebuilt)} bytes of binary data")


if __name__ == "__main__":
    main()
