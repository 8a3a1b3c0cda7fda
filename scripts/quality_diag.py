#!/usr/bin/env python3
"""Where L-FAST's keypoints lose against FAST-9 and ORB (docs/quality.md).

Runs the `lfast` CLI (target/release/lfast, `cargo build --release`) on the
Oxford-format scenes of ../shared/data/homography and scores the keypoints
with the protocol of `lfast eval repeatability` (docs/evaluation.md, suite 4):
image 1 against images 2..N, common region, one-to-one pairs closest first
within eps, repeatability = pairs / min(common), matching score = cross-checked
Hamming matches within eps / min(common). The `variants` section runs each
variant with its own cap, `n_features = budget`, as the suite does since
2026-11-26; `--top-n` cuts the uncapped output to the top N by response
instead (the suite's protocol before, and that of the other sections).

    python3 scripts/quality_diag.py [--data ../shared/data/homography] [--budget 500] [SECTION ...]

Sections: levels, localisation, loss, candidates, swap, snap (default: all), and
snaprank, gate, variants, rerank, xscale, quotas, vo (VO ATE over the twenty RANSAC seeds of `lfast eval vo`; needs ../kitti beside --data).
Needs numpy and opencv-python (cv2 FAST/ORB for the references, cv2.cornerHarris).
"""
import argparse
import json
import os
import re
import subprocess
import sys
import tempfile

import cv2
import numpy as np
from lfast_data import data_dir

ROOT = os.path.dirname(os.path.dirname(os.path.abspath(__file__)))
LFAST = os.path.join(ROOT, "target", "release", "lfast")
SCALE = 1.2
CACHE = {}


def scenes(data):
    out = []
    for name in sorted(os.listdir(data)):
        d = os.path.join(data, name)
        if not os.path.isfile(os.path.join(d, "img1.png")):
            continue
        pairs = []
        for k in range(2, 100):
            img, h = os.path.join(d, f"img{k}.png"), os.path.join(d, f"H1to{k}p")
            if not (os.path.isfile(img) and os.path.isfile(h)):
                break
            pairs.append((k, img, np.loadtxt(h)))
        out.append((name, os.path.join(d, "img1.png"), pairs))
    return out


def gray(path):
    img = cv2.imread(path, cv2.IMREAD_UNCHANGED)
    if img.ndim == 3:
        img = cv2.cvtColor(img, cv2.COLOR_BGR2GRAY)
    return img


def lfast(paths, cfg):
    """Keypoints (Nx7: x y size angle response octave class) and descriptors of each path."""
    key = (tuple(paths), json.dumps(cfg, sort_keys=True))
    if key in CACHE:
        return CACHE[key]
    with tempfile.TemporaryDirectory() as tmp:
        conf = os.path.join(tmp, "c.toml")
        with open(conf, "w") as f:
            for k, v in cfg.items():
                f.write(f"{k} = {json.dumps(v)}\n")
        res = {}
        for i, p in enumerate(paths):
            d = os.path.join(tmp, str(i))
            subprocess.run([LFAST, "detect", "--backend", "cpu", "--config", conf, "--format", "npy", "--out", d, p],
                           check=True, stdout=subprocess.DEVNULL)
            stem = os.path.splitext(os.path.basename(p))[0]
            res[p] = (np.load(os.path.join(d, stem + ".keypoints.npy")), np.load(os.path.join(d, stem + ".descriptors.npy")))
    CACHE[key] = res
    return res


def level_images(img, levels=8):
    out = [img]
    h, w = img.shape
    for l in range(1, levels):
        s = SCALE ** l
        out.append(cv2.resize(out[-1], (max(1, round(w / s)), max(1, round(h / s))), interpolation=cv2.INTER_LINEAR))
    return out


def warp(h, pts):
    q = np.c_[pts, np.ones(len(pts))] @ h.T
    return q[:, :2] / q[:, 2:3]


def inside(p, shape):
    return (p[:, 0] >= 0) & (p[:, 1] >= 0) & (p[:, 0] <= shape[1] - 1) & (p[:, 1] <= shape[0] - 1)


