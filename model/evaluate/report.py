"""The speed-against-error report (bpy-free): metrics tables, equal-quality speed-up, plots, report files.

``ssgi_addon/pipeline/report.py`` renders every evaluation scene with every method and times it; it hands this
module a *raw* record (plain data, JSON-able) plus the images of each scene. This module turns it into:

- ``report.json``: every raw number (per method, per scene: metrics and timed parts), the summaries, the
  equal-quality speed-ups, scaling and temporal numbers, machine, versions and settings;
- ``report.md``: the tables, the default model's targets (printed, not asserted), and plain sentences on where the
  learned methods lose to Cycles + OIDN, by how much;
- ``pareto.png``: PSNR against time (log axis), one curve per family, two panels: whole wall time here and
  each method's own cost;
- ``examples.png``: one scene, every method side by side (whole image + a 2x crop), Cycles at equal time.

Its parts: ``analysis`` (summaries, equal-quality speed-ups, Pareto fronts, verdicts, targets), ``figures``
(the two PNGs), ``markdown`` (report.md) and ``record`` (date, machine, versions, the JSON file). The peak
memory of a cold prediction is measured by the prediction benchmark (``infer/bench.peak_memory``).
"""
from __future__ import annotations

from pathlib import Path

from .. import files
from . import analysis, figures, markdown, record


def write_outputs(raw: dict, images: dict, out) -> dict:
    """Analyse ``raw`` and write report.json, report.md, pareto.png and examples.png into ``out``.

    ``images``: {scene: {method key: HxWx3 linear}} with the key "ref" for the reference. The example scene is
    the one where the default model's PSNR is the median (the first scene when there is no model)."""
    out = Path(out)
    out.mkdir(parents=True, exist_ok=True)
    analysis.analyse(raw)
    ex = figures.example_scene(raw, images)
    written = {}
    if ex is not None:
        tiles, err = figures.example_tiles(raw, images[ex])
        written["examples"] = str(figures.examples_png(
            tiles, out / "examples.png", err=err,
            title=f"scene {ex}: each method; Cycles at equal time to the default model "
                  f"(tonemapped x/(1+x), sRGB; box = 2x crop below)"))
        raw["example_scene"] = ex
    written["pareto"] = str(figures.pareto_png(raw, out / "pareto.png"))
    raw["files"] = dict(written, json=str(out / "report.json"), md=str(out / "report.md"))
    written["md"] = str(files.write_text(out / "report.md", markdown.report_md(raw)))
    written["json"] = str(record.write_json(out / "report.json", raw))
    return written
