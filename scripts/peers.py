#!/usr/bin/env python3
"""camsim against its peers, Blender's Cycles and Mitsuba 3, on the same scenes (BENCHMARKS.md).

For each scene (glTF files: Blender's Cycles reads them through its own glTF importer, Mitsuba 3
through meshes that Blender's importer writes out for it) every renderer renders the same camera,
resolution, box pixel filter of one pixel and 8 bounces, on the same number of threads, and the
script prints two Markdown tables:

1. **Unbiased, equal error.** Two seeds of N samples per pixel each. The per-pixel variance of one
   render is (Y1 - Y2)^2 / 2 (Y the luminance), so its relative error is
   e^2 = mean(((Y1 - Y2)^2 / 2) / (Ybar^2 + eps^2)), eps = 1 % of the mean (Rousselle et al. 2011,
   the metric of BENCHMARKS.md's convergence table), measured against no reference. An unbiased
   renderer's error falls as 1/sqrt(samples), so its CPU time to a relative error E is
   t (e / E)^2: the equal-error CPU-time ratio of two renderers is the ratio of their t e^2.
   Cycles runs without adaptive sampling and denoising, Mitsuba 3 (`llvm_ad_spectral`, `path`)
   with its `independent` and its `ldsampler` sampler.
2. **With each one's noise reduction.** Cycles with its defaults (adaptive sampling to 0.01, Open
   Image Denoise on albedo and normal passes) and camsim with `--adaptive-error 0.01 --denoise`,
   at several sample caps; error = relative RMSE of luminance against each renderer's own
   converged render (its noise subtracted in quadrature), against CPU seconds. Mitsuba 3 has no
   CPU denoiser.

CPU time (user + system of every thread) is the figure, as in BENCHMARKS.md: camsim's is the
whole `camsim render` process (reading the file, building the BVH, writing the EXRs), Cycles' the
`bpy.ops.render.render` call (scene sync, BVH, render, denoise), Mitsuba's the `mi.render` call
and its evaluation after one warm-up render (LLVM kernels compiled; the compile time is printed
apart).

Needs, outside the repository and the default test command (Blender 5.0 needs Python 3.11):

    python3.11 -m venv ../peers-venv
    ../peers-venv/bin/pip install bpy mitsuba OpenEXR numpy oidn
    cargo build --release -p camsim-cli
    ../peers-venv/bin/python scripts/peers.py

Mitsuba's `llvm_ad_*` variants need a recent LLVM: with Debian 12's libLLVM 14 or 15 every render
stops at "LLVM ERROR: Cannot select: fmaximum"; `apt install libllvm19` (Dr.Jit then finds
`libLLVM.so.19.1`, or set `DRJIT_LIBLLVM_PATH`).

`--denoise` needs Open Image Denoise for camsim: the `oidn` wheel's library, with a `libtbb.so.12`
beside it (bpy ships one: link `bpy/lib/libtbb.so.12` into `oidn/lib.linux.x64/`); the script
finds it in the venv or takes `CAMSIM_OIDN_LIBRARY`.
"""

import argparse
import glob
import json
import os
import resource
import subprocess
import sys
import tempfile
import time

import numpy as np

ROOT = os.path.dirname(os.path.dirname(os.path.abspath(__file__)))
SHARED = os.path.join(os.path.dirname(ROOT), "shared")
SCENES = {
    "room": os.path.join(SHARED, "scenes", "gltf", "room.glb"),
    "textured": os.path.join(SHARED, "scenes", "gltf", "textured.glb"),
}
# Rec. 709 luminance weights (ITU-R BT.709): Cycles' and Mitsuba's linear RGB to Y.
REC709_Y = np.array([0.2126, 0.7152, 0.0722])


def rel_error2(y, ref, ref_noise2=0.0):
    """Squared relative RMSE of luminance (Rousselle et al. 2011; eps = 1 % of the mean)."""
    eps = 0.01 * float(np.mean(ref))
    e2 = float(np.mean((y - ref) ** 2 / (ref**2 + eps**2)))
    return max(e2 - ref_noise2, 0.0)


def two_seed_error2(y1, y2):
    """Squared relative error of one render from two independent seeds (no reference)."""
    ybar = 0.5 * (y1 + y2)
    eps = 0.01 * float(np.mean(ybar))
    return float(np.mean(0.5 * (y1 - y2) ** 2 / (ybar**2 + eps**2)))


