"""Small hostile and odd input images for the CLI tests, from the standard library alone.

    make_images.py nan-exr OUT.exr W H    an uncompressed float RGB EXR, every value NaN
    make_images.py png OUT.png W H        an 8-bit grey PNG, a ramp
    make_images.py png-claim OUT.png W H  a PNG whose header claims W x H pixels but whose
                                          data holds one row (a hostile size)
"""
import struct
import sys
import zlib


def nan_exr(path, w, h):
    def attr(name, typ, data):
        return name.encode() + b"\0" + typ.encode() + b"\0" + struct.pack("<i", len(data)) + data

    chlist = b"".join(c.encode() + b"\0" + struct.pack("<iBBBBii", 2, 0, 0, 0, 0, 1, 1)
                      for c in "BGR") + b"\0"
    box = struct.pack("<iiii", 0, 0, w - 1, h - 1)
    header = (attr("channels", "chlist", chlist) + attr("compression", "compression", b"\0") +
              attr("dataWindow", "box2i", box) + attr("displayWindow", "box2i", box) +
              attr("lineOrder", "lineOrder", b"\0") +
              attr("pixelAspectRatio", "float", struct.pack("<f", 1.0)) +
              attr("screenWindowCenter", "v2f", struct.pack("<ff", 0, 0)) +
              attr("screenWindowWidth", "float", struct.pack("<f", 1.0)) + b"\0")
    start = 8 + len(header) + 8 * h
    line = struct.pack("<f", float("nan")) * (3 * w)
    block = 8 + len(line)
    with open(path, "wb") as f:
        f.write(struct.pack("<ii", 20000630, 2) + header)
        for y in range(h):
            f.write(struct.pack("<q", start + y * block))
        for y in range(h):
            f.write(struct.pack("<ii", y, len(line)) + line)


def png_file(path, w, h, rows):
    """An 8-bit grey PNG whose header says w x h, holding `rows` rows of a ramp."""
    raw = b"".join(b"\0" + bytes((x * 255 // max(w - 1, 1)) % 256 for x in range(w))
                   for _ in range(rows))

    def chunk(tag, data):
        return (struct.pack(">I", len(data)) + tag + data +
                struct.pack(">I", zlib.crc32(tag + data) & 0xffffffff))

    with open(path, "wb") as f:
        f.write(b"\x89PNG\r\n\x1a\n" + chunk(b"IHDR", struct.pack(">IIBBBBB", w, h, 8, 0, 0, 0, 0)) +
                chunk(b"IDAT", zlib.compress(raw)) + chunk(b"IEND", b""))


def grey_png(path, w, h):
    png_file(path, w, h, h)


def png_claim(path, w, h):
    png_file(path, w, h, 1)


if __name__ == "__main__":
    kind, out, w, h = sys.argv[1], sys.argv[2], int(sys.argv[3]), int(sys.argv[4])
    {"nan-exr": nan_exr, "png": grey_png, "png-claim": png_claim}[kind](out, w, h)
