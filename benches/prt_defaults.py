#!/usr/bin/env python3
"""PRT with default settings on meshes we did not make (issue 15): transfer
error against `--check`, the self-check's estimate, and frames per second,
for the current build and optionally an older one. Run serially on a quiet
machine:

    PENUMBRA_DATA=../shared/data python3 benches/prt_defaults.py [--before OLD_BINARY]

Meshes: the shared cow, spot, teapot, Stanford bunny and dragon, both built-in
animations, and three written here (the same formulas as
tests/prt_defaults.rs): a spiky ball, a thin closed shell and a curtain of
overhanging folds. Every figure comes from `penumbra prt ... --json`; the
commands are printed. Accuracy runs use one frame (the animations 30 frames,
4 checked, as Table 1 does); speed runs `--frames N` without checks, twice
per binary, interleaved, keeping the faster.
"""
import argparse, json, math, os, subprocess, sys, tempfile

ap = argparse.ArgumentParser()
ap.add_argument("--bin", default="target/release/penumbra")
ap.add_argument("--before", help="an older penumbra binary to compare with")
ap.add_argument("--probe", default="grace")
ap.add_argument("--only", help="comma-separated mesh names")
a = ap.parse_args()
data = os.environ.get("PENUMBRA_DATA")
if not data:
    sys.exit("set PENUMBRA_DATA to the shared data folder")
env = os.path.join(data, "probes", a.probe + ".hdr")


def write_obj(path, verts, faces):
    with open(path, "w") as f:
        for v in verts:
            f.write("v %.7f %.7f %.7f\n" % v)
        for t in faces:
            f.write("f %d %d %d\n" % tuple(i + 1 for i in t))


def sphere_grid(seg, rings):
    ring = lambda k, i: 1 + (k - 1) * seg + i % seg
    bottom = 1 + (rings - 1) * seg
    f = []
    for i in range(seg):
        f += [(0, ring(1, i + 1), ring(1, i)), (bottom, ring(rings - 1, i), ring(rings - 1, i + 1))]
    for k in range(1, rings - 1):
        for i in range(seg):
            p, q, r, s = ring(k, i), ring(k, i + 1), ring(k + 1, i + 1), ring(k + 1, i)
            f += [(p, q, r), (p, r, s)]
    return f


