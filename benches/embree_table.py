#!/usr/bin/env python3
"""penumbra against native Embree, one thread each, on the very same rays.

`benches/embree_bench` (the project's copy of `../shared/tools/embree_bench`
with `--threads N`: Embree 3 through its C API, built with -O3 -march=native;
see its README for how its rays are made bit-identical to penumbra's) and `target/release/penumbra`, run alternately,
ROUNDS times each, keeping each side's best. Every process measures one
repetition (`--reps 1` for Embree), so both sides are "best of ROUNDS" over
the same stretch of time on this shared machine. Embree's tool traces the
same rays with several APIs in one process, so its stream call (primary
rays) and `rtcOccluded16` (AO) run after others have warmed the caches and
the branch predictors; penumbra gets one untimed run first for those rows
(`--warmup 1`, worth about 10% on the bunny's MLRTA packets), and neither
side for `rtcIntersect1` (single and random rays), which Embree's tool
measures first. The build is a process of its own on both sides (a 16x16
`trace`: the kd-tree's build and `prepare` of a fresh process).

Workloads (the issue's table):
  primary    1024^2 primary rays of the default camera (kitchen: the interior
             view): Embree's best coherent stream call against MLRTA packets,
             and against 4x4 packets through the wide BVH (`--accel bvh`).
  single     the same rays through rtcIntersect1 against `trace --single-ray`.
  ao         256 cosine rays per vertex, directions generated inside the timed
             loop on both sides: rtcOccluded16 against `ao --method raycast`
             (Embree given the directions ready is also reported).
  random     1M random rays (Embree's --gen-rays file) through rtcIntersect1
             against `trace-rays`.
  build      Embree's high-quality BVH build against the kd-tree build plus
             MLRTA's `prepare` (milliseconds, lower is better).

Then, at each of `--threads` (default 1,2), on bunny, dragon100k, cow and every
`--public` mesh (OBJ files we did not make; public scans):
  random     1M random rays aimed at that mesh (`--gen-rays`) through
             rtcIntersect1 on N threads against `trace-rays --accel bvh
             --threads N` (`--warmup 1 --repeat 3`); the hits compared.
  primary    1024^2 primary rays (bunny and the public meshes): Embree's best
             coherent API at one thread (the stream calls), its threaded
             rtcIntersect1M at N > 1, against `trace` (MLRTA) on N threads.

Writes `assets/figures/embree-table.md` (also printed). Exits 0 with a message
when Embree (libembree-dev), g++, the tool's source or the models are missing.

    PENUMBRA_DATA=../shared/data python3 benches/embree_table.py [--rounds 5] [--quick] \
        [--threads 1,2] [--public a.obj,b.obj]

`--quick` runs 256^2 primary rays, 16 AO rays and 100K random rays, one round
(checks the script).
"""

from __future__ import annotations

import argparse
import json
import os
import shutil
import subprocess
import sys
import tempfile
from pathlib import Path

ROOT = Path(__file__).resolve().parent.parent
EXE = ROOT / "target" / "release" / "penumbra"
TOOL_DIR = Path(os.environ.get("EMBREE_BENCH_DIR", ROOT / "benches" / "embree_bench"))
TOOL = ROOT / "target" / "embree_bench_threads" / "embree_bench"
OUT = ROOT / "assets" / "figures" / "embree-table.md"
KITCHEN_VIEW = ["--eye", "3.2,1.6,2.2", "--target", "-1.0,0.9,-1.5", "--fov", "60"]
STREAM_APIS = ("rtcIntersect1M(coherent ctx)", "rtcIntersectNp(coherent ctx)")


def skip(why):
    print(f"embree_table: skipped: {why}")
    sys.exit(0)


def run(cmd):
    print("$ " + " ".join(str(c) for c in cmd), file=sys.stderr)
    out = subprocess.run([str(c) for c in cmd], stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True)
    if out.returncode != 0:
        sys.exit(f"failed ({out.returncode}): {' '.join(str(c) for c in cmd)}\n{out.stderr}")
    return out.stdout


def embree(args):
    """Embree's JSON lines, keyed by (mode, api)."""
    lines = [json.loads(l) for l in run([TOOL] + args).splitlines() if l.startswith("{")]
    return {(l["mode"], l.get("api", "")): l for l in lines}


def penumbra(args, warm=False, threads=1):
    """One measured run; `warm`: after one untimed run (see the docstring)."""
    warmup = ["--warmup", "1"] if warm else []
    return json.loads(run([EXE] + args + warmup + ["--threads", threads, "--json"]))


