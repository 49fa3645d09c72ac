#!/usr/bin/env bash
# Load test of `texatlas serve` on loopback: 1,000 status requests per second
# (GET /v1/jobs/{id}) for 30 s while 2 jobs run, then prints the p99 latency and the error count.
#
#   scripts/load.sh                 # builds target/release/texatlas if needed
#   TEXATLAS_BIN=path/to/texatlas RATE=1000 DURATION=30s GRID=160 scripts/load.sh
#
# Needs `hey` (Debian: apt-get install hey), curl and python3. Traffic goes to 127.0.0.1 only;
# the script starts its own server on a free port with a temp data dir and stops it at the end.
# A background loop keeps 2 jobs in flight (a generated GRID x GRID wavy grid, 2 GRID^2
# triangles) for the whole run, so workers are busy while the status requests are measured.
set -euo pipefail

repo=$(cd "$(dirname "${BASH_SOURCE[0]}")/.." && pwd)
bin="${TEXATLAS_BIN:-$repo/target/release/texatlas}"
rate="${RATE:-1000}"
duration="${DURATION:-30s}"
grid="${GRID:-160}"
conc=20
per_worker=$(( (rate + conc - 1) / conc ))

command -v hey >/dev/null || { echo "load.sh: needs hey (apt-get install hey)" >&2; exit 2; }
if [ ! -x "$bin" ]; then
  (cd "$repo" && cargo build --release --bin texatlas)
fi

work=$(mktemp -d)
"$bin" serve --bind 127.0.0.1:0 --data-dir "$work/data" --workers 2 >"$work/stdout" 2>"$work/server.log" &
server=$!
feeder=""
cleanup() {
  [ -n "$feeder" ] && kill "$feeder" 2>/dev/null || true
  kill "$server" 2>/dev/null || true
  wait "$server" 2>/dev/null || true
  rm -rf "$work"
}
trap cleanup EXIT

for _ in $(seq 100); do
  base=$(sed -n 's/^texatlas listening on //p' "$work/stdout")
  [ -n "$base" ] && break
  sleep 0.1
done
[ -n "$base" ] || { echo "load.sh: the server did not start" >&2; cat "$work/server.log" >&2; exit 1; }

python3 - "$grid" "$work/grid.glb" <<'PY'
import json, math, struct, sys
n, out = int(sys.argv[1]), sys.argv[2]
pos, idx = bytearray(), bytearray()
lo, hi = [1e30] * 3, [-1e30] * 3
for j in range(n + 1):
    for i in range(n + 1):
        x, y = i / n, j / n
        p = (x, y, 0.1 * math.sin(6 * x) * math.cos(4 * y))
        lo = [min(a, b) for a, b in zip(lo, p)]; hi = [max(a, b) for a, b in zip(hi, p)]
        pos += struct.pack("<3f", *p)
count = 0
for j in range(n):
    for i in range(n):
        v = lambda a, b: b * (n + 1) + a
        for k in (v(i, j), v(i + 1, j), v(i + 1, j + 1), v(i, j), v(i + 1, j + 1), v(i, j + 1)):
            idx += struct.pack("<I", k); count += 1
binary = bytes(pos + idx)
doc = {"asset": {"version": "2.0"}, "scene": 0, "scenes": [{"nodes": [0]}], "nodes": [{"mesh": 0}],
       "meshes": [{"primitives": [{"attributes": {"POSITION": 0}, "indices": 1}]}],
       "accessors": [{"bufferView": 0, "componentType": 5126, "count": (n + 1) ** 2, "type": "VEC3", "min": lo, "max": hi},
                     {"bufferView": 1, "componentType": 5125, "count": count, "type": "SCALAR"}],
       "bufferViews": [{"buffer": 0, "byteOffset": 0, "byteLength": len(pos)},
                       {"buffer": 0, "byteOffset": len(pos), "byteLength": len(idx)}],
       "buffers": [{"byteLength": len(binary)}]}
j = json.dumps(doc).encode(); j += b" " * (-len(j) % 4)
total = 12 + 8 + len(j) + 8 + len(binary)
with open(out, "wb") as f:
    f.write(b"glTF" + struct.pack("<II", 2, total) + struct.pack("<I", len(j)) + b"JSON" + j
            + struct.pack("<I", len(binary)) + b"BIN\0" + binary)
PY

submit() {
  curl -sf -X POST -H 'content-type: model/gltf-binary' --data-binary @"$work/grid.glb" "$base/v1/jobs" \
    | python3 -c 'import json,sys; print(json.load(sys.stdin)["id"])'
}
in_flight() {
  local n=0 s
  for s in queued running; do
    n=$(( n + $(curl -sf "$base/v1/jobs?status=$s&limit=100" | python3 -c 'import json,sys; print(len(json.load(sys.stdin)["jobs"]))') ))
  done
  echo "$n"
}

first=$(submit)
submit >/dev/null
# Keep 2 jobs in flight while hey runs.
( while true; do [ "$(in_flight)" -lt 2 ] && submit >/dev/null; sleep 0.3; done ) &
feeder=$!
for _ in $(seq 200); do
  [ "$(curl -sf "$base/v1/jobs?status=running" | python3 -c 'import json,sys; print(len(json.load(sys.stdin)["jobs"]))')" -ge 2 ] && break
  sleep 0.05
done

echo "load.sh: $rate req/s ($conc connections x $per_worker/s) for $duration on GET $base/v1/jobs/$first, 2 jobs of $((2 * grid * grid)) triangles in flight"
hey -z "$duration" -c "$conc" -q "$per_worker" "$base/v1/jobs/$first" >"$work/hey.txt"
kill "$feeder" 2>/dev/null || true
feeder=""
done_jobs=$(curl -sf "$base/v1/jobs?status=succeeded&limit=100" | python3 -c 'import json,sys; print(len(json.load(sys.stdin)["jobs"]))')

python3 - "$work/hey.txt" "$done_jobs" <<'PY'
import re, sys
text = open(sys.argv[1]).read()
def find(pattern, default="?"):
    m = re.search(pattern, text)
    return m.group(1) if m else default
codes = re.findall(r"\[(\d{3})\]\s+(\d+) responses", text)
total = sum(int(n) for _, n in codes)
ok = sum(int(n) for c, n in codes if c == "200")
errors_block = text.split("Error distribution:")[1] if "Error distribution:" in text else ""
transport_errors = sum(int(n) for n in re.findall(r"\[(\d+)\]\s", errors_block))
p99 = float(find(r"99%+ in ([0-9.]+) secs", "nan")) * 1000
p50 = float(find(r"50%+ in ([0-9.]+) secs", "nan")) * 1000
rps = find(r"Requests/sec:\s+([0-9.]+)")
errors = (total - ok) + transport_errors
print(f"requests: {total}  rate: {rps}/s  p50: {p50:.2f} ms  p99: {p99:.2f} ms  errors: {errors}  (jobs succeeded meanwhile: {sys.argv[2]})")
PY
