#!/usr/bin/env python3
"""Writes the per-format malformed-file corpus read by tests/integration/malformed_corpus.rs.

Run from the repository root: `python3 tools/make_malformed_corpus.py`. Deterministic (fixed
seeds, no timestamps): rerunning it rewrites the same bytes. For each format a tiny valid
seed is broken in about 35 ways: empty, garbage, wrong magic, truncations at several
offsets, byte flips, inserted bytes, NaN/Inf/huge numbers, wrong counts and deleted lines.
Each folder's MANIFEST.txt says, per file, what the reader must give: `ok`, `err`, or
`any` (no panic is all that is asked: a flipped digit may still be a valid file).
"""
import os
import random
import re
import shutil
import struct
import zlib

ROOT = os.path.join(os.path.dirname(os.path.abspath(__file__)), "..", "tests", "fixtures",
                    "malformed")


# ---- tiny valid seeds -----------------------------------------------------------------

def pcd(data, body):
    head = ("# .PCD v0.7 - Point Cloud Data file format\nVERSION 0.7\nFIELDS x y z rgb\n"
            "SIZE 4 4 4 4\nTYPE F F F U\nCOUNT 1 1 1 1\nWIDTH 3\nHEIGHT 1\n"
            f"VIEWPOINT 0 0 0 1 0 0 0\nPOINTS 3\nDATA {data}\n")
    return head.encode() + body


POINTS = [(0.1, 0.2, 0.3, 0xFF102030), (1.5, -2.0, 0.25, 0xFF405060), (0.0, 0.5, 1.0, 0xFFFFFFFF)]


def pcd_ascii():
    rows = "".join(f"{x} {y} {z} {c}\n" for x, y, z, c in POINTS)
    return pcd("ascii", rows.encode())


def pcd_binary():
    return pcd("binary", b"".join(struct.pack("<fffI", *p) for p in POINTS))


def pcd_compressed():
    # Columns (SoA), then an LZF stream of literal runs only (valid LZF).
    cols = b"".join(struct.pack("<3f", *[p[k] for p in POINTS]) for k in range(3))
    cols += struct.pack("<3I", *[p[3] for p in POINTS])
    stream = b""
    for k in range(0, len(cols), 32):
        chunk = cols[k:k + 32]
        stream += bytes([len(chunk) - 1]) + chunk
    return pcd("binary_compressed", struct.pack("<II", len(stream), len(cols)) + stream)


def ply(fmt, body):
    return (f"ply\nformat {fmt} 1.0\ncomment seed\nelement vertex 3\nproperty float x\n"
            "property float y\nproperty float z\nproperty uchar red\nproperty uchar green\n"
            "property uchar blue\nelement face 1\nproperty list uchar int vertex_indices\n"
            "end_header\n").encode() + body


def ply_ascii():
    rows = "".join(f"{x} {y} {z} 10 20 30\n" for x, y, z, _ in POINTS) + "3 0 1 2\n"
    return ply("ascii", rows.encode())


def ply_binary():
    body = b"".join(struct.pack("<fffBBB", x, y, z, 10, 20, 30) for x, y, z, _ in POINTS)
    return ply("binary_little_endian", body + struct.pack("<Biii", 3, 0, 1, 2))


def xyz():
    return b"# seed\n0.1 0.2 0.3\n1.5,-2.0,0.25\n0 0.5 1 7\n"


def png(width, height, bit_depth, color_type, rows):
    def chunk(kind, data):
        return (struct.pack(">I", len(data)) + kind + data
                + struct.pack(">I", zlib.crc32(kind + data) & 0xFFFFFFFF))
    raw = b"".join(b"\x00" + r for r in rows)
    ihdr = struct.pack(">IIBBBBB", width, height, bit_depth, color_type, 0, 0, 0)
    return (b"\x89PNG\r\n\x1a\n" + chunk(b"IHDR", ihdr) + chunk(b"IDAT", zlib.compress(raw, 9))
            + chunk(b"IEND", b""))


def depth_png():
    rows = [b"".join(struct.pack(">H", 500 + 10 * (r * 4 + c)) for c in range(4)) for r in range(3)]
    return png(4, 3, 16, 0, rows)


def color_png():
    rows = [bytes([(r * 40 + c * 10 + k * 70) % 256 for c in range(4) for k in range(3)])
            for r in range(3)]
    return png(4, 3, 8, 2, rows)


