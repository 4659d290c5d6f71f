#!/usr/bin/env bash
# corvid-node and corvid-render --nodes as a user runs them, on loopback:
# options are checked before anything starts; a node serves 2 lavapipe devices;
# a render on it writes the same PNG as the local render, and a second render
# uploads no scene bytes; CORVID_NODES works like --nodes; an unreachable node
# (security options that are wrong are clear errors: tests/node/security_test.c covers the rest)
# is a clear error; SIGTERM drains and the node exits 0 with a summary.
set -u
node=$1 render=$2
tmp=$(mktemp -d)
node_pid=
cleanup() { [ -n "$node_pid" ] && kill -9 "$node_pid" 2>/dev/null; rm -rf "$tmp"; }
trap cleanup EXIT
pass=0 fail=0
check() {  # check "what" command...
  local what=$1; shift
  if "$@"; then pass=$((pass + 1)); else fail=$((fail + 1)); echo "FAILED: $what" >&2; fi
}

"$node" --help > "$tmp/help.txt"
check "--help exits 0" test $? -eq 0
check "--help lists --listen" grep -q -- "--listen HOST:PORT" "$tmp/help.txt"
for bad in "--idle-timeout 0" "--idle-timeout=-5" "--max-sessions 99999999999" "--backend opengl" "--listen nocolon" \
           "--cache-size 12Q" "--cache-size 1M" "--bogus" "--mock-devices 65"; do
  # shellcheck disable=SC2086
  "$node" $bad > /dev/null 2> "$tmp/err.txt"
  check "'$bad' exits 2" test $? -eq 2
  check "'$bad' explained" test -s "$tmp/err.txt"
done
check "range is stated" grep -q "1..64" "$tmp/err.txt"
check "--help lists --token-file" grep -q -- "--token-file FILE" "$tmp/help.txt"
check "--help lists the quotas" grep -q -- "--quota-inflight N" "$tmp/help.txt"
# Security options: each mistake is a clear error before anything starts.
security_case() {  # security_case "what" "needle" args...
  local what=$1 needle=$2; shift 2
  "$node" --backend mock --cache-dir "$tmp/cache" "$@" > /dev/null 2> "$tmp/err.txt"
  check "$what exits 2" test $? -eq 2
  check "$what explained" grep -q -- "$needle" "$tmp/err.txt"
}
security_case "--token-file of a missing file" "token file '$tmp/none': No such file" --token-file "$tmp/none"
: > "$tmp/empty-token"
security_case "--token-file of an empty file" "is empty" --token-file "$tmp/empty-token"
CORVID_NODE_TOKEN_FILE="$tmp/none" security_case "CORVID_NODE_TOKEN_FILE of a missing file" "token file"
security_case "--token on the command line" "visible to every user" --token abc
security_case "non-loopback --listen without a token" "give a token with --token-file" --listen 0.0.0.0:0
security_case "--tls-cert without --tls-key" "needs --tls-key" --tls-cert "$tmp/cert.pem"
security_case "--tls-client-ca without TLS" "needs --tls-cert" --tls-client-ca "$tmp/ca.pem"
security_case "--quota-inflight over 1024" "1..1024" --quota-inflight 2000
security_case "--quota-memory not a size" "not a size" --quota-memory lots
security_case "--memory-limit not a size" "memory-limit: '0' is not a size" --memory-limit 0
check "--help lists the node-wide memory limit" grep -q -- "--memory-limit BYTES" "$tmp/help.txt"

security_case "--peers with a unix: socket" "--peers: 'unix:/tmp/x.sock': a 'unix' target" --peers node0:7700,unix:/tmp/x.sock
security_case "--peers with an empty entry" "--peers: '' is not HOST:PORT" --peers node0:7700,
check "--help lists --peers" grep -q -- "--peers HOST:PORT,..." "$tmp/help.txt"

