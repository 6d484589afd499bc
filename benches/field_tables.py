#!/usr/bin/env python3
"""The displacement-field paper's experiments with penumbra's CLI.

    PENUMBRA_DATA=../shared/data python3 benches/field_tables.py [--repeat 3] [--json out.json]

Prints Markdown tables:
- Figure 8: the corner (3267 vertices, 256 cosine rays each = 836,352 rays)
  receiving from stanford-bunny, cow and dragon100k, and a scene of several
  objects (assets/scenes/*-corner.json): ray casting (kd-tree) and field AO
  times on the CPU and the GPU, field build time, RMS error of per-vertex
  accessibility against ray casting with the same rays.
- Figure 6: the bunny at 3 positional x 4 directional resolutions: build
  time, AO time, RMS error, bytes.
- Storage (32/8/1 bits), direction sampling (concentric/polar/rejection) and
  positional interpolation (nearest/bilinear).
- Rays that start inside the caster's sphere against the rest.

Times are the best of --repeat runs (this machine's slow phases are long).
"""

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
SCENES = {
    "stanford-bunny": ROOT / "assets/scenes/bunny-corner.json",
    "cow": ROOT / "assets/scenes/cow-corner.json",
    "dragon100k": ROOT / "assets/scenes/dragon-corner.json",
    "multiple objects": ROOT / "assets/scenes/multi-corner.json",
}


def run(args):
    cmd = [str(EXE)] + [str(a) for a in args] + ["--json"]
    print("$ " + " ".join(cmd), file=sys.stderr)
    out = subprocess.run(cmd, stdout=subprocess.PIPE, stderr=subprocess.PIPE, text=True)
    if out.returncode != 0:
        sys.exit(f"failed ({out.returncode}): {' '.join(cmd)}\n{out.stderr}")
    return json.loads(out.stdout)


def best(runs, key):
    return min(r[key] for r in runs)


def gpu_available():
    info = run(["info"])
    return info.get("selected") is not None


def scene_with_field(tmp, scene, mesh, field):
    """A copy of `scene` (paths made absolute) whose `mesh` uses `field`."""
    data = json.loads(Path(scene).read_text())
    for k, v in data["meshes"].items():
        if not v.startswith("$"):
            data["meshes"][k] = str((Path(scene).parent / v).resolve())
    data["fields"] = {mesh: str(field)}
    path = Path(tmp) / f"{mesh}-{Path(field).stem}.json"
    path.write_text(json.dumps(data))
    return path


def figure8(args, tmp, gpu):
    rows = []
    for name, scene in SCENES.items():
        row = {"scene": name}
        for device in ["cpu"] + (["gpu"] if gpu else []):
            runs = [
                run(["ao", "--scene", scene, "--method", "field", "--rays", 256, "--per-vertex", Path(tmp) / "f8.csv",
                     "--reference", "--device", device])
                for _ in range(args.repeat)
            ]
            r = runs[0]
            row["triangles"] = r["casters"]["triangles"]
            row["points"] = r["points"]
            row["rays"] = r["points"] * 256
            row[f"raycast_ms_{device}"] = min(x["reference"]["raycast_ms"] for x in runs)
            row[f"field_ms_{device}"] = best(runs, "ao_ms")
            row["build_ms"] = min(x["build_ms"] for x in runs)
            row["rms"] = r["reference"]["rms_error"]
            row["rays_detail"] = r["reference"]["rays"]
            if "fields_only" in r["reference"]:
                row["rms_fields_only"] = r["reference"]["fields_only"]["rms_error"]
                row["self_ms"] = r["self_occlusion_ms"][0]
        rows.append(row)
    print("\n### Figure 8: corner receiver, 256 cosine rays per vertex, 4225 maps of 32x32, 8-bit, concentric\n")
    cols = "| caster(s) | triangles | receiver points | rays | ray casting CPU | ray casting GPU | field build | field AO CPU | field AO GPU | RMS error |"
    print(cols)
    print("|---|---:|---:|---:|---:|---:|---:|---:|---:|---:|")
    for r in rows:
        g = lambda k: f"{r[k]:.0f} ms" if k in r else "-"
        rms = f"{r['rms']:.4f}" + (f" (field lookups alone {r['rms_fields_only']:.4f}; self-occlusion cast once in {r['self_ms']:.0f} ms)" if "rms_fields_only" in r else "")
        print(f"| {r['scene']} | {r['triangles']:,} | {r['points']:,} | {r['rays']:,} | {g('raycast_ms_cpu')} | {g('raycast_ms_gpu')} "
              f"| {r['build_ms'] / 1000:.1f} s | {g('field_ms_cpu')} | {g('field_ms_gpu')} | {rms} |")
    print("\nRays starting inside a caster's bounding sphere, and per-ray disagreement with ray casting:\n")
    print("| caster(s) | rays inside a sphere | wrong inside | wrong outside |")
    print("|---|---:|---:|---:|")
    for r in rows:
        d = r["rays_detail"]
        print(f"| {r['scene']} | {d['inside_sphere']:,} ({d['inside_sphere'] / d['total']:.1%}) "
              f"| {d['disagree_fraction_inside']:.2%} | {d['disagree_fraction_outside']:.2%} |")
    return rows


