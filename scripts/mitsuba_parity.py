#!/usr/bin/env python3
"""Judges plsr's import of Mitsuba 3 XML scenes the way Mitsuba judges its own
renders (src/render/tests/test_renders.py of mitsuba3): a per-pixel z-test of
the image against a high-spp reference whose per-sample variance comes from
Mitsuba's `moment` integrator.

Usage:

    python3 scripts/mitsuba_parity.py SCENE.xml|FOLDER ... [options]

    --size N              render at a reduced size, longest side N (see below)
    --ref-spp N           reference samples per pixel (default 4096)
    --spp N               test samples per pixel (default: Mitsuba's rule,
                          2e6 // pixels, at least 1)
    --seed S              plsr's seed and the Mitsuba self-check's (default 0)
    --ref-seed S          reference seed (default 1; passes use S*2^20 + i)
    -D NAME=VALUE         scene parameter for both renderers (repeatable;
                          `spp` is set to the spp of each render when the
                          scene uses $spp; -D goes to plsr only if it has -D)
    --pass-samples N      samples per reference pass (default 2^22; memory)
    --mitsuba-self-check  also render the test image with Mitsuba and z-test it
    --check-moment        also render the reference plainly (same seeds) and
                          compare its mean with the moment integrator's
    --no-plsr             judge Mitsuba only (needs --mitsuba-self-check to
                          judge anything; references are still rendered)
    --ref-always          render references even for scenes plsr refused
    --plsr-scene FILE     with one scene: plsr renders FILE instead (a perturbed
                          copy, to see the test fail); the reference is the scene's
    --plsr PATH           plsr binary (default target/release/plsr, then
                          target/debug/plsr, next to this script)
    --threads N           threads for Mitsuba and plsr (default: all cores)
    --variant V           Mitsuba variant (default llvm_ad_rgb, else scalar_rgb)
    --cache DIR           reference cache (default /tmp/mitsuba_parity_cache)
    --no-cache            neither read nor write the cache
    --write-fixtures DIR  store small scenes' references for a Rust test
    --fixture-max-pixels  what "small" means (default 4096 = 64x64)
    --save-images DIR     write plsr's image, the reference and the rejected
                          pixels (RGB EXR) for every judged scene
    --json FILE           also write the rows as JSON
    --keep-temp           keep the temporary folders (resized scenes, outputs)
    --verbose             show Mitsuba's warnings (hidden: log level Error)

Method (as in mitsuba3's test_renders.py, read at commit b45b0a930):

* Reference: `moment` integrator around the scene's own integrator. `moment`
  records, per sample, the sample's colour converted to CIE XYZ
  (srgb_to_xyz in RGB variants) as the AOVs `<name>.X/Y/Z` and its square as
  `m2_<name>.X/Y/Z`; the film averages both, so var = E[x^2] - E[x]^2 is the
  per-sample variance of the XYZ values. (Layers are picked by name: the
  `nested` name sorts after `m2_nested`, so `Bitmap.split()`'s order, which
  the Mitsuba test relies on for its `_arg_0` names, would swap them.)
* Test image (plsr's RGB, or Mitsuba's film RGB): converted to XYZ with
  `mi.Bitmap.convert(PixelFormat.XYZ, Float32, srgb_gamma=False)`, i.e. the
  linear sRGB (D65) to XYZ matrix
      X = 0.412453 R + 0.357580 G + 0.180423 B
      Y = 0.212671 R + 0.715160 G + 0.072169 B
      Z = 0.019334 R + 0.119193 G + 0.950227 B
* z = |img - ref| * sqrt(spp / max(var_ref, 1e-4)) per pixel and channel,
  p = 2 (1 - Phi(z)) with Phi(z) = (1 - erf(-z / sqrt 2)) / 2 in float32,
  alpha = 1 - (1 - 0.01)^(1 / pixel_count)  (Sidak over the *pixels*, as
  Mitsuba does, although 3 channels per pixel are tested), a pixel-channel
  passes when p > alpha, the scene passes when the number of passing
  pixel-channels / 3 >= 0.9975 * pixel_count.
* Test spp = 2e6 // pixel_count (at least 1), as Mitsuba's test.
  Caveat: the z-test ignores the reference's own noise; with a reference of
  R spp and a test of N spp the true z is smaller by sqrt(1 + N/R).
* Also printed: the ratio of the images' means per RGB channel
  (mean(img) / mean(ref)) and the relative MSE,
  mean((img - ref)^2 / (ref^2 + 0.01)) over the RGB pixel-channels.

--size N: the documentation scenes state their film sizes as literal numbers
(only one of them uses `$res`, none `$resx`/`$resy`), and 8 of the 9 files in
docs/scenes/include/ hold the film of the scenes that include them, so the
size cannot be given as a parameter. The scene is rewritten instead: the root
file and every file it includes (recursively) are copied into a temporary
folder, the included ones at the same location relative to the file that
includes them (an include found elsewhere through the file resolver is
copied aside and named by its absolute path). Every <film>'s width and height
(and crop_*) are scaled to the longest side N, keeping the aspect ratio
(`$name` values are resolved through -D and <default>s first); a <sensor>
without a film gets an hdrfilm of the default 768x576 scaled. The copied
root gets `<path value="ORIGINAL_FOLDER"/>` as its first child and each
copied include `<path value="FOLDER_OF_THE_FILE_THAT_INCLUDED_IT"/>` (which
reproduces Mitsuba's resolver order inside an include); relative <path>
values are made absolute. Scenes already within N are rendered unmodified.

Threads: Mitsuba's OpenEXR reading and writing deadlock in this Mitsuba
(3.9.1, drjit 1.5) when drjit's thread pool has one thread, so loading and
EXR I/O run with at least 2 threads and only the renders with --threads.

Cache: references are stored in --cache as <key>.npz + <key>.json, the key a
SHA-256 of the texts of the scene and its includes, the size, the reference
spp and seed, the variant and Mitsuba's version (not of meshes and textures:
clear the cache when those change).

Fixtures (--write-fixtures DIR, scenes of at most --fixture-max-pixels):
DIR/<scene>.ref.exr (reference mean) and DIR/<scene>.var.exr (per-sample
variance), both float32 CIE XYZ (channels X, Y, Z), and DIR/<scene>.json
with the scene, spp, seeds, Mitsuba's version and the test's constants; a
copy of the scene as rendered: DIR/<scene>.xml when self-contained (no
include, path or file names), else DIR/<scene>.scene/ (the root file and, when
resized, the rewritten includes), its <path>s naming the original folders
relative to the copy (so it only works where those folders are).
"""
import argparse
import datetime
import hashlib
import json
import os
import re
import shutil
import subprocess
import sys
import tempfile
import time
import xml.etree.ElementTree as ET
from contextlib import contextmanager
from pathlib import Path

