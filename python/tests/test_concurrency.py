"""Solves release the GIL: an object busy with a solve in one thread refuses the others with a
BsarapError (not pyo3's bare RuntimeError), and Ctrl-C stops the calls that loop over many solves
between two of them, leaving the object usable."""
import json
import subprocess
import sys
import threading
import time
from pathlib import Path

import numpy as np
import pytest

import bsarap
from bsarap import BsarapError
from conftest import sphere

TESTS = Path(__file__).resolve().parent
BUSY = "is busy with a solve in another thread"
POSE = {1: ([0.0, 0.0, 0.5], bsarap.rotation([1, 0, 0], 60))}
#: Group 1 goes up by one unit over 10 s, linearly: a frame's handles say which frame it is.
RISE = json.dumps({"duration": 10.0, "fps": 100, "paths": [{"group": 1, "path": {
    "type": "keyframed", "interpolation": "linear", "keys": [
        {"time": 0.0}, {"time": 10.0, "translation": [0.0, 0.0, 1.0]}]}}]})


def while_solving(solve, obj, probes):
    """Runs `solve()` in a thread; once `obj` is seen busy (its `positions` refused), calls each
    probe and collects what it raised. Returns (solve's result, [(probe index, exception)])."""
    result, raised = {}, []
    worker = threading.Thread(target=lambda: result.update(value=solve()))
    worker.start()
    seen = False
    while worker.is_alive() and not seen:
        try:
            obj.positions
        except BsarapError:
            seen = True
        time.sleep(0.001)
    assert seen, "the solve ended before it was seen running: make it longer"
    for i, probe in enumerate(probes):
        try:
            probe()
        except Exception as e:  # noqa: BLE001: each probe's exception is checked below
            raised.append((i, e))
    alive = worker.is_alive()
    worker.join()
    assert alive, "the solve ended while the probes ran: make it longer"
    assert "value" in result, "the threaded solve raised"
    return result["value"], raised


def test_deformer_busy_in_another_thread():
    """Every method, reading or solving, of a Deformer another thread is solving with raises a
    BsarapError that says so; the threaded solve completes as it would alone, and the deformer
    serves again once it returns."""
    V, F, labels = sphere(5)
    d = bsarap.Deformer(V, F, labels, method="arap", tol=0, max_iters=500)
    timeline = bsarap.Timeline.from_json(RISE)
    targets = d.rest[d.handle_vertices]  # read before: a getter in the probe would be refused first
    probes = [
        lambda: d.solve(POSE), lambda: d.solve_targets(targets),
        lambda: d.solve_to_rest(POSE), lambda: d.settle(), lambda: d.set_stopping(1e-3, 10),
        lambda: d.reset(), lambda: d.targets(POSE), lambda: d.positions, lambda: d.base,
        lambda: d.details, lambda: d.rest, lambda: d.labels, lambda: d.handle_vertices,
        lambda: d.groups, lambda: d.method, lambda: d.energy, lambda: d.bending_length,
        lambda: d.bending_length_world, lambda: d.settle_pending, lambda: d.notice,
        lambda: bsarap.record(d, timeline, 2),
    ]
    U, raised = while_solving(lambda: d.solve(POSE), d, probes)
    assert [i for i, _ in raised] == list(range(len(probes)))
    for i, e in raised:
        assert type(e) is BsarapError, (i, e)
        assert BUSY in str(e) and "each thread its own Deformer" in str(e), (i, e)
    assert d.stats.iterations == 500
    alone = bsarap.Deformer(V, F, labels, method="arap", tol=0, max_iters=500)
    np.testing.assert_allclose(U, alone.solve(POSE), rtol=0, atol=1e-9)
    np.testing.assert_array_equal(d.positions, U)
    d.set_stopping(1e-3, 10)
    d.solve(POSE)


def test_arap_busy_in_another_thread():
    """The same for Arap: solve, energy, reset and the getters."""
    V, F, labels = sphere(5)
    b = np.nonzero(labels >= 0)[0]
    bc = V[b] + np.where(labels[b, None] == 1, [0.0, 0.3, 0.4], 0.0)
    a = bsarap.Arap(V, F, b, tol=0, max_iters=500)
    probes = [
        lambda: a.solve(bc), lambda: a.energy(V), lambda: a.reset(), lambda: a.positions,
        lambda: a.rotations, lambda: a.b,
    ]
    U, raised = while_solving(lambda: a.solve(bc), a, probes)
    assert [i for i, _ in raised] == list(range(len(probes)))
    for i, e in raised:
        assert type(e) is BsarapError and BUSY in str(e), (i, e)
        assert "each thread its own Arap" in str(e), (i, e)
    np.testing.assert_allclose(U[b], bc, atol=1e-12)
    np.testing.assert_array_equal(a.positions, U)


