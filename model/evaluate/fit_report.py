"""The fit's judging and its report (bpy-free): a network's scores on the views (its raw output, as validation
scores it, and as the SSGI node shows it), its prediction time, the verdict against the generic model, and
``MODEL.fit_report.json`` / ``.md`` beside the fitted model (``write``). learn/fit.py makes the numbers'
runs; this module measures and writes them."""
from __future__ import annotations

import math
from pathlib import Path

import numpy as np

from .. import channels as ch, files, images, metrics, normalize
from ..infer import bench, predictor
from ..infer.compose import compose
from ..learn.validation import evaluate


def number(v):
    """Plain float (or None) for checkpoints (weights_only) and JSON."""
    if v is None:
        return None
    v = float(v)
    return v if math.isfinite(v) else (None if math.isnan(v) else v)


def arch_label(arch: dict) -> str:
    if arch.get("backbone") == "unet":
        return f"unet w{'/'.join(map(str, arch['widths']))} c{'/'.join(map(str, arch['convs']))}"
    if arch.get("backbone") == "fssgi":
        return f"fssgi w{arch['width']} {arch['pre']}+{arch['post']}"
    return str(arch.get("variant"))


def as_node(net) -> predictor.Predictor:
    """``net`` as the node runs it (Predictor.predict: output bound, 0 where the albedo is black)."""
    return predictor.Predictor(net.eval(), dict(inputs=list(net.arch["inputs"]), arch=dict(net.arch)), path="fit")


def time_ms(net, size, repeats: int) -> float:
    """Fastest of ``repeats`` predictions of a view (ms): the whole Predictor.predict, as the node runs it.
    The minimum, not the median: the 2 cores are shared, and other processes only ever add time."""
    w, h = size  # bench's synthetic input holds every stored input group (world included)
    return bench.time_predictor(as_node(net), w, h, repeats=max(1, repeats))["ms_min"]


def score(net, samples) -> dict:
    """PSNR, tonemapped PSNR and SSIM of the raw network output on ``samples`` (data.Sample), as training's
    validation scores it (``validation.evaluate``); the fit's decisions use this one. {} without samples."""
    if not samples:
        return {}
    ev = evaluate(net, samples)
    return dict(psnr=number(ev["val_psnr"]), tm_psnr=number(ev["val_tm_psnr"]), ssim=number(ev["val_ssim"]))


def score_node(net, views, keys) -> dict:
    """The views ``keys`` of ``views`` (data.StoredSamples) scored through Predictor.predict, i.e. what the
    SSGI node shows (``score`` scores the raw network output): a model that adds EEVEE's rest (ref_diffuse) is
    composed with the view's rest when the view holds it (model/infer/compose.py), and
    scored against Cycles' whole image. Pooled over the geometry pixels; SSIM with the reference pasted where
    nothing was hit, as ``evaluate`` does."""
    keys = views.keys(keys)
    if not keys:
        return {}
    was_training = net.training
    pred = as_node(net)
    p, tp, ss = metrics.PooledPSNR(), metrics.PooledPSNR(tonemapped=True), []
    try:
        for k in keys:
            g = views.raw[k]
            out = pred.predict(g)
            if ch.adds_part(pred.target) and ch.base_group(pred.target) in g:
                out = compose(out, g, pred.target)
            r = metrics.score(out, normalize.target(g), images.geometry_mask(g["depth"], g["normal"]),
                              with_flip=False)
            p.add_score(r)
            tp.add_score(r)
            ss.append(r["ssim"])
    finally:
        net.train(was_training)
    return dict(psnr=number(p.value), tm_psnr=number(tp.value), ssim=number(float(np.mean(ss))))


