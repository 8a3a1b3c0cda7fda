#!/usr/bin/env python3
"""Compares features dumped by the C and C++ tests with `lfast detect`'s JSON, bit for bit.

    compare_features.py JSON_DIR DUMP_DIR

JSON_DIR holds `lfast detect --format json` output (NAME.json); DUMP_DIR holds
NAME.EXT.features files, one line a keypoint: the IEEE bits of x, y, size, angle
and response as 8 hex digits, octave, class_id, and the descriptor as 64 hex
digits. The JSON's floats are the shortest text that reads back as the same
float32, so packing them as float32 gives the bits `lfast detect` had.
Exit 0 when every dump equals its JSON and every JSON has a dump.
"""

import json
import os
import struct
import sys


def f32_bits(v):
    return "%08x" % struct.unpack("<I", struct.pack("<f", v))[0]


def lines_of_json(path):
    with open(path) as f:
        doc = json.load(f)
    out = []
    for k, d in zip(doc["keypoints"], doc["descriptors"], strict=True):
        floats = [k["pt"][0], k["pt"][1], k["size"], k["angle"], k["response"]]
        out.append(" ".join([f32_bits(v) for v in floats] + [str(k["octave"]), str(k["class_id"]), d.lower()]))
    return out


def main():
    if len(sys.argv) != 3:
        print(__doc__, file=sys.stderr)
        return 2
    json_dir, dump_dir = sys.argv[1], sys.argv[2]
    dumps = {}
    for name in os.listdir(dump_dir):
        if name.endswith(".features"):
            dumps[os.path.splitext(name[: -len(".features")])[0]] = os.path.join(dump_dir, name)
    bad = 0
    jsons = sorted(n for n in os.listdir(json_dir) if n.endswith(".json"))
    if not jsons:
        print(f"no JSON files in {json_dir}", file=sys.stderr)
        return 1
    for name in jsons:
        stem = name[: -len(".json")]
        want = lines_of_json(os.path.join(json_dir, name))
        if stem not in dumps:
            print(f"{stem}: no dump in {dump_dir}", file=sys.stderr)
            bad += 1
            continue
        with open(dumps[stem]) as f:
            got = [line.strip() for line in f if line.strip()]
        if got == want:
            print(f"{stem}: {len(want)} keypoints and descriptors identical to lfast detect")
            continue
        bad += 1
        print(f"{stem}: {len(got)} keypoints, lfast detect has {len(want)}", file=sys.stderr)
        for i, (g, w) in enumerate(zip(got, want)):
            if g != w:
                print(f"  first difference at keypoint {i}:\n    got  {g}\n    want {w}", file=sys.stderr)
                break
    return 1 if bad else 0


if __name__ == "__main__":
    sys.exit(main())
