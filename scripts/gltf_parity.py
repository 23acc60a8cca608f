#!/usr/bin/env python3
"""Cross-checks plsr's glTF import against Blender 4.5's (Khronos' glTF
importer, rendered with Cycles): each model is rendered by both from the same
camera under the same equirectangular environment, and the script prints per
model the silhouette IoU, the mean colour ratio plsr ÷ Blender on the pixels
both cover, the load time and peak memory of each, and writes a side-by-side
PNG (plsr | Blender | difference ×4).

Usage:

    python3 scripts/gltf_parity.py MODEL.glb|FOLDER ... --env ENV.hdr [options]

    --env FILE        equirectangular environment (.hdr or .exr), both renderers
    --blender-python  the Python 3.11 of a venv with `bpy` 4.5 (default
                      $BLENDER_PYTHON, else /work/venvs/bpy/bin/python)
    --plsr PATH       plsr binary (default target/release/plsr next to this
                      script)
    --size W,H        image size (default 320,240)
    --spp N           samples per pixel, both renderers (default 64)
    --max-depth N     plsr's max_depth; Cycles gets N − 1 bounces (default 8)
    --out DIR         where images, scenes and the table go (default
                      /tmp/gltf_parity)
    --json FILE       also write the rows as JSON
    --view X,Y,Z      direction from the model to the camera, glTF axes
                      (default 0.45,0.35,1: in front, a little right, above)
    --write-fixtures DIR  also write Blender's block means and camera per
                      model (--block N pixels, default 16)
    --downsample-env IN OUT.exr  box-filter an environment to --env-size

The environment's top row is glTF's +y and its centre column looks along +x
(how Blender's Environment Texture maps a Z-up world after the importer's
y-up → z-up turn); a first row, `(environment)`, renders the environment alone
in both to check that orientation.

The script runs with a Python that has numpy, OpenEXR and Pillow; it starts
Blender's Python (same file, `--blender-worker`) for the Blender side. Set up
the venv once (bpy 4.5 pins numpy 1.26):

    python3.11 -m venv /work/venvs/bpy && /work/venvs/bpy/bin/pip install 'bpy==4.5.*'

Cycles is set as a fair reference: no clamping, filter glossy 0, a box pixel
filter, the Standard view (EXR output is linear anyway), no denoising, no
adaptive sampling. Blender's importer marks single-sided materials for
back-face culling, which Cycles ignores: the script makes their back faces
transparent (a Mix with a Transparent BSDF by `Backfacing`), as plsr and
glTF viewers cull them; `--keep-back-faces` leaves Cycles' default.

Fixtures for `tests/it/gltf_fixtures.rs`: `--downsample-env IN OUT.exr
--env-size 128,64` makes the small environment, then

    python3 scripts/gltf_parity.py MODELS... --env small.exr --size 160,120 \
        --spp 512 --block 8 --no-env-check --write-fixtures tests/data/realworld/gltf/fixtures
"""

import json
import math
import os
import subprocess
import sys
import tempfile
import time
from pathlib import Path

HERE = Path(__file__).resolve().parent

# -------------------------------------------------------------------------
# The Blender side (runs inside the bpy venv)


