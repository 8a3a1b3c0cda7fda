"""Recorded input and MCAP output against independent writers and readers:
ROS 2 bags written by ``mcap-ros2-support`` and ``rosbags``, foxglove.RawImage
by ``mcap-protobuf-support``, FFV1 video by Debian's ``ffmpeg``; the output
MCAP read back with Python's ``mcap`` reader and ``mcap-protobuf-support``.
The reference is ``lfast detect`` on the same frames as PNG files."""

from __future__ import annotations

import json
import os
import subprocess
from pathlib import Path

import cv2
import numpy as np
import pytest

import bags
import lfast
from conftest import IN_CI, KITTI, cli_arrays, kitti_frames

TOPIC = "/kitti/image"


def run(cli: Path, *args, check: bool = True) -> subprocess.CompletedProcess:
    p = subprocess.run([str(cli), *map(str, args)], capture_output=True, text=True)
    if check:
        assert p.returncode == 0, f"exit {p.returncode}\n{p.stdout}\n{p.stderr}"
    return p


@pytest.fixture(scope="module")
def frames() -> list[np.ndarray]:
    return [cv2.imread(str(p), cv2.IMREAD_GRAYSCALE) for p in kitti_frames(51)]


@pytest.fixture(scope="module")
def ref(cli: Path, tmp_path_factory: pytest.TempPathFactory, frames) -> list[tuple[np.ndarray, np.ndarray]]:
    """(keypoints, descriptors) of each KITTI frame from its PNG file."""
    out = tmp_path_factory.mktemp("png_ref")
    run(cli, "detect", KITTI, "--out", out, "--backend", "cpu", "--quiet")
    return [cli_arrays(json.loads((out / f"{i:06d}.json").read_text())) for i in range(len(frames))]


def outputs(out: Path, suffix: str = ".json") -> list[Path]:
    return sorted(p for p in out.iterdir() if p.name.endswith(suffix) and not p.name.startswith("."))


def assert_equal_to_ref(out_dir: Path, ref, indices) -> None:
    files = outputs(out_dir)
    assert [int(p.name.split("_")[0]) for p in files] == list(indices), [p.name for p in files]
    for p, i in zip(files, indices):
        k, d = cli_arrays(json.loads(p.read_text()))
        np.testing.assert_array_equal(k, ref[i][0], err_msg=p.name)
        np.testing.assert_array_equal(d, ref[i][1], err_msg=p.name)


def no_temporaries(root: Path) -> None:
    left = [p for p in root.rglob("*") if p.name.endswith(".tmp")]
    assert not left, left


def ros2_bag(path: Path, frames, kind: str, **kw) -> Path:
    if kind in ("mono8", "bgr8"):
        msgs = [(bags.log_time(i), bags.image_msg(g, kind, i, pad=5)) for i, g in enumerate(frames)]
        return bags.write_ros2(path, [(TOPIC, "sensor_msgs/msg/Image", msgs)], **kw)
    ext = {"png": ".png", "jpeg": ".jpg"}[kind]
    msgs = [(bags.log_time(i), bags.compressed_msg(cv2.imencode(ext, g)[1].tobytes(), kind, i)) for i, g in enumerate(frames)]
    return bags.write_ros2(path, [(TOPIC, "sensor_msgs/msg/CompressedImage", msgs)], **kw)


@pytest.mark.parametrize("kind", ["mono8", "bgr8", "png"])
def test_a_bag_gives_the_png_frames_keypoints_bit_for_bit(cli, tmp_path, frames, ref, kind):
    bag = ros2_bag(tmp_path / f"seq01_{kind}.mcap", frames, kind)
    out = tmp_path / "out"
    p = run(cli, "detect", bag, "--out", out, "--backend", "cpu", "--format", "json")
    assert "summary: done 51, skipped 0, failed 0 of 51 frames" in p.stdout, p.stdout
    assert_equal_to_ref(out / bag.stem, ref, range(51))
    # named by index and log time; the JSON says which frame it is
    first = json.loads((out / bag.stem / f"000000_{bags.log_time(0)}.json").read_text())
    assert first["image"] == str(bag)
    assert first["frame"] == {
        "topic": TOPIC, "index": 0, "time_ns": bags.log_time(0), "stamp_ns": bags.log_time(0) - bags.STAMP_LAG
    }


