#!/usr/bin/env bash
# The record-and-replay tools end to end (docs/ros.md, record and replay): wet_curly_hair_bag_to_hair
# turns recorded Strands messages into .hair frames that hold exactly what the messages held, and
# wet_curly_hair_render draws them into a contact sheet with strands in every tile. Input: the
# committed test/data/replay_expected.bag (27 /wet_curly_hair/strands messages).
set -u
build=$1
source "$(dirname "${BASH_SOURCE[0]}")/lib.sh"
to_hair=$(tool_path wet_curly_hair_bag_to_hair "$build") || exit 1
render=$(tool_path wet_curly_hair_render "$build") || exit 1
here="$(cd "$(dirname "${BASH_SOURCE[0]}")/../.." && pwd)"
bag="$here/test/data/replay_expected.bag"
out=$(mktemp -d)
trap 'rm -rf "$out"' EXIT
pass=0 fail=0
check() { if eval "$2"; then pass=$((pass + 1)); else echo "FAIL: $1"; fail=$((fail + 1)); fi; }

"$to_hair" --wet "$bag" "$out/all" > "$out/all.txt" 2> "$out/err"
rc=$?
check "bag_to_hair --wet exits 0 (got $rc: $(head -c 300 "$out/err"))" "[ $rc -eq 0 ]"
"$to_hair" --count 3 "$bag" "$out/three" > "$out/three.txt" 2> "$out/err"
rc=$?
check "bag_to_hair --count 3 exits 0 (got $rc)" "[ $rc -eq 0 ]"
# Every frame file equals its message (numbered by message index): strand sizes, positions (the
# cohesion display positions with --wet) as float32, saturation in the transparency array.
check "frames hold exactly what the messages held" "/usr/bin/python3 - '$bag' '$out' <<'PY'
import os, struct, sys
import rosbag
bag, out = sys.argv[1], sys.argv[2]

def read_hair(path):
    b = open(path, 'rb').read()
    assert b[:4] == b'HAIR', path
    strands, points, flags, default_segments = struct.unpack_from('<IIII', b, 4)
    off = 128
    if flags & 1:
        segments = list(struct.unpack_from('<%dH' % strands, b, off)); off += 2 * strands
    else:
        segments = [default_segments] * strands
    assert flags & 2, 'no points'
    pts = struct.unpack_from('<%df' % (3 * points), b, off); off += 12 * points
    if flags & 4: off += 4 * points
    alpha = struct.unpack_from('<%df' % points, b, off) if flags & 8 else None
    return segments, pts, alpha

msgs = [m for _, m, _ in rosbag.Bag(bag).read_messages(topics=['/wet_curly_hair/strands'])]
ok = len(msgs) == 27
listed = open(out + '/all.txt').read().split()
ok = ok and len(listed) == len(msgs) and sorted(os.listdir(out + '/all')) == [os.path.basename(p) for p in listed]
def same(path, m, wet):
    seg, pts, alpha = read_hair(path)
    off = list(m.strand_offsets)
    want = [off[i + 1] - off[i] - 1 for i in range(len(off) - 1)]
    xyz = m.wet_positions if wet and len(m.wet_positions) else m.positions
    f32 = lambda v: struct.unpack('<f', struct.pack('<f', v))[0]
    return (seg == want and list(pts) == [f32(v) for v in xyz] and alpha is not None
            and list(alpha) == [f32(v) for v in m.saturation])
for k, m in enumerate(msgs):
    ok = ok and same('%s/all/frame_%05d.hair' % (out, k), m, True)
# the wet positions differ from the dynamic ones somewhere (cohesion is on in the replay scene)
ok = ok and any(list(m.wet_positions) != list(m.positions) for m in msgs)
three = sorted(os.listdir(out + '/three'))
ok = ok and len(three) == 3 and three[0] == 'frame_00000.hair' and three[-1] == 'frame_00026.hair'
for name in three:
    ok = ok and same(out + '/three/' + name, msgs[int(name[6:11])], False)
sys.exit(0 if ok else 1)
PY"

