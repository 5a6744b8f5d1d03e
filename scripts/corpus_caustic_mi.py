"""Mitsuba 3 side of scripts/corpus-caustic-benchmark: renders a Mitsuba scene file as written, but for its film
size and sample count, with its own integrator, and prints one JSON line (spp, seconds).

  python corpus_caustic_mi.py SCENE.xml OUT.exr --width W --height H --spp N [--seed S] [--variant V]
                              [--crop X Y CW CH]

The file is read from its own directory (relative mesh and texture paths resolve as there); the film's
`width`/`height` and the sampler's `sample_count` are replaced by parameters given to Mitsuba's loader, and a
film's `high_quality_edges` (Mitsuba 0.x's, which 3.9.1 refuses as unreferenced; it changes no image) is removed.
--crop renders only the CW×CH pixels from (X, Y) of the film (hdrfilm's crop window: the same pixels and values as
in the whole image); OUT is CW×CH.
"""
import argparse
import json
import os
import re
import tempfile
import time

import mitsuba as mi


def main():
    ap = argparse.ArgumentParser()
    ap.add_argument("scene")
    ap.add_argument("out")
    ap.add_argument("--width", type=int, required=True)
    ap.add_argument("--height", type=int, required=True)
    ap.add_argument("--spp", type=int, required=True)
    ap.add_argument("--seed", type=int, default=0)
    ap.add_argument("--variant", default="scalar_rgb")
    ap.add_argument("--crop", nargs=4, type=int, metavar=("X", "Y", "CW", "CH"))
    a = ap.parse_args()
    mi.set_variant(a.variant)
    text = open(a.scene).read()
    # The film size and the sample count as parameters: the first integer named width/height/sample_count.
    for name in ("width", "height", "sample_count"):
        text = re.sub(r'(<integer\s+name="%s"\s+value=")[^"]*(")' % name, r"\g<1>$mi_%s\g<2>" % name, text, count=1)
    text = re.sub(r'<boolean\s+name="high_quality_edges"[^>]*/>', "", text)
    if a.crop is not None:
        names = ("crop_offset_x", "crop_offset_y", "crop_width", "crop_height")
        crop = "".join('<integer name="%s" value="%d"/>' % (n, v) for n, v in zip(names, a.crop))
        text = re.sub(r'(<film\s+type="hdrfilm"[^>]*>)', lambda m: m.group(1) + crop, text, count=1)
    directory = os.path.dirname(os.path.abspath(a.scene))
    mi.file_resolver().prepend(directory)
    with tempfile.NamedTemporaryFile("w", suffix=".xml", dir=None, delete=False) as f:
        f.write(text)
        path = f.name
    try:
        scene = mi.load_file(path, mi_width=str(a.width), mi_height=str(a.height), mi_sample_count=str(a.spp))
    finally:
        os.unlink(path)
    start = time.perf_counter()
    image = mi.render(scene, spp=a.spp, seed=a.seed)
    seconds = time.perf_counter() - start
    mi.util.write_bitmap(a.out, image)
    print(json.dumps({"spp": a.spp, "seconds": seconds}))


if __name__ == "__main__":
    main()
