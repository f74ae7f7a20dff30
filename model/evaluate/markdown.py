"""The report's ``report.md`` (bpy-free): the methods table, the verdicts, scaling, temporal stability, the
targets, the ladders, settings, machine and versions, from an analysed raw record (``analysis.analyse``)."""
from __future__ import annotations

import json
import math

from .analysis import FAMILIES, fmt_t
from .record import finite_or_str, json_default

SOFTWARE_GL = "software GL (Mesa llvmpipe): says nothing about a GPU"


def _f(x, fmt="{:.2f}") -> str:
    if x is None or (isinstance(x, float) and not math.isfinite(x)):
        return "n/a" if x is None or math.isnan(x) else ("inf" if x > 0 else "-inf")
    return fmt.format(x)


def _parts(m) -> str:
    t = m["summary"]["time"]
    names = {"gbuffer_s": "G-buffer (sw GL)", "rest_s": "EEVEE's other components (sw GL)", "predict_s": "predict",
             "render_s": "render", "denoise_s": "denoise"}
    return " + ".join(f"{names[k]} {fmt_t(t[k])}" for k in names if k in t and k != "whole_s")


def _eq(m, which="whole") -> str:
    e = m.get("equal_quality", {}).get(which)
    if not e or not math.isfinite(e.get("speedup", math.nan)):
        return ""
    b = {"=": "", "<=": "<= ", ">=": ">= "}[e["bound"]]
    side = {"method": "SSGI side wins" if m["family"] == "ssgi" else "this wins",
            "cycles_oidn": "Cycles+OIDN wins", "undecided": "undecided: below the ladder",
            "unknown": "?"}[e["winner"]]
    return f"{b}{e['speedup']:.2f}x ({side})"


def report_md(raw: dict) -> str:
    st, ma, ve = raw.get("settings", {}), raw.get("machine", {}), raw.get("versions", {})
    methods = raw["methods"]
    L = ["# SSGI: speed against error", "",
         f"Made {raw.get('date', '?')} by `{raw.get('command', '?')}` in {fmt_t(raw.get('run_s'))} "
         f"({raw.get('run_s', 0) / 60:.1f} min) of wall time.", "",
         f"**{len(raw.get('scenes', []))} scene(s)** at {st.get('size')} ({st.get('source', '')}): "
         + ", ".join(f"`{s}`" for s in raw.get("scenes", [])), "",
         "Every number below was measured in this one run on this machine. Times are wall time per image, "
         "excluding process start-up and the first-render shader compile (one untimed warm-up render per EEVEE "
         f"configuration). EEVEE runs on {SOFTWARE_GL}.", ""]
    ag = raw.get("gbuffer_agreement_db")
    if ag:
        L += ["Scenes rebuilt from the dataset: PSNR of the EEVEE direct image rendered here against the dataset's "
              f"stored one (below {raw.get('gbuffer_agreement_threshold_db', '?')} dB the report adds a note that the rebuilt scene differs): " + ", ".join(f"`{k}` {_f(v, '{:.1f}')} dB" for k, v in ag.items()), ""]
    L += ["## Methods", "",
          "| method | PSNR dB (worst scene) | tm-PSNR dB | SSIM (worst) | FLIP (worst) | whole time here | parts | own cost | params | MFLOP/px | equal-quality speed-up vs Cycles+OIDN: whole / own |",
          "|---|---|---|---|---|---|---|---|---|---|---|"]
    order = list(FAMILIES)
    keys = sorted((k for k, m in methods.items() if m.get("summary")),
                  key=lambda k: (order.index(methods[k]["family"]), methods[k].get("spp", 0), methods[k]["summary"]["own_s"]))
    for k in keys:
        m, s = methods[k], methods[k]["summary"]
        own = fmt_t(s["own_s"]) + (" (sw GL)" if m.get("own_is_software_gl") else "")
        star = " **(default)**" if k == raw.get("default_model_key") else ""
        L.append(f"| {m['label']}{star} | {_f(s['psnr'])} ({_f(s['worst_psnr'])}, {s['worst_scene']}) | {_f(s['tm_psnr'])} | "
                 f"{_f(s['ssim'], '{:.3f}')} ({_f(s['worst_ssim'], '{:.3f}')}) | {_f(s['flip'], '{:.3f}')} "
                 f"({_f(s['worst_flip'], '{:.3f}')}) | {fmt_t(s['whole_s'])} | {_parts(m)} | {own} | "
                 f"{m.get('params', '') or ''} | {_f(m['macs_per_px'] * 2e-6, '{:.3f}') if m.get('macs_per_px') else ''} | "
                 f"{_eq(m)}{' / ' + _eq(m, 'own') if _eq(m, 'own') else ''} |")
    L += ["", "PSNR: linear RGB clamped to [0, 1], MSE pooled over all pixels of all scenes (the seed's convention); "
          "tm-PSNR: the same after the Reinhard tonemap x/(1+x); SSIM: mean over scenes; FLIP: mean HDR-FLIP over "
          "scenes (lower is better). Worst: the scene with the lowest PSNR / SSIM / the highest FLIP. "
          "Equal-quality speed-up: the time Cycles + OIDN needs for the same pooled PSNR (log-time interpolated on "
          "its spp ladder) divided by the method's time; `<=`/`>=`: outside the ladder, a bound. "
          "The reference row: another Cycles render at the reference's settings with another seed "
          f"(on {st.get('reference_scenes', '?')} scene(s)); its PSNR is the reference's self-agreement.", ""]
    L += ["## Where the learned methods stand against Cycles + OIDN", ""]
    for k, lines in raw.get("verdicts", {}).items():
        L.append(f"- **{methods[k]['label']}**: " + "; ".join(lines) + ".")
    L.append("")
    sc = raw.get("scaling")
    if sc:
        L += ["## Scaling", "",
              "Prediction on synthetic inputs of each size: median of repeated warm calls in this process "
              "(torch threads as in the settings); peak memory: one prediction in a fresh Python process, its "
              "peak resident set minus the resident set just before (model and inputs already loaded).", "",
              "| model | " + " | ".join(sc["sizes"]) + " |", "|---|" + "---|" * len(sc["sizes"])]
        for k, rows in sc.get("models", {}).items():
            by = {r["size"]: r for r in rows}
            L.append(f"| {methods[k]['label'] if k in methods else k} | " + " | ".join(
                f"{by[z]['ms']:.0f} ms, +{_f(by[z].get('peak_mb'), '{:.0f}')} MB" if z in by else "" for z in sc["sizes"]) + " |")
        for name, key in (("EEVEE G-buffer raster (sw GL)", "gbuffer"), ("Cycles 1 spp + OIDN", "cycles_1spp_oidn")):
            by = {r["size"]: r for r in sc.get(key, [])}
            if by:
                L.append(f"| {name} (scene `{sc.get('scene')}`) | " + " | ".join(
                    fmt_t(by[z]["seconds"]) if z in by else "" for z in sc["sizes"]) + " |")
        L += ["", f"PSNR at the larger sizes: {sc.get('psnr_note', 'not measured')}", ""]
    tp = raw.get("temporal")
    if tp:
        L += [f"## Temporal stability: {tp['frames']} frames of a camera move in `{tp['scene']}`", "",
              "Mean frame-to-frame change of (image - reference) after the Reinhard tonemap (lower is steadier); "
              f"reference {tp['ref_samples']} spp per frame. Cycles + OIDN at equal time: {tp.get('oidn_spp')} spp "
              f"(its mean time {fmt_t(tp.get('oidn_s'))} is the closest rung to the default model's "
              f"{fmt_t(tp.get('model_s'))}); Cycles' seed is {tp.get('cycles_seed_note')}. OIDN has no temporal mode.", "",
              "| method | frame-to-frame change of error | mean abs error |", "|---|---|---|"]
        for name, r in tp["methods"].items():
            L.append(f"| {name} | {r['change']:.4f} | {r['mean_abs_error']:.4f} |")
        L.append("")
    L += shot_section(raw.get("temporal_shot"))
    tg = raw.get("targets", {})
    if tg:
        L += ["## Targets for the default model (measured, not asserted)", "", "```",
              json.dumps(finite_or_str(tg), indent=1, default=json_default), "```", ""]
    L += ["## Ladders", "", "| spp | Cycles raw: time, PSNR | Cycles + OIDN: time (render + denoise), PSNR |", "|---|---|---|"]
    raw_l = {r["spp"]: r for r in raw.get("ladders", {}).get("cycles", [])}
    for r in raw.get("ladders", {}).get("cycles_oidn", []):
        a = raw_l.get(r["spp"])
        m = methods.get(f"cycles_oidn_{r['spp']}", {})
        L.append(f"| {r['spp']} | {fmt_t(a['whole_s']) + ', ' + _f(a['psnr']) + ' dB' if a else ''} | "
                 f"{fmt_t(r['whole_s'])} ({_parts(m) if m.get('summary') else ''}), {_f(r['psnr'])} dB |")
    L += ["", "## Settings", "", "```", json.dumps(finite_or_str(st), indent=1, default=json_default), "```", "",
          "## Machine and versions", "", "```", json.dumps(finite_or_str(dict(machine=ma, versions=ve)), indent=1,
                                                           default=json_default), "```", ""]
    if raw.get("notes"):
        L += ["## Notes", ""] + [f"- {n}" for n in raw["notes"]] + [""]
    return "\n".join(L)