def test_jpeg_messages_equal_the_same_jpeg_bytes_as_files(cli, tmp_path, frames):
    bag = ros2_bag(tmp_path / "jpeg.mcap", frames[:8], "jpeg")
    files = tmp_path / "jpg"
    files.mkdir()
    for i, g in enumerate(frames[:8]):
        (files / f"{i:06d}.jpg").write_bytes(cv2.imencode(".jpg", g)[1].tobytes())
    run(cli, "detect", files, "--out", tmp_path / "from_files", "--backend", "cpu", "--quiet")
    run(cli, "detect", bag, "--out", tmp_path / "from_bag", "--backend", "cpu", "--quiet")
    want = [cli_arrays(json.loads((tmp_path / "from_files" / f"{i:06d}.json").read_text())) for i in range(8)]
    assert_equal_to_ref(tmp_path / "from_bag" / "jpeg", want, range(8))


def test_foxglove_raw_images_in_protobuf(cli, tmp_path, frames, ref):
    bag = bags.write_foxglove_raw(tmp_path / "fox.mcap", frames[:10])
    run(cli, "detect", bag, "--out", tmp_path / "out", "--backend", "cpu", "--quiet")
    assert_equal_to_ref(tmp_path / "out" / "fox", ref, range(10))


def test_a_rosbags_bag_and_its_camera_info_give_the_folders_trajectory(cli, tmp_path, frames, ref):
    seq = KITTI.parent
    p0 = [float(v) for v in (seq / "calib.txt").read_text().split("\n")[0].split()]
    k = [p0[0], 0.0, p0[2], 0.0, p0[5], p0[6], 0.0, 0.0, 1.0]
    mcap_file = bags.write_rosbags(tmp_path / "rosbag", frames, k)
    out = tmp_path / "out"
    run(cli, "detect", mcap_file, "--topic", "/camera/image_raw", "--out", out, "--backend", "cpu", "--quiet")
    assert_equal_to_ref(out / mcap_file.stem, ref, range(51))
    # vo: intrinsics from /camera/camera_info, ground truth from the poses file
    v = run(cli, "vo", mcap_file, "--poses", seq / "poses.txt", "--out", tmp_path / "vo_bag", "--backend", "cpu")
    assert "intrinsics from /camera/camera_info" in v.stdout, v.stdout
    run(cli, "vo", seq, "--out", tmp_path / "vo_dir", "--backend", "cpu", "--quiet")
    assert (tmp_path / "vo_bag" / "trajectory.txt").read_text() == (tmp_path / "vo_dir" / "trajectory.txt").read_text()
    # without a CameraInfo topic, --calib is needed and named
    noinfo = ros2_bag(tmp_path / "noinfo.mcap", frames[:3], "mono8")
    e = run(cli, "vo", noinfo, "--out", tmp_path / "vo_x", "--backend", "cpu", check=False)
    assert e.returncode == 2 and "--calib" in e.stderr, e.stderr


def read_mcap(path: Path):
    from mcap.reader import make_reader
    from mcap_protobuf.decoder import DecoderFactory

    with open(path, "rb") as f:
        r = make_reader(f, decoder_factories=[DecoderFactory()])
        summary = r.get_summary()
        msgs = [(ch.topic, sch.name, m.log_time, d) for sch, ch, m, d in r.iter_decoded_messages()]
    return summary, msgs


