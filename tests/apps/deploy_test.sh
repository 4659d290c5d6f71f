#!/usr/bin/env bash
# deploy/ as far as this machine can take it: deploy/local-cluster.sh 2 starts two
# lavapipe nodes, corvid-render renders through the --nodes list it prints, each
# node's /metrics counts the work, and SIGTERM drains and stops the cluster; a node
# killed with SIGKILL stops the others and the script exits 1. The
# files for machines we cannot run here are checked, not run: compose.yaml and the
# Kubernetes manifests must parse as YAML and have the parts deploy/README.md
# promises, and the systemd unit must pass `systemd-analyze verify` without a
# warning. A missing tool skips its check with a note.
set -u
node=$(realpath "$1") render=$(realpath "$2")
root=$(cd "$(dirname "$0")/../.." && pwd)
tmp=$(mktemp -d)
cluster_pid=
cleanup() { [ -n "$cluster_pid" ] && kill -TERM "$cluster_pid" 2>/dev/null && wait "$cluster_pid"; rm -rf "$tmp"; }
trap cleanup EXIT
pass=0 fail=0
check() {  # check "what" command...
  local what=$1; shift
  if "$@"; then pass=$((pass + 1)); else fail=$((fail + 1)); echo "FAILED: $what" >&2; fi
}

# ---- run: a local cluster of 2 nodes, a render through it --------------------------
CORVID_NODE=$node LOCAL_CLUSTER_NODES_FILE=$tmp/nodes TMPDIR=$tmp \
  bash "$root/deploy/local-cluster.sh" 2 > "$tmp/cluster.out" 2>&1 &
cluster_pid=$!
for _ in $(seq 300); do [ -s "$tmp/nodes" ] && break; sleep 0.1; done
nodes=$(cat "$tmp/nodes" 2>/dev/null)
check "cluster printed its --nodes list" grep -q "ready: --nodes $nodes" "$tmp/cluster.out"
check "two nodes in the list" test "$(echo "$nodes" | tr ',' '\n' | grep -c '^127.0.0.1:[0-9]*$')" -eq 2
"$render" --nodes "$nodes" --size 96x54 --frames 2 --out "$tmp/render/frame" > "$tmp/render.out" 2>&1
check "render through the cluster exits 0" test $? -eq 0
check "render wrote a PNG" test -s "$tmp/render/frame.png"
check "PNG signature" test "$(head -c 8 "$tmp/render/frame.png" | od -An -tx1 | tr -d ' \n')" = 89504e470d0a1a0a
check "render used both nodes" grep -q "node1.gpu1: " "$tmp/render.out"
for i in 0 1; do
  url=$(grep -o "node$i on .*metrics http://[^ ]*/metrics" "$tmp/cluster.out" | grep -o "http://.*")
  if command -v curl > /dev/null; then
    curl -sf "$url" > "$tmp/metrics$i.txt"
  else
    python3 -c 'import sys, urllib.request; sys.stdout.write(urllib.request.urlopen(sys.argv[1]).read().decode())' \
      "$url" > "$tmp/metrics$i.txt"
  fi
  check "node$i metrics: 2 sessions (its 2 devices)" grep -qx "corvid_node_sessions_total 2" "$tmp/metrics$i.txt"
  check "node$i metrics: submissions counted" grep -qE "^corvid_node_submissions_total [1-9]" "$tmp/metrics$i.txt"
  check "node$i metrics: no errors" grep -qx "corvid_node_errors_total 0" "$tmp/metrics$i.txt"
done
cluster_dir=$(sed -n 's/.*cache \(.*\)\/node0\/cache$/\1/p' "$tmp/cluster.out" | head -n 1)
check "cluster made its temp dir" test -d "$cluster_dir"
kill -TERM "$cluster_pid"
wait "$cluster_pid"
status=$?
cluster_pid=
check "SIGTERM: cluster exits 0" test "$status" -eq 0
check "SIGTERM: node0 drained and stopped" grep -q "node0: corvid-node: stopped after 2 sessions" "$tmp/cluster.out"
check "SIGTERM: node1 drained and stopped" grep -q "node1: corvid-node: stopped after 2 sessions" "$tmp/cluster.out"
check "SIGTERM: temp dir removed" test ! -e "$cluster_dir"
# A node killed by a signal (SIGKILL: no drain, no status of its own) stops the others: the
# script must not read the 128+9 of `wait -n` as its own interruption and go on waiting.
CORVID_NODE=$node LOCAL_CLUSTER_NODES_FILE=$tmp/nodes2 TMPDIR=$tmp \
  bash "$root/deploy/local-cluster.sh" 2 > "$tmp/cluster2.out" 2>&1 &