security_case "--metrics-token-file without --metrics-port" "needs --metrics-port" --metrics-token-file "$tmp/none"
security_case "--metrics-token-file of a missing file" "token file '$tmp/none': No such file" \
  --metrics-port 0 --metrics-token-file "$tmp/none"

# A unix socket: the node names its path (it printed "unix:1", gRPC's port for it); metrics with a token say
# so; metrics on 0.0.0.0 without one are warned about.
echo "metrics-secret" > "$tmp/metrics-token"
chmod 600 "$tmp/metrics-token"
"$node" --backend mock --listen "unix:$tmp/node.sock" --cache-dir "$tmp/cache" --port-file "$tmp/unix-port" \
  --metrics-port 0 --metrics-token-file "$tmp/metrics-token" > "$tmp/unix.out" 2> "$tmp/unix.err" &
node_pid=$!
for _ in $(seq 100); do [ -s "$tmp/unix-port" ] && break; sleep 0.1; done
check "unix socket: the node prints its path" grep -q "listening on unix:$tmp/node.sock with 1 device" "$tmp/unix.out"
check "metrics token: the node says it is required" grep -q "/metrics (bearer token required)" "$tmp/unix.out"
kill -TERM "$node_pid"; wait "$node_pid"; node_pid=
rm -f "$tmp/unix-port"
"$node" --backend mock --listen 127.0.0.1:0 --cache-dir "$tmp/cache" --port-file "$tmp/unix-port" \
  --metrics-port 0 --metrics-listen 0.0.0.0 > /dev/null 2> "$tmp/open.err" &
node_pid=$!
for _ in $(seq 100); do [ -s "$tmp/unix-port" ] && break; sleep 0.1; done
check "metrics on 0.0.0.0 without a token: warned" grep -q "without --metrics-token-file" "$tmp/open.err"
kill -TERM "$node_pid"; wait "$node_pid"; node_pid=

# Numbers read one strict way (corvid/parse.h): a sign or a blank is refused.
for bad in "--idle-timeout=+5" "--max-sessions= 3" "--cache-size=+1G" "--cache-size= 12M" "--gpus=+2"; do
  timeout -k 5 20 "$node" --backend mock --cache-dir "$tmp/cache" "$bad" > /dev/null 2> "$tmp/err.txt"
  check "'$bad' exits 2" test $? -eq 2
  check "'$bad' explained" grep -qF -- "'${bad#*=}' is not" "$tmp/err.txt"
done
# FIFOs (and other files that are not regular) are refused at once: reading a token from a
# FIFO, or writing the port to one, blocked the node (with SIGTERM blocked for sigwait).
mkfifo "$tmp/fifo"
timeout -k 5 20 "$node" --backend mock --cache-dir "$tmp/cache" --token-file "$tmp/fifo" > /dev/null 2> "$tmp/err.txt"
check "--token-file FIFO exits 2 (no hang)" test $? -eq 2
check "--token-file FIFO explained" grep -qF "token file '$tmp/fifo': is not a regular file (a FIFO)" "$tmp/err.txt"
CORVID_NODE_TOKEN_FILE=$tmp/fifo timeout -k 5 20 "$node" --backend mock --cache-dir "$tmp/cache" > /dev/null 2> "$tmp/err.txt"
check "CORVID_NODE_TOKEN_FILE FIFO exits 2 (no hang)" test $? -eq 2
check "CORVID_NODE_TOKEN_FILE FIFO explained" grep -qF "is not a regular file (a FIFO)" "$tmp/err.txt"
timeout -k 5 20 "$node" --backend mock --listen 127.0.0.1:0 --cache-dir "$tmp/cache" --port-file "$tmp/fifo" > /dev/null 2> "$tmp/err.txt"
check "--port-file FIFO exits 1 (no hang)" test $? -eq 1
check "--port-file FIFO explained" grep -qF -- "--port-file: $tmp/fifo: is not a regular file (a FIFO)" "$tmp/err.txt"

