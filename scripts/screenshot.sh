#!/usr/bin/env bash
# Starts the real editor binary under Xvfb (software Vulkan: lavapipe), waits until it has drawn
# a solved frame, saves a screenshot and asks the editor to quit (Ctrl+Q), checking it exits 0.
#
#   scripts/screenshot.sh [OUT.png] [MESH]
#
# Needs: xvfb mesa-vulkan-drivers libvulkan1 imagemagick xdotool (see TOOLCHAIN notes).
# BIN overrides the binary (default: target/debug/bsarap, built if missing).
set -euo pipefail
cd "$(dirname "$0")/.."

OUT=${1:-target/screenshots/editor.png}
MESH=${2:-}
BIN=${BIN:-target/debug/bsarap}
DISPLAY_NUM=${DISPLAY_NUM:-:99}
TIMEOUT=${TIMEOUT:-120}

if [[ ! -x "$BIN" ]]; then
  cargo build -p app
fi
mkdir -p "$(dirname "$OUT")"
LOG=$(mktemp)
RUNTIME=$(mktemp -d)
chmod 700 "$RUNTIME"

Xvfb "$DISPLAY_NUM" -screen 0 1280x800x24 -nolisten tcp >/dev/null 2>&1 &
XVFB_PID=$!
APP_PID=
cleanup() {
  [[ -n "$APP_PID" ]] && kill "$APP_PID" 2>/dev/null || true
  kill "$XVFB_PID" 2>/dev/null || true
  rm -rf "$RUNTIME"
}
trap cleanup EXIT
sleep 1

export DISPLAY=$DISPLAY_NUM XDG_RUNTIME_DIR=$RUNTIME
# Recent files and autosaves of this run stay in the temporary folder.
export BSARAP_CONFIG_DIR=${BSARAP_CONFIG_DIR:-$RUNTIME/config}
unset WAYLAND_DISPLAY
RUST_LOG=${RUST_LOG:-warn} "$BIN" edit ${MESH:+"$MESH"} >"$LOG" 2>&1 &
APP_PID=$!

# Wait for the editor to report its first solved frame on screen.
start=$SECONDS
until grep -q "first solved frame displayed" "$LOG"; do
  if ! kill -0 "$APP_PID" 2>/dev/null; then
    echo "the editor exited early:" >&2; cat "$LOG" >&2; exit 1
  fi
  if (( SECONDS - start > TIMEOUT )); then
    echo "no solved frame after ${TIMEOUT}s:" >&2; cat "$LOG" >&2; exit 1
  fi
  sleep 0.5
done
sleep "${SETTLE:-3}"   # a few more frames (software rendering is slow)
import -window root "$OUT"
echo "screenshot: $OUT"

# Quit through the editor's own shortcut and check the exit status.
WID=$(xdotool search --name "BS-ARAP editor" | head -n1)
xdotool windowfocus --sync "$WID" 2>/dev/null || true
xdotool key --clearmodifiers ctrl+q
for _ in $(seq 1 40); do
  kill -0 "$APP_PID" 2>/dev/null || break
  sleep 0.25
done
if kill -0 "$APP_PID" 2>/dev/null; then
  echo "the editor did not exit after Ctrl+Q" >&2; exit 1
fi
wait "$APP_PID"; status=$?
APP_PID=
echo "editor exited with status $status"
exit "$status"
