"""The report's analysis (bpy-free): per-method summaries, the Cycles ladders, equal-quality speed-ups, Pareto
fronts, the verdicts and the default model's targets, computed from the raw record ``ssgi_addon/pipeline/report.py``
measures (``analyse(raw)``). The files made of it are written by ``report.write_outputs``.

Metrics per image (``metrics.score``): PSNR by the seed's convention (linear RGB clamped to [0, 1], MSE
pooled over pixels and channels; over several scenes the MSE is pooled over all of them), PSNR after the
Reinhard tonemap, SSIM and HDR-FLIP (NVIDIA's flip-evaluator on the linear HDR images; 0 = identical,
higher = worse). A method's "mean" is the pooled PSNR / the mean SSIM
and FLIP over scenes; its "worst" is the scene with the lowest PSNR (and highest FLIP), named.

Equal-quality speed-up (``equal_quality``): on the Cycles + OIDN ladder (mean time per image against pooled
PSNR, for 1, 2, 4, ... spp), log(time) is interpolated linearly in PSNR between the two rungs that bracket
the method's PSNR; speed-up = that time / the method's time. Above 1 the method wins; below 1 Cycles + OIDN
wins. Outside the ladder only a bound is known (``bound`` is "<=" or ">=").
"""
from __future__ import annotations

import math

import numpy as np

from .. import metrics

FAMILIES = {  # family -> (label, colour, marker)
    "eevee_direct": ("EEVEE direct light only", "#7f7f7f", "s"),
    "eevee_gi": ("EEVEE ray tracing + fast GI", "#9467bd", "D"),
    "linear": ("linear regression", "#8c564b", "P"),
    "ssgi": ("SSGI networks (EEVEE G-buffer + CNN)", "#d62728", "o"),
    "cycles": ("Cycles, raw", "#1f77b4", "v"),
    "cycles_oidn": ("Cycles + OIDN (albedo, normal)", "#2ca02c", "^"),
    "reference": ("Cycles reference (another seed)", "#000000", "*"),
}


def temporal_change(preds, refs) -> dict:
    """Mean frame-to-frame change of the error (prediction - reference), after the Reinhard tonemap:
    mean over consecutive frame pairs of mean |e_t - e_{t-1}|, with e = tonemap(pred) - tonemap(ref)."""
    if len(preds) != len(refs) or len(preds) < 2:
        raise ValueError("temporal_change needs at least two frames and one reference per frame")
    errs = [metrics.tonemap(metrics.clean(p)) - metrics.tonemap(metrics.clean(r)) for p, r in zip(preds, refs)]
    steps = [float(np.mean(np.abs(b - a))) for a, b in zip(errs, errs[1:])]
    return dict(change=float(np.mean(steps)), per_step=steps, mean_abs_error=float(np.mean([np.mean(np.abs(e)) for e in errs])))



# ------------------------------------------------------------------------------------------------ summaries


def _mean(xs):
    xs = [x for x in xs if x is not None and math.isfinite(x)]
    return float(np.mean(xs)) if xs else math.nan


def summarize_method(m: dict) -> dict:
    """Mean and worst of one method over its scenes (``m["per_scene"]``: scene -> metrics + time parts)."""
    ps = m.get("per_scene", {})
    if not ps:
        return {}
    names = sorted(ps)
    scored = [s for s in names if ps[s]["pixels"]]  # a scene with no geometry pixel has no PSNR
    n_px = sum(ps[s]["pixels"] for s in scored)
    mse = sum(ps[s]["mse"] * ps[s]["pixels"] for s in scored) / n_px if n_px else math.nan
    tm_mse = sum(ps[s]["tm_mse"] * ps[s]["pixels"] for s in scored) / n_px if n_px else math.nan
    worst = min(scored or names, key=lambda s: ps[s]["psnr"] if ps[s]["pixels"] else math.inf)
    worst_flip = max(names, key=lambda s: ps[s]["flip"])
    parts: dict[str, float] = {}
    for key in sorted({k for s in names for k in ps[s].get("time", {})}):
        parts[key] = _mean(ps[s]["time"].get(key) for s in names)
    return dict(n_scenes=len(names), psnr=metrics.psnr_from_mse(mse) if n_px else math.nan,
                tm_psnr=metrics.psnr_from_mse(tm_mse) if n_px else math.nan,
                ssim=_mean(ps[s]["ssim"] for s in names), flip=_mean(ps[s]["flip"] for s in names),
                worst_scene=worst, worst_psnr=ps[worst]["psnr"], worst_ssim=min(ps[s]["ssim"] for s in names),
                worst_flip_scene=worst_flip, worst_flip=ps[worst_flip]["flip"], time=parts,
                whole_s=parts.get("whole_s", math.nan), own_s=parts.get("own_s", math.nan))