def read_exr_luminance(path):
    """Luminance of an EXR: Y of camsim's spectral radiance (CIE 1931 ybar, per band), or of an
    RGB image's linear Rec. 709 channels."""
    import OpenEXR

    with OpenEXR.File(path) as f:
        ch = f.channels()
        names = list(ch.keys())
        spectral = sorted(n for n in names if n.startswith("S0."))
        if spectral:
            import mitsuba as mi

            mi.set_variant("scalar_rgb")
            # Channel names as the spectral OpenEXR layout writes them: S0.550,000000nm.
            lam = [float(n[3:-2].replace(",", ".")) for n in spectral]
            step = lam[1] - lam[0] if len(lam) > 1 else 10.0
            y = sum(ch[n].pixels.astype(np.float64) * float(mi.cie1931_y(w)) for n, w in zip(spectral, lam))
            return 683.0 * step * y
        if "RGB" in ch:
            rgb = ch["RGB"].pixels.astype(np.float64)
        elif "RGBA" in ch:
            rgb = ch["RGBA"].pixels[..., :3].astype(np.float64)
        else:
            rgb = np.stack([ch[c].pixels for c in ("R", "G", "B")], -1).astype(np.float64)
        return rgb @ REC709_Y


# ---------------------------------------------------------------------------------------------
# Workers: each renderer in its own process (bpy and Mitsuba bundle their own libraries).


def worker_cycles(a):
    """Render a glTF with Cycles as the shared references were made; print cpu_s as JSON."""
    import bpy

    bpy.ops.wm.read_factory_settings(use_empty=True)
    bpy.ops.import_scene.gltf(filepath=a["scene"])
    sc = bpy.context.scene
    cams = [o for o in sc.objects if o.type == "CAMERA"]
    sc.camera = cams[0]
    world = bpy.data.worlds.new("black")
    world.color = (0.0, 0.0, 0.0)
    # Blender 5's new worlds are node trees with a grey background: switch it off.
    for n in world.node_tree.nodes if world.node_tree else []:
        if n.type == "BACKGROUND":
            n.inputs["Strength"].default_value = 0.0
    sc.world = world
    sc.render.engine = "CYCLES"
    c = sc.cycles
    c.device = "CPU"
    sc.render.resolution_x, sc.render.resolution_y = a["resolution"]
    sc.render.resolution_percentage = 100
    sc.render.threads_mode = "FIXED"
    sc.render.threads = a["threads"]
    c.seed = a["seed"]
    c.samples = a["spp"]
    c.use_adaptive_sampling = a["noise_reduction"]
    c.adaptive_threshold = 0.01
    c.use_denoising = a["noise_reduction"]
    c.denoiser = "OPENIMAGEDENOISE"
    c.max_bounces = 8
    for k in ("diffuse", "glossy", "transmission", "volume", "transparent_max"):
        setattr(c, f"{k}_bounces", 8)
    c.sample_clamp_direct = 0.0
    c.sample_clamp_indirect = 0.0
    c.pixel_filter_type = "BOX"
    c.filter_width = 1.0
    sc.view_settings.view_transform = "Standard"
    sc.render.image_settings.file_format = "OPEN_EXR"
    sc.render.image_settings.color_depth = "32"
    sc.render.filepath = a["out"]
    t0 = time.process_time()
    w0 = time.perf_counter()
    bpy.ops.render.render(write_still=True)
    print(json.dumps({"cpu_s": time.process_time() - t0, "wall_s": time.perf_counter() - w0}))