def spiky(seg=48, rings=24):
    v = [(0.0, 1.0, 0.0)]
    for k in range(1, rings):
        th = math.pi * k / rings
        for i in range(seg):
            ph = 2 * math.pi * i / seg
            r = 1.9 if (k % 4 == 2 and i % 6 == (k // 4) % 6) else 1.0
            v.append((r * math.sin(th) * math.cos(ph), r * math.cos(th), r * math.sin(th) * math.sin(ph)))
    v.append((0.0, -1.0, 0.0))
    return v, sphere_grid(seg, rings)


def shell(seg=48, half=12, t=0.03):
    n = 1 + half * seg
    v = []
    for r in (1.0, 1.0 - t):
        v.append((0.0, -r, 0.0))
        for k in range(1, half + 1):
            th = math.pi / 2 * k / half
            for i in range(seg):
                ph = 2 * math.pi * i / seg
                v.append((r * math.sin(th) * math.cos(ph), -r * math.cos(th), r * math.sin(th) * math.sin(ph)))
    ring = lambda s, k, i: s * n + 1 + (k - 1) * seg + i % seg
    f = []
    for s in (0, 1):
        push = lambda t: f.append(t[::-1] if s == 1 else t)
        for i in range(seg):
            push((s * n, ring(s, 1, i), ring(s, 1, i + 1)))
        for k in range(1, half):
            for i in range(seg):
                p, q, r_, s_ = ring(s, k, i), ring(s, k, i + 1), ring(s, k + 1, i + 1), ring(s, k + 1, i)
                push((p, s_, r_))
                push((p, r_, q))
    for i in range(seg):
        p, q, r_, s_ = ring(0, half, i), ring(0, half, i + 1), ring(1, half, i + 1), ring(1, half, i)
        f += [(p, s_, r_), (p, r_, q)]
    return v, f


def curtain(nx=64, ny=40):
    v = []
    for j in range(ny):
        t = j / (ny - 1)
        for i in range(nx):
            u = i / (nx - 1)
            amp = 0.22 * (0.4 + t)
            w = 7 * math.pi * u
            v.append((-1 + 2 * u + 0.6 * amp * math.cos(w), 1.4 * t, amp * math.sin(w)))
    f = []
    for j in range(ny - 1):
        for i in range(nx - 1):
            p = j * nx + i
            f += [(p, p + 1, p + nx + 1), (p, p + nx + 1, p + nx)]
    return v, f


tmp = tempfile.mkdtemp(prefix="prt-defaults-")
ours = {}
for name, make in [("spiky", spiky), ("shell", shell), ("curtain", curtain)]:
    path = os.path.join(tmp, name + ".obj")
    write_obj(path, *make())
    ours[name] = path

meshes = ["cow", "spot", "teapot", "stanford-bunny", "cloth", "character", "spiky", "shell", "curtain", "dragon100k"]
if a.only:
    meshes = a.only.split(",")


def source(m):
    if m in ("cloth", "character"):
        return ["--animated", m]
    return ["--mesh", ours.get(m) or os.path.join(data, "models", m + ".obj")]


def run(binary, args):
    cmd = [binary, "prt", "--env", env, "--json", "--device", "cpu"] + args
    print("$ " + " ".join(cmd), file=sys.stderr)
    out = subprocess.run(cmd, capture_output=True, text=True)
    if out.returncode != 0:
        sys.exit(out.stderr)
    return json.loads(out.stdout)


def accuracy(binary, m):
    extra = ["--frames", "30", "--check-frames", "4"] if m in ("cloth", "character") else []
    return run(binary, source(m) + extra + ["--check"])


def speed(binary, m, new):
    frames = "5" if m in ("stanford-bunny", "dragon100k") else "60"
    return run(binary, source(m) + ["--frames", frames] + (["--self-check", "off"] if new else []))


binaries = [("before", a.before, False)] if a.before else []
binaries.append(("after", a.bin, True))
rows = {}
for m in meshes:
    row = {}
    for label, binary, new in binaries:
        j = accuracy(binary, m)
        row[label] = {"err": j["transfer_l2_error"], "self": j.get("self_check"), "json": j, "fps": 0.0}
    for _ in range(2):
        for label, binary, new in binaries:
            j = speed(binary, m, new)
            row[label]["fps"] = max(row[label]["fps"], j["fps"])
            row[label]["drawn"] = j["avg_blockers_per_vertex"]
    rows[m] = row

print("\n| mesh | triangles | error before | fps before | error after | self-check (+/- 1 s.e.) | fps after | blockers/vertex before -> after | culling, two-sided after |")
print("|---|---|---|---|---|---|---|---|---|")
for m in meshes:
    r = rows[m]
    aft = r["after"]
    j = aft["json"]
    sc = aft["self"]
    before = r.get("before")
    b_err = f"{100 * before['err']:.2f}%" if before else "-"
    b_fps = f"{before['fps']:.2f}" if before else "-"
    b_drawn = f"{before['drawn']:.0f} -> " if before else ""
    print(
        f"| {m} | {j['triangles']} | {b_err} | {b_fps} | {100 * aft['err']:.2f}% | "
        f"{100 * sc['estimate']:.2f}% (+/- {100 * sc['uncertainty']:.2f}) | {aft['fps']:.2f} | "
        f"{b_drawn}{aft['drawn']:.0f} | {'on' if j['backface_culling'] else 'off'}, {'on' if j['two_sided'] else 'off'} |"
    )