def ladder(methods: dict, family: str) -> list[tuple[int, float, float, float]]:
    """(spp, whole time, own time, PSNR) of a Cycles family, by spp."""
    out = []
    for m in methods.values():
        if m["family"] == family and m.get("summary"):
            s = m["summary"]
            out.append((int(m["spp"]), s["whole_s"], s["own_s"], s["psnr"]))
    return sorted(out)


def equal_quality(rungs, psnr: float, t_method: float) -> dict:
    """The time the ladder ``rungs`` [(time, PSNR), ...] (cheapest first) needs to reach ``psnr``, and the
    speed-up ``t_eq / t_method``.

    log(time) is interpolated linearly in PSNR between the bracketing rungs of the ladder's upper envelope
    (a rung that is slower but not better than a cheaper one is ignored). Below the cheapest rung's PSNR the
    ladder reaches the quality already at its cheapest time (``bound`` "<="); above its best rung it is not
    reached (``bound`` ">=": the speed-up is at least the given value)."""
    env: list[tuple[float, float]] = []
    for t, p in sorted(rungs):
        if not (math.isfinite(t) and math.isfinite(p)) or t <= 0:
            continue
        if not env or p > env[-1][1]:
            env.append((t, p))
    res = dict(psnr=psnr, method_s=t_method, bound="=", time_s=math.nan, speedup=math.nan, winner="unknown",
               bracket=None)
    if not env or not math.isfinite(psnr) or not (t_method > 0):
        return res
    if psnr <= env[0][1]:
        t_eq, bound, br = env[0][0], "<=", (0, 0)
    elif psnr > env[-1][1]:
        t_eq, bound, br = env[-1][0], ">=", (len(env) - 1, len(env) - 1)
    else:
        i = next(k for k in range(1, len(env)) if env[k][1] >= psnr)
        (t0, p0), (t1, p1) = env[i - 1], env[i]
        f = (psnr - p0) / (p1 - p0)
        t_eq, bound, br = math.exp(math.log(t0) + f * (math.log(t1) - math.log(t0))), "=", (i - 1, i)
    sp = t_eq / t_method
    # "<=": the ladder needs at most t_eq, so the speed-up is at most sp; ">=": at least sp
    if bound == "<=":  # the ladder needs at most t_eq: the method cannot be more than sp times faster
        winner = "cycles_oidn" if sp < 1 else "undecided"
    elif bound == ">=":
        winner = "method" if sp >= 1 else "undecided"
    else:
        winner = "method" if sp > 1 else "cycles_oidn"
    res.update(time_s=t_eq, speedup=sp, bound=bound, winner=winner, bracket=[env[br[0]], env[br[1]]])
    return res


def pareto_front(points) -> list:
    """Keys of the points (key, time, PSNR) that no other point beats in both (faster or as fast, and better
    or as good, one of them strictly)."""
    pts = [(k, t, p) for k, t, p in points if math.isfinite(t) and math.isfinite(p)]
    front = []
    for k, t, p in pts:
        if not any((t2 <= t and p2 >= p) and (t2 < t or p2 > p) for _, t2, p2 in pts):
            front.append(k)
    return front


def closest_rung(rungs, t: float):
    """The rung (spp, time, ...) whose time is closest to ``t`` on a log scale."""
    ok = [r for r in rungs if math.isfinite(r[1]) and r[1] > 0]
    if not ok or not (t > 0):
        return None
    return min(ok, key=lambda r: abs(math.log(r[1]) - math.log(t)))


