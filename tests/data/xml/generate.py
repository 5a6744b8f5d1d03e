#!/usr/bin/env python3
"""Writes Mitsuba 3 XML twins of caustica's TOML scenes with Mitsuba's own writer.

Each TOML scene is turned into a Mitsuba scene dictionary (the same plugins and properties, transforms
as `mi.ScalarTransform4f`, caustica's caustic settings as the `caustics_*` properties of the path
integrator), parsed with `mitsuba.parser.parse_dict` and written with `mitsuba.parser.write_file`. The
XML files are therefore written by another program than caustica: they test that caustica reads what
Mitsuba writes (`<default>`s with `$` references, `lookat`, decomposed transforms, `name` attributes on
nested plugins). `tests/suite/scene_xml.rs` renders each twin and its TOML scene and compares the images.

Usage (from the repository root; Mitsuba from PyPI, its scalar_rgb variant needs no LLVM):
    python3 -m venv build/mi-venv && build/mi-venv/bin/pip install mitsuba==3.9.1
    build/mi-venv/bin/python tests/data/xml/generate.py
"""

import os
import sys
import tomllib

import mitsuba as mi

mi.set_variant("scalar_rgb")
import mitsuba.parser as parser  # noqa: E402  (needs the variant)

ROOT = os.path.dirname(os.path.dirname(os.path.dirname(os.path.dirname(os.path.abspath(__file__)))))
OUT = os.path.join(ROOT, "tests", "data", "xml")
SCENES = [
    "scenes/cornell-caustics.toml",
    "scenes/envmap-glass.toml",
    "scenes/teapot-glossy.toml",
    "scenes/teapot-glossy-small-light.toml",
    "tests/data/glossy-mirror.toml",
    "tests/data/mirror-box.toml",
    "tests/data/mirror-ceiling.toml",
]
T = mi.ScalarTransform4f


def transform(to_world):
    """The matrix of a TOML `to_world` (one table or a list, the first applied first)."""
    ops = to_world if isinstance(to_world, list) else [to_world]
    m = T()
    for op in ops:
        (kind, v), = op.items()
        if kind == "translate":
            t = T().translate(v)
        elif kind == "rotate":
            t = T().rotate(v["axis"], v["angle"])
        elif kind == "scale":
            t = T().scale(v if isinstance(v, list) else [v, v, v])
        elif kind == "look_at":
            t = T().look_at(origin=v["origin"], target=v["target"], up=v["up"])
        elif kind == "matrix":
            t = T(mi.ScalarMatrix4f([v[4 * r:4 * r + 4] for r in range(4)]))
        else:
            raise ValueError(kind)
        m = t @ m
    return m


def colour(v):
    return {"type": "rgb", "value": v} if isinstance(v, list) else float(v)


def bsdf(v):
    if isinstance(v, str):
        return {"type": "ref", "id": v}
    d = {"type": v["type"]}
    for k, x in v.items():
        if k == "type":
            continue
        if k in ("bsdf", "bsdf_0", "bsdf_1"):
            d[k] = bsdf(x)
        elif k in ("reflectance", "specular_reflectance", "eta", "k"):
            d[k] = colour(x)
        else:
            d[k] = x
    return d


def relocate(filename, scene_dir):
    """A file name relative to the scene's directory → relative to the XML file's directory."""
    return os.path.relpath(os.path.join(scene_dir, filename), OUT)


def scene_dict(scene, scene_dir):
    integ = scene.get("integrator", {})
    d = {"type": "scene"}
    i = {"type": "path"}
    for k in ("max_depth", "rr_depth"):
        if k in integ:
            i[k] = integ[k]
    for k, x in integ.get("caustics", {}).items():
        i["caustics_" + k] = x
    d["integrator"] = i
    s = scene["sensor"]
    film = s.get("film", {})
    f = {"type": "hdrfilm", "rfilter": {"type": "box"}}
    for k in ("width", "height"):
        if k in film:
            f[k] = film[k]
    if "crop" in film:
        x0, y0, x1, y1 = film["crop"]
        f.update(crop_offset_x=x0, crop_offset_y=y0, crop_width=x1 - x0, crop_height=y1 - y0)
    sampler = {"type": "independent"}
    if "samples_per_pixel" in integ:
        sampler["sample_count"] = integ["samples_per_pixel"]
    if "seed" in integ:
        sampler["seed"] = integ["seed"]
    sensor = {"type": "perspective", "fov": float(s["fov"]), "film": f, "sampler": sampler}
    if "fov_axis" in s:
        sensor["fov_axis"] = s["fov_axis"]
    if "to_world" in s:
        sensor["to_world"] = transform(s["to_world"])
    d["sensor"] = sensor
    for name, b in scene.get("bsdf", {}).items():
        d[name] = bsdf(b)
    for n, sh in enumerate(scene.get("shape", [])):
        x = {}
        for k, v in sh.items():
            if k == "to_world":
                x[k] = transform(v)
            elif k == "bsdf":
                x[k] = bsdf(v)
            elif k == "emitter":
                x[k] = {"type": v["type"], "radiance": colour(v["radiance"])}
            elif k == "filename":
                x[k] = relocate(v, scene_dir)
            elif k == "radius":
                x[k] = float(v)
            else:
                x[k] = v
        d[f"shape_{n}"] = x
    for n, e in enumerate(scene.get("emitter", [])):
        x = {}
        for k, v in e.items():
            if k == "to_world":
                x[k] = transform(v)
            elif k == "radiance":
                x[k] = colour(v)
            elif k == "filename":
                x[k] = relocate(v, scene_dir)
            elif k == "scale":
                x[k] = float(v)
            else:
                x[k] = v
        d[f"emitter_{n}"] = x
    return d


def main():
    config = parser.ParserConfig("scalar_rgb")
    for rel in SCENES:
        path = os.path.join(ROOT, rel)
        with open(path, "rb") as f:
            scene = tomllib.load(f)
        state = parser.parse_dict(config, scene_dict(scene, os.path.dirname(path)))
        out = os.path.join(OUT, os.path.splitext(os.path.basename(rel))[0] + ".xml")
        parser.write_file(state, out)
        print(f"{rel} -> {os.path.relpath(out, ROOT)}", file=sys.stderr)


if __name__ == "__main__":
    main()
