"""MCAP files for the recording tests, written by independent writers:
Python's ``mcap`` + ``mcap-ros2-support`` (sensor_msgs in CDR), ``mcap`` +
``mcap-protobuf-support`` + ``foxglove-schemas-protobuf`` (foxglove.RawImage)
and ``rosbags`` (a ROS 2 bag in MCAP storage); and videos by Debian's
``ffmpeg``. Never by lfast's own MCAP writer.
"""

from __future__ import annotations

import shutil
import subprocess
from pathlib import Path
from typing import Iterable, Sequence

import numpy as np

TIME = """int32 sec
uint32 nanosec"""
HEADER = "builtin_interfaces/Time stamp\nstring frame_id"
SEP = "\n" + "=" * 80 + "\n"

IMAGE_MSGDEF = (
    "std_msgs/Header header\nuint32 height\nuint32 width\nstring encoding\nuint8 is_bigendian\nuint32 step\nuint8[] data"
    + SEP + "MSG: std_msgs/Header\n" + HEADER
    + SEP + "MSG: builtin_interfaces/Time\n" + TIME
)
COMPRESSED_MSGDEF = (
    "std_msgs/Header header\nstring format\nuint8[] data"
    + SEP + "MSG: std_msgs/Header\n" + HEADER
    + SEP + "MSG: builtin_interfaces/Time\n" + TIME
)
CAMERA_INFO_MSGDEF = (
    "std_msgs/Header header\nuint32 height\nuint32 width\nstring distortion_model\nfloat64[] d\nfloat64[9] k\n"
    "float64[9] r\nfloat64[12] p\nuint32 binning_x\nuint32 binning_y\nsensor_msgs/RegionOfInterest roi"
    + SEP + "MSG: std_msgs/Header\n" + HEADER
    + SEP + "MSG: builtin_interfaces/Time\n" + TIME
    + SEP + "MSG: sensor_msgs/RegionOfInterest\nuint32 x_offset\nuint32 y_offset\nuint32 height\nuint32 width\nbool do_rectify"
)

#: Log time of frame 0 and the spacing (10 Hz), ns; each image's header stamp is 1 ms earlier.
T0 = 1_317_067_241_000_000_000
DT = 100_000_000
STAMP_LAG = 1_000_000


def log_time(i: int) -> int:
    return T0 + i * DT