def score(p1, d1, s1, p2, d2, s2, h, eps=2.5):
    """(repeatability, matching score, pairs [(i1, i2, dist)], common index arrays)."""
    q1 = warp(h, p1) if len(p1) else np.zeros((0, 2))
    c1 = np.nonzero(inside(q1, s2))[0] if len(p1) else np.zeros(0, int)
    b2 = warp(np.linalg.inv(h), p2) if len(p2) else np.zeros((0, 2))
    c2 = np.nonzero(inside(b2, s1))[0] if len(p2) else np.zeros(0, int)
    denom = min(len(c1), len(c2))
    if denom == 0:
        return 0.0, 0.0, [], c1, c2
    a, b = q1[c1], p2[c2]
    grid = {}
    for j, (x, y) in enumerate(b):
        grid.setdefault((int(x // eps), int(y // eps)), []).append(j)
    cand = []
    for i, (x, y) in enumerate(a):
        gx, gy = int(x // eps), int(y // eps)
        for dx in (-1, 0, 1):
            for dy in (-1, 0, 1):
                for j in grid.get((gx + dx, gy + dy), ()):
                    d = float(np.hypot(x - b[j, 0], y - b[j, 1]))
                    if d <= eps:
                        cand.append((d, i, j))
    cand.sort()
    u1, u2, pairs = set(), set(), []
    for d, i, j in cand:
        if i not in u1 and j not in u2:
            u1.add(i)
            u2.add(j)
            pairs.append((c1[i], c2[j], d))
    ms = 0.0
    if d1 is not None and len(c1) and len(c2):
        bits = np.unpackbits(d1[c1], axis=1).astype(np.int16)
        bits2 = np.unpackbits(d2[c2], axis=1).astype(np.int16)
        ham = bits @ (1 - bits2).T + (1 - bits) @ bits2.T
        fwd, back = ham.argmin(1), ham.argmin(0)
        good = sum(1 for i, j in enumerate(fwd) if back[j] == i and np.hypot(*(a[i] - b[j])) <= eps)
        ms = good / denom
    return len(pairs) / denom, ms, pairs, c1, c2


def top(kps, desc, n):
    if n is None or len(kps) <= n:
        return kps, desc
    return kps[:n], desc[:n]  # the CLI writes SPEC 9 order (response descending)


def cv_orb(img, n):
    orb = cv2.ORB_create(n)
    k, d = orb.detectAndCompute(img, None)
    return k, d


def cv_fast(img, n):
    k = cv2.FastFeatureDetector_create(20, True).detect(img)
    k = sorted(k, key=lambda x: -x.response)[:n]
    k, d = cv2.ORB_create(n).compute(img, k)
    return k, d


def kp_arr(k):
    return np.array([p.pt for p in k], dtype=np.float64).reshape(-1, 2)


def all_pairs(data):
    for name, ref, pairs in scenes(data):
        for k, img, h in pairs:
            yield name, ref, k, img, h


def section_levels(a):
    print("\n## levels: pyramid level of the top N, and the share of each level's keypoints that repeat")
    cfg = {}
    paths = sorted({p for _, r, _, i, _ in all_pairs(a.data) for p in (r, i)})
    res = lfast(paths, cfg)
    per = np.zeros((8, 2))
    count = np.zeros(8)
    for name, ref, k, img, h in all_pairs(a.data):
        (k1, d1), (k2, d2) = top(*res[ref], a.budget), top(*res[img], a.budget)
        s1, s2 = gray(ref).shape, gray(img).shape
        rep, ms, pairs, c1, c2 = score(k1[:, :2], None, s1, k2[:, :2], None, s2, h)
        lv = k1[:, 5].astype(int)
        hit = np.zeros(len(k1), bool)
        hit[[p[0] for p in pairs]] = True
        for l in range(8):
            sel = np.intersect1d(np.nonzero(lv == l)[0], c1)
            per[l] += (hit[sel].sum(), len(sel))
            count[l] += (lv == l).sum()
    n_pairs = sum(1 for _ in all_pairs(a.data))
    print("| level | keypoints of image 1 (mean) | repeated (of common) |")
    print("|---:|---:|---:|")
    for l in range(8):
        print(f"| {l} | {count[l] / n_pairs:.0f} | {100 * per[l, 0] / max(per[l, 1], 1):.1f}% |")


def detectors(a, ref, img):
    """(label, p1, d1, levels1, p2, d2, levels2) for lfast default, FAST-9, ORB at the budget."""
    res = lfast([ref, img], {})
    (k1, d1), (k2, d2) = top(*res[ref], a.budget), top(*res[img], a.budget)
    g1, g2 = gray(ref), gray(img)
    yield "L-FAST", k1[:, :2], d1, k1[:, 5], k2[:, :2], d2, k2[:, 5]
    for lab, f in (("FAST-9", cv_fast), ("ORB", cv_orb)):
        a1, e1 = f(g1, a.budget)
        a2, e2 = f(g2, a.budget)
        yield lab, kp_arr(a1), e1, np.array([p.octave for p in a1]), kp_arr(a2), e2, np.array([p.octave for p in a2])


def section_localisation(a):
    print("\n## localisation: distance of one-to-one corresponding keypoints (pairs within 5 px), in image n pixels")
    print("| detector | pairs within 5 px | <= 1 px | 1-1.5 | 1.5-2.5 | 2.5-5 | rep @1.5 | rep @2.5 | rep @5 | level-0 pairs median (px) | level >=3 median |")
    print("|---|---:|---:|---:|---:|---:|---:|---:|---:|---:|---:|")
    acc = {}
    for name, ref, k, img, h in all_pairs(a.data):
        s1, s2 = gray(ref).shape, gray(img).shape
        for lab, p1, d1, l1, p2, d2, l2 in detectors(a, ref, img):
            st = acc.setdefault(lab, {"d": [], "rep": {1.5: [], 2.5: [], 5.0: []}, "d0": [], "d3": []})
            for eps in (1.5, 2.5, 5.0):
                st["rep"][eps].append(score(p1, None, s1, p2, None, s2, h, eps)[0])
            pairs = score(p1, None, s1, p2, None, s2, h, 5.0)[2]
            st["d"] += [p[2] for p in pairs]
            st["d0"] += [p[2] for p in pairs if l1[p[0]] == 0]
            st["d3"] += [p[2] for p in pairs if l1[p[0]] >= 3]
    for lab, st in acc.items():
        d = np.array(st["d"])
        bins = [np.mean(d <= 1), np.mean((d > 1) & (d <= 1.5)), np.mean((d > 1.5) & (d <= 2.5)), np.mean(d > 2.5)]
        r = [100 * np.mean(st["rep"][e]) for e in (1.5, 2.5, 5.0)]
        m0 = np.median(st["d0"]) if st["d0"] else float("nan")
        m3 = np.median(st["d3"]) if st["d3"] else float("nan")
        print(f"| {lab} | {len(d)} | " + " | ".join(f"{100 * b:.0f}%" for b in bins)
              + f" | {r[0]:.1f}% | {r[1]:.1f}% | {r[2]:.1f}% | {m0:.2f} | {m3:.2f} |")


def edge_map(path):
    with tempfile.TemporaryDirectory() as tmp:
        subprocess.run([LFAST, "edges", "--backend", "cpu", "--out", tmp, path], check=True, stdout=subprocess.DEVNULL)
        f = [x for x in os.listdir(tmp) if x.endswith(".png")][0]
        return cv2.imread(os.path.join(tmp, f), cv2.IMREAD_GRAYSCALE)


def near(points, q, r):
    if len(points) == 0:
        return False
    return bool((((points - q) ** 2).sum(1) <= r * r).any())


def section_loss(a):
    print("\n## loss: level-0 keypoints of image 1 (top N) whose warped position has no top-N keypoint within 2.5 px in image n")
    print("Classified by the first stage of image n that has nothing within 2.5 px of the warped position (level 0).")
    tally = {}
    for name, ref, k, img, h in all_pairs(a.data):
        res = lfast([ref, img], {})
        unc = lfast([img], {"n_features": 0})[img][0]
        cand = lfast([img], {"nms_radius": 0})[img][0]
        (k1, _), (k2, _) = top(*res[ref], a.budget), top(*res[img], a.budget)
        e = edge_map(img)
        ey, ex = np.nonzero(e == 255)
        edges = np.c_[ex + 0.5, ey + 0.5]
        s2 = e.shape
        q = warp(h, k1[:, :2])
        for i in range(len(k1)):
            if k1[i, 5] != 0 or not inside(q[i:i + 1], s2)[0]:
                continue
            if near(k2[:, :2], q[i], 2.5):
                c = "repeated in top N"
            elif near(unc[unc[:, 5] == 0][:, :2], q[i], 2.5):
                c = "a level-0 keypoint there, lost to the cap"
            elif near(unc[:, :2], q[i], 2.5):
                c = "a keypoint of another level there, lost to the cap"
            elif near(cand[cand[:, 5] == 0][:, :2], q[i], 2.5):
                c = "an L-FAST candidate there, lost to corner NMS"
            elif near(edges, q[i], 2.5):
                c = "edge pixels there, no L-FAST corner"
            else:
                c = "no edge pixel within 2.5 px"
            tally[c] = tally.get(c, 0) + 1
    tot = sum(tally.values())
    print("| fate in image n | share of level-0 keypoints of image 1 |")
    print("|---|---:|")
    for c in ("repeated in top N", "a level-0 keypoint there, lost to the cap", "a keypoint of another level there, lost to the cap",
              "an L-FAST candidate there, lost to corner NMS", "edge pixels there, no L-FAST corner", "no edge pixel within 2.5 px"):
        print(f"| {c} | {100 * tally.get(c, 0) / tot:.1f}% |")


def harris(img):
    return cv2.cornerHarris(img.astype(np.float32), 7, 3, 0.04)


def section_candidates(a):
    print("\n## candidates: does the level-0 candidate set repeat, against Harris maxima? (uncapped, one level)")
    print("| set (level 0, image 1 vs n) | points in image 1 (mean) | repeatability @2.5 | @1.5 |")
    print("|---|---:|---:|---:|")
    acc = {}
    for name, ref, k, img, h in all_pairs(a.data):
        g1, g2 = gray(ref), gray(img)
        sets = {}
        for lab, cfg in (("L-FAST candidates, before corner NMS", {"n_levels": 1, "nms_radius": 0}),
                         ("L-FAST after corner NMS (r 3)", {"n_levels": 1})):
            r = lfast([ref, img], cfg)
            sets[lab] = (r[ref][0][:, :2], r[img][0][:, :2])
        n = len(sets["L-FAST after corner NMS (r 3)"][0])
        hm = []
        for g in (g1, g2):
            R = harris(g)
            mx = cv2.dilate(R, np.ones((7, 7), np.uint8))
            ys, xs = np.nonzero((R == mx) & (R > 0))
            o = np.argsort(-R[ys, xs])[:n]
            hm.append(np.c_[xs[o] + 0.5, ys[o] + 0.5])
        sets["Harris 7x7 maxima (r 3), as many as L-FAST after NMS"] = tuple(hm)
        fr = cv2.FastFeatureDetector_create(20, True)
        sets["FAST-9 (NMS), all"] = tuple(kp_arr(fr.detect(g)) for g in (g1, g2))
        for lab, (p1, p2) in sets.items():
            st = acc.setdefault(lab, [[], [], []])
            st[0].append(len(p1))
            st[1].append(score(p1, None, g1.shape, p2, None, g2.shape, h, 2.5)[0])
            st[2].append(score(p1, None, g1.shape, p2, None, g2.shape, h, 1.5)[0])
    for lab, st in acc.items():
        print(f"| {lab} | {np.mean(st[0]):.0f} | {100 * np.mean(st[1]):.1f}% | {100 * np.mean(st[2]):.1f}% |")


def section_swap(a):
    print("\n## swap: L-FAST keypoints described by cv2 ORB's compute")
    print("| keypoints + descriptors | repeatability | matching score |")
    print("|---|---:|---:|")
    acc = {}
    orb = cv2.ORB_create(a.budget)
    for name, ref, k, img, h in all_pairs(a.data):
        g1, g2 = gray(ref), gray(img)
        res = lfast([ref, img], {})
        (k1, d1), (k2, d2) = top(*res[ref], a.budget), top(*res[img], a.budget)
        rows = {"L-FAST + L-FAST rBRIEF": (k1[:, :2], d1, k2[:, :2], d2)}
        cvk = []
        for kk, g in ((k1, g1), (k2, g2)):
            kp = [cv2.KeyPoint(float(x), float(y), float(sz), float(an), float(r), int(o))
                  for x, y, sz, an, r, o, _ in kk]
            kp, d = orb.compute(g, kp)
            cvk.append((kp_arr(kp), d))
        rows["L-FAST keypoints + cv2 ORB compute"] = (cvk[0][0], cvk[0][1], cvk[1][0], cvk[1][1])
        o1, e1 = cv_orb(g1, a.budget)
        o2, e2 = cv_orb(g2, a.budget)
        rows["cv2 ORB + cv2 ORB"] = (kp_arr(o1), e1, kp_arr(o2), e2)
        for lab, (p1, d1_, p2, d2_) in rows.items():
            r, m, *_ = score(p1, d1_, g1.shape, p2, d2_, g2.shape, h)
            acc.setdefault(lab, []).append((r, m))
    for lab, v in acc.items():
        v = np.array(v)
        print(f"| {lab} | {100 * v[:, 0].mean():.1f}% | {100 * v[:, 1].mean():.1f}% |")


def snapped(kps, g, radius):
    """Each keypoint moved to the Harris maximum of its level within the (2r+1)^2 square."""
    lv = level_images(g)
    hs = [harris(x) for x in lv]
    out = kps[:, :2].copy()
    for i, (x, y, _, _, _, o, _) in enumerate(kps):
        o = int(o)
        s = SCALE ** o
        cx, cy = int(np.floor(x / s)), int(np.floor(y / s))
        R = hs[o]
        y0, y1, x0, x1 = max(cy - radius, 0), min(cy + radius + 1, R.shape[0]), max(cx - radius, 0), min(cx + radius + 1, R.shape[1])
        win = R[y0:y1, x0:x1]
        dy, dx = np.unravel_index(np.argmax(win), win.shape)
        out[i] = ((x0 + dx + 0.5) * s, (y0 + dy + 0.5) * s)
    return out


def section_snap(a):
    print("\n## snap: L-FAST top N moved to the Harris maximum nearby (cv2.cornerHarris 7x7 on each level), positions only")
    print("| variant | repeatability @2.5 | @1.5 |")
    print("|---|---:|---:|")
    acc = {}
    for name, ref, k, img, h in all_pairs(a.data):
        g1, g2 = gray(ref), gray(img)
        for sup in (4, 3):
            res = lfast([ref, img], {"support": sup})
            (k1, _), (k2, _) = top(*res[ref], a.budget), top(*res[img], a.budget)
            for r in (0, 1, 2, 3):
                p1 = snapped(k1, g1, r) if r else k1[:, :2]
                p2 = snapped(k2, g2, r) if r else k2[:, :2]
                lab = f"support {sup}, " + (f"snap radius {r}" if r else "as detected")
                st = acc.setdefault(lab, [[], []])
                st[0].append(score(p1, None, g1.shape, p2, None, g2.shape, h, 2.5)[0])
                st[1].append(score(p1, None, g1.shape, p2, None, g2.shape, h, 1.5)[0])
    for lab, st in acc.items():
        print(f"| {lab} | {100 * np.mean(st[0]):.1f}% | {100 * np.mean(st[1]):.1f}% |")


def snap_select(kps, g, radius, n):
    """Uncapped keypoints snapped to the Harris maximum of their level within
    radius (0 = as detected), re-ranked by the Harris response there, one per
    position, top n."""
    lv = level_images(g)
    hs = [harris(x) for x in lv]
    seen, out = set(), []
    for x, y, _, _, _, o, _ in kps:
        o = int(o)
        s = SCALE ** o
        cx, cy = int(np.floor(x / s)), int(np.floor(y / s))
        R = hs[o]
        y0, y1 = max(cy - radius, 0), min(cy + radius + 1, R.shape[0])
        x0, x1 = max(cx - radius, 0), min(cx + radius + 1, R.shape[1])
        win = R[y0:y1, x0:x1]
        dy, dx = np.unravel_index(np.argmax(win), win.shape)
        key = (o, x0 + dx, y0 + dy)
        if key in seen:
            continue
        seen.add(key)
        out.append((win[dy, dx], (x0 + dx + 0.5) * s, (y0 + dy + 0.5) * s))
    out.sort(key=lambda t: -t[0])
    return np.array([[a, b] for _, a, b in out[:n]])


def section_snaprank(a):
    print("\n## snaprank: every L-FAST keypoint (uncapped) snapped to the Harris maximum within r on its level, re-ranked by the Harris response there, one per position, top N")
    print("| variant | repeatability @2.5 | @1.5 |")
    print("|---|---:|---:|")
    acc = {}
    for name, ref, k, img, h in all_pairs(a.data):
        g1, g2 = gray(ref), gray(img)
        for sup in (4, 3):
            for nms in (3, 1):
                res = lfast([ref, img], {"support": sup, "nms_radius": nms})
                for r in (0, 1, 2, 3):
                    p1 = snap_select(res[ref][0], g1, r, a.budget)
                    p2 = snap_select(res[img][0], g2, r, a.budget)
                    lab = f"support {sup}, nms radius {nms}, snap radius {r}"
                    st = acc.setdefault(lab, [[], []])
                    st[0].append(score(p1, None, g1.shape, p2, None, g2.shape, h, 2.5)[0])
                    st[1].append(score(p1, None, g1.shape, p2, None, g2.shape, h, 1.5)[0])
    for lab, st in acc.items():
        print(f"| {lab} | {100 * np.mean(st[0]):.1f}% | {100 * np.mean(st[1]):.1f}% |")


def harris_maxima(cands, g, gate, n):
    """Harris maxima (7x7 squares, cv2.cornerHarris on each level) within `gate`
    pixels of an L-FAST candidate of the same level (gate None: every maximum),
    one pyramid, ranked by the response, top n; and the level-0 count uncapped."""
    out = []
    for o, im in enumerate(level_images(g)):
        s = SCALE ** o
        R = harris(im)
        m = np.ones(R.shape, np.uint8)
        if gate is not None:
            m[:] = 0
            c = cands[cands[:, 5] == o]
            if len(c):
                m[np.clip(np.floor(c[:, 1] / s).astype(int), 0, R.shape[0] - 1),
                  np.clip(np.floor(c[:, 0] / s).astype(int), 0, R.shape[1] - 1)] = 1
            if gate:
                m = cv2.dilate(m, np.ones((2 * gate + 1, 2 * gate + 1), np.uint8))
        # The maximum among the gated pixels (a gated pixel may win against an
        # ungated stronger neighbour, as corner NMS ranks candidates only).
        mx = cv2.dilate(np.where(m > 0, R, -np.inf).astype(np.float32), np.ones((7, 7), np.uint8))
        ys, xs = np.nonzero((m > 0) & (R >= mx) & (R > 0))
        out += [(R[y, x], (x + 0.5) * s, (y + 0.5) * s, o) for y, x in zip(ys, xs)]
    out.sort(key=lambda t: -t[0])
    arr = np.array([t[1:] for t in out]).reshape(-1, 3)
    return arr[:n, :2], int((arr[:, 2] == 0).sum())


def section_gate(a):
    print("\n## gate: Harris maxima kept where an L-FAST candidate lies within d pixels, against the default (positions at the pixel centre, cv2 Harris and pyramid)")
    print("| set, top N | " + " | ".join(s[0] for s in scenes(a.data)) + " | mean | level-0 points of image 1, uncapped |")
    print("|---|" + "---:|" * (len(scenes(a.data)) + 2))
    acc, l0 = {}, {}
    for name, ref, k, img, h in all_pairs(a.data):
        g1, g2 = gray(ref), gray(img)
        cand = lfast([ref, img], {"mode": "paper", "support": 3, "nms_radius": 0, "snap_radius": 0})
        base = lfast([ref, img], {"mode": "paper", "support": 3, "snap_radius": 1})
        (k1, _), (k2, _) = top(*base[ref], a.budget), top(*base[img], a.budget)
        sets = {"default, snapped to the cv2 Harris pixel": (snapped(k1, g1, 1), snapped(k2, g2, 1),
                                                                 int((base[ref][0][:, 5] == 0).sum()))}
        for d in (0, 1, 2, 3, 5, None):
            (p1, n1), (p2, _) = harris_maxima(cand[ref][0], g1, d, a.budget), harris_maxima(cand[img][0], g2, d, a.budget)
            sets["every Harris maximum" if d is None else f"Harris maxima, gate d = {d}"] = (p1, p2, n1)
        for lab, (p1, p2, n1) in sets.items():
            acc.setdefault(lab, {}).setdefault(name, []).append(score(p1, None, g1.shape, p2, None, g2.shape, h)[0])
            if n1 is not None and k == 2:
                l0.setdefault(lab, []).append(n1)
    for lab, per in acc.items():
        allv = [v for vs in per.values() for v in vs]
        cnt = f"{np.mean(l0[lab]):.0f}" if lab in l0 else "–"
        print(f"| {lab} | " + " | ".join(f"{100 * np.mean(v):.1f}" for v in per.values()) + f" | {100 * np.mean(allv):.1f} | {cnt} |")


# Spelled out in full, so that a change of Config::default() does not change what a row means.
VARIANTS = {
    "branch s4 (the default before 2026-11-26)": {"mode": "branch", "support": 4, "snap_radius": 0},
    "branch s3": {"mode": "branch", "support": 3, "snap_radius": 0},
    "branch s3, snap 1": {"mode": "branch", "support": 3, "snap_radius": 1},
    "branch s3, nms 4, snap 2": {"mode": "branch", "support": 3, "nms_radius": 4, "snap_radius": 2},
    "paper s3": {"mode": "paper", "support": 3, "snap_radius": 0},
    "paper s3, snap 1": {"mode": "paper", "support": 3, "snap_radius": 1},
    "paper s3, nms 4, snap 1": {"mode": "paper", "support": 3, "nms_radius": 4, "snap_radius": 1},
    "paper s3, nms 4, snap 2": {"mode": "paper", "support": 3, "nms_radius": 4, "snap_radius": 2},
    "paper s3, snap 1, no edges": {"mode": "paper", "support": 3, "snap_radius": 1, "reject_edges": True},
    "paper s3, nms 4, snap 2, no edges": {"mode": "paper", "support": 3, "nms_radius": 4, "snap_radius": 2, "reject_edges": True},
    "paper s3, nms 4, snap 2, no edges, 180 bins (default)": {
        "mode": "paper", "support": 3, "nms_radius": 4, "snap_radius": 2, "reject_edges": True, "orientation_bins": 180},
}
# Every variant names nms_radius, snap_radius, reject_edges and orientation_bins
# (3, 0, false, 30 = SPEC's unless given).
SPELLED = {"nms_radius": 3, "snap_radius": 0, "reject_edges": False, "orientation_bins": 30}
VARIANTS = {n: dict(SPELLED, **v) for n, v in VARIANTS.items()}


def section_variants(a):
    how = "top N of the uncapped output by response" if a.top_n else "n_features = N"
    print(f"\n## variants: repeatability / matching score per scene at budget N = {a.budget}, {how} (lfast detect, CPU)")
    names = [n for n in VARIANTS if not a.only or n in a.only]
    sc = [s[0] for s in scenes(a.data)]
    print("| variant | " + " | ".join(sc) + " | mean over pairs |")
    print("|---|" + "---:|" * (len(sc) + 1))
    paths = sorted({p for _, r, _, i, _ in all_pairs(a.data) for p in (r, i)})
    for n in names:
        res = lfast(paths, VARIANTS[n] if a.top_n else dict({"n_features": a.budget}, **VARIANTS[n]))
        per, allp = {}, []
        for name, ref, k, img, h in all_pairs(a.data):
            (k1, d1), (k2, d2) = top(*res[ref], a.budget), top(*res[img], a.budget)
            r, m, *_ = score(k1[:, :2], d1, gray(ref).shape, k2[:, :2], d2, gray(img).shape, h)
            per.setdefault(name, []).append((r, m))
            allp.append((r, m))
        cell = lambda v: f"{100 * np.mean([x[0] for x in v]):.1f} / {100 * np.mean([x[1] for x in v]):.1f}"
        print(f"| {n} | " + " | ".join(cell(per[s]) for s in sc) + f" | {cell(allp)} |")
        sys.stdout.flush()


def selection_table(a, title, first, extra=""):
    """Prints a selection table's title and header; returns the default's
    uncapped keypoints of every image of --data and their paths."""
    print(f"\n## {title} (rep / MS)")
    print(f"| {first} | " + " | ".join(s[0] for s in scenes(a.data)) + f" | mean over pairs |{extra}")
    print("|---|" + "---:|" * (len(scenes(a.data)) + 1 + bool(extra)))
    paths = sorted({p for _, r, _, i, _ in all_pairs(a.data) for p in (r, i)})
    return lfast(paths, {}), paths


def score_selections(a, res, name, pick, extra=""):
    """One table row: rep / MS per scene and over all pairs of the keypoints
    `pick(p)` (indices into res[p]) selects in every image p."""
    per, allp = {}, []
    for sc, ref, k, img, h in all_pairs(a.data):
        (k1, d1), (k2, d2) = ((res[p][0][o, :2], res[p][1][o]) for p in (ref, img) for o in [pick(p)])
        r, m, *_ = score(k1, d1, gray(ref).shape, k2, d2, gray(img).shape, h)
        per.setdefault(sc, []).append((r, m))
        allp.append((r, m))
    cell = lambda v: f"{100 * np.mean([x[0] for x in v]):.1f} / {100 * np.mean([x[1] for x in v]):.1f}"
    print(f"| {name} | " + " | ".join(cell(per[s[0]]) for s in scenes(a.data)) + f" | {cell(allp)} |{extra}")
    sys.stdout.flush()


def section_rerank(a):
    """The default's uncapped keypoints ranked for the cap by another score, top N."""
    res, _ = selection_table(a, f"rerank: the default's uncapped keypoints, top {a.budget} by another score", "ranking")
    eig = {}

    def score_of(p, kind):
        k = res[p][0]
        if kind == "harris":
            return k[:, 4]
        if kind.startswith("harris x 1.2^"):
            return k[:, 4] * SCALE ** (float(kind.split("^")[1].split()[0]) * k[:, 5])
        if p not in eig:  # min eigenvalue (Shi-Tomasi), 7x7 block, on cv2-resized levels
            eig[p] = [cv2.cornerMinEigenVal(x.astype(np.float32), 7, 3) for x in level_images(gray(p))]
        out = np.zeros(len(k))
        for i, (x, y, _, _, _, o, _) in enumerate(k):
            m, s = eig[p][int(o)], SCALE ** int(o)
            out[i] = m[min(int(np.floor(y / s + 1 / 32)), m.shape[0] - 1), min(int(np.floor(x / s + 1 / 32)), m.shape[1] - 1)]
        return out

    for kind in ("harris", "min eigenvalue", "harris x 1.2^-2 level", "harris x 1.2^-1 level", "harris x 1.2^1 level", "harris x 1.2^2 level"):
        score_selections(a, res, kind, lambda p: np.argsort(-score_of(p, kind), kind="stable")[:a.budget])


def cross_scale_keep(k, r, dl):
    """False for a keypoint with a stronger one (response, then earlier row) at
    another level at most `dl` levels away, within r * 1.2^max(levels) px."""
    xy, resp, lev = k[:, :2], k[:, 4], k[:, 5].astype(int)
    keep = np.ones(len(k), bool)
    for i in range(len(k)):
        d = np.hypot(*(xy - xy[i]).T)
        other = (lev != lev[i]) & (np.abs(lev - lev[i]) <= dl)
        near = other & (d <= r * SCALE ** np.maximum(lev, lev[i]))
        stronger = (resp > resp[i]) | ((resp == resp[i]) & (np.arange(len(k)) < i))
        keep[i] = not np.any(near & stronger)
    return keep


def section_xscale(a):
    """The default's uncapped keypoints without those that a stronger keypoint
    of a neighbouring level duplicates (one corner, one scale), top N."""
    res, paths = selection_table(
        a, f"xscale: the default's uncapped keypoints less cross-level duplicates, top {a.budget}", "suppression", " kept |")
    for name, r, dl in (("none", 0, 0), ("within 1 level px, levels ±1", 1.0, 1), ("within 1.5 level px, levels ±1", 1.5, 1),
                        ("within 2 level px, levels ±1", 2.0, 1), ("within 1.5 level px, levels ±2", 1.5, 2)):
        keeps = {p: np.ones(len(res[p][0]), bool) if r == 0 else cross_scale_keep(res[p][0], r, dl) for p in paths}

        def pick(p):
            idx = np.nonzero(keeps[p])[0]
            return idx[np.argsort(-res[p][0][idx, 4], kind="stable")[:a.budget]]

        kept = np.mean([keeps[p].mean() for p in paths])
        score_selections(a, res, name, pick, f" {100 * kept:.0f}% |")


def quota_pick(k, n, carry, ratio=1 / SCALE):
    """Indices of the top keypoints per level by response under geometric
    quotas, `ratio` from one level to the next over 8 levels (ORB's 1/1.2; the
    last level takes the rest; 1/1.44 is about SPEC 9's area quotas); with
    `carry`, what a level cannot fill passes to the next."""
    f = ratio
    per = n * (1 - f) / (1 - f ** 8)
    quotas = [int(round(per * f ** l)) for l in range(7)]
    quotas.append(max(n - sum(quotas), 0))
    lev, out, spare = k[:, 5].astype(int), [], 0
    for l, q in enumerate(quotas):
        idx = np.nonzero(lev == l)[0]
        take = idx[np.argsort(-k[idx, 4], kind="stable")[: q + spare]]
        spare = q + spare - len(take) if carry else 0
        out.extend(take)
    out = np.array(out, int)
    return out[np.argsort(-k[out, 4], kind="stable")]


def section_quotas(a):
    """The default's uncapped keypoints under per-level quotas, N in all."""
    res, _ = selection_table(a, f"quotas: the default's uncapped keypoints, {a.budget} under per-level quotas", "selection")
    pickers = {
        "top N by Harris (the default)": lambda k: np.argsort(-k[:, 4], kind="stable")[: a.budget],
        "ORB's quotas (ratio 1/1.2)": lambda k: quota_pick(k, a.budget, False),
        "ORB's quotas, a short level's rest to the next": lambda k: quota_pick(k, a.budget, True),
        "area quotas (ratio 1/1.44, as SPEC 9's cap)": lambda k: quota_pick(k, a.budget, False, 1 / SCALE**2),
        "quotas, ratio 1/1.1": lambda k: quota_pick(k, a.budget, False, 1 / 1.1),
        "quotas, ratio 1 (equal)": lambda k: quota_pick(k, a.budget, False, 0.999999),
    }
    for name, pick in pickers.items():
        score_selections(a, res, name, lambda p: pick(res[p][0]))


SEEDS = [24301] + list(range(1, 20))  # eval::vo::SEEDS


def section_vo(a):
    """VO ATE over the RANSAC seeds and the level-0 count (target d) of each variant."""
    seq = os.path.join(a.data, "..", "kitti", "seq01_000000-000050")
    print(f"\n## vo: `lfast vo` ATE RMSE (SE(3)) over RANSAC seeds {SEEDS}, and level-0 keypoints per frame (n_levels 1, no cap)")
    print("| variant | ATE mean (m) | standard error | min | max | keypoints/frame | level-0 keypoints/frame |")
    print("|---|---:|---:|---:|---:|---:|---:|")
    frames = sorted(os.path.join(seq, "image_0", f) for f in os.listdir(os.path.join(seq, "image_0")))
    rows = [(n, VARIANTS[n]) for n in VARIANTS if not a.only or n in a.only]
    rows += [(f, None) for f in ("fast", "orbslam") if not a.only or f in a.only]
    for n, cfg in rows:
        ates, kp = [], 0
        with tempfile.TemporaryDirectory() as tmp:
            conf = os.path.join(tmp, "c.toml")
            with open(conf, "w") as f:
                for k, v in (cfg or {}).items():
                    f.write(f"{k} = {json.dumps(v)}\n")
            for seed in SEEDS:
                args = [LFAST, "vo", "--seed", str(seed), "--out", os.path.join(tmp, str(seed)), seq]
                args += ["--config", conf] if cfg is not None else ["--features", n]
                out = subprocess.run(args, check=True, capture_output=True, text=True)
                text = out.stderr + out.stdout
                ates.append(float(re.search(r"ATE RMSE ([0-9.]+)", text).group(1)))
                kp = int(re.search(r"(\d+) keypoints", text).group(1))
        l0 = "–"
        if cfg is not None:
            res = lfast(frames, dict(cfg, n_levels=1))
            l0 = f"{np.mean([len(res[p][0]) for p in frames]):.0f}"
        se = np.std(ates, ddof=1) / np.sqrt(len(ates)) if len(ates) > 1 else float("nan")
        print(f"| {n} | {np.mean(ates):.3f} | {se:.3f} | {min(ates):.3f} | {max(ates):.3f} | {kp} | {l0} |")
        sys.stdout.flush()


def main():
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--data", default=str(data_dir() / "homography"))
    ap.add_argument("--budget", type=int, default=500)
    ap.add_argument("--top-n", action="store_true",
                    help="variants section: the top N of the uncapped output by response instead of n_features = N")
    ap.add_argument("--only", action="append", help="variants and vo sections: only these variants (repeatable)")
    ap.add_argument("--seeds", metavar="A-B", help="vo section: RANSAC seeds A..=B instead of the eval's twenty")
    ap.add_argument("--variant", action="append", default=[], metavar="NAME=JSON",
                    help="variants and vo sections: one more variant, config fields as JSON (repeatable; "
                         "nms_radius 3, snap_radius 0, reject_edges false unless given); "
                         "only the variants given this way run, with those of --only")
    ap.add_argument("sections", nargs="*", default=["levels", "localisation", "loss", "candidates", "swap", "snap"])
    a = ap.parse_args()
    if a.seeds:
        lo, _, hi = a.seeds.partition("-")
        SEEDS[:] = range(int(lo), int(hi or lo) + 1)
    for v in a.variant:
        name, _, js = v.partition("=")
        VARIANTS[name] = dict(SPELLED, **json.loads(js))
        a.only = (a.only or []) + [name]
    if not os.path.isfile(LFAST):
        sys.exit(f"{LFAST} is missing: run `cargo build --release` first")
    print(f"data {a.data}, budget {a.budget}, scenes {[s[0] for s in scenes(a.data)]}")
    for s in a.sections:
        globals()["section_" + s](a)
        sys.stdout.flush()


if __name__ == "__main__":
    main()