import numpy as np

LLVM_LIB = "/usr/lib/x86_64-linux-gnu/libLLVM.so.19.1"
if "DRJIT_LIBLLVM_PATH" not in os.environ and os.path.exists(LLVM_LIB):
    os.environ["DRJIT_LIBLLVM_PATH"] = LLVM_LIB

import drjit as dr  # noqa: E402
import mitsuba as mi  # noqa: E402

SIGNIFICANCE = 0.01
PASS_FRACTION = 0.9975
VAR_FLOOR = 1e-4
SAMPLE_BUDGET = 2_000_000
RGB_TO_XYZ = [[0.412453, 0.357580, 0.180423],
              [0.212671, 0.715160, 0.072169],
              [0.019334, 0.119193, 0.950227]]
HDRFILM_DEFAULT = (768, 576)
CACHE_FORMAT = 1

# --------------------------------------------------------------------------
# Mitsuba setup and threads

RENDER_THREADS = None


def setup_mitsuba(variant, threads):
    global RENDER_THREADS
    chosen = None
    for v in ([variant] if variant else ["llvm_ad_rgb", "scalar_rgb"]):
        try:
            mi.set_variant(v)
            if v.startswith("llvm"):   # fails here when libLLVM is missing
                dr.eval(dr.llvm.Float([1.0, 2.0]) + 1.0)
            chosen = v
            break
        except Exception as e:  # noqa: BLE001
            print(f"note: Mitsuba variant {v} unavailable ({e})", file=sys.stderr)
    if chosen is None:
        sys.exit("no usable Mitsuba variant")
    RENDER_THREADS = threads
    dr.set_thread_count(max(2, threads))
    return chosen


@contextmanager
def render_threads():
    """drjit's pool at --threads for a render, back to >= 2 afterwards (EXR
    I/O and texture loading deadlock with a single thread)."""
    dr.set_thread_count(RENDER_THREADS)
    try:
        yield
    finally:
        dr.set_thread_count(max(2, RENDER_THREADS))


# --------------------------------------------------------------------------
# Scene files: includes, parameters, resizing

PARAM_RE = re.compile(r"\$([A-Za-z_][A-Za-z0-9_]*)")


def subst_params(text, params):
    for k in sorted(params, key=len, reverse=True):
        text = text.replace("$" + k, str(params[k]))
    return text


class SceneInfo:
    def __init__(self, scene, params, size, out_root=None):
        self.scene = Path(scene).resolve()
        self.root_dir = self.scene.parent
        self.size = size
        self.out_root = out_root
        self.files = []            # (original path, text), in parse order
        self.params = dict(params)  # -D params, then <default>s (first wins)
        self.orig_films = []       # (width, height) as written
        self.films = []            # (width, height) rendered (crop size)
        self.uses = set()          # $names referenced
        self.self_contained = True
        self.has_sensor = False
        self.rendered_path = self.scene
        self.resized = False

    @property
    def pixel_size(self):
        return self.films[0] if self.films else HDRFILM_DEFAULT

    def text_hash(self):
        h = hashlib.sha256()
        for _, text in self.files:
            h.update(text.encode())
            h.update(b"\0")
        return h.hexdigest()


def _resolve(name, here, path_dirs, root_dir):
    """Emulates Mitsuba's FileResolver for an include: the including file's
    folder, then the <path>s (the latest first), then the scene's folder."""
    p = Path(name)
    if p.is_absolute():
        return p.resolve() if p.exists() else None
    for d in [here] + list(reversed(path_dirs)) + [root_dir]:
        c = Path(d) / p
        if c.exists():
            return c.resolve()
    return None


def _scaled(w, h, n):
    if n is None or max(w, h) <= n:
        return w, h
    s = n / max(w, h)
    return max(1, round(w * s)), max(1, round(h * s))