# A node on a free loopback port with 2 virtual GPUs on lavapipe.
"$node" --listen 127.0.0.1:0 --port-file "$tmp/port" --adapters llvmpipe --gpus 2 --cache-dir "$tmp/cache" \
  > "$tmp/node.out" 2> "$tmp/node.err" &
node_pid=$!
for _ in $(seq 100); do [ -s "$tmp/port" ] && break; sleep 0.1; done
port=$(cat "$tmp/port" 2>/dev/null)
check "node wrote its port" test -n "$port"
check "node says where it listens" grep -q "listening on 127.0.0.1:$port with 2 devices" "$tmp/node.out"

args=(--size 96x54 --frames 2 --ao-samples 2)
"$render" --adapters llvmpipe --gpus 1 "${args[@]}" --out "$tmp/local/frame" > /dev/null 2>&1
check "local render exits 0" test $? -eq 0
"$render" --nodes "127.0.0.1:$port" "${args[@]}" --out "$tmp/remote/frame" > "$tmp/remote.txt" 2> "$tmp/remote.err"
check "remote render exits 0" test $? -eq 0
check "remote PNG equals the local one" cmp -s "$tmp/local/frame.png" "$tmp/remote/frame.png"
check "remote EXR equals the local one" cmp -s "$tmp/local/frame.exr" "$tmp/remote/frame.exr"
check "both node devices used" grep -q "node0.gpu1: columns" "$tmp/remote.txt"
check "first render uploads the scene" grep -q "node0.gpu0: .*scene data uploaded [1-9]" "$tmp/remote.txt"
CORVID_NODES="127.0.0.1:$port" "$render" "${args[@]}" --out "$tmp/again/frame" > "$tmp/again.txt" 2>&1
check "CORVID_NODES render exits 0" test $? -eq 0
check "CORVID_NODES render equals the local one" cmp -s "$tmp/local/frame.png" "$tmp/again/frame.png"
check "second render uploads nothing" grep -q "node0.gpu0: .*scene data uploaded 0.00 MB" "$tmp/again.txt"

"$render" --nodes "127.0.0.1:$port" --gpus 2 --out "$tmp/x/frame" > /dev/null 2> "$tmp/err.txt"
check "--nodes with --gpus exits 2" test $? -eq 2
check "--nodes with --gpus explained" grep -q "give one or the other" "$tmp/err.txt"
"$render" --nodes "127.0.0.1:$port,,127.0.0.1:1" --out "$tmp/x/frame" > /dev/null 2> "$tmp/err.txt"
check "empty node entry exits 2" test $? -eq 2
check "empty node entry explained" grep -q "entry 2 of" "$tmp/err.txt"
"$render" --nodes "127.0.0.1:99999" --out "$tmp/x/frame" > /dev/null 2> "$tmp/err.txt"
check "bad port exits 2" test $? -eq 2
check "bad port explained" grep -q "1..65535" "$tmp/err.txt"
# A port nothing listens on (the node's own port + nothing: take a fresh closed one).
closed=$(python3 -c 'import socket; s=socket.socket(); s.bind(("127.0.0.1",0)); print(s.getsockname()[1]); s.close()')
timeout 60 "$render" --nodes "127.0.0.1:$closed" "${args[@]}" --out "$tmp/x/frame" > /dev/null 2> "$tmp/err.txt"
check "unreachable node exits 1" test $? -eq 1
check "unreachable node named" grep -q "127.0.0.1:$closed" "$tmp/err.txt"
check "nothing written for an unreachable node" test ! -e "$tmp/x/frame.png"
# One node of two down at start: the render goes on with the one that answers and names the other (it failed
# outright).
timeout 120 "$render" --nodes "127.0.0.1:$closed,127.0.0.1:$port" "${args[@]}" --out "$tmp/half/frame" \
  > "$tmp/half.txt" 2> "$tmp/half.err"
check "one node down: render exits 0" test $? -eq 0
check "one node down: it is named" grep -q "node '127.0.0.1:$closed' did not answer, rendering without it" \
  "$tmp/half.err"