def test_format_mcap_is_read_back_by_the_mcap_and_protobuf_readers(cli, tmp_path, frames):
    bag = ros2_bag(tmp_path / "seq.mcap", frames[:5], "mono8")
    out = tmp_path / "out"
    run(cli, "detect", bag, "--out", out, "--backend", "cpu", "--format", "json,mcap", "--quiet")
    summary, msgs = read_mcap(out / "seq.lfast.mcap")
    schemas = {s.name: s.encoding for s in summary.schemas.values()}
    assert schemas == {"foxglove.ImageAnnotations": "protobuf", "lfast.Features": "protobuf"}
    topics = sorted(c.topic for c in summary.channels.values())
    assert topics == [f"{TOPIC}/lfast/features", f"{TOPIC}/lfast/keypoints"]
    assert summary.statistics.message_count == 10
    # the --draw palette (src/cli/draw.rs), by pyramid level
    palette = [
        (255, 64, 64), (64, 255, 64), (64, 160, 255), (255, 220, 0),
        (255, 0, 255), (0, 255, 255), (255, 140, 0), (200, 200, 255),
    ]
    for i in range(5):
        ann = [d for t, s, lt, d in msgs if t.endswith("keypoints") and lt == bags.log_time(i)]
        feat = [d for t, s, lt, d in msgs if t.endswith("features") and lt == bags.log_time(i)]
        assert len(ann) == 1 and len(feat) == 1
        j = json.loads((out / "seq" / f"{i:06d}_{bags.log_time(i)}.json").read_text())
        k, d = cli_arrays(j)
        # lfast.Features: the JSON's keypoints and descriptors as arrays
        f = feat[0]
        np.testing.assert_array_equal(np.frombuffer(f.keypoints, "<f4").reshape(-1, 7), k)
        np.testing.assert_array_equal(np.frombuffer(f.descriptors, np.uint8).reshape(-1, 32), d)
        assert (f.frame, f.width, f.height, f.time_ns) == (i, 1241, 376, bags.log_time(i))
        assert f.stamp_ns == bags.log_time(i) - bags.STAMP_LAG
        # foxglove.ImageAnnotations: a circle per keypoint at the pixel centre, stamped with the image
        a = ann[0]
        stamp = bags.log_time(i) - bags.STAMP_LAG
        assert (a.timestamp.seconds, a.timestamp.nanos) == divmod(stamp, 1_000_000_000)
        assert len(a.circles) == len(k)
        if i == 0:
            for c, kp in zip(a.circles, k):
                assert (c.position.x, c.position.y) == (float(kp[0]) + 0.5, float(kp[1]) + 0.5)
                assert c.diameter == pytest.approx(float(kp[2]), rel=1e-7)
                col = tuple(round(v * 255) for v in (c.outline_color.r, c.outline_color.g, c.outline_color.b))
                assert col == palette[int(kp[5])] and c.outline_color.a == 1 and c.fill_color.a == 0


def test_include_images_copies_the_topic(cli, tmp_path, frames):
    bag = ros2_bag(tmp_path / "seq.mcap", frames[:3], "mono8")
    out = tmp_path / "out"
    run(cli, "detect", bag, "--out", out, "--backend", "cpu", "--format", "mcap", "--include-images", "--quiet")
    from mcap.reader import make_reader

    with open(bag, "rb") as a, open(out / "seq.lfast.mcap", "rb") as b:
        src = [(m.log_time, m.data) for _, _, m in make_reader(a).iter_messages()]
        copied = [(m.log_time, m.data) for _, c, m in make_reader(b).iter_messages(topics=[TOPIC])]
    assert copied == src
    # --format mcap alone: no per-frame file
    assert not (out / "seq").exists()


def test_every_frames_and_time_ranges(cli, tmp_path, frames):
    bag = ros2_bag(tmp_path / "r.mcap", frames[:20], "mono8")

    def names(*opts):
        out = tmp_path / ("o" + "_".join(o.replace(".", "") for o in opts))
        run(cli, "detect", bag, "--out", out, "--backend", "cpu", "--quiet", *opts)
        return [int(p.name.split("_")[0]) for p in outputs(out / "r")]

    assert names("--every", "5") == [0, 5, 10, 15]
    assert names("--frames", "3..7") == [3, 4, 5, 6]
    assert names("--frames", "4") == [0, 1, 2, 3]
    assert names("--time", "0.5..1.15") == [5, 6, 7, 8, 9, 10, 11]
    assert names("--frames", "2..", "--every", "7") == [2, 9, 16]


def test_messages_out_of_order_in_the_file_come_in_log_time_order(cli, tmp_path, frames, ref):
    order = [3, 0, 4, 1, 5, 2]  # small chunks: their time ranges overlap
    msgs = [(bags.log_time(i), bags.image_msg(frames[i], "mono8", i)) for i in order]
    bag = bags.write_ros2(tmp_path / "shuffled.mcap", [(TOPIC, "sensor_msgs/msg/Image", msgs)], chunk_size=600_000)
    p = run(cli, "detect", bag, "--out", tmp_path / "out", "--backend", "cpu")
    lines = [l for l in p.stdout.splitlines() if ": frame " in l]
    assert [int(l.split(": frame ")[1].split()[0]) for l in lines] == list(range(6)), p.stdout
    assert_equal_to_ref(tmp_path / "out" / "shuffled", ref, range(6))