def verdict(final, gen, size, gain_db: float) -> str:
    """One sentence: does the scene gain (at least ``gain_db`` dB better than the generic model and at most
    half its prediction time)? ``size``: the views' (height, width)."""
    # judged on the held-out test views as the node shows them (Predictor.predict); val (raw network
    # output) only when there are no test views
    which = "test_node" if final.get("test_node") else "val"
    fv = final[which].get("psnr")
    if gen is None:
        return f"fitted model: {which} PSNR {fv:.2f} dB, {final['ms']:.1f} ms per view (no generic model to compare with)"
    gv = gen[which].get("psnr")
    gain = fv - gv
    key = "ms_big" if final.get("ms_big") and gen.get("ms_big") else "ms"
    at = final["bench_size"] if key == "ms_big" else f"{size[1]}x{size[0]}"
    ratio = final[key] / gen[key] if gen[key] else math.nan
    label = "test, as the node shows it" if which == "test_node" else "val"
    s = (f"held-out ({label}) PSNR {fv:.2f} dB vs generic {gv:.2f} dB ({gain:+.2f} dB), prediction at {at} "
         f"{final[key]:.1f} ms vs {gen[key]:.1f} ms ({ratio:.2f}x)")
    if gain >= gain_db and ratio <= 0.5:
        return "the scene gains: " + s
    why = []
    if gain < gain_db:
        why.append(f"less than {gain_db:g} dB better")
    if not ratio <= 0.5:
        why.append("not at most half the prediction time")
    return f"the scene does not gain enough ({' and '.join(why)}): " + s


# ------------------------------------------------------------------------------ a shot's withheld frames

WITHHELD_METHODS = ("fitted", "fitted_network", "generic", "eevee_gi", "cycles_1spp_oidn", "oracle_diffuse")
WITHHELD_LABELS = {"fitted": "fitted model (SSGI node)", "fitted_network": "fitted network alone, without its lightmap (with its reflection map, if any)",
                   "generic": "generic model (SSGI node)",
                   "eevee_gi": "EEVEE's own render at the scene's settings (its GI as the artist set it)",
                   "cycles_1spp_oidn": "Cycles 1 spp + OIDN",
                   "oracle_diffuse": "ceiling: the reference's diffuse part + EEVEE's rest (as the node corrects it)",
                   "oracle_eevee_rest": "ceiling without the reflection map: the reference's diffuse part + EEVEE's "
                                        "own rest"}
SHOT_BAR_DB = 35.0  # the bar for a fitted model on withheld frames (dB)


def score_withheld(frames: list[dict]) -> dict:
    """Scores of a shot's withheld frames. ``frames``: [{frame, ref (HxWx3), mask (HxW bool, the geometry
    pixels), images: {method: HxWx3}, seconds: {method: s}}], every image the whole frame (the node's image:
    prediction composed with EEVEE's own rest). PSNR and tonemapped PSNR pooled over the geometry pixels of
    all frames, SSIM their mean, each frame's PSNR, and the mean seconds a frame."""
    out: dict = {"frames": [int(f["frame"]) for f in frames], "methods": {}}
    names = [m for m in WITHHELD_METHODS if all(m in f["images"] for f in frames)] + sorted(
        {m for f in frames for m in f["images"]} - set(WITHHELD_METHODS))
    for m in names:
        p, tp, ss, per, secs = metrics.PooledPSNR(), metrics.PooledPSNR(tonemapped=True), [], {}, []
        for f in frames:
            if m not in f["images"]:
                continue
            r = metrics.score(f["images"][m], f["ref"], f["mask"], with_flip=False)
            p.add_score(r)
            tp.add_score(r)
            ss.append(r["ssim"])
            per[str(int(f["frame"]))] = number(r["psnr"])
            if f.get("seconds", {}).get(m) is not None:
                secs.append(float(f["seconds"][m]))
        out["methods"][m] = dict(psnr=number(p.value), tm_psnr=number(tp.value), ssim=number(float(np.mean(ss))),
                                 per_frame=per, seconds=number(float(np.mean(secs))) if secs else None)
    return out


def withheld_verdict(w: dict, bar_db: float = SHOT_BAR_DB) -> str:
    """One sentence on the withheld frames: the fitted model against the bar, the generic model and Cycles
    1 spp + OIDN."""
    ms = w["methods"]
    f = ms["fitted"]["psnr"]
    parts = [f"withheld frames {', '.join(map(str, w['frames']))} as the node renders them: fitted {f:.2f} dB"]
    for m in ("generic", "eevee_gi", "cycles_1spp_oidn"):
        if m in ms:
            parts.append(f"{WITHHELD_LABELS[m].split(' (')[0]} {ms[m]['psnr']:.2f} dB")
    ok = f >= bar_db and ("cycles_1spp_oidn" not in ms or f >= ms["cycles_1spp_oidn"]["psnr"])
    return ("the shot is fitted: " if ok else f"the shot is not fitted (below {bar_db:g} dB or Cycles 1 spp + OIDN): ") \
        + ", ".join(parts)