def depth_tiff():
    # Baseline little-endian TIFF: 4x3, 16-bit grey, one uncompressed strip.
    w, h = 4, 3
    pixels = b"".join(struct.pack("<H", 500 + 10 * i) for i in range(w * h))
    entries = [(256, 3, 1, w), (257, 3, 1, h), (258, 3, 1, 16), (259, 3, 1, 1), (262, 3, 1, 1),
               (273, 4, 1, 0), (277, 3, 1, 1), (278, 3, 1, h), (279, 4, 1, len(pixels))]
    ifd_at = 8
    data_at = ifd_at + 2 + 12 * len(entries) + 4
    ifd = struct.pack("<H", len(entries))
    for tag, ty, n, v in entries:
        v = data_at if tag == 273 else v
        val = struct.pack("<HH", v, 0) if ty == 3 else struct.pack("<I", v)
        ifd += struct.pack("<HHI", tag, ty, n) + val
    return b"II*\x00" + struct.pack("<I", ifd_at) + ifd + struct.pack("<I", 0) + pixels


def intrinsics_json():
    return (b'{"width": 640, "height": 480, "intrinsic_matrix": '
            b'[525.0, 0, 0, 0, 525.0, 0, 319.5, 239.5, 1]}\n')


def intrinsics_xml():
    return (b'<?xml version="1.0"?>\n<!-- PCL image grabber -->\n<intrinsics>\n<depth>\n'
            b"<focal_length_x>525</focal_length_x>\n<focal_length_y>525</focal_length_y>\n"
            b"<principal_point_x>319.5</principal_point_x>\n"
            b"<principal_point_y>239.5</principal_point_y>\n"
            b"<z_multiplication_factor>0.001</z_multiplication_factor>\n</depth>\n"
            b"</intrinsics>\n")


def scene_toml():
    return (b'model = "model.toml"\nseed = 3\n\n[camera]\nwidth = 64\nheight = 48\nfx = 60.0\n'
            b"fy = 60.0\ncx = 31.5\ncy = 23.5\neye = [0.0, -0.4, 0.3]\ntarget = [0.0, 0.0, 0.06]\n"
            b"up = [0.0, 0.0, 1.0]\n\n[sensor]\nenabled = true\ndepth_k = 0.002\n\n"
            b'[[frames]]\n[[frames.loads]]\nkind = "probe"\nat = [0.05, -0.01, 0.1]\n'
            b"force = [-0.1, 0.4, -0.2]\n")


TET_NODES = [(0, 0, 0), (1, 0, 0), (0, 1, 0), (0, 0, 1), (1, 1, 1)]
TETS = [(0, 1, 2, 3), (1, 2, 3, 4)]


def vtk():
    pts = "".join(f"{x} {y} {z}\n" for x, y, z in TET_NODES)
    cells = "".join(f"4 {a} {b} {c} {d}\n" for a, b, c, d in TETS)
    return (f"# vtk DataFile Version 3.0\nseed\nASCII\nDATASET UNSTRUCTURED_GRID\n"
            f"POINTS {len(TET_NODES)} double\n{pts}CELLS {len(TETS)} {5 * len(TETS)}\n{cells}"
            f"CELL_TYPES {len(TETS)}\n10\n10\n").encode()


def vtu():
    pts = " ".join(f"{x} {y} {z}" for x, y, z in TET_NODES)
    conn = " ".join(str(i) for t in TETS for i in t)
    return (f'<?xml version="1.0"?>\n<VTKFile type="UnstructuredGrid" version="0.1">\n'
            f'<UnstructuredGrid>\n<Piece NumberOfPoints="{len(TET_NODES)}" '
            f'NumberOfCells="{len(TETS)}">\n<Points>\n<DataArray type="Float64" '
            f'NumberOfComponents="3" format="ascii">{pts}</DataArray>\n</Points>\n<Cells>\n'
            f'<DataArray type="Int64" Name="connectivity" format="ascii">{conn}</DataArray>\n'
            f'<DataArray type="Int64" Name="offsets" format="ascii">4 8</DataArray>\n'
            f'<DataArray type="UInt8" Name="types" format="ascii">10 10</DataArray>\n'
            f"</Cells>\n</Piece>\n</UnstructuredGrid>\n</VTKFile>\n").encode()


