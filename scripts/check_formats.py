#!/usr/bin/env python3
"""Reads back what `lfast detect --format json,csv,npy,yaml` wrote and checks
that every format holds the same features as the JSON.

    python3 scripts/check_formats.py OUT_DIR

For each OUT_DIR/**/NAME.json: NAME.yaml is read with cv2.FileStorage
(keypoints and a CV_8U N x 32 descriptor matrix), NAME.keypoints.npy and
NAME.descriptors.npy with numpy (float32 N x 7, uint8 N x 32), NAME.csv with
the csv module. Exits non-zero on any mismatch or missing file.
"""
import argparse
import csv
import json
import pathlib
import sys

import cv2
import numpy as np


def json_arrays(path):
    f = json.loads(path.read_text())
    kps = np.array(
        [[k["pt"][0], k["pt"][1], k["size"], k["angle"], k["response"], k["octave"], k["class_id"]] for k in f["keypoints"]],
        dtype=np.float32,
    ).reshape(-1, 7)
    desc = np.array([list(bytes.fromhex(d)) for d in f["descriptors"]], dtype=np.uint8).reshape(-1, 32)
    return kps, desc


def yaml_arrays(path):
    fs = cv2.FileStorage(str(path), cv2.FILE_STORAGE_READ)
    if not fs.isOpened():
        raise ValueError("cv2.FileStorage cannot open it")
    node = fs.getNode("keypoints")
    rows = []
    for i in range(node.size()):
        k = node.at(i)
        rows.append([k.at(j).real() for j in range(k.size())])
    kps = np.array(rows, dtype=np.float32).reshape(-1, 7)
    desc = fs.getNode("descriptors").mat()
    fs.release()
    if desc is None:  # an empty matrix reads back as None
        desc = np.zeros((0, 32), np.uint8)
    return kps, desc


def csv_arrays(path):
    with open(path, newline="") as f:
        r = list(csv.DictReader(f))
    cols = ["x", "y", "size", "angle", "response", "octave", "class_id"]
    kps = np.array([[float(row[c]) for c in cols] for row in r], dtype=np.float32).reshape(-1, 7)
    desc = np.array([list(bytes.fromhex(row["descriptor"])) for row in r], dtype=np.uint8).reshape(-1, 32)
    return kps, desc


def main():
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("out_dir", type=pathlib.Path)
    args = ap.parse_args()
    jsons = sorted(args.out_dir.rglob("*.json"))
    if not jsons:
        print(f"no .json files under {args.out_dir}", file=sys.stderr)
        return 1
    bad = 0
    for j in jsons:
        base = str(j)[: -len(".json")]
        kps, desc = json_arrays(j)
        checks = {}
        try:
            checks["yaml"] = yaml_arrays(pathlib.Path(base + ".yaml"))
            checks["npy"] = (np.load(base + ".keypoints.npy"), np.load(base + ".descriptors.npy"))
            checks["csv"] = csv_arrays(pathlib.Path(base + ".csv"))
        except Exception as e:  # a missing or unreadable file
            print(f"FAIL {base}: {e}", file=sys.stderr)
            bad += 1
            continue
        file_bad = 0
        for name, (k, d) in checks.items():
            problems = []
            if k.shape != kps.shape:
                problems.append(f"keypoints shape {k.shape} != {kps.shape}")
            elif not np.array_equal(k.astype(np.float32), kps):
                problems.append(f"keypoints differ (max |diff| {np.abs(k.astype(np.float32) - kps).max()})")
            if name == "npy" and k.dtype != np.float32:
                problems.append(f"keypoints dtype {k.dtype}")
            if d.shape != desc.shape or d.dtype != np.uint8:
                problems.append(f"descriptors {d.shape} {d.dtype} != {desc.shape} uint8")
            elif not np.array_equal(d, desc):
                problems.append("descriptors differ")
            if problems:
                print(f"FAIL {base} ({name}): " + "; ".join(problems), file=sys.stderr)
                file_bad += 1
        bad += file_bad
        if not file_bad:
            print(f"ok   {base}: {len(kps)} keypoints in json, yaml, npy, csv")
    print(f"{len(jsons)} files checked, {bad} problems")
    return 1 if bad else 0


if __name__ == "__main__":
    sys.exit(main())
