#!/usr/bin/env bash
# corvid-render as a user runs it: a small frame on 2 virtual GPUs writes a
# valid EXR (with its AOV layers) and PNG of the right size; bad input gives a
# clear message and a non-zero exit, and writes nothing.
set -u
render=$1
tmp=$(mktemp -d)
trap 'rm -rf "$tmp"' EXIT
pass=0 fail=0
not() { ! "$@"; }
check() {  # check "what" command...
  local what=$1; shift
  if "$@"; then pass=$((pass + 1)); else fail=$((fail + 1)); echo "FAILED: $what" >&2; fi
}

# "--option=value" and "--option value" alike, for every option.
"$render" --gpus=2 --adapters llvmpipe --size=96x54 --frames 2 --ao-samples=2 --out="$tmp/a/frame" > "$tmp/out.txt" 2> "$tmp/err.txt"
check "render exits 0" test $? -eq 0
check "EXR written" test -s "$tmp/a/frame.exr"
check "PNG written" test -s "$tmp/a/frame.png"
check "EXR magic" test "$(head -c 4 "$tmp/a/frame.exr" | od -An -tx1 | tr -d ' \n')" = "762f3101"
check "PNG magic" test "$(head -c 8 "$tmp/a/frame.png" | od -An -tx1 | tr -d ' \n')" = "89504e470d0a1a0a"
# PNG IHDR: width and height as big-endian u32 at bytes 16..23.
check "PNG is 96x54" test "$(dd if="$tmp/a/frame.png" bs=1 skip=16 count=8 2>/dev/null | od -An -tx1 | tr -d ' \n')" = "0000006000000036"
for layer in albedo.R normal.X depth.Z shadow.Y ao.Y direct.R direct.G direct.B; do
  check "EXR has $layer" grep -q "$layer" "$tmp/a/frame.exr"
done
check "reports both devices" grep -q "gpu1: columns" "$tmp/out.txt"
check "reports its rays" grep -q "1 shadow + 2 AO rays/pixel/frame" "$tmp/out.txt"
# --shadow-samples: several shadow rays a pixel, said in the summary.
"$render" --gpus 2 --adapters llvmpipe --size 64x32 --frames 1 --ao-samples 1 --shadow-samples=4 \
  --out "$tmp/ss/frame" > "$tmp/out.txt" 2> "$tmp/err.txt"
check "--shadow-samples 4 renders" test $? -eq 0 -a -s "$tmp/ss/frame.exr"
check "--shadow-samples 4 reported" grep -q "4 shadow + 1 AO rays/pixel/frame" "$tmp/out.txt"
# --reflection-samples: several reflection rays a pixel, said in the summary
# (64x32 pixels, 1 frame, 2 samples: 8192 rays with their shadow rays).
"$render" --gpus 2 --adapters llvmpipe --size 64x32 --frames 1 --ao-samples 1 --reflection-samples 2 \
  --out "$tmp/rs/frame" > "$tmp/out.txt" 2> "$tmp/err.txt"
check "--reflection-samples 2 renders" test $? -eq 0 -a -s "$tmp/rs/frame.exr"
check "--reflection-samples 2 reported" grep -q "reflections: 8192 rays with their shadow rays, 4 a traced pixel a frame" "$tmp/out.txt"

# --dump-graph: the frame's render graph as text (and FILE.dot), naming the
# passes and, on 2 devices, the G-buffer multicast and the visibility copy-back.
# One frame: its split is the even one; a second frame's comes from the first's
# timings, and on a loaded machine 64 columns in tiles of 8 can leave dev1 none.
"$render" --gpus 2 --adapters llvmpipe --size 64x32 --frames 1 --ao-samples 1 --quiet --out "$tmp/g/frame" \
  --dump-graph "$tmp/g/graph.txt" 2> "$tmp/err.txt"
check "--dump-graph exits 0" test $? -eq 0
for graph_pass in gbuffer trace accumulate filter composite present; do
  check "graph dump names pass '$graph_pass'" grep -q "pass '$graph_pass'" "$tmp/g/graph.txt"
