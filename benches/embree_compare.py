#!/usr/bin/env python3
"""Exactness and speed of `penumbra trace-rays` against Embree.

For every model and ray set this script writes the rays to a RAYS.f32 file,
runs `penumbra trace-rays --json` on each requested device, traces the same
rays with native Embree (`../shared/tools/embree_bench --modes rays --hits`,
single thread), and compares the closest hits ray by ray.

Ray sets per model:
  random   N rays; origins uniform in the model's bounding box scaled by 3
           about its centre, directions towards uniform points inside the box
           (not normalised: t = 1 at the target point). Most rays are aimed
           at the model and some start inside its box.
  primary  W x H primary rays of the contract's default camera (eye at
           c + 2.5 r u, u = normalize(0.3, 0.4, 1.0), r = half the box
           diagonal, up +y, vertical fov 45 degrees, row 0 at the top,
           pixel centres at half-integer offsets, unit directions).

Embree: the native tool (Embree 3 C API, -O3 -march=native) calls
rtcIntersect1 once per ray (single-ray API, no packets or streams, one
thread), with tnear = 0 and tfar = +inf, default scene flags; it builds the
BVH (one thread, high quality) before timing and reports the best of
--repeat traversals. The Python `embreex` bindings used before paid per-call
overhead and understated Embree; `benches/embree_table.py` has the speed
comparison of every workload (packets, AO, build), this script the
exactness of hits. Without the tool (libembree-dev, g++) it says so and
exits 0.

Checks (each model x ray set x device): hit/miss agreement >= 99.99 % and
relative t error at the 99.9th percentile <= 1e-4. Exit code 1 if any check
fails, 2 on a usage or run error.

Also reported: penumbra-only / Embree-only hit counts (a few such rays,
with a float64 check of the triangle each side reported, are printed and kept
in --json), the fraction of both-hit rays whose triangle differs (ties: shared
edges, coincident or duplicate triangles) with the largest relative t gap
among them, the t difference as a distance over the box diagonal (relative t
error is ill-conditioned for hits just in front of the origin and for grazing
hits), and, with several devices, how many hits differ bit for bit between
them. A device other than cpu that fails (no adapter) is reported as skipped.

Only numpy and the native tool are needed. Commands run are printed to stderr, the
Markdown table to stdout; --json writes every number.
"""

from __future__ import annotations

import argparse
import json
import os
import shlex
import subprocess
import sys
import tempfile
import time
from pathlib import Path

import numpy as np

REPO = Path(__file__).resolve().parent.parent
DEFAULT_MODELS = ["stanford-bunny", "dragon100k", "kitchen"]
MISS = 0xFFFFFFFF
AGREEMENT_MIN = 0.9999
T_ERR_P999_MAX = 1e-4


def log(msg: str) -> None:
    print(msg, file=sys.stderr, flush=True)


# --------------------------------------------------------------------------
# OBJ
# --------------------------------------------------------------------------


def load_obj(path: Path) -> tuple[np.ndarray, np.ndarray]:
    """Vertices (float32, V x 3) and triangles (int64, T x 3) of an OBJ file.

    Same numbering as penumbra's loader: `#` starts a comment, `v x y z`
    lines are vertices (extra components ignored), `f` lines are faces whose
    tokens are `v`, `v/vt`, `v//vn` or `v/vt/vn` with 1-based or negative
    (relative to the vertices read so far) indices, fan-triangulated in file
    order (v0,v1,v2), (v0,v2,v3), ... across all objects and groups.
    Everything else is ignored.
    """
    vertices: list[float] = []
    tris: list[int] = []
    nv = 0
    with open(path, "rb") as f:
        text = f.read().decode("utf-8", errors="replace")
    for line_no, raw in enumerate(text.splitlines(), 1):
        if "#" in raw:
            raw = raw.split("#", 1)[0]
        tokens = raw.split()
        if not tokens:
            continue
        key = tokens[0]
        if key == "v":
            if len(tokens) < 4:
                raise ValueError(f"{path}:{line_no}: vertex needs 3 coordinates")
            vertices.extend((float(tokens[1]), float(tokens[2]), float(tokens[3])))
            nv += 1
        elif key == "f":
            face = []
            for tok in tokens[1:]:
                i = int(tok.split("/", 1)[0])
                if i > 0:
                    face.append(i - 1)
                elif i < 0:
                    face.append(nv + i)
                else:
                    raise ValueError(f"{path}:{line_no}: face index 0")
            if len(face) < 3:
                raise ValueError(f"{path}:{line_no}: face with fewer than 3 vertices")
            v0 = face[0]
            for k in range(2, len(face)):
                tris.extend((v0, face[k - 1], face[k]))
    # float() then float32 is decimal -> f64 -> f32; penumbra parses straight
    # to f32. The two can differ only for decimals within 2^-53 (relative) of
    # an f32 rounding midpoint, which short OBJ decimals never are.
    v = np.asarray(vertices, dtype=np.float64).astype(np.float32).reshape(-1, 3)
    t = np.asarray(tris, dtype=np.int64).reshape(-1, 3)
    if len(t) == 0:
        raise ValueError(f"{path}: no faces")
    if t.min() < 0 or t.max() >= len(v):
        raise ValueError(f"{path}: face index out of range")
    return v, t


