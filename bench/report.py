#!/usr/bin/env python3
"""Turns bench/results/*.json (from bench/run_all.sh) into the Markdown tables of BENCHMARKS.md
and the Fig. 10 plot bench/fig10.png:
    python3 bench/report.py > bench/results/tables.md
"""
import json
import os

import numpy as np

R = "bench/results"
PAPER = {  # Sun et al. 2017, Table 1: SPF ARAP, SPF BS-ARAP, speedup
    "knight": (0.0568, 0.0056, 10.1),
    "cheburashka": (0.733, 0.0284, 25.8),
    "bunny": (3.207, 0.0987, 32.5),
    "armadillo": (3.830, 0.108, 35.8),
    "dragon": (10.224, 0.261, 39.2),  # Tyra, 100k vertices; our dragon is a 50k stand-in
}
ORDER = ["knight", "cheburashka", "decimated-max", "bunny", "armadillo", "dragon"]
MESH = {
    "knight": "../shared/meshes/decimated-knight.off --handles ../shared/meshes/decimated-knight-selection.dmat",
    "cheburashka": "../shared/meshes/cheburashka.off --handles bench/handles/cheburashka.json",
    "decimated-max": "../shared/meshes/decimated-max.obj --handles ../shared/meshes/decimated-max-selection.dmat",
    "bunny": "../shared/meshes/bunny.off --handles bench/handles/bunny.json",
    "armadillo": "../shared/meshes/armadillo.obj --handles bench/handles/armadillo.json",
    "dragon": "../shared/meshes/dragon.obj --handles bench/handles/dragon.json",
}


def load(name):
    p = os.path.join(R, name)
    if not os.path.exists(p) or os.path.getsize(p) == 0:
        return None  # not run, or still running
    with open(p) as f:
        return json.load(f)


def table():
    print("| mesh | V | frames | method | precompute ms | ms/iter | local | rhs | solve | energy "
          "| iters/frame | s/frame | FPS | final E | frames at cap | speedup vs ARAP (s/frame) "
          "| iteration ratio |")
    print("|---|---:|---:|---|---:|---:|---:|---:|---:|---:|---:|---:|---:|---:|---:|---:|---:|")
    for n in ORDER:
        j = load(n + ".json")
        if j is None:
            continue
        ar = j["methods"].get("arap")
        for m, r in j["methods"].items():
            if "error" in r:
                print(f"| {n} | {j['vertices']} | {j['frames']} | {m} | failed: {r['error']} |"
                      + " |" * 12)
                continue
            sp = it = ""
            if ar and "error" not in ar and m != "arap":
                sp = f"{ar['seconds_per_frame'] / r['seconds_per_frame']:.2f}×"
                it = f"{ar['iterations_per_frame'] / r['iterations_per_frame']:.2f}×"
            print(f"| {n} | {j['vertices']} | {j['frames']} | {m} | {r['precompute_ms']:.1f} "
                  f"| {r['ms_per_iteration']:.2f} | {r['local_ms_per_iteration']:.2f} "
                  f"| {r['rhs_ms_per_iteration']:.2f} | {r['solve_ms_per_iteration']:.2f} "
                  f"| {r['energy_ms_per_iteration']:.2f} | {r['iterations_per_frame']:.1f} "
                  f"| {r['seconds_per_frame']:.4f} | {r['fps']:.1f} | {r['final_energy']:.3e} "
                  f"| {r['frames_at_cap']} | {sp} | {it} |")
    print()
    print("| mesh | paper SPF ARAP | paper SPF BS-ARAP | paper speedup | our SPF ARAP | our SPF BS-ARAP "
          "| our speedup | our iters/frame ARAP → BS-ARAP |")
    print("|---|---:|---:|---:|---:|---:|---:|---|")
    for n in ORDER:
        j = load(n + ".json")
        if j is None or n not in PAPER:
            continue
        a, b = j["methods"].get("arap", {}), j["methods"].get("bsarap", {})
        pa, pb, ps = PAPER[n]
        if "error" in a or "error" in b or not a or not b:
            def spf(r):
                if "error" in r:
                    return "failed (see below)"
                return f"{r['seconds_per_frame']:.4f}" if r else "n/a"
            print(f"| {n} | {pa} | {pb} | {ps}× | {spf(a)} | {spf(b)} | | |")
            continue
        print(f"| {n} | {pa} | {pb} | {ps}× | {a['seconds_per_frame']:.4f} | {b['seconds_per_frame']:.4f} "
              f"| {a['seconds_per_frame'] / b['seconds_per_frame']:.2f}× "
              f"| {a['iterations_per_frame']:.1f} → {b['iterations_per_frame']:.1f} |")
    print()
    print("| mesh | libigl ms/iter | our ARAP ms/iter | libigl / ours (ms/iter) | libigl iters/frame* "
          "| our ARAP iters/frame* | libigl s/frame* | our ARAP s/frame* |")
    print("|---|---:|---:|---:|---:|---:|---:|---:|")
    for n in ORDER:
        j, g = load(n + ".json"), load(n + ".libigl.json")
        if j is None or g is None or "arap" not in j["methods"]:
            continue
        a = j["methods"]["arap"]
        # *: frames 1..F-1. Frame F is the rest pose again, which our solvers return exactly
        # without iterating while libigl iterates towards it; s/frame* = ms/iter × iters/frame*.
        gi, ai = np.mean(g["iterations"][:-1]), np.mean(a["iterations"][:-1])
        print(f"| {n} | {g['ms_per_iteration']:.2f} | {a['ms_per_iteration']:.2f} "
              f"| {g['ms_per_iteration'] / a['ms_per_iteration']:.2f}× | {gi:.1f} | {ai:.1f} "
              f"| {g['ms_per_iteration'] * gi / 1e3:.4f} | {a['ms_per_iteration'] * ai / 1e3:.4f} |")
    print()
    print("\\* frames 1 to F−1: frame F is the rest pose, which our solvers return exactly without "
          "iterating (libigl iterates); s/frame\\* = ms/iter × iters/frame\\*.")
    print()
    print("Commands (from the repository root):")
    print()
    for n in ORDER:
        j = load(n + ".json")
        if j is None:
            continue
        print(f"- {n}: `target/release/bsarap bench {MESH[n]} --frames {j['frames']} --tol 1e-4 "
              f"--max-iters 100 --anderson 5` and `python3 bench/libigl_reference.py {MESH[n]} "
              f"--frames {j['frames']} --tol 1e-4 --max-iters 100`")