def blender_worker(args):
    import bpy
    from mathutils import Matrix, Vector

    job = json.loads(Path(args[0]).read_text())
    bpy.ops.wm.read_factory_settings(use_empty=True)
    scene = bpy.context.scene
    load_s = load_mb = None
    start = time.perf_counter()
    if job.get("model"):
        t0 = time.perf_counter()
        bpy.ops.import_scene.gltf(filepath=job["model"])
        load_s = time.perf_counter() - t0
        import resource
        load_mb = resource.getrusage(resource.RUSAGE_SELF).ru_maxrss / 1024
        if job.get("cull_back_faces", True):
            cull_back_faces(bpy)
        # glTF's animations at t = 0 s, plsr's default: Khronos' importer
        # puts t = 0 at frame 0 (the scene starts at frame 1, t = 1/24 s).
        scene.frame_set(0)

    def to_gltf(v):  # Blender (x, y, z) = glTF (x, −z, y)
        return [v[0], v[2], -v[1]]

    def to_blender(v):
        return Vector((v[0], -v[2], v[1]))

    # Bounds in glTF axes, of every mesh as evaluated.
    deps = bpy.context.evaluated_depsgraph_get()
    lo, hi = [math.inf] * 3, [-math.inf] * 3
    for o in scene.objects:
        if o.type != "MESH":
            continue
        e = o.evaluated_get(deps)
        for c in e.bound_box:
            p = to_gltf(e.matrix_world @ Vector(c))
            lo = [min(a, b) for a, b in zip(lo, p)]
            hi = [max(a, b) for a, b in zip(hi, p)]
    if not math.isfinite(lo[0]):
        lo, hi = [-1.0] * 3, [1.0] * 3

    # The camera: looking at the bounding sphere's centre from `view`.
    vfov = job["vfov"]
    w, h = job["size"]
    centre = [(a + b) / 2 for a, b in zip(lo, hi)]
    radius = max(1e-6, 0.5 * math.dist(lo, hi))
    hfov = 2 * math.atan(math.tan(math.radians(vfov) / 2) * w / h)
    half = min(math.radians(vfov), hfov) / 2
    dist = radius / math.sin(half) * 1.02
    view = Vector(job["view"]).normalized()
    position = [c + dist * v for c, v in zip(centre, view)]
    if job.get("camera"):  # given (the environment check)
        position, centre = job["camera"]["position"], job["camera"]["look_at"]
    cam_data = bpy.data.cameras.new("parity")
    cam_data.sensor_fit = "VERTICAL"
    cam_data.angle_y = math.radians(vfov)
    cam_data.clip_start = max(1e-4, dist * 1e-4) if job.get("model") else 1e-3
    cam_data.clip_end = 1e6
    cam = bpy.data.objects.new("parity", cam_data)
    scene.collection.objects.link(cam)
    p, t = to_blender(position), to_blender(centre)
    forward = (t - p).normalized()
    right = forward.cross(Vector((0, 0, 1))).normalized()
    up = right.cross(forward)
    rot = Matrix((right, up, -forward)).transposed()
    cam.matrix_world = Matrix.Translation(p) @ rot.to_4x4()
    scene.camera = cam

    # The environment.
    world = bpy.data.worlds.new("parity")
    scene.world = world
    world.use_nodes = True
    nt = world.node_tree
    env = nt.nodes.new("ShaderNodeTexEnvironment")
    env.image = bpy.data.images.load(job["env"])
    env.interpolation = "Linear"
    bg = nt.nodes["Background"]
    nt.links.new(env.outputs["Color"], bg.inputs["Color"])
    bg.inputs["Strength"].default_value = 1.0

    # Cycles as a fair reference.
    r = scene.render
    r.engine = "CYCLES"
    c = scene.cycles
    c.device = "CPU"
    c.samples = job["spp"]
    c.seed = 0
    c.use_adaptive_sampling = False
    c.use_denoising = False
    c.sample_clamp_direct = 0.0
    c.sample_clamp_indirect = 0.0
    c.blur_glossy = 0.0
    c.pixel_filter_type = "BOX"
    bounces = max(0, job["max_depth"] - 1)
    c.max_bounces = bounces
    c.diffuse_bounces = bounces
    c.glossy_bounces = bounces
    c.transmission_bounces = bounces
    c.volume_bounces = bounces
    c.transparent_max_bounces = 64
    c.caustics_reflective = True
    c.caustics_refractive = True
    scene.view_settings.view_transform = "Standard"
    scene.view_settings.look = "None"
    scene.view_settings.exposure = 0.0
    scene.view_settings.gamma = 1.0
    r.film_transparent = bool(job.get("model"))
    r.resolution_x, r.resolution_y = w, h
    r.resolution_percentage = 100
    r.image_settings.file_format = "OPEN_EXR"
    r.image_settings.color_depth = "32"
    r.image_settings.color_mode = "RGBA"
    r.filepath = job["out"]
    t0 = time.perf_counter()
    bpy.ops.render.render(write_still=True)
    render_s = time.perf_counter() - t0
    import resource
    Path(job["result"]).write_text(json.dumps({
        # From before the import to the end of the render: with a probe job
        # (one pixel, one sample) what it takes to be ready to render.
        "ready_s": time.perf_counter() - start,
        "ready_mb": resource.getrusage(resource.RUSAGE_SELF).ru_maxrss / 1024,
        "position": position, "look_at": centre, "up": [0, 1, 0],
        "vfov": vfov, "load_s": load_s, "load_mb": load_mb, "render_s": render_s,
        "blender": bpy.app.version_string,
    }))