#: Runs CALL and sends SIGINT 0.3 s after the call is seen running (its deformer busy); the
#: handler notes whether the call still held the deformer when it ran (so the interrupt came
#: between two of its steps, with steps left: the calls look for Ctrl-C before a step, never
#: after their last). Then checks that the deformer still solves.
INTERRUPTED = r"""
import json, os, signal, sys, threading, time
import numpy as np
import bsarap
from conftest import sphere

V, F, labels = sphere(LEVEL)
pose = {1: ([0.0, 0.0, 0.5], bsarap.rotation([1, 0, 0], 60))}
d = bsarap.Deformer(V, F, labels, method="arap", tol=0, max_iters=MAX_ITERS)
timeline = bsarap.Timeline.from_json(sys.argv[1])
where = []

def on_sigint(signum, frame):
    try:
        d.positions
        where.append("after the call")
    except bsarap.BsarapError:
        where.append("inside the call")
    raise KeyboardInterrupt

def interrupt_once_running():
    while True:
        try:
            d.positions
        except Exception:  # busy: BsarapError (RuntimeError before it said so)
            break
        time.sleep(0.001)
    time.sleep(0.3)
    os.kill(os.getpid(), signal.SIGINT)

signal.signal(signal.SIGINT, on_sigint)
threading.Thread(target=interrupt_once_running, daemon=True).start()
try:
    CALL
    outcome = "returned"
except KeyboardInterrupt:
    outcome = "interrupted"
handles = d.handle_vertices
left_at = d.positions[handles].tolist()
d.set_stopping(1e-4, 50)
U = d.solve(pose)
solves = bool(np.allclose(U[handles], d.targets(pose), atol=1e-12))
print(json.dumps({"outcome": outcome, "where": where, "left_at": left_at,
                  "targets": d.targets({}).tolist(), "solves": solves,
                  "settle_pending": d.settle_pending}))
"""


def interrupted(call, level, max_iters):
    script = INTERRUPTED.replace("CALL", call).replace("LEVEL", str(level))
    script = script.replace("MAX_ITERS", str(max_iters))
    run = subprocess.run([sys.executable, "-c", script, RISE], cwd=TESTS, capture_output=True,
                         text=True, timeout=600)
    assert run.returncode == 0, run.stderr
    return json.loads(run.stdout.splitlines()[-1])


def test_ctrl_c_stops_solve_to_rest_between_steps():
    """2000 one-iteration solves never converge (tol 0): Ctrl-C while they run stops them
    between two solves; the deformer holds the last one's pose and solves again."""
    r = interrupted("d.solve_to_rest(pose, max_steps=2000)", level=5, max_iters=1)
    assert r["outcome"] == "interrupted" and r["where"] == ["inside the call"], r
    assert r["solves"] and r["settle_pending"] is False, r


def test_ctrl_c_stops_record_between_frames():
    """Recording 1000 frames stops between two frames; the deformer holds the last recorded
    frame (its handles say which: one before the last) and solves again."""
    r = interrupted("bsarap.record(d, timeline, 1000)", level=4, max_iters=5)
    assert r["outcome"] == "interrupted" and r["where"] == ["inside the call"], r
    assert r["solves"], r
    # The handles of group 1 rise linearly: frame k of 1000 has them k/999 above rest.
    rise = np.array(r["left_at"]) - np.array(r["targets"])
    assert np.allclose(rise[:, :2], 0.0, atol=1e-9), r
    frames = np.unique(np.round(rise[:, 2] * 999, 6))
    assert frames[0] == 0.0 and frames[-1] == np.round(frames[-1]), frames
    assert 1 <= frames[-1] < 999, frames


#: Exports 5000 frames with SIGINT sent 0.2 s in (the export takes seconds); the handler notes
#: whether the file was written yet (it is written whole at the end).
EXPORT_INTERRUPTED = r"""
import json, os, signal, sys, threading
import bsarap
from conftest import sphere

V, F, labels = sphere(3)
d = bsarap.Deformer(V, F, labels, method="arap", tol=0, max_iters=1)
recording = bsarap.record(d, bsarap.Timeline.from_json(sys.argv[1]), 5000)
folder = sys.argv[2]
out = os.path.join(folder, "rise.glb")
where = []

def on_sigint(signum, frame):
    where.append("after the call" if os.path.exists(out) else "inside the call")
    raise KeyboardInterrupt

signal.signal(signal.SIGINT, on_sigint)
threading.Timer(0.2, os.kill, (os.getpid(), signal.SIGINT)).start()
try:
    bsarap.export_gltf(out, recording)
    outcome = "returned"
except KeyboardInterrupt:
    outcome = "interrupted"
left = os.listdir(folder)
size = bsarap.export_gltf(out, recording, every=1000)
print(json.dumps({"outcome": outcome, "where": where, "left": left,
                  "again": size == os.path.getsize(out)}))
"""


def test_ctrl_c_stops_export_before_writing(tmp_path):
    """Exporting 5000 frames stops between two frames and writes nothing; the recording exports
    again."""
    run = subprocess.run([sys.executable, "-c", EXPORT_INTERRUPTED, RISE, str(tmp_path)],
                         cwd=TESTS, capture_output=True, text=True, timeout=600)
    assert run.returncode == 0, run.stderr
    r = json.loads(run.stdout.splitlines()[-1])
    assert r["outcome"] == "interrupted" and r["where"] == ["inside the call"], r
    assert r["left"] == [] and r["again"], r