def _resize_film(film, info):
    ints = {c.get("name"): c for c in film if c.tag == "integer"}

    def val(name, default):
        c = ints.get(name)
        if c is None:
            return default
        return int(float(subst_params(c.get("value", ""), info.params)))

    w = val("width", HDRFILM_DEFAULT[0])
    h = val("height", HDRFILM_DEFAULT[1])
    info.orig_films.append((w, h))
    cw, ch = val("crop_width", w), val("crop_height", h)
    nw, nh = _scaled(w, h, info.size)
    if (nw, nh) == (w, h):
        info.films.append((cw, ch))
        return

    def setv(name, v):
        c = ints.get(name)
        if c is None:
            c = ET.SubElement(film, "integer", {"name": name})
        c.set("value", str(v))

    setv("width", nw)
    setv("height", nh)
    if any(k in ints for k in ("crop_width", "crop_height", "crop_offset_x", "crop_offset_y")):
        sx, sy = nw / w, nh / h
        ox = min(nw - 1, round(val("crop_offset_x", 0) * sx))
        oy = min(nh - 1, round(val("crop_offset_y", 0) * sy))
        ncw = max(1, min(nw - ox, round(cw * sx)))
        nch = max(1, min(nh - oy, round(ch * sy)))
        for k, v in (("crop_offset_x", ox), ("crop_offset_y", oy),
                     ("crop_width", ncw), ("crop_height", nch)):
            setv(k, v)
        info.films.append((ncw, nch))
    else:
        info.films.append((nw, nh))


def _walk(info, path, out_path, path_dirs, depth, including_dir=None):
    """Reads one scene file (the root or an include) in document order:
    records its parameters and films, resizes the films (info.size), follows
    the includes and, when out_path is given, writes the modified copy."""
    if depth > 15:
        raise RuntimeError(f"{path}: includes nested too deep")
    text = Path(path).read_text()
    info.files.append((str(path), text))
    info.uses.update(PARAM_RE.findall(text))
    tree = ET.ElementTree(ET.fromstring(text))
    root = tree.getroot()
    here = Path(path).parent
    paths = list(path_dirs)   # <path>s of an include stay in it (Mitsuba
                              # restores the resolver after an include)

    def visit(el):
        for child in list(el):
            tag = child.tag
            if not isinstance(tag, str):
                continue
            if tag == "default":
                info.params.setdefault(child.get("name"), child.get("value"))
            elif tag == "path":
                info.self_contained = False
                v = child.get("value", "")
                cand = Path(v) if Path(v).is_absolute() else here / v
                if not cand.exists():
                    cand = _resolve(v, here, paths, info.root_dir) or cand
                cand = cand.resolve()
                paths.append(str(cand))
                child.set("value", str(cand))
            elif tag == "include":
                info.self_contained = False
                name = subst_params(child.get("filename", ""), info.params)
                found = _resolve(name, here, paths, info.root_dir)
                if found is None:
                    raise RuntimeError(f"{path}: included file {name!r} not found")
                sub_out = None
                if out_path is not None:
                    if not Path(name).is_absolute() and (here / name).resolve() == found:
                        sub_out = (Path(out_path).parent / name).resolve()
                        if info.out_root not in sub_out.parents:
                            sub_out = None
                    if sub_out is None:
                        tag_ = hashlib.sha1(str(found).encode()).hexdigest()[:10]
                        sub_out = info.out_root / "_included" / tag_ / found.name
                        # Relative to the including copy, so that the copy
                        # still finds it once moved into a fixture folder.
                        child.set("filename",
                                  os.path.relpath(sub_out, Path(out_path).parent))
                    sub_out.parent.mkdir(parents=True, exist_ok=True)
                _walk(info, found, sub_out, paths, depth + 1, including_dir=str(here))
            elif tag == "sensor":
                info.has_sensor = True
                if child.find("film") is None:
                    w, h = HDRFILM_DEFAULT
                    nw, nh = _scaled(w, h, info.size)
                    info.orig_films.append((w, h))
                    info.films.append((nw, nh))
                    if (nw, nh) != (w, h):
                        f = ET.SubElement(child, "film", {"type": "hdrfilm"})
                        ET.SubElement(f, "integer", {"name": "width", "value": str(nw)})
                        ET.SubElement(f, "integer", {"name": "height", "value": str(nh)})
                visit(child)
            elif tag == "film":
                _resize_film(child, info)
                visit(child)
            else:
                if child.get("name", "").endswith("filename"):
                    info.self_contained = False
                visit(child)

    visit(root)
    if out_path is not None:
        first = str(info.root_dir) if depth == 0 else including_dir
        el = ET.Element("path", {"value": first})
        root.insert(0, el)
        ET.indent(tree, space="    ")
        tree.write(out_path, encoding="unicode")


def prepare_scene(scene, size, params, tmp):
    """Reads a scene and its includes; when a film is larger than `size`,
    writes the resized copy into tmp/scene/ and renders that."""
    info = SceneInfo(scene, params, None)
    _walk(info, info.scene, None, [], 0)
    if size is None or all(max(w, h) <= size for w, h in info.orig_films) \
            and (info.orig_films or not info.has_sensor):
        return info
    out_root = (Path(tmp) / "scene").resolve()
    out_root.mkdir(parents=True, exist_ok=True)
    info2 = SceneInfo(scene, params, size, out_root)
    info2.rendered_path = out_root / info2.scene.name
    info2.resized = True
    _walk(info2, info2.scene, info2.rendered_path, [], 0)
    # the key of the cache: the original texts (the copies name temp folders)
    info2.files = info.files
    return info2


