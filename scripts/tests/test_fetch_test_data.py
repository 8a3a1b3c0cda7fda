"""Tests of scripts/fetch_test_data.sh (run by .ci/run: python3 -m pytest scripts/tests).

The download path runs against a local HTTP server on 127.0.0.1 that serves small
files laid out as their origins lay them out: single files under a pinned commit
(as raw.githubusercontent.com), two zips read with Range requests (as KITTI's S3
archives), a .tar.gz of PPM/PGM images (as the Oxford scenes), and one file whose
bytes do not match the manifest. A temporary manifest and sources file describe
them; every origin URL names a host under .invalid, which --mirror replaces with the
local server, so nothing leaves the machine. The images come from tests/data.
"""

import hashlib
import io
import os
import pathlib
import subprocess
import sys
import tarfile
import zipfile

import pytest
from http_origin import Origin

REPO = pathlib.Path(__file__).resolve().parents[2]
SCRIPT = REPO / "scripts" / "fetch_test_data.sh"
sys.path.insert(0, str(REPO / "scripts" / "test_data"))
sys.path.insert(0, str(REPO / "scripts"))
import catalog  # noqa: E402
import pixels  # noqa: E402
from lfast_data import data_dir, in_ci, note_skip  # noqa: E402

DATA = REPO / "tests" / "data"
COMMIT = "0123456789abcdef0123456789abcdef01234567"

# An official-format KITTI calib.txt (labels, P0-P3, Tr) and what the data folder keeps.
CALIB = (
    "P0: 7.188560000000e+02 0.000000000000e+00 6.071928000000e+02 0.000000000000e+00 0.000000000000e+00 "
    "7.188560000000e+02 1.852157000000e+02 0.000000000000e+00 0.000000000000e+00 0.000000000000e+00 "
    "1.000000000000e+00 0.000000000000e+00\n"
    "P1: 7.188560000000e+02 0.000000000000e+00 6.071928000000e+02 -3.861448000000e+02 0.000000000000e+00 "
    "7.188560000000e+02 1.852157000000e+02 0.000000000000e+00 0.000000000000e+00 0.000000000000e+00 "
    "1.000000000000e+00 0.000000000000e+00\n"
    "P2: 1 2 3 4 5 6 7 8 9 10 11 12\nP3: 1 2 3 4 5 6 7 8 9 10 11 12\nTr: 1 2 3 4 5 6 7 8 9 10 11 12\n"
)
CALIB_P0P1 = " ".join(CALIB.splitlines()[0].split()[1:]) + "\n" + " ".join(CALIB.splitlines()[1].split()[1:])
POSES = "".join(f"1.000000e+00 0 0 {i}.0 0 1.000000e+00 0 0 0 0 1.000000e+00 {2 * i}.5\n" for i in range(5))


def png_to_pnm(png):
    w, h, c, samples = pixels.decode_png(png)
    return b"P%d\n%d %d\n255\n" % (5 if c == 1 else 6, w, h) + samples


def row(path, data, dataset, pixel_source=None):
    pix = pixels.png_pixel_hash(pixel_source or data) if pixels.is_png(pixel_source or data) else "-"
    return catalog.Row(path, len(data), hashlib.sha256(data).hexdigest(), pix, dataset)