def tool_available():
    """Builds the tool if needed; None when it cannot be."""
    if TOOL.is_file():
        return None
    if not (TOOL_DIR / "build.sh").is_file():
        return f"{TOOL_DIR} not found"
    if not Path("/usr/include/embree3/rtcore.h").is_file():
        return "Embree 3 headers missing (apt-get install -y libembree-dev)"
    if shutil.which("g++") is None:
        return "g++ missing"
    env = dict(os.environ, OUT=str(TOOL.parent))
    out = subprocess.run(["sh", str(TOOL_DIR / "build.sh")], env=env, capture_output=True, text=True)
    return None if out.returncode == 0 and TOOL.is_file() else f"building embree_bench failed: {out.stderr.strip()}"


def hits_agree(a, b):
    """"yes", or how many of Embree's hits penumbra's file has on the same triangle."""
    x, y = Path(a).read_bytes(), Path(b).read_bytes()
    if x == y:
        return "yes"
    import struct
    rec = 8  # f32 t, u32 triangle (a miss: +inf, 0xFFFFFFFF), both tools' format
    n = min(len(x), len(y)) // rec
    tri = lambda d, i: struct.unpack_from("<I", d, i * rec + 4)[0]
    hit = [i for i in range(n) if tri(x, i) != 0xFFFFFFFF]
    agree = sum(1 for i in hit if tri(x, i) == tri(y, i))
    return f"{agree:,} of Embree's {len(hit):,}"


class Best:
    """Each side's best over the rounds."""

    def __init__(self):
        self.v = {}

    def hi(self, key, x):
        self.v[key] = max(self.v.get(key, x), x)

    def lo(self, key, x):
        self.v[key] = min(self.v.get(key, x), x)