def msh():
    nodes = "".join(f"{i + 1} {x} {y} {z}\n" for i, (x, y, z) in enumerate(TET_NODES))
    els = "".join(f"{i + 1} 4 2 0 1 {a + 1} {b + 1} {c + 1} {d + 1}\n"
                  for i, (a, b, c, d) in enumerate(TETS))
    return (f"$MeshFormat\n2.2 0 8\n$EndMeshFormat\n$Nodes\n{len(TET_NODES)}\n{nodes}$EndNodes\n"
            f"$Elements\n{len(TETS)}\n{els}$EndElements\n").encode()


def model_toml():
    return (b'units = "SI"\nformulation = "corotational"\ngravity = [0.0, 0.0, -9.81]\n\n'
            b'[mesh]\npath = "tets.vtk"\n\n[material]\nyoung = 1000.0\npoisson = 0.45\n\n'
            b"[mass]\ntotal = 0.1\n\n[[fixed]]\nnodes = [0, 1, 2]\n\n[[loads]]\nnode = 4\n"
            b"force = [0.0, 0.0, -0.01]\n\n[[effectors]]\nname = \"tip\"\nat = [1.0, 1.0, 1.0]\n")


# Recording JSON: the corpus file replaces one file of a valid one-frame recording; its
# name starts with the file it replaces.
def camera_pose():
    return (b'{"robot_from_camera": [[1, 0, 0, 0], [0, -1, 0, 0.4], [0, 0, -1, 0.5], '
            b"[0, 0, 0, 1]]}\n")


def actuators():
    return (b'[[{"name": "north", "displacement_controlled": true, "shortening": 0.001, '
            b'"tension": 0.5}]]\n')


def inputs():
    return b'[{"frame": 0, "cables": {"north": 0.001}}]\n'


def truth():
    return b'{"frames": [{"frame": 0, "loads": [], "actuators": [], "pixels": [1, 0, 0]}]}\n'


# ---- mutations --------------------------------------------------------------------------

NUMBER = re.compile(rb"-?\d+(\.\d+)?([eE][-+]?\d+)?")
COUNTS = re.compile(rb"(POINTS|WIDTH|element vertex|NumberOfPoints=\"|NumberOfCells=\"|CELLS|"
                    rb"\$Nodes\n|\$Elements\n|\"width\": |<focal_length_x>)\s*(\d+)")


def replace_number(data, which, new):
    found = list(NUMBER.finditer(data))
    if not found:
        return data + b" " + new
    m = found[which % len(found)]
    return data[:m.start()] + new + data[m.end():]


def replace_count(data, new):
    m = COUNTS.search(data)
    if not m:
        return replace_number(data, 0, new)
    return data[:m.start(2)] + new + data[m.end(2):]