# ------------------------------------------------------------------------------------------------ analysis


def analyse(raw: dict) -> dict:
    """Summaries, equal-quality speed-ups, Pareto fronts and verdicts from the raw record (mutates and
    returns it)."""
    methods = raw["methods"]
    for m in methods.values():
        m["summary"] = summarize_method(m)
    oidn = ladder(methods, "cycles_oidn")
    raw["ladders"] = {f: [dict(spp=r[0], whole_s=r[1], own_s=r[2], psnr=r[3]) for r in ladder(methods, f)]
                      for f in ("cycles", "cycles_oidn")}
    for key, m in methods.items():
        s = m.get("summary")
        if not s or m["family"] in ("cycles", "cycles_oidn", "reference"):
            continue
        m["equal_quality"] = dict(
            whole=equal_quality([(r[1], r[3]) for r in oidn], s["psnr"], s["whole_s"]),
            own=equal_quality([(r[2], r[3]) for r in oidn], s["psnr"], s["own_s"]))
        rung = closest_rung(oidn, s["whole_s"])
        if rung is not None:
            c = methods[f"cycles_oidn_{rung[0]}"]["summary"]
            m["equal_time_oidn"] = dict(spp=rung[0], whole_s=rung[1], psnr=c["psnr"], ssim=c["ssim"], flip=c["flip"],
                                        worst_scene=c["worst_scene"], worst_psnr=c["worst_psnr"],
                                        psnr_gap=c["psnr"] - s["psnr"])
    for which in ("whole_s", "own_s"):
        pts = [(k, m["summary"][which], m["summary"]["psnr"]) for k, m in methods.items()
               if m.get("summary") and m["family"] != "reference"]
        raw.setdefault("pareto", {})[which] = pareto_front(pts)
    raw["verdicts"] = verdicts(raw)
    raw["targets"] = targets(raw)
    return raw


def learned(raw) -> list[str]:
    return [k for k, m in raw["methods"].items() if m["family"] in ("ssgi", "linear") and m.get("summary")]


def fmt_t(t) -> str:
    if t is None or not math.isfinite(t):
        return "n/a"
    return f"{t * 1000:.0f} ms" if t < 1 else f"{t:.2f} s"