def worker_export(a):
    """Write a glTF's meshes (world space, one PLY per material), materials, lights and camera as
    Blender's importer reads them, for the Mitsuba worker."""
    import bpy

    bpy.ops.wm.read_factory_settings(use_empty=True)
    bpy.ops.import_scene.gltf(filepath=a["scene"])
    sc = bpy.context.scene
    deps = bpy.context.evaluated_depsgraph_get()
    out = a["dir"]
    shapes, lights = [], []
    for o in sc.objects:
        if o.type == "MESH":
            ev = o.evaluated_get(deps)
            me = ev.to_mesh()
            me.calc_loop_triangles()
            mw = o.matrix_world
            uv = me.uv_layers.active.data if me.uv_layers.active else None
            by_mat = {}
            for t in me.loop_triangles:
                by_mat.setdefault(t.material_index, []).append(t)
            for mi_, tris in by_mat.items():
                mat = me.materials[mi_] if mi_ < len(me.materials) else None
                spec = material_spec(mat, out)
                # Per corner: world position and uv (Blender's uv origin is the image's bottom
                # left, Mitsuba's bitmap's its top left).
                corners = np.array([[*(mw @ me.vertices[vi].co), *(uv[li].uv if uv else (0.0, 0.0))]
                                    for t in tris for li, vi in zip(t.loops, t.vertices)])
                corners[:, 4] = 1.0 - corners[:, 4]
                stem = os.path.join(out, f"{o.name}_{mi_}".replace(" ", "_"))
                if spec["emission"] is None:
                    write_ply(stem + ".ply", corners)
                    shapes.append({"ply": stem + ".ply", **spec})
                    continue
                # glTF doubleSided emitters (Cycles' mesh emission leaves both faces), for
                # Mitsuba's one-sided area emitters: two copies 0.1 mm apart, each facing away
                # from the other.
                tri = corners[:, :3].reshape(-1, 3, 3)
                nrm = np.cross(tri[:, 1] - tri[:, 0], tri[:, 2] - tri[:, 0])
                nrm /= np.linalg.norm(nrm, axis=1, keepdims=True)
                for side, sign in (("front", 1.0), ("back", -1.0)):
                    c = corners.reshape(-1, 3, 5).copy()
                    c[:, :, :3] += sign * 1e-4 * nrm[:, None, :]
                    if sign < 0:
                        c = c[:, ::-1]
                    write_ply(f"{stem}_{side}.ply", c.reshape(-1, 5))
                    shapes.append({"ply": f"{stem}_{side}.ply", **spec})
            ev.to_mesh_clear()
        elif o.type == "LIGHT" and o.data.type == "POINT":
            p = o.matrix_world.translation
            # Blender's point light of P watts: radiant intensity P / (4 pi) per unit colour.
            i = [o.data.energy / (4.0 * np.pi) * c for c in o.data.color]
            lights.append({"position": [p.x, p.y, p.z], "intensity": i})
    cam = sc.camera or [o for o in sc.objects if o.type == "CAMERA"][0]
    sc.render.resolution_x, sc.render.resolution_y = a["resolution"]
    frame = cam.data.view_frame(scene=sc)
    half_h = max(abs(v.y) for v in frame) / abs(frame[0].z)
    mw = cam.matrix_world
    origin = mw.translation
    # Blender's camera looks down its local -z with +y up.
    fwd = mw.to_3x3().col[2] * -1.0
    up = mw.to_3x3().col[1]
    desc = {
        "shapes": shapes,
        "lights": lights,
        "camera": {
            "origin": list(origin),
            "target": list(origin + fwd),
            "up": list(up),
            "vfov_deg": float(np.degrees(2.0 * np.arctan(half_h))),
        },
    }
    with open(os.path.join(out, "scene.json"), "w") as f:
        json.dump(desc, f, indent=1)
    print(json.dumps({"cpu_s": 0.0}))


def write_ply(path, corners):
    """An ASCII PLY of unshared triangles: rows of x, y, z, u, v, three per triangle."""
    n = len(corners) // 3
    with open(path, "w") as f:
        f.write(f"ply\nformat ascii 1.0\nelement vertex {3 * n}\n")
        f.write("property float x\nproperty float y\nproperty float z\nproperty float u\nproperty float v\n")
        f.write(f"element face {n}\nproperty list uchar int vertex_indices\nend_header\n")
        for row in corners:
            f.write(" ".join(f"{x:.9g}" for x in row) + "\n")
        for i in range(n):
            f.write(f"3 {3 * i} {3 * i + 1} {3 * i + 2}\n")