def fig10():
    j = load("fig10.json")
    if j is None:
        return
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    fig, ax = plt.subplots(1, 2, figsize=(11, 4))
    rows = []
    for m, r in j["methods"].items():
        if "error" in r:
            continue
        e = np.array(r["first_frame_normalized_energies"])  # E_k / E_0
        if len(e) < 2:
            continue
        star = e[-1]
        rel = (e - star) / (e[0] - star)  # 1 at the start, 0 at the (1000-iteration) optimum
        ax[0].semilogy(e, label=m)
        ax[1].semilogy(np.maximum(rel, 1e-16), label=m)
        row = [m, f"{star:.4f}"]
        for th in (0.95, 0.9, 0.8):
            k = np.nonzero(e <= th)[0]
            row.append(str(k[0]) if len(k) else f">{len(e) - 1}")
        for th in (1e-1, 1e-2, 1e-3):
            k = np.nonzero(rel <= th)[0]
            row.append(str(k[0]) if len(k) else f">{len(e) - 1}")
        rows.append(row)
    ax[0].set(xlabel="iteration", ylabel="E / E0 (E0: Laplacian-editing fit)",
              title="decimated-max: energy normalized to 0–1 (paper's Fig. 10)")
    ax[1].set(xlabel="iteration", ylabel="(E − E*) / (E0 − E*)",
              title="distance to the converged energy E* (1000 iterations)")
    for a in ax:
        a.grid(True, which="both", alpha=0.3)
        a.legend()
    fig.tight_layout()
    fig.savefig("bench/fig10.png", dpi=110)
    print()
    print("| method | E*/E0 | iters to E/E0 ≤ 0.95 | ≤ 0.9 | ≤ 0.8 | iters to (E−E*)/(E0−E*) ≤ 1e-1 | ≤ 1e-2 | ≤ 1e-3 |")
    print("|---|---:|---:|---:|---:|---:|---:|---:|")
    for r in rows:
        print("| " + " | ".join(r) + " |")


def pairs():
    """bench/run_all.sh pairs: ours and libigl alternated on armadillo, one row per pair."""
    rows = []
    for k in range(1, 100):
        j, g = load(f"pairs/armadillo.{k}.json"), load(f"pairs/armadillo.{k}.libigl.json")
        if j is None or g is None:
            break
        a = j["methods"].get("arap")
        if a is None or "error" in a:
            continue
        rows.append((k, a, g))
    if not rows:
        return
    print()
    print("| pair | our ms/iter | local | rhs | solve | libigl ms/iter | libigl / ours "
          "| our iters/frame* | libigl iters/frame* |")
    print("|---:|---:|---:|---:|---:|---:|---:|---:|---:|")
    for k, a, g in rows:
        print(f"| {k} | {a['ms_per_iteration']:.2f} | {a['local_ms_per_iteration']:.2f} "
              f"| {a['rhs_ms_per_iteration']:.2f} | {a['solve_ms_per_iteration']:.2f} "
              f"| {g['ms_per_iteration']:.2f} | {g['ms_per_iteration'] / a['ms_per_iteration']:.2f}× "
              f"| {np.mean(a['iterations'][:-1]):.1f} | {np.mean(g['iterations'][:-1]):.1f} |")
    print()
    print("\\* frames 1 to F−1 (frame F is the rest pose; see the libigl table).")


if __name__ == "__main__":
    table()
    fig10()
    pairs()