def cull_back_faces(bpy):
    """Cycles ignores the importer's `use_backface_culling` (glTF's
    `doubleSided: false`): make those materials' back faces transparent, as
    a glTF viewer (and plsr) draws them. Glass (a Principled BSDF with a
    transmission weight) keeps its back faces: light leaves through them, and
    plsr never culls a transmissive material."""
    for mat in bpy.data.materials:
        if not (mat.use_backface_culling and mat.use_nodes):
            continue
        nt = mat.node_tree
        if any(n.type == "BSDF_PRINCIPLED" and not n.inputs["Transmission Weight"].is_linked
               and n.inputs["Transmission Weight"].default_value > 0 for n in nt.nodes):
            continue
        out = next((n for n in nt.nodes if n.type == "OUTPUT_MATERIAL"
                    and n.is_active_output), None)
        if out is None or not out.inputs["Surface"].is_linked:
            continue
        link = out.inputs["Surface"].links[0]
        surface = link.from_socket
        nt.links.remove(link)
        geometry = nt.nodes.new("ShaderNodeNewGeometry")
        transparent = nt.nodes.new("ShaderNodeBsdfTransparent")
        mix = nt.nodes.new("ShaderNodeMixShader")
        nt.links.new(geometry.outputs["Backfacing"], mix.inputs["Fac"])
        nt.links.new(surface, mix.inputs[1])
        nt.links.new(transparent.outputs["BSDF"], mix.inputs[2])
        nt.links.new(mix.outputs["Shader"], out.inputs["Surface"])


def image_worker(args):
    """Writes the image `args[0]` (as Blender reads it: linear RGBA, rows
    bottom-up) to the .npy file `args[1]`, top row first."""
    import bpy
    import numpy as np

    img = bpy.data.images.load(args[0])
    w, h = img.size
    px = np.array(img.pixels[:], dtype=np.float32).reshape(h, w, 4)
    np.save(args[1], px[::-1].copy())


# -------------------------------------------------------------------------
# The driver


def read_rgba(path):
    import numpy as np
    import OpenEXR

    with OpenEXR.File(str(path)) as f:
        ch = f.parts[0].channels
        if "RGBA" in ch:
            return np.asarray(ch["RGBA"].pixels, dtype=np.float64)
        if "RGB" in ch:
            rgb = np.asarray(ch["RGB"].pixels, dtype=np.float64)
            return np.concatenate([rgb, np.ones(rgb.shape[:2] + (1,))], axis=-1)
        raise RuntimeError(f"{path}: no RGB(A) channels (has {sorted(ch)})")


def timed(cmd, **kw):
    """Runs `cmd` under /usr/bin/time: (completed process, seconds, peak MB)."""
    with tempfile.NamedTemporaryFile("r", suffix=".time") as tf:
        full = ["/usr/bin/time", "-f", "%e %M", "-o", tf.name] + cmd
        p = subprocess.run(full, capture_output=True, text=True, **kw)
        try:
            s, kb = tf.read().split()[-2:]
            return p, float(s), float(kb) / 1024
        except ValueError:
            return p, math.nan, math.nan


def plsr_scene(model, env, cam, size, spp, max_depth):
    shape = ""
    if model:
        shape = f'[[shapes]]\ntype = "gltf"\nfile = {json.dumps(str(model))}\n'
    else:  # the environment check: something far behind the camera
        shape = ('[[shapes]]\ntype = "sphere"\ncenter = [0, 0, 1000]\n'
                 'radius = 0.001\n')
    return f"""# Written by scripts/gltf_parity.py
[camera]
position = {json.dumps(cam["position"])}
look_at = {json.dumps(cam["look_at"])}
up = [0, 1, 0]
vfov = {cam["vfov"]}
resolution = [{size[0]}, {size[1]}]

[render]
spp = {spp}
max_depth = {max_depth}
seed = 0

[environment]
file = {json.dumps(str(env))}
up = [0, 1, 0]
forward = [1, 0, 0]
filter = "bilinear"

{shape}"""


