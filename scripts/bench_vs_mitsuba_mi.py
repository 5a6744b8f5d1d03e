"""Mitsuba 3 side of scripts/bench-vs-mitsuba and scripts/make-caustic-reference: renders
scenes/cornell-caustics.toml's scene (the numbers of scenes/reference/cornell-caustics/README.md), its two
spheres analytic, or with --ply loaded from the PLY files that caustica's own sphere generator wrote, so that
both renderers trace identical triangles.

  python bench_vs_mitsuba_mi.py OUT.exr [--ply MIRROR.ply GLASS.ply] --spp N --threads T [--seconds S]
                                 [--pass-spp P] [--sampler TYPE] [--crop X Y W H]

--sampler: Mitsuba's sampler plugin (default `independent`, its default; `ldsampler`, `multijitter`, ... for a
stratified one like caustica's own).
--crop: render only the W×H pixels from (X, Y) of the 256×256 film (hdrfilm's crop window: the same pixels,
sample positions and values as in the full image); OUT is W×H.

Renders passes of P spp (distinct seeds) after one untimed pass that compiles the kernel: until N spp with
--spp N, or with --seconds S as many as fit in S seconds (a pass that would end after S at the rate measured
so far is not started); the image is the passes' mean.
Prints one JSON line: samples, seconds (rendering only, as caustica's seconds_render), samples_per_second, and
samples_untimed (the compiling pass's samples, which a profile of the whole process also counts).
"""
import argparse
import json
import time

import drjit as dr
import mitsuba as mi

mi.set_variant("llvm_ad_rgb")
T = mi.ScalarTransform4f


def scene_dict(ply, width, height, sampler, crop):
    def diffuse(rgb):
        return {"type": "twosided", "bsdf": {"type": "diffuse", "reflectance": {"type": "rgb", "value": rgb}}}

    film = {"type": "hdrfilm", "width": width, "height": height, "rfilter": {"type": "box"}, "pixel_format": "rgb"}
    if crop is not None:
        film.update(crop_offset_x=crop[0], crop_offset_y=crop[1], crop_width=crop[2], crop_height=crop[3])
    if ply is None:
        mirror = {"type": "sphere", "center": [-0.45, -0.65, -0.3], "radius": 0.35}
        glass = {"type": "sphere", "center": [0.4, -0.35, 0.25], "radius": 0.3}
    else:
        mirror, glass = {"type": "ply", "filename": ply[0]}, {"type": "ply", "filename": ply[1]}
    white, red, green = diffuse([0.8, 0.8, 0.8]), diffuse([0.8, 0.1, 0.1]), diffuse([0.1, 0.8, 0.1])
    return {
        "type": "scene",
        "integrator": {"type": "path", "max_depth": -1, "rr_depth": 5},
        "sensor": {
            "type": "perspective",
            "fov": 39.3077,
            "fov_axis": "smaller",
            "to_world": T().look_at(origin=[0, 0, 3.9], target=[0, 0, 0], up=[0, 1, 0]),
            "sampler": {"type": sampler},
            "film": film,
        },
        "floor": {"type": "rectangle", "to_world": T().translate([0, -1, 0]) @ T().rotate([1, 0, 0], -90), "bsdf": white},
        "ceiling": {"type": "rectangle", "to_world": T().translate([0, 1, 0]) @ T().rotate([1, 0, 0], 90), "bsdf": white},
        "back": {"type": "rectangle", "to_world": T().translate([0, 0, -1]), "bsdf": white},
        "left": {"type": "rectangle", "to_world": T().translate([-1, 0, 0]) @ T().rotate([0, 1, 0], 90), "bsdf": red},
        "right": {"type": "rectangle", "to_world": T().translate([1, 0, 0]) @ T().rotate([0, 1, 0], -90), "bsdf": green},
        "light": {
            "type": "rectangle",
            "to_world": T().translate([0, 0.99, 0]) @ T().rotate([1, 0, 0], 90) @ T().scale([0.25, 0.25, 1]),
            "bsdf": {"type": "diffuse", "reflectance": {"type": "rgb", "value": [0, 0, 0]}},
            "emitter": {"type": "area", "radiance": {"type": "rgb", "value": [15, 15, 15]}},
        },
        "mirror": {**mirror, "bsdf": {"type": "conductor", "material": "none"}},
        "glass": {**glass, "bsdf": {"type": "dielectric", "int_ior": 1.5, "ext_ior": 1.0}},
    }


def main():
    ap = argparse.ArgumentParser()
    ap.add_argument("out")
    ap.add_argument("--ply", nargs=2, metavar=("MIRROR", "GLASS"))
    ap.add_argument("--crop", nargs=4, type=int, metavar=("X", "Y", "W", "H"))
    ap.add_argument("--spp", type=int, default=256)
    ap.add_argument("--seconds", type=float)
    ap.add_argument("--pass-spp", type=int, default=32)
    ap.add_argument("--threads", type=int, default=2)
    ap.add_argument("--width", type=int, default=256)
    ap.add_argument("--height", type=int, default=256)
    ap.add_argument("--seed", type=int, default=7)
    ap.add_argument("--sampler", default="independent")
    a = ap.parse_args()
    if a.sampler == "ldsampler":
        # Mitsuba rounds the low-discrepancy sampler's count up to a square power of two (4, 16, 64, ...):
        # render passes of that size, so that the samples counted are the samples rendered.
        n = 1
        while n < a.pass_spp:
            n *= 4
        a.pass_spp = n
    dr.set_thread_count(a.threads)
    scene = mi.load_dict(scene_dict(a.ply, a.width, a.height, a.sampler, a.crop))

    def render(spp, seed):
        img = mi.render(scene, spp=spp, seed=seed)
        dr.eval(img)
        dr.sync_thread()
        return img

    # Both modes render passes of --pass-spp samples with distinct seeds (the seed is not baked into the
    # kernel, so every pass reuses the kernel the untimed warm-up pass compiled); the image is their mean.
    render(a.pass_spp, a.seed + 100_000)
    acc, spp, seconds, seed = None, 0, 0.0, a.seed
    while True:
        if a.seconds is None:
            if spp >= a.spp:
                break
        elif spp > 0 and seconds * (spp + a.pass_spp) / spp > a.seconds:
            # The next pass would end after the limit at the rate measured so far: stop, so that Mitsuba
            # renders at most --seconds, as caustica's --time-limit does.
            break
        t0 = time.perf_counter()
        img = render(a.pass_spp, seed)
        seconds += time.perf_counter() - t0
        acc = img if acc is None else acc + img
        spp += a.pass_spp
        seed += 1
    img = acc * (a.pass_spp / spp)
    mi.Bitmap(img).write(a.out)
    samples = spp * (a.crop[2] * a.crop[3] if a.crop else a.width * a.height)
    untimed = a.pass_spp * (a.crop[2] * a.crop[3] if a.crop else a.width * a.height)
    print(json.dumps({"samples": samples, "spp": spp, "seconds": seconds, "samples_per_second": samples / seconds, "samples_untimed": untimed}))


if __name__ == "__main__":
    main()
