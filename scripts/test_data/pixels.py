"""PNG and PNM pixels with the standard library only, for scripts/fetch_test_data.sh.

The test-data manifest checks every PNG twice over: by its bytes (size, sha256) and
by its pixels. The pixel hash is

    sha256(b"%dx%dx%d\\n" % (width, height, channels) + samples)

where samples are the decoded 8-bit samples, row after row, channels interleaved as
the file stores them (gray 1, gray+alpha 2, RGB 3, RGBA 4). With numpy:
`hashlib.sha256(b"%dx%dx%d\\n" % (w, h, c) + array.tobytes())` on the array that
Pillow gives (cv2 gives BGR: convert first).

Files derived by re-encoding (the Oxford scenes come as PPM/PGM) cannot match the
bytes of a copy encoded by another program, only its pixels; a PNG whose bytes
differ from the manifest is therefore accepted when its pixels match.
"""

import hashlib
import struct
import zlib

PNG_SIGNATURE = b"\x89PNG\r\n\x1a\n"
CHANNELS = {0: 1, 4: 2, 2: 3, 6: 4}  # PNG colour type -> samples per pixel


class ImageError(ValueError):
    """A PNG or PNM this module does not read (damaged, or a variant it leaves out)."""


def pixel_hash(width, height, channels, samples):
    """The manifest's pixel hash (hex) of decoded 8-bit samples."""
    if len(samples) != width * height * channels:
        raise ImageError(f"{len(samples)} samples for {width}x{height}x{channels}")
    h = hashlib.sha256(b"%dx%dx%d\n" % (width, height, channels))
    h.update(samples)
    return h.hexdigest()


def is_png(data):
    return data[:8] == PNG_SIGNATURE


def _chunks(data):
    """(type, payload) of each chunk, checking every CRC."""
    if not is_png(data):
        raise ImageError("not a PNG (bad signature)")
    pos = 8
    while pos < len(data):
        if pos + 12 > len(data):
            raise ImageError(f"truncated chunk header at byte {pos}")
        (length,) = struct.unpack(">I", data[pos : pos + 4])
        kind = data[pos + 4 : pos + 8]
        end = pos + 8 + length
        if end + 4 > len(data):
            raise ImageError(f"chunk {kind!r} at byte {pos} runs past the end of the file")
        payload = data[pos + 8 : end]
        (crc,) = struct.unpack(">I", data[end : end + 4])
        if zlib.crc32(kind + payload) != crc:
            raise ImageError(f"chunk {kind!r} at byte {pos}: CRC mismatch")
        yield kind, payload
        if kind == b"IEND":
            return
        pos = end + 4
    raise ImageError("no IEND chunk")


def _paeth_row(line, prev, bpp):
    out = bytearray(line)
    for i in range(len(out)):
        a = out[i - bpp] if i >= bpp else 0
        b = prev[i]
        c = prev[i - bpp] if i >= bpp else 0
        p = a + b - c
        pa, pb, pc = abs(p - a), abs(p - b), abs(p - c)
        if pa <= pb and pa <= pc:
            pred = a
        elif pb <= pc:
            pred = b
        else:
            pred = c
        out[i] = (out[i] + pred) & 255
    return out


def _unfilter(raw, width, height, bpp):
    stride = width * bpp
    if len(raw) != height * (stride + 1):
        raise ImageError(f"image data holds {len(raw)} bytes, {height * (stride + 1)} expected")
    rows = []
    prev = bytes(stride)
    for y in range(height):
        start = y * (stride + 1)
        kind = raw[start]
        line = raw[start + 1 : start + 1 + stride]
        if kind == 0:
            out = bytes(line)
        elif kind == 1:  # Sub
            out = bytearray(line)
            for i in range(bpp, stride):
                out[i] = (out[i] + out[i - bpp]) & 255
        elif kind == 2:  # Up
            out = bytes([(x + p) & 255 for x, p in zip(line, prev)])
        elif kind == 3:  # Average
            out = bytearray(line)
            for i in range(stride):
                left = out[i - bpp] if i >= bpp else 0
                out[i] = (out[i] + ((left + prev[i]) >> 1)) & 255
        elif kind == 4:
            out = _paeth_row(line, prev, bpp)
        else:
            raise ImageError(f"row {y}: unknown filter type {kind}")
        rows.append(bytes(out))
        prev = out
    return b"".join(rows)