def shot_section(ts: dict | None) -> list[str]:
    """The report's warped-flicker section of a shot (ssgi_addon/pipeline/shot_measure.py), or nothing."""
    if not ts:
        return []
    L: list[str] = []
    L += [f"## Warped flicker: {ts['n_frames']} frames of the shot `{ts['shot']}` (frames {ts['frames'][0]}-"
          f"{ts['frames'][1]}, {ts['size'][0]}x{ts['size'][1]})", "",
          "Each method's frame-to-frame change after reprojecting frame t-1 into t with EEVEE's motion vectors, "
          "minus the reference's own change (mean |(m_t - warp m_t-1) - (r_t - warp r_t-1)|, Reinhard "
          f"tonemap, on the {100 * ts['scored_pixel_share']:.0f} % of the pixels that are the same surface in "
          f"both frames; lower is steadier); reference Cycles {ts['ref_samples']} spp + OIDN; Cycles' seed is "
          f"{ts['cycles_seed']}. SSGI's temporal window: {ts['window']} frames of weight {ts['weight']}.", "",
          "| method | warped flicker | unwarped change of error | PSNR dB | tonemapped PSNR dB | s/frame |",
          "|---|---|---|---|---|---|"]
    for name, r in ts["methods"].items():
        L.append(f"| {name} | {r['warped']:.4f} | {r['unwarped']:.4f} | {r['psnr']:.2f} | {r['tm_psnr']:.2f} | "
                 f"{r['s_per_frame']:.2f} |")
    L += ["", f"Bar: SSGI temporal at most Cycles 1 spp + OIDN's warped flicker: "
          f"{ts['bar']['flicker_at_most_cycles_1spp']}; PSNR cost against temporal off "
          f"{ts['bar']['psnr_cost_db']:+.2f} dB (at most 0.3: {ts['bar']['psnr_cost_ok']}).", ""]
    return L