def main():
    p = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    p.add_argument("--rounds", type=int, default=5)
    p.add_argument("--quick", action="store_true")
    p.add_argument("--out", type=Path, default=OUT)
    p.add_argument("--threads", default="1,2", help="thread counts of the random and primary rows")
    p.add_argument("--public", default="", help="comma-separated OBJ files we did not make")
    args = p.parse_args()
    threads = [int(t) for t in args.threads.split(",") if t]
    public = [Path(m) for m in args.public.split(",") if m]
    for m in public:
        if not m.is_file():
            sys.exit(f"--public: {m}: no such file")
    data = os.environ.get("PENUMBRA_DATA")
    if not data:
        skip("PENUMBRA_DATA is not set (the folder holding models/)")
    models = Path(data) / "models"
    needed = ["stanford-bunny", "dragon100k", "kitchen", "cow"]
    missing = [m for m in needed if not (models / f"{m}.obj").is_file()]
    if missing:
        skip(f"models missing in {models}: {', '.join(missing)}")
    if not EXE.is_file():
        skip(f"{EXE} not built (cargo build --release --bin penumbra)")
    why = tool_available()
    if why:
        skip(why)
    side, ao_rays, n_random = (256, 16, 100_000) if args.quick else (1024, 256, 1_000_000)
    rounds = 1 if args.quick else args.rounds
    size = ["--width", side, "--height", side]
    best = Best()
    load_before = os.getloadavg()[0]
    with tempfile.TemporaryDirectory() as tmp:
        rays = Path(tmp) / "random.f32"
        run([TOOL, models / "stanford-bunny.obj", "--modes", "none", "--gen-rays", n_random, rays])
        for r in range(rounds):
            print(f"round {r + 1}/{rounds}", file=sys.stderr)
            for name, view in [("stanford-bunny", []), ("dragon100k", []), ("kitchen", KITCHEN_VIEW)]:
                mesh = models / f"{name}.obj"
                e = embree([mesh, "--modes", "primary", "--reps", 1] + size + view)
                best.hi((name, "primary", "embree"), max(e[("primary", a)]["mrays_per_s"] for a in STREAM_APIS))
                if name == "stanford-bunny":
                    best.hi((name, "single", "embree"), e[("primary", "rtcIntersect1")]["mrays_per_s"])
                    best.lo((name, "build", "embree"), e[("build", "")]["build_ms"])
                    version = e[("build", "")]["embree"]
                pen = penumbra(["trace", "--mesh", mesh] + size + view, warm=True)
                best.hi((name, "primary", "penumbra"), pen["mrays_per_s"])
                packets = penumbra(["trace", "--mesh", mesh, "--accel", "bvh"] + size + view, warm=True)
                best.hi((name, "bvh packets", "penumbra"), packets["mrays_per_s"])
                if name == "stanford-bunny":
                    built = penumbra(["trace", "--mesh", mesh, "--width", 16, "--height", 16])
                    best.lo((name, "build", "penumbra"), built["build_ms"] + built["prepare_ms"])
                    single = penumbra(["trace", "--mesh", mesh, "--single-ray"] + size)
                    best.hi((name, "single", "penumbra"), single["mrays_per_s"])
            for name in ["cow", "stanford-bunny"]:
                mesh = models / f"{name}.obj"
                e = embree([mesh, "--modes", "ao", "--ao-rays", ao_rays, "--reps", 1])
                best.hi((name, "ao", "embree"), e[("ao", "rtcOccluded16")]["mrays_per_s"])
                best.hi((name, "ao ready", "embree"), e[("ao", "rtcOccluded16(dirs precomputed)")]["mrays_per_s"])
                pen = penumbra(["ao", "--mesh", mesh, "--method", "raycast", "--rays", ao_rays,
                                "--per-vertex", Path(tmp) / "ao.csv"], warm=True)
                best.hi((name, "ao", "penumbra"), pen["mrays_per_s"])
            mesh = models / "stanford-bunny.obj"
            e = embree([mesh, "--modes", "rays", "--rays", rays, "--reps", 1])
            best.hi(("stanford-bunny", "random", "embree"), e[("rays", "rtcIntersect1")]["mrays_per_s"])
            pen = penumbra(["trace-rays", "--mesh", mesh, "--rays", rays, "--out", Path(tmp) / "hits.bin"])
            best.hi(("stanford-bunny", "random", "penumbra"), pen["mrays_per_s"])
        # Random and primary rays per mesh and thread count.
        meshes = [(n, models / f"{n}.obj", False) for n in ["stanford-bunny", "dragon100k", "cow"]]
        meshes += [(m.stem, m, True) for m in public]
        same = {}
        for name, mesh, _ in meshes:
            rays = Path(tmp) / f"{name}.f32"
            run([TOOL, mesh, "--modes", "none", "--gen-rays", n_random, rays])
            for r in range(rounds):
                print(f"{name}: round {r + 1}/{rounds}", file=sys.stderr)
                for t in threads:
                    eh, ph = Path(tmp) / "e.hits", Path(tmp) / "p.hits"
                    e = embree([mesh, "--modes", "rays", "--rays", rays, "--reps", 1, "--threads", t, "--hits", eh])
                    best.hi((name, "random", t, "embree"), e[("rays", "rtcIntersect1")]["mrays_per_s"])
                    pen = penumbra(["trace-rays", "--mesh", mesh, "--rays", rays, "--accel", "bvh", "--out", ph,
                                    "--repeat", 3], warm=True, threads=t)
                    best.hi((name, "random", t, "penumbra"), pen["mrays_per_s"])
                    same[name] = hits_agree(eh, ph)
                    if name == "stanford-bunny" or (name, mesh, True) in meshes:
                        e = embree([mesh, "--modes", "primary", "--reps", 1, "--threads", t] + size)
                        apis = STREAM_APIS if t == 1 else ("rtcIntersect1M(coherent ctx)",)
                        best.hi((name, "primary", t, "embree"), max(e[("primary", a)]["mrays_per_s"] for a in apis))
                        pen = penumbra(["trace", "--mesh", mesh] + size, warm=True, threads=t)
                        best.hi((name, "primary", t, "penumbra"), pen["mrays_per_s"])
    b = best.v
    load = (load_before, os.getloadavg()[0])
    k = f"{side}^2"
    rows = [
        (f"bunny {k} primary", "stream, coherent", ("stanford-bunny", "primary"), "MLRTA"),
        (f"dragon100k {k} primary", "stream, coherent", ("dragon100k", "primary"), "MLRTA"),
        (f"kitchen interior {k} primary", "stream, coherent", ("kitchen", "primary"), "MLRTA"),
        (f"bunny {k} primary", "stream, coherent", ("stanford-bunny", "bvh packets"), "BVH 4x4 packets"),
        (f"dragon100k {k} primary", "stream, coherent", ("dragon100k", "bvh packets"), "BVH 4x4 packets"),
        (f"kitchen interior {k} primary", "stream, coherent", ("kitchen", "bvh packets"), "BVH 4x4 packets"),
        (f"bunny {k} primary", "`rtcIntersect1`", ("stanford-bunny", "single"), "single ray"),
        (f"cow AO, {ao_rays} rays/vertex", "`rtcOccluded16`", ("cow", "ao"), "`ao` raycast"),
        (f"bunny AO, {ao_rays} rays/vertex", "`rtcOccluded16`", ("stanford-bunny", "ao"), "`ao` raycast"),
        (f"bunny {n_random:,} random rays", "`rtcIntersect1`", ("stanford-bunny", "random"), "`trace-rays`"),
    ]
    lines = [
        f"Native Embree {version} against penumbra, one thread each, same rays; "
        f"best of {rounds} alternating rounds (`benches/embree_table.py`; {os.cpu_count()} cores, "
        f"load average {load[0]:.1f} at the start, {load[1]:.1f} at the end: absolute figures drop "
        "on a busy machine, the ratios much less). Packets and AO are measured warm on both sides "
        "(Embree's calls after its other APIs' passes over the same rays, penumbra's after `--warmup 1`), "
        "single and random rays and the build cold on both.",
        "",
        "| work | Embree best API | Embree Mrays/s | penumbra | penumbra Mrays/s | penumbra / Embree |",
        "|---|---|---:|---|---:|---:|",
    ]
    for work, api, (model, kind), ours in rows:
        em = b[(model, "primary" if kind == "bvh packets" else kind, "embree")]
        pe = b[(model, kind, "penumbra")]
        lines.append(f"| {work} | {api} | {em:.1f} | {ours} | {pe:.1f} | {pe / em:.2f} |")
    eb, pb = b[("stanford-bunny", "build", "embree")], b[("stanford-bunny", "build", "penumbra")]
    lines.append(f"| bunny build (1 thread) | BVH, high quality | {eb:.0f} ms | kd-tree + prepare | {pb:.0f} ms "
                 f"| {pb / eb:.2f}x the time |")
    lines += [
        "",
        "Embree given the AO directions ready (`rtcOccluded16`, directions generated before the clock): "
        + ", ".join(f"{m} {b[(m, 'ao ready', 'embree')]:.1f} Mrays/s (penumbra / Embree "
                    f"{b[(m, 'ao', 'penumbra')] / b[(m, 'ao ready', 'embree')]:.2f})" for m in ["cow", "stanford-bunny"])
        + ".",
    ]
    lines += [
        "",
        f"## Random rays and threads",
        "",
        f"{n_random:,} random rays per mesh aimed at it (`embree_bench --gen-rays`, the rays `penumbra bench`'s "
        "`random-rays` also traces), closest hits, `rtcIntersect1` against `penumbra trace-rays --accel bvh` "
        f"(`--warmup 1 --repeat 3`) at {', '.join(map(str, threads))} threads on both sides; best of {rounds} "
        "alternating rounds. Same hits: the triangle ids of both hit files compared.",
        "",
        "| mesh | threads | Embree Mrays/s | penumbra Mrays/s | penumbra / Embree | same hits |",
        "|---|---:|---:|---:|---:|---|",
    ]
    label = {n: f"{n} (public)" if pub else n for n, _, pub in meshes}
    for name, _, _ in meshes:
        for t in threads:
            em, pe = b[(name, "random", t, "embree")], b[(name, "random", t, "penumbra")]
            lines.append(f"| {label[name]} | {t} | {em:.2f} | {pe:.2f} | {pe / em:.2f} | {same[name]} |")
    lines += [
        "",
        f"Primary rays, {k}, the default camera, `penumbra trace` (MLRTA) against Embree's best coherent "
        "API at one thread (the stream calls) and its threaded `rtcIntersect1M` stream above:",
        "",
        "| mesh | threads | Embree Mrays/s | penumbra Mrays/s | penumbra / Embree |",
        "|---|---:|---:|---:|---:|",
    ]
    for name, _, _ in meshes:
        for t in threads:
            if (name, "primary", t, "embree") in b:
                em, pe = b[(name, "primary", t, "embree")], b[(name, "primary", t, "penumbra")]
                lines.append(f"| {label[name]} | {t} | {em:.1f} | {pe:.1f} | {pe / em:.2f} |")
    table = "\n".join(lines) + "\n"
    print(table)
    if not args.quick:
        args.out.parent.mkdir(parents=True, exist_ok=True)
        args.out.write_text(table)
        print(f"wrote {args.out}", file=sys.stderr)


if __name__ == "__main__":
    main()
