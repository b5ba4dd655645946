"""How fast the aperture profile analysis fits the MAV, per shape class, beside the paper's Table I.

    python benchmarks/aperture_profile.py [--depth 0.6] [--repeats 20] [--out benchmarks/out/aperture_profile.json]

Arora & Papachristos (§IV-E, Table I) report the average solution time of
Algorithm 1's contour fitting per aperture shape class: orthogonal 0.88 s,
collapsed 0.97 s, amoeba 1.10 s, U-shaped 1.13 s. Here each of the four
openings of ``collapsed_mockup`` is rasterised from the scene definition at
the pixel size of the MMS's eye-in-hand camera (``CAMERA_INTRINSICS``) at
``--depth`` metres from the wall, and ``profile_analysis`` looks for N_v
configurations of the Tello's nose-first contour. Per shape: the best and
median CPU time of this thread over ``--repeats`` calls (``time.thread_time``:
one core's work), the configurations found and how many came from the
sliding search. Target: ≤ 0.1 s per shape on one core.
"""

from __future__ import annotations

import argparse
import statistics
import time
from pathlib import Path
from typing import Any

from bench_common import machine_info, print_tables, write_report  # the module next to this script

from marsupial.skills.aperture import ProfileParams, mav_contour, profile_analysis
from marsupial.world.apertures import aperture_outline, rasterised
from marsupial.world.robots.mms import CAMERA_INTRINSICS

PAPER_TABLE_I_S = {"orthogonal": 0.88, "collapsed": 0.97, "amoeba": 1.10, "u": 1.13}  # Table I, average [s]
SHAPE_NAMES = {"orthogonal": "orthogonal", "collapsed": "collapsed", "amoeba": "amoeba", "u": "U-shaped"}
TARGET_S = 0.1
DEFAULT_OUT = Path(__file__).resolve().parent / "out" / "aperture_profile.json"


def time_shape(shape: str, depth: float, repeats: int, params: ProfileParams) -> dict[str, Any]:
    """CPU seconds (best, median) of ``profile_analysis`` on one opening, and what it found."""
    K = CAMERA_INTRINSICS.K
    mask, _ = rasterised(aperture_outline(shape), depth / K[0, 0])
    c_m = mav_contour(depth, K)
    times = []
    for _ in range(repeats):
        start = time.thread_time()
        valid = profile_analysis(mask, c_m, params)
        times.append(time.thread_time() - start)
    return {
        "shape": shape, "image_px": list(mask.shape[::-1]), "best_s": min(times), "median_s": statistics.median(times),
        "found": len(valid), "from_sliding": sum(1 for v in valid if v.shift_px != 0),
        "paper_s": PAPER_TABLE_I_S[shape],
    }


def main(argv: list[str] | None = None) -> dict[str, Any]:
    """Time every shape class, print the table beside Table I, write the JSON report."""
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("--depth", type=float, default=0.6, help="camera-to-wall distance (m, default 0.6)")
    parser.add_argument("--repeats", type=int, default=20, help="calls per shape (default 20)")
    parser.add_argument("--out", type=Path, default=DEFAULT_OUT, help="JSON output")
    args = parser.parse_args(argv)
    params = ProfileParams()
    rows = [time_shape(shape, args.depth, args.repeats, params) for shape in PAPER_TABLE_I_S]
    report = {
        "depth_m": args.depth, "repeats": args.repeats, "params": vars(params), "target_s": TARGET_S,
        "shapes": rows, "all_within_target": all(r["median_s"] <= TARGET_S for r in rows),
        "machine": machine_info(),
    }
    table = [
        (SHAPE_NAMES[r["shape"]], "×".join(map(str, r["image_px"])), f"{r['best_s'] * 1e3:.1f}",
         f"{r['median_s'] * 1e3:.1f}", f"{r['paper_s']:.2f}", f"{r['found']} ({r['from_sliding']})",
         "yes" if r["median_s"] <= TARGET_S else "NO")
        for r in rows
    ]
    header = ("shape class", "image px", "best ms", "median ms", "paper Table I s", "found (sliding)", "≤ 0.1 s")
    print_tables([(f"Aperture profile analysis at {args.depth} m, one core", header, table)], report["machine"])
    write_report(report, args.out)
    return report


if __name__ == "__main__":
    main()