@pytest.fixture
def setup(tmp_path):
    """Origins under tmp/www, a manifest and sources under tmp/, the data folder tmp/out."""
    www = tmp_path / "www"
    coins, text = (DATA / "coins.png").read_bytes(), (DATA / "text.png").read_bytes()
    chess, camera = (DATA / "chessboard_GRAY.png").read_bytes(), (DATA / "camera_cc0_v0.18plus.png").read_bytes()
    astronaut = (DATA / "astronaut_256.png").read_bytes()

    gh = www / "gh" / COMMIT / "data"
    gh.mkdir(parents=True)
    (gh / "coins.png").write_bytes(coins)
    bad = bytearray(text)
    bad[len(bad) // 2] ^= 0xFF  # one byte changed: must be refused
    (gh / "text.png").write_bytes(bytes(bad))

    # A zip bigger than four 4 MiB range blocks, the needed members first, then padding:
    # reading them must not transfer the whole archive. One member is ZIP64.
    bucket = www / "bucket"
    bucket.mkdir()
    with zipfile.ZipFile(bucket / "gray.zip", "w", zipfile.ZIP_STORED) as z:
        z.writestr("dataset/sequences/00/image_0/000000.png", chess)
        with z.open("dataset/sequences/00/image_0/000001.png", "w", force_zip64=True) as f:
            f.write(camera)
        z.writestr("dataset/sequences/00/calib.txt", CALIB)
        z.writestr("dataset/sequences/00/times.txt", "".join(f"{i / 10:e}\n" for i in range(9)))
        z.writestr("dataset/sequences/99/padding.bin", bytes(20 << 20))
    with zipfile.ZipFile(bucket / "poses.zip", "w", zipfile.ZIP_DEFLATED) as z:
        z.writestr("dataset/poses/00.txt", POSES)

    # The Oxford layout: PPM (RGB) and PGM (gray) images in a .tar.gz, in a folder.
    scene = io.BytesIO()
    with tarfile.open(fileobj=scene, mode="w:gz") as t:
        for name, data in (
            ("scene/img1.ppm", png_to_pnm(astronaut)),
            ("scene/img2.pgm", png_to_pnm(coins)),
            ("scene/H1to2p", b"   1.0   0.0   2.0\n   0.0   1.0   3.0\n   0.0   0.0   1.0\n"),
        ):
            info = tarfile.TarInfo(name)
            info.size = len(data)
            t.addfile(info, io.BytesIO(data))
    (www / "vgg").mkdir()
    (www / "vgg" / "scene.tar.gz").write_bytes(scene.getvalue())

    rows = [
        row("standard/cc0/coins.png", coins, "cc0"),
        row("standard/cc0/text.png", text, "cc0"),
        row("kitti/seq00/image_0/000000.png", chess, "kitti"),
        row("kitti/seq00/image_0/000001.png", camera, "kitti"),
        row("kitti/seq00/calib.txt", CALIB_P0P1.encode(), "kitti"),
        row("kitti/seq00/times.txt", b"0.000000e+00\n1.000000e-01\n2.000000e-01\n", "kitti"),
        row("kitti/seq00/poses.txt", "".join(POSES.splitlines(keepends=True)[:3]).encode(), "kitti"),
        # the copies the manifest was written from were encoded by another program
        row("homography/scene/img1.png", astronaut, "oxford"),
        row("homography/scene/img2.png", coins, "oxford"),
        row("homography/scene/H1to2p", b"   1.0   0.0   2.0\n   0.0   1.0   3.0\n   0.0   0.0   1.0\n", "oxford"),
        row("orb.png", chess, "repo"),
    ]
    catalog.write_manifest(tmp_path / "manifest.tsv", rows, ["test manifest"])
    (tmp_path / "sources.ini").write_text(
        f"""
[cc0]
get.gh = files https://raw.example.invalid/gh/{COMMIT}/data/
files =
    standard/cc0/coins.png  gh:coins.png
    standard/cc0/text.png   gh:text.png
[kitti]
get.gray = zip https://s3.example.invalid/bucket/gray.zip
get.poses = zip https://s3.example.invalid/bucket/poses.zip
files =
    kitti/seq00/image_0/  gray:dataset/sequences/00/image_0/
    kitti/seq00/calib.txt gray:dataset/sequences/00/calib.txt kitti-calib-p0p1
    kitti/seq00/times.txt gray:dataset/sequences/00/times.txt head=3
    kitti/seq00/poses.txt poses:dataset/poses/00.txt head=3
[oxford]
get.scene = tar https://www.example.invalid/vgg/scene.tar.gz
files =
    homography/scene/H    scene:H
    homography/scene/img  scene:img pnm-png
[repo]
get.repo = repo tests/data
files =
    orb.png  repo:chessboard_GRAY.png
"""
    )
    return tmp_path, www, rows


def run(tmp, *args, mirror=None):
    cmd = ["bash", str(SCRIPT), *args, "--manifest", str(tmp / "manifest.tsv"), "--sources", str(tmp / "sources.ini")]
    if mirror:
        cmd += ["--mirror", mirror]
    env = {k: v for k, v in os.environ.items() if k != "LFAST_DATA_MIRROR"}
    p = subprocess.run(cmd, stdout=subprocess.PIPE, stderr=subprocess.STDOUT, text=True, env=env, timeout=120)
    return p.returncode, p.stdout


def test_download_verifies_refuses_and_resumes(setup):
    tmp, www, rows = setup
    out = tmp / "out"
    with Origin(www) as origin:
        rc, log = run(tmp, str(out), mirror=origin.url)
        assert rc == 1, log
        text = next(r for r in rows if r.path == "standard/cc0/text.png")
        bad_sha = hashlib.sha256((www / "gh" / COMMIT / "data" / "text.png").read_bytes()).hexdigest()
        refused = [line for line in log.splitlines() if line.startswith("REFUSED")]
        assert len(refused) == 1, log
        assert "standard/cc0/text.png" in refused[0] and text.sha256 in refused[0] and bad_sha in refused[0]
        assert not (out / "standard/cc0/text.png").exists()
        assert not (out / ".fetch-tmp").exists()
        assert f"export LFAST_TEST_DATA={out.resolve()}" in log.splitlines()[-1]
        # every other file landed with the bytes the manifest names, or its pixels
        for r in rows:
            if r.path != text.path:
                data = (out / r.path).read_bytes()
                assert r.path.startswith("homography/scene/img") or hashlib.sha256(data).hexdigest() == r.sha256
                if r.pixels != "-":
                    assert pixels.png_pixel_hash(data) == r.pixels
        assert (out / "kitti/seq00/calib.txt").read_text() == CALIB_P0P1
        # the zip was read in pieces, never whole
        zip_size = (www / "bucket" / "gray.zip").stat().st_size
        gets = [e for e in origin.log if e[1] == "/bucket/gray.zip"]
        assert gets and all(spec and spec.startswith("bytes=") for _, _, spec, _ in gets)
        assert origin.sent("/bucket/gray.zip") < zip_size / 2

        rc, check = run(tmp, "--check", str(out))
        assert rc == 1 and "MISSING standard/cc0/text.png" in check and "10 ok, 1 missing, 0 wrong" in check, check

        # a rerun asks only for what is still missing
        origin.log.clear()
        rc, log = run(tmp, str(out), mirror=origin.url)
        assert rc == 1, log
        assert origin.paths() == [f"/gh/{COMMIT}/data/text.png"], origin.log
        assert "10 files were already there" in log

        # the origin fixed: the last file lands, nothing else is fetched again
        (www / "gh" / COMMIT / "data" / "text.png").write_bytes((DATA / "text.png").read_bytes())
        origin.log.clear()
        rc, log = run(tmp, str(out), mirror=origin.url)
        assert rc == 0, log
        assert origin.paths() == [f"/gh/{COMMIT}/data/text.png"]
        rc, check = run(tmp, "--check", str(out))
        assert rc == 0 and "11 ok, 0 missing, 0 wrong" in check, check

        # a file damaged in the data folder is removed and fetched again
        (out / "kitti/seq00/calib.txt").write_text(CALIB)
        rc, log = run(tmp, str(out), mirror=origin.url)
        assert rc == 0 and "removed kitti/seq00/calib.txt: it does not match the manifest" in log, log
        assert (out / "kitti/seq00/calib.txt").read_text() == CALIB_P0P1


def test_only_selects_datasets(setup):
    tmp, www, _ = setup
    out = tmp / "out"
    with Origin(www) as origin:
        rc, log = run(tmp, str(out), "--only", "oxford,repo", mirror=origin.url)
        assert rc == 0, log
        assert {p for p in origin.paths()} == {"/vgg/scene.tar.gz"}
    assert sorted(p.relative_to(out).as_posix() for p in out.rglob("*") if p.is_file()) == [
        "homography/scene/H1to2p",
        "homography/scene/img1.png",
        "homography/scene/img2.png",
        "orb.png",
    ]
    rc, log = run(tmp, str(out), "--only", "nope")
    assert rc == 2 and "no dataset 'nope'" in log


def test_server_without_range_support_is_not_read_whole(setup):
    tmp, www, _ = setup
    out = tmp / "out"
    with Origin(www) as origin:
        rc, log = run(tmp, str(out), "--only", "kitti", mirror=origin.url + "/no-range")
    assert rc == 1
    assert "ignored the Range request" in log and "--archives DIR" in log, log
    assert not (out / "kitti").exists()


def test_damaged_archive_fails_cleanly(setup):
    tmp, www, _ = setup
    tgz = www / "vgg" / "scene.tar.gz"
    tgz.write_bytes(tgz.read_bytes()[: tgz.stat().st_size // 2])
    out = tmp / "out"
    with Origin(www) as origin:
        rc, log = run(tmp, str(out), "--only", "oxford", mirror=origin.url)
        assert origin.paths() == ["/vgg/scene.tar.gz"]  # tried once, not once a file
    assert rc == 1 and "Traceback" not in log, log
    assert [line.split(":")[0] for line in log.splitlines() if line.startswith("FAILED")] == [
        "FAILED homography/scene/H1to2p",
        "FAILED homography/scene/img1.png",
        "FAILED homography/scene/img2.png",
    ]
    assert not (out / "homography").exists()


def test_archives_folder_replaces_the_network(setup):
    tmp, www, rows = setup
    out = tmp / "out"
    archives = tmp / "archives"
    archives.mkdir()
    for name in ("gray.zip", "poses.zip"):
        (archives / name).write_bytes((www / "bucket" / name).read_bytes())
    rc, log = run(tmp, str(out), "--only", "kitti", "--archives", str(archives), mirror="http://127.0.0.1:9")
    assert rc == 0, log
    assert len([r for r in rows if r.dataset == "kitti"]) == len(list((out / "kitti").rglob("*.*")))


def test_check_names_wrong_and_missing_files(setup):
    tmp, _, rows = setup
    out = tmp / "out"
    for r in rows:
        if r.path == "kitti/seq00/calib.txt":
            (out / r.path).parent.mkdir(parents=True)
            (out / r.path).write_text(CALIB)  # the official file, not the derived one
    rc, log = run(tmp, "--check", str(out))
    assert rc == 1
    assert "WRONG kitti/seq00/calib.txt: expected 456 bytes" in log, log
    assert "MISSING standard/cc0/coins.png" in log
    assert "0 ok, 10 missing, 1 wrong" in log


def test_transforms_on_literal_inputs():
    assert catalog.apply_text_transform("kitti-calib-p0p1", CALIB.encode()).decode() == CALIB_P0P1
    assert len(CALIB_P0P1) == 456 and not CALIB_P0P1.endswith("\n")
    assert catalog.apply_text_transform("head=2", b"a\nb\nc\n") == b"a\nb\n"
    with pytest.raises(catalog.CatalogError):
        catalog.apply_text_transform("head=4", b"a\nb\nc\n")
    with pytest.raises(catalog.CatalogError):
        catalog.apply_text_transform("kitti-calib-p0p1", b"P0: 1 2 3\n")


def test_png_filters_on_a_literal_image():
    # 3x5 gray, one row per filter type (None, Sub, Up, Average, Paeth), answers by hand:
    # Sub:   10, 10+5, 15+250 = 10, 15, 9 (mod 256)
    # Up:    10+1, 15+1, 9+1 = 11, 16, 10
    # Avg:   0+(0+11)//2=5 -> 2+5=7; 1+(7+16)//2=12; 3+(12+10)//2=14 -> 7, 12, 14
    # Paeth: a=0,b=7,c=0 -> b: 7+1=8; a=8,b=12,c=7 -> p=13 -> b(12): 12+0=12; a=12,b=14,c=12
    #        -> p=14 -> b(14): 14+2=16 -> 8, 12, 16
    raw = bytes([0, 1, 2, 3, 1, 10, 5, 250, 2, 1, 1, 1, 3, 2, 1, 3, 4, 1, 0, 2])
    import struct
    import zlib

    def chunk(kind, payload):
        return struct.pack(">I", len(payload)) + kind + payload + struct.pack(">I", zlib.crc32(kind + payload))

    png = (
        pixels.PNG_SIGNATURE
        + chunk(b"IHDR", struct.pack(">IIBBBBB", 3, 5, 8, 0, 0, 0, 0))
        + chunk(b"IDAT", zlib.compress(raw))
        + chunk(b"IEND", b"")
    )
    w, h, c, samples = pixels.decode_png(png)
    assert (w, h, c) == (3, 5, 1)
    assert list(samples) == [1, 2, 3, 10, 15, 9, 11, 16, 10, 7, 12, 14, 8, 12, 16]
    assert pixels.decode_png(pixels.encode_png(w, h, c, samples))[3] == samples
    assert pixels.pixel_hash(w, h, c, samples) == hashlib.sha256(b"3x5x1\n" + samples).hexdigest()
    damaged = bytearray(png)
    damaged[-20] ^= 1
    with pytest.raises(pixels.ImageError):
        pixels.decode_png(bytes(damaged))


def test_pnm_reader():
    assert pixels.decode_pnm(b"P5\n# a comment\n2 1\n255\n\x00\xff") == (2, 1, 1, b"\x00\xff")
    assert pixels.decode_pnm(b"P6 1 1 255 abc") == (1, 1, 3, b"abc")
    for bad in (b"P2\n1 1\n255\n0", b"P5\n2 2\n255\n\x00", b"P5\n1 1\n65535\n\x00\x00"):
        with pytest.raises(pixels.ImageError):
            pixels.decode_pnm(bad)


def test_committed_manifest_and_sources_agree():
    datasets = catalog.read_sources(REPO / "scripts" / "test_data" / "sources.ini")
    rows = catalog.read_manifest(REPO / "scripts" / "test_data" / "manifest.tsv")
    assert {r.dataset for r in rows} == set(datasets)
    for r in rows:
        assert catalog.dataset_of(datasets, r.path) == r.dataset, r.path
        rule = datasets[r.dataset].rule_for(r.path)
        assert rule.source or r.dataset == "standard", r.path
        assert (r.pixels != "-") == r.path.endswith(".png"), r.path
    orb = next(r for r in rows if r.path == "orb_bit_pattern_31.txt")
    data = (REPO / "data" / "orb_bit_pattern_31.txt").read_bytes()
    assert (len(data), hashlib.sha256(data).hexdigest()) == (orb.size, orb.sha256)


def test_manifest_matches_the_shared_data():
    data = data_dir()
    if not data.is_dir():
        if in_ci():
            pytest.fail(f"{data} is missing; CI must provide it")
        note_skip("pytest scripts/tests manifest check", data)
        pytest.skip(f"{data} is absent (set LFAST_TEST_DATA or fetch it with scripts/fetch_test_data.sh)")
    p = subprocess.run(["bash", str(SCRIPT), "--check", str(data)], capture_output=True, text=True, timeout=300)
    assert p.returncode == 0, p.stdout + p.stderr