# --------------------------------------------------------------------------
# Images

def bitmap_channels(bmp):
    """{channel name: HxW float64} of a Bitmap (layers prefixed 'layer.')."""
    st = bmp.struct_()
    names = [st[i].name for i in range(bmp.channel_count())]
    arr = np.array(bmp, copy=True).astype(np.float64)
    if arr.ndim == 2:
        arr = arr[..., None]
    return {n: arr[..., i] for i, n in enumerate(names)}


def rgb_to_xyz(rgb):
    """Mitsuba's conversion: Bitmap RGB -> XYZ (float32, no sRGB gamma)."""
    b = mi.Bitmap(np.ascontiguousarray(rgb, dtype=np.float32), mi.Bitmap.PixelFormat.RGB)
    return np.array(b.convert(mi.Bitmap.PixelFormat.XYZ, mi.Struct.Type.Float32, False),
                    copy=True)


def xyz_to_rgb(xyz):
    b = mi.Bitmap(np.ascontiguousarray(xyz, dtype=np.float32), mi.Bitmap.PixelFormat.XYZ)
    return np.array(b.convert(mi.Bitmap.PixelFormat.RGB, mi.Struct.Type.Float32, False),
                    copy=True)


def pick(ch, names, what):
    missing = [n for n in names if n not in ch]
    if missing:
        raise RuntimeError(f"{what}: no channel(s) {missing} among {sorted(ch)}")
    return np.stack([ch[n] for n in names], axis=-1)


def read_rgb_exr(path):
    ch = bitmap_channels(mi.Bitmap(str(path)))
    if all(n in ch for n in "RGB"):
        return pick(ch, ["R", "G", "B"], str(path))
    if "Y" in ch:
        return np.repeat(ch["Y"][..., None], 3, axis=-1)
    raise RuntimeError(f"{path}: no R, G, B channels (has {sorted(ch)})")


def write_exr(path, arr, fmt):
    mi.Bitmap(np.ascontiguousarray(arr, dtype=np.float32), fmt).write(str(path))


# --------------------------------------------------------------------------
# The z-test (as mitsuba3 src/render/tests/test_renders.py)

def z_test(img_xyz, spp, ref_xyz, var_xyz):
    """Two-sided p-values of the z statistic, float32 as Mitsuba computes."""
    var = np.maximum(var_xyz.astype(np.float32), np.float32(VAR_FLOOR))
    z = np.abs(img_xyz.astype(np.float32) - ref_xyz.astype(np.float32)) \
        * np.sqrt(np.float32(spp) / var)
    flat = dr.scalar.ArrayXf(z.astype(np.float32).ravel())
    cdf = (1.0 - dr.erf(-flat / dr.sqrt(2.0))) * 0.5
    cdf = np.array(cdf, dtype=np.float32).reshape(z.shape)
    return (np.float32(2.0) * (np.float32(1.0) - cdf)).astype(np.float32)


def judge(img_rgb, spp, ref, what):
    """z-test of an RGB image against the reference dict; returns a dict."""
    ref_xyz, var_xyz, ref_rgb = ref["xyz"], ref["var"], ref["rgb"]
    if img_rgb.shape != ref_rgb.shape:
        raise RuntimeError(f"{what}: image is {img_rgb.shape[1]}x{img_rgb.shape[0]}, "
                           f"reference {ref_rgb.shape[1]}x{ref_rgb.shape[0]}")
    img_xyz = rgb_to_xyz(img_rgb)
    p = z_test(img_xyz, spp, ref_xyz, var_xyz)
    pixels = img_rgb.shape[0] * img_rgb.shape[1]
    alpha = 1.0 - (1.0 - SIGNIFICANCE) ** (1.0 / pixels)
    ok = p > alpha
    passing = np.count_nonzero(ok) / 3
    with np.errstate(divide="ignore", invalid="ignore"):
        ratio = (img_rgb.reshape(-1, 3).mean(0) / ref_rgb.reshape(-1, 3).mean(0))
    rel_mse = float(np.mean((img_rgb - ref_rgb) ** 2 / (ref_rgb ** 2 + 1e-2)))
    return {
        "passed": bool(passing >= PASS_FRACTION * pixels),
        "pass_fraction": float(np.count_nonzero(ok) / ok.size),
        "min_p": float(p.min()),
        "alpha": alpha,
        "mean_ratio": [float(x) for x in ratio],
        "rel_mse": rel_mse,
        "ok_mask": ok,
    }


# --------------------------------------------------------------------------
# Mitsuba renders

def load_scene(info, spp):
    kw = {k: str(v) for k, v in info.cli_params.items()}
    if "spp" in info.uses and "spp" not in kw:
        kw["spp"] = str(spp)
    return mi.load_file(str(info.rendered_path), **kw)