done
check "graph dump: trace on both devices" grep -q "^      dev1 \[" "$tmp/g/graph.txt"
check "graph dump: G-buffer multicast" grep -q "transfer 'gbuffer position' after 'gbuffer': MULTICAST: dev0->dev1 \[0,64)" "$tmp/g/graph.txt"
check "graph dump: visibility gathered" grep -q "transfer 'visibility' after 'trace': ISOLATED_TO_ISOLATED: dev1->dev0 \[" "$tmp/g/graph.txt"
# Virtual GPUs of one adapter share the gathered textures (zero-copy, the default); =off copies.
check "graph dump: visibility gathered zero-copy" grep -q "transfer 'visibility' after 'trace': .*(zero-copy" "$tmp/g/graph.txt"
CORVID_ZERO_COPY=off "$render" --gpus 2 --adapters llvmpipe --size 64x32 --frames 1 --ao-samples 1 --quiet \
  --out "$tmp/g/frame" --dump-graph "$tmp/g/copies.txt" 2> "$tmp/err.txt"
check "CORVID_ZERO_COPY=off exits 0" test $? -eq 0
check "CORVID_ZERO_COPY=off: the gathers copy" not grep -q "zero-copy" "$tmp/g/copies.txt"
CORVID_ZERO_COPY=sometimes "$render" --gpus 2 --adapters llvmpipe --size 64x32 --frames 1 --quiet \
  --out "$tmp/zb/frame" 2> "$tmp/err.txt"
check "bad CORVID_ZERO_COPY exits 1" test $? -eq 1
check "bad CORVID_ZERO_COPY explained" grep -qF "CORVID_ZERO_COPY='sometimes' is not one of auto, on, off" "$tmp/err.txt"
check "bad CORVID_ZERO_COPY: nothing written" test ! -e "$tmp/zb"
"$render" --help > "$tmp/help.txt"
check "--help lists CORVID_ZERO_COPY" grep -q "CORVID_ZERO_COPY=auto|on|off" "$tmp/help.txt"
check "graph dot written" grep -q "^digraph corvid_graph" "$tmp/g/graph.txt.dot"
check "graph dot has the trace node" grep -q 'label="trace' "$tmp/g/graph.txt.dot"

# --stats and --trace: JSON of every frame (tests/renderer/render_outputs_test.c
# checks the figures against cv_render_stats; here: the files as a user gets them).
"$render" --gpus 2 --adapters llvmpipe --size 64x32 --frames 3 --ao-samples 1 --quiet --out "$tmp/s/frame" \
  --stats "$tmp/s/stats.json" --trace="$tmp/s/trace.json" 2> "$tmp/err.txt"