check "one node down: the other's devices render (node1.gpu0 primary)" grep -q "node1.gpu0: .*primary" "$tmp/half.err"
check "one node down: PNG equals the local one" cmp -s "$tmp/local/frame.png" "$tmp/half/frame.png"

# The client's environment, read strictly too: a FIFO token file and a timeout that is not a number.
CORVID_NODE_TOKEN_FILE=$tmp/fifo timeout -k 5 30 "$render" --nodes "127.0.0.1:$port" "${args[@]}" --out "$tmp/x/frame" \
  > /dev/null 2> "$tmp/err.txt"
check "client CORVID_NODE_TOKEN_FILE FIFO exits 1 (no hang)" test $? -eq 1
check "client CORVID_NODE_TOKEN_FILE FIFO explained" grep -qF "CORVID_NODE_TOKEN_FILE: token file '$tmp/fifo': is not a regular file (a FIFO)" "$tmp/err.txt"
CORVID_NODE_TIMEOUT_MS=abc "$render" --nodes "127.0.0.1:$port" "${args[@]}" --out "$tmp/x/frame" > /dev/null 2> "$tmp/err.txt"
check "CORVID_NODE_TIMEOUT_MS=abc exits 1" test $? -eq 1
check "CORVID_NODE_TIMEOUT_MS=abc explained" grep -qF "CORVID_NODE_TIMEOUT_MS: 'abc' is not a whole number in 1..86400000 (milliseconds)" "$tmp/err.txt"
check "nothing written for a bad client environment" test ! -e "$tmp/x/frame.png"

kill -TERM "$node_pid"
wait "$node_pid"
status=$?
node_pid=
check "SIGTERM: node exits 0" test "$status" -eq 0
check "SIGTERM: node drained" grep -q "draining" "$tmp/node.err"
check "SIGTERM: node summary (3 renders x 2 devices)" grep -q "stopped after 6 sessions" "$tmp/node.err"

# A drain that runs out: a render still going when the node gets SIGTERM with --drain-timeout 1. The node
# exits within the timeout and CV_NODE_CANCEL_GRACE_MS (1 s), plus 2 s for a loaded CI machine (it took the
# timeout twice over, and more, when it counted naps instead of watching a deadline); both sides say why.
"$node" --listen 127.0.0.1:0 --port-file "$tmp/port2" --adapters llvmpipe --gpus 1 --cache-dir "$tmp/cache" \
  --drain-timeout 1 > /dev/null 2> "$tmp/drain.err" &
node_pid=$!
for _ in $(seq 100); do [ -s "$tmp/port2" ] && break; sleep 0.1; done
timeout 120 "$render" --nodes "127.0.0.1:$(cat "$tmp/port2")" --size 32x18 --frames 4096 --ao-samples 1 \
  --out "$tmp/drain/frame" > "$tmp/drain.out" 2> "$tmp/drain-render.err" &
render_pid=$!
for _ in $(seq 300); do grep -q "frame 2/" "$tmp/drain-render.err" 2>/dev/null && break; sleep 0.1; done
start=$(date +%s%N)
kill -TERM "$node_pid"
wait "$node_pid"
status=$?
node_pid=
elapsed_ms=$(( ($(date +%s%N) - start) / 1000000 ))
wait "$render_pid"
render_status=$?
check "drain timeout: node exits 0" test "$status" -eq 0
check "drain timeout: node exits within 1 s + 1 s grace (+2 s slack): took $elapsed_ms ms" test "$elapsed_ms" -lt 4000
check "drain timeout: node log says why the session ended" \
  grep -q "ended: drain timeout (1 s) expired" "$tmp/drain.err"
check "drain timeout: render fails" test "$render_status" -eq 1
check "drain timeout: render says the node is shutting down" \
  grep -q "node shutting down: drain timeout (1 s) expired" "$tmp/drain-render.err"

echo "node_cli: $pass passed, $fail failed"
[ "$fail" -eq 0 ]