def srgb8(x):
    import numpy as np

    x = np.clip(x, 0, 1)
    y = np.where(x <= 0.0031308, 12.92 * x, 1.055 * np.power(x, 1 / 2.4) - 0.055)
    return (y * 255 + 0.5).astype(np.uint8)


def side_by_side(a, b, mask, path):
    """plsr | Blender | |difference| ×4, over grey where either leaves the
    pixel uncovered (plsr's colour includes the environment behind an edge,
    Blender's transparent film does not)."""
    import numpy as np
    from PIL import Image

    both = (a[..., 3:4] > 0.999) & (b[..., 3:4] > 0.999)

    def over(img):
        return np.where(both, img[..., :3], 0.18)

    a, b = over(a), over(b)

    lum = b.mean(-1)
    scale = 0.8 / max(1e-6, np.percentile(lum[mask] if mask.any() else lum, 99))
    row = np.concatenate([a * scale, b * scale, np.abs(a - b) * scale * 4], axis=1)
    Image.fromarray(srgb8(row)).save(path)


def compare(a, b):
    """Silhouette IoU and the mean colour ratio on pixels both cover fully
    (eroded by one pixel, so that edge antialiasing does not count)."""
    import numpy as np

    ma, mb = a[..., 3] > 0.5, b[..., 3] > 0.5
    union = (ma | mb).sum()
    iou = float((ma & mb).sum() / union) if union else math.nan
    full = (a[..., 3] > 0.999) & (b[..., 3] > 0.999)
    inner = full.copy()
    inner[1:, :] &= full[:-1, :]
    inner[:-1, :] &= full[1:, :]
    inner[:, 1:] &= full[:, :-1]
    inner[:, :-1] &= full[:, 1:]
    if inner.sum() < 16:
        return iou, [math.nan] * 3, math.nan, inner
    ma_rgb = a[inner][:, :3].mean(0)
    mb_rgb = b[inner][:, :3].mean(0)
    ratio = [float(x / y) if y > 0 else math.nan for x, y in zip(ma_rgb, mb_rgb)]
    w = np.array([0.2126, 0.7152, 0.0722])
    lum = float((ma_rgb @ w) / (mb_rgb @ w)) if (mb_rgb @ w) > 0 else math.nan
    return iou, ratio, lum, inner