def withheld_markdown(w: dict) -> list[str]:
    L = ["", "## Withheld frames (never baked, nor any view within "
         f"{w.get('gap', 1)} frame of them)", "",
         f"Frames {', '.join(map(str, w['frames']))} of the shot {w['shot'][0]}-{w['shot'][1]}, camera "
         f"{w.get('camera')!r}, at {w['size'][0]}x{w['size'][1]}, against Cycles {w['ref_samples']} spp + OIDN "
         f"(another seed). {w.get('how', '')}", "",
         "| method | PSNR | PSNR (tonemapped) | SSIM | seconds a frame here | " +
         " | ".join(f"frame {f}" for f in w["frames"]) + " |",
         "|---|---:|---:|---:|---:|" + "---:|" * len(w["frames"])]
    for m, r in w["methods"].items():
        L.append(f"| {WITHHELD_LABELS.get(m, m)} | {_n(r['psnr'])} | {_n(r['tm_psnr'])} | {_n(r['ssim'], '{:.3f}')} | "
                 f"{_n(r.get('seconds'))} | " + " | ".join(_n(r["per_frame"].get(str(f))) for f in w["frames"]) + " |")
    return L


def plain(x):
    """``x`` as plain data for checkpoints and JSON (numbers as ``number``; the key ``net`` left out)."""
    if isinstance(x, dict):
        return {str(k): plain(v) for k, v in x.items() if k != "net"}
    if isinstance(x, (list, tuple)):
        return [plain(v) for v in x]
    if isinstance(x, (np.floating, float)):
        return number(x)
    if isinstance(x, (np.integer,)):
        return int(x)
    return x


def report_paths(model) -> tuple[Path, Path]:
    m = Path(model)
    return m.with_name(m.stem + ".fit_report.json"), m.with_name(m.stem + ".fit_report.md")


def _n(v, fmt="{:.2f}"):
    return "-" if v is None else fmt.format(v)


