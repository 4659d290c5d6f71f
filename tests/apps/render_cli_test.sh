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

"$render" --gpus 2 --adapters llvmpipe --size 96x54 --frames 2 --ao-samples 2 --out "$tmp/a/frame" > "$tmp/out.txt" 2> "$tmp/err.txt"
check "render exits 0" test $? -eq 0
check "EXR written" test -s "$tmp/a/frame.exr"
check "PNG written" test -s "$tmp/a/frame.png"
check "EXR magic" test "$(head -c 4 "$tmp/a/frame.exr" | od -An -tx1 | tr -d ' \n')" = "762f3101"
check "PNG magic" test "$(head -c 8 "$tmp/a/frame.png" | od -An -tx1 | tr -d ' \n')" = "89504e470d0a1a0a"
# PNG IHDR: width and height as big-endian u32 at bytes 16..23.
check "PNG is 96x54" test "$(dd if="$tmp/a/frame.png" bs=1 skip=16 count=8 2>/dev/null | od -An -tx1 | tr -d ' \n')" = "0000006000000036"
for layer in albedo.R normal.X depth.Z shadow.Y ao.Y; do
  check "EXR has $layer" grep -q "$layer" "$tmp/a/frame.exr"
done
check "reports both devices" grep -q "gpu1: columns" "$tmp/out.txt"

"$render" --scene "$tmp/missing.glb" --out "$tmp/b/frame" > /dev/null 2> "$tmp/err.txt"
check "missing scene exits 1" test $? -eq 1
check "missing scene names the file" grep -q "missing.glb" "$tmp/err.txt"
check "nothing written for a missing scene" test ! -e "$tmp/b/frame.exr"
check "no folder left for a failed render" test ! -e "$tmp/b"

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
"$render" --help > "$tmp/help.txt"
check "help exits 0" test $? -eq 0
check "help lists --gpus" grep -q -- "--gpus" "$tmp/help.txt"

echo "render_cli: $pass passed, $fail failed"
test "$fail" -eq 0
