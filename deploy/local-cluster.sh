#!/usr/bin/env bash
# Starts N corvid-node processes on this machine, on loopback, as a small local
# cluster: each serves lavapipe through --gpus virtual GPUs (default 2; 1..2),
# has its own cache directory under a temporary directory and its own metrics
# port, and runs with the options the containers use (deploy/Containerfile.*,
# compose.yaml) except for what differs on one machine: 127.0.0.1 and free ports
# instead of 0.0.0.0:7700/9400, no token or TLS, and no --peers (ports are picked
# at start: a loopback node without --peers sends partitions to loopback
# addresses only, which are exactly this cluster's). Prints the --nodes list for
# scripts/render.sh / corvid-render, then waits. Ctrl-C or SIGTERM drains every
# node (each finishes its running sessions, up to --drain-timeout) and stops them.
#
#   deploy/local-cluster.sh 2                  # then, in another shell:
#   scripts/render.sh --nodes 127.0.0.1:P0,127.0.0.1:P1
#
# Usage: deploy/local-cluster.sh N [--gpus 1|2] [--keep] [extra corvid-node options...]
#   --keep   keep the temporary directory (caches, logs) after stopping
# Environment: CORVID_NODE (the binary; default build/apps/corvid-node, built if missing),
#   LOCAL_CLUSTER_NODES_FILE (also write the --nodes list to this file).
set -uo pipefail
cd "$(dirname "$0")/.." || exit 1

usage() { sed -n '2,/^set -uo/p' "$0" | sed -e '/^set -uo/d' -e 's/^# \{0,1\}//'; }
count=${1:-}
case "$count" in
  -h|--help) usage; exit 0 ;;
  ''|*[!0-9]*) echo "local-cluster: give the number of nodes, 1..16 (see --help)" >&2; exit 2 ;;
esac
shift
if [ "$count" -lt 1 ] || [ "$count" -gt 16 ]; then
  echo "local-cluster: $count nodes: 1..16" >&2; exit 2
fi
gpus=2 keep=0 extra=()
while [ $# -gt 0 ]; do
  case "$1" in
    --gpus) gpus=${2:-}; shift 2 ;;
    --gpus=*) gpus=${1#--gpus=}; shift ;;
    --keep) keep=1; shift ;;
    *) extra+=("$1"); shift ;;
  esac
done
case "$gpus" in 1|2) ;; *) echo "local-cluster: --gpus '$gpus': 1 or 2 virtual GPUs per node" >&2; exit 2 ;; esac

node_bin=${CORVID_NODE:-build/apps/corvid-node}
if [ ! -x "$node_bin" ]; then
  echo "local-cluster: $node_bin missing: building it"
  if ! { cmake -S . -B build -G Ninja -DCMAKE_BUILD_TYPE=RelWithDebInfo >/dev/null &&
         cmake --build build --target corvid-node; }; then
    echo "local-cluster: cannot build corvid-node" >&2; exit 1
  fi
fi
export XDG_RUNTIME_DIR=${XDG_RUNTIME_DIR:-/tmp}
dir=$(mktemp -d "${TMPDIR:-/tmp}/corvid-local-cluster.XXXXXX")
pids=()
ended=()   # ended[i]: the status of node i when the wait loop saw it end by itself
stopping=0

stop_all() {   # drain every node, wait for each, report; exit status: 0 if all stopped cleanly
  stopping=1
  trap '' INT TERM
  echo "local-cluster: stopping ${#pids[@]} nodes (drain)"
  for pid in "${pids[@]}"; do kill -TERM "$pid" 2>/dev/null; done
  local status=0 i=0
  for pid in "${pids[@]}"; do
    local rc=${ended[$i]:-}
    [ -z "$rc" ] && { wait "$pid"; rc=$?; }
    [ -n "${ended[$i]:-}" ] && status=1   # ended by itself, even with status 0: not a clean stop
    if [ "$rc" -ne 0 ]; then
      echo "local-cluster: node$i exited $rc (log: $dir/node$i/node.err)" >&2; status=1
    else
      echo "local-cluster: node$i: $(tail -n 1 "$dir/node$i/node.err" 2>/dev/null)"
    fi
    i=$((i + 1))
  done
  if [ "$keep" -eq 1 ] || [ "$status" -ne 0 ]; then
    echo "local-cluster: kept $dir"
  else
    rm -rf "$dir"
  fi
  exit "$status"
}
trap stop_all INT TERM

list=()
for ((i = 0; i < count; i++)); do
  mkdir -p "$dir/node$i"
  "$node_bin" --name "node$i" --listen 127.0.0.1:0 --port-file "$dir/node$i/port" \
    --metrics-port 0 --metrics-listen 127.0.0.1 \
    --cache-dir "$dir/node$i/cache" --adapters llvmpipe --gpus "$gpus" --drain-timeout 30 \
    "${extra[@]}" > "$dir/node$i/node.out" 2> "$dir/node$i/node.err" &
  pids+=($!)
done
for ((i = 0; i < count; i++)); do
  for _ in $(seq 300); do
    [ -s "$dir/node$i/port" ] && grep -q "metrics at" "$dir/node$i/node.out" 2>/dev/null && break
    kill -0 "${pids[$i]}" 2>/dev/null || break
    sleep 0.1
  done
  if [ ! -s "$dir/node$i/port" ]; then
    echo "local-cluster: node$i did not start:" >&2
    cat "$dir/node$i/node.err" >&2
    keep=1
    stop_all
  fi
  port=$(cat "$dir/node$i/port")
  metrics=$(grep -o "http://[^ ]*/metrics" "$dir/node$i/node.out")
  echo "local-cluster: node$i on 127.0.0.1:$port (pid ${pids[$i]}), $gpus lavapipe device(s), metrics $metrics, cache $dir/node$i/cache"
  list+=("127.0.0.1:$port")
done
nodes=$(IFS=,; echo "${list[*]}")
[ -n "${LOCAL_CLUSTER_NODES_FILE:-}" ] && echo "$nodes" > "$LOCAL_CLUSTER_NODES_FILE"
echo "local-cluster: ready: --nodes $nodes"
echo "local-cluster: e.g. scripts/render.sh --nodes $nodes    (Ctrl-C here stops the cluster)"

# Wait; a node that exits on its own (crash, killed by any signal, SIGKILL included)
# stops the cluster with an error. `wait -n` returns either because a node ended
# (its status, 128+N when a signal killed it) or because a trapped signal came:
# then the trap's stop_all runs and exits, so this loop never sees that return.
# Which node ended is read from the pids themselves, not guessed from the status.
while [ "$stopping" -eq 0 ]; do
  wait -n "${pids[@]}" 2>/dev/null
  rc=$?
  [ "$stopping" -eq 1 ] && break
  for i in "${!pids[@]}"; do
    if ! kill -0 "${pids[$i]}" 2>/dev/null; then
      how="status $rc"
      [ "$rc" -gt 128 ] && how="killed by signal $((rc - 128)) ($(kill -l $((rc - 128)) 2>/dev/null))"
      echo "local-cluster: node$i (pid ${pids[$i]}) exited by itself ($how); stopping the others" >&2
      ended[$i]=$rc
      keep=1
      stop_all
    fi
  done
done