def decode_png(data):
    """(width, height, channels, samples) of an 8-bit, non-interlaced, non-palette PNG."""
    header = None
    idat = []
    for kind, payload in _chunks(data):
        if kind == b"IHDR":
            if len(payload) != 13:
                raise ImageError("IHDR is not 13 bytes")
            header = struct.unpack(">IIBBBBB", payload)
        elif kind == b"IDAT":
            idat.append(payload)
    if header is None:
        raise ImageError("no IHDR chunk")
    width, height, depth, colour, _, _, interlace = header
    if depth != 8 or colour not in CHANNELS or interlace != 0:
        raise ImageError(f"unsupported PNG: bit depth {depth}, colour type {colour}, interlace {interlace}")
    try:
        raw = zlib.decompress(b"".join(idat))
    except zlib.error as e:
        raise ImageError(f"image data does not inflate: {e}") from e
    channels = CHANNELS[colour]
    return width, height, channels, _unfilter(raw, width, height, channels)


def png_pixel_hash(data):
    return pixel_hash(*decode_png(data))


def encode_png(width, height, channels, samples):
    """A PNG of 8-bit samples: filter 0 on every row, zlib level 9, one IDAT.

    Plain on purpose: what is checked is the pixels, and this is easy to read back."""
    colour = {v: k for k, v in CHANNELS.items()}[channels]
    stride = width * channels
    if len(samples) != height * stride:
        raise ImageError(f"{len(samples)} samples for {width}x{height}x{channels}")
    raw = b"".join(b"\x00" + samples[y * stride : (y + 1) * stride] for y in range(height))

    def chunk(kind, payload):
        return struct.pack(">I", len(payload)) + kind + payload + struct.pack(">I", zlib.crc32(kind + payload))

    ihdr = struct.pack(">IIBBBBB", width, height, 8, colour, 0, 0, 0)
    return PNG_SIGNATURE + chunk(b"IHDR", ihdr) + chunk(b"IDAT", zlib.compress(raw, 9)) + chunk(b"IEND", b"")


def decode_pnm(data):
    """(width, height, channels, samples) of a binary PGM (P5) or PPM (P6), maxval <= 255."""
    magic = data[:2]
    if magic not in (b"P5", b"P6"):
        raise ImageError(f"not a binary PGM/PPM (starts with {data[:2]!r})")
    fields = []
    pos = 2
    while len(fields) < 3:
        while pos < len(data) and data[pos : pos + 1].isspace():
            pos += 1
        if data[pos : pos + 1] == b"#":
            while pos < len(data) and data[pos : pos + 1] not in (b"\n", b"\r"):
                pos += 1
            continue
        start = pos
        while pos < len(data) and data[pos : pos + 1].isdigit():
            pos += 1
        if start == pos:
            raise ImageError(f"bad PNM header at byte {pos}")
        fields.append(int(data[start:pos]))
    width, height, maxval = fields
    if not 0 < maxval <= 255:
        raise ImageError(f"PNM maxval {maxval}: only 8-bit samples are read")
    if not data[pos : pos + 1].isspace():
        raise ImageError("PNM header does not end in a whitespace byte")
    pos += 1
    channels = 1 if magic == b"P5" else 3
    size = width * height * channels
    samples = data[pos : pos + size]
    if len(samples) != size:
        raise ImageError(f"PNM holds {len(samples)} sample bytes, {size} expected")
    return width, height, channels, bytes(samples)