def mutations(seed, rng, text):
    """(name, bytes, expectation) for one seed; `text` formats get number and line edits."""
    n = len(seed)
    out = [("seed", seed, "ok"), ("empty", b"", "err"),
           ("garbage", bytes(rng.randrange(256) for _ in range(96)), "err"),
           ("wrong_magic", b"\x00\xffXQ" + seed[4:], "err")]
    for frac in (10, 25, 50, 75, 90):
        out.append((f"truncated_{frac}pct", seed[:n * frac // 100], "any"))
    out.append(("truncated_last_byte", seed[:-1], "any"))
    for k in range(8):
        b = bytearray(seed)
        at = rng.randrange(n)
        b[at] ^= 1 << rng.randrange(8)
        out.append((f"flip_{k}_at_{at}", bytes(b), "any"))
    for k in range(3):
        at = rng.randrange(n)
        junk = bytes(rng.randrange(256) for _ in range(rng.randrange(1, 9)))
        out.append((f"insert_{k}_at_{at}", seed[:at] + junk + seed[at:], "any"))
    if text:
        for k, (label, new) in enumerate([("nan", b"nan"), ("inf", b"inf"), ("neg_inf", b"-inf"),
                                          ("huge", b"1e308"), ("overflow", b"1e400"),
                                          ("neg_huge", b"-99999999999999999999")]):
            out.append((f"number_{label}", replace_number(seed, 3 + 5 * k, new), "any"))
        for label, new in [("zero", b"0"), ("negative", b"-1"), ("times_1000", b"3000"),
                           ("2_pow_40", b"1099511627776")]:
            out.append((f"count_{label}", replace_count(seed, new), "any"))
        lines = seed.split(b"\n")
        for k in (1, len(lines) // 2, len(lines) - 2):
            cut = b"\n".join(lines[:k] + lines[k + 1:])
            out.append((f"line_{k}_deleted", cut, "any"))
        dup = b"\n".join(lines[:2] + lines[1:])
        out.append(("line_1_duplicated", dup, "any"))
        out.append(("crlf_line_ends", seed.replace(b"\n", b"\r\n"), "any"))
        out.append(("cr_line_ends", seed.replace(b"\n", b"\r"), "any"))
    else:
        for k in range(4):
            b = bytearray(seed)
            at = n - 4 * (k + 1)
            b[at:at + 4] = struct.pack("<f", [float("nan"), float("inf"), 1e38, -1e38][k])
            out.append((f"tail_float_{k}", bytes(b), "any"))
        for k in range(4):
            b = bytearray(seed)
            at = rng.randrange(n)
            b[at:at + 4] = b"\xff\xff\xff\xff"
            out.append((f"all_ones_{k}_at_{at}", bytes(b), "any"))
        out.append(("count_times_1000", replace_count(seed, b"3000"), "any"))
        out.append(("count_2_pow_40", replace_count(seed, b"1099511627776"), "any"))
        out.append(("doubled", seed + seed, "any"))
        out.append(("zeros_appended", seed + bytes(64), "any"))
    return out


FORMATS = [
    # folder, extension, seed, text, expectation overrides
    ("pcd_ascii", "pcd", pcd_ascii(), True, {}),
    ("pcd_binary", "pcd", pcd_binary(), False, {"doubled": "err", "zeros_appended": "err"}),
    # PCL's writer pads compressed blocks with zeros, and PCL reads them: so do we.
    ("pcd_binary_compressed", "pcd", pcd_compressed(), False,
     {"doubled": "err", "zeros_appended": "ok"}),
    ("ply_ascii", "ply", ply_ascii(), True, {}),
    ("ply_binary", "ply", ply_binary(), False, {}),
    ("xyz", "xyz", xyz(), True, {"empty": "ok", "wrong_magic": "any", "cr_line_ends": "ok",
                                  "crlf_line_ends": "ok"}),
    ("depth_png", "png", depth_png(), False, {}),
    ("color_png", "png", color_png(), False, {}),
    ("depth_tiff", "tiff", depth_tiff(), False, {}),
    ("intrinsics_json", "json", intrinsics_json(), True, {}),
    ("intrinsics_xml", "xml", intrinsics_xml(), True, {}),
    ("scene_toml", "toml", scene_toml(), True, {}),
    ("model_toml", "toml", model_toml(), True, {"seed": "any"}),
    ("vtu", "vtu", vtu(), True, {}),
    ("vtk", "vtk", vtk(), True, {}),
    ("msh", "msh", msh(), True, {}),
]

RECORDING = [("camera_pose", camera_pose()), ("actuators", actuators()), ("inputs", inputs()),
             ("truth", truth())]


def write_folder(folder, entries):
    path = os.path.join(ROOT, folder)
    shutil.rmtree(path, ignore_errors=True)
    os.makedirs(path)
    lines = [f"# file expectation (ok, err, any); made by tools/make_malformed_corpus.py"]
    for name, data, expect in entries:
        with open(os.path.join(path, name), "wb") as f:
            f.write(data)
        lines.append(f"{name} {expect}")
    with open(os.path.join(path, "MANIFEST.txt"), "w") as f:
        f.write("\n".join(lines) + "\n")


def main():
    for i, (folder, ext, seed, text, overrides) in enumerate(FORMATS):
        rng = random.Random(1000 + i)
        entries = [(f"{label}.{ext}", data, overrides.get(label, expect))
                   for label, data, expect in mutations(seed, rng, text)]
        if folder == "model_toml":
            # The mesh the model names (aux: read through the model, not on its own).
            entries.append(("tets.vtk", vtk(), "aux"))
        write_folder(folder, entries)
    entries = []
    for j, (target, seed) in enumerate(RECORDING):
        rng = random.Random(2000 + j)
        for label, data, expect in mutations(seed, rng, True):
            if label.startswith("count_") or label.startswith("line_"):
                if j % 2:  # half the count and line edits per file keep the corpus small
                    continue
            entries.append((f"{target}__{label}.json", data, "any"))
    write_folder("recording_json", entries)


if __name__ == "__main__":
    main()