def verdicts(raw) -> dict:
    """Plain sentences, per learned method, on which side wins and by how much (measured numbers only)."""
    out = {}
    methods = raw["methods"]
    oidn = ladder(methods, "cycles_oidn")
    for k in learned(raw):
        m, s = methods[k], methods[k]["summary"]
        eq = m.get("equal_quality", {}).get("whole", {})
        lines = []
        sp = eq.get("speedup", math.nan)
        if not math.isfinite(sp):
            lines.append("no Cycles + OIDN ladder to compare with")
        elif eq["winner"] == "method":
            lines.append(f"wins: Cycles + OIDN needs {'at least ' if eq['bound'] == '>=' else ''}"
                         f"{fmt_t(eq['time_s'])} to reach its {s['psnr']:.2f} dB; it takes {fmt_t(s['whole_s'])} "
                         f"here ({'at least ' if eq['bound'] == '>=' else ''}{sp:.2f}x faster at equal PSNR)")
        elif eq["winner"] == "undecided":
            b0, b1 = eq["bracket"][0]
            if eq["bound"] == "<=":
                lines.append(f"undecided: Cycles + OIDN's cheapest rung ({fmt_t(b0)}) is {b1 - s['psnr']:.2f} dB better "
                             f"than its {s['psnr']:.2f} dB, but it takes only {fmt_t(s['whole_s'])} here; the ladder "
                             f"does not go cheaper")
            else:
                lines.append(f"undecided: its {s['psnr']:.2f} dB is above Cycles + OIDN's best rung ({b1:.2f} dB in "
                             f"{fmt_t(b0)}), but it takes {fmt_t(s['whole_s'])}; the ladder does not go further")
        else:
            first = oidn[0] if oidn else None
            if eq["bound"] == "<=" and first is not None:
                lines.append(f"loses: Cycles + OIDN at its cheapest rung ({first[0]} spp, {fmt_t(first[1])}) is already "
                             f"{first[3] - s['psnr']:.2f} dB better than its {s['psnr']:.2f} dB, and "
                             f"{s['whole_s'] / first[1]:.2f}x faster than its {fmt_t(s['whole_s'])} here")
            else:
                lines.append(f"loses: Cycles + OIDN reaches its {s['psnr']:.2f} dB in {fmt_t(eq['time_s'])}, "
                             f"{1 / sp:.2f}x faster than its {fmt_t(s['whole_s'])} here")
        et = m.get("equal_time_oidn")
        if et:
            better = []
            if et["psnr"] > s["psnr"]:
                better.append(f"PSNR {et['psnr']:.2f} vs {s['psnr']:.2f} dB")
            if et["ssim"] > s["ssim"]:
                better.append(f"SSIM {et['ssim']:.3f} vs {s['ssim']:.3f}")
            if et["flip"] < s["flip"]:
                better.append(f"FLIP {et['flip']:.3f} vs {s['flip']:.3f}")
            if et["worst_psnr"] > s["worst_psnr"]:
                better.append(f"worst scene {et['worst_psnr']:.2f} dB ({et['worst_scene']}) vs "
                              f"{s['worst_psnr']:.2f} dB ({s['worst_scene']})")
            if better:
                lines.append(f"at equal time (Cycles + OIDN {et['spp']} spp, {fmt_t(et['whole_s'])}) Cycles + OIDN does "
                             f"better on: " + "; ".join(better))
            else:
                lines.append(f"at equal time (Cycles + OIDN {et['spp']} spp, {fmt_t(et['whole_s'])}) it is at least as "
                             f"good on PSNR, SSIM, FLIP and the worst scene")
        eo = m.get("equal_quality", {}).get("own", {})
        if math.isfinite(eo.get("speedup", math.nan)):
            lines.append(f"own cost only (prediction {fmt_t(s['own_s'])}, G-buffer raster not counted): speed-up "
                         f"{eo['bound'] if eo['bound'] != '=' else ''}{eo['speedup']:.2f}x against Cycles + OIDN")
        out[k] = lines
    return out


def targets(raw) -> dict:
    """The targets for the shipped default model (prediction time and memory by size), measured (printed in report.md, never asserted)."""
    methods = raw["methods"]
    k = raw.get("default_model_key")
    if not k or k not in methods or not methods[k].get("summary"):
        return {"note": "no default model among the evaluated models"}
    s = methods[k]["summary"]
    res: dict = {"model": methods[k]["label"]}
    cheaper = [(kk, m["summary"]["psnr"]) for kk, m in methods.items()
               if kk != k and m.get("summary") and m["family"] != "reference" and m["summary"]["own_s"] < s["own_s"]]
    res["pareto_own_cost_here"] = dict(
        on_front=k in raw.get("pareto", {}).get("own_s", []),
        beats_every_cheaper=all(p < s["psnr"] for _, p in cheaper),
        cheaper_methods_better=[dict(method=methods[kk]["label"], psnr=p) for kk, p in cheaper if p >= s["psnr"]])
    sc = raw.get("scaling", {})
    rows = {r["size"]: r for r in sc.get("models", {}).get(k, [])}
    c1 = {r["size"]: r for r in sc.get("cycles_1spp_oidn", [])}
    for size in sc.get("sizes", []):
        r, c = rows.get(size), c1.get(size)
        if r is None:
            continue
        d = dict(predict_ms=r["ms"], peak_mb=r.get("peak_mb"))
        if c is not None:
            d.update(cycles_1spp_oidn_s=c["seconds"], faster_than_cycles_1spp_oidn=r["ms"] / 1000 < c["seconds"])
        res[f"at_{size}"] = d
    last = rows.get("1920x1080")
    res["predict_50ms_at_240x135"] = None if "240x135" not in rows else rows["240x135"]["ms"] <= 50
    res["predict_3s_2GB_at_1920x1080"] = None if last is None else (
        last["ms"] <= 3000 and (last.get("peak_mb") is None or last["peak_mb"] <= 2048))
    return res