def material_spec(mat, out):
    """Base colour (or its image, saved as PNG) and emitted radiance of a Principled BSDF."""
    spec = {"rgb": [0.8, 0.8, 0.8], "texture": None, "emission": None}
    if mat is None or not mat.node_tree:
        return spec
    bsdf = next((n for n in mat.node_tree.nodes if n.type == "BSDF_PRINCIPLED"), None)
    if bsdf is None:
        return spec
    base = bsdf.inputs["Base Color"]
    spec["rgb"] = list(base.default_value[:3])
    if base.is_linked:
        node = base.links[0].from_node
        while node.type != "TEX_IMAGE" and node.inputs and any(i.is_linked for i in node.inputs):
            node = next(i for i in node.inputs if i.is_linked).links[0].from_node
        if node.type == "TEX_IMAGE" and node.image is not None:
            path = os.path.join(out, f"{mat.name}.png".replace(" ", "_"))
            img = node.image
            img.filepath_raw = path
            img.file_format = "PNG"
            img.save()
            spec["texture"] = path
    strength = bsdf.inputs["Emission Strength"].default_value
    colour = bsdf.inputs["Emission Color"].default_value[:3]
    if strength > 0 and max(colour) > 0:
        spec["emission"] = [strength * c for c in colour]
    return spec


def worker_mitsuba(a):
    """Render the exported scene with Mitsuba 3 (llvm_ad_spectral, path); print cpu_s."""
    import drjit as dr
    import mitsuba as mi

    mi.set_variant("llvm_ad_spectral")
    dr.set_thread_count(a["threads"])
    with open(os.path.join(a["dir"], "scene.json")) as f:
        desc = json.load(f)
    cam = desc["camera"]
    w, h = a["resolution"]
    scene = {
        "type": "scene",
        # Mitsuba's max_depth counts the camera vertex: 8 bounces = 9.
        "integrator": {"type": "path", "max_depth": 9},
        "sensor": {
            "type": "perspective",
            "fov": cam["vfov_deg"],
            "fov_axis": "y",
            "to_world": mi.ScalarTransform4f().look_at(cam["origin"], cam["target"], cam["up"]),
            "film": {"type": "hdrfilm", "width": w, "height": h, "rfilter": {"type": "box"},
                     "pixel_format": "rgb"},
            "sampler": {"type": a["sampler"], "sample_count": a["spp"]},
        },
    }
    for i, s in enumerate(desc["shapes"]):
        refl = ({"type": "bitmap", "filename": s["texture"], "filter_type": "bilinear"}
                if s["texture"] else {"type": "rgb", "value": s["rgb"]})
        shape = {"type": "ply", "filename": s["ply"], "face_normals": True,
                 "bsdf": {"type": "twosided", "bsdf": {"type": "diffuse", "reflectance": refl}}}
        if s["emission"]:
            shape["emitter"] = {"type": "area", "radiance": {"type": "rgb", "value": s["emission"]}}
        scene[f"shape{i}"] = shape
    for i, lt in enumerate(desc["lights"]):
        scene[f"light{i}"] = {"type": "point", "position": lt["position"],
                              "intensity": {"type": "rgb", "value": lt["intensity"]}}
    sc = mi.load_dict(scene)
    t0 = time.process_time()
    np.array(mi.render(sc, seed=1000 + a["seed"], spp=min(a["spp"], 4)))
    compile_s = time.process_time() - t0
    t0 = time.process_time()
    w0 = time.perf_counter()
    img = np.array(mi.render(sc, seed=a["seed"], spp=a["spp"]))
    cpu = time.process_time() - t0
    wall = time.perf_counter() - w0
    np.save(a["out"], img[..., :3].astype(np.float64) @ REC709_Y)
    print(json.dumps({"cpu_s": cpu, "wall_s": wall, "warmup_cpu_s": compile_s}))


# ---------------------------------------------------------------------------------------------
# The driver.


def run_worker(kind, args):
    out = subprocess.run([sys.executable, os.path.abspath(__file__), "--worker", kind, json.dumps(args)],
                         capture_output=True, text=True)
    if out.returncode != 0:
        sys.exit(f"{kind} worker failed:\n{out.stdout[-3000:]}\n{out.stderr[-3000:]}")
    # The last JSON object printed (Mitsuba's coloured log lines may precede it on its line).
    line = [ln[ln.index("{"):] for ln in out.stdout.splitlines() if "{\"cpu_s\"" in ln]
    if not line:
        sys.exit(f"{kind} worker printed no timing:\n{out.stdout[-3000:]}")
    return json.loads(line[-1])


