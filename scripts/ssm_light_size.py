#!/usr/bin/env python3
"""Remakes docs/ssm-light-size.svg: GPU time ÷ `hard` against the light's size on `penumbra`.

For each size, one `shadowlab bench` run times `hard` and the techniques below on the same scene
and output (128², the default view), so every point is a ratio from one run (DESIGN.md: speed is
reported as ratios, never asserted). Usage, from the repository root after a release build:

    python3 scripts/ssm_light_size.py [--binary target/release/shadowlab] [--out docs/ssm-light-size.svg]

The numbers are also printed, for the README.
"""

import argparse
import json
import math
import subprocess
import sys
import tempfile
from pathlib import Path

SIZES = [0.25, 0.35, 0.5, 0.7, 1.0]
SERIES = [
    ("ssm", "ssm (lod, adaptive, 3 layers)", "#d62728"),
    ("ssm:layers=1", "ssm, one layer (the paper's LOD)", "#ff7f0e"),
    ("ssm:lod=false", "ssm, no LOD", "#ff9896"),
    ("sampled:samples=64", "sampled, 64 samples", "#1f77b4"),
    ("pcss", "pcss", "#2ca02c"),
]


def bench(binary: str, size: float, frames: int) -> dict:
    with tempfile.TemporaryDirectory() as tmp:
        out = Path(tmp) / "bench.json"
        cmd = [binary, "bench", "--scene", f"penumbra:light_size={size}", "--size", "128x128",
               "--frames", str(frames), "--technique", "hard"]
        for spec, _, _ in SERIES:
            cmd += ["--technique", spec]
        cmd += ["--json", str(out)]
        subprocess.run(cmd, check=True, stdout=subprocess.DEVNULL)
        doc = json.loads(out.read_text())
    return {row["spec"]: row["time_ratio_over_hard"] for row in doc["techniques"]} | {"adapter": doc["adapter"]["name"]}


def svg(ratios: dict, adapter: str) -> str:
    left, right, top, bottom = 60.0, 410.0, 20.0, 270.0
    lo, hi = 0.0, 7.0  # log2 of the ratio: 1 … 128
    x = lambda s: left + (right - left) * (math.log(s) - math.log(SIZES[0])) / (math.log(SIZES[-1]) - math.log(SIZES[0]))
    y = lambda r: bottom - (bottom - top) * (min(max(math.log2(max(r, 1e-9)), lo), hi) - lo) / (hi - lo)
    out = ['<svg xmlns="http://www.w3.org/2000/svg" width="560" height="320" font-family="sans-serif" font-size="11">',
           '<rect width="560" height="320" fill="white"/>']
    for k in range(int(hi) + 1):
        yy = y(2.0 ** k)
        out.append(f'<line x1="{left:.0f}" x2="{right:.0f}" y1="{yy:.1f}" y2="{yy:.1f}" stroke="#ddd"/>'
                   f'<text x="54" y="{yy + 4:.1f}" text-anchor="end">{2 ** k}</text>')
    for s in SIZES:
        xx = x(s)
        out.append(f'<line x1="{xx:.1f}" x2="{xx:.1f}" y1="{top:.0f}" y2="{bottom:.0f}" stroke="#eee"/>'
                   f'<text x="{xx:.1f}" y="286" text-anchor="middle">{s}</text>')
    out.append(f'<text x="{(left + right) / 2:.1f}" y="308" text-anchor="middle">light size (m), penumbra scene, 128², '
               f'{adapter}, one run per size</text>')
    out.append(f'<text x="14" y="{(top + bottom) / 2:.1f}" text-anchor="middle" '
               f'transform="rotate(-90 14 {(top + bottom) / 2:.1f})">GPU ms ÷ hard (log)</text>')
    for i, (spec, label, colour) in enumerate(SERIES):
        points = [(x(s), y(ratios[s][spec])) for s in SIZES if ratios[s].get(spec)]
        out.append(f'<polyline fill="none" stroke="{colour}" stroke-width="2" points="'
                   + " ".join(f"{px:.1f},{py:.1f}" for px, py in points) + '"/>')
        out += [f'<circle cx="{px:.1f}" cy="{py:.1f}" r="3" fill="{colour}"/>' for px, py in points]
        ly = 30 + 18 * i
        out.append(f'<line x1="420" x2="440" y1="{ly}" y2="{ly}" stroke="{colour}" stroke-width="2"/>'
                   f'<text x="444" y="{ly + 4}">{label}</text>')
    out.append("</svg>")
    return "\n".join(out) + "\n"


def main() -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--binary", default="target/release/shadowlab")
    parser.add_argument("--out", default="docs/ssm-light-size.svg")
    parser.add_argument("--frames", type=int, default=5)
    args = parser.parse_args()
    ratios, adapter = {}, "?"
    for size in SIZES:
        ratios[size] = bench(args.binary, size, args.frames)
        adapter = ratios[size].pop("adapter")
        print(f"light {size} m: " + ", ".join(f"{spec} {ratios[size][spec]:.1f}×" for spec, _, _ in SERIES), flush=True)
    Path(args.out).write_text(svg(ratios, adapter.split(" (")[0]))
    print(f"→ {args.out}")
    return 0


if __name__ == "__main__":
    sys.exit(main())