def test_topic_choice_and_unsupported_encodings_are_named(cli, tmp_path, frames):
    img = [(bags.log_time(i), bags.image_msg(g, "mono8", i)) for i, g in enumerate(frames[:2])]
    two = bags.write_ros2(
        tmp_path / "two.mcap",
        [("/left/image", "sensor_msgs/msg/Image", img), ("/right/image", "sensor_msgs/msg/Image", img[:1])],
    )
    e = run(cli, "detect", two, "--out", tmp_path / "o1", check=False)
    assert e.returncode == 1, e
    assert "/left/image (sensor_msgs/msg/Image, 2 messages)" in e.stderr, e.stderr
    assert "/right/image (sensor_msgs/msg/Image, 1 messages)" in e.stderr and "--topic" in e.stderr, e.stderr
    run(cli, "detect", two, "--topic", "/right/image", "--out", tmp_path / "o2", "--backend", "cpu", "--quiet")
    assert len(outputs(tmp_path / "o2" / "two")) == 1
    e = run(cli, "detect", two, "--topic", "/nope", "--out", tmp_path / "o3", check=False)
    assert e.returncode == 1 and "no topic `/nope`" in e.stderr, e.stderr
    bayer = dict(bags.image_msg(frames[0], "mono8", 0), encoding="bayer_rggb8")
    b = bags.write_ros2(tmp_path / "bayer.mcap", [("/cam", "sensor_msgs/msg/Image", [(1, bayer), (2, bayer)])])
    e = run(cli, "detect", b, "--out", tmp_path / "o4", "--backend", "cpu", check=False)
    assert e.returncode == 1 and "`bayer_rggb8`" in e.stderr, e.stderr
    assert len(e.stderr.strip().splitlines()) == 1, e.stderr


def damaged_bag(tmp_path: Path, frames, **kw) -> Path:
    return ros2_bag(tmp_path / "d.mcap", frames[:12], "mono8", **kw)


