#!/usr/bin/env python3
"""Golden regression harness for the `penumbra` command line.

Runs one fixed set of command lines (every subcommand on --device cpu and,
where it has one, gpu; every --help; the guide's examples; the bad inputs of
tests/cli*.rs) with a binary, records everything observable, and compares
two recordings. Python 3.11, standard library only.

    python3 golden.py record --bin PATH --out DIR [--only REGEX] [--jobs N] [-v]
    python3 golden.py compare DIR_A DIR_B [--raw] [--max-details N]
    python3 golden.py volatile DIR_A DIR_B   # every raw difference, by JSON key / line / file
    python3 golden.py summary DIR            # case counts by subcommand, device, outcome
    python3 golden.py list [--only REGEX]

record
    Inputs are snapshotted once into ./inputs/ (next to this script) at
    first use: repo files (assets/, tests/) are read with `git show` from
    the commit INPUTS_COMMIT of --repo (default: this repository), falling
    back to its work tree; shared data from --data (default
    ../shared/data beside the repository); generated inputs (bad OBJs, ray files,
    probes, scene files, ...) are written by this script (GEN). Later
    records only read ./inputs/, so they do not depend on where the repo
    keeps its files. Every case runs in its own fresh working directory at
    the fixed path /tmp/pg/<case> (messages that echo paths are then
    identical between runs and binaries; a lock file keeps two records from
    running at once), with the inputs it names copied to ./in/ there and
    passed by relative paths (in/assets/corner.obj, ...). argv[0] is always
    "penumbra", whatever the binary's path (clap prints it in usage lines).
    Environment: a fixed minimal one (PATH, HOME, LANG=C.UTF-8, a private
    XDG_RUNTIME_DIR, XDG_CACHE_HOME and PENUMBRA_CACHE_DIR inside the case
    dir, PENUMBRA_DATA=<case>/in/data, a Mesa shader cache shared by all
    cases so GPU pipelines compile once: the cache changes compile times
    only), plus the case's own variables; stdin is /dev/null. Per step it
    keeps argv, env, exit code, stdout, stderr and every file created,
    changed or deleted in the case directory (hash + the file itself), and
    the directories created. A case may have several steps (build a field,
    then use it) and harness-side steps (truncate a file, flip a bit).

compare
    Per case and step: argv (must be the same), exit code, stdout, stderr,
    output files (the set of names, then contents), deleted files, created
    directories. Prints a table of counts and every difference (first
    differing JSON key, line or byte) and exits 1 on any difference.
    --raw compares without any normalisation.

    JSON is compared strictly apart from the rules below: numbers as
    written (1 and 1.0 differ; no float rounding), key order, and the
    layout (every --json stdout is one compact line ending in a newline).

Normalisation (kept minimal; derived with `volatile base1 base2` on two
baseline recordings; nothing else is ignored or skipped):

 1. JSON values of timing keys become "<t>": in --json stdout, in the
    `key: value` lines stdout prints without --json (including values that
    are JSON objects there), and in JSON files written that are not
    byte-identical. Timing keys (TIMING_KEY) are exactly: `ms` and names
    with `ms` as an underscore-separated word (build_ms, ao_ms, runs.min_ms,
    times_ms, ao_ms_mean, gpu_ms_per_frame, phases_ms, frame_ms, ...),
    `fps`, `fps_best`, `mrays_per_s`, `estimated_s` (sweep's forecast),
    `speedup` (bounded vs Whitted time) and `phases` (prt --profile: the
    share of time per phase).
 2. stderr and non-JSON stdout lines (STDERR_RULES): `penumbra: progress:`
    lines are dropped (--progress prints at most one a second, so their
    number and counts follow the speed); `about N s more` (sweep's
    forecast) and `; checked, N ms)` / `; cached, N ms)` (max-error's check
    time) get `<n>` for N.
 3. sweep's Pareto front is decided by measured times: in cases `sweep.*`
    the JSON keys `front` and `pareto` are dropped, sweep.csv is compared
    without its `time_ms` and `pareto` columns, and sweep.png (error
    plotted against time) by its PNG header (width, height, depth, colour
    type) only.
 4. No rule: `--max-error` picks the *fastest* candidate within the budget
    for ssao and prt (timing dependent), so those cases use an impossible
    budget (then the most accurate candidate is used: deterministic); field
    tries candidates cheapest-first (deterministic). The choice cache they
    write (cache/max-error-choices.json) holds candidate times: rule 1.

VOLATILE lists these cases with the reason; compare prints it every time.
Everything else (GPU outputs on lavapipe included) was byte-identical
across recordings, with warm and cold shader caches and --jobs 1 and 2.
"""

import argparse
import fcntl
import hashlib
import json
import math
import os
import re
import shlex
import shutil
import signal
import struct
import subprocess
import sys
import threading
import time
import zlib
from concurrent.futures import ThreadPoolExecutor
from pathlib import Path

HERE = Path(__file__).resolve().parent
INPUTS = HERE / "inputs"
CASE_ROOT = Path("/tmp/pg")
DEFAULT_REPO = HERE.parent.parent
DEFAULT_DATA = DEFAULT_REPO.parent / "shared" / "data"
# The commit whose assets/ and tests/ the input list names (the layout before
# the workspace split); inputs are read from it with `git show`, so any later
# binary runs on exactly the same files.
INPUTS_COMMIT = "fc355c6012de50826d28054ea7162b3ab3636e78"

# ---------------------------------------------------------------------------
# Normalisation rules (see the docstring). Keep these short and explicit.
# ---------------------------------------------------------------------------

# JSON keys whose values are measured times or derived from them (rule 1).
# `(.*_)?ms(_.*)?`: ms, build_ms, ao_ms, runs.min_ms, times_ms, ao_ms_mean,
# gpu_ms_per_frame, phases_ms (a dict of times), frame_ms (number, list or dict).
TIMING_KEY = re.compile(r"^(.*_)?ms(_.*)?$|^(fps|fps_best|mrays_per_s|estimated_s|speedup|phases)$")

# Rule 2: stderr and non-JSON stdout lines.
DROP_LINE = re.compile(r"^penumbra: progress:")
STDERR_RULES = [
    # sweep: "4 settings x 2 repeats; about 3 s more (as the first run took)"
    (re.compile(r"about \d+ s more"), "about <n> s more"),
    # max-error: "(error 0.07, at most 0.08 at 95% confidence; checked, 139 ms)"
    (re.compile(r"; (checked|cached), \d+ ms\)"), r"; \1, <n> ms)"),
]
# Summary lines on stdout without --json: "key: value" (value maybe JSON).
KEY_VALUE = re.compile(r"^(\s*)([A-Za-z0-9_]+): (.*)$")

# Rule 3: files of sweep cases (and the JSON sweep prints).
SWEEP_JSON_DROP = {"front", "pareto"}
SWEEP_CSV_DROP = {"time_ms", "pareto"}

# Cases whose baseline output differs between two recordings beyond rules 1
# and 2, and what is done about them (printed by compare).
VOLATILE = {
    "sweep.*": "Pareto front, per-row pareto flags and the error-vs-time plot depend on measured "
               "times: rule 3 (front/pareto dropped, sweep.csv without time_ms/pareto, sweep.png by header)",
    "*.progress.*": "progress lines (--progress) are rate-limited to one a second: dropped (rule 2)",
    "*max-error*": "the check's duration is printed on stderr and the cache file holds candidate times "
                   "(rules 1, 2); budgets chosen so the choice does not depend on speed (rule 4)",
}


class Lit(str):
    """A JSON number as written (1.0 and 1 stay different; no float rounding)."""


def jparse(text):
    return json.loads(text, parse_float=Lit, parse_int=Lit, parse_constant=Lit)


def canon(v):
    """Compact JSON text of a parsed value, numbers as written, keys in file order."""
    if isinstance(v, dict):
        return "{" + ",".join(json.dumps(k, ensure_ascii=False) + ":" + canon(x) for k, x in v.items()) + "}"
    if isinstance(v, list):
        return "[" + ",".join(canon(x) for x in v) + "]"
    if isinstance(v, Lit):
        return str(v)
    return json.dumps(v, ensure_ascii=False)


def norm_json(v, drop=()):
    if isinstance(v, dict):
        return {k: ("<t>" if TIMING_KEY.match(k) else norm_json(x, drop)) for k, x in v.items() if k not in drop}
    if isinstance(v, list):
        return [norm_json(x, drop) for x in v]
    return v


def norm_line(line, drop=()):
    m = KEY_VALUE.match(line)
    if m:
        indent, key, val = m.groups()
        if TIMING_KEY.match(key):
            return f"{indent}{key}: <t>"
        if key in drop:
            return f"{indent}{key}: <dropped>"
        try:
            v = jparse(val)
        except ValueError:
            v = None
        if isinstance(v, (dict, list)):
            return f"{indent}{key}: " + canon(norm_json(v, drop))
    for rx, rep in STDERR_RULES:
        line = rx.sub(rep, line)
    return line


def norm_text(text, drop=()):
    return "\n".join(norm_line(l, drop) for l in text.split("\n") if not DROP_LINE.match(l))


def parse_json_stdout(text):
    """The single JSON object of a --json stdout, or None."""
    s = text.strip()
    if not s.startswith("{"):
        return None
    try:
        v = jparse(s)
    except ValueError:
        return None
    return v if isinstance(v, dict) else None


def json_layout(text, v):
    """How a JSON text is laid out: 'compact+newline' (what every --json prints), or for
    pretty files the indentation step, the final newline and the separator style (line counts
    are left out: they follow the values, e.g. sweep's front)."""
    if canon(v) + "\n" == text:
        return "compact+newline"
    if canon(v) == text:
        return "compact"
    indents = [len(l) - len(l.lstrip(" ")) for l in text.split("\n")]
    step = min([i for i in indents if i > 0], default=0)
    return f"pretty: newlines {text.count(chr(10)) > 1}, indent {step}, final newline {text.endswith(chr(10))}, ': ' {': ' in text}"


# ---------------------------------------------------------------------------
# Inputs
# ---------------------------------------------------------------------------

class Inputs:
    def __init__(self, repo, data):
        self.repo = Path(repo)
        self.data = Path(data)
        self.commit = INPUTS_COMMIT
        self.lock = threading.Lock()

    def _from_repo(self, rel):
        if self.commit and (self.repo / ".git").exists():
            r = subprocess.run(["git", "-C", str(self.repo), "show", f"{self.commit}:{rel}"],
                               stdout=subprocess.PIPE, stderr=subprocess.DEVNULL)
            if r.returncode == 0:
                return r.stdout
        p = self.repo / rel
        if p.is_file():
            return p.read_bytes()
        raise FileNotFoundError(f"input {rel}: not in {self.repo} at {self.commit} nor in its work tree")

    def ensure(self, name):
        """Path of input `name` in the snapshot, fetching it at first use."""
        dest = INPUTS / name
        if dest.is_file():
            return dest
        with self.lock:
            if dest.is_file():
                return dest
            if name.startswith(("assets/", "tests/")):
                data = self._from_repo(name)
            elif name.startswith("data/"):
                data = (self.data / name[len("data/"):]).read_bytes()
            elif name.startswith("gen/"):
                gen = GEN.get(name[len("gen/"):])
                if gen is None:
                    raise KeyError(f"no generator for input {name}")
                data = gen(self) if callable(gen) else gen
                if isinstance(data, str):
                    data = data.encode()
            else:
                raise KeyError(f"unknown input {name}")
            dest.parent.mkdir(parents=True, exist_ok=True)
            tmp = dest.with_name(dest.name + ".part")
            tmp.write_bytes(data)
            tmp.rename(dest)
            return dest

    def read(self, name):
        return self.ensure(name).read_bytes()


# ---- generated inputs ----------------------------------------------------

def f32s(values):
    return b"".join(struct.pack("<f", v) for v in values)


def rays(rs):
    return b"".join(f32s(r) for r in rs)


NAN, INF = float("nan"), float("inf")
DOWN = [-500.0, 2.0, 500.0, 0.0, -1.0, 0.0]


class XorShift:
    """tests/common/mod.rs's Rng."""

    def __init__(self, s):
        self.s = s

    def f32(self):
        m = (1 << 64) - 1
        self.s ^= (self.s << 13) & m
        self.s ^= self.s >> 7
        self.s ^= (self.s << 17) & m
        return (self.s >> 40) / float(1 << 24)


def obj_bounds(text):
    lo, hi = [INF] * 3, [-INF] * 3
    for line in text.splitlines():
        if line.startswith("v "):
            c = [float(x) for x in line.split()[1:4]]
            lo = [min(a, b) for a, b in zip(lo, c)]
            hi = [max(a, b) for a, b in zip(hi, c)]
    return lo, hi


def random_rays(inp, mesh, n, seed):
    lo, hi = obj_bounds(inp.read(mesh).decode())
    ext = [h - l for l, h in zip(lo, hi)]
    ctr = [(l + h) / 2 for l, h in zip(lo, hi)]
    rng = XorShift(seed)
    out = []
    for _ in range(n):
        o = [ctr[k] + (rng.f32() * 3.0 - 1.5) * ext[k] for k in range(3)]
        t = [lo[k] + rng.f32() * ext[k] for k in range(3)]
        out.append(o + [t[k] - o[k] for k in range(3)])
    return rays(out)


def rgbe(c):
    v = max(c)
    if v < 1e-32:
        return bytes(4)
    m, e = math.frexp(v)
    s = m * 256.0 / v
    return bytes([int(c[0] * s), int(c[1] * s), int(c[2] * s), e + 128])