cluster_pid=$!
for _ in $(seq 300); do [ -s "$tmp/nodes2" ] && break; sleep 0.1; done
node0_pid=$(sed -n 's/.*node0 on [^ ]* (pid \([0-9]*\)).*/\1/p' "$tmp/cluster2.out")
check "second cluster: node0's pid printed" test -n "$node0_pid"
[ -n "$node0_pid" ] && kill -KILL "$node0_pid"
for _ in $(seq 200); do kill -0 "$cluster_pid" 2> /dev/null || break; sleep 0.1; done
check "SIGKILL of a node: the script stopped (within 20 s)" test "$(kill -0 "$cluster_pid" 2> /dev/null && echo up)" = ""
kill -TERM "$cluster_pid" 2> /dev/null
wait "$cluster_pid"
status=$?
cluster_pid=
check "SIGKILL of a node: the script exits 1" test "$status" -eq 1
check "SIGKILL of a node: it says which node and how" grep -q "node0 (pid $node0_pid) exited by itself (killed by signal 9 (KILL))" "$tmp/cluster2.out"
check "SIGKILL of a node: node1 drained and stopped" grep -q "node1: corvid-node: stopped after 0 sessions" "$tmp/cluster2.out"
bash "$root/deploy/local-cluster.sh" 0 > /dev/null 2> "$tmp/err.txt"
check "0 nodes refused (exit 2)" test $? -eq 2
bash "$root/deploy/local-cluster.sh" 2 --gpus 3 > /dev/null 2> "$tmp/err.txt"
check "--gpus 3 refused (exit 2)" test $? -eq 2

# ---- checked: YAML files parse and hold what the README says -----------------------
if python3 -c 'import yaml' 2> /dev/null; then
  python3 - "$root/deploy" > "$tmp/yaml.txt" 2>&1 <<'PY'
import sys, yaml
d = sys.argv[1]
compose = yaml.safe_load(open(d + "/compose.yaml"))
s = compose["services"]
assert set(s) == {"node0", "node1", "primary"}, s.keys()
nodes = s["primary"]["command"][s["primary"]["command"].index("--nodes") + 1]
for n in ("node0", "node1"):
    cmd = s[n]["command"]
    assert "--metrics-port" in cmd and "corvid_node_token" in s[n]["secrets"], n
    # Every node may send partitions to exactly the nodes the client renders on.
    assert cmd[cmd.index("--peers") + 1] == nodes, n
    assert "--metrics-token-file" in cmd, n + ": metrics on 0.0.0.0 without a token"
assert "--nodes" in s["primary"]["command"]
assert compose["secrets"]["corvid_node_token"]["file"]
for name, gpu in (("corvid-node-lavapipe.yaml", False), ("corvid-node-nvidia.yaml", True)):
    docs = [x for x in yaml.safe_load_all(open(d + "/kubernetes/" + name)) if x]
    kinds = {x["kind"]: x for x in docs}
    assert kinds["Service"]["spec"]["clusterIP"] == "None", name
    sts = kinds["StatefulSet"]
    assert sts["spec"]["serviceName"] == kinds["Service"]["metadata"]["name"], name
    pod = sts["spec"]["template"]
    assert pod["metadata"]["annotations"]["prometheus.io/scrape"] == "true", name
    c = pod["spec"]["containers"][0]
    # The probes (plaintext) use the plaintext health port next to the TLS port.
    assert "--health-listen" in c["args"] and "0.0.0.0:7701" in c["args"], name
    assert "--metrics-token-file" in c["args"], name + ": metrics on 0.0.0.0 without a token"
    assert c["readinessProbe"]["grpc"]["port"] == 7701 and c["livenessProbe"]["grpc"]["port"] == 7701, name
    assert ("nvidia.com/gpu" in c["resources"]["limits"]) == gpu, name
    # --peers: one stable pod name per replica (the names in the header's --nodes).
    peers = c["args"][c["args"].index("--peers") + 1].split(",")
    assert peers == ["corvid-node-%d.corvid-node.corvid.svc.cluster.local:7700" % i
                     for i in range(sts["spec"]["replicas"])], name
    secrets = {v["secret"]["secretName"] for v in pod["spec"]["volumes"] if "secret" in v}
    assert secrets == {"corvid-node-token", "corvid-node-tls"}, name
    print(name, "ok:", ", ".join(x["kind"] for x in docs))
print("compose.yaml ok")
PY
  check "YAML files parse and hold the promised parts" test $? -eq 0
  cat "$tmp/yaml.txt"
else
  echo "deploy_test: python3-yaml missing: YAML checks skipped (apt-get install python3-yaml)"
fi

# ---- checked: no file publishes metrics on 0.0.0.0 without a token -------------------
for f in "$root"/deploy/Containerfile.*; do
  if grep -q -- '"--metrics-listen", "0.0.0.0"' "$f"; then
    check "$(basename "$f"): metrics on 0.0.0.0 need --metrics-token-file" grep -q -- '--metrics-token-file' "$f"
  fi
done

# ---- checked: the systemd unit -------------------------------------------------------
if command -v systemd-analyze > /dev/null; then
  mkdir -p "$tmp/unit"
  # verify wants ExecStart's program to exist: point it at the one just built.
  sed "s|/usr/local/bin/corvid-node|$node|" "$root/deploy/systemd/corvid-node.service" > "$tmp/unit/corvid-node.service"
  systemd-analyze verify "$tmp/unit/corvid-node.service" > "$tmp/verify.txt" 2>&1
  check "systemd-analyze verify exits 0" test $? -eq 0
  check "systemd-analyze verify says nothing (no unknown keys)" test ! -s "$tmp/verify.txt"
  cat "$tmp/verify.txt"
else
  echo "deploy_test: systemd-analyze missing: unit not verified (apt-get install systemd)"
fi

echo "deploy: $pass passed, $fail failed"
[ "$fail" -eq 0 ]