def stamp(i: int) -> dict:
    t = log_time(i) - STAMP_LAG
    return {"sec": t // 1_000_000_000, "nanosec": t % 1_000_000_000}


def image_msg(gray: np.ndarray, encoding: str, i: int, pad: int = 0) -> dict:
    """A sensor_msgs/msg/Image of the gray frame as mono8 or bgr8 (B = G = R),
    each row followed by ``pad`` bytes (so that ``step`` matters)."""
    h, w = gray.shape
    px = gray if encoding == "mono8" else np.repeat(gray[:, :, None], 3, axis=2).reshape(h, w * 3)
    if pad:
        px = np.concatenate([px, np.full((h, pad), 0xAB, np.uint8)], axis=1)
    return {
        "header": {"stamp": stamp(i), "frame_id": "cam0"},
        "height": h,
        "width": w,
        "encoding": encoding,
        "is_bigendian": 0,
        "step": px.shape[1],
        "data": np.ascontiguousarray(px).tobytes(),
    }


def compressed_msg(data: bytes, fmt: str, i: int) -> dict:
    return {"header": {"stamp": stamp(i), "frame_id": "cam0"}, "format": fmt, "data": data}


def write_ros2(
    path: Path,
    topics: Sequence[tuple[str, str, Iterable[tuple[int, dict]]]],
    chunk_size: int = 1024 * 1024,
    compression: str = "zstd",
    use_chunking: bool = True,
) -> Path:
    """An MCAP file (profile ros2) with, per (topic, datatype, messages), the
    messages as (log time, dict), serialised by mcap-ros2-support. Messages
    are written topic after topic."""
    from mcap.writer import CompressionType
    from mcap.writer import Writer
    from mcap_ros2._dynamic import serialize_dynamic

    defs = {
        "sensor_msgs/msg/Image": IMAGE_MSGDEF,
        "sensor_msgs/msg/CompressedImage": COMPRESSED_MSGDEF,
        "sensor_msgs/msg/CameraInfo": CAMERA_INFO_MSGDEF,
    }
    comp = {"zstd": CompressionType.ZSTD, "lz4": CompressionType.LZ4, "none": CompressionType.NONE}[compression]
    with open(path, "wb") as f:
        w = Writer(f, chunk_size=chunk_size, compression=comp, use_chunking=use_chunking)
        w.start(profile="ros2", library="lfast tests")
        schemas: dict = {}
        for topic, datatype, messages in topics:
            if datatype not in schemas:
                sid = w.register_schema(name=datatype, encoding="ros2msg", data=defs[datatype].encode())
                schemas[datatype] = (sid, serialize_dynamic(datatype, defs[datatype])[datatype])
            sid, encode = schemas[datatype]
            cid = w.register_channel(topic=topic, message_encoding="cdr", schema_id=sid)
            for seq, (t, m) in enumerate(messages):
                w.add_message(channel_id=cid, log_time=t, data=encode(m), publish_time=t, sequence=seq)
        w.finish()
    return path


def write_foxglove_raw(path: Path, frames: Sequence[np.ndarray], topic: str = "/camera/raw") -> Path:
    """foxglove.RawImage (protobuf) mono8 messages of the frames."""
    from foxglove_schemas_protobuf.RawImage_pb2 import RawImage
    from mcap_protobuf.writer import Writer

    with open(path, "wb") as f, Writer(f) as w:
        for i, g in enumerate(frames):
            m = RawImage()
            t = log_time(i) - STAMP_LAG
            m.timestamp.seconds, m.timestamp.nanos = t // 1_000_000_000, t % 1_000_000_000
            m.frame_id = "cam0"
            m.width, m.height, m.encoding, m.step = g.shape[1], g.shape[0], "mono8", g.shape[1]
            m.data = g.tobytes()
            w.write_message(topic, m, log_time=log_time(i), publish_time=log_time(i))
    return path


def write_rosbags(bag_dir: Path, frames: Sequence[np.ndarray], k: Sequence[float]) -> Path:
    """A ROS 2 bag (rosbags, MCAP storage) with /camera/image_raw (mono8) and
    /camera/camera_info (K = k); returns the .mcap file in it."""
    from rosbags.rosbag2 import StoragePlugin, Writer
    from rosbags.typesys import Stores, get_typestore

    ts = get_typestore(Stores.ROS2_HUMBLE)
    Image = ts.types["sensor_msgs/msg/Image"]
    CameraInfo = ts.types["sensor_msgs/msg/CameraInfo"]
    Header = ts.types["std_msgs/msg/Header"]
    Time = ts.types["builtin_interfaces/msg/Time"]
    RegionOfInterest = ts.types["sensor_msgs/msg/RegionOfInterest"]
    with Writer(bag_dir, version=8, storage_plugin=StoragePlugin.MCAP) as w:
        img_c = w.add_connection("/camera/image_raw", Image.__msgtype__, typestore=ts)
        info_c = w.add_connection("/camera/camera_info", CameraInfo.__msgtype__, typestore=ts)
        p = [k[0], 0.0, k[2], 0.0, 0.0, k[4], k[5], 0.0, 0.0, 0.0, 1.0, 0.0]
        for i, g in enumerate(frames):
            s = stamp(i)
            hdr = Header(stamp=Time(sec=s["sec"], nanosec=s["nanosec"]), frame_id="cam0")
            info = CameraInfo(
                header=hdr, height=g.shape[0], width=g.shape[1], distortion_model="plumb_bob",
                d=np.zeros(5), k=np.array(k, dtype=np.float64), r=np.eye(3).reshape(9), p=np.array(p),
                binning_x=0, binning_y=0,
                roi=RegionOfInterest(x_offset=0, y_offset=0, height=0, width=0, do_rectify=False),
            )
            w.write(info_c, log_time(i), ts.serialize_cdr(info, CameraInfo.__msgtype__))
            img = Image(header=hdr, height=g.shape[0], width=g.shape[1], encoding="mono8", is_bigendian=0,
                        step=g.shape[1], data=np.ascontiguousarray(g).reshape(-1))
            w.write(img_c, log_time(i), ts.serialize_cdr(img, Image.__msgtype__))
    found = sorted(bag_dir.glob("*.mcap"))
    assert len(found) == 1, found
    return found[0]


def ffmpeg() -> str | None:
    return shutil.which("ffmpeg")


def encode_video(frames_dir: Path, out: Path, codec_args: Sequence[str]) -> Path:
    """ffmpeg encodes frames_dir/%06d.png at 10 frames/s."""
    subprocess.run(
        ["ffmpeg", "-nostdin", "-v", "error", "-y", "-framerate", "10", "-i", str(frames_dir / "%06d.png"),
         *codec_args, str(out)],
        check=True,
    )
    return out