check "--stats and --trace exit 0" test $? -eq 0
check "stats: 3 frames of 2 devices, rays add up to the summary" python3 -c '
import json, sys
d = json.load(open(sys.argv[1]))
f, s = d["frames"], d["summary"]
assert [x["frame"] for x in f] == [0, 1, 2] and s["frames"] == 3 and s["device_count"] == 2
assert all(len(x["devices"]) == 2 and sum(v["columns"]["width"] for v in x["devices"]) == 64 for x in f)
assert sum(v["rays"] for x in f for v in x["devices"]) == s["rays_total"] == 3 * 64 * 32 * 2
assert all(p["ms"] >= 0 for x in f for v in x["devices"] for p in v["passes"])' "$tmp/s/stats.json"
check "trace: named device processes, one event per pass instance per frame" python3 -c '
import json, sys
e = json.load(open(sys.argv[1]))["traceEvents"]
names = {x["args"]["name"] for x in e if x["ph"] == "M" and x["name"] == "process_name"}
assert names == {"gpu0", "gpu1", "host"}, names
passes = [x for x in e if x["ph"] == "X" and x["cat"] == "pass"]
assert len(passes) == 1 + 3 * (2 * 2 + 2) + 4, len(passes)  # gbuffer; trace, reflect x2, accumulate, reflect_filter a frame; reflect_denoise, filter, composite, present
assert all(x["dur"] >= 0 and x["ts"] >= 0 for x in e if x["ph"] == "X")' "$tmp/s/trace.json"
compare_direct() { "$(dirname "$render")/corvid-compare" "$1" "$1" --layer direct > /dev/null; }
check "corvid-compare reads the direct layer" compare_direct "$tmp/s/frame.exr"
# Bad --stats / --trace destinations fail before the render starts and write nothing.
"$render" --size 8x8 --frames 1 --out "$tmp/sb/frame" --stats "$tmp/nodir/stats.json" > /dev/null 2> "$tmp/err.txt"
check "--stats in a missing folder exits 1" test $? -eq 1
check "--stats in a missing folder explained" grep -qF -- "--stats: $tmp/nodir/stats.json: cannot create a temporary file beside it: No such file or directory" "$tmp/err.txt"
check "--stats in a missing folder: found before rendering" not grep -q "scene 'room'" "$tmp/err.txt"
check "--stats in a missing folder: nothing written" test ! -e "$tmp/sb"
echo plain > "$tmp/plainfile"
"$render" --size 8x8 --frames 1 --out "$tmp/sb/frame" --trace "$tmp/plainfile/trace.json" > /dev/null 2> "$tmp/err.txt"
check "--trace under a file exits 1" test $? -eq 1
check "--trace under a file explained" grep -qF -- "--trace: $tmp/plainfile/trace.json: Not a directory" "$tmp/err.txt"
check "--trace under a file: nothing written" test ! -e "$tmp/sb"
"$render" --size 8x8 --frames 1 --out "$tmp/sb/frame" --stats "$tmp/same.json" --trace "$tmp/./same.json" > /dev/null 2> "$tmp/err.txt"
check "--trace = --stats exits 1" test $? -eq 1
check "--trace = --stats explained" grep -qF -- "--trace: '$tmp/./same.json' is also the --stats file" "$tmp/err.txt"
check "--trace = --stats: nothing written" test ! -e "$tmp/same.json"
"$render" --size 8x8 --frames 1 --out "$tmp/sb/frame" --stats "$tmp/sb/frame.exr" > /dev/null 2> "$tmp/err.txt"
check "--stats = the EXR exits 1" test $? -eq 1
check "--stats = the EXR explained" grep -qF -- "is also the EXR" "$tmp/err.txt"
"$render" --reference 1 --size 8x8 --out "$tmp/sb/frame" --trace "$tmp/t.json" > /dev/null 2> "$tmp/err.txt"
check "--trace with --reference exits 2" test $? -eq 2
check "--trace with --reference explained" grep -qF -- "--reference renders on the CPU" "$tmp/err.txt"
check "nothing written for refused --stats/--trace" test ! -e "$tmp/sb" -a ! -e "$tmp/t.json"

"$render" --scene "$tmp/missing.glb" --out "$tmp/b/frame" > /dev/null 2> "$tmp/err.txt"
check "missing scene exits 1" test $? -eq 1
check "missing scene names the file" grep -q "missing.glb" "$tmp/err.txt"
check "nothing written for a missing scene" test ! -e "$tmp/b/frame.exr"
check "no folder left for a failed render" test ! -e "$tmp/b"
mkfifo "$tmp/fifo.obj"
timeout 20 "$render" --scene "$tmp/fifo.obj" --out "$tmp/b/frame" > /dev/null 2> "$tmp/err.txt"
check "FIFO scene exits 1 (no hang)" test $? -eq 1
check "FIFO scene explained" grep -q "fifo.obj: is not a regular file" "$tmp/err.txt"