def bunny_field(tmp, side, res, bits=8, directions="concentric"):
    out = Path(tmp) / f"bunny-{side}-{res}-{bits}-{directions}.dfield"
    data = Path(os.environ["PENUMBRA_DATA"]) / "models" / "stanford-bunny.obj"
    r = run(["field", "build", "--mesh", data, "--positions", side * side, "--res", res, "--bits", bits,
             "--directions", directions, "-o", out])
    return out, r


def bunny_ao(args, tmp, field, positional="bilinear", device="cpu"):
    scene = scene_with_field(tmp, SCENES["stanford-bunny"], "stanford-bunny", field)
    runs = [run(["ao", "--scene", scene, "--method", "field", "--rays", 256, "--per-vertex", Path(tmp) / "f6.csv",
                 "--positional", positional, "--reference", "--device", device]) for _ in range(args.repeat)]
    return runs[0]["reference"]["rms_error"], best(runs, "ao_ms")


def figure6(args, tmp):
    rows = []
    for side in [33, 46, 65]:
        for res in [16, 32, 64, 128]:
            field, built = bunny_field(tmp, side, res)
            rms, ms = bunny_ao(args, tmp, field)
            rows.append({"maps": side * side, "res": res, "build_ms": built["build_ms"], "ao_ms": ms, "rms": rms,
                         "bytes": built["bytes"]})
    print("\n### Figure 6: the bunny over the corner, 8-bit concentric maps, 256 rays per vertex (CPU)\n")
    print("| positional samples | map | build | AO | RMS error | bytes |")
    print("|---:|---:|---:|---:|---:|---:|")
    for r in rows:
        print(f"| {r['maps']:,} | {r['res']}x{r['res']} | {r['build_ms'] / 1000:.1f} s | {r['ao_ms']:.0f} ms | {r['rms']:.4f} | {r['bytes']:,} |")
    return rows


def variants(args, tmp):
    out = {"storage": [], "directions": [], "positional": []}
    print("\n### Storage: 4225 maps of 32x32, concentric\n")
    print("| bits | RMS error | bytes | AO CPU |")
    print("|---:|---:|---:|---:|")
    for bits in [32, 8, 1]:
        field, built = bunny_field(tmp, 65, 32, bits=bits)
        rms, ms = bunny_ao(args, tmp, field)
        out["storage"].append({"bits": bits, "rms": rms, "bytes": built["bytes"], "ao_ms": ms})
        print(f"| {bits} | {rms:.4f} | {built['bytes']:,} | {ms:.0f} ms |")
    print("\n### Direction sampling: 4225 maps of 32x32 texels, 8-bit\n")
    print("| sampling | RMS error |")
    print("|---|---:|")
    for d in ["concentric", "polar", "rejection"]:
        field, _ = bunny_field(tmp, 65, 32, directions=d)
        rms, _ = bunny_ao(args, tmp, field)
        out["directions"].append({"directions": d, "rms": rms})
        print(f"| {d} | {rms:.4f} |")
    print("\n### Positional interpolation: 32x32 8-bit concentric maps\n")
    print("| positional samples | nearest (the paper) | bilinear |")
    print("|---:|---:|---:|")
    for side in [17, 33, 65]:
        field, _ = bunny_field(tmp, side, 32)
        near, _ = bunny_ao(args, tmp, field, "nearest")
        bil, _ = bunny_ao(args, tmp, field, "bilinear")
        out["positional"].append({"maps": side * side, "nearest": near, "bilinear": bil})
        print(f"| {side * side:,} | {near:.4f} | {bil:.4f} |")
    return out


def main():
    p = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    p.add_argument("--repeat", type=int, default=3)
    p.add_argument("--json", type=Path)
    p.add_argument("--only", choices=["figure8", "figure6", "variants"])
    args = p.parse_args()
    if "PENUMBRA_DATA" not in os.environ:
        sys.exit("set PENUMBRA_DATA to the shared data folder (../shared/data)")
    if not EXE.exists():
        sys.exit(f"{EXE} is missing: cargo build --release first")
    tmp = tempfile.mkdtemp(prefix="field_tables_")
    results = {}
    try:
        if args.only in (None, "figure8"):
            results["figure8"] = figure8(args, tmp, gpu_available())
        if args.only in (None, "figure6"):
            results["figure6"] = figure6(args, tmp)
        if args.only in (None, "variants"):
            results["variants"] = variants(args, tmp)
    finally:
        shutil.rmtree(tmp, ignore_errors=True)
    if args.json:
        args.json.write_text(json.dumps(results, indent=1))


if __name__ == "__main__":
    main()