def oidn_library():
    lib = os.environ.get("CAMSIM_OIDN_LIBRARY")
    if lib:
        return lib
    hits = glob.glob(os.path.join(sys.prefix, "lib", "python*", "site-packages", "oidn", "lib.linux.x64",
                                  "libOpenImageDenoise.so.*"))
    return hits[0] if hits else None


class Bench:
    def __init__(self, opts, tmp):
        self.o = opts
        self.tmp = tmp
        self.res = [int(v) for v in opts.resolution.split("x")]

    def camsim(self, scene, spp, seed, noise_reduction=False):
        out = os.path.join(self.tmp, f"camsim-{os.path.basename(scene)}-{spp}-{seed}-{int(noise_reduction)}")
        cmd = [self.o.camsim, "render", scene, "--resolution", self.o.resolution, "--spp", str(spp),
               "--seed", str(seed), "--max-depth", "8", "--threads", str(self.o.threads), "--quiet", "--out", out]
        env = dict(os.environ)
        if noise_reduction:
            cmd += ["--adaptive-error", "0.01", "--min-spp", str(min(spp, 16)), "--denoise"]
            lib = oidn_library()
            if lib is None:
                sys.exit("--denoise needs Open Image Denoise: pip install oidn, or set CAMSIM_OIDN_LIBRARY")
            env["CAMSIM_OIDN_LIBRARY"] = lib
        before = resource.getrusage(resource.RUSAGE_CHILDREN)
        w0 = time.perf_counter()
        p = subprocess.run(cmd, capture_output=True, text=True, env=env)
        wall = time.perf_counter() - w0
        after = resource.getrusage(resource.RUSAGE_CHILDREN)
        if p.returncode != 0:
            sys.exit(f"camsim failed: {' '.join(cmd)}\n{p.stderr[-3000:]}")
        cpu = (after.ru_utime - before.ru_utime) + (after.ru_stime - before.ru_stime)
        with open(os.path.join(out, "render.json")) as f:
            mean_spp = json.load(f).get("samples_per_pixel_mean", spp)
        return read_exr_luminance(os.path.join(out, "radiance.exr")), {"cpu_s": cpu, "wall_s": wall,
                                                                         "spp_mean": mean_spp}

    def cycles(self, scene, spp, seed, noise_reduction=False):
        out = os.path.join(self.tmp, f"cycles-{os.path.basename(scene)}-{spp}-{seed}-{int(noise_reduction)}.exr")
        t = run_worker("cycles", {"scene": scene, "spp": spp, "seed": seed, "threads": self.o.threads,
                                  "resolution": self.res, "noise_reduction": noise_reduction, "out": out})
        return read_exr_luminance(out), t

    def mitsuba(self, scene, spp, seed, sampler):
        d = os.path.join(self.tmp, "mitsuba-" + os.path.basename(scene))
        if not os.path.exists(os.path.join(d, "scene.json")):
            os.makedirs(d, exist_ok=True)
            run_worker("export", {"scene": scene, "dir": d, "resolution": self.res})
        out = os.path.join(self.tmp, f"mitsuba-{os.path.basename(scene)}-{sampler}-{spp}-{seed}.npy")
        t = run_worker("mitsuba", {"dir": d, "spp": spp, "seed": seed, "threads": self.o.threads,
                                   "resolution": self.res, "sampler": sampler, "out": out})
        return np.load(out), t


def unbiased_table(b, name, scene, spp, target):
    rows = []
    runs = [("camsim", lambda s: b.camsim(scene, spp, s)),
            ("Cycles 5.0", lambda s: b.cycles(scene, spp, s))]
    if not b.o.no_mitsuba:
        runs += [("Mitsuba 3 independent", lambda s: b.mitsuba(scene, spp, s, "independent")),
                 ("Mitsuba 3 ldsampler", lambda s: b.mitsuba(scene, spp, s, "ldsampler"))]
    for label, fn in runs:
        y1, t1 = fn(1)
        y2, t2 = fn(2)
        cpu = 0.5 * (t1["cpu_s"] + t2["cpu_s"])
        e2 = two_seed_error2(y1, y2)
        rows.append({"renderer": label, "cpu_s": cpu, "error": e2**0.5, "t_to_target": cpu * e2 / target**2,
                     "mean": float(np.mean(0.5 * (y1 + y2))), "warmup": t1.get("warmup_cpu_s")})
        print(f"  {name} {label}: {cpu:.2f} CPU s, error {100 * e2**0.5:.2f} %", file=sys.stderr)
    base = rows[0]["t_to_target"]
    print(f"\n{name}, {b.o.resolution}, {spp} spp, {b.o.threads} threads, unbiased:\n")
    print(f"| renderer | CPU s for {spp} spp | relative error at {spp} spp | CPU s to {100 * target:g} % "
          "| camsim / it |")
    print("|---|---:|---:|---:|---:|")
    for r in rows:
        note = f" (+{r['warmup']:.1f} s warm-up)" if r["warmup"] and r["warmup"] >= 0.05 else ""
        print(f"| {r['renderer']} | {r['cpu_s']:.2f}{note} | {100 * r['error']:.2f} % | {r['t_to_target']:.1f} | "
              f"{base / r['t_to_target']:.2f} |")