def report_markdown(rep: dict, model) -> str:
    L = [f"# Fit report: {Path(model).name}", "", f"**{rep['verdict']}**", "",
         f"Views {rep['views']['size'][0]}x{rep['views']['size'][1]}: {len(rep['views']['train'])} train, "
         f"{len(rep['views']['val'])} val (choose), {len(rep['views']['test'])} test (judge). "
         f"Target {rep['target_psnr']:.2f} dB val PSNR ({'reached' if rep['target_reached'] else 'NOT reached'}). "
         f"Fit took {rep['minutes']:.2f} of {rep['budget_minutes']:g} min.", "",
         "## Size search (smallest first)", "",
         "| size | architecture | start | params | MACs/px | predict ms | val PSNR | trained s | decision |",
         "|---|---|---|---:|---:|---:|---:|---:|---|"]
    for r in rep["rows"]:
        if r["phase"] == "size":
            L.append(f"| {r['name']} | {r['arch']} | {r['start']} | {r['params']:,} | {_n(r.get('macs_per_px'), '{:.0f}')} | "
                     f"{_n(r.get('ms'), '{:.1f}')} | {_n(r.get('val_psnr'))} | {_n(r.get('seconds'), '{:.0f}')} | {r['decision']} |")
    L += ["", f"## Inputs (drop when val PSNR falls by at most {rep['drop_tol']:g} dB against the control)", "",
          "| without | inputs | passes rendered | val PSNR | change dB | decision |", "|---|---|---|---:|---:|---|"]
    for r in rep["rows"]:
        if r["phase"] == "inputs":
            d = r.get("delta_db")
            L.append(f"| {r['group']} | {r.get('spec') or '-'} | {', '.join(p.replace('use_pass_', '') for p in r.get('passes', [])) or '-'} | "
                     f"{_n(r.get('val_psnr'))} | {_n(None if d is None else -d, '{:+.2f}')} | {r['decision']} |")
    f, g = rep["final"], rep.get("generic")
    big = f.get("bench_size") or "-"
    L += ["", "## Result", "", "Test columns: the held-out views as the SSGI node shows them (Predictor.predict: "
          "output bound, 0 where the albedo is black); \"raw\" is the network output, as validation scores it.", "",
          f"| model | inputs | params | predict ms (views' size) | predict ms ({big}) | val PSNR (raw) | "
          "test PSNR (raw) | test PSNR | test PSNR (tonemapped) | test SSIM |",
          "|---|---|---:|---:|---:|---:|---:|---:|---:|---:|"]
    for name, m in (("fitted", f), ("generic", g)):
        if m:
            tn = m.get("test_node") or {}
            L.append(f"| {name} ({m['arch']}) | {','.join(m['inputs'])} | {m['params']:,} | {_n(m['ms'], '{:.1f}')} | "
                     f"{_n(m.get('ms_big'), '{:.1f}')} | {_n(m['val'].get('psnr'))} | {_n(m['test'].get('psnr'))} | "
                     f"{_n(tn.get('psnr'))} | {_n(tn.get('tm_psnr'))} | {_n(tn.get('ssim'), '{:.3f}')} |")
    if rep.get("polish"):
        p = rep["polish"]
        L += ["", f"Polish (the kept network, kept inputs, the rest of the budget): val {_n(p['before'])} -> "
              f"{_n(p['after'])} dB in {_n(p['seconds'], '{:.0f}')} s of training."]
    if rep.get("lightmap"):
        m = rep["lightmap"]
        L += ["", "## Shot lightmap", "",
              f"A world-space field of the diffuse light (model/infer/lightmap.py), {m['points']:,} points of the "
              f"training views, {m['steps']:,} steps in {_n(m['seconds'], '{:.0f}')} s; blended into the network's "
              f"diffuse part with weight **{m['lam']:g}** (0: not used), chosen on the validation views:", "",
              "| field \\ weight | " + " | ".join(str(k) for k in m["val_psnr"]) + " |",
              "|---|" + "---:|" * len(m["val_psnr"])]
        tried = m.get("tried") or {"+".join(m.get("known", [])) or "none": m}
        for name, t in tried.items():  # the whole light ("none"), and the light minus the frame's direct light
            what = ("the light the model adds to EEVEE's GI-off image (signed)" if m.get("target") == ch.COMBINED_TARGET
                    else "the whole diffuse light" if name == "none" else f"the light minus the frame's {name}")
            kept = " (kept)" if name == ("+".join(m.get("known", [])) or "none") else ""
            L += [f"| {what}{kept}: val PSNR (dB) | " + " | ".join(_n(v) for v in t["val_psnr"].values()) + " |"]
        if m.get("known"):
            L += ["", f"The kept field learned the diffuse light minus the frame's own {' + '.join(m['known'])}; the node "
                  "adds those passes back each frame, so direct light and moving shadows come from the frame itself."]
    if rep.get("reflmap"):
        m = rep["reflmap"]
        L += ["", "## Shot reflection map", "",
              f"A world-space field of the correction to EEVEE's reflections (model/infer/reflmap.py), "
              f"{m['points']:,} glossy pixels of the training views, {m['steps']:,} steps in "
              f"{_n(m['seconds'], '{:.0f}')} s (L1 {_n(m.get('loss_without'), '{:.4f}')} -> {_n(m.get('loss'), '{:.4f}')}); "
              f"added to EEVEE's rest with weight **{m['lam']:g}** (0: not used), chosen on the validation views "
              "(Cycles' diffuse part + EEVEE's rest + weight x the map, against Cycles):", "",
              "| weight | " + " | ".join(str(k) for k in m["val_psnr"]) + " |",
              "|---|" + "---:|" * len(m["val_psnr"]),
              "| val PSNR (dB) | " + " | ".join(_n(v) for v in m["val_psnr"].values()) + " |"]
    if rep.get("withheld"):
        L += withheld_markdown(rep["withheld"])
    L += ["", f"Data: {rep['data']}", f"Command: `{rep['command']}`", ""]
    return "\n".join(L)


def write(report: dict, model) -> tuple[Path, Path]:
    """Write ``report`` as MODEL.fit_report.json and .md beside ``model`` (atomically); returns both paths."""
    jpath, mpath = report_paths(model)
    files.write_json(jpath, report, indent=1)
    files.write_text(mpath, report_markdown(report, model))
    return jpath, mpath
