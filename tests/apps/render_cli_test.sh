#!/usr/bin/env bash
# corvid-render as a user runs it: a small frame on 2 virtual GPUs writes a
# valid EXR (with its AOV layers) and PNG of the right size; bad input gives a
# clear message and a non-zero exit, and writes nothing.
set -u
render=$1
tmp=$(mktemp -d)
trap 'rm -rf "$tmp"' EXIT
pass=0 fail=0
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