def used_bounds(v: np.ndarray, t: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Bounds of the vertices that triangles use (as penumbra's Mesh::bounds)."""
    used = v[np.unique(t)]
    return used.min(axis=0).astype(np.float64), used.max(axis=0).astype(np.float64)


# --------------------------------------------------------------------------
# Rays
# --------------------------------------------------------------------------


def random_rays(lo: np.ndarray, hi: np.ndarray, n: int, rng: np.random.Generator) -> np.ndarray:
    c = 0.5 * (lo + hi)
    half = 0.5 * (hi - lo)
    origins = (c + (rng.random((n, 3)) * 2.0 - 1.0) * 3.0 * half).astype(np.float32)
    targets = (lo + rng.random((n, 3)) * (hi - lo)).astype(np.float32)
    dirs = targets - origins
    # A zero direction is invalid in RAYS.f32; redraw the (measure-zero) cases.
    bad = ~np.any(dirs != 0, axis=1)
    while bad.any():
        k = int(bad.sum())
        targets[bad] = (lo + rng.random((k, 3)) * (hi - lo)).astype(np.float32)
        dirs[bad] = targets[bad] - origins[bad]
        bad = ~np.any(dirs != 0, axis=1)
    return np.concatenate([origins, dirs], axis=1).astype(np.float32)


def primary_rays(lo: np.ndarray, hi: np.ndarray, w: int, h: int) -> np.ndarray:
    """The contract's default camera (see penumbra::scene::Camera)."""
    c = 0.5 * (lo + hi)
    r = 0.5 * float(np.linalg.norm(hi - lo))
    u = np.array([0.3, 0.4, 1.0])
    u /= np.linalg.norm(u)
    eye = c + 2.5 * r * u
    forward = (c - eye) / np.linalg.norm(c - eye)
    world_up = np.array([0.0, 1.0, 0.0])
    if np.linalg.norm(np.cross(forward, world_up)) ** 2 < 1e-12:
        world_up = np.array([0.0, 0.0, 1.0])
    right = np.cross(forward, world_up)
    right /= np.linalg.norm(right)
    up = np.cross(right, forward)
    tan_half = np.tan(0.5 * np.radians(45.0))
    aspect = w / h
    py = (1.0 - 2.0 * (np.arange(h) + 0.5) / h) * tan_half
    px = (2.0 * (np.arange(w) + 0.5) / w - 1.0) * tan_half * aspect
    PY, PX = np.meshgrid(py, px, indexing="ij")  # row-major, row 0 on top
    d = forward + PX[..., None] * right + PY[..., None] * up
    d = d.reshape(-1, 3)
    d /= np.linalg.norm(d, axis=1, keepdims=True)
    o = np.broadcast_to(eye, d.shape)
    return np.concatenate([o, d], axis=1).astype(np.float32)


# --------------------------------------------------------------------------
# Embree
# --------------------------------------------------------------------------


TOOL_DIR = Path(os.environ.get("EMBREE_BENCH_DIR", REPO.parent / "shared" / "tools" / "embree_bench"))
TOOL = REPO / "target" / "embree_bench" / "embree_bench"


def embree_tool() -> Path | None:
    """The native embree_bench (built with its build.sh if needed), or None."""
    if not TOOL.is_file() and (TOOL_DIR / "build.sh").is_file() \
            and Path("/usr/include/embree3/rtcore.h").is_file():
        subprocess.run(["sh", str(TOOL_DIR / "build.sh")], env=dict(os.environ, OUT=str(TOOL.parent)),
                       stdout=subprocess.PIPE, stderr=subprocess.PIPE)
    return TOOL if TOOL.is_file() else None


class Embree:
    """Native Embree through `embree_bench --modes rays` (rtcIntersect1 per
    ray, one thread, tnear 0, tfar +inf), on the mesh file itself: the tool
    reads the OBJ with penumbra's triangle order and writes hits in
    penumbra's format. It replaced the Python `embreex` bindings, whose
    per-call overhead understated Embree."""

    def __init__(self, mesh: Path, work: Path):
        self.tool = embree_tool()
        if self.tool is None:
            raise RuntimeError("embree_bench is not available (apt-get install -y libembree-dev g++)")
        self.mesh, self.work = mesh, work
        self.flags = "default scene flags"
        self.build_ms = float("nan")
        self.version = "?"

    def trace(self, rays: np.ndarray, repeat: int = 1) -> dict:
        """Closest hits; the time is the fastest of `repeat` runs."""
        rays_path = self.work / "embree.rays.f32"
        hits_path = self.work / "embree.hits.bin"
        rays.astype("<f4").tofile(rays_path)
        cmd = [str(self.tool), str(self.mesh), "--modes", "rays", "--rays", str(rays_path),
               "--hits", str(hits_path), "--reps", str(max(1, repeat))]
        log("$ " + shlex.join(cmd))
        out = subprocess.run(cmd, check=True, stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True).stdout
        lines = [json.loads(l) for l in out.splitlines() if l.startswith("{")]
        build = next(l for l in lines if l["mode"] == "build")
        run = next(l for l in lines if l["mode"] == "rays")
        self.build_ms, self.version = build["build_ms"], build["embree"]
        hits = np.fromfile(hits_path, dtype=np.dtype([("t", "<f4"), ("tri", "<u4")]))
        seconds = run["best_ms"] / 1e3
        return {"t": hits["t"].copy(), "tri": hits["tri"].copy(), "seconds": seconds, "cpu_seconds": seconds}


# --------------------------------------------------------------------------
# penumbra
# --------------------------------------------------------------------------


def run_penumbra(exe: Path, mesh: Path, rays_path: Path, hits_path: Path, device: str,
                 repeat: int = 1) -> tuple[dict, np.ndarray, np.ndarray]:
    """Runs trace-rays `repeat` times; keeps the JSON of the fastest run."""
    cmd = [str(exe), "trace-rays", "--mesh", str(mesh), "--rays", str(rays_path), "--out", str(hits_path),
           "--device", device, "--json"]
    if device == "cpu":
        cmd[-1:-1] = ["--threads", "1"]
    info = None
    for _ in range(max(1, repeat)):
        log("$ " + shlex.join(cmd))
        proc = subprocess.run(cmd, stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True)
        if proc.returncode != 0:
            raise RuntimeError(f"penumbra exited with {proc.returncode}:\n{proc.stderr.strip()}")
        run = json.loads(proc.stdout)
        if info is None or (run.get("mrays_per_s") or 0) > (info.get("mrays_per_s") or 0):
            info = run
    raw = np.fromfile(hits_path, dtype=np.dtype([("t", "<f4"), ("tri", "<u4")]))
    return info, raw["t"].astype(np.float32), raw["tri"].astype(np.uint32)


# --------------------------------------------------------------------------
# Comparison
# --------------------------------------------------------------------------


def barycentric_margin(v: np.ndarray, tris: np.ndarray, rays: np.ndarray, tri_index: int, ray_index: int) -> dict:
    """Float64 ray/triangle test: t and the smallest barycentric coordinate
    (negative: the ray passes outside the triangle, by that fraction)."""
    a, b, c = (v[tris[tri_index, k]].astype(np.float64) for k in range(3))
    o = rays[ray_index, :3].astype(np.float64)
    d = rays[ray_index, 3:].astype(np.float64)
    e1, e2 = b - a, c - a
    p = np.cross(d, e2)
    det = float(np.dot(e1, p))
    if det == 0.0:
        return {"t": None, "min_barycentric": None, "note": "ray parallel to triangle or degenerate"}
    s = o - a
    u = float(np.dot(s, p)) / det
    q = np.cross(s, e1)
    w = float(np.dot(d, q)) / det
    t = float(np.dot(e2, q)) / det
    return {"t": t, "min_barycentric": min(u, w, 1.0 - u - w)}


def compare(tp: np.ndarray, trip: np.ndarray, te: np.ndarray, trie: np.ndarray,
            dir_len: np.ndarray, diag: float) -> dict:
    hp = trip != MISS
    he = trie != MISS
    both = hp & he
    n = len(tp)
    m = {
        "rays": int(n),
        "penumbra_hits": int(hp.sum()),
        "embree_hits": int(he.sum()),
        "agreement": float(np.mean(hp == he)) if n else 1.0,
        "penumbra_only": int((hp & ~he).sum()),
        "embree_only": int((~hp & he).sum()),
        "both_hit": int(both.sum()),
    }
    if both.any():
        t_p = tp[both].astype(np.float64)
        t_e = te[both].astype(np.float64)
        rel = np.abs(t_p - t_e) / np.maximum(np.abs(t_e), np.finfo(np.float32).tiny)
        m["t_rel_err"] = {
            "median": float(np.quantile(rel, 0.5)),
            "p99": float(np.quantile(rel, 0.99)),
            "p99.9": float(np.quantile(rel, 0.999)),
            "max": float(rel.max()),
        }
        # The same difference as a distance, over the scene's size: relative t
        # error is ill-conditioned for hits very near the origin, where both
        # tracers' rounding is set by the coordinates, not by t.
        dist = np.abs(t_p - t_e) * dir_len[both] / diag
        m["dist_err_over_diag"] = {"p99.9": float(np.quantile(dist, 0.999)), "max": float(dist.max())}
        diff = trip[both] != trie[both]
        m["triangle_differs"] = float(diff.mean())
        m["triangle_differs_count"] = int(diff.sum())
        m["triangle_differs_max_t_rel"] = float(rel[diff].max()) if diff.any() else 0.0
        m["embree_t_zero"] = int((t_e == 0).sum())
    else:
        m["t_rel_err"] = {"median": 0.0, "p99": 0.0, "p99.9": 0.0, "max": 0.0}
        m["dist_err_over_diag"] = {"p99.9": 0.0, "max": 0.0}
        m["triangle_differs"] = 0.0
        m["triangle_differs_count"] = 0
        m["triangle_differs_max_t_rel"] = 0.0
        m["embree_t_zero"] = 0
    return m


def examples(v, tris, rays, tp, trip, te, trie, limit: int) -> list[dict]:
    """A few rays where penumbra and Embree disagree (hit/miss first, then
    the largest t differences), with a float64 check of both triangles."""
    hp = trip != MISS
    he = trie != MISS
    out = []
    mismatch = np.flatnonzero(hp != he)
    both = np.flatnonzero(hp & he)
    rel = np.abs(tp[both].astype(np.float64) - te[both]) / np.maximum(te[both].astype(np.float64), 1e-38)
    worst = both[np.argsort(-rel)[: max(0, limit - min(limit, len(mismatch)))]]
    worst = [i for i in worst if rel[np.searchsorted(both, i)] > T_ERR_P999_MAX]
    for i in list(mismatch[:limit]) + list(worst):
        e = {
            "ray": int(i),
            "origin": [float(x) for x in rays[i, :3]],
            "dir": [float(x) for x in rays[i, 3:]],
            "origin_bits": [f"{x:08x}" for x in rays[i, :3].view(np.uint32)],
            "dir_bits": [f"{x:08x}" for x in rays[i, 3:].view(np.uint32)],
            "penumbra": {"t": float(tp[i]), "triangle": int(trip[i]) if hp[i] else None},
            "embree": {"t": float(te[i]), "triangle": int(trie[i]) if he[i] else None},
        }
        if hp[i]:
            e["penumbra"]["f64_check"] = barycentric_margin(v, tris, rays, int(trip[i]), int(i))
        if he[i]:
            e["embree"]["f64_check"] = barycentric_margin(v, tris, rays, int(trie[i]), int(i))
        out.append(e)
    return out


# --------------------------------------------------------------------------
# Main
# --------------------------------------------------------------------------


def parse_args(argv=None):
    p = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    p.add_argument("--penumbra", type=Path, default=REPO / "target" / "release" / "penumbra",
                   help="penumbra binary (default: target/release/penumbra)")
    p.add_argument("--models", nargs="+", default=None,
                   help="OBJ files (default: stanford-bunny, dragon100k, kitchen from $PENUMBRA_DATA/models)")
    p.add_argument("--rays", type=int, default=1_000_000, help="random rays per model (0: skip the set)")
    p.add_argument("--primary", default="1024x1024", help="primary image WxH (0x0: skip the set)")
    p.add_argument("--devices", default="cpu", help="comma-separated penumbra devices: cpu, gpu, auto")
    p.add_argument("--gpu-max-rays", type=int, default=0,
                   help="trace only the first N rays of each set on non-cpu devices (0: all)")
    p.add_argument("--repeat", type=int, default=1,
                   help="time Embree and penumbra this many times each and keep the fastest (noisy machines)")
    p.add_argument("--seed", type=int, default=1, help="seed of the random ray set")
    p.add_argument("--json", type=Path, default=None, help="write all numbers here")
    p.add_argument("--examples", type=int, default=8, help="disagreeing rays to keep per run in --json")
    p.add_argument("--workdir", type=Path, default=None, help="keep RAYS.f32 / HITS.bin files here")
    p.add_argument("--packets", action="store_true",
                   help="instead of the exactness runs: speed of `penumbra trace` (MLRTA packets on and off, "
                        "single rays; 1 and 2 threads) against Embree on the very rays it traced (--dump-rays)")
    return p.parse_args(argv)


def resolve_models(names):
    data = Path(os.environ.get("PENUMBRA_DATA", REPO.parent / "shared" / "data"))
    if names is None:
        return [data / "models" / f"{m}.obj" for m in DEFAULT_MODELS]
    out = []
    for m in names:
        p = Path(m)
        if not p.exists() and not p.suffix and (data / "models" / f"{m}.obj").exists():
            p = data / "models" / f"{m}.obj"
        out.append(p)
    return out


def fmt_mrays(x):
    return "-" if x is None else f"{x:.3f}"


def fmt_ratio(x):
    return "-" if x is None else f"{x:.2f}"


def packets_speed(args, exe: Path) -> int:
    """`penumbra trace` modes against single-ray Embree on the same primary rays.

    Each round runs Embree once and every penumbra mode once, alternating, and
    each keeps its fastest round: a shared machine's slow phases then do not
    fall on one tracer only.
    """
    pw, ph = (int(x) for x in args.primary.lower().split("x"))
    work = Path(args.workdir or tempfile.mkdtemp(prefix="embree_packets_"))
    work.mkdir(parents=True, exist_ok=True)
    modes = [
        ("mlrta on", ["--mlrta", "on"], 1),
        ("mlrta on", ["--mlrta", "on"], 2),
        ("mlrta on, min tile 32", ["--mlrta", "on", "--min-tile", "32"], 1),
        ("mlrta on, min tile 32", ["--mlrta", "on", "--min-tile", "32"], 2),
        ("mlrta off", ["--mlrta", "off"], 1),
        ("single ray", ["--single-ray"], 1),
        ("single ray", ["--single-ray"], 2),
    ]
    rows = []
    for model in resolve_models(args.models):
        name = model.stem
        rays_path = work / f"{name}-primary-{pw}x{ph}.rays.f32"
        base = [str(exe), "trace", "--mesh", str(model), "--width", str(pw), "--height", str(ph), "--device", "cpu", "--json"]
        subprocess.run(base + ["--dump-rays", str(rays_path), "--threads", "1"], check=True,
                       stdout=subprocess.PIPE, stderr=subprocess.PIPE)
        rays = np.fromfile(rays_path, dtype="<f4").reshape(-1, 6)
        embree = Embree(model, work)
        best = {}
        emb_s = float("inf")
        for _ in range(max(1, args.repeat)):
            emb_s = min(emb_s, embree.trace(rays, 1)["seconds"])
            for label, flags, threads in modes:
                cmd = base + flags + ["--threads", str(threads)]
                log("$ " + shlex.join(cmd))
                out = json.loads(subprocess.run(cmd, check=True, stdout=subprocess.PIPE,
                                                stderr=subprocess.PIPE, text=True).stdout)
                key = (label, threads)
                if key not in best or out["mrays_per_s"] > best[key]["mrays_per_s"]:
                    best[key] = out
        emb = len(rays) / emb_s / 1e6
        for (label, threads), out in best.items():
            rows.append({
                "model": name, "mode": label, "threads": threads, "mrays_per_s": out["mrays_per_s"],
                "embree_mrays_per_s": emb, "ratio": out["mrays_per_s"] / emb,
                "cells_per_packet": out["cells_per_packet"], "isects_per_packet": out["isects_per_packet"],
                "ep_steps_per_packet": out.get("ep_steps_per_packet"),
            })
    print(f"Primary rays {pw}x{ph} of the default camera; Embree single-ray, 1 thread, on the rays penumbra traced; "
          f"best of {max(1, args.repeat)} alternating rounds.\n")
    print("| model | mode | threads | penumbra Mrays/s | Embree Mrays/s | ratio | cells/packet | isects/packet |")
    print("|---|---|---:|---:|---:|---:|---:|---:|")
    for r in rows:
        print(f"| {r['model']} | {r['mode']} | {r['threads']} | {r['mrays_per_s']:.2f} | {r['embree_mrays_per_s']:.2f} "
              f"| {r['ratio']:.2f} | {r['cells_per_packet']:.2f} | {r['isects_per_packet']:.2f} |")
    print("\nTwo threads against one (the same best-of rounds):\n")
    print("| model | mode | 1 thread Mrays/s | 2 threads Mrays/s | speed-up |")
    print("|---|---|---:|---:|---:|")
    by_key = {(r["model"], r["mode"], r["threads"]): r["mrays_per_s"] for r in rows}
    for (model, mode, threads), two in by_key.items():
        one = by_key.get((model, mode, 1))
        if threads == 2 and one:
            print(f"| {model} | {mode} | {one:.2f} | {two:.2f} | {two / one:.2f} |")
    if args.json:
        args.json.write_text(json.dumps({"packets": rows}, indent=1))
    return 0


def main(argv=None) -> int:
    args = parse_args(argv)
    exe = args.penumbra.resolve()
    if not exe.is_file():
        log(f"error: penumbra binary {exe} not found (cargo build --release, or --penumbra PATH)")
        return 2
    devices = [d.strip() for d in args.devices.split(",") if d.strip()]
    for d in devices:
        if d not in ("cpu", "gpu", "auto"):
            log(f"error: unknown device {d!r}")
            return 2
    try:
        pw, ph = (int(x) for x in args.primary.lower().split("x"))
    except ValueError:
        log(f"error: --primary must be WxH, got {args.primary!r}")
        return 2
    models = resolve_models(args.models)
    for m in models:
        if not m.is_file():
            log(f"error: model {m} not found (set PENUMBRA_DATA or pass --models)")
            return 2
    if embree_tool() is None:
        log("skipped: native embree_bench is not available (apt-get install -y libembree-dev g++; "
            f"its source is looked for in {TOOL_DIR}, or set EMBREE_BENCH_DIR)")
        return 0
    if args.packets:
        return packets_speed(args, exe)


    tmp = None
    if args.workdir is None:
        tmp = tempfile.TemporaryDirectory(prefix="embree_compare_")
        work = Path(tmp.name)
    else:
        work = args.workdir
        work.mkdir(parents=True, exist_ok=True)

    version = "?"
    results = []
    skipped = []
    failed = False
    try:
        for model in models:
            name = model.stem
            log(f"== {name}: loading {model}")
            v, tris = load_obj(model)
            lo, hi = used_bounds(v, tris)
            diag = float(np.linalg.norm(hi - lo)) or 1.0
            log(f"   {len(v)} vertices, {len(tris)} triangles, bounds {lo.tolist()} .. {hi.tolist()}")
            embree = Embree(model, work)

            sets = []
            if args.rays > 0:
                rng = np.random.default_rng(args.seed)
                sets.append(("random", random_rays(lo, hi, args.rays, rng)))
            if pw > 0 and ph > 0:
                sets.append((f"primary {pw}x{ph}", primary_rays(lo, hi, pw, ph)))

            for set_name, rays in sets:
                tag = set_name.split()[0]
                log(f"-- {name} / {set_name}: {len(rays)} rays; Embree (rtcIntersect1, 1 thread)")
                emb = embree.trace(rays, args.repeat)
                version = embree.version
                emb_mrays = len(rays) / emb["seconds"] / 1e6
                log(f"   Embree: {emb['seconds'] * 1e3:.1f} ms wall, {emb['cpu_seconds'] * 1e3:.1f} ms CPU, "
                    f"{emb_mrays:.3f} Mrays/s")
                per_device = {}
                for device in devices:
                    n = len(rays)
                    if device != "cpu" and args.gpu_max_rays > 0:
                        n = min(n, args.gpu_max_rays)
                    sub = rays[:n]
                    rays_path = work / f"{name}-{tag}-{n}.rays.f32"
                    hits_path = work / f"{name}-{tag}-{n}-{device}.hits.bin"
                    if not rays_path.exists() or rays_path.stat().st_size != sub.nbytes:
                        sub.astype("<f4").tofile(rays_path)
                    try:
                        if device == "cpu":
                            # Alternate the two tracers, one run each per round, and
                            # keep each one's fastest: a slow phase of a shared
                            # machine then cannot fall on one of them only.
                            info, tp, trip = run_penumbra(exe, model, rays_path, hits_path, device, 1)
                            for _ in range(max(1, args.repeat) - 1):
                                again = embree.trace(rays, 1)
                                if again["seconds"] < emb["seconds"]:
                                    emb = again
                                    emb_mrays = len(rays) / emb["seconds"] / 1e6
                                run, tp, trip = run_penumbra(exe, model, rays_path, hits_path, device, 1)
                                if (run.get("mrays_per_s") or 0) > (info.get("mrays_per_s") or 0):
                                    info = run
                        else:
                            info, tp, trip = run_penumbra(exe, model, rays_path, hits_path, device, args.repeat)
                    except RuntimeError as e:
                        if device == "cpu":
                            raise
                        # No adapter (exit code 2) or a device failure: report and
                        # go on with the other devices rather than abort.
                        log(f"   skipped {device}: {e}")
                        skipped.append({"model": name, "ray_set": set_name, "device": device, "error": str(e)})
                        continue
                    if len(tp) != n:
                        raise RuntimeError(f"{hits_path}: {len(tp)} hits for {n} rays")
                    # Bit-for-bit agreement with the devices already run, on the
                    # rays both traced.
                    cross = {}
                    for other, (tq, triq) in per_device.items():
                        k = min(n, len(tq))
                        same = (tp[:k].view(np.uint32) == tq[:k].view(np.uint32)) & (trip[:k] == triq[:k])
                        cross[other] = {"rays": int(k), "differ": int(k - same.sum())}
                        log(f"   penumbra {device} vs {other}: {k - int(same.sum())} of {k} hits differ (bitwise)")
                    per_device[device] = (tp, trip)
                    te, trie = emb["t"][:n], emb["tri"][:n]
                    dir_len = np.linalg.norm(sub[:, 3:].astype(np.float64), axis=1)
                    m = compare(tp, trip, te, trie, dir_len, diag)
                    p_mrays = info.get("mrays_per_s")
                    # Embree's rate over the whole set; the subset rate is the same
                    # rays/s up to noise (the rays are i.i.d. / the image rows).
                    checks = {
                        "agreement": m["agreement"] >= AGREEMENT_MIN,
                        "t_rel_err_p99.9": m["t_rel_err"]["p99.9"] <= T_ERR_P999_MAX,
                    }
                    ok = all(checks.values())
                    failed |= not ok
                    row = {
                        "model": name,
                        "model_path": str(model),
                        "triangles": int(len(tris)),
                        "ray_set": set_name,
                        "device": info.get("device", device),
                        "device_arg": device,
                        "adapter": info.get("adapter"),
                        "penumbra_threads": info.get("threads"),
                        "penumbra_timing": info.get("timing"),
                        "penumbra_trace_ms": info.get("trace_ms"),
                        "penumbra_build_ms": info.get("build_ms"),
                        "penumbra_mrays_per_s": p_mrays,
                        "embree_mrays_per_s": emb_mrays,
                        "embree_trace_ms": emb["seconds"] * 1e3,
                        "embree_cpu_ms": emb["cpu_seconds"] * 1e3,
                        "embree_rays": int(len(rays)),
                        "embree_build_ms": embree.build_ms,
                        "ratio": (p_mrays / emb_mrays) if p_mrays else None,
                        **m,
                        "checks": {k: ("PASS" if v_ else "FAIL") for k, v_ in checks.items()},
                        "kdtree": info.get("kdtree"),
                        "vs_other_devices": cross,
                    }
                    if args.examples > 0 and (m["penumbra_only"] or m["embree_only"]
                                              or m["t_rel_err"]["max"] > T_ERR_P999_MAX):
                        row["examples"] = examples(v, tris, sub, tp, trip, te, trie, args.examples)
                    results.append(row)
                    for e in row.get("examples", []):
                        if (e["penumbra"]["triangle"] is None) != (e["embree"]["triangle"] is None):
                            who = "Embree-only" if e["penumbra"]["triangle"] is None else "penumbra-only"
                            chk = e["embree" if who == "Embree-only" else "penumbra"]["f64_check"]
                            log(f"   {who} hit: ray {e['ray']} o={e['origin']} d={e['dir']} "
                                f"triangle {e['embree']['triangle'] if who == 'Embree-only' else e['penumbra']['triangle']}"
                                f", float64 check of that triangle: t={chk['t']}, min barycentric="
                                f"{chk['min_barycentric']} (< 0: the ray passes outside it)")
                    t = m["t_rel_err"]
                    for k, v_ in checks.items():
                        log(f"   [{('PASS' if v_ else 'FAIL')}] {name} / {set_name} / {device}: {k} "
                            + (f"{m['agreement'] * 100:.4f} % (>= {AGREEMENT_MIN * 100:.2f} %)" if k == "agreement"
                               else f"{t['p99.9']:.3g} (<= {T_ERR_P999_MAX:g})"))
                    log(f"   penumbra {info.get('device')} ({info.get('adapter')}, {info.get('threads')} threads, "
                        f"{info.get('timing')}): {fmt_mrays(p_mrays)} Mrays/s; penumbra-only {m['penumbra_only']}, "
                        f"Embree-only {m['embree_only']}; t rel err median {t['median']:.3g} p99 {t['p99']:.3g} "
                        f"p99.9 {t['p99.9']:.3g} max {t['max']:.3g} (as distance / bbox diagonal: max "
                        f"{m['dist_err_over_diag']['max']:.3g}); triangle differs "
                        f"{m['triangle_differs'] * 100:.4f} % (max t rel {m['triangle_differs_max_t_rel']:.3g})")
    except RuntimeError as e:
        log(f"error: {e}")
        return 2
    finally:
        if tmp is not None:
            tmp.cleanup()

    print(f"Embree {version} native (embree_bench, rtcIntersect1 per ray, 1 thread); "
          f"penumbra CPU runs use --threads 1.\n")
    print("| model | rays | device | agreement % | p-only / E-only | t err p99.9 | t err max | tri differs % "
          "| penumbra Mrays/s | Embree Mrays/s | ratio | checks |")
    print("|---|---|---|---:|---:|---:|---:|---:|---:|---:|---:|---|")
    for r in results:
        dev = r["device"] if r["device"] == "cpu" else f"{r['device']} ({r['adapter']})"
        if r["device"] == "cpu":
            dev = f"cpu, {r['penumbra_threads']} thread" + ("s" if r["penumbra_threads"] != 1 else "")
        checks = "PASS" if all(v == "PASS" for v in r["checks"].values()) else \
            "FAIL: " + ", ".join(k for k, v in r["checks"].items() if v != "PASS")
        print(f"| {r['model']} | {r['ray_set']}: {r['rays']:,} | {dev} | {r['agreement'] * 100:.4f} | "
              f"{r['penumbra_only']} / {r['embree_only']} | {r['t_rel_err']['p99.9']:.2e} | "
              f"{r['t_rel_err']['max']:.2e} | {r['triangle_differs'] * 100:.4f} | "
              f"{fmt_mrays(r['penumbra_mrays_per_s'])} | {r['embree_mrays_per_s']:.3f} | "
              f"{fmt_ratio(r['ratio'])} | {checks} |")

    for sk in skipped:
        print(f"\nskipped: {sk['model']} / {sk['ray_set']} on {sk['device']}: {sk['error'].splitlines()[-1]}")

    if args.json is not None:
        doc = {
            "embree": {
                "version": version,
                "api": "rtcIntersect1 per ray (native embree_bench --modes rays), single thread",
                "scene_flags": "default",
                "tnear": 0.0,
                "tfar": "inf",
            },
            "penumbra": str(exe),
            "seed": args.seed,
            "repeat": args.repeat,
            "thresholds": {"agreement_min": AGREEMENT_MIN, "t_rel_err_p99.9_max": T_ERR_P999_MAX},
            "results": results,
            "skipped": skipped,
            "passed": not failed,
        }
        args.json.write_text(json.dumps(doc, indent=2))
        log(f"wrote {args.json}")
    log("ALL CHECKS PASS" if not failed else "SOME CHECKS FAILED")
    return 1 if failed else 0


if __name__ == "__main__":
    sys.exit(main())
