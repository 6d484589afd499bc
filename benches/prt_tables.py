#!/usr/bin/env python3
"""The paper's Tables 1 and 2 for penumbra's animated scenes, plus the
integration and LUT-size variants. Run serially on a quiet machine:

    PENUMBRA_DATA=../shared/data python3 benches/prt_tables.py [--frames 120]

Every figure comes from `penumbra prt ... --json`; the commands are printed.
"""
import argparse, json, os, subprocess, sys

ap = argparse.ArgumentParser()
ap.add_argument("--frames", type=int, default=120)
ap.add_argument("--gpu-frames", type=int, default=20)
ap.add_argument("--probe", default="grace")
ap.add_argument("--bin", default="target/release/penumbra")
a = ap.parse_args()
data = os.environ.get("PENUMBRA_DATA")
if not data:
    sys.exit("set PENUMBRA_DATA to the shared data folder")
env = os.path.join(data, "probes", a.probe + ".hdr")

def run(args):
    cmd = [a.bin, "prt", "--env", env, "--json"] + args
    print("$ " + " ".join(cmd), file=sys.stderr)
    out = subprocess.run(cmd, capture_output=True, text=True)
    if out.returncode != 0:
        sys.exit(out.stderr)
    return json.loads(out.stdout)

scenes = ["cloth", "character"]
print("### Table 1\n")
print("| scene | vertices | triangles | low-res triangles | blockers/vertex | blockers/vertex with PVS | fps CPU (2 threads) | fps CPU with PVS | fps GPU (lavapipe) | GPU kernel ms/frame | L2 transfer error |")
print("|---|---|---|---|---|---|---|---|---|---|---|")
for s in scenes:
    base = ["--animated", s, "--frames", str(a.frames)]
    cpu = run(base + ["--device", "cpu", "--check", "--check-frames", "4"])
    pvs = run(base + ["--device", "cpu", "--pvs", "on"])
    gpu = run(["--animated", s, "--frames", str(a.gpu_frames), "--device", "gpu"])
    print(f"| {s} | {cpu['vertices']} | {cpu['triangles']} | {cpu['hierarchy']['low_res_triangles']} | "
          f"{cpu['avg_blockers_per_vertex']:.1f} | {pvs['avg_blockers_per_vertex']:.1f} | {cpu['fps']:.0f} | {pvs['fps']:.0f} | "
          f"{gpu['fps']:.1f} | {gpu['gpu_ms_per_frame']:.1f} | {100*cpu['transfer_l2_error']:.2f}% |")

print("\n### Table 2 (share of frame time, CPU, 2 threads; GPU: integration = kernel)\n")
print("| scene | device | rasterization | integration | transform | other | ms/frame |")
print("|---|---|---|---|---|---|---|")
for s in scenes:
    for dev, frames in [("cpu", a.frames), ("gpu", a.gpu_frames)]:
        j = run(["--animated", s, "--frames", str(frames), "--device", dev, "--profile"])
        p = j["phases"]
        print(f"| {s} | {dev} | {100*p['rasterization']:.0f}% | {100*p['integration']:.0f}% | {100*p['transform']:.0f}% | {100*p['other']:.0f}% | {j['frame_ms']['mean']:.2f} |")

print("\n### Knobs on the cloth (CPU, 2 threads): speed against L2 error\n")
print("| setting | fps | L2 transfer error |")
print("|---|---|---|")
for label, extra in [
    ("default (32x32, LUT 128, 5 bands, cells-linear, hierarchy)", []),
    ("--integration cells (the paper's grey levels)", ["--integration", "cells"]),
    ("--integration pixels", ["--integration", "pixels"]),
    ("--lut 64", ["--lut", "64"]),
    ("--lut 256", ["--lut", "256"]),
    ("--mask 16 --lut 64", ["--mask", "16", "--lut", "64"]),
    ("--mask 64 --lut 256", ["--mask", "64", "--lut", "256"]),
    ("--hierarchy off", ["--hierarchy", "off"]),
    ("--coarse-tolerance 0 (the paper's plain two levels)", ["--coarse-tolerance", "0"]),
    ("--near rings", ["--near", "rings"]),
    ("--near rings --coarse-tolerance 0", ["--near", "rings", "--coarse-tolerance", "0"]),
    ("--pvs on", ["--pvs", "on"]),
    ("--order 3", ["--order", "3"]),
    ("--brdf phong", ["--brdf", "phong"]),
    ("--shadows off", ["--shadows", "off"]),
]:
    j = run(["--animated", "cloth", "--frames", str(a.frames), "--device", "cpu", "--check", "--check-frames", "4"] + extra)
    print(f"| {label} | {j['fps']:.0f} | {100*j['transfer_l2_error']:.2f}% |")