def write_fixture(args, name, model, cam, size, b):
    """`DIR/NAME.json`: the camera, and Blender's mean linear RGB and
    coverage over each `--block`-sized block, row by row from the top."""
    import numpy as np

    k = args.block
    h, w = b.shape[:2]
    blocks = b[: h // k * k, : w // k * k].reshape(h // k, k, w // k, k, 4).mean((1, 3))
    args.write_fixtures.mkdir(parents=True, exist_ok=True)
    fixture = {
        "model": model.name,
        "environment": args.env.name,
        "camera": {"position": cam["position"], "look_at": cam["look_at"],
                   "vfov": cam["vfov"]},
        "resolution": size,
        "max_depth": args.max_depth,
        "blender_spp": args.spp,
        "block": k,
        "blocks": [[round(float(x), 6) for x in v] for v in blocks.reshape(-1, 4)],
        "made_by": "scripts/gltf_parity.py --write-fixtures, Blender "
                   + cam.get("blender", "?") + ", Cycles",
    }
    (args.write_fixtures / f"{name}.json").write_text(json.dumps(fixture, indent=0))


def downsample_env(args):
    """Box-filters an environment map to `--env-size` (via Blender's reader,
    which reads .hdr), written as an RGB OpenEXR."""
    import numpy as np
    import OpenEXR

    src, dst = args.downsample_env
    if dst.resolve() == src.resolve():
        raise SystemExit(f"{dst}: would overwrite the environment it reads")
    with tempfile.TemporaryDirectory() as tmp:
        npy = Path(tmp) / "env.npy"
        subprocess.run([args.blender_python, str(Path(__file__).resolve()),
                        "--image-worker", str(src.resolve()), str(npy)], check=True,
                       capture_output=True)
        px = np.load(npy)[..., :3].astype(np.float64)
    w, h = (int(x) for x in args.env_size.split(","))
    H, W = px.shape[:2]
    if H % h or W % w:
        raise SystemExit(f"{src}: {W}x{H} is not a multiple of {w}x{h}")
    small = px.reshape(h, H // h, w, W // w, 3).mean((1, 3)).astype(np.float32)
    header = {"compression": OpenEXR.ZIP_COMPRESSION, "type": OpenEXR.scanlineimage}
    with OpenEXR.File(header, {"RGB": np.ascontiguousarray(small)}) as f:
        f.write(str(dst))
    print(f"{src} ({W}x{H}) -> {dst} ({w}x{h})")


def run_one(name, model, args, out):
    import numpy as np

    size = [int(x) for x in args.size.split(",")]
    job = {
        "model": str(model) if model else None, "env": str(args.env),
        "size": size, "spp": args.spp, "max_depth": args.max_depth,
        "vfov": 40.0 if model else 80.0,
        "view": [float(x) for x in args.view.split(",")],
        "out": str(out / f"{name}.blender.exr"),
        "result": str(out / f"{name}.blender.json"),
        "cull_back_faces": not args.keep_back_faces,
    }
    if not model:
        job["camera"] = {"position": [0, 0, 0], "look_at": [-1, 0.15, 0.3]}
    (out / f"{name}.job.json").write_text(json.dumps(job))
    p, b_s, b_mb = timed([args.blender_python, str(Path(__file__).resolve()),
                          "--blender-worker", str(out / f"{name}.job.json")])
    if p.returncode != 0:
        raise RuntimeError(f"Blender failed on {name}:\n{p.stdout[-2000:]}\n{p.stderr[-2000:]}")
    cam = json.loads(Path(job["result"]).read_text())
    scene = out / f"{name}.toml"
    scene.write_text(plsr_scene(model, args.env, cam, size, args.spp, args.max_depth))
    p, p_s, p_mb = timed([str(args.plsr), "render", str(scene),
                          "-o", str(out / f"{name}.plsr.exr")])
    if p.returncode != 0:
        raise RuntimeError(f"plsr failed on {name}:\n{p.stderr[-2000:]}")
    notes = [line for line in p.stderr.splitlines() if line.startswith("note:")]
    # Load alone: a render of one pixel, one sample, in each renderer
    # (Blender's importer defers decoding images to the render: its import
    # time alone is not comparable).
    load = {}
    if model:
        probe = dict(job, size=[1, 1], spp=1, out=str(out / f"{name}.probe.exr"),
                     result=str(out / f"{name}.probe.json"))
        (out / f"{name}.probe-job.json").write_text(json.dumps(probe))
        p, _, _ = timed([args.blender_python, str(Path(__file__).resolve()),
                         "--blender-worker", str(out / f"{name}.probe-job.json")])
        if p.returncode == 0:
            ready = json.loads(Path(probe["result"]).read_text())
            load["blender_ready_s"] = ready["ready_s"]
            load["blender_ready_mb"] = ready["ready_mb"]
        _, load["plsr_s"], load["plsr_mb"] = timed(
            [str(args.plsr), "render", str(scene), "-q", "--spp", "1",
             "--resolution", "1,1", "-o", str(out / f"{name}.load.exr")])
        load["blender_import_s"] = cam["load_s"]
        load["blender_import_mb"] = cam["load_mb"]
    a = read_rgba(out / f"{name}.plsr.exr")
    b = read_rgba(out / f"{name}.blender.exr")
    if not model:  # the environment seen directly: no alpha to compare
        a[..., 3] = 1.0
        b[..., 3] = 1.0
    iou, ratio, lum, inner = compare(a, b)
    side_by_side(a, b, inner, out / f"{name}.png")
    if model and args.write_fixtures:
        write_fixture(args, name, model, cam, size, b)
    return {
        "model": name, "iou": iou, "ratio_rgb": ratio, "ratio_lum": lum,
        "pixels": int(inner.sum()), "plsr_render_s": p_s, "plsr_peak_mb": p_mb,
        "blender_s": b_s, "blender_peak_mb": b_mb,
        "blender_render_s": cam["render_s"], **load, "notes": notes,
    }


def main():
    import argparse

    if len(sys.argv) > 1 and sys.argv[1] == "--blender-worker":
        blender_worker(sys.argv[2:])
        return
    if len(sys.argv) > 1 and sys.argv[1] == "--image-worker":
        image_worker(sys.argv[2:])
        return
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("models", nargs="*", type=Path)
    ap.add_argument("--env", type=Path)
    ap.add_argument("--blender-python", default=os.environ.get(
        "BLENDER_PYTHON", "/work/venvs/bpy/bin/python"))
    ap.add_argument("--plsr", type=Path, default=HERE.parent / "target/release/plsr")
    ap.add_argument("--size", default="320,240")
    ap.add_argument("--spp", type=int, default=64)
    ap.add_argument("--max-depth", type=int, default=8)
    ap.add_argument("--out", type=Path, default=Path("/tmp/gltf_parity"))
    ap.add_argument("--json", type=Path)
    ap.add_argument("--view", default="0.45,0.35,1")
    ap.add_argument("--no-env-check", action="store_true")
    ap.add_argument("--keep-back-faces", action="store_true",
                    help="leave Cycles drawing single-sided materials' back faces")
    ap.add_argument("--write-fixtures", type=Path, metavar="DIR",
                    help="write each model's Blender block means and camera "
                         "(for tests/it/gltf_fixtures.rs)")
    ap.add_argument("--block", type=int, default=16,
                    help="fixture block size in pixels (default 16)")
    ap.add_argument("--downsample-env", nargs=2, type=Path, metavar=("IN", "OUT.exr"),
                    help="write IN (.hdr or .exr) box-filtered to --env-size "
                         "as OUT.exr, and stop")
    ap.add_argument("--env-size", default="128,64")
    args = ap.parse_args()
    if args.downsample_env:
        downsample_env(args)
        return
    if not args.models or args.env is None:
        ap.error("give models and --env")
    args.env = args.env.resolve()
    args.out.mkdir(parents=True, exist_ok=True)
    models = []
    for m in args.models:
        if m.is_dir():
            models += sorted(p for p in m.iterdir() if p.suffix.lower() in (".glb", ".gltf"))
        else:
            models.append(m)
    jobs = [] if args.no_env_check else [("(environment)", None)]
    jobs += [(m.stem, m.resolve()) for m in models]
    rows = []
    print(f"{'model':<26} {'IoU':>6} {'plsr/Blender R, G, B':>22} {'lum':>6} "
          f"{'load plsr':>10} {'Blender':>8} {'ready':>8} {'peak plsr':>10} {'Blender':>8} {'ready':>8}")
    for name, model in jobs:
        try:
            row = run_one(name.strip("()"), model, args, args.out)
        except RuntimeError as e:
            print(f"{name:<26} failed: {e}")
            rows.append({"model": name, "error": str(e)})
            continue
        row["model"] = name
        rows.append(row)
        rgb = ", ".join(f"{x:.3f}" for x in row["ratio_rgb"])
        lp = f"{row['plsr_s']:.2f} s" if "plsr_s" in row else "—"
        lb = f"{row['blender_import_s']:.2f} s" if row.get("blender_import_s") else "—"
        mp = f"{row['plsr_mb']:.0f} MB" if "plsr_mb" in row else "—"
        mb = f"{row['blender_import_mb']:.0f} MB" if row.get("blender_import_mb") else "—"
        rs = f"{row['blender_ready_s']:.2f} s" if row.get("blender_ready_s") else "—"
        rm = f"{row['blender_ready_mb']:.0f} MB" if row.get("blender_ready_mb") else "—"
        print(f"{name:<26} {row['iou']:6.3f} {rgb:>22} {row['ratio_lum']:6.3f} "
              f"{lp:>10} {lb:>8} {rs:>8} {mp:>10} {mb:>8} {rm:>8}", flush=True)
    if args.json:
        args.json.write_text(json.dumps(rows, indent=1))
    print(f"side-by-side images (plsr | Blender | difference x4): {args.out}/*.png")


if __name__ == "__main__":
    main()