def test_a_truncated_bag_keeps_every_intact_frame_and_says_where_it_stopped(cli, tmp_path, frames, ref):
    bag = damaged_bag(tmp_path, frames)
    data = bag.read_bytes()
    cut = tmp_path / "cut.mcap"
    cut.write_bytes(data[: len(data) * 6 // 10])
    out = tmp_path / "out"
    p = run(cli, "detect", cut, "--out", out, "--backend", "cpu", "--format", "json,mcap", check=False)
    assert p.returncode == 1, p
    assert "reading stopped near byte" in p.stderr and "truncated" in p.stderr, p.stderr
    done = outputs(out / "cut")
    assert 0 < len(done) < 12
    assert_equal_to_ref(out / "cut", ref, range(len(done)))
    # the MCAP holds those frames and is whole (it has its summary)
    summary, msgs = read_mcap(out / "cut.lfast.mcap")
    assert summary.statistics.message_count == 2 * len(done)
    no_temporaries(out)


def test_a_chunk_with_a_bad_crc_stops_reading_there(cli, tmp_path, frames, ref):
    # uncompressed chunks of about two frames each
    bag = damaged_bag(tmp_path, frames, chunk_size=600_000, compression="none")
    from mcap.reader import make_reader

    with open(bag, "rb") as f:
        chunks = sorted(make_reader(f).get_summary().chunk_indexes, key=lambda c: c.message_start_time)
    bad = chunks[2]
    data = bytearray(bag.read_bytes())
    data[bad.chunk_start_offset + bad.chunk_length // 2] ^= 0x55
    broken = tmp_path / "crc.mcap"
    broken.write_bytes(bytes(data))
    out = tmp_path / "out"
    p = run(cli, "detect", broken, "--out", out, "--backend", "cpu", check=False)
    assert p.returncode == 1, p
    assert f"chunk at byte {bad.chunk_start_offset}" in p.stderr and "CRC" in p.stderr, p.stderr
    first_bad = (bad.message_start_time - bags.T0) // bags.DT
    assert_equal_to_ref(out / "crc", ref, range(first_bad))
    no_temporaries(out)


def test_a_message_cut_off_in_an_unchunked_file(cli, tmp_path, frames, ref):
    bag = damaged_bag(tmp_path, frames, use_chunking=False)
    data = bag.read_bytes()
    cut = tmp_path / "msgcut.mcap"
    # the cut falls inside the seventh image message
    frame_bytes = (len(data) - 2000) // 12
    cut.write_bytes(data[: 1000 + frame_bytes * 6 + frame_bytes // 2])
    p = run(cli, "detect", cut, "--out", tmp_path / "out", "--backend", "cpu", check=False)
    assert p.returncode == 1 and "ends inside a record" in p.stderr, p.stderr
    assert_equal_to_ref(tmp_path / "out" / "msgcut", ref, range(6))


def test_frames_yields_the_recording_as_numpy(tmp_path, frames):
    bag = ros2_bag(tmp_path / "py.mcap", frames[:6], "bgr8")
    got = list(lfast.frames(bag))
    assert [t for t, _ in got] == [bags.log_time(i) for i in range(6)]
    for (_, img), g in zip(got, frames):
        assert img.dtype == np.uint8 and img.shape == g.shape
        np.testing.assert_array_equal(img, g)
    folder = list(lfast.frames(KITTI))
    assert len(folder) == 51 and folder[0][0] is None
    np.testing.assert_array_equal(folder[3][1], frames[3])
    with pytest.raises(ValueError, match="image topic"):
        two = bags.write_ros2(
            tmp_path / "two.mcap",
            [(t, "sensor_msgs/msg/Image", [(1, bags.image_msg(frames[0], "mono8", 0))]) for t in ("/a", "/b")],
        )
        list(lfast.frames(two))
    assert len(list(lfast.frames(two, topic="/b"))) == 1
    # damage: the intact frames, then ValueError naming where reading stopped
    data = bag.read_bytes()
    (tmp_path / "cut.mcap").write_bytes(data[: len(data) // 2])
    seen = []
    with pytest.raises(ValueError, match="reading stopped"):
        for t, img in lfast.frames(tmp_path / "cut.mcap"):
            seen.append(img)
    assert 0 < len(seen) < 6
    det = lfast.Detector(backend="cpu")
    k1, d1 = det.detectAndCompute(seen[0])
    k2, d2 = det.detectAndCompute(frames[0])
    np.testing.assert_array_equal(d1, d2)


@pytest.fixture(scope="module")
def ffv1(tmp_path_factory: pytest.TempPathFactory, frames) -> Path:
    if bags.ffmpeg() is None:
        if IN_CI:
            pytest.fail("ffmpeg is missing; CI installs it (apt-get install ffmpeg)")
        pytest.skip("ffmpeg not installed")
    d = tmp_path_factory.mktemp("video")
    return bags.encode_video(KITTI, d / "seq01.mkv", ["-c:v", "ffv1", "-pix_fmt", "gray"])


def test_an_ffv1_video_gives_the_png_frames_keypoints(cli, tmp_path, ffv1, ref, frames):
    out = tmp_path / "out"
    p = run(cli, "detect", ffv1, "--out", out, "--backend", "cpu", "--format", "json,mcap", "--include-images")
    assert "done 51, skipped 0, failed 0 of 51 frames" in p.stdout, p.stdout
    assert_equal_to_ref(out / "seq01", ref, range(51))
    assert outputs(out / "seq01")[10].name == "000010_1000000000.json"
    got = list(lfast.frames(ffv1))
    assert [t for t, _ in got][:3] == [0, 100_000_000, 200_000_000]
    np.testing.assert_array_equal(got[50][1], frames[50])
    # --include-images: the frames as foxglove.RawImage on /video
    summary, msgs = read_mcap(out / "seq01.lfast.mcap")
    raw = [d for t, s, lt, d in msgs if t == "/video"]
    assert len(raw) == 51 and raw[7].encoding == "mono8"
    np.testing.assert_array_equal(np.frombuffer(raw[7].data, np.uint8).reshape(376, 1241), frames[7])


def test_a_truncated_video_keeps_every_intact_frame(cli, tmp_path, ffv1, ref):
    data = ffv1.read_bytes()
    cut = tmp_path / "cut.mkv"
    cut.write_bytes(data[: len(data) * 4 // 10])
    out = tmp_path / "out"
    p = run(cli, "detect", cut, "--out", out, "--backend", "cpu", "--format", "json,mcap", check=False)
    assert p.returncode == 1, p
    assert "reading stopped after frame" in p.stderr and "File ended prematurely" in p.stderr, p.stderr
    n = len(outputs(out / "cut"))
    assert 10 < n < 51
    assert_equal_to_ref(out / "cut", ref, range(n))
    summary, _ = read_mcap(out / "cut.lfast.mcap")
    assert summary.statistics.message_count == 2 * n
    no_temporaries(out)
    with pytest.raises(ValueError, match="File ended prematurely"):
        list(lfast.frames(cut))