def render_reference(info, spp, seed, pass_samples, check_plain):
    """Mean (RGB and XYZ) and per-sample XYZ variance from `moment`, in
    passes of at most pass_samples samples (seeds seed*2^20 + pass)."""
    t0 = time.perf_counter()
    scene = load_scene(info, spp)
    film = scene.sensors()[0].film()
    w, h = (int(x) for x in film.crop_size())
    inner = scene.integrator()
    integ = mi.load_dict({"type": "moment", "nested": inner})
    per_pass = max(1, min(spp, pass_samples // (w * h)))
    acc = {"rgb": 0.0, "xyz": 0.0, "m2": 0.0}
    plain, plain_time = 0.0, 0.0
    done, i = 0, 0
    while done < spp:
        n = min(per_pass, spp - done)
        s = (seed << 20) + i
        with render_threads():
            integ.render(scene, seed=s, spp=n)
        ch = bitmap_channels(film.bitmap(raw=False))
        acc["rgb"] = acc["rgb"] + n * pick(ch, ["R", "G", "B"], "moment film")
        acc["xyz"] = acc["xyz"] + n * pick(ch, ["nested.X", "nested.Y", "nested.Z"], "moment film")
        acc["m2"] = acc["m2"] + n * pick(ch, ["m2_nested.X", "m2_nested.Y", "m2_nested.Z"],
                                         "moment film")
        if check_plain:
            tp = time.perf_counter()
            with render_threads():
                inner.render(scene, seed=s, spp=n)
            chp = bitmap_channels(film.bitmap(raw=False))
            plain = plain + n * pick(chp, ["R", "G", "B"], "film")
            plain_time += time.perf_counter() - tp
        done += n
        i += 1
    ref = {k: v / spp for k, v in acc.items()}
    ref["var"] = ref["m2"] - ref["xyz"] ** 2
    del ref["m2"]
    ref["time"] = time.perf_counter() - t0 - plain_time   # load + moment renders
    ref["passes"] = i
    if check_plain:
        plain = plain / spp
        scale = max(1e-6, float(np.abs(plain).mean()))
        from_xyz = xyz_to_rgb(ref["xyz"])
        ref["moment_check"] = {
            "max_abs_diff_root_vs_plain": float(np.abs(ref["rgb"] - plain).max()),
            "max_abs_diff_xyz_vs_plain": float(np.abs(from_xyz - plain).max()),
            "mean_plain": [float(x) for x in plain.reshape(-1, 3).mean(0)],
            "mean_moment": [float(x) for x in from_xyz.reshape(-1, 3).mean(0)],
            "rel_to_mean": float(np.abs(from_xyz - plain).max() / scale),
        }
    return ref


def mitsuba_test_image(info, spp, seed):
    t0 = time.perf_counter()
    scene = load_scene(info, spp)
    with render_threads():
        scene.integrator().render(scene, seed=seed, spp=spp)
    ch = bitmap_channels(scene.sensors()[0].film().bitmap(raw=False))
    return pick(ch, ["R", "G", "B"], "film"), time.perf_counter() - t0


def cache_key(info, spp, seed, variant):
    h = hashlib.sha256()
    h.update(json.dumps({
        "format": CACHE_FORMAT, "text": info.text_hash(), "size": list(info.pixel_size),
        "spp": spp, "seed": seed, "variant": variant,
        "mitsuba": mi.__version__, "params": sorted(info.cli_params.items()),
    }, sort_keys=True).encode())
    return h.hexdigest()[:24]


def get_reference(info, args, variant):
    key = cache_key(info, args.ref_spp, args.ref_seed, variant)
    cdir = Path(args.cache)
    npz, meta = cdir / f"{key}.npz", cdir / f"{key}.json"
    if not args.no_cache and npz.exists() and meta.exists() and not args.check_moment:
        d = np.load(npz)
        m = json.loads(meta.read_text())
        return {"rgb": d["rgb"], "xyz": d["xyz"], "var": d["var"], "time": m["time"],
                "cached": True, "key": key}
    ref = render_reference(info, args.ref_spp, args.ref_seed, args.pass_samples,
                           args.check_moment)
    ref["cached"] = False
    ref["key"] = key
    if not args.no_cache:
        cdir.mkdir(parents=True, exist_ok=True)
        np.savez_compressed(npz, rgb=ref["rgb"], xyz=ref["xyz"], var=ref["var"])
        meta.write_text(json.dumps({
            "scene": str(info.scene), "size": list(info.pixel_size), "spp": args.ref_spp,
            "seed": args.ref_seed, "variant": variant, "mitsuba": mi.__version__,
            "time": ref["time"], "threads": args.threads, "passes": ref["passes"],
            "date": datetime.datetime.now().isoformat(timespec="seconds"),
        }, indent=1))
    return ref


# --------------------------------------------------------------------------
# plsr

class Plsr:
    def __init__(self, path):
        self.path = path
        try:
            self.help = subprocess.run([path, "render", "--help"], capture_output=True,
                                       text=True, timeout=60).stdout
        except OSError as e:
            sys.exit(f"cannot run plsr ({path}): {e}")
        self.has_D = re.search(r"(^|\s)-D[\s,<]", self.help) is not None
        self.has_threads = "--threads" in self.help
        self.has_quiet = "--quiet" in self.help
        self.extra_args = []

    def render(self, info, out, spp, seed, threads, scene_file=None):
        cmd = [self.path, "render", str(scene_file or info.rendered_path), "-o", str(out),
               "--spp", str(spp), "--seed", str(seed)]
        if self.has_threads:
            cmd += ["--threads", str(threads)]
        if self.has_quiet:
            cmd += ["-q"]
        cmd += self.extra_args
        if self.has_D:
            d = dict(info.cli_params)
            if "spp" in info.uses:
                d.setdefault("spp", spp)
            for k, v in d.items():
                cmd += ["-D", f"{k}={v}"]
        t0 = time.perf_counter()
        r = subprocess.run(cmd, capture_output=True, text=True)
        dt = time.perf_counter() - t0
        if r.returncode != 0 or not Path(out).exists():
            text = r.stderr + "\n" + r.stdout
            if info.resized:   # name the original files, not the temporary copies
                text = text.replace(str(info.out_root), str(info.root_dir))
            lines = [l.strip() for l in text.splitlines() if l.strip()]
            crash = "panicked" in text or r.returncode < 0
            err = next((l for l in lines if "panicked" in l or "error" in l.lower()),
                       lines[0] if lines else f"exit status {r.returncode}")
            if r.returncode < 0:
                err = f"killed by signal {-r.returncode}: {err}"
            return None, dt, err, crash
        return read_rgb_exr(out), dt, None, False


def default_plsr():
    here = Path(__file__).resolve().parent.parent
    for base in (here, Path("/work/main")):
        for kind in ("release", "debug"):
            p = base / "target" / kind / "plsr"
            if p.exists():
                return str(p)
    return "plsr"


# --------------------------------------------------------------------------
# Fixtures

def _relativize(xml_file):
    """Absolute <path> values and include names -> relative to xml_file."""
    tree = ET.parse(xml_file)
    here = Path(xml_file).resolve().parent
    for el in tree.iter():
        attr = {"path": "value", "include": "filename"}.get(el.tag)
        if attr and Path(el.get(attr, "")).is_absolute():
            el.set(attr, os.path.relpath(el.get(attr), here))
    ET.indent(tree, space="    ")
    tree.write(xml_file, encoding="unicode")


def fixture_scene(d, name, info):
    """The scene as rendered, next to the fixture: a self-contained scene
    as <name>.xml; otherwise <name>.scene/ holding the root (and, when
    resized, the rewritten includes) whose <path>s name the original folders
    relative to the copy. Returns the name relative to d."""
    if info.self_contained and not info.resized:
        shutil.copyfile(info.scene, d / f"{name}.xml")
        return f"{name}.xml"
    dest = d / f"{name}.scene"
    shutil.rmtree(dest, ignore_errors=True)
    if info.resized:
        shutil.copytree(info.out_root, dest)
    else:
        dest.mkdir(parents=True)
        tree = ET.parse(info.scene)
        tree.getroot().insert(0, ET.Element("path", {"value": str(info.root_dir)}))
        for el in tree.getroot():
            if el.tag == "path" and not Path(el.get("value", "")).is_absolute():
                el.set("value", str((info.root_dir / el.get("value")).resolve()))
        tree.write(dest / info.scene.name, encoding="unicode")
    for f in dest.rglob("*.xml"):
        _relativize(f)
    return str(Path(dest.name) / info.scene.name)


def write_fixture(dirpath, name, info, ref, args, variant, test_spp):
    d = Path(dirpath)
    d.mkdir(parents=True, exist_ok=True)
    w, h = info.pixel_size
    write_exr(d / f"{name}.ref.exr", ref["xyz"], mi.Bitmap.PixelFormat.XYZ)
    write_exr(d / f"{name}.var.exr", ref["var"], mi.Bitmap.PixelFormat.XYZ)
    scene_copy = fixture_scene(d, name, info)
    pixels = w * h
    (d / f"{name}.json").write_text(json.dumps({
        "scene": name,
        "scene_source": str(info.scene),
        "scene_file": scene_copy,
        "scene_sha256": info.text_hash(),
        "resized_to_longest_side": args.size if info.resized else None,
        "width": w, "height": h,
        "reference_spp": args.ref_spp,
        "reference_seed": args.ref_seed,
        "reference_passes_seeds": "reference_seed * 2^20 + pass index",
        "test_spp": test_spp,
        "test_seed": args.seed,
        "parameters": {k: str(v) for k, v in info.cli_params.items()},
        "mitsuba_version": mi.__version__,
        "mitsuba_variant": variant,
        "mean_file": f"{name}.ref.exr",
        "variance_file": f"{name}.var.exr",
        "color_space": "CIE XYZ (channels X, Y, Z), float32",
        "rgb_to_xyz": RGB_TO_XYZ,
        "variance": "per-sample: E[xyz^2] - E[xyz]^2 from Mitsuba's moment integrator",
        "z_test": {
            "z": "|img_xyz - ref_xyz| * sqrt(test_spp / max(var, variance_floor))",
            "p": "2 * (1 - Phi(z)), Phi(z) = (1 - erf(-z / sqrt(2))) / 2, float32",
            "variance_floor": VAR_FLOOR,
            "significance": SIGNIFICANCE,
            "alpha": 1.0 - (1.0 - SIGNIFICANCE) ** (1.0 / pixels),
            "alpha_formula": "1 - (1 - significance)^(1 / (width * height))",
            "pass": "count(p > alpha) / 3 >= pass_fraction * width * height",
            "pass_fraction": PASS_FRACTION,
        },
    }, indent=1) + "\n")


# --------------------------------------------------------------------------
# Main

def collect_scenes(items):
    out = []
    for it in items:
        p = Path(it)
        if p.is_dir():
            out += sorted(p.glob("*.xml"))
        elif p.exists():
            out.append(p)
        else:
            sys.exit(f"no such scene or folder: {it}")
    return out


def fmt_time(t):
    return "-" if t is None else f"{t:.1f}s" if t < 100 else f"{t:.0f}s"


def main():
    ap = argparse.ArgumentParser(
        description="Judge plsr's Mitsuba XML import with Mitsuba's own z-test.",
        formatter_class=argparse.RawDescriptionHelpFormatter, epilog=__doc__)
    ap.add_argument("scenes", nargs="+", help="scene files or folders of *.xml")
    ap.add_argument("--size", type=int, help="render at longest side N (smaller only)")
    ap.add_argument("--ref-spp", type=int, default=4096)
    ap.add_argument("--spp", type=int, help="test spp (default 2e6 // pixels)")
    ap.add_argument("--seed", type=int, default=0)
    ap.add_argument("--ref-seed", type=int, default=1)
    ap.add_argument("-D", dest="defines", action="append", default=[], metavar="NAME=VALUE",
                    help="scene parameter for both renderers")
    ap.add_argument("--mitsuba-self-check", action="store_true")
    ap.add_argument("--check-moment", action="store_true")
    ap.add_argument("--no-plsr", action="store_true")
    ap.add_argument("--ref-always", action="store_true")
    ap.add_argument("--plsr", default=None)
    ap.add_argument("--plsr-scene", metavar="FILE",
                    help="with one scene: plsr renders FILE instead (e.g. a deliberately "
                         "perturbed copy, to see the test fail); the reference is the scene's")
    ap.add_argument("--plsr-arg", dest="plsr_args", action="append", default=[],
                    metavar="ARG", help="extra argument for `plsr render` (repeatable), "
                    "e.g. --plsr-arg=--light-picking=spatial")
    ap.add_argument("--threads", type=int, default=os.cpu_count() or 1)
    ap.add_argument("--variant", default=None)
    ap.add_argument("--cache", default="/tmp/mitsuba_parity_cache")
    ap.add_argument("--no-cache", action="store_true")
    ap.add_argument("--pass-samples", type=int, default=1 << 22,
                    help="samples per reference pass (memory; default 2^22)")
    ap.add_argument("--write-fixtures", metavar="DIR")
    ap.add_argument("--fixture-max-pixels", type=int, default=64 * 64)
    ap.add_argument("--save-images", metavar="DIR")
    ap.add_argument("--json", metavar="FILE")
    ap.add_argument("--keep-temp", action="store_true")
    ap.add_argument("--verbose", action="store_true", help="Mitsuba's warnings too")
    args = ap.parse_args()

    variant = setup_mitsuba(args.variant, max(1, args.threads))
    if not args.verbose:   # e.g. the samplers' "sample count rounded" warnings
        mi.set_log_level(mi.LogLevel.Error)
    defines = {}
    for d in args.defines:
        k, _, v = d.partition("=")
        defines[k] = v
    plsr = None if args.no_plsr else Plsr(args.plsr or default_plsr())
    if plsr is not None:
        plsr.extra_args = list(args.plsr_args)
    scenes = collect_scenes(args.scenes)
    if args.plsr_scene and (len(scenes) != 1 or args.size):
        sys.exit("--plsr-scene needs exactly one scene and no --size")
    print(f"Mitsuba {mi.__version__} ({variant}), {len(scenes)} scene(s), reference "
          f"{args.ref_spp} spp, threads {args.threads}"
          + ("" if plsr is None else f", plsr {plsr.path}"
             + (" (-D)" if plsr.has_D else "")), flush=True)
    NW = max([34] + [len(p.stem) for p in scenes])
    hdr = (f"{'scene':{NW}} {'size':>9} {'spp':>5} {'result':7} {'pass %':>7} "
           f"{'mean ratio R, G, B':>20} {'relMSE':>8} {'plsr':>7} {'mitsuba':>8} {'ref':>8}")
    print(hdr)
    print("-" * len(hdr), flush=True)

    rows = []
    for scene in scenes:
        name = scene.stem
        tmp = Path(tempfile.mkdtemp(prefix=f"parity_{name}_"))
        row = {"scene": name, "path": str(scene)}
        try:
            info = prepare_scene(scene, args.size, defines, tmp)
            info.cli_params = defines
            w, h = info.pixel_size
            pixels = w * h
            spp = args.spp or max(1, SAMPLE_BUDGET // pixels)
            row.update(width=w, height=h, spp=spp, resized=info.resized)
            size_s = f"{w}x{h}"

            img = None
            if plsr is not None:
                img, row["plsr_time"], err, crash = plsr.render(
                    info, tmp / "plsr.exr", spp, args.seed, args.threads, args.plsr_scene)
                if err is not None:
                    row.update(result="crashed" if crash else "refused", error=err)
                    print(f"{name:{NW}} {size_s:>9} {spp:>5} "
                          f"{'CRASHED' if crash else 'REFUSED'} {err}", flush=True)
                    if not args.ref_always:
                        rows.append(row)
                        continue

            ref = get_reference(info, args, variant)
            row["ref_time"] = ref["time"]
            row["ref_cached"] = ref["cached"]
            if "moment_check" in ref:
                row["moment_check"] = ref["moment_check"]
            if args.write_fixtures and pixels <= args.fixture_max_pixels:
                write_fixture(args.write_fixtures, name, info, ref, args, variant, spp)

            if args.mitsuba_self_check:
                mimg, row["mitsuba_time"] = mitsuba_test_image(info, spp, args.seed)
                mj = judge(mimg, spp, ref, "mitsuba")
                mj.pop("ok_mask")
                row["mitsuba"] = mj

            ref_s = fmt_time(ref["time"]) + ("*" if ref["cached"] else "")
            mi_s = fmt_time(row.get("mitsuba_time"))
            if img is not None and row.get("result") not in ("refused", "crashed"):
                j = judge(img, spp, ref, "plsr")
                ok = j.pop("ok_mask")
                row.update(j)
                row["result"] = "pass" if j["passed"] else "FAIL"
                if args.save_images:
                    sd = Path(args.save_images)
                    sd.mkdir(parents=True, exist_ok=True)
                    write_exr(sd / f"{name}.plsr.exr", img, mi.Bitmap.PixelFormat.RGB)
                    write_exr(sd / f"{name}.ref.exr", ref["rgb"], mi.Bitmap.PixelFormat.RGB)
                    write_exr(sd / f"{name}.rejected.exr",
                              (~ok).astype(np.float32), mi.Bitmap.PixelFormat.XYZ)
                ratio = ", ".join(f"{x:.3f}" for x in j["mean_ratio"])
                print(f"{name:{NW}} {size_s:>9} {spp:>5} {row['result']:7} "
                      f"{100 * j['pass_fraction']:6.2f}% {ratio:>20} {j['rel_mse']:8.2e} "
                      f"{fmt_time(row['plsr_time']):>7} {mi_s:>8} {ref_s:>8}", flush=True)
            elif row.get("result") not in ("refused", "crashed"):
                row["result"] = "mitsuba-only"
                print(f"{name:{NW}} {size_s:>9} {spp:>5} {'-':7} {'':>7} {'':>20} {'':>8} "
                      f"{'-':>7} {mi_s:>8} {ref_s:>8}", flush=True)
            if row.get("result") in ("refused", "crashed"):
                print(f"  reference (plsr refused): {ref_s}", flush=True)
            if args.mitsuba_self_check:
                mj = row["mitsuba"]
                ratio = ", ".join(f"{x:.3f}" for x in mj["mean_ratio"])
                print(f"  mitsuba self-check: {'pass' if mj['passed'] else 'FAIL'} "
                      f"{100 * mj['pass_fraction']:.2f}%  mean ratio {ratio}  "
                      f"relMSE {mj['rel_mse']:.2e}  min p {mj['min_p']:.2e} "
                      f"(alpha {mj['alpha']:.2e})", flush=True)
            if "moment_check" in row:
                mc = row["moment_check"]
                print(f"  moment vs plain render: max |diff| {mc['max_abs_diff_xyz_vs_plain']:.2e}"
                      f" (film RGB {mc['max_abs_diff_root_vs_plain']:.2e}), means "
                      f"{[round(x, 5) for x in mc['mean_moment']]} vs "
                      f"{[round(x, 5) for x in mc['mean_plain']]}", flush=True)
        except Exception as e:  # noqa: BLE001
            msg = " ".join(l.strip() for l in str(e).strip().splitlines()) or type(e).__name__
            msg = msg.replace(str((tmp / "scene").resolve()), str(Path(scene).resolve().parent))
            if row.get("result") in ("refused", "crashed"):
                row["mitsuba_error"] = msg
                print(f"  mitsuba error: {msg[:400]}", flush=True)
            else:
                row.update(result="error", error=msg)
                print(f"{name:{NW}} {'':>9} {'':>5} ERROR   {msg[:400]}", flush=True)
        finally:
            if not args.keep_temp:
                shutil.rmtree(tmp, ignore_errors=True)
            else:
                row["temp"] = str(tmp)
        rows.append(row)

    judged = [r for r in rows if r.get("result") in ("pass", "FAIL")]
    passed = sum(r["result"] == "pass" for r in judged)
    refused = sum(r.get("result") == "refused" for r in rows)
    crashed = sum(r.get("result") == "crashed" for r in rows)
    errors = sum(r.get("result") == "error" for r in rows)
    print("-" * len(hdr))
    print(f"passed {passed} / rendered {len(judged)} / refused {refused}"
          + (f" / crashed {crashed}" if crashed else "")
          + (f" / errors {errors}" if errors else "")
          + "   (* = reference from the cache, its time is the original render's)")
    if args.json:
        Path(args.json).write_text(json.dumps({
            "mitsuba": mi.__version__, "variant": variant, "ref_spp": args.ref_spp,
            "ref_seed": args.ref_seed, "seed": args.seed, "size": args.size,
            "threads": args.threads, "plsr": None if plsr is None else plsr.path,
            "rows": rows,
            "summary": {"passed": passed, "rendered": len(judged), "refused": refused,
                        "crashed": crashed, "errors": errors},
        }, indent=1) + "\n")
    return 0 if passed == len(judged) else 1


if __name__ == "__main__":
    sys.exit(main())