"$render" --sheet 3 --fps 50 --out "$out/sheet.png" "$out"/three/*.hair > /dev/null 2> "$out/err"
rc=$?
check "render --sheet 3 exits 0 (got $rc: $(head -c 300 "$out/err"))" "[ $rc -eq 0 ]"
"$render" "$out/three/frame_00000.hair" > /dev/null 2> "$out/err"
rc=$?
check "render of one frame exits 0 and writes FRAME.png beside it (got $rc)" \
  "[ $rc -eq 0 ] && [ -s $out/three/frame_00000.png ]"
# Decode the PNGs (8-bit RGB or RGBA, non-interlaced, as Cairo writes them): sizes as documented
# (3 tiles of 400 x 400 in a row; one picture 800 x 800) and strands drawn in every tile.
check "sheet is 1200 x 400 with strands in each tile; single picture 800 x 800 with strands" \
  "/usr/bin/python3 - '$out/sheet.png' '$out/three/frame_00000.png' <<'PY'
import struct, sys, zlib

def decode(path):
    b = open(path, 'rb').read()
    assert b[:8] == b'\x89PNG\r\n\x1a\n'
    pos, idat, w = 8, b'', 0
    while pos < len(b):
        n, kind = struct.unpack_from('>I4s', b, pos)
        data = b[pos + 8:pos + 8 + n]
        if kind == b'IHDR':
            w, h, depth, color, _, _, interlace = struct.unpack('>IIBBBBB', data)
            assert depth == 8 and color in (2, 6) and interlace == 0
            bpp = 3 if color == 2 else 4
        elif kind == b'IDAT':
            idat += data
        pos += 12 + n
    raw, rows, prev, i = zlib.decompress(idat), [], bytearray(w * bpp), 0
    for y in range(h):
        f, line = raw[i], bytearray(raw[i + 1:i + 1 + w * bpp]); i += 1 + w * bpp
        for x in range(len(line)):
            a = line[x - bpp] if x >= bpp else 0
            c = prev[x - bpp] if x >= bpp else 0
            up = prev[x]
            if f == 1: line[x] = (line[x] + a) & 255
            elif f == 2: line[x] = (line[x] + up) & 255
            elif f == 3: line[x] = (line[x] + (a + up) // 2) & 255
            elif f == 4:
                p = a + up - c
                pa, pb, pc = abs(p - a), abs(p - up), abs(p - c)
                line[x] = (line[x] + (a if pa <= pb and pa <= pc else up if pb <= pc else c)) & 255
        rows.append(bytes(line)); prev = line
    return w, h, bpp, rows

def drawn(rows, bpp, x0, x1, y0, y1):
    # Share of non-background pixels in the middle half of a tile (the legend, axes and caption
    # lie in its corners; the camera is fitted to the hair).
    bg = rows[y0 + 2][(x0 + 2) * bpp:(x0 + 3) * bpp]  # a corner pixel: the background
    qx, qy = (x1 - x0) // 4, (y1 - y0) // 4
    xs, ys = range(x0 + qx, x1 - qx, 2), range(y0 + qy, y1 - qy, 2)
    hits = sum(rows[y][x * bpp:(x + 1) * bpp] != bg for y in ys for x in xs)
    return hits / (len(xs) * len(ys))

w, h, bpp, rows = decode(sys.argv[1])
ok = (w, h) == (1200, 400)
for t in range(3):
    ok = ok and drawn(rows, bpp, 400 * t, 400 * t + 400, 0, 400) > 0.02
w, h, bpp, rows = decode(sys.argv[2])
ok = ok and (w, h) == (800, 800) and drawn(rows, bpp, 0, 800, 0, 800) > 0.02
sys.exit(0 if ok else 1)
PY"

# Bad input: a clear message and a failing exit, nothing written.
"$to_hair" "$out/no_such.bag" "$out/none" > /dev/null 2> "$out/err"
rc=$?
check "bag_to_hair on a missing bag exits 1 with a message (got $rc)" \
  "[ $rc -eq 1 ] && [ -s $out/err ] && [ ! -e $out/none/frame_00000.hair ]"
"$render" --out "$out/bad.png" "$out/no_such.hair" > /dev/null 2> "$out/err"
rc=$?
check "render of a missing file fails with a message (got $rc)" \
  "[ $rc -ne 0 ] && grep -q no_such.hair $out/err && [ ! -e $out/bad.png ]"
echo "$pass passed, $fail failed"
[ "$fail" -eq 0 ]
