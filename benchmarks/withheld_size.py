"""Benchmark: shot fits' withheld frames scored at an artist size, several models side by side.

A shot fit (``cli.py fit --frames A-B``) scores its withheld frames at the views' size (240x135). This renders
chosen withheld frames of each fitted model's shot at ``--size`` through the node's render path
(``pipeline.fit.render_withheld``: RenderSession at the scene's samples, the default working resolution, the
model's lightmap; EEVEE's own render; Cycles 1 spp + OIDN; a Cycles ``--ref-samples`` + OIDN reference, the same
seed for every model) and prints each method's PSNR, tonemapped PSNR and SSIM over the geometry pixels, and the
seconds a frame. Every model reads the plan (cameras, frames, .blend) of its own fit folder, MODEL.fit/.

    .venv/bin/python benchmarks/withheld_size.py --models room.pt roomc.pt --size 960x540 --frames 25 43 \\
        [--ref-samples 16] [--out DIR] [--json F]
"""
from __future__ import annotations

import argparse
import json
import sys
from pathlib import Path

import _bootstrap  # noqa: E402  (the checkout as package ssgi)

from ssgi.model.cliargs import parse_size  # noqa: E402
from ssgi.model.errors import UserError  # noqa: E402


def main(argv=None) -> int:
    ap = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    ap.add_argument("--models", nargs="+", required=True, metavar="MODEL.pt", help="shot fits (each with MODEL.fit/)")
    ap.add_argument("--size", type=parse_size, default=(960, 540))
    ap.add_argument("--frames", nargs="+", type=int, default=None,
                    help="withheld frames to render (default: every withheld frame of each plan)")
    ap.add_argument("--ref-samples", type=int, default=16, help="Cycles samples of the reference (+ OIDN)")
    ap.add_argument("--out", default=None, help="a PNG sheet a frame per model here (reference | SSGI | ...)")
    ap.add_argument("--json", default=None)
    a = ap.parse_args(argv)
    from ssgi.model.evaluate import fit_report
    from ssgi.ssgi_addon.pipeline import fit as pfit

    rows = {}
    for model in a.models:
        plan_path = pfit.work_dir(model) / "views_plan.json"
        if not plan_path.is_file():
            raise UserError(f"{model}: no fit plan at {plan_path} (a shot fit's model, with its .fit folder, is needed)")
        plan = json.loads(plan_path.read_text())
        frames = a.frames or plan["test_frames"]
        bad = [f for f in frames if f not in plan["test_frames"]]
        if bad:
            raise UserError(f"--frames {bad}: not withheld frames of {model}'s shot ({plan['test_frames']})")
        plan = dict(plan, test_frames=list(frames))
        out = Path(a.out) / Path(model).stem if a.out else None
        done = pfit.render_withheld(plan["blend"], plan, list(a.size), str(model), None, a.ref_samples, out,
                                    log=lambda m: print(m, file=sys.stderr, flush=True))
        w = fit_report.score_withheld(done)
        rows[str(model)] = w
        for m, r in w["methods"].items():
            print(f"{Path(model).name} {a.size[0]}x{a.size[1]} frames {','.join(map(str, frames))} {m}: "
                  f"PSNR {r['psnr']:.2f} dB, tonemapped {r['tm_psnr']:.2f}, SSIM {r['ssim']:.3f}, "
                  f"{r['seconds'] or 0:.1f} s a frame; per frame {r['per_frame']}", flush=True)
    if a.json:
        Path(a.json).write_text(json.dumps(dict(size=list(a.size), ref_samples=a.ref_samples, rows=rows,
                                                command="benchmarks/withheld_size.py " + " ".join(
                                                    argv if argv is not None else sys.argv[1:])), indent=1,
                                           default=str))
    return 0


if __name__ == "__main__":
    _bootstrap.run_main(main)