def hdr_probe(sky, ground, w=32, h=16):
    """tests/common/cli.rs's write_probe: sky above the horizon, ground below (RLE scanlines)."""
    out = bytearray(b"#?RADIANCE\nFORMAT=32-bit_rle_rgbe\n\n" + f"-Y {h} +X {w}\n".encode())
    for row in range(h):
        px = rgbe(sky if row < h // 2 else ground)
        out += bytes([2, 2, w >> 8, w & 255])
        for comp in range(4):
            i = 0
            while i < w:
                n = min(128, w - i)
                out += bytes([n]) + bytes([px[comp]]) * n
                i += n
    return bytes(out)


def hdr_header(w, h):
    return f"#?RADIANCE\nFORMAT=32-bit_rle_rgbe\n\n-Y {h} +X {w}\n"


def cube_in_corner(inp):
    lines = []
    for l in inp.read("assets/cube-with-hole.obj").decode().splitlines():
        if l.startswith("v "):
            c = [float(x) for x in l[2:].split()]
            lines.append("v %r %r %r" % (0.15 * c[0] + 0.4, 0.15 * c[1] + 0.2, 0.15 * c[2] + 0.4))
        else:
            lines.append(l)
    return "\n".join(lines)


def ground_under_wall(inp):
    lo, hi = obj_bounds(inp.read("assets/wall-on-floor.obj").decode())
    c = [(a + b) / 2 for a, b in zip(lo, hi)]
    half = max(b - a for a, b in zip(lo, hi))
    n = 48
    at = lambda i: 2.0 * i / (n - 1) - 1.0
    text = ""
    for i in range(n * n):
        text += "v %r %r %r\n" % (c[0] + at(i % n) * half, lo[1], c[2] + at(i // n) * half)
    for q in range((n - 1) * (n - 1)):
        i = q // (n - 1) * n + q % (n - 1)
        for t in ([i, i + n, i + 1], [i + 1, i + n, i + n + 1]):
            text += "f %d %d %d\n" % (t[0] + 1, t[1] + 1, t[2] + 1)
    return text


def garbage_bytes(n, seed):
    rng = XorShift(seed)
    return bytes(int(rng.f32() * 256.0) for _ in range(n))


def corner_scene(caster, **extra):
    s = {"meshes": {"corner": "../assets/corner.obj", "sphere": "../assets/sphere-on-plane.obj"},
         "instances": [{"mesh": "corner", "role": "receiver"}, caster]}
    s.update(extra)
    return json.dumps(s)


TRI = "v 0 0 0\nv 1 0 0\nv 0 1 0\n"
GLTF = json.dumps({
    "asset": {"version": "2.0"}, "buffers": [{"uri": "tri%20data.bin", "byteLength": 36}],
    "bufferViews": [{"buffer": 0, "byteLength": 36}],
    "accessors": [{"bufferView": 0, "componentType": 5126, "count": 3, "type": "VEC3",
                   "min": [0, 0, 0], "max": [1, 1, 0]}],
    "meshes": [{"primitives": [{"attributes": {"POSITION": 0}}]}],
    "nodes": [{"mesh": 0}], "scenes": [{"nodes": [0]}], "scene": 0})

GEN = {
    # bad OBJ files (tests/cli.rs section 1, cli_guards.rs, cli_field.rs)
    "bad/two.obj": "v 0 0\nv 1 0 0\nv 0 1 0\nf 1 2 3\n",
    "bad/word.obj": "v 0 0 0\nv 1 zero 0\nv 0 1 0\nf 1 2 3\n",
    "bad/nan.obj": "v 0 0 0\nv 1 0 0\nv 0 nan 0\nf 1 2 3\n",
    "bad/inf.obj": "# comment\nv 0 0 0\nv inf 0 0\nv 0 1 0\nf 1 2 3\n",
    "bad/neginf.obj": "v 0 0 0\nv 1 0 0\nv 0 1 -inf\nf 1 2 3\n",
    "bad/overflow.obj": "v 0 0 0\nv 1e39 0 0\nv 0 1 0\nf 1 2 3\n",
    "bad/range.obj": "v 0 0 0\nv 1 0 0\nv 0 1 0\n\nf 1 2 7\n",
    "bad/zero.obj": "v 0 0 0\nv 1 0 0\nv 0 1 0\nf 0 1 2\n",
    "bad/edge.obj": "v 0 0 0\nv 1 0 0\nv 0 1 0\nf 1 2 3\nf 1 2\n",
    "bad/negative.obj": "v 0 0 0\nv 1 0 0\nv 0 1 0\nf -4 -2 -1\n",
    "bad/empty.obj": "",
    "bad/comments.obj": "# just a comment\n# and another\n\n",
    "bad/vertices-only.obj": "v 0 0 0\nv 1 0 0\nv 0 1 0\n",
    "bad/garbage.obj": lambda inp: garbage_bytes(4096, 0x9E3779B97F4A7C15),
    "bad/huge.obj": "v 0 0 0\nv 3e38 0 0\nv 0 3e38 0\nf 1 2 3\nf 99999999999999999999 1 2\n",
    "bad/huge-index.obj": "v 0 0 0\nv 1 0 0\nv 0 1 0\nf 1 2 4294967297\n",
    "bad/digits.obj": "v 0 0 0\nv 1 0 0\nv 0 1 0\nf 1 2 99999999999999999999999\n",
    "bad/nan-first.obj": "v nan 0 0\nv 1 0 0\nv 0 1 0\nf 1 2 3\n",
    "bad/nan-z.obj": "v 0 0 0\nv 1 0 nan\nv 0 1 0\nf 1 2 3\n",
    "bad/nothing.obj": "# nothing\n",
    "bad/unknown.xyz": b"\x00\x01\x02binary-ish\xff\xfe",
    "degenerate.obj": "v 1 1 1\nv 1 1 1\nv 1 1 1\nf 1 2 3\n",
    "bom.obj": lambda inp: "\ufeff".encode() + inp.read("assets/sphere-on-plane.obj"),
    "tri.obj": TRI + "f 1 2 3\n",
    "mesh.ply": "ply\nformat ascii 1.0\nelement vertex 3\nproperty float x\nproperty float y\nproperty float z\n"
                "element face 1\nproperty list uchar int vertex_indices\nend_header\n0 0 0\n1 0 0\n0 1 0\n3 0 1 2\n",
    "t.gltf": GLTF,
    "tri data.bin": f32s([0, 0, 0, 1, 0, 0, 0, 1, 0]),
    "cube-in-corner.obj": cube_in_corner,
    "ground.obj": ground_under_wall,
    # ray files (tests/cli.rs section 2)
    "rays/down.f32": rays([DOWN]),
    "rays/odd.f32": rays([DOWN]) + b"\x00",
    "rays/nan.f32": rays([DOWN, DOWN, [0.0, 2.0, 0.0, 0.0, NAN, 0.0]]),
    "rays/inf.f32": rays([DOWN, [INF, 2.0, 0.0, 0.0, -1.0, 0.0]]),
    "rays/zero.f32": rays([[0.0, 2.0, 0.0, 0.0, 0.0, 0.0]]),
    "rays/empty.f32": b"",
    "rays/half.f32": bytes(12),
    "rays/zeros24.f32": bytes(24),
    "rays/nan-dir.f32": rays([[0.0, 2.0, 0.0, NAN, -1.0, 0.0]]),
    "rays/known5.f32": rays([
        [-500.0, 2.0, 500.0, 0.0, -4.0, 0.0], [500.0, 2.0, -500.0, 0.0, -4.0, 0.0],
        [-500.0, 2.0, 500.0, 1.0, -1.0, 0.0], [-500.0, 2.0, 500.0, 0.0, 1.0, 0.0],
        [500.0, 2.0, -500.0, 3.0, 0.5, -2.0]]),
    "rays/sphere2000.f32": lambda inp: random_rays(inp, "assets/sphere-on-plane.obj", 2000, 2024),
    "rays/sphere200.f32": lambda inp: random_rays(inp, "assets/sphere-on-plane.obj", 200, 7),
    "rays/cow1000.f32": lambda inp: random_rays(inp, "data/models/cow.obj", 1000, 99),
    "rays/down-y3.f32": rays([[0.0, 3.0, 0.0, 0.0, -1.0, 0.0]]),
    # probes
    "probe.hdr": hdr_probe([2.0, 1.8, 1.5], [0.2, 0.2, 0.25]),
    "probe2.hdr": hdr_probe([2.0, 1.5, 1.0], [0.2, 0.25, 0.3]),
    "probe3.hdr": hdr_probe([0.9, 0.8, 0.7], [0.2, 0.2, 0.2]),
    "hdr/text.hdr": "not a Radiance file\n",
    "hdr/fake.hdr": "this is plain text, not a Radiance HDR file\n",
    "hdr/empty.hdr": hdr_header(0, 0),
    "hdr/vast.hdr": hdr_header(400000, 200000),
    "hdr/promise.hdr": hdr_header(4096, 2048),
    "hdr/env.hdr": "not read: refused first",
    # fields
    "dfield/garbage.dfield": b"this is not a field at all, not at all, no no no no no no no no no no no no no no no no no no no no no no no",
    # scene files (tests/cli.rs section 4); paths relative to in/gen/scenes/
    "scenes/broken.json": "{\n  \"meshes\": {},\n  \"instances\": [\n}\n",
    "scenes/binary.json": bytes([0xFF, 0xFE, 0x00, 0x7B]),
    "scenes/typo.json": corner_scene({"mesh": "sphere", "role": "caster", "scael": 0.2}).replace("../", "../../"),
    "scenes/unknown-mesh.json": corner_scene({"mesh": "bunny", "role": "caster"}).replace("../", "../../"),
    "scenes/scale0.json": corner_scene({"mesh": "sphere", "role": "caster", "scale": 0.0}).replace("../", "../../"),
    "scenes/scaleneg.json": corner_scene({"mesh": "sphere", "role": "caster", "scale": -2.0}).replace("../", "../../"),
    "scenes/axis.json": corner_scene({"mesh": "sphere", "role": "caster", "rotate": {"axis": [0, 0, 0], "degrees": 30}}).replace("../", "../../"),
    "scenes/noinstances.json": json.dumps({"meshes": {"corner": "../../assets/corner.obj"}, "instances": []}),
    "scenes/ghost.json": json.dumps({"meshes": {"ghost": "ghost-mesh.obj"}, "instances": [{"mesh": "ghost"}]}),
    "scenes/fake.hdr": "this is plain text, not a Radiance HDR file\n",
    "scenes/env.json": corner_scene({"mesh": "sphere", "role": "caster", "scale": 0.2},
                                    environment={"map": "fake.hdr"}).replace("../", "../../"),
    "scenes/data.json": json.dumps({"meshes": {"bunny": "$PENUMBRA_DATA/models/stanford-bunny.obj"},
                                    "instances": [{"mesh": "bunny"}]}),
    "scenes/valid.json": corner_scene({"mesh": "sphere", "role": "caster", "scale": 0.2, "translate": [0.5, 0.0, 0.5],
                                       "rotate": {"axis": [0, 1, 0], "degrees": 30}}).replace("../", "../../"),
    "scenes/frames.json": json.dumps({
        "meshes": {"corner": "../../assets/corner.obj", "cube": "../../assets/cube-with-hole.obj"},
        "instances": [{"mesh": "corner", "role": "receiver"},
                      {"mesh": "cube", "role": "caster", "scale": 0.15, "translate": [0.4, 0.2, 0.4],
                       "motion": {"degrees_per_frame": 20, "translate_per_frame": [0.05, 0, 0]}},
                      {"mesh": "cube", "role": "caster", "scale": 0.1, "translate": [0.2, 0.3, 0.7]}]}),
    "scenes/both.json": json.dumps({
        "meshes": {"corner": "../../assets/corner.obj", "cube": "../../assets/cube-with-hole.obj"},
        "instances": [{"mesh": "corner", "role": "receiver"},
                      {"mesh": "cube", "role": "both", "scale": 0.15, "translate": [0.35, 0.17, 0.35]},
                      {"mesh": "cube", "role": "both", "scale": 0.12, "translate": [0.75, 0.14, 0.3],
                       "rotate": {"axis": [0, 1, 0], "degrees": 30}}]}),
    "scenes/reach.json": json.dumps({
        "meshes": {"floor": "../../assets/corner.obj", "near": "../../assets/cube-with-hole.obj",
                   "far": "../../assets/sphere-on-plane.obj"},
        "instances": [{"mesh": "floor", "role": "receiver"},
                      {"mesh": "near", "role": "caster", "translate": [0.3, 0.15, 0.3], "scale": 0.12},
                      {"mesh": "far", "role": "caster", "translate": [9, 0, 0], "scale": 0.2}]}),
    "scenes/near-only.json": json.dumps({
        "meshes": {"floor": "../../assets/corner.obj", "near": "../../assets/cube-with-hole.obj",
                   "far": "../../assets/sphere-on-plane.obj"},
        "instances": [{"mesh": "floor", "role": "receiver"},
                      {"mesh": "near", "role": "caster", "translate": [0.3, 0.15, 0.3], "scale": 0.12}]}),
    "scenes/guard.json": json.dumps({"meshes": {"m": "../../assets/sphere-on-plane.obj"}, "instances": [{"mesh": "m"}]}),
    "scenes/gold.json": json.dumps({"meshes": {"a": "../rt/good.obj"}, "instances": [{"mesh": "a", "material": "gold"}]}),
    "scenes/sphere.json": json.dumps({"meshes": {"a": "../rt/good.obj"}, "instances": [{"mesh": "a"}],
                                      "spheres": [{"center": [0, 0, 0], "radius": -1}]}),
    # raytrace inputs (tests/cli_raytrace.rs, cli_guards.rs)
    "rt/good.obj": TRI + "f 1 2 3\n",
    "rt/bad.mtl": "newmtl m\nKd 0.5 abc 0.5\n",
    "rt/badmtl.obj": "mtllib bad.mtl\n" + TRI + "usemtl m\nf 1 2 3\n",
    "rt/badvn.obj": TRI + "vn 0 0 nan\nf 1//1 2//1 3//1\n",
    "rt/badvni.obj": TRI + "vn 0 0 1\nf 1//1 2//1 3//4\n",
    "rt/badni.mtl": "newmtl m\nNi -2\n",
    "rt/badni.obj": "mtllib badni.mtl\n" + TRI + "usemtl m\nf 1 2 3\n",
    "rt/a.obj": "mtllib missing.mtl\nmtllib tex.mtl\nv 0 0 0\nv 1 0 0\nv 0 1 0\nusemtl red\nf 1 2 3\nusemtl nowhere\nf 1 3 2\n",
    "rt/tex.mtl": "newmtl red\nKd 1 0 0\nmap_Kd red.png\n",
    "rt/badpath.txt": "0,0,5 0,0,0\n",
    "rt/path.txt": "# eye target fov\n0,3,8 0,0.8,0 45\n4,3,6 0,0.8,0 45\n",
    "rt/m.mtl": "newmtl red\nKd 1 0 0\n",
    "rt/m.obj": "mtllib m.mtl\nv 0 0 0\nv 1 0 0\nv 0 1 0\nusemtl red\nf 1 2 3\n",
    "rt/reg-ni.obj": "mtllib ../../tests/regressions/mtl/ni-zero-warning-per-line-repeats-a-long-name.mtl\n" + TRI + "f 1 2 3\n",
    "rt/reg-xyz.obj": "mtllib ../../tests/regressions/mtl/xyz-colour-overflows-rgb.mtl\n" + TRI + "f 1 2 3\n",
    # ssao MTL albedo (tests/cli_outputs.rs)
    "mtl/m.mtl": "newmtl red\nKd 1 0 0\n",
    "mtl/with.obj": "mtllib m.mtl\nv -1 0 -1\nv 0 0 -1\nv 0 0 1\nv -1 0 1\nv 1 0 -1\nv 1 0 1\nf 2 3 6 5\nusemtl red\nf 1 4 3 2\n",
    "mtl/without.obj": "v -1 0 -1\nv 0 0 -1\nv 0 0 1\nv -1 0 1\nv 1 0 -1\nv 1 0 1\nf 2 3 6 5\nf 1 4 3 2\n",
}

# Files an input needs beside it (MTLs, a scene's meshes, a glTF's buffer).
DEPS = {
    "assets/raytrace/checker-spheres.json": ["assets/raytrace/checker-spheres.obj"],
    "assets/raytrace/checker-spheres.obj": ["assets/raytrace/checker-spheres.mtl"],
    "assets/raytrace/cornell-mirror-glass.json": ["assets/raytrace/cornell-mirror-glass.obj"],
    "assets/raytrace/cornell-mirror-glass.obj": ["assets/raytrace/cornell-mirror-glass.mtl"],
    "assets/raytrace/tir-block.json": ["assets/raytrace/tir-block.obj"],
    "assets/raytrace/tir-block.obj": ["assets/raytrace/tir-block.mtl"],
    "assets/raytrace/grazing.json": ["assets/raytrace/grazing.obj"],
    "assets/raytrace/grazing.obj": ["assets/raytrace/grazing.mtl"],
    "assets/raytrace/inside-glass.json": ["assets/raytrace/checker-spheres.obj"],
    "data/scenes/CornellBox-Original.obj": ["data/scenes/CornellBox-Original.mtl"],
    "assets/scenes/chess.json": ["assets/chess/board.obj", "assets/chess/pawn.obj", "assets/chess/rook.obj",
                                 "assets/chess/bishop.obj"],
    "assets/scenes/cow-corner.json": ["assets/corner.obj", "data/models/cow.obj"],
    "assets/scenes/bunny-corner.json": ["assets/corner.obj", "data/models/stanford-bunny.obj"],
    "assets/animations/flag/flag-000.obj": [f"assets/animations/flag/flag-00{i}.obj" for i in range(1, 8)],
    "gen/t.gltf": ["gen/tri data.bin"],
    "gen/mtl/with.obj": ["gen/mtl/m.mtl"],
    "gen/rt/badmtl.obj": ["gen/rt/bad.mtl"],
    "gen/rt/badni.obj": ["gen/rt/badni.mtl"],
    "gen/rt/a.obj": ["gen/rt/tex.mtl"],
    "gen/rt/m.obj": ["gen/rt/m.mtl"],
    "gen/rt/reg-ni.obj": ["tests/regressions/mtl/ni-zero-warning-per-line-repeats-a-long-name.mtl"],
    "gen/rt/reg-xyz.obj": ["tests/regressions/mtl/xyz-colour-overflows-rgb.mtl"],
    "gen/scenes/gold.json": ["gen/rt/good.obj"],
    "gen/scenes/sphere.json": ["gen/rt/good.obj"],
    "gen/scenes/env.json": ["gen/scenes/fake.hdr", "assets/corner.obj", "assets/sphere-on-plane.obj"],
    "gen/scenes/valid.json": ["assets/corner.obj", "assets/sphere-on-plane.obj"],
    "gen/scenes/typo.json": ["assets/corner.obj", "assets/sphere-on-plane.obj"],
    "gen/scenes/unknown-mesh.json": ["assets/corner.obj", "assets/sphere-on-plane.obj"],
    "gen/scenes/scale0.json": ["assets/corner.obj", "assets/sphere-on-plane.obj"],
    "gen/scenes/scaleneg.json": ["assets/corner.obj", "assets/sphere-on-plane.obj"],
    "gen/scenes/axis.json": ["assets/corner.obj", "assets/sphere-on-plane.obj"],
    "gen/scenes/noinstances.json": ["assets/corner.obj"],
    "gen/scenes/frames.json": ["assets/corner.obj", "assets/cube-with-hole.obj"],
    "gen/scenes/both.json": ["assets/corner.obj", "assets/cube-with-hole.obj"],
    "gen/scenes/reach.json": ["assets/corner.obj", "assets/cube-with-hole.obj", "assets/sphere-on-plane.obj"],
    "gen/scenes/near-only.json": ["assets/corner.obj", "assets/cube-with-hole.obj", "assets/sphere-on-plane.obj"],
    "gen/scenes/guard.json": ["assets/sphere-on-plane.obj"],
}

# ---------------------------------------------------------------------------
# Cases
# ---------------------------------------------------------------------------

CASES = []
NAMES = set()


SUBCOMMANDS = ["info", "trace-rays", "ao", "trace", "prt", "field", "ssao", "raytrace", "sweep", "gen-assets"]


class Case:
    def __init__(self, name, steps, env=None, setup=(), inputs=(), timeout=180, note=None):
        self.name = name
        self.steps = steps
        self.env = env or {}
        self.setup = list(setup)
        self.inputs = list(inputs)
        self.timeout = timeout
        self.note = note

    @property
    def group(self):
        argv = next((s["argv"] for s in self.steps if "argv" in s), [])
        if any(a in ("--help", "-h", "--version") for a in argv) or (argv and argv[0] == "help") or not argv:
            return "help"
        if argv[0] == "field" and len(argv) > 1:
            return "field " + argv[1]
        if argv[0] not in SUBCOMMANDS:
            return "(top level)"
        return argv[0]

    @property
    def device(self):
        for s in self.steps:
            a = s.get("argv", [])
            for i, x in enumerate(a):
                if x == "--device" and i + 1 < len(a):
                    return a[i + 1]
        return "-"


def step(cmd, **kw):
    if isinstance(cmd, str):
        argv = shlex.split(cmd)
    else:
        argv = list(cmd)
    d = {"argv": argv}
    d.update(kw)
    return d


def C(name, *steps, **kw):
    assert name not in NAMES, name
    assert re.fullmatch(r"[A-Za-z0-9_.+-]+", name), name
    NAMES.add(name)
    st = [s if isinstance(s, dict) else step(s) for s in steps]
    CASES.append(Case(name, st, **kw))


def py(op, *args):
    """A harness-side step (the same for every binary): file manipulations between runs."""
    return {"py": [op] + list(args)}


# Shorthands for inputs (paths relative to the case directory).
A = "in/assets/"
CWH, CORNER, SOP, PLANE, BOX, WALL, WELL = (A + n for n in (
    "cube-with-hole.obj", "corner.obj", "sphere-on-plane.obj", "open-plane.obj", "closed-box.obj",
    "wall-on-floor.obj", "cylindrical-well.obj"))
COW, TEAPOT, BUNNY = "in/data/models/cow.obj", "in/data/models/teapot.obj", "in/data/models/stanford-bunny.obj"
GRACE, PISA, UFFIZI = "in/data/probes/grace.hdr", "in/data/probes/pisa.hdr", "in/data/probes/uffizi.hdr"
PROBE = "in/gen/probe.hdr"
CHECKER = A + "raytrace/checker-spheres.json"
G = "in/gen/"


def build_cases():
    # ---------------- help ------------------------------------------------
    C("help.top", "--help")
    C("help.top-h", "-h")
    C("help.version", "--version")
    C("help.noargs", [])
    C("help.help", "help")
    for sub in ["info", "trace-rays", "ao", "trace", "prt", "field", "field build", "field info", "ssao",
                "raytrace", "sweep", "gen-assets"]:
        C("help." + sub.replace(" ", "-"), f"{sub} --help")
    C("help.ao-short", "ao -h")
    C("help.help-ao", "help ao")
    C("help.help-field-build", "help field build")

    # ---------------- info ------------------------------------------------
    C("info.text", "info")
    C("info.json", "info --json")
    C("info.json.backend-vulkan", "info --json", env={"WGPU_BACKEND": "vulkan"})
    C("info.json.backend-gl", "info --json", env={"WGPU_BACKEND": "gl"})
    C("info.json.adapter-unmatched", "info --json", env={"WGPU_ADAPTER_NAME": "definitely-not-an-adapter"})
    C("info.bad-option", "info --frobnicate")

    # ---------------- trace-rays -----------------------------------------
    C("trace-rays.known5.cpu", f"trace-rays --mesh {PLANE} --rays {G}rays/known5.f32 --out hits.bin --device cpu --json")
    C("trace-rays.known5.text.cpu", f"trace-rays --mesh {PLANE} --rays {G}rays/known5.f32 --out hits.bin --device cpu")
    C("trace-rays.known5.kdtree.cpu", f"trace-rays --mesh {PLANE} --rays {G}rays/known5.f32 --out hits.bin --accel kdtree --device cpu --json")
    C("trace-rays.known5.gpu", f"trace-rays --mesh {PLANE} --rays {G}rays/known5.f32 --out hits.bin --device gpu --json")
    C("trace-rays.empty.cpu", f"trace-rays --mesh {PLANE} --rays {G}rays/empty.f32 --out hits.bin --device cpu --json")
    C("trace-rays.sphere2000.bvh.cpu", f"trace-rays --mesh {SOP} --rays {G}rays/sphere2000.f32 --out hits.bin --device cpu --json")
    C("trace-rays.sphere2000.kdtree.cpu", f"trace-rays --mesh {SOP} --rays {G}rays/sphere2000.f32 --out hits.bin --accel kdtree --device cpu --json")
    C("trace-rays.sphere2000.gpu", f"trace-rays --mesh {SOP} --rays {G}rays/sphere2000.f32 --out hits.bin --device gpu --json")
    C("trace-rays.cow1000.cpu", f"trace-rays --mesh {COW} --rays {G}rays/cow1000.f32 --out hits.bin --device cpu --threads 1 --json")
    C("trace-rays.cow1000.gpu", f"trace-rays --mesh {COW} --rays {G}rays/cow1000.f32 --out hits.bin --device gpu --json")
    C("trace-rays.repeat.cpu", f"trace-rays --mesh {SOP} --rays {G}rays/sphere200.f32 --out hits.bin --warmup 1 --repeat 3 --device cpu --json")
    C("trace-rays.ply-mesh.cpu", f"trace-rays --mesh {G}mesh.ply --rays {G}rays/sphere200.f32 --out hits.bin --device cpu --json")
    C("trace-rays.glb-mesh.cpu", f"trace-rays --mesh {A}animations/bending-tube.glb --rays {G}rays/sphere200.f32 --out hits.bin --device cpu --json")
    C("trace-rays.dump-from-trace.cpu",
      f"trace --mesh {CORNER} --width 20 --height 12 --dump-rays rays.f32 --device cpu --json",
      f"trace-rays --mesh {CORNER} --rays rays.f32 --out hits.bin --device cpu")
    # bad rays (tests/cli.rs section 2, 9)
    for n in ["odd", "nan", "inf", "zero", "half", "nan-dir"]:
        C(f"trace-rays.bad-rays.{n}", f"trace-rays --mesh {PLANE} --rays {G}rays/{n}.f32 --out hits.bin --device cpu")
    C("trace-rays.bad-rays.nan-dir.json", f"trace-rays --mesh {PLANE} --rays {G}rays/nan-dir.f32 --out hits.bin --device cpu --json")
    C("trace-rays.bad-rays.missing", f"trace-rays --mesh {PLANE} --rays nowhere.f32 --out hits.bin --device cpu")
    C("trace-rays.bad.out-folder-missing", f"trace-rays --mesh {PLANE} --rays {G}rays/down.f32 --out nowhere/hits.bin --device cpu")
    C("trace-rays.bad.out-is-rays", f"trace-rays --mesh {SOP} --rays {G}rays/zeros24.f32 --out {G}rays/zeros24.f32")
    C("trace-rays.bad.nan-mesh-bad-rays", f"trace-rays --mesh {G}bad/nan-first.obj --rays {G}rays/nan-dir.f32 --out hits.bin --device cpu")
    C("trace-rays.bad.huge-mesh-half", f"trace-rays --mesh {G}bad/huge.obj --rays {G}rays/half.f32 --out hits.bin --device cpu --json")
    C("trace-rays.bad.no-rays-option", f"trace-rays --mesh {PLANE} --out hits.bin --device cpu")
    C("trace-rays.bad.accel", f"trace-rays --mesh {PLANE} --rays {G}rays/down.f32 --out hits.bin --accel octree --device cpu")
    C("trace-rays.degenerate", f"trace-rays --mesh {G}degenerate.obj --rays {G}rays/down.f32 --out hits.bin --device cpu")

    # ---------------- bad meshes through trace-rays / ao / trace ----------
    bad_meshes = ["two", "word", "nan", "inf", "neginf", "overflow", "range", "zero", "edge", "negative",
                  "empty", "comments", "vertices-only", "garbage"]
    for m in bad_meshes:
        mesh = f"{G}bad/{m}.obj"
        C(f"badmesh.{m}.trace-rays", f"trace-rays --mesh {mesh} --rays {G}rays/down.f32 --out hits.bin --device cpu")
        C(f"badmesh.{m}.ao.json", f"ao --mesh {mesh} --method raycast --rays 4 --per-vertex ao.csv --device cpu --json")
        C(f"badmesh.{m}.trace", f"trace --mesh {mesh} --width 8 --height 8 --device cpu")
    for m in ["nan", "range"]:
        mesh = f"{G}bad/{m}.obj"
        C(f"badmesh.{m}.trace-rays.json", f"trace-rays --mesh {mesh} --rays {G}rays/down.f32 --out hits.bin --device cpu --json")
        C(f"badmesh.{m}.ao", f"ao --mesh {mesh} --method raycast --rays 4 --per-vertex ao.csv --device cpu")
        C(f"badmesh.{m}.trace.json", f"trace --mesh {mesh} --width 8 --height 8 --device cpu --json")
    C("badmesh.folder.ao", f"ao --mesh folder.obj --method raycast --rays 4 --per-vertex ao.csv --device cpu",
      setup=[("mkdir", "folder.obj")])
    C("badmesh.folder.trace", "trace --mesh folder.obj --width 8 --height 8 --device cpu --json", setup=[("mkdir", "folder.obj")])
    C("badmesh.missing.ao", "ao --mesh missing.obj --method raycast --rays 4 --per-vertex ao.csv --device cpu")
    C("badmesh.missing.trace-rays", f"trace-rays --mesh missing.obj --rays {G}rays/down.f32 --out hits.bin --device cpu --json")
    C("badmesh.huge-index.ao", f"ao --mesh {G}bad/huge-index.obj --method raycast --rays 8 --per-vertex ao.csv --device cpu")
    C("badmesh.digits.ao", f"ao --mesh {G}bad/digits.obj --method raycast --rays 8 --per-vertex ao.csv --device cpu")
    C("badmesh.unknown-format.ao", f"ao --mesh {G}bad/unknown.xyz --method raycast --rays 4 --per-vertex ao.csv --device cpu")
    for short, g in [("base-colour-1e39", "base-colour-1e39-overflowed-to-infinity"),
                     ("no-accessors-external-buffer", "position-accessor-of-no-accessors-external-buffer"),
                     ("no-accessors-json-validation", "position-accessor-of-no-accessors-panicked-gltf-json-validation")]:
        C(f"badmesh.glb.{short}", f"ao --mesh in/tests/regressions/glb/{g}.glb --method raycast --rays 4 --per-vertex ao.csv --device cpu")
    C("ao.polygon-fan-45000.cpu", "ao --mesh in/tests/regressions/obj/polygon-fan-45000-triangles.obj --method raycast --rays 2 --per-vertex ao.csv --device cpu --json")
    C("ao.degenerate.cpu", f"ao --mesh {G}degenerate.obj --method raycast --rays 8 --per-vertex ao.csv --device cpu")
    C("trace.degenerate.cpu", f"trace --mesh {G}degenerate.obj --width 8 --height 8 --device cpu --json")

    # ---------------- ao --method raycast ---------------------------------
    C("ao.raycast.cwh64.cpu", f"ao --mesh {CWH} --method raycast --rays 64 --per-vertex out.csv --device cpu --json")
    C("ao.raycast.cwh64.text.cpu", f"ao --mesh {CWH} --method raycast --rays 64 --per-vertex out.csv --device cpu")
    C("ao.raycast.cwh64.seed7-threads1.cpu", f"ao --mesh {CWH} --method raycast --rays 64 --per-vertex out.csv --seed 7 --threads 1 --device cpu --json")
    C("ao.raycast.cwh64.seed8-threads2.cpu", f"ao --mesh {CWH} --method raycast --rays 64 --per-vertex out.csv --seed 8 --threads 2 --device cpu")
    C("ao.raycast.cwh64.gpu", f"ao --mesh {CWH} --method raycast --rays 64 --per-vertex out.csv --device gpu --json")
    C("ao.raycast.corner64.seed11.cpu", f"ao --mesh {CORNER} --method raycast --rays 64 --seed 11 --per-vertex out.csv --device cpu --json")
    C("ao.raycast.corner16.seed11.gpu", f"ao --mesh {CORNER} --method raycast --rays 16 --seed 11 --per-vertex out.csv --device gpu --json")
    C("ao.raycast.closed-box.warn.cpu", f"ao --mesh {BOX} --method raycast --rays 16 --per-vertex ao.csv --device cpu")
    C("ao.raycast.closed-box.radius.cpu", f"ao --mesh {BOX} --method raycast --rays 16 --radius 0.2 --per-vertex ao.csv --device cpu --json")
    C("ao.raycast.open-plane.cpu", f"ao --mesh {PLANE} --method raycast --rays 64 --per-vertex ao.csv --device cpu")
    C("ao.raycast.well.radius.cpu", f"ao --mesh {WELL} --method raycast --rays 32 --radius 0.5 --per-vertex ao.csv --device cpu --json")
    C("ao.raycast.receiver.cpu", f"ao --mesh {WALL} --receiver {PLANE} --method raycast --rays 16 --per-vertex out.csv --device cpu --json")
    C("ao.raycast.receiver.gpu", f"ao --mesh {WALL} --receiver {PLANE} --method raycast --rays 16 --per-vertex out.csv --device gpu --json")
    C("ao.raycast.scene.cpu", f"ao --scene {G}scenes/valid.json --method raycast --rays 16 --per-vertex scene.csv --device cpu --json")
    C("ao.raycast.image.corner.cpu", f"ao --mesh {CORNER} --method raycast --rays 16 --image ao.png --width 64 --height 48 --device cpu --json")
    C("ao.raycast.image.corner.gpu", f"ao --mesh {CORNER} --method raycast --rays 8 --image ao.png --width 32 --height 24 --device gpu --json")
    C("ao.raycast.image+csv.camera.cpu", f"ao --mesh {CORNER} --method raycast --rays 16 --per-vertex v.csv --image ao.png --width 40 --height 30 --eye 2,1.5,2 --target 0.5,0.5,0.5 --fov 60 --device cpu --json")
    for name, extra in [("exr", "--image a.exr"), ("png", "--image a.png"), ("png16", "--image a16.png --png-bits 16"),
                        ("pfm", "--image a.pfm"), ("transparent-png", "--image t.png --background transparent"),
                        ("transparent-exr", "--image t.exr --background transparent")]:
        C(f"ao.raycast.image-format.{name}.cpu", f"ao --mesh {SOP} --method raycast --rays 16 --width 40 --height 30 --device cpu --json {extra}")
    C("ao.raycast.ply.cpu", f"ao --mesh {SOP} --method raycast --rays 16 --per-vertex ao.ply --device cpu --json",
      f"ao --mesh ao.ply --method raycast --rays 16 --per-vertex again.csv --device cpu --json")
    C("ao.raycast.ply.gpu", f"ao --mesh {SOP} --method raycast --rays 8 --per-vertex ao.ply --device gpu --json")
    C("ao.raycast.bom.cpu", f"ao --mesh {G}bom.obj --method raycast --rays 8 --per-vertex bom.csv --device cpu")
    C("ao.raycast.gltf-companion.cpu", f"ao --mesh {G}t.gltf --method raycast --rays 4 --per-vertex t.csv --device cpu --json")
    C("ao.raycast.glb-tube.cpu", f"ao --mesh {A}animations/bending-tube.glb --method raycast --rays 8 --per-vertex tube.csv --device cpu --json")
    C("ao.raycast.ascii-ply.cpu", f"ao --mesh {G}mesh.ply --method raycast --rays 8 --per-vertex ply.csv --device cpu --json")
    C("ao.raycast.cow.cpu", f"ao --mesh {COW} --method raycast --rays 16 --per-vertex cow.csv --device cpu --json")
    C("ao.raycast.cow.gpu", f"ao --mesh {COW} --method raycast --rays 8 --per-vertex cow.csv --device gpu --json")
    C("ao.raycast.teapot.radius.cpu", f"ao --mesh {TEAPOT} --method raycast --rays 16 --radius 0.5 --per-vertex teapot.csv --device cpu --json")
    C("ao.raycast.bunny.cpu", f"ao --mesh {BUNNY} --method raycast --rays 4 --per-vertex bunny.csv --device cpu --json")
    C("ao.raycast.repeat.cpu", f"ao --mesh {SOP} --method raycast --rays 8 --per-vertex a.csv --warmup 1 --repeat 3 --device cpu --json")
    C("ao.raycast.default-seed-twice.cpu",
      f"ao --mesh {CWH} --method raycast --rays 64 --per-vertex d1.csv --device cpu",
      f"ao --mesh {CWH} --method raycast --rays 64 --per-vertex d2.csv --device cpu")
    C("ao.raycast.replace-stale.cpu", py("write", "ao.csv", "stale contents that are longer than nothing\n" * 200),
      f"ao --mesh {SOP} --method raycast --rays 4 --per-vertex ao.csv")
    C("ao.raycast.device-auto", f"ao --mesh {CWH} --method raycast --rays 8 --per-vertex out.csv --device auto --json")
    C("ao.raycast.device-auto.adapter-unmatched", f"ao --mesh {CWH} --method raycast --rays 8 --per-vertex out.csv --device auto --json",
      env={"WGPU_ADAPTER_NAME": "definitely-not-an-adapter"})
    C("ao.raycast.device-default", f"ao --mesh {CWH} --method raycast --rays 8 --per-vertex out.csv --json")
    C("ao.raycast.closed-stdout.cpu", step(f"ao --mesh {SOP} --method raycast --rays 64 --per-vertex ao.csv --device cpu --json",
                                           close_stdout=True))
    C("ao.raycast.backend-gl.gpu", f"ao --mesh {SOP} --method raycast --rays 4 --per-vertex gl.csv --device gpu",
      env={"WGPU_BACKEND": "gl"})
    # every GPU command on the GL backend (llvmpipe GL): runs, or exit 2 naming what it lacks (cli_guards.rs)
    gl = {"WGPU_BACKEND": "gl"}
    C("backend-gl.trace.gpu", f"trace --mesh {SOP} --width 16 --height 16 --out t.png --device gpu --json", env=gl)
    C("backend-gl.trace-rays.gpu", f"trace-rays --mesh {SOP} --rays {G}rays/down-y3.f32 --out h.bin --device gpu --json", env=gl)
    C("backend-gl.ao-field.gpu", f"ao --mesh {SOP} --receiver {SOP} --method field --positions 8 --res 8 --rays 4 --per-vertex f.csv --device gpu --json", env=gl)
    C("backend-gl.ssao.gpu", f"ssao --mesh {SOP} --estimator sphere --spp 4 --radius 0.5 --width 16 --height 16 --out s.png --device gpu", env=gl)
    C("backend-gl.sweep-ssao.gpu", f"sweep ssao --mesh {SOP} --width 16 --height 16 --grid spp=4 --out sw --device gpu", env=gl)
    # (prt on GL is left out: its kernel takes 155 s to compile on llvmpipe GL with a cold cache)
    C("backend-gl.raytrace.gpu", f"raytrace --method whitted --mesh {SOP} --width 16 --height 16 --out r.png --device gpu --json", env=gl)
    C("ao.raycast.progress.cpu", f"ao --mesh {CORNER} --method raycast --rays 8 --per-vertex ao.csv --device cpu --progress",
      env={"PENUMBRA_PROGRESS_DELAY_MS": "0"})
    # bad parameters (tests/cli.rs section 3)
    ao_base = f"ao --mesh {CWH} --method raycast --per-vertex out.csv --device cpu"
    for name, rest in [("rays0", "--rays 0"), ("radius0", "--rays 8 --radius 0"), ("radius-neg-eq", "--rays 8 --radius=-1"),
                       ("radius-neg-sep", "--rays 8 --radius -1"), ("radius-nan", "--rays 8 --radius nan"),
                       ("threads0", "--rays 8 --threads 0"), ("width0", "--rays 8 --image out.png --width 0"),
                       ("threads-100000", "--rays 8 --threads 100000"), ("rays-u32max", "--rays 4294967295"),
                       ("rays-word", "--rays many"), ("seed-word", "--rays 8 --seed x")]:
        C(f"ao.bad.{name}", f"{ao_base} {rest}")
    C("ao.bad.method-unknown", f"ao --mesh {CWH} --method magic --rays 8 --per-vertex out.csv --device cpu")
    C("ao.bad.device-quantum", f"ao --mesh {CWH} --method raycast --rays 8 --per-vertex out.csv --device quantum")
    C("ao.bad.device-twice", f"{ao_base} --rays 8 --device gpu")
    C("ao.bad.no-output", f"ao --mesh {CWH} --method raycast --rays 8 --device cpu")
    C("ao.bad.no-method", f"ao --mesh {CWH} --rays 8 --per-vertex out.csv --device cpu")
    C("ao.bad.out-folder-missing.csv", f"ao --mesh {CWH} --method raycast --rays 8 --per-vertex no-such-folder/x.csv --device cpu")
    C("ao.bad.out-folder-missing.png", f"ao --mesh {CWH} --method raycast --rays 8 --image no-such-folder/x.png --device cpu")
    C("ao.bad.field-without-receiver", f"ao --mesh {CWH} --method field --rays 8 --per-vertex out.csv --device cpu")
    C("ao.bad.receiver-without-mesh", f"ao --receiver {CWH} --method raycast --rays 8 --device cpu")
    C("ao.bad.mesh-and-scene", f"ao --mesh {CWH} --scene {G}scenes/valid.json --method raycast --rays 8 --per-vertex o.csv --device cpu")
    C("ao.bad.image-huge", f"ao --mesh {PLANE} --method raycast --rays 8 --image out.png --width 65536 --height 65536 --device cpu")
    C("ao.bad.image-width0-height5", f"ao --mesh {PLANE} --method raycast --rays 8 --image out.png --width 0 --height 5 --device cpu")
    C("ao.bad.gpu-adapter-unmatched", f"ao --mesh {CWH} --method raycast --rays 8 --per-vertex out.csv --device gpu",
      env={"WGPU_ADAPTER_NAME": "definitely-not-an-adapter"})
    C("ao.bad.backend-vulcan", f"ao --mesh {SOP} --method raycast --rays 4 --per-vertex a.csv --device gpu",
      env={"WGPU_BACKEND": "vulcan"})
    # scene files (tests/cli.rs section 4): ao and trace
    for n in ["broken", "binary", "typo", "unknown-mesh", "scale0", "scaleneg", "axis", "noinstances", "ghost", "env"]:
        C(f"scene.bad.{n}.ao", f"ao --scene {G}scenes/{n}.json --method raycast --rays 4 --per-vertex scene.csv --device cpu")
        C(f"scene.bad.{n}.trace", f"trace --scene {G}scenes/{n}.json --width 8 --height 8 --device cpu --json")
    C("scene.bad.data-unset.ao", f"ao --scene {G}scenes/data.json --method raycast --rays 4 --per-vertex scene.csv --device cpu",
      env={"PENUMBRA_DATA": None})
    C("scene.bad.data-unset.trace", f"trace --scene {G}scenes/data.json --width 8 --height 8 --device cpu --json",
      env={"PENUMBRA_DATA": None})
    C("scene.bad.regression-data-mesh-missing", "ao --scene in/tests/regressions/scene/data-mesh-missing-named-by-scene.json --method raycast --rays 4 --per-vertex s.csv --device cpu")
    C("scene.valid.trace.cpu", f"trace --scene {G}scenes/valid.json --width 16 --height 16 --device cpu --json")
    C("scene.cow-corner.ao.cpu", f"ao --scene {A}scenes/cow-corner.json --method raycast --rays 8 --per-vertex s.csv --device cpu --json")

    # ---------------- ao --method field / field build / field info ---------
    C("field-build.bits8-concentric", f"field build --mesh {CWH} -o cube-8.dfield --positions 100 --res 8 --bits 8 --directions concentric --json",
      "field info cube-8.dfield --json", "field info cube-8.dfield")
    C("field-build.bits32-polar", f"field build --mesh {CWH} -o cube-32.dfield --positions 100 --res 8 --bits 32 --directions polar --json",
      "field info cube-32.dfield --json")
    C("field-build.bits1-rejection", f"field build --mesh {CWH} -o cube-1.dfield --positions 100 --res 8 --bits 1 --directions rejection --json",
      "field info cube-1.dfield")
    C("field-build.grid4226-res2", f"field build --mesh {CWH} -o grid.dfield --positions 4226 --res 2 --json")
    C("field-build.text", f"field build --mesh {SOP} -o s.dfield --positions 18 --res 8")
    C("field-build.repeat", f"field build --mesh {SOP} --positions 18 --res 8 -o f.dfield --warmup 1 --repeat 2 --json")
    C("field-build.cow", f"field build --mesh {COW} --positions 66 --res 8 -o cow.dfield --json")
    C("field-build.threads1", f"field build --mesh {CWH} --positions 64 --res 8 --threads 1 -o t.dfield --json")
    fb = f"field build --mesh {CWH} -o x.dfield"
    for name, rest in [("positions0", "--positions 0"), ("positions-neg", "--positions -3"), ("positions-100000", "--positions 100000"),
                       ("res1", "--res 1"), ("res4096", "--res 4096"), ("bits4", "--bits 4"), ("directions-spiral", "--directions spiral"),
                       ("threads0", "--threads 0"), ("repeat0", "--repeat 0")]:
        C(f"field-build.bad.{name}", f"{fb} {rest}")
    C("field-build.bad.out-folder-missing", f"field build --mesh {CWH} -o missing/x.dfield")
    C("field-build.bad.no-out", f"field build --mesh {CWH}")
    C("field-build.bad.empty-mesh", f"field build --mesh {G}bad/nothing.obj -o o.dfield --res 4 --positions 4")
    C("field-build.bad.nan-mesh", f"field build --mesh {G}bad/nan-z.obj -o o.dfield --res 4 --positions 4")
    C("field-info.bad.corrupt",
      f"field build --mesh {CWH} -o good.dfield --positions 16 --res 4",
      py("truncate", "good.dfield", "truncated.dfield", 10),
      py("flipbit", "good.dfield", "flipped.dfield", 120),
      f"field info {G}dfield/garbage.dfield",
      "field info truncated.dfield",
      "field info flipped.dfield --json",
      f"ao --mesh {CWH} --receiver {CORNER} --method field --field {G}dfield/garbage.dfield --rays 8 --per-vertex o.csv --device cpu",
      f"ao --mesh {CWH} --receiver {CORNER} --method field --field truncated.dfield --rays 8 --per-vertex o.csv --device cpu",
      f"ao --mesh {CWH} --receiver {CORNER} --method field --field flipped.dfield --rays 8 --per-vertex o.csv --device cpu")
    C("field-info.bad.missing", "field info none.dfield")
    C("field-info.bad.no-file", "field info")
    CIC = f"{G}cube-in-corner.obj"
    aof = f"ao --mesh {CIC} --receiver {CORNER} --method field --rays 32 --per-vertex ao.csv"
    C("ao.field.reference.cpu", f"{aof} --positions 289 --res 16 --reference --device cpu --json")
    C("ao.field.gpu", f"{aof} --positions 289 --res 16 --device gpu --json")
    C("ao.field.prebuilt.cpu", f"field build --mesh {CIC} -o cube.dfield --positions 289 --res 16",
      f"{aof} --field cube.dfield --device cpu --json")
    C("ao.field.nearest-bits32.cpu", f"{aof} --positions 100 --res 8 --bits 32 --positional nearest --device cpu --json")
    C("ao.field.bits1-polar.cpu", f"{aof} --positions 100 --res 8 --bits 1 --directions polar --device cpu --json")
    C("ao.field.image.cpu", f"{aof} --positions 100 --res 8 --image f.png --width 48 --height 32 --device cpu --json")
    C("ao.field.frames.cpu", f"ao --scene {G}scenes/frames.json --method field --rays 16 --positions 100 --res 8 --frames 3 --per-vertex ao.csv --device cpu --json")
    C("ao.field.frames-pattern.cpu", step(["ao", "--scene", f"{G}scenes/frames.json", "--method", "field", "--rays", "16", "--positions", "100",
                                           "--res", "8", "--frames", "3", "--per-vertex", "v_{}.csv", "--image", "f_{:04}.png",
                                           "--width", "48", "--height", "32", "--device", "cpu"]))
    C("ao.field.frames.gpu", f"ao --scene {G}scenes/frames.json --method field --rays 8 --positions 100 --res 8 --frames 2 --per-vertex ao.csv --device gpu --json")
    C("ao.field.both.cpu", f"ao --scene {G}scenes/both.json --method field --rays 32 --positions 289 --res 16 --reference --per-vertex ao.csv --device cpu --json")
    C("ao.field.reach-radius.cpu", f"ao --method field --scene {G}scenes/reach.json --rays 16 --positions 258 --res 8 --per-vertex ao.csv --json --radius 0.5 --device cpu",
      f"ao --method field --scene {G}scenes/near-only.json --rays 16 --positions 258 --res 8 --per-vertex near.csv --json --radius 0.5 --device cpu")
    C("ao.field.reach-infinite.cpu", f"ao --method field --scene {G}scenes/reach.json --rays 16 --positions 258 --res 8 --per-vertex ao.csv --json --device cpu")
    C("ao.field.cow-corner.cpu", f"ao --scene {A}scenes/cow-corner.json --method field --rays 16 --positions 258 --res 8 --per-vertex ao.csv --device cpu --json")
    C("ao.field.max-error.cpu",
      f"ao --mesh {WALL} --receiver {G}ground.obj --method field --rays 32 --reference --per-vertex ao.csv --device cpu --json --max-error 0.085",
      f"ao --mesh {WALL} --receiver {G}ground.obj --method field --rays 32 --reference --per-vertex ao2.csv --device cpu --json --max-error 0.085",
      note="second run reads the max-error cache (cached: true)")
    C("ao.field.max-error.bad-res", f"ao --mesh {WALL} --receiver {G}ground.obj --method field --rays 32 --per-vertex ao.csv --device cpu --max-error 0.05 --res 16")
    for bad in ["0", "-1", "nan"]:
        C(f"ao.field.max-error.bad.{bad}", f"ao --mesh {WALL} --receiver {G}ground.obj --method field --rays 32 --per-vertex ao.csv --device cpu --max-error {bad}")
    for name, rest in [("frames0", "--frames 0"), ("res1", "--res 1"), ("positional", "--positional everywhere")]:
        C(f"ao.field.bad.{name}", f"{aof} {rest} --device cpu")
    C("ao.field.bad.other-mesh-field", f"field build --mesh {BOX} -o box.dfield --positions 16 --res 4",
      f"{aof} --field box.dfield --device cpu")

    # ---------------- trace ------------------------------------------------
    C("trace.corner64.json.cpu", f"trace --mesh {CORNER} --width 64 --height 64 --device cpu --json")
    C("trace.corner64.json.gpu", f"trace --mesh {CORNER} --width 16 --height 16 --device gpu --json")
    C("trace.cwh8.text.cpu", f"trace --mesh {CWH} --device cpu --width 8 --height 8")
    C("trace.camera-image.cpu", f"trace --mesh {CORNER} --width 32 --height 24 --eye 2,1.5,2 --target 0.5,0.5,0.5 --fov 60 --out trace.png --device cpu --json")
    for mesh in ["sphere-on-plane", "closed-box", "cube-with-hole"]:
        m = A + mesh + ".obj"
        size = "--width 72 --height 40 --shadows"
        C(f"trace.modes.{mesh}.mlrta-on.cpu", f"trace --mesh {m} --out on.png --device cpu --json {size} --tile 32 --min-tile 4 --mlrta on")
        C(f"trace.modes.{mesh}.mlrta-off.cpu", f"trace --mesh {m} --out off.png --device cpu --json {size} --tile 32 --min-tile 4 --mlrta off")
        C(f"trace.modes.{mesh}.single-ray.cpu", f"trace --mesh {m} --out single.png --device cpu --json {size} --single-ray")
        C(f"trace.modes.{mesh}.bvh.cpu", f"trace --mesh {m} --out bvh.png --device cpu --json {size} --accel bvh")
    C("trace.single-ray-kdtree.cpu", f"trace --mesh {SOP} --width 32 --height 24 --single-ray --accel kdtree --out k.png --device cpu --json")
    C("trace.split-factor4.cpu", f"trace --mesh {SOP} --width 64 --height 48 --tile 32 --split-factor 4 --device cpu --json")
    C("trace.ep-budget.cpu", f"trace --mesh {SOP} --width 32 --height 24 --ep-budget 2 --device cpu --json")
    C("trace.plain.cpu", f"trace --mesh {SOP} --out plain.png --device cpu --json --width 48 --height 48")
    C("trace.light-below.cpu", f"trace --mesh {SOP} --out below.png --device cpu --json --width 48 --height 48 --light 0,-1000,0")
    C("trace.shadows-on.cpu", f"trace --mesh {SOP} --width 32 --height 24 --device cpu --json --shadows on")
    C("trace.shadows-off.cpu", f"trace --mesh {SOP} --width 32 --height 24 --device cpu --json --shadows off")
    for mode in ["uniform", "adaptive"]:
        C(f"trace.aa-{mode}.cpu", f"trace --mesh {SOP} --width 64 --height 64 --tile 32 --min-tile 4 --aa {mode} --aa-samples 4 --aa-reference --aa-image aa.png --tiles-image tiles.png --device cpu --json")
    C("trace.aa-reference-new.cpu", f"trace --mesh {SOP} --width 32 --height 24 --aa adaptive --device cpu --json --reference")
    C("trace.aa-adaptive-noref.cpu", f"trace --mesh {SOP} --width 32 --height 24 --aa adaptive --device cpu --json")
    C("trace.aa-image-exr.cpu", f"trace --mesh {SOP} --width 32 --height 24 --aa uniform --aa-image aa.exr --device cpu --json")
    C("trace.out-pfm+png.cpu", f"trace --mesh {SOP} --width 40 --height 30 --device cpu --out t.png",
      f"trace --mesh {SOP} --width 40 --height 30 --device cpu --out t.pfm")
    C("trace.repeat.cpu", f"trace --mesh {SOP} --width 32 --height 24 --warmup 1 --repeat 3 --device cpu --json")
    C("trace.cow.cpu", f"trace --mesh {COW} --width 64 --height 48 --shadows --out cow.png --device cpu --json")
    C("trace.teapot.bvh.cpu", f"trace --mesh {TEAPOT} --width 64 --height 48 --accel bvh --out teapot.png --device cpu --json")
    C("trace.bunny.cpu", f"trace --mesh {BUNNY} --width 32 --height 24 --out bunny.png --device cpu --json")
    for mlrta in ["on", "off"]:
        C(f"trace.packets-{mlrta}.gpu", f"trace --mesh {SOP} --width 24 --height 16 --tile 32 --shadows --mlrta {mlrta} --out g.png --device gpu --json")
    C("trace.packets.cpu-twin", f"trace --mesh {SOP} --width 24 --height 16 --tile 32 --shadows --mlrta on --out c.png --device cpu --json")
    C("trace.cow.gpu", f"trace --mesh {COW} --width 16 --height 16 --out cow.png --device gpu --json")
    C("trace.gpu-adapter-unmatched", f"trace --mesh {CWH} --width 8 --height 8 --device gpu --json",
      env={"WGPU_ADAPTER_NAME": "definitely-not-an-adapter"})
    tb = f"trace --mesh {CWH} --device cpu"
    for name, rest in [("width0", "--width 0 --height 16"), ("height0", "--width 16 --height 0"), ("huge", "--width 100000 --height 100000"),
                       ("fov0", "--width 16 --height 16 --fov 0"), ("fov180", "--width 16 --height 16 --fov 180"),
                       ("fov-nan", "--width 16 --height 16 --fov nan"), ("eye-eq-target", "--width 16 --height 16 --eye 1,2,3 --target 1,2,3"),
                       ("threads0", "--width 16 --height 16 --threads 0"), ("eye-two", "--width 16 --height 16 --eye 1,2"),
                       ("eye-nan", "--width 16 --height 16 --eye 1,nan,2"), ("target-abc", "--width 16 --height 16 --target a,b,c"),
                       ("eye-inf", "--width 8 --height 8 --eye inf,0,0"), ("width-neg", "--width -8 --height 8"),
                       ("split-factor8", "--width 16 --height 16 --split-factor 8"), ("split-factor1", "--width 16 --height 16 --split-factor 1"),
                       ("min-tile2", "--width 16 --height 16 --min-tile 2"), ("tile-lt-min", "--width 16 --height 16 --tile 8 --min-tile 16"),
                       ("tile-neg", "--width 16 --height 16 --tile -1"), ("aa-samples5", "--width 16 --height 16 --aa adaptive --aa-samples 5"),
                       ("aa-samples0", "--width 16 --height 16 --aa adaptive --aa-samples 0"), ("aa-sometimes", "--width 16 --height 16 --aa sometimes"),
                       ("mlrta-maybe", "--width 16 --height 16 --mlrta maybe"), ("light-two", "--width 16 --height 16 --light 1,2"),
                       ("single-ray-mlrta", "--width 16 --height 16 --single-ray --mlrta on"),
                       ("single-ray-tile", "--width 8 --height 8 --single-ray --tile 16"),
                       ("bvh-aa", "--width 8 --height 8 --accel bvh --aa adaptive"), ("aa-samples-noaa", "--width 8 --height 8 --aa-samples 16"),
                       ("repeat0", "--width 8 --height 8 --repeat 0"), ("repeat1001", "--width 8 --height 8 --repeat 1001"),
                       ("warmup1001", "--width 8 --height 8 --warmup 1001"), ("shadows-maybe", "--width 8 --height 8 --shadows maybe"),
                       ("unknown-option", "--width 8 --height 8 --frobnicate")]:
        C(f"trace.bad.{name}", f"{tb} {rest}")
    C("trace.bad.no-mesh", "trace --width 8 --height 8 --device cpu")
    C("trace.bad.mesh-and-scene", f"trace --mesh {CWH} --scene {CWH} --width 8 --height 8 --device cpu")
    C("trace.bad.device-quantum", f"trace --mesh {PLANE} --width 8 --height 8 --device quantum")
    C("top.unknown-subcommand", "frobnicate")
    C("top.unknown-option", "--frobnicate")

    # ---------------- ssao -------------------------------------------------
    SB = f"ssao --mesh {SOP} --estimator importance --spp 8 --radius 0.5 --width 64 --height 48 --truth-rays 16 --reference-spp 64"
    C("ssao.contract.cpu", f"{SB} --out ao.png --device cpu --json")
    C("ssao.contract.text.cpu", f"{SB} --out ao.png --device cpu")
    C("ssao.contract.auto", f"{SB} --out ao.png --device auto --json")
    C("ssao.contract.gpu", f"ssao --mesh {SOP} --estimator importance --spp 8 --radius 0.5 --width 32 --height 24 --truth-rays 8 --reference-spp 32 --out ao.png --device gpu --json")
    for e in ["raymarch", "sphere", "hemisphere", "importance", "tangent-sphere", "base-disk"]:
        C(f"ssao.estimator.{e}.cpu", f"ssao --mesh {SOP} --estimator {e} --spp 8 --radius 0.5 --width 40 --height 30 --truth-rays 8 --reference-spp 32 --interleave off --filter off --out ao.png --image img.png --device cpu --json")
    for e in ["raymarch", "base-disk"]:
        C(f"ssao.estimator.{e}.gpu", f"ssao --mesh {SOP} --estimator {e} --spp 8 --radius 0.5 --width 24 --height 16 --truth-rays 0 --reference-spp 0 --interleave off --filter off --out ao.png --image img.png --device gpu --json")
    for i, knobs in enumerate(["--estimator importance --measure step", "--estimator hemisphere --measure exp --sigma 4",
                               "--estimator raymarch --steps 2 --measure exp",
                               "--estimator sphere --calibrate off --bias 0 --filter-depth 0.1",
                               "--estimator base-disk --resolution half"]):
        name = ["measure-step", "measure-exp-sigma", "raymarch-steps2", "calibrate-off", "half-res"][i]
        C(f"ssao.knobs.{name}.cpu", f"ssao --mesh {SOP} {knobs} --spp 8 --radius 0.5 --width 40 --height 30 --truth-rays 0 --reference-spp 0 --out ao.png --device cpu --json")
    C("ssao.knobs.half-res.gpu", f"ssao --mesh {SOP} --estimator base-disk --resolution half --spp 8 --radius 0.5 --width 24 --height 16 --truth-rays 0 --reference-spp 0 --out ao.png --device gpu --json")
    C("ssao.filter-on.gpu", f"ssao --mesh {SOP} --spp 8 --radius 0.5 --width 24 --height 16 --truth-rays 0 --reference-spp 0 --out ao.png --filter on --estimator importance --device gpu --json")
    C("ssao.lean.cpu", f"ssao --mesh {SOP} --spp 8 --radius 0.5 --width 64 --height 48 --truth-rays 0 --reference-spp 0 --out ao.png --estimator importance --device cpu --json")
    for seed in [1, 2]:
        C(f"ssao.seed{seed}.cpu", f"{SB} --out s.png --device cpu --seed {seed} --filter off")
    C("ssao.formats.cpu", f"ssao --mesh {SOP} --estimator sphere --spp 8 --radius 0.5 --width 40 --height 30 --truth-rays 0 --reference-spp 0 --device cpu --out ao.png --image img.png",
      f"ssao --mesh {SOP} --estimator sphere --spp 8 --radius 0.5 --width 40 --height 30 --truth-rays 0 --reference-spp 0 --device cpu --out ao.exr --image img.exr",
      f"ssao --mesh {SOP} --estimator sphere --spp 8 --radius 0.5 --width 40 --height 30 --truth-rays 0 --reference-spp 0 --device cpu --out ao16.png --image img2.pfm --png-bits 16")
    C("ssao.transparent.cpu", f"ssao --mesh {SOP} --estimator sphere --spp 4 --radius 0.5 --width 40 --height 30 --truth-rays 0 --reference-spp 0 --device cpu --out t.png --background transparent --json")
    C("ssao.indirect.cpu", f"ssao --mesh {SOP} --estimator importance --spp 8 --radius 0.5 --width 48 --height 36 --out ao.png --image lit.png --indirect --ambient 0.5 --reference-rays 8 --screen-reference-spp 32 --device cpu --json")
    C("ssao.mtl-albedo.cpu", f"ssao --mesh {G}mtl/with.obj --estimator sphere --spp 4 --radius 0.5 --width 40 --height 30 --truth-rays 0 --reference-spp 0 --device cpu --image with.exr",
      f"ssao --mesh {G}mtl/without.obj --estimator sphere --spp 4 --radius 0.5 --width 40 --height 30 --truth-rays 0 --reference-spp 0 --device cpu --image without.exr")
    C("ssao.repeat.cpu", f"ssao --mesh {SOP} --estimator importance --spp 4 --radius 0.2 --width 32 --height 24 --truth-rays 0 --reference-spp 0 --out s.png --warmup 1 --repeat 3 --device cpu --json")
    C("ssao.progress.cpu", f"ssao --mesh {SOP} --estimator importance --spp 4 --radius 0.2 --width 100 --height 75 --truth-rays 16 --reference-spp 16 --device cpu --out ao.png --progress",
      env={"PENUMBRA_PROGRESS_DELAY_MS": "0"})
    C("ssao.cow.cpu", f"ssao --mesh {COW} --estimator importance --spp 8 --radius 0.1 --width 64 --height 48 --truth-rays 16 --reference-spp 32 --out cow.png --device cpu --json")
    C("ssao.cow.gpu", f"ssao --mesh {COW} --estimator importance --spp 8 --radius 0.1 --width 32 --height 24 --truth-rays 0 --reference-spp 0 --out cow.png --device gpu --json")
    C("ssao.scene-camera.cpu", f"ssao --scene {A}scenes/cow-corner.json --estimator hemisphere --spp 8 --radius 0.1 --width 48 --height 36 --truth-rays 8 --reference-spp 16 --out s.png --device cpu --json")
    C("ssao.eye-target.cpu", f"ssao --mesh {SOP} --estimator sphere --spp 4 --radius 0.5 --width 32 --height 24 --eye 3,2,3 --target 0,0,0 --fov 50 --truth-rays 0 --reference-spp 0 --out e.png --device cpu --json")
    ME = f"ssao --mesh {CORNER} --radius 0.3 --width 64 --height 48 --out ao.png --device cpu --json"
    C("ssao.max-error.impossible.cpu", f"{ME} --max-error 0.000001",
      f"{ME} --max-error 0.000001", note="most accurate candidate (deterministic); second run from the cache")
    C("ssao.max-error.impossible-sphere.cpu", f"{ME} --max-error 0.000001 --estimator sphere")
    for bad in ["0", "-1", "nan"]:
        C(f"ssao.max-error.bad.{bad}", f"{ME} --max-error {bad}")
    sb = f"ssao --mesh {SOP} --width 32 --height 24 --device cpu"
    for name, rest in [("spp0", "--estimator importance --spp 0 --radius 1 --out ao.png"), ("spp-neg", "--estimator importance --spp -4 --radius 1 --out ao.png"),
                       ("spp-99999", "--estimator importance --spp 99999 --radius 1 --out ao.png"),
                       ("radius0", "--estimator importance --spp 8 --radius 0 --out ao.png"), ("radius-neg", "--estimator importance --spp 8 --radius -1 --out ao.png"),
                       ("radius-nan", "--estimator importance --spp 8 --radius NaN --out ao.png"), ("radius-inf", "--estimator importance --spp 8 --radius inf --out ao.png"),
                       ("estimator-magic", "--estimator magic --spp 8 --radius 1 --out ao.png"),
                       ("sphere-step", "--estimator sphere --measure step --spp 8 --radius 1 --out ao.png"),
                       ("base-disk-exp", "--estimator base-disk --measure exp --spp 8 --radius 1 --out ao.png"),
                       ("raymarch-steps3", "--estimator raymarch --steps 3 --spp 8 --radius 1 --out ao.png"),
                       ("raymarch-steps0", "--estimator raymarch --steps 0 --spp 8 --radius 1 --out ao.png"),
                       ("sigma-neg", "--estimator importance --measure exp --sigma -2 --spp 8 --radius 1 --out ao.png"),
                       ("sigma-no-exp", "--estimator importance --sigma 2 --spp 8 --radius 1 --out ao.png"),
                       ("filter-depth0", "--estimator importance --filter-depth 0 --spp 8 --radius 1 --out ao.png"),
                       ("bias-nan", "--estimator importance --bias NaN --spp 8 --radius 1 --out ao.png"),
                       ("ambient-neg", "--estimator importance --ambient -1 --spp 8 --radius 1 --out ao.png"),
                       ("interleave-maybe", "--estimator importance --interleave maybe --spp 8 --radius 1 --out ao.png"),
                       ("no-out", "--estimator importance --spp 8 --radius 1"),
                       ("out-dir-missing", "--estimator importance --spp 8 --radius 1 --out /no/such/dir/ao.png"),
                       ("fov0", "--estimator importance --spp 8 --radius 1 --out ao.png --fov 0"),
                       ("repeat0", "--estimator importance --spp 8 --radius 1 --out ao.png --repeat 0"),
                       ("ambient-neg-image", "--estimator importance --ambient -1 --spp 8 --radius 1 --image img.png"),
                       ("steps-not-raymarch", "--estimator sphere --spp 4 --radius 0.5 --steps 4 --out ao.png"),
                       ("ambient-no-image", "--estimator sphere --spp 4 --radius 0.5 --ambient 0.5 --out ao.png"),
                       ("resolution-quarter", "--estimator sphere --spp 4 --radius 0.5 --resolution quarter --out ao.png")]:
        C(f"ssao.bad.{name}", f"{sb} {rest}")
    C("ssao.bad.width0", f"ssao --mesh {SOP} --estimator importance --spp 8 --radius 1 --width 0 --height 10 --out ao.png --device cpu")
    C("ssao.bad.mesh-missing", "ssao --mesh /no/such.obj --estimator importance --spp 8 --radius 1 --out ao.png")
    C("ssao.bad.mesh-nan", f"ssao --mesh {G}bad/nan-z.obj --estimator importance --spp 8 --radius 1 --out ao.png")
    C("ssao.exp-sigma-applies.cpu", f"ssao --mesh {SOP} --estimator sphere --spp 4 --radius 0.5 --width 8 --height 8 --measure exp --sigma 3 --out x.png")

    # ---------------- prt ----------------------------------------------------
    CLOTH = f"prt --animated cloth --env {PROBE} --frames 3 --width 64 --height 48"
    C("prt.cloth.check-profile.cpu", f"{CLOTH} --device cpu --check --check-rays 256 --check-frames 2 --profile --out cloth.png --json")
    C("prt.cloth.text.cpu", f"{CLOTH} --device cpu --out cloth.png")
    C("prt.cloth.gpu", f"prt --animated cloth --env {PROBE} --frames 2 --width 32 --height 24 --device gpu --exposure 0.5 --out g.png --json")
    C("prt.cloth-phong-cells.gpu", f"prt --animated cloth --brdf phong --integration cells --env {PROBE} --frames 2 --width 32 --height 24 --device gpu --exposure 0.5 --out g.png --json")
    C("prt.cloth-phong-cells.cpu", f"prt --animated cloth --brdf phong --integration cells --env {PROBE} --frames 2 --width 32 --height 24 --device cpu --exposure 0.5 --out c.png --json")
    C("prt.character.cpu", f"prt --animated character --mask 16 --order 3 --env {PROBE} --frames 2 --width 32 --height 24 --device cpu --exposure 0.5 --out c.png --json")
    C("prt.character.gpu", f"prt --animated character --mask 16 --order 3 --env {PROBE} --frames 2 --width 32 --height 24 --device gpu --exposure 0.5 --out g.png --json")
    for name, knobs in [("mask16-lut64", "--mask 16 --lut 64"), ("mask64-lut32-order3", "--mask 64 --lut 32 --order 3"),
                        ("hierarchy-off", "--hierarchy off --group-culling off"), ("near-rings", "--near rings --ring 2"),
                        ("pvs", "--pvs on --pvs-frames 2"), ("phong", "--brdf phong --shininess 8 --specular 0.3"),
                        ("integration-pixels", "--integration pixels"), ("shadows-off", "--shadows off"),
                        ("shadows-raytraced", "--shadows raytraced --check-rays 64"), ("backface-two-sided", "--backface on --two-sided off"),
                        ("cells-linear-coarse", "--integration cells-linear --coarse 64 --coarse-tolerance 0 --group-size 16"),
                        ("env-spin-albedo", "--env-spin 30 --albedo 0.8,0.6,0.4 --per-vertex v.csv --out a.png --width 24 --height 18")]:
        C(f"prt.knobs.{name}.cpu", f"prt --mesh {SOP} --env {PROBE} --frames 2 --device cpu {knobs} --json")
    C("prt.cloth.env-spin-start-dt.cpu", f"prt --animated cloth --env {PROBE} --frames 2 --env-spin 30 --start 0.5 --dt 0.1 --self-check off --width 24 --height 18 --out s.png --device cpu --json")
    C("prt.self-check.default.cpu", f"prt --animated cloth --env {PROBE} --device cpu --json")
    C("prt.self-check.threshold.cpu", f"prt --animated cloth --env {PROBE} --device cpu --json --self-check-threshold 0.001")
    C("prt.self-check.off.cpu", f"prt --animated cloth --env {PROBE} --device cpu --json --self-check off")
    C("prt.reference-new.cpu", f"prt --animated cloth --env {PROBE} --frames 2 --self-check off --device cpu --json --reference --reference-rays 64 --reference-frames 1")
    C("prt.reference-old.cpu", f"prt --animated cloth --env {PROBE} --frames 2 --self-check off --device cpu --json --check --check-rays 64 --check-frames 1")
    C("prt.numbers-out.cpu", step(["prt", "--animated", "cloth", "--env", f"{G}probe2.hdr", "--frames", "3", "--width", "48", "--height", "36",
                                   "--albedo", "0.8,0.6,0.4", "--sh-out", "sh.json", "--per-vertex", "v.csv", "--per-vertex-transfer",
                                   "--device", "cpu", "--json", "--out", "f{:02}.exr"]),
      f"prt --animated cloth --env {G}probe2.hdr --frames 3 --width 48 --height 36 --albedo 0.8,0.6,0.4 --exposure 0.5 --out last.png --device cpu",
      f"prt --animated cloth --env {G}probe2.hdr --frames 3 --width 48 --height 36 --albedo 0.8,0.6,0.4 --out last.pfm --device cpu")
    for probe in ["grace", "pisa", "uffizi"]:
        C(f"prt.sh-out.{probe}.cpu", f"prt --mesh {G}tri.obj --env in/data/probes/{probe}.hdr --sh-out sh.json --self-check off --device cpu")
    C("prt.repeat.cpu", f"prt --animated cloth --env {PROBE} --frames 3 --self-check off --per-vertex prt.csv --warmup 1 --repeat 3 --device cpu --json")
    C("prt.out-frames.cpu", f"prt --animated cloth --env {PROBE} --frames 2 --self-check off --width 24 --height 18 --out-frames frames --device cpu --json",
      setup=[("mkdir", "frames")])
    C("prt.mesh-sequence.flag.cpu", f"prt --mesh-sequence 'in/assets/animations/flag/*.obj' --env {PISA} --width 32 --height 24 --out flag.exr --reference --reference-frames 2 --reference-rays 64 --device cpu --json",
      inputs=["assets/animations/flag/flag-000.obj"])
    C("prt.glb.tube-twist.cpu", f"prt --mesh {A}animations/bending-tube.glb --animation twist --frames 4 --env {UFFIZI} --per-vertex tube.csv --per-vertex-transfer --device cpu --json")
    C("prt.glb.morph-blob.cpu", f"prt --mesh {A}animations/morph-blob.glb --frames 3 --env {PROBE} --self-check off --width 24 --height 18 --out m.png --device cpu --json")
    C("prt.glb.animation-none.cpu", f"prt --mesh {A}animations/bending-tube.glb --animation none --env {PROBE} --self-check off --device cpu --json")
    C("prt.scene.chess.cpu", f"prt --scene {A}scenes/chess.json --env {GRACE} --frames 2 --width 48 --height 36 --out chess.png --self-check off --device cpu --json")
    C("prt.scene.chess-inter-off.cpu", f"prt --scene {A}scenes/chess.json --env {PISA} --frames 2 --inter-object off --per-vertex chess.csv --self-check off --device cpu --json")
    C("prt.cow.cpu", f"prt --mesh {COW} --env {GRACE} --frames 2 --width 48 --height 36 --out cow.png --device cpu --json")
    C("prt.cow.gpu", f"prt --mesh {COW} --env {GRACE} --frames 2 --width 32 --height 24 --self-check off --out cow.png --device gpu --json")
    C("prt.regression-hdr.cpu", f"prt --mesh {G}tri.obj --env in/tests/regressions/hdr/old-rle-eight-run-markers-in-a-row.hdr --sh-out sh.json --self-check off --device cpu")
    C("prt.max-error.impossible.cpu", f"prt --mesh {SOP} --env {PROBE} --check --check-rays 256 --device cpu --json --max-error 0.000001")
    C("prt.max-error.bad-mask", f"prt --mesh {SOP} --env {PROBE} --check --check-rays 256 --device cpu --json --max-error 0.05 --mask 16")
    C("prt.interrupt.cpu", step(f"prt --animated cloth --env {G}probe3.hdr --frames 100000 --self-check off --per-vertex radiance.csv --device cpu",
                                interrupt_after_tmp=0.3),
      note="SIGINT once the streamed CSV's temporary exists: exit 130, nothing left")
    pb = f"prt --device cpu"
    for name, rest in [("env-text", f"--animated cloth --env {G}hdr/text.hdr"), ("env-missing", "--animated cloth --env missing.hdr"),
                       ("animated-flag", f"--animated flag --env {PROBE}"), ("no-mesh", f"--env {PROBE}"),
                       ("mesh-and-animated", f"--mesh {SOP} --animated cloth --env {PROBE}"), ("mesh-nan", f"--mesh {G}bad/nan.obj --env {PROBE}"),
                       ("mesh-empty", f"--mesh {G}bad/nothing.obj --env {PROBE}"), ("frames0", f"--animated cloth --env {PROBE} --frames 0"),
                       ("order0", f"--animated cloth --env {PROBE} --order 0"), ("order-neg", f"--animated cloth --env {PROBE} --order -3"),
                       ("mask20", f"--animated cloth --env {PROBE} --mask 20"), ("lut0", f"--animated cloth --env {PROBE} --lut 0"),
                       ("lut100000", f"--animated cloth --env {PROBE} --lut 100000"),
                       ("specular2", f"--animated cloth --env {PROBE} --brdf phong --specular 2"),
                       ("shininess-neg", f"--animated cloth --env {PROBE} --brdf phong --shininess -1"),
                       ("exposure0", f"--animated cloth --env {PROBE} --exposure 0"), ("dt-nan", f"--animated cloth --env {PROBE} --dt nan"),
                       ("check-rays0", f"--animated cloth --env {PROBE} --check-rays 0"),
                       ("check-rays0-with-check", f"--animated cloth --env {PROBE} --check --check-rays 0"),
                       ("exposure0-with-out", f"--animated cloth --env {PROBE} --exposure 0 --out x.png"),
                       ("start-static", f"--mesh {SOP} --env {PROBE} --frames 2 --env-spin 30 --start 0.5 --dt 0.1"),
                       ("coarse-tolerance-neg", f"--animated cloth --env {PROBE} --coarse-tolerance -1"),
                       ("self-check-threshold0", f"--animated cloth --env {PROBE} --self-check-threshold 0"),
                       ("shadows-off-self-check-on", f"--animated cloth --env {PROBE} --shadows off --self-check on"),
                       ("out-folder-missing", f"--animated cloth --env {PROBE} --out no/such/folder/x.png"),
                       ("shininess-no-phong", f"--mesh {SOP} --env {SOP} --shininess 8"),
                       ("check-rays-no-reference", f"--mesh {SOP} --env {SOP} --check-rays 64"),
                       ("width-no-out", f"--mesh {SOP} --env {SOP} --width 64"),
                       ("per-vertex-transfer-alone", f"--mesh {SOP} --env {SOP} --per-vertex-transfer"),
                       ("hdr-empty", f"--mesh {SOP} --env {G}hdr/empty.hdr"), ("hdr-vast", f"--mesh {SOP} --env {G}hdr/vast.hdr"),
                       ("hdr-promise", f"--mesh {SOP} --env {G}hdr/promise.hdr"),
                       ("scene-pvs", f"--scene {A}scenes/chess.json --env {PROBE} --pvs on"),
                       ("sequence-none", f"--mesh-sequence 'nothing/*.obj' --env {PROBE}"),
                       ("glb-bad-animation", f"--mesh {A}animations/bending-tube.glb --animation nosuchclip --env {PROBE}")]:
        C(f"prt.bad.{name}", f"{pb} {rest}")
    C("prt.bad.order9.gpu", f"prt --animated cloth --env {PROBE} --order 9 --device gpu")

    # ---------------- raytrace -----------------------------------------------
    RB = "raytrace --method whitted --width 48 --height 36"
    for ext in ["png", "exr", "pfm"]:
        C(f"raytrace.whitted.checker.{ext}.cpu", f"{RB} --scene {CHECKER} --out img.{ext} --device cpu --json")
    C("raytrace.whitted.checker.text.cpu", f"{RB} --scene {CHECKER} --out img.png --device cpu")
    for ext in ["png", "pfm"]:
        C(f"raytrace.whitted.checker.{ext}.gpu", f"raytrace --method whitted --width 24 --height 18 --scene {CHECKER} --out img.{ext} --device gpu --json")
    for name, extra in [("base", ""), ("max-depth0", "--max-depth 0"), ("spp4", "--spp 4"), ("packets-off", "--packets off"),
                        ("packets-on", "--packets on"), ("fresnel", "--fresnel on"), ("ray-tree", "--ray-tree 24,20"),
                        ("ambient-background", "--ambient 0.1,0.1,0.2 --background 0.3,0.3,0.3 --exposure 2 --out e.png")]:
        C(f"raytrace.whitted.knobs.{name}.cpu", f"{RB} --scene {CHECKER} --device cpu --json {extra}")
    for samples in [1, 8]:
        C(f"raytrace.whitted.cornell-light-samples{samples}.cpu", f"{RB} --mesh {A}raytrace/cornell-mirror-glass.obj --light-samples {samples} --device cpu --json")
    for sc in ["tir-block", "grazing", "inside-glass", "cornell-mirror-glass"]:
        C(f"raytrace.whitted.{sc}.cpu", f"raytrace --method whitted --width 40 --height 30 --scene {A}raytrace/{sc}.json --out {sc}.png --device cpu --json")
    C("raytrace.whitted.cornell-original.cpu", "raytrace --method whitted --mesh in/data/scenes/CornellBox-Original.obj --width 48 --height 48 --eye 0,1,3.5 --target 0,1,0 --fov 40 --light-samples 4 --out cornell.exr --device cpu --json")
    C("raytrace.whitted.cornell-original.gpu", "raytrace --method whitted --mesh in/data/scenes/CornellBox-Original.obj --width 24 --height 24 --eye 0,1,3.5 --target 0,1,0 --fov 40 --out cornell.png --device gpu --json")
    C("raytrace.whitted.teapot.cpu", f"raytrace --method whitted --mesh {TEAPOT} --width 48 --height 36 --out teapot.png --device cpu --json")
    C("raytrace.whitted.frames-path-pattern.cpu", step(f"{RB} --scene {CHECKER} --frames 3 --path {G}rt/path.txt --device cpu --json".split() + ["--out", "frame_{:03}.png"]))
    C("raytrace.whitted.frames-last.cpu", f"{RB} --scene {CHECKER} --frames 2 --out last.png --device cpu")
    C("raytrace.whitted.warnings.cpu", f"{RB} --mesh {G}rt/a.obj --device cpu --json")
    C("raytrace.whitted.regression-mtl-ni.cpu", f"{RB} --mesh {G}rt/reg-ni.obj --device cpu --json")
    C("raytrace.whitted.regression-mtl-xyz.cpu", f"{RB} --mesh {G}rt/reg-xyz.obj --device cpu --json")
    C("raytrace.whitted.repeat.cpu", f"raytrace --method whitted --mesh {SOP} --width 16 --height 12 --out r.png --warmup 1 --repeat 3 --device cpu --json")
    for name, args in [("bad-mtl", f"--mesh {G}rt/badmtl.obj"), ("bad-ni", f"--mesh {G}rt/badni.obj"), ("bad-vn", f"--mesh {G}rt/badvn.obj"),
                       ("bad-vn-index", f"--mesh {G}rt/badvni.obj"), ("scene-gold", f"--scene {G}scenes/gold.json"),
                       ("scene-sphere-radius", f"--scene {G}scenes/sphere.json"), ("out-jpg", f"--mesh {G}rt/good.obj --out x.jpg"),
                       ("max-depth17", f"--mesh {G}rt/good.obj --max-depth 17"), ("spp0", f"--mesh {G}rt/good.obj --spp 0"),
                       ("light-samples0", f"--mesh {G}rt/good.obj --light-samples 0"), ("frames0", f"--mesh {G}rt/good.obj --frames 0"),
                       ("exposure0", f"--mesh {G}rt/good.obj --exposure 0"), ("bad-path", f"--mesh {G}rt/good.obj --frames 2 --path {G}rt/badpath.txt"),
                       ("ray-tree-outside", f"--mesh {G}rt/good.obj --ray-tree 48,0"), ("mesh-missing", "--mesh none.obj"),
                       ("ambient-x", f"--mesh {G}rt/good.obj --ambient 1,x,1"), ("epsilon-whitted", f"--mesh {SOP} --epsilon 0.1"),
                       ("reference-whitted", f"--mesh {SOP} --reference"), ("path-no-frames", f"--mesh {SOP} --path {SOP}"),
                       ("packets-maybe", f"--mesh {G}rt/good.obj --packets maybe")]:
        C(f"raytrace.bad.{name}", f"{RB} {args} --device cpu --json")
    C("raytrace.bad.no-method", f"raytrace --mesh {SOP} --width 8 --height 8 --device cpu")
    C("raytrace.bad.method-magic", f"raytrace --method magic --mesh {SOP} --width 8 --height 8 --device cpu")
    C("raytrace.bad.bounded-ray-tree", f"raytrace --mesh {SOP} --width 8 --height 8 --method bounded --ray-tree 1,1")
    C("raytrace.bad.bounded-repeat", f"raytrace --method bounded --mesh {SOP} --width 8 --height 8 --out b.png --repeat 2")
    C("raytrace.bad.bounded-error-image-exr", f"raytrace --method bounded --mesh {SOP} --width 8 --height 8 --error-image t.exr")
    # bounded
    C("raytrace.bounded.reference-check.cpu", f"raytrace --method bounded --width 80 --height 60 --scene {CHECKER} --frames 3 --reference --check 4 --error-image why.png --epsilon 0.1 --split 4 --device cpu --json")
    C("raytrace.bounded.default.cpu", f"raytrace --method bounded --mesh {SOP} --width 16 --height 12 --epsilon 0.1 --device cpu --json")
    C("raytrace.bounded.frames-pattern.cpu", step(f"raytrace --method bounded --epsilon 0.05 --scene {CHECKER} --width 64 --height 48 --frames 3 --reference --check 16 --error-image why.png --device cpu --json".split() + ["--out", "frame_{:04}.png"]))
    C("raytrace.bounded.epsilon0.cpu", f"raytrace --method bounded --epsilon 0 --scene {CHECKER} --width 48 --height 36 --reference --out b.png --device cpu --json")
    C("raytrace.bounded.paper-bound-span.cpu", f"raytrace --method bounded --bound paper --span on --reproject off --epsilon 0.1 --scene {CHECKER} --width 48 --height 36 --frames 2 --out b.exr --device cpu --json")
    C("raytrace.bounded.patches-teapot.cpu", f"raytrace --method bounded --patches on --mesh {TEAPOT} --width 48 --height 36 --frames 2 --reference --out b.png --device cpu --json")
    C("raytrace.bounded.memory-min-pixels.cpu", f"raytrace --method bounded --memory-mb 1 --min-pixels 8 --floor 0.01 --scene {CHECKER} --width 48 --height 36 --frames 2 --device cpu --json")
    C("raytrace.bounded.slow-path-cpu.gpu", f"raytrace --method bounded --width 24 --height 18 --scene {CHECKER} --frames 2 --slow-path cpu --device gpu --out b.png --json")
    C("raytrace.bounded.slow-path-device.gpu", f"raytrace --method bounded --width 24 --height 18 --scene {CHECKER} --frames 2 --slow-path device --device gpu --out b.png --json")
    for name, args in [("epsilon-neg", "--epsilon -0.1"), ("floor0", "--floor 0"), ("memory0", "--memory-mb 0"), ("min-pixels0", "--min-pixels 0"),
                       ("spp4", "--spp 4"), ("slow-path-gpu", "--slow-path gpu"), ("split3", "--split 3"), ("bound-magic", "--bound magic")]:
        C(f"raytrace.bounded.bad.{name}", f"raytrace --method bounded --width 48 --height 36 --scene {CHECKER} {args} --device cpu --json")

    # ---------------- gen-assets ---------------------------------------------
    C("gen-assets.json", "gen-assets --out out --json")
    C("gen-assets.text", "gen-assets --out out")
    C("gen-assets.default-out", "gen-assets")
    C("gen-assets.bad.out-is-file", "gen-assets --out f.txt", setup=[("write", "f.txt", "x\n")])

    # ---------------- sweep --------------------------------------------------
    def sw(name, args, device, rep=2):
        C(f"sweep.{name}.{device}", f"sweep {args} --out {name}-{device} --repeat {rep} --device {device} --json")
    for dev in ["cpu", "gpu"]:
        small = dev == "gpu"
        sw("field", f"field --mesh {SOP} --grid res=8,16 --grid bits=1,8 --grid positions=258 --truth-rays 32", dev)
        sw("ssao", f"ssao --mesh {CORNER} --grid estimator=sphere,importance --grid spp=4,16 --width {32 if small else 64} --height {24 if small else 48} --truth-rays 16", dev)
        sw("trace", f"trace --mesh {SOP} --width {24 if small else 64} --height {16 if small else 48}", dev)
        sw("prt", f"prt --mesh {SOP} --grid mask=16,32 --grid hierarchy=off --truth-rays 64", dev)
        sw("bounded", f"bounded --scene {CHECKER} --grid epsilon=0.02,0.2 --grid split=16 --width {24 if small else 64} --height {18 if small else 48}", dev)
    C("sweep.field-receiver.text.cpu", f"sweep field --mesh {CWH} --receiver {PLANE} --grid res=8 --grid bits=8 --grid positions=66 --truth-rays 16 --out swr --repeat 1 --device cpu")
    C("sweep.ssao-measure.cpu", f"sweep ssao --mesh {SOP} --grid estimator=importance --grid spp=4 --grid measure=step,exp --width 32 --height 24 --truth-rays 8 --out swm --repeat 1 --device cpu --json")
    for name, args in [("unknown-knob", "field --grid foo=1"), ("grid-no-values", "field --grid res"), ("grid-res1000", "field --grid res=1000"),
                       ("spp-four", "ssao --grid spp=four"), ("trace-radius", "trace --radius 2"), ("prt-receiver", f"prt --receiver {SOP}"),
                       ("repeat0", "field --repeat 0"), ("method-magic", "magic"),
                       ("sphere-step", "ssao --grid estimator=sphere --grid measure=step")]:
        C(f"sweep.bad.{name}", f"sweep {args} --mesh {SOP} --out out --device cpu")
    C("sweep.bad.no-out", f"sweep field --mesh {SOP} --device cpu")

    # ---------------- the guide's examples (docs/guide/*.md, run by tests/docs.rs) ----
    # As written (default --device auto, which is the CPU path here), except the
    # bunny ones, which are left to the small bunny cases above.
    C("guide.ao.corner", f"ao --mesh {CORNER} --method raycast --rays 64 --per-vertex corner-ao.csv --image corner-ao.png --width 320 --height 240 --json")
    C("guide.ao.field-build-info-use", f"field build --mesh {CWH} --positions 258 --res 16 --bits 8 -o cube.dfield",
      "field info cube.dfield",
      f"ao --mesh {CWH} --receiver {PLANE} --method field --field cube.dfield --rays 32 --per-vertex plane-ao.csv")
    C("guide.outputs.ao-exr-ply", f"ao --mesh {CORNER} --method raycast --rays 64 --image ao.exr --per-vertex ao.ply")
    C("guide.outputs.ao-png16", f"ao --mesh {CORNER} --method raycast --rays 64 --image ao.png --png-bits 16")
    C("guide.outputs.prt-cloth", step(["prt", "--animated", "cloth", "--env", GRACE, "--frames", "4", "--width", "320", "--height", "240",
                                       "--out", "cloth-{:04}.exr", "--sh-out", "grace-sh.json", "--per-vertex", "cloth.csv", "--per-vertex-transfer"]))
    C("guide.prt.cloth-png", step(["prt", "--animated", "cloth", "--env", GRACE, "--frames", "4", "--width", "320", "--height", "240",
                                   "--out", "cloth-{:04}.png", "--sh-out", "grace-sh.json", "--per-vertex", "cloth.csv", "--json"]))
    C("guide.prt.flag-sequence", f"prt --mesh-sequence 'in/assets/animations/flag/*.obj' --env {PISA} --width 320 --height 240 --out flag.exr --reference --reference-frames 2 --reference-rays 256 --json",
      inputs=["assets/animations/flag/flag-000.obj"])
    C("guide.prt.tube-twist", f"prt --mesh {A}animations/bending-tube.glb --animation twist --frames 8 --env {UFFIZI} --per-vertex tube.csv --per-vertex-transfer")
    C("guide.prt.chess-inter-off", f"prt --scene {A}scenes/chess.json --env {PISA} --frames 4 --inter-object off --per-vertex chess.csv --self-check off")
    C("guide.raytrace.checker-640", f"raytrace --method whitted --scene {CHECKER} --width 640 --height 480 --out spheres.png")
    C("guide.raytrace.cornell-original", "raytrace --method whitted --mesh in/data/scenes/CornellBox-Original.obj --width 256 --height 256 --eye 0,1,3.5 --target 0,1,0 --fov 40 --light-samples 16 --out cornell.exr")
    C("guide.raytrace.bounded", step(f"raytrace --method bounded --epsilon 0.05 --scene {CHECKER} --width 320 --height 240 --frames 4 --reference --check 16 --error-image why.png --json".split() + ["--out", "frame_{:04}.png"]))
    C("guide.ssao.indirect", f"ssao --mesh {SOP} --estimator importance --spp 8 --radius 0.5 --width 320 --height 240 --out ssao-ao.png --image ssao-lit.png --indirect --reference-rays 32 --screen-reference-spp 64 --json")
    C("guide.trace.dump-and-trace-rays", f"trace --mesh {SOP} --width 320 --height 240 --out sphere-trace.png --tiles-image sphere-tiles.png --dump-rays sphere-rays.f32 --json",
      f"trace-rays --mesh {SOP} --rays sphere-rays.f32 --out sphere-hits.bin --json")
    C("guide.trace.wall-aa-reference", f"trace --mesh {WALL} --width 320 --height 240 --aa adaptive --reference --json")
    # the bunny, small
    C("ao.field.bunny-corner.small.cpu", f"ao --scene {A}scenes/bunny-corner.json --method field --rays 8 --positions 66 --res 8 --per-vertex ao.csv --device cpu --json")
    C("ssao.bunny.small.cpu", f"ssao --mesh {BUNNY} --estimator hemisphere --spp 4 --radius 0.02 --width 48 --height 36 --truth-rays 8 --reference-spp 16 --out b.png --device cpu --json")

    # ---------------- guards: outputs over inputs (cli_guards.rs) -----------
    gsetup = [("mkdir", "in/assets/sub"), ("symlink", "in/assets/sphere-on-plane.obj", "link.obj"),
              ("hardlink", "in/assets/sphere-on-plane.obj", "hard.obj")]
    spellings = {"path": SOP, "dot": "in/assets/./sphere-on-plane.obj", "dotdot": "in/assets/sub/../sphere-on-plane.obj",
                 "symlink": "link.obj", "hardlink": "hard.obj", "absolute": "{case}/in/assets/sphere-on-plane.obj"}
    commands = {
        "ao-per-vertex": "ao --mesh {mesh} --method raycast --rays 4 --per-vertex {out}",
        "ao-image": "ao --mesh {mesh} --method raycast --rays 4 --image {out}",
        "trace-out": "trace --mesh {mesh} --width 8 --height 8 --out {out}",
        "trace-dump-rays": "trace --mesh {mesh} --width 8 --height 8 --dump-rays {out}",
        "ssao-out": "ssao --mesh {mesh} --estimator sphere --spp 4 --radius 0.5 --width 8 --height 8 --out {out}",
        "field-build": "field build --mesh {mesh} --positions 2 --res 4 --bits 8 -o {out}",
        "raytrace-out": "raytrace --method whitted --mesh {mesh} --width 8 --height 8 --out {out}",
        "trace-rays-out": "trace-rays --mesh {mesh} --rays " + G + "rays/zeros24.f32 --out {out}",
    }
    for cname, tmpl in commands.items():
        for sname, out in spellings.items():
            if sname not in ("path", "symlink") and cname not in ("ao-per-vertex", "trace-out"):
                continue
            C(f"guard.{cname}.{sname}", tmpl.format(mesh=SOP, out=out) + " --json", setup=gsetup)
    C("guard.raytrace-frame-pattern", step(f"raytrace --method whitted --mesh frame_0001.obj --width 8 --height 8 --frames 3".split() + ["--out", "frame_{:04}.obj"]),
      setup=[("copy", SOP, "frame_0001.obj")])
    for opt, out in [("sh-out", f"{G}hdr/env.hdr"), ("per-vertex", f"{G}hdr/env.hdr"), ("per-vertex-mesh", SOP)]:
        o = opt.replace("-mesh", "")
        C(f"guard.prt-{opt}", f"prt --mesh {SOP} --env {G}hdr/env.hdr --{o} {out}")
    C("guard.prt-frame-pattern", step(f"prt --mesh {SOP} --env f_0002.hdr --frames 3".split() + ["--out", "f_{:04}.hdr"]),
      setup=[("copy", G + "hdr/env.hdr", "f_0002.hdr")])
    C("guard.ao-ply-over-ply", f"ao --mesh {G}mesh.ply --method raycast --rays 4 --per-vertex {G}mesh.ply")
    C("guard.scene-mesh", f"ao --scene {G}scenes/guard.json --method raycast --rays 4 --per-vertex {SOP}")
    C("guard.mtl-companion", f"raytrace --method whitted --mesh {G}rt/m.obj --width 8 --height 8 --out {G}rt/m.mtl --device cpu")
    C("guard.gltf-buffer", f"ao --mesh {G}t.gltf --method raycast --rays 4 --per-vertex 'in/gen/tri data.bin' --device cpu")
    # options that do not apply (cli_guards.rs, cli_outputs.rs)
    aor = f"ao --mesh {SOP} --method raycast --rays 4 --per-vertex ao.csv"
    rt = f"raytrace --mesh {SOP} --width 8 --height 8"
    ss = f"ssao --mesh {SOP} --estimator sphere --spp 4 --radius 0.5 --width 8 --height 8"
    for name, line in [("ao-frames", f"{aor} --frames 2"), ("ao-bits", f"{aor} --bits 8"), ("ao-field", f"{aor} --field {SOP}"),
                       ("ao-width", f"{aor} --width 64"), ("ao-positional", f"{aor} --positional nearest"),
                       ("ao-reference-raycast", f"{aor} --reference"), ("ao-max-error-raycast", f"{aor} --max-error 0.1"),
                       ("ssao-sigma", f"{ss} --sigma 3"),
                       ("ao-png-bits-csv", f"ao --mesh {CORNER} --method raycast --rays 4 --per-vertex v.csv --png-bits 16"),
                       ("ao-png-bits-exr", f"ao --mesh {CORNER} --method raycast --rays 4 --image a.exr --png-bits 16"),
                       ("ao-background-csv", f"ao --mesh {CORNER} --method raycast --rays 4 --per-vertex v.csv --background transparent"),
                       ("ssao-png-bits-exr", f"ssao --mesh {CORNER} --estimator sphere --spp 4 --radius 1 --image a.exr --png-bits 16"),
                       ("ssao-background-image", f"ssao --mesh {CORNER} --estimator sphere --spp 4 --radius 1 --image a.exr --background black"),
                       ("trace-min-tile-single", f"trace --mesh {SOP} --width 8 --height 8 --single-ray --min-tile 16"),
                       ("raytrace-bounded-max-error", f"{rt} --method bounded --max-error 0.1"),
                       ("prt-albedo-per-vertex", f"prt --mesh {SOP} --env {PROBE} --albedo 0.8,0.6,0.4 --per-vertex v.csv")]:
        C(f"applies.{name}", line)
    # image formats checked before any work (cli_outputs.rs): the mesh does not exist
    for name, line in [("ao-image", "ao --mesh missing.obj --method raycast --rays 4 --image x.jpg"),
                       ("ao-field-image", "ao --mesh missing.obj --method field --receiver missing.obj --rays 4 --image x.jpg"),
                       ("ssao-out", "ssao --mesh missing.obj --estimator sphere --spp 4 --radius 1 --out x.jpg"),
                       ("ssao-image", "ssao --mesh missing.obj --estimator sphere --spp 4 --radius 1 --image x.jpg"),
                       ("trace-out", "trace --mesh missing.obj --width 8 --height 8 --out x.jpg"),
                       ("trace-aa-image", "trace --mesh missing.obj --width 8 --height 8 --aa uniform --aa-image x.jpg"),
                       ("prt-out", "prt --mesh missing.obj --env missing.hdr --out x.jpg"),
                       ("raytrace-out", "raytrace --method whitted --mesh missing.obj --width 8 --height 8 --out x.jpg"),
                       ("trace-tiles-exr", "trace --mesh missing.obj --width 8 --height 8 --tiles-image t.exr"),
                       ("raytrace-error-image-exr", "raytrace --method bounded --mesh missing.obj --width 8 --height 8 --error-image t.exr"),
                       ("ao-pfm-transparent", "ao --mesh missing.obj --method raycast --rays 4 --image t.pfm --background transparent"),
                       ("ao-no-extension", "ao --mesh missing.obj --method raycast --rays 4 --image noext")]:
        C(f"format.{name}", line)


# ---------------------------------------------------------------------------
# Running
# ---------------------------------------------------------------------------

def sha256(data):
    return hashlib.sha256(data).hexdigest()


def inputs_of(case):
    names = list(case.inputs)
    toks = []
    for s in case.steps:
        for a in s.get("argv", []):
            toks.append(a)
            if "=" in a:
                toks.append(a.split("=", 1)[1])
    for op in case.setup:
        if op[0] in ("copy", "symlink", "hardlink"):
            toks.append(op[1])
    for t in toks:
        if t.startswith("in/") and "*" not in t and "{" not in t:
            names.append(os.path.normpath(t[3:]))
    out, seen = [], set()
    while names:
        n = names.pop(0)
        if n in seen:
            continue
        seen.add(n)
        out.append(n)
        names.extend(DEPS.get(n, []))
    return out


def snapshot(root):
    files, dirs = {}, set()
    for dp, dn, fn in os.walk(root):
        rel = os.path.relpath(dp, root)
        if rel != ".":
            dirs.add(rel)
        for f in fn:
            p = os.path.join(dp, f)
            r = os.path.normpath(os.path.join(rel, f))
            if os.path.islink(p):
                files[r] = "link:" + os.readlink(p)
            elif os.path.isfile(p):
                with open(p, "rb") as fh:
                    files[r] = sha256(fh.read())
            else:
                files[r] = "special"
    return files, dirs


def base_env(casedir):
    return {
        "PATH": "/usr/local/bin:/usr/bin:/bin",
        "HOME": str(CASE_ROOT / ".home"),
        "LANG": "C.UTF-8",
        "XDG_RUNTIME_DIR": str(CASE_ROOT / ".xdg"),
        "XDG_CACHE_HOME": str(casedir / "xdg-cache"),
        "PENUMBRA_CACHE_DIR": str(casedir / "cache"),
        "PENUMBRA_DATA": str(casedir / "in" / "data"),
        "MESA_SHADER_CACHE_DIR": str(CASE_ROOT / ".mesa-cache"),
    }


def subst(s, casedir):
    return s.replace("{case}", str(casedir))


def run_py(op, casedir):
    name = op[0]
    p = lambda x: casedir / x
    if name == "truncate":
        data = p(op[1]).read_bytes()
        p(op[2]).write_bytes(data[: len(data) - op[3]])
    elif name == "flipbit":
        data = bytearray(p(op[1]).read_bytes())
        if op[3] < len(data):
            data[op[3]] ^= 1
        p(op[2]).write_bytes(bytes(data))
    elif name == "write":
        p(op[1]).write_bytes(op[2].encode() if isinstance(op[2], str) else op[2])
    elif name == "append":
        with open(p(op[1]), "ab") as fh:
            fh.write(op[2].encode())
    else:
        raise ValueError(name)


def run_step(binary, st, casedir, env, timeout):
    argv = [subst(a, casedir) for a in st["argv"]]
    start = time.monotonic()
    # argv[0] is always "penumbra" (clap prints it in usage lines), whatever the binary's path.
    kw = dict(cwd=casedir, env=env, stdin=subprocess.DEVNULL, stderr=subprocess.PIPE, start_new_session=True)
    if st.get("close_stdout"):
        proc = subprocess.Popen(["penumbra"] + argv, executable=binary, stdout=subprocess.PIPE, **kw)
        proc.stdout.close()
        try:
            err = proc.communicate(timeout=timeout)[1]
            code = proc.returncode
        except subprocess.TimeoutExpired:
            os.killpg(proc.pid, signal.SIGKILL)
            err = proc.communicate()[1]
            code = "timeout"
        out = b""
    elif st.get("interrupt_after_tmp") is not None:
        proc = subprocess.Popen(["penumbra"] + argv, executable=binary, stdout=subprocess.PIPE, **kw)
        out_chunks = []
        reader = threading.Thread(target=lambda: out_chunks.append(proc.stdout.read()))
        reader.start()
        deadline = time.monotonic() + 60
        found = False
        while time.monotonic() < deadline and proc.poll() is None:
            if any(f.endswith(".tmp") for _, _, fs in os.walk(casedir) for f in fs):
                found = True
                break
            time.sleep(0.02)
        if found:
            time.sleep(st["interrupt_after_tmp"])
        if proc.poll() is None:
            proc.send_signal(signal.SIGINT)
        try:
            err = proc.stderr.read()
            proc.wait(timeout=timeout)
            code = proc.returncode
        except subprocess.TimeoutExpired:
            os.killpg(proc.pid, signal.SIGKILL)
            proc.wait()
            code = "timeout"
        reader.join()
        out = out_chunks[0] if out_chunks else b""
        if not found:
            err += b"\n[golden: no temporary appeared before the run ended]\n"
    else:
        proc = subprocess.Popen(["penumbra"] + argv, executable=binary, stdout=subprocess.PIPE, **kw)
        try:
            out, err = proc.communicate(timeout=timeout)
            code = proc.returncode
        except subprocess.TimeoutExpired:
            os.killpg(proc.pid, signal.SIGKILL)
            out, err = proc.communicate()
            code = "timeout"
    return argv, code, out, err, time.monotonic() - start


def run_case(case, binary, outdir, inp):
    casedir = CASE_ROOT / case.name
    if casedir.exists() or casedir.is_symlink():
        shutil.rmtree(casedir)
    casedir.mkdir(parents=True)
    for name in inputs_of(case):
        src = inp.ensure(name)
        dst = casedir / "in" / name
        dst.parent.mkdir(parents=True, exist_ok=True)
        shutil.copyfile(src, dst)
    for op in case.setup:
        kind = op[0]
        if kind == "mkdir":
            (casedir / op[1]).mkdir(parents=True, exist_ok=True)
        elif kind == "symlink":
            os.symlink(casedir / op[1], casedir / op[2])
        elif kind == "hardlink":
            os.link(casedir / op[1], casedir / op[2])
        elif kind == "copy":
            shutil.copyfile(casedir / op[1], casedir / op[2])
        elif kind == "write":
            (casedir / op[1]).write_text(op[2])
        else:
            raise ValueError(kind)
    env = base_env(casedir)
    for k, v in case.env.items():
        if v is None:
            env.pop(k, None)
        else:
            env[k] = subst(v, casedir)
    rdir = outdir / "cases" / case.name
    if rdir.exists():
        shutil.rmtree(rdir)
    rdir.mkdir(parents=True)
    meta = {"name": case.name, "group": case.group, "device": case.device, "note": case.note, "steps": []}
    env_shown = {k: v for k, v in case.env.items()}
    t0 = time.monotonic()
    before = snapshot(casedir)
    for i, st in enumerate(case.steps):
        if "py" in st:
            run_py(st["py"], casedir)
            meta["steps"].append({"py": st["py"] if not (st["py"][0] == "write") else [st["py"][0], st["py"][1], sha256(st["py"][2].encode())]})
            before = snapshot(casedir)
            continue
        argv, code, out, err, secs = run_step(binary, st, casedir, env, case.timeout)
        after = snapshot(casedir)
        written = {f: h for f, h in after[0].items() if before[0].get(f) != h}
        deleted = sorted(f for f in before[0] if f not in after[0])
        newdirs = sorted(after[1] - before[1])
        (rdir / f"s{i}.stdout").write_bytes(out)
        (rdir / f"s{i}.stderr").write_bytes(err)
        for f, h in written.items():
            if h.startswith(("link:", "special")):
                continue
            dst = rdir / "files" / f"s{i}" / f
            dst.parent.mkdir(parents=True, exist_ok=True)
            shutil.copyfile(casedir / f, dst)
        meta["steps"].append({"argv": argv, "env": env_shown, "exit": code, "seconds": round(secs, 3),
                              "stdout_sha": sha256(out), "stderr_sha": sha256(err),
                              "written": written, "deleted": deleted, "dirs_created": newdirs,
                              **({"close_stdout": True} if st.get("close_stdout") else {}),
                              **({"interrupt_after_tmp": st["interrupt_after_tmp"]} if st.get("interrupt_after_tmp") is not None else {})})
        before = after
    meta["seconds"] = round(time.monotonic() - t0, 3)
    (rdir / "case.json").write_text(json.dumps(meta, indent=1, sort_keys=True))
    shutil.rmtree(casedir, ignore_errors=True)
    return meta


def selected(only):
    build_cases()
    rx = re.compile(only) if only else None
    return [c for c in CASES if not rx or rx.search(c.name)]


def cmd_record(args):
    binary = str(Path(args.bin).resolve())
    if not os.access(binary, os.X_OK):
        sys.exit(f"not an executable: {binary}")
    outdir = Path(args.out).resolve()
    if not args.only and (outdir / "cases").exists():
        shutil.rmtree(outdir / "cases")
    outdir.mkdir(parents=True, exist_ok=True)
    cases = selected(args.only)
    inp = Inputs(args.repo, args.data)
    for d in [CASE_ROOT, CASE_ROOT / ".home", CASE_ROOT / ".xdg", CASE_ROOT / ".mesa-cache"]:
        d.mkdir(parents=True, exist_ok=True)
    os.chmod(CASE_ROOT / ".xdg", 0o700)
    lock = open(CASE_ROOT / ".lock", "w")
    try:
        fcntl.flock(lock, fcntl.LOCK_EX | fcntl.LOCK_NB)
    except OSError:
        print("another record is running (lock /tmp/pg/.lock); waiting", file=sys.stderr)
        fcntl.flock(lock, fcntl.LOCK_EX)
    # Snapshot every input first (sequentially), so runs only copy.
    for c in cases:
        for n in inputs_of(c):
            inp.ensure(n)
    t0 = time.monotonic()
    done = [0]
    results = {}

    def one(c):
        m = run_case(c, binary, outdir, inp)
        done[0] += 1
        codes = ",".join(str(s.get("exit")) for s in m["steps"] if "argv" in s)
        if args.verbose:
            print(f"[{done[0]}/{len(cases)}] {c.name}: exit {codes} in {m['seconds']:.1f} s", file=sys.stderr)
        return m

    # Longest (GPU, sweep) cases first so the pool ends evenly.
    order = sorted(cases, key=lambda c: (0 if (c.device == "gpu" or c.group == "sweep") else 1))
    with ThreadPoolExecutor(max_workers=args.jobs) as ex:
        for m in ex.map(one, order):
            results[m["name"]] = m
    total = time.monotonic() - t0
    index = {"binary": binary, "binary_sha256": sha256(Path(binary).read_bytes()), "cases": [c.name for c in cases],
             "seconds": round(total, 1), "jobs": args.jobs, "only": args.only,
             "recorded_at": time.strftime("%Y-%m-%dT%H:%M:%S")}
    old = outdir / "index.json"
    if args.only and old.exists():
        prev = json.loads(old.read_text())
        names = list(dict.fromkeys(prev.get("cases", []) + index["cases"]))
        index["cases"] = names
    old.write_text(json.dumps(index, indent=1))
    slow = sorted(results.values(), key=lambda m: -m["seconds"])[:8]
    print(f"recorded {len(cases)} cases into {outdir} in {total:.1f} s (--jobs {args.jobs})")
    print("slowest: " + ", ".join(f"{m['name']} {m['seconds']:.1f}s" for m in slow))
    bad = [m["name"] for m in results.values() if any(s.get("exit") == "timeout" for s in m["steps"])]
    if bad:
        print("timed out: " + ", ".join(bad))


# ---------------------------------------------------------------------------
# Comparing
# ---------------------------------------------------------------------------

def first_diff_json(a, b, path=""):
    if type(a) != type(b):
        return f"{path or '.'}: {canon(a)[:120]} != {canon(b)[:120]}"
    if isinstance(a, dict):
        for k in list(a) + [k for k in b if k not in a]:
            if k not in a:
                return f"{path}.{k}: only in B ({canon(b[k])[:100]})"
            if k not in b:
                return f"{path}.{k}: only in A ({canon(a[k])[:100]})"
            d = first_diff_json(a[k], b[k], f"{path}.{k}")
            if d:
                return d
        if list(a) != list(b):
            return f"{path or '.'}: key order {list(a)[:12]} != {list(b)[:12]}"
        return None
    if isinstance(a, list):
        if len(a) != len(b):
            return f"{path}: list length {len(a)} != {len(b)}"
        for i, (x, y) in enumerate(zip(a, b)):
            d = first_diff_json(x, y, f"{path}[{i}]")
            if d:
                return d
        return None
    if a != b:
        return f"{path or '.'}: {canon(a)[:120]} != {canon(b)[:120]}"
    return None


def first_diff_text(a, b):
    la, lb = a.split("\n"), b.split("\n")
    for i, (x, y) in enumerate(zip(la, lb)):
        if x != y:
            return f"line {i + 1}: {x[:160]!r} != {y[:160]!r}"
    if len(la) != len(lb):
        i = min(len(la), len(lb))
        extra = (la if len(la) > len(lb) else lb)[i]
        return f"line {i + 1}: only in {'A' if len(la) > len(lb) else 'B'}: {extra[:160]!r}"
    return None


def png_header(data):
    if data[:8] != b"\x89PNG\r\n\x1a\n":
        return None
    return struct.unpack(">IIBB", data[16:26])


def csv_drop(text, drop):
    lines = text.split("\n")
    if not lines:
        return text
    header = lines[0].split(",")
    keep = [i for i, h in enumerate(header) if h not in drop]
    return "\n".join(",".join(c for i, c in enumerate(l.split(",")) if i in keep) for l in lines)


class Stats:
    def __init__(self):
        self.c = {k: 0 for k in ["cases", "identical", "steps", "exit", "stdout_json", "stdout_text", "stderr",
                                 "files", "files_bytes", "files_json", "files_csv", "files_pngheader"]}


def compare_case(name, A, B, raw, st):
    diffs = []
    ma = json.loads((A / "cases" / name / "case.json").read_text())
    mb = json.loads((B / "cases" / name / "case.json").read_text())
    sweep = name.startswith("sweep.")
    drop = SWEEP_JSON_DROP if (sweep and not raw) else ()
    if len(ma["steps"]) != len(mb["steps"]):
        return [f"step count {len(ma['steps'])} != {len(mb['steps'])}"]
    for i, (sa, sb) in enumerate(zip(ma["steps"], mb["steps"])):
        if "py" in sa:
            if sa != sb:
                diffs.append(f"s{i}: harness step differs")
            continue
        st.c["steps"] += 1
        tag = f"s{i}" if len(ma["steps"]) > 1 else ""
        pre = (tag + " ") if tag else ""
        if sa["argv"] != sb["argv"]:
            diffs.append(f"{pre}argv differs (case definitions differ): {sa['argv']} vs {sb['argv']}")
            continue
        st.c["exit"] += 1
        if sa["exit"] != sb["exit"]:
            diffs.append(f"{pre}exit code {sa['exit']} != {sb['exit']}")
        # stdout
        oa = (A / "cases" / name / f"s{i}.stdout").read_bytes().decode("utf-8", "replace")
        ob = (B / "cases" / name / f"s{i}.stdout").read_bytes().decode("utf-8", "replace")
        ja, jb = parse_json_stdout(oa), parse_json_stdout(ob)
        if ja is not None and jb is not None:
            st.c["stdout_json"] += 1
            la, lb = json_layout(oa, parse_json_stdout(oa)), json_layout(ob, parse_json_stdout(ob))
            if not raw:
                ja, jb = norm_json(ja, drop), norm_json(jb, drop)
            d = first_diff_json(ja, jb)
            if d:
                diffs.append(f"{pre}stdout JSON {d}")
            elif la != lb:
                diffs.append(f"{pre}stdout JSON laid out differently: {la[:60]} != {lb[:60]}")
        else:
            st.c["stdout_text"] += 1
            ta, tb = (oa, ob) if raw else (norm_text(oa, drop), norm_text(ob, drop))
            d = first_diff_text(ta, tb)
            if d:
                diffs.append(f"{pre}stdout {d}")
        # stderr
        ea = (A / "cases" / name / f"s{i}.stderr").read_bytes().decode("utf-8", "replace")
        eb = (B / "cases" / name / f"s{i}.stderr").read_bytes().decode("utf-8", "replace")
        st.c["stderr"] += 1
        if not raw:
            ea, eb = norm_text(ea), norm_text(eb)
        d = first_diff_text(ea, eb)
        if d:
            diffs.append(f"{pre}stderr {d}")
        # files
        fa, fb = sa["written"], sb["written"]
        for f in sorted(set(fa) | set(fb)):
            if f not in fb:
                diffs.append(f"{pre}file {f}: written only by A")
                continue
            if f not in fa:
                diffs.append(f"{pre}file {f}: written only by B")
                continue
            st.c["files"] += 1
            if fa[f].startswith(("link:", "special")) or fb[f].startswith(("link:", "special")):
                if fa[f] != fb[f]:
                    diffs.append(f"{pre}file {f}: {fa[f]} != {fb[f]}")
                else:
                    st.c["files_bytes"] += 1
                continue
            da = (A / "cases" / name / "files" / f"s{i}" / f).read_bytes()
            db = (B / "cases" / name / "files" / f"s{i}" / f).read_bytes()
            # The kept files are what is compared; a file edited after recording shows.
            for side, data, h in (("A", da, fa[f]), ("B", db, fb[f])):
                if sha256(data) != h:
                    diffs.append(f"{pre}file {f}: the copy kept in {side} does not match the hash recorded when it was written")
            if da == db:
                st.c["files_bytes"] += 1
                continue
            base = os.path.basename(f)
            if not raw and sweep and base == "sweep.png":
                st.c["files_pngheader"] += 1
                ha, hb = png_header(da), png_header(db)
                if ha != hb or ha is None:
                    diffs.append(f"{pre}file {f}: PNG header (w, h, depth, colour) {ha} != {hb}")
                continue
            if not raw and sweep and base == "sweep.csv":
                st.c["files_csv"] += 1
                d = first_diff_text(csv_drop(da.decode(), SWEEP_CSV_DROP), csv_drop(db.decode(), SWEEP_CSV_DROP))
                if d:
                    diffs.append(f"{pre}file {f}: {d}")
                continue
            if not raw and (base.endswith(".json") or f.startswith("cache/")):
                try:
                    ta, tb = da.decode(), db.decode()
                    xa, xb = jparse(ta), jparse(tb)
                except ValueError:
                    xa = xb = None
                if xa is not None:
                    st.c["files_json"] += 1
                    d = first_diff_json(norm_json(xa, drop), norm_json(xb, drop))
                    if d:
                        diffs.append(f"{pre}file {f}: JSON {d}")
                    elif json_layout(ta, xa) != json_layout(tb, xb):
                        diffs.append(f"{pre}file {f}: JSON laid out differently")
                    continue
            # byte difference: describe it
            off = next((k for k, (x, y) in enumerate(zip(da, db)) if x != y), min(len(da), len(db)))
            desc = f"{pre}file {f}: bytes differ (sizes {len(da)} vs {len(db)}, first at byte {off})"
            try:
                d = first_diff_text(da.decode(), db.decode())
                if d:
                    desc += f"; {d}"
            except UnicodeDecodeError:
                pass
            diffs.append(desc)
        if sa["deleted"] != sb["deleted"]:
            diffs.append(f"{pre}deleted files {sa['deleted']} != {sb['deleted']}")
        if sa["dirs_created"] != sb["dirs_created"]:
            diffs.append(f"{pre}directories created {sa['dirs_created']} != {sb['dirs_created']}")
    return diffs


def cmd_compare(args):
    A, B = Path(args.a), Path(args.b)
    ia = json.loads((A / "index.json").read_text())
    ib = json.loads((B / "index.json").read_text())
    na, nb = ia["cases"], ib["cases"]
    st = Stats()
    all_diffs = {}
    for n in sorted(set(na) - set(nb)):
        all_diffs[n] = ["case only in A"]
    for n in sorted(set(nb) - set(na)):
        all_diffs[n] = ["case only in B"]
    common = [n for n in na if n in set(nb)]
    for n in common:
        st.c["cases"] += 1
        d = compare_case(n, A, B, args.raw, st)
        if d:
            all_diffs[n] = d
        else:
            st.c["identical"] += 1
    c = st.c
    print(f"A: {A} ({ia.get('binary')}, {ia.get('seconds')} s)")
    print(f"B: {B} ({ib.get('binary')}, {ib.get('seconds')} s)")
    print(f"normalisation: {'none (--raw)' if args.raw else 'on (see golden.py docstring)'}")
    rows = [("cases compared", c["cases"]), ("cases identical", c["identical"]),
            ("cases differing", len(all_diffs)), ("steps (command runs) compared", c["steps"]),
            ("exit codes compared", c["exit"]), ("stdout compared as JSON", c["stdout_json"]),
            ("stdout compared as text", c["stdout_text"]), ("stderr compared", c["stderr"]),
            ("output files compared", c["files"]), ("  byte-identical", c["files_bytes"]),
            ("  JSON files compared normalised (not byte-identical)", c["files_json"]),
            ("  sweep.csv compared without time/pareto columns", c["files_csv"]),
            ("  sweep.png compared by PNG header", c["files_pngheader"])]
    w = max(len(r[0]) for r in rows)
    print("-" * (w + 10))
    for k, v in rows:
        print(f"{k:<{w}}  {v:>6}")
    print("-" * (w + 10))
    if not args.raw:
        for pat, why in VOLATILE.items():
            print(f"volatile (handled): {pat}: {why}")
    if all_diffs:
        print(f"\n{len(all_diffs)} case(s) differ:")
        for n, ds in all_diffs.items():
            print(f"  {n}:")
            for d in ds[: args.max_details]:
                print(f"    - {d}")
            if len(ds) > args.max_details:
                print(f"    ... {len(ds) - args.max_details} more")
        return 1
    print("\nno differences")
    return 0


def all_json_diffs(a, b, path, out):
    """Every differing leaf of two JSON values, as (path, key)."""
    if isinstance(a, dict) and isinstance(b, dict):
        for k in set(a) | set(b):
            if k not in a or k not in b:
                out.append((f"{path}.{k}", k))
            else:
                all_json_diffs(a[k], b[k], f"{path}.{k}", out)
    elif isinstance(a, list) and isinstance(b, list) and len(a) == len(b):
        for i, (x, y) in enumerate(zip(a, b)):
            all_json_diffs(x, y, f"{path}[]", out)
    elif a != b:
        out.append((path, path.rsplit(".", 1)[-1].rstrip("[]")))


def cmd_volatile(args):
    """What differs between two recordings of the same binary, without normalisation:
    the JSON keys (by name, with the cases they differ in), stderr/stdout text lines,
    and output files. This is how the normalisation rules were derived."""
    A, B = Path(args.a), Path(args.b)
    names = json.loads((A / "index.json").read_text())["cases"]
    keys, lines, files, exits = {}, {}, {}, []
    for n in names:
        ma = json.loads((A / "cases" / n / "case.json").read_text())
        mb = json.loads((B / "cases" / n / "case.json").read_text())
        for i, (sa, sb) in enumerate(zip(ma["steps"], mb["steps"])):
            if "argv" not in sa:
                continue
            if sa["exit"] != sb["exit"]:
                exits.append(f"{n} s{i}: {sa['exit']} != {sb['exit']}")
            for kind in ("stdout", "stderr"):
                ta = (A / "cases" / n / f"s{i}.{kind}").read_bytes().decode("utf-8", "replace")
                tb = (B / "cases" / n / f"s{i}.{kind}").read_bytes().decode("utf-8", "replace")
                ja, jb = parse_json_stdout(ta), parse_json_stdout(tb)
                if ja is not None and jb is not None:
                    out = []
                    all_json_diffs(ja, jb, "", out)
                    for path, key in out:
                        keys.setdefault(key, {}).setdefault(path, set()).add(n)
                elif ta != tb:
                    la, lb = ta.split("\n"), tb.split("\n")
                    for x, y in zip(la, lb):
                        if x != y:
                            lines.setdefault(f"{kind}: {x[:110]}", set()).add(n)
                    if len(la) != len(lb):
                        lines.setdefault(f"{kind}: line count {len(la)} vs {len(lb)}", set()).add(n)
            for f in set(sa["written"]) | set(sb["written"]):
                if sa["written"].get(f) != sb["written"].get(f):
                    files.setdefault(os.path.basename(f), set()).add(n)
    print("JSON keys that differ (key: paths; number of cases; an example case):")
    for k in sorted(keys):
        cases = set().union(*keys[k].values())
        print(f"  {k}: {', '.join(sorted(keys[k]))[:150]}; {len(cases)} cases; e.g. {sorted(cases)[0]}")
    print("\ntext lines that differ (first recording's version):")
    for l in sorted(lines):
        print(f"  [{len(lines[l])}] {l}   e.g. {sorted(lines[l])[0]}")
    print("\nfiles that differ:")
    for f in sorted(files):
        print(f"  {f}: {', '.join(sorted(files[f]))[:200]}")
    print("\nexit codes that differ:", exits or "none")


def cmd_list(args):
    cases = selected(args.only)
    groups = {}
    for c in cases:
        groups.setdefault(c.group, []).append(c)
    for c in cases:
        print(f"{c.name:55s} {c.group:12s} {c.device:5s} " + " ; ".join(" ".join(s["argv"]) if "argv" in s else f"[py {s['py'][0]}]" for s in c.steps))
    print(f"\n{len(cases)} cases: " + ", ".join(f"{g} {len(v)}" for g, v in sorted(groups.items())))


def cmd_summary(args):
    """Case counts by subcommand, device and outcome (from a recording)."""
    A = Path(args.dir)
    idx = json.loads((A / "index.json").read_text())
    table = {}
    for n in idx["cases"]:
        m = json.loads((A / "cases" / n / "case.json").read_text())
        codes = [s["exit"] for s in m["steps"] if "argv" in s]
        kind = "help" if m["group"] == "help" else ("ok" if all(c == 0 for c in codes) else "error")
        row = table.setdefault(m["group"], {"cases": 0, "cpu": 0, "gpu": 0, "ok": 0, "error": 0, "help": 0, "seconds": 0.0})
        row["cases"] += 1
        row[kind] += 1
        if m["device"] in ("cpu", "gpu"):
            row[m["device"]] += 1
        row["seconds"] += m["seconds"]
    print(f"{'subcommand':14s} {'cases':>5s} {'cpu':>4s} {'gpu':>4s} {'exit0':>5s} {'error':>5s} {'help':>4s} {'cpu-s':>6s}")
    tot = {"cases": 0, "cpu": 0, "gpu": 0, "ok": 0, "error": 0, "help": 0, "seconds": 0.0}
    for g, r in sorted(table.items()):
        print(f"{g:14s} {r['cases']:5d} {r['cpu']:4d} {r['gpu']:4d} {r['ok']:5d} {r['error']:5d} {r['help']:4d} {r['seconds']:6.1f}")
        for k in tot:
            tot[k] += r[k]
    print(f"{'total':14s} {tot['cases']:5d} {tot['cpu']:4d} {tot['gpu']:4d} {tot['ok']:5d} {tot['error']:5d} {tot['help']:4d} {tot['seconds']:6.1f}")
    print(f"record wall time: {idx.get('seconds')} s with --jobs {idx.get('jobs')}")


def main():
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    sub = ap.add_subparsers(dest="cmd", required=True)
    r = sub.add_parser("record")
    r.add_argument("--bin", required=True)
    r.add_argument("--out", required=True)
    r.add_argument("--only")
    r.add_argument("--jobs", type=int, default=2)
    r.add_argument("--repo", default=str(DEFAULT_REPO), help="where repo inputs come from at first use")
    r.add_argument("--data", default=str(DEFAULT_DATA), help="shared data, at first use")
    r.add_argument("-v", "--verbose", action="store_true")
    c = sub.add_parser("compare")
    c.add_argument("a")
    c.add_argument("b")
    c.add_argument("--raw", action="store_true", help="no normalisation")
    c.add_argument("--max-details", type=int, default=6)
    l = sub.add_parser("list")
    l.add_argument("--only")
    v = sub.add_parser("volatile")
    v.add_argument("a")
    v.add_argument("b")
    s = sub.add_parser("summary")
    s.add_argument("dir")
    args = ap.parse_args()
    if args.cmd == "record":
        cmd_record(args)
    elif args.cmd == "compare":
        sys.exit(cmd_compare(args))
    elif args.cmd == "list":
        cmd_list(args)
    elif args.cmd == "volatile":
        cmd_volatile(args)
    elif args.cmd == "summary":
        cmd_summary(args)


if __name__ == "__main__":
    main()
