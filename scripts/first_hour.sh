#!/usr/bin/env bash
# A new user's first hour in a real window (issue 46): the editor binary under Xvfb with no
# window manager and no desktop portal (the in-app file dialog, forced by the preference), driven
# by real X input (xdotool): paint the active group with a brush stroke, pose it with G Y 0.1
# Enter, shorten the timeline and record it, export glTF through the in-app dialog, save the
# scene (Ctrl+S, in-app dialog), reopen it (Ctrl+O, in-app dialog), take a screenshot and quit.
# Then the files are checked: the .glb is binary glTF, the scene has the painted labels and the
# pose, and the editor reports that it opened the saved scene.
#
#   scripts/first_hour.sh [OUT_DIR]
#
# Needs what scripts/screenshot.sh needs (xvfb, lavapipe, imagemagick, xdotool) and python3.
# Widget positions are those of the 1280×800 window at UI scale 1 (the default layout).
set -euo pipefail
cd "$(dirname "$0")/.."

OUT=$(realpath -m "${1:-target/first_hour}")
BIN=${BIN:-target/debug/bsarap}
DISPLAY_NUM=${DISPLAY_NUM:-:98}
TIMEOUT=${TIMEOUT:-240}

[[ -x "$BIN" ]] || cargo build -p app
rm -rf "$OUT"; mkdir -p "$OUT"
LOG=$OUT/editor.log
RUNTIME=$(mktemp -d); chmod 700 "$RUNTIME"
CONFIG=$RUNTIME/config; mkdir -p "$CONFIG"
echo '{"in_app_file_dialog": true}' >"$CONFIG/prefs.json"

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
# No D-Bus session and no portal: the system dialog cannot be shown.
export DISPLAY=$DISPLAY_NUM XDG_RUNTIME_DIR=$RUNTIME BSARAP_CONFIG_DIR=$CONFIG
unset WAYLAND_DISPLAY DBUS_SESSION_BUS_ADDRESS
RUST_LOG=${RUST_LOG:-warn} "$BIN" edit >"$LOG" 2>&1 &
APP_PID=$!

# Waits until the log has a line matching $1 (after line $2 of the log, default 0).
wait_for() {
  local start=$SECONDS skip=${2:-0}
  until tail -n +"$((skip + 1))" "$LOG" | grep -q -- "$1"; do
    if ! kill -0 "$APP_PID" 2>/dev/null; then
      echo "the editor exited while waiting for \"$1\":" >&2; cat "$LOG" >&2; exit 1
    fi
    if (( SECONDS - start > TIMEOUT )); then
      echo "no \"$1\" after ${TIMEOUT}s:" >&2; import -window root "$OUT/stuck.png"; cat "$LOG" >&2
      exit 1
    fi
    sleep 0.5
  done
}
lines() { wc -l <"$LOG"; }
shot() { import -window root "$OUT/$1.png"; }
key() { xdotool key --clearmodifiers "$@"; sleep 0.7; }
click() { xdotool mousemove "$1" "$2"; sleep 0.3; xdotool click 1; sleep 0.7; }
# Types a full path into the open in-app dialog's file name field and confirms it.
choose() {
  sleep 1.5
  shot "dialog-$(basename "$1")"
  click "$DIALOG_FIELD_X" "$DIALOG_FIELD_Y"
  key ctrl+a
  xdotool type --delay 20 "$1"; sleep 0.5
  key Return
}
DIALOG_FIELD_X=${DIALOG_FIELD_X:-560}
DIALOG_FIELD_Y=${DIALOG_FIELD_Y:-565}

wait_for "first solved frame displayed"
sleep 2
WID=$(xdotool search --name "BS-ARAP editor" | head -n1)
xdotool windowfocus --sync "$WID" 2>/dev/null || true
shot 1-opened

# Paint: a brush stroke of the active group (group 0) across the body.
xdotool mousemove 430 330; sleep 0.3
xdotool mousedown 1; sleep 0.3
for x in 450 470 490 510 530 550; do xdotool mousemove "$x" 335; sleep 0.15; done
xdotool mouseup 1; sleep 1
shot 2-painted

# Pose: G (pose tool), G (move), Y (along Y), 0.1, Enter.
key g; key g; key y; xdotool type --delay 50 "0.1"; sleep 0.3; key Return
sleep 2
shot 3-posed

# A short timeline (0.2 s at 30 fps: 7 frames), then Record.
click 357 699
key ctrl+a; xdotool type --delay 30 "0.2"; key Return
n=$(lines); click 60 722
wait_for "status: recorded" "$n"
shot 4-recorded

# Export glTF… (File menu) through the in-app dialog.
click 25 12
shot 5-file-menu
click 56 204
n=$(lines); choose "$OUT/walk.glb"
wait_for "status: wrote" "$n"

# Save (Ctrl+S asks where: no scene file yet), then open it again (Ctrl+O).
n=$(lines); key ctrl+s; choose "$OUT/posed.json"
wait_for "status: saved" "$n"
n=$(lines); key ctrl+o; choose "$OUT/posed.json"
wait_for "first solved frame displayed\|status: handles from posed.json" "$n"
sleep 3
shot 6-reopened

key ctrl+q
for _ in $(seq 1 40); do kill -0 "$APP_PID" 2>/dev/null || break; sleep 0.25; done
if kill -0 "$APP_PID" 2>/dev/null; then echo "the editor did not exit after Ctrl+Q" >&2; exit 1; fi
wait "$APP_PID"; APP_PID=

python3 - "$OUT" <<'EOF'
import json, struct, sys
out = sys.argv[1]
glb = open(f"{out}/walk.glb", "rb").read()
assert glb[:4] == b"glTF", "walk.glb is not binary glTF"
n = struct.unpack("<I", glb[12:16])[0]
doc = json.loads(glb[20:20 + n])
targets = len(doc["meshes"][0]["primitives"][0]["targets"])
assert targets == 7, f"{targets} morph targets, expected 7"
scene = json.load(open(f"{out}/posed.json"))
labels = scene["handles"]["labels"]
painted = sum(1 for l in labels if l == 0)
# creature.dmat gives group 0 465 vertices; the brush stroke adds the body under it.
assert painted > 465, f"group 0 has {painted} vertices: the stroke painted nothing"
paths = {p["group"]: p["path"] for p in scene["timeline"]["paths"]}
key = paths[0]["keys"][0]
assert abs(key["translation"][1] - 0.1) < 1e-9 and abs(key["translation"][0]) < 1e-9, key
print(f"walk.glb: {len(glb)} bytes, {targets} morph targets; posed.json: group 0 has "
      f"{painted} vertices, moved by {key['translation']}")
EOF
grep -q "status: handles from posed.json" "$LOG" || { echo "the saved scene was not reopened" >&2; exit 1; }
echo "first hour: all steps done; screenshots and files in $OUT"