def reduced_table(b, name, scene, caps, ref_spp):
    """Time to error with each renderer's noise reduction, against its own converged render."""
    print(f"\n{name}, {b.o.resolution}, {b.o.threads} threads, with noise reduction (references: two "
          f"seeds of each renderer, camsim's {ref_spp} spp each, Cycles' ../shared's 512 spp each at "
          "256x192, else its own):\n")
    print("| renderer | sample cap | mean spp | CPU s | relative error |")
    print("|---|---:|---:|---:|---:|")
    for label, fn in (("camsim --adaptive-error 0.01 --denoise", b.camsim), ("Cycles 5.0 defaults", b.cycles)):
        stored = [scene.replace(".glb", f"-cycles-seed{i}.exr") for i in (1, 2)]
        if fn == b.cycles and b.res == [256, 192] and all(os.path.exists(f) for f in stored):
            # ../shared's Cycles renders of these files (2 x 512 spp, the same settings; the
            # script's import of the .glb renders them within 0.1 %).
            r1, r2 = (read_exr_luminance(f) for f in stored)
        else:
            r1, _ = fn(scene, ref_spp, 11)
            r2, _ = fn(scene, ref_spp, 12)
        ref = 0.5 * (r1 + r2)
        ref_noise2 = two_seed_error2(r1, r2) / 2.0
        for cap in caps:
            y, t = fn(scene, cap, 1, noise_reduction=True)
            e = rel_error2(y, ref, ref_noise2) ** 0.5
            spp_mean = t.get("spp_mean")
            spp_text = f"{spp_mean:.1f}" if spp_mean is not None else "-"
            print(f"| {label} | {cap} | {spp_text} | {t['cpu_s']:.2f} | {100 * e:.2f} % |")
            sys.stdout.flush()


def main():
    if len(sys.argv) > 2 and sys.argv[1] == "--worker":
        {"cycles": worker_cycles, "export": worker_export, "mitsuba": worker_mitsuba}[sys.argv[2]](
            json.loads(sys.argv[3]))
        return
    p = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    p.add_argument("--camsim", default=os.path.join(ROOT, "target", "release", "camsim"))
    p.add_argument("--scenes", default="room,textured", help="comma list of: " + ", ".join(SCENES))
    p.add_argument("--resolution", default="256x192")
    p.add_argument("--threads", type=int, default=2)
    p.add_argument("--spp", type=int, default=64, help="samples per pixel of the unbiased runs")
    p.add_argument("--target", type=float, default=0.05, help="relative error of the equal-error column")
    p.add_argument("--caps", default="16,64,256", help="sample caps of the noise-reduced runs")
    p.add_argument("--ref-spp", type=int, default=1024, help="samples of each converged reference seed")
    p.add_argument("--no-mitsuba", action="store_true")
    p.add_argument("--no-reduced", action="store_true", help="skip the noise-reduced table")
    o = p.parse_args()
    if not os.path.exists(o.camsim):
        sys.exit(f"{o.camsim} not found: cargo build --release -p camsim-cli")
    with tempfile.TemporaryDirectory(prefix="camsim-peers-") as tmp:
        b = Bench(o, tmp)
        for name in o.scenes.split(","):
            unbiased_table(b, name, SCENES[name], o.spp, o.target)
            if not o.no_reduced:
                reduced_table(b, name, SCENES[name], [int(c) for c in o.caps.split(",")], o.ref_spp)


if __name__ == "__main__":
    main()