# Output paths of any length up to the system's limit: a prefix of 1099
# characters once lost ".exr"/".png" to a fixed buffer (the PNG overwrote the EXR).
long="$tmp/long"
while [ ${#long} -lt 900 ]; do long="$long/$(printf 'd%.0s' $(seq 150))"; done
long="$long/$(printf 'f%.0s' $(seq $((1099 - ${#long} - 1))))"
"$render" --size 8x8 --frames 1 --out "$long" > "$tmp/out.txt" 2> "$tmp/err.txt"
check "1099-character prefix exits 0" test $? -eq 0
check "1099-character prefix: EXR" test "$(head -c 4 "$long.exr" | od -An -tx1 | tr -d ' \n')" = "762f3101"
check "1099-character prefix: PNG" test "$(head -c 8 "$long.png" | od -An -tx1 | tr -d ' \n')" = "89504e470d0a1a0a"
check "1099-character prefix: only the two files" test "$(ls -A "$(dirname "$long")" | wc -l)" -eq 2
"$render" --size 8x8 --frames 1 --out "$tmp/$(printf 'x%.0s' $(seq 300))" > /dev/null 2> "$tmp/err.txt"
check "file name too long exits 1" test $? -eq 1
check "file name too long explained" grep -q "File name too long" "$tmp/err.txt"

# Scenes at extreme scales: tiny ones are framed, ones the renderer's float
# arithmetic cannot show are refused (they rendered an empty sky, exit 0).
cube() {  # cube FILE SIDE
  awk -v s="$2" 'BEGIN { for (v = 0; v < 8; v++) printf "v %.9g %.9g %.9g\n", s * (v % 2), s * (int(v / 2) % 2), s * int(v / 4);
    print "f 1 2 4 3\nf 5 6 8 7\nf 1 2 6 5\nf 3 4 8 7\nf 1 3 7 5\nf 2 4 8 6" }' > "$1"
}
cube "$tmp/tiny.obj" 1e-5
"$render" --scene "$tmp/tiny.obj" --size 8x8 --frames 1 --quiet --out "$tmp/t/frame" 2> "$tmp/err.txt"
check "1e-5 scene renders" test $? -eq 0
cube "$tmp/huge.obj" 1e20
"$render" --scene "$tmp/huge.obj" --size 8x8 --frames 1 --quiet --out "$tmp/h/frame" 2> "$tmp/err.txt"
check "1e20 scene exits 1" test $? -eq 1
check "1e20 scene explained" grep -q "huge.obj: scene extent 1e+20" "$tmp/err.txt"
check "nothing written for a 1e20 scene" test ! -e "$tmp/h"

# Destinations that cannot take the files fail before the render starts (no
# scene line), and leave existing files and the folder as they were.
echo plain > "$tmp/plain"
"$render" --out "$tmp/plain/frame" > /dev/null 2> "$tmp/err.txt"
check "output under a file exits 1" test $? -eq 1
check "output under a file explained" grep -q -- "--out: $tmp/plain/frame.exr: Not a directory" "$tmp/err.txt"
check "output under a file: found before rendering" not grep -q "scene 'room'" "$tmp/err.txt"
mkdir -p "$tmp/c/frame.png" && echo old > "$tmp/c/frame.exr"
"$render" --size 8x8 --frames 1 --out "$tmp/c/frame" > /dev/null 2> "$tmp/err.txt"
check "PNG path is a folder exits 1" test $? -eq 1
check "PNG path is a folder explained" grep -q "frame.png: is a directory" "$tmp/err.txt"
check "PNG path is a folder: found before rendering" not grep -q "scene 'room'" "$tmp/err.txt"
check "PNG path is a folder: old EXR kept" test "$(cat "$tmp/c/frame.exr")" = old
check "PNG path is a folder: no temporary left" test "$(ls -A "$tmp/c" | wc -l)" -eq 2

"$render" --size 0x10 2> "$tmp/err.txt"
check "bad size exits 2" test $? -eq 2
check "bad size explained" grep -q -- "--size" "$tmp/err.txt"
"$render" --no-such-flag 2> "$tmp/err.txt"
check "unknown flag exits 2" test $? -eq 2
check "unknown flag named" grep -q "no-such-flag" "$tmp/err.txt"
# Values that were silently coerced are refused with the option, the value
# and the accepted range (exit 2, nothing rendered).
refused() {  # refused "what" "expected message" option...
  local what=$1 msg=$2; shift 2
  "$render" "$@" --out "$tmp/r/frame" > /dev/null 2> "$tmp/err.txt"
  check "$what exits 2" test $? -eq 2
  check "$what explained" grep -qF -- "$msg" "$tmp/err.txt"
}
refused "size over 2^32" "--size: '4294967297x2' is not WxH with each side in 1..16384" --size 4294967297x2
refused "size with a sign" "--size: '-8x8' is not WxH" --size=-8x8
refused "size 0" "--size: '0x10' is not WxH" --size 0x10
refused "AO samples 0" "--ao-samples: '0' is not a whole number in 1..32" --ao-samples 0
refused "AO samples 33" "--ao-samples: '33' is not a whole number in 1..32" --ao-samples=33
refused "shadow samples 3" "--shadow-samples: '3' is not one of 1, 2, 4, 8, 16, 32" --shadow-samples 3
refused "shadow samples 64" "--shadow-samples: '64' is not one of 1, 2, 4, 8, 16, 32" --shadow-samples=64
refused "shadow samples 0" "--shadow-samples: '0' is not one of 1, 2, 4, 8, 16, 32" --shadow-samples 0
refused "reflection samples 3" "--reflection-samples: '3' is not one of 1, 2, 4, 8" --reflection-samples 3
refused "reflection samples 16" "--reflection-samples: '16' is not one of 1, 2, 4, 8" --reflection-samples=16
refused "reflection samples 0" "--reflection-samples: '0' is not one of 1, 2, 4, 8" --reflection-samples 0
refused "reflection samples over the texture limit" "8 reflection samples of a 4096-row image" --size 16x4096 --reflection-samples 8
refused "frames over the limit" "--frames: '5000' is not a whole number in 1..4096" --frames 5000
refused "filter over 8" "--filter: '9' is not a whole number in 0..8" --filter 9
refused "negative seed" "--seed: '-1' is not a whole number in 0..4294967295" --seed -1
refused "seed over 32 bits" "--seed: '4294967296' is not a whole number in 0..4294967295" --seed 4294967296
refused "negative stress" "--scene: 'stress:-5' is not stress:N" --scene stress:-5
refused "overflowing stress" "--scene: 'stress:18446744073709551616' is not stress:N" --scene stress:18446744073709551616
refused "flag with a value" "--quiet takes no value" --quiet=1
refused "AO radius 0" "--ao-radius: '0' is not a finite number of scene units > 0" --ao-radius 0
# The view and light controls: wrong counts, non-finite numbers and values
# outside their ranges are refused naming the option and the value.
refused "camera with 3 numbers" "--camera: '1,2,3' is not 7 finite numbers EX,EY,EZ,TX,TY,TZ,FOV" --camera 1,2,3
refused "camera with 8 numbers" "--camera: '1,2,3,4,5,6,45,1' is not 7 finite numbers" --camera 1,2,3,4,5,6,45,1
refused "camera with NaN" "--camera: 'nan,0,0,0,0,1,45' is not 7 finite numbers" --camera nan,0,0,0,0,1,45
refused "camera with inf" "--camera: '0,0,0,0,0,1,inf' is not 7 finite numbers" --camera 0,0,0,0,0,1,inf
refused "camera fov 180" "--camera: '0,1,5,0,1,0,180' is not EX,EY,EZ,TX,TY,TZ,FOV with FOV in (0,170] degrees" --camera 0,1,5,0,1,0,180
refused "camera fov 170.5" "with FOV in (0,170] degrees" --camera 0,1,5,0,1,0,170.5
refused "camera fov 0" "with FOV in (0,170] degrees" --camera 0,1,5,0,1,0,0
refused "camera eye at target" "--camera: '1,1,1,1,1,1,45': renderer: camera eye (1, 1, 1) equals its target" --camera 1,1,1,1,1,1,45
refused "camera empty item" "--camera: '1,,1,0,0,0,45' is not 7 finite numbers" --camera 1,,1,0,0,0,45
refused "sun with 2 numbers" "--sun: '1,2' is not 4 finite numbers DX,DY,DZ,A" --sun 1,2
refused "sun toward 0,0,0" "--sun: '0,0,0,1' is not DX,DY,DZ,A with a direction other than 0,0,0" --sun 0,0,0,1
refused "sun angle 90" "--sun: '0,1,0,90' is not DX,DY,DZ,A with A in [0,90) degrees" --sun 0,1,0,90
refused "sun angle negative" "--sun: '0,1,0,-1' is not DX,DY,DZ,A with A in [0,90) degrees" --sun 0,1,0,-1
refused "sun with NaN" "--sun: '0,nan,0,1' is not 4 finite numbers" --sun 0,nan,0,1
refused "orbit inf" "--orbit: 'inf' is not a finite number of degrees per frame in -360..360" --orbit inf
refused "orbit 400" "--orbit: '400' is not a finite number of degrees per frame" --orbit 400
check "nothing rendered for refused values" test ! -e "$tmp/r"
# Accepted: a camera of its own, a hard sun, an orbit (the moving camera's path).
"$render" --size 32x18 --frames 3 --camera 0.5,1.6,3.5,0,1,0,70 --sun 0.3,1,0.2,0 --orbit 2 --quiet \
  --out "$tmp/v/frame" 2> "$tmp/err.txt"
check "camera, sun and orbit render exits 0" test $? -eq 0
check "camera, sun and orbit render: EXR" test -s "$tmp/v/frame.exr"
"$render" --scene stress:-5 2> "$tmp/err.txt"
check "negative number not echoed as 2^64-5" not grep -q 18446744073709551611 "$tmp/err.txt"
"$render" --out "" 2> "$tmp/err.txt"
check "empty --out exits 2" test $? -eq 2
check "empty --out explained" grep -qF -- "--out: '' is not a path ending in a file name" "$tmp/err.txt"
mkdir -p "$tmp/o"
"$render" --out "$tmp/o/" 2> "$tmp/err.txt"
check "--out ending in / exits 2" test $? -eq 2
check "--out ending in / explained" grep -qF -- "--out: '$tmp/o/' is not a path ending in a file name" "$tmp/err.txt"
check "no hidden .exr or .png" test -z "$(ls -A "$tmp/o")"
"$render" --adapters ",,," --out "$tmp/r/frame" 2> "$tmp/err.txt"
check "empty adapter entries exit 1" test $? -eq 1
check "empty adapter entries explained" grep -qF -- "--adapters: ',,,': entry 1 is empty" "$tmp/err.txt"
"$render" --adapters "llvmpipe," --out "$tmp/r/frame" 2> "$tmp/err.txt"
check "trailing comma in adapters explained" grep -qF -- "--adapters: 'llvmpipe,': entry 2 is empty" "$tmp/err.txt"
"$render" --gpus 0 2> "$tmp/err.txt"
check "--gpus 0 exits 2" test $? -eq 2
check "--gpus 0 states the range" grep -qF -- "--gpus: '0' is not a count in 1..64" "$tmp/err.txt"
# An explicit --gpus wins over CORVID_VIRTUAL_GPUS, which is checked only when used.
CORVID_VIRTUAL_GPUS=bogus "$render" --gpus 1 --size 8x8 --frames 1 --quiet --out "$tmp/e/frame" 2> "$tmp/err.txt"
check "--gpus overrides a bad CORVID_VIRTUAL_GPUS" test $? -eq 0
check "--gpus with CORVID_VIRTUAL_GPUS writes the PNG" test -s "$tmp/e/frame.png"
CORVID_VIRTUAL_GPUS=bogus "$render" --size 8x8 --frames 1 --quiet --out "$tmp/e/frame" 2> "$tmp/err.txt"
check "a used, bad CORVID_VIRTUAL_GPUS exits 1" test $? -eq 1
check "a used, bad CORVID_VIRTUAL_GPUS is named" grep -qF "CORVID_VIRTUAL_GPUS: 'bogus' is not a count in 1..64" "$tmp/err.txt"

# ---- hostile inputs --------------------------------------------------------------
# --dump-graph is an output like --out, --stats and --trace: checked and reserved before the
# render (a bad path threw the images away after it), distinct from the others (it overwrote
# the EXR), never a FIFO (it hung), and written atomically (a failed dump left empty files).
"$render" --size 8x8 --frames 1 --out "$tmp/dg/frame" --dump-graph "$tmp/nodir/graph.txt" > /dev/null 2> "$tmp/err.txt"
check "--dump-graph in a missing folder exits 1" test $? -eq 1
check "--dump-graph in a missing folder explained" grep -qF -- "--dump-graph: $tmp/nodir/graph.txt: cannot create a temporary file beside it: No such file or directory" "$tmp/err.txt"
check "--dump-graph in a missing folder: found before rendering" not grep -q "scene 'room'" "$tmp/err.txt"
check "--dump-graph in a missing folder: nothing written" test ! -e "$tmp/dg"
mkdir -p "$tmp/dg2" && echo old > "$tmp/dg2/frame.exr"
"$render" --size 8x8 --frames 1 --out "$tmp/dg2/frame" --dump-graph "$tmp/dg2/./frame.exr" > /dev/null 2> "$tmp/err.txt"
check "--dump-graph = the EXR exits 1" test $? -eq 1
check "--dump-graph = the EXR explained" grep -qF -- "--dump-graph: '$tmp/dg2/./frame.exr' is also the EXR" "$tmp/err.txt"
check "--dump-graph = the EXR: the EXR kept" test "$(cat "$tmp/dg2/frame.exr")" = old
"$render" --size 8x8 --frames 1 --out "$tmp/dg/frame" --stats "$tmp/g.json" --dump-graph "$tmp/g.json" > /dev/null 2> "$tmp/err.txt"
check "--dump-graph = --stats exits 1" test $? -eq 1
check "--dump-graph = --stats explained" grep -qF -- "--dump-graph: '$tmp/g.json' is also the --stats file" "$tmp/err.txt"
"$render" --size 8x8 --frames 1 --out "$tmp/dg/frame" --trace "$tmp/g.dot" --dump-graph "$tmp/g" > /dev/null 2> "$tmp/err.txt"
check "--dump-graph's dot file = --trace exits 1" test $? -eq 1
check "--dump-graph's dot file = --trace explained" grep -qF -- "--dump-graph: '$tmp/g.dot' is also the --trace file" "$tmp/err.txt"
mkfifo "$tmp/graph.fifo"
timeout 20 "$render" --size 8x8 --frames 1 --out "$tmp/dg/frame" --dump-graph "$tmp/graph.fifo" > /dev/null 2> "$tmp/err.txt"
check "--dump-graph to a FIFO exits 1 (no hang)" test $? -eq 1
check "--dump-graph to a FIFO explained" grep -qF -- "--dump-graph: $tmp/graph.fifo: exists and is not a regular file" "$tmp/err.txt"
mkdir -p "$tmp/dg3/graph.txt.dot"
"$render" --size 8x8 --frames 1 --out "$tmp/dg3/frame" --dump-graph "$tmp/dg3/graph.txt" > /dev/null 2> "$tmp/err.txt"
check "--dump-graph whose dot path is a folder exits 1" test $? -eq 1
check "--dump-graph whose dot path is a folder explained" grep -qF -- "graph.txt.dot: is a directory" "$tmp/err.txt"
check "--dump-graph whose dot path is a folder: no empty FILE left" test "$(ls -A "$tmp/dg3")" = graph.txt.dot
"$render" --reference 1 --size 8x8 --out "$tmp/dg/frame" --dump-graph "$tmp/g.txt" > /dev/null 2> "$tmp/err.txt"
check "--dump-graph with --reference exits 2" test $? -eq 2
check "--dump-graph with --reference explained" grep -qF -- "--dump-graph record the GPU renderer's frames and graph; --reference renders on the CPU" "$tmp/err.txt"
"$render" --reference 1 --gpus 2 --size 8x8 --out "$tmp/dg/frame" > /dev/null 2> "$tmp/err.txt"
check "--gpus with --reference exits 2" test $? -eq 2
check "--gpus with --reference explained" grep -qF -- "--reference renders on the CPU, on no device" "$tmp/err.txt"
check "nothing written for refused --dump-graph" test ! -e "$tmp/dg" -a ! -e "$tmp/g.txt" -a ! -e "$tmp/g.json"
# Numbers read one strict way (corvid/parse.h): a sign or a blank is refused like any other text.
refused "--gpus with a plus sign" "--gpus: '+2' is not a count in 1..64" --gpus +2
refused "--gpus with a blank" "--gpus: ' 2' is not a count in 1..64" --gpus " 2"
refused "--virtual-gpus with a plus sign" "--virtual-gpus: '+1' is not a count in 1..64" --virtual-gpus +1
refused "--frames with a plus sign" "--frames: '+2' is not a whole number in 1..4096" --frames +2
refused "--gpus over the device limit" "--gpus: '65' is not a count in 1..64 (the device limit)" --gpus 65
CORVID_TRANSFER_ASYNC=no "$render" --gpus 2 --adapters llvmpipe --size 8x8 --frames 1 --quiet --out "$tmp/ta/frame" 2> "$tmp/err.txt"
check "CORVID_TRANSFER_ASYNC=no exits 1" test $? -eq 1
check "CORVID_TRANSFER_ASYNC=no explained" grep -qF "CORVID_TRANSFER_ASYNC='no' is not 0 (synchronous transfers) or 1 (the default)" "$tmp/err.txt"
check "CORVID_TRANSFER_ASYNC=no: nothing written" test ! -e "$tmp/ta"
CORVID_TRANSFER_ASYNC=0 "$render" --gpus 2 --adapters llvmpipe --size 8x8 --frames 1 --quiet --out "$tmp/ta/frame" 2> "$tmp/err.txt"
check "CORVID_TRANSFER_ASYNC=0 renders" test $? -eq 0 -a -s "$tmp/ta/frame.png"
# A denormal is finite: 1e-45 is a number of stops like any other (strtof's ERANGE is not "not finite").
"$render" --size 8x8 --frames 1 --quiet --exposure 1e-45 --out "$tmp/dn/frame" 2> "$tmp/err.txt"
check "--exposure 1e-45 accepted" test $? -eq 0
refused "--exposure 1e39 (past float)" "--exposure: '1e39' is not a finite number of stops" --exposure 1e39
# A path of about 4100 characters: the message keeps the reason at its end, the path is cut in its middle.
"$render" --size 8x8 --out "$tmp/$(printf 'p%.0s' $(seq 4100))" > /dev/null 2> "$tmp/err.txt"
check "4100-character path exits 1" test $? -eq 1
check "4100-character path: the reason kept" grep -q "File name too long$" "$tmp/err.txt"
check "4100-character path: the path cut in its middle" grep -qF " [...] " "$tmp/err.txt"
# A write that fails (here a file-size limit, as a full disk; the CPU reference: no GPU driver
# writes a cache under the limit) names the file, not its hidden temporary.
(trap '' XFSZ; ulimit -f 4; exec "$render" --reference 1 --size 64x64 --quiet --out "$tmp/fz/frame") 2> "$tmp/err.txt"
check "failed write exits 1" test $? -eq 1
check "failed write names the EXR" grep -qF "$tmp/fz/frame.exr" "$tmp/err.txt"
check "failed write does not name the temporary" not grep -q "corvid-tmp" "$tmp/err.txt"
check "failed write: nothing left" test ! -e "$tmp/fz"
# Device memory running out names the texture, its size and format and its bytes (it said only
# "vkBindImageMemory 'gbuffer position': VK_ERROR_OUT_OF_DEVICE_MEMORY"). lavapipe's memory is the
# process's: a 3 GB address-space limit and a 16384x16384 frame (4 GiB G-buffer textures). A build
# that cannot start under such a limit (a sanitizer's shadow memory) skips it.
if (ulimit -v 3000000; "$render" --help > /dev/null 2>&1); then
  (ulimit -v 3000000; exec "$render" --size 16384x16384 --frames 1 --quiet --out "$tmp/oom/frame") 2> "$tmp/err.txt"
  check "device out of memory exits 1" test $? -eq 1
  check "device out of memory: the texture's size, format and bytes" \
    grep -qE "CV_ERROR_OUT_OF_MEMORY: texture '[^']+' \(16384x16384 [a-z0-9 ]+, [0-9]+ bytes\) on device 'gpu0'" "$tmp/err.txt"
  check "device out of memory: nothing written" test ! -e "$tmp/oom"
else
  echo "render_cli: this build cannot run under ulimit -v: the out-of-memory message is not checked"
fi
# SIGINT / SIGTERM during a render remove the hidden temporaries and the folders --out made,
# and exit 130 / 143 (they were left behind).
interrupt() {  # interrupt SIGNAL DIR: a long render into DIR/a/b, stopped once it renders
  "$render" --size 64x32 --frames 4096 --out "$2/a/b/frame" --stats "$2/a/s.json" --dump-graph "$2/g.txt" \
    > /dev/null 2> "$tmp/int.err" &
  local pid=$!
  for _ in $(seq 300); do grep -q "scene 'room'" "$tmp/int.err" && break; sleep 0.1; done
  kill "-$1" "$pid"
  wait "$pid"
}
interrupt INT "$tmp/int"
check "SIGINT: exit 130" test $? -eq 130
check "SIGINT: the folders --out made are gone" test ! -e "$tmp/int"
check "SIGINT: said so" grep -q "interrupted: removed the unfinished output files" "$tmp/int.err"
mkdir -p "$tmp/term"
interrupt TERM "$tmp/term"
check "SIGTERM: exit 143" test $? -eq 143
check "SIGTERM: an existing folder stays, empty" test -d "$tmp/term" -a -z "$(ls -A "$tmp/term")"

"$render" --help > "$tmp/help.txt"
check "help exits 0" test $? -eq 0
check "help lists --gpus" grep -q -- "--gpus" "$tmp/help.txt"
check "help lists --dump-graph" grep -q -- "--dump-graph" "$tmp/help.txt"
check "help lists --stats and --trace" grep -q -- "--stats FILE.*--trace FILE" <(tr -d '\n' < "$tmp/help.txt")
check "help says what --ao-samples 0 does" grep -q "0 is refused" "$tmp/help.txt"
check "help lists --shadow-samples" grep -q -- "--shadow-samples N" "$tmp/help.txt"
check "help lists --reflection-samples" grep -q -- "--reflection-samples N" "$tmp/help.txt"

echo "render_cli: $pass passed, $fail failed"
test "$fail" -eq 0
