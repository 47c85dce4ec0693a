#!/usr/bin/env bash
# paramdds launcher with the original C++ example's interface: a parameter server (-s) or the demo client.
# Creates (or reuses) the project's virtual environment .venv on first use.
set -euo pipefail

HERE="$(cd "$(dirname "${BASH_SOURCE[0]}")" && pwd)"
VENV="${PARAMDDS_VENV:-$HERE/.venv}"

usage() {
    cat <<'USAGE'
Usage: ./run.sh [OPTIONS] [-- EXTRA PARAMDDS ARGS]

Options:
  -d, --domain       <int>   Domain ID (default: 1)
  -v, --verbosity    <int>   Log verbosity 0-5 (default: 1)
  -q, --qos-file     <str>   QoS XML path (default: qos/DDS_QOS_PROFILES.xml)
  -p, --params-file  <str>   YAML parameters file: what the server loads, what the client
                             sets (default: examples/params.yaml for the server,
                             examples/demo_set.yaml for the client: values that differ)
  -n, --node-name    <str>   Unique name for this server (default: parameter_server)
  -t, --target       <str>   Server name to send requests to (default: parameter_server)
  -s, --server               Run as parameter server
      --demo                 Start a server and run the client once against it (loopback only)
  -h, --help                 Show help

Any other argument is passed to `paramdds` (for example --once, --localhost).
USAGE
}

DOMAIN="${PARAMDDS_DOMAIN:-1}"
VERBOSITY=1
QOS_FILE="$HERE/qos/DDS_QOS_PROFILES.xml"
PARAMS_FILE=""   # -p: the one file of both roles; by default each role has its own
SERVER_FILE="$HERE/examples/params.yaml"
CLIENT_FILE="$HERE/examples/demo_set.yaml"
NODE_NAME="parameter_server"
TARGET="parameter_server"
MODE="client"
EXTRA=()

need() { [ $# -ge 2 ] || { echo "run.sh: $1 needs a value" >&2; usage >&2; exit 2; }; }
while [ $# -gt 0 ]; do
    case "$1" in
        -d|--domain) need "$@"; DOMAIN="$2"; shift 2 ;;
        -v|--verbosity) need "$@"; VERBOSITY="$2"; shift 2 ;;
        -q|--qos-file) need "$@"; QOS_FILE="$2"; shift 2 ;;
        -p|--params-file) need "$@"; PARAMS_FILE="$2"; shift 2 ;;
        -n|--node-name) need "$@"; NODE_NAME="$2"; shift 2 ;;
        -t|--target) need "$@"; TARGET="$2"; shift 2 ;;
        -s|--server) MODE="server"; shift ;;
        --demo) MODE="demo"; shift ;;
        -h|--help) usage; exit 0 ;;
        --) shift; EXTRA+=("$@"); break ;;
        *) EXTRA+=("$1"); shift ;;
    esac
done

case "$VERBOSITY" in
    0) LEVEL=error ;; 1) LEVEL=warning ;; 2) LEVEL=info ;; 3|4|5) LEVEL=debug ;;
    *) echo "run.sh: --verbosity takes 0-5, got '$VERBOSITY'" >&2; exit 2 ;;
esac

# Create or update the virtual environment; flock makes two concurrent first runs safe.
ensure_venv() {
    local stamp="$VENV/.paramdds-installed"
    if [ -x "$VENV/bin/paramdds" ] && [ "$stamp" -nt "$HERE/pyproject.toml" ]; then
        return
    fi
    mkdir -p "$(dirname "$VENV")"
    exec 9>"$VENV.lock"
    flock 9
    if ! { [ -x "$VENV/bin/paramdds" ] && [ "$stamp" -nt "$HERE/pyproject.toml" ]; }; then
        echo "run.sh: setting up $VENV (first run only)..." >&2
        [ -x "$VENV/bin/python" ] || python3 -m venv "$VENV"
        local log="$VENV/.paramdds-install.log"
        if ! { "$VENV/bin/python" -m pip install --upgrade pip \
               && "$VENV/bin/python" -m pip install -e "$HERE"; } >"$log" 2>&1; then
            cat "$log" >&2
            echo "run.sh: installing paramdds into $VENV failed (log above, kept in $log)" >&2
            exit 1
        fi
        touch "$stamp"
    fi
    flock -u 9
}
ensure_venv
if [ -n "$PARAMS_FILE" ]; then SERVER_FILE="$PARAMS_FILE"; CLIENT_FILE="$PARAMS_FILE"; fi
PARAMDDS="$VENV/bin/paramdds"
COMMON=(-d "$DOMAIN" -q "$QOS_FILE" --log-level "$LEVEL")

case "$MODE" in
    server)
        exec "$PARAMDDS" server "${COMMON[@]}" --node-name "$NODE_NAME" --params-file "$SERVER_FILE" "${EXTRA[@]}"
        ;;
    client)
        exec "$PARAMDDS" demo "${COMMON[@]}" --target "$TARGET" --params-file "$CLIENT_FILE" "${EXTRA[@]}"
        ;;
    demo)
        "$PARAMDDS" server "${COMMON[@]}" --localhost --node-name "$NODE_NAME" --params-file "$SERVER_FILE" &
        SERVER_PID=$!
        trap 'kill -TERM "$SERVER_PID" 2>/dev/null || true; wait "$SERVER_PID" 2>/dev/null || true' EXIT
        "$PARAMDDS" demo "${COMMON[@]}" --localhost --target "$NODE_NAME" --params-file "$CLIENT_FILE" --once "${EXTRA[@]}"
        ;;
esac
