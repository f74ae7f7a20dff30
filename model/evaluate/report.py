"""The speed-against-error report (bpy-free): metrics tables, equal-quality speed-up, plots, report files.

``ssgi_addon/report_run.py`` renders every evaluation scene with every method and times it; it hands this
module a *raw* record (plain data, JSON-able) plus the images of each scene. This module turns it into:

- ``report.json``: every raw number (per method, per scene: metrics and timed parts), the summaries, the
  equal-quality speed-ups, scaling and temporal numbers, machine, versions and settings;
- ``report.md``: the tables, the targets of issue 6 (printed, not asserted), and plain sentences on where the
  learned methods lose to Cycles + OIDN, by how much;
- ``pareto.png``: PSNR against time (log axis), one curve per family, two panels: whole wall time here and
  each method's own cost;
- ``examples.png``: one scene, every method side by side (whole image + a 2x crop), Cycles at equal time.

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

import datetime
import json
import math
import os
import platform
import sys
from pathlib import Path

import numpy as np

from .. import files, images, metrics
from ..errors import UserError

FAMILIES = {  # family -> (label, colour, marker)
    "eevee_direct": ("EEVEE direct light only", "#7f7f7f", "s"),
    "eevee_gi": ("EEVEE ray tracing + fast GI", "#9467bd", "D"),
    "linear": ("linear regression", "#8c564b", "P"),
    "ssgi": ("SSGI networks (EEVEE G-buffer + CNN)", "#d62728", "o"),
    "cycles": ("Cycles, raw", "#1f77b4", "v"),
    "cycles_oidn": ("Cycles + OIDN (albedo, normal)", "#2ca02c", "^"),
    "reference": ("Cycles reference (another seed)", "#000000", "*"),
}
SOFTWARE_GL = "software GL (Mesa llvmpipe): says nothing about a GPU"
PNG_EXPOSURE = 1.0


# ------------------------------------------------------------------------------------------------ metrics


_PEAK_CODE = r"""
import json, sys, time
sys.path.insert(0, sys.argv[1])
import cli
pkg = cli.load_package()
from importlib import import_module
ck, bench = import_module(pkg.__name__ + ".model.infer.predictor"), import_module(pkg.__name__ + ".model.infer.bench")
w, h, threads = int(sys.argv[3]), int(sys.argv[4]), int(sys.argv[5])
pred = ck.load_predictor(sys.argv[2], num_threads=threads)
g = bench.synthetic_groups(w, h)
before = bench._vm("VmRSS")
t = time.perf_counter()
pred.predict(g)
dt = time.perf_counter() - t
print("PEAK" + json.dumps(dict(peak_mb=(bench._vm("VmHWM") - before) / 2 ** 20, first_ms=1000 * dt)))
"""


def peak_memory(model, w: int, h: int, threads: int = 1, timeout: float = 600) -> dict:
    """Peak memory of one prediction at ``w`` x ``h`` in a fresh Python process (nothing to reuse): the
    process's peak resident set during ``predict`` minus its resident set just before (model and inputs
    loaded). Also the time of that first, cold prediction."""
    import subprocess

    root = Path(__file__).resolve().parents[2]
    p = subprocess.run([sys.executable, "-c", _PEAK_CODE, str(root), str(model), str(w), str(h), str(threads)],
                       capture_output=True, text=True, timeout=timeout)
    line = next((l for l in p.stdout.splitlines() if l.startswith("PEAK")), None)
    if p.returncode != 0 or line is None:
        return dict(peak_mb=None, error=(p.stderr.strip().splitlines() or ["?"])[-1][:200])
    return json.loads(line[4:])


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


def _fmt_t(t) -> str:
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
                         f"{_fmt_t(eq['time_s'])} to reach its {s['psnr']:.2f} dB; it takes {_fmt_t(s['whole_s'])} "
                         f"here ({'at least ' if eq['bound'] == '>=' else ''}{sp:.2f}x faster at equal PSNR)")
        elif eq["winner"] == "undecided":
            b0, b1 = eq["bracket"][0]
            if eq["bound"] == "<=":
                lines.append(f"undecided: Cycles + OIDN's cheapest rung ({_fmt_t(b0)}) is {b1 - s['psnr']:.2f} dB better "
                             f"than its {s['psnr']:.2f} dB, but it takes only {_fmt_t(s['whole_s'])} here; the ladder "
                             f"does not go cheaper")
            else:
                lines.append(f"undecided: its {s['psnr']:.2f} dB is above Cycles + OIDN's best rung ({b1:.2f} dB in "
                             f"{_fmt_t(b0)}), but it takes {_fmt_t(s['whole_s'])}; the ladder does not go further")
        else:
            first = oidn[0] if oidn else None
            if eq["bound"] == "<=" and first is not None:
                lines.append(f"loses: Cycles + OIDN at its cheapest rung ({first[0]} spp, {_fmt_t(first[1])}) is already "
                             f"{first[3] - s['psnr']:.2f} dB better than its {s['psnr']:.2f} dB, and "
                             f"{s['whole_s'] / first[1]:.2f}x faster than its {_fmt_t(s['whole_s'])} here")
            else:
                lines.append(f"loses: Cycles + OIDN reaches its {s['psnr']:.2f} dB in {_fmt_t(eq['time_s'])}, "
                             f"{1 / sp:.2f}x faster than its {_fmt_t(s['whole_s'])} here")
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
                lines.append(f"at equal time (Cycles + OIDN {et['spp']} spp, {_fmt_t(et['whole_s'])}) Cycles + OIDN does "
                             f"better on: " + "; ".join(better))
            else:
                lines.append(f"at equal time (Cycles + OIDN {et['spp']} spp, {_fmt_t(et['whole_s'])}) it is at least as "
                             f"good on PSNR, SSIM, FLIP and the worst scene")
        eo = m.get("equal_quality", {}).get("own", {})
        if math.isfinite(eo.get("speedup", math.nan)):
            lines.append(f"own cost only (prediction {_fmt_t(s['own_s'])}, G-buffer raster not counted): speed-up "
                         f"{eo['bound'] if eo['bound'] != '=' else ''}{eo['speedup']:.2f}x against Cycles + OIDN")
        out[k] = lines
    return out


def targets(raw) -> dict:
    """Issue 6's targets for the shipped default model, measured (printed in report.md, never asserted)."""
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


# ------------------------------------------------------------------------------------------------ outputs


def _json_default(o):
    if isinstance(o, (np.floating, np.integer)):
        return o.item()
    if isinstance(o, np.ndarray):
        return o.tolist()
    if isinstance(o, Path):
        return str(o)
    return str(o)


def _finite_or_str(o):
    """JSON has no inf/nan: write them as strings "inf", "-inf", "nan"."""
    if isinstance(o, float) and not math.isfinite(o):
        return "nan" if math.isnan(o) else ("inf" if o > 0 else "-inf")
    if isinstance(o, dict):
        return {k: _finite_or_str(v) for k, v in o.items()}
    if isinstance(o, (list, tuple)):
        return [_finite_or_str(v) for v in o]
    return o


def write_json(path, raw: dict) -> Path:
    return files.write_json(path, _finite_or_str(raw), indent=1, default=_json_default, allow_nan=False)


def machine() -> dict:
    """What ran the report: CPU, cores, memory, load, OS."""
    cpu = platform.processor() or ""
    try:
        for line in Path("/proc/cpuinfo").read_text().splitlines():
            if line.startswith("model name"):
                cpu = line.split(":", 1)[1].strip()
                break
    except OSError:
        pass
    mem = None
    try:
        for line in Path("/proc/meminfo").read_text().splitlines():
            if line.startswith("MemTotal:"):
                mem = round(int(line.split()[1]) / 2 ** 20, 1)
    except OSError:
        pass
    return dict(cpu=cpu, cores=os.cpu_count(), memory_gib=mem, os=platform.platform(),
                python=sys.version.split()[0], loadavg_start=list(os.getloadavg()) if hasattr(os, "getloadavg") else None)


def versions() -> dict:
    out = dict(python=sys.version.split()[0], numpy=np.__version__)
    for mod in ("torch", "flip_evaluator", "skimage", "OpenEXR", "matplotlib"):
        try:
            m = __import__(mod)
            out[mod] = str(getattr(m, "__version__", "")) or _dist_version(mod)
        except ImportError:
            out[mod] = None
    return out


def _dist_version(mod: str) -> str:
    from importlib import metadata
    for name in (mod, mod.replace("_", "-"), mod.lower()):
        try:
            return metadata.version(name)
        except metadata.PackageNotFoundError:
            continue
    return "?"


def _save_fig(fig, path) -> Path:
    """Write a matplotlib figure as PNG atomically and close it."""
    import matplotlib.pyplot as plt
    try:
        return files.atomic_write(path, lambda p: fig.savefig(p, format="png"))
    finally:
        plt.close(fig)


def _points(raw, family, which):
    pts = []
    for k, m in raw["methods"].items():
        if m["family"] == family and m.get("summary"):
            s = m["summary"]
            pts.append((s[which], s["psnr"], m))
    return sorted(pts, key=lambda p: p[0])


def pareto_png(raw: dict, path) -> Path:
    """PSNR against time (log axis), one curve per family; left: whole wall time here, right: own cost."""
    import matplotlib
    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    fig, axes = plt.subplots(1, 2, figsize=(14, 5.6), dpi=110, sharey=True)
    titles = {"whole_s": "whole wall time per image here (2-core CPU, software GL)",
              "own_s": "own cost per image (learned: prediction only; Cycles: render + denoise)"}
    ys = [m["summary"]["psnr"] for m in raw["methods"].values() if m.get("summary") and math.isfinite(m["summary"]["psnr"])]
    for ax, which in zip(axes, ("whole_s", "own_s")):
        for fam, (label, colour, marker) in FAMILIES.items():
            pts = [p for p in _points(raw, fam, which) if math.isfinite(p[0]) and p[0] > 0 and math.isfinite(p[1])]
            if not pts:
                continue
            ax.plot([p[0] for p in pts], [p[1] for p in pts], marker=marker, color=colour, label=label,
                    ls="-" if len(pts) > 1 else "none", ms=7 if fam != "reference" else 12, lw=1.5)
            for t, p, m in pts:
                tag = (f"{m['spp']}" if fam.startswith("cycles") else m.get("short", ""))
                if tag:
                    ax.annotate(tag, (t, p), textcoords="offset points", xytext=(4, -10 if fam == "cycles" else 5),
                                fontsize=7, color=colour)
        front = raw.get("pareto", {}).get(which, [])
        fp = sorted((raw["methods"][k]["summary"][which], raw["methods"][k]["summary"]["psnr"]) for k in front)
        if len(fp) > 1:
            ax.step([p[0] for p in fp], [p[1] for p in fp], where="post", color="#ff7f0e", alpha=0.35, lw=6,
                    label="Pareto front", zorder=0)
        ax.set_xscale("log")
        ax.set_xlabel("seconds per image (log scale)")
        ax.set_title(titles[which], fontsize=10)
        ax.grid(alpha=0.3, which="both")
    axes[0].set_ylabel("PSNR, dB (seed's convention: linear, clamped to [0,1])")
    if ys:
        axes[0].set_ylim(min(ys) - 1.0, max(ys) + 1.5)
    handles, labels = axes[0].get_legend_handles_labels()
    for h_, l_ in zip(*axes[1].get_legend_handles_labels()):
        if l_ not in labels:
            handles.append(h_)
            labels.append(l_)
    fig.legend(handles, labels, fontsize=8, loc="lower center", ncol=4, frameon=False)
    st = raw.get("settings", {})
    fig.suptitle(f"SSGI: error against time on {len(raw.get('scenes', []))} scene(s) at {st.get('size', '?')}", fontsize=12)
    fig.tight_layout(rect=(0, 0.08, 1, 1))
    return _save_fig(fig, path)


def crop_box(h: int, w: int, err: np.ndarray | None = None) -> tuple[int, int, int, int]:
    """A half-size box (y0, y1, x0, x1): around the largest error of ``err`` (HxW) when given, else centred."""
    ch_, cw = max(1, h // 2), max(1, w // 2)
    if err is None or not np.isfinite(err).any():
        y, x = h // 2, w // 2
    else:
        from scipy.ndimage import uniform_filter
        e = uniform_filter(np.nan_to_num(err).astype(np.float64), size=(ch_, cw), mode="constant")
        y, x = np.unravel_index(int(np.argmax(e)), e.shape)
    y0 = int(min(max(0, y - ch_ // 2), h - ch_))
    x0 = int(min(max(0, x - cw // 2), w - cw))
    return y0, y0 + ch_, x0, x0 + cw


def examples_png(tiles, path, title: str = "", err: np.ndarray | None = None, cols: int = 4) -> Path:
    """``tiles``: [(title, HxWx3 linear image)], the first the reference. Each cell: the whole image with the
    crop box drawn, and below it the 2x crop (nearest). One exposure for all."""
    import matplotlib
    matplotlib.use("Agg")
    import matplotlib.pyplot as plt
    from matplotlib.patches import Rectangle

    h, w = tiles[0][1].shape[:2]
    y0, y1, x0, x1 = crop_box(h, w, err)
    rows = math.ceil(len(tiles) / cols)
    gap = max(2, h // 40)
    cw = 3.4  # inches per column
    cell_h = cw * (2 * h + gap) / w + 0.4  # image + crop, and two lines of title
    fig, axes = plt.subplots(rows, cols, figsize=(cw * cols, cell_h * rows + 0.5), dpi=110, squeeze=False)
    for ax in axes.flat:
        ax.axis("off")
    for i, (name, img) in enumerate(tiles):
        im = images.srgb(img, PNG_EXPOSURE)
        crop = im[y0:y1, x0:x1].repeat(2, axis=0).repeat(2, axis=1)[:h, :w]
        cell = np.ones((2 * h + gap, w, 3))
        cell[:h] = im
        cell[h + gap:h + gap + crop.shape[0], :crop.shape[1]] = crop
        a = axes.flat[i]
        a.imshow(cell, interpolation="nearest")
        a.add_patch(Rectangle((x0 - 0.5, y0 - 0.5), x1 - x0, y1 - y0, fill=False, ec="#ffcc00", lw=1))
        a.set_title(name, fontsize=7.5)
    fig.suptitle(title, fontsize=10)
    fig.subplots_adjust(left=0.01, right=0.99, bottom=0.01, top=1 - 0.75 / (cell_h * rows + 0.5), wspace=0.03,
                        hspace=0.4 / cell_h + 0.02)
    return _save_fig(fig, path)


def _f(x, fmt="{:.2f}") -> str:
    if x is None or (isinstance(x, float) and not math.isfinite(x)):
        return "n/a" if x is None or math.isnan(x) else ("inf" if x > 0 else "-inf")
    return fmt.format(x)


def _parts(m) -> str:
    t = m["summary"]["time"]
    names = {"gbuffer_s": "G-buffer (sw GL)", "predict_s": "predict", "render_s": "render",
             "denoise_s": "denoise"}
    return " + ".join(f"{names[k]} {_fmt_t(t[k])}" for k in names if k in t and k != "whole_s")


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
    L = [f"# SSGI: speed against error", "",
         f"Made {raw.get('date', '?')} by `{raw.get('command', '?')}` in {_fmt_t(raw.get('run_s'))} "
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
        own = _fmt_t(s["own_s"]) + (" (sw GL)" if m.get("own_is_software_gl") else "")
        star = " **(default)**" if k == raw.get("default_model_key") else ""
        L.append(f"| {m['label']}{star} | {_f(s['psnr'])} ({_f(s['worst_psnr'])}, {s['worst_scene']}) | {_f(s['tm_psnr'])} | "
                 f"{_f(s['ssim'], '{:.3f}')} ({_f(s['worst_ssim'], '{:.3f}')}) | {_f(s['flip'], '{:.3f}')} "
                 f"({_f(s['worst_flip'], '{:.3f}')}) | {_fmt_t(s['whole_s'])} | {_parts(m)} | {own} | "
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
                    _fmt_t(by[z]["seconds"]) if z in by else "" for z in sc["sizes"]) + " |")
        L += ["", f"PSNR at the larger sizes: {sc.get('psnr_note', 'not measured')}", ""]
    tp = raw.get("temporal")
    if tp:
        L += [f"## Temporal stability: {tp['frames']} frames of a camera move in `{tp['scene']}`", "",
              "Mean frame-to-frame change of (image - reference) after the Reinhard tonemap (lower is steadier); "
              f"reference {tp['ref_samples']} spp per frame. Cycles + OIDN at equal time: {tp.get('oidn_spp')} spp "
              f"(its mean time {_fmt_t(tp.get('oidn_s'))} is the closest rung to the default model's "
              f"{_fmt_t(tp.get('model_s'))}); Cycles' seed is {tp.get('cycles_seed_note')}. OIDN has no temporal mode.", "",
              "| method | frame-to-frame change of error | mean abs error |", "|---|---|---|"]
        for name, r in tp["methods"].items():
            L.append(f"| {name} | {r['change']:.4f} | {r['mean_abs_error']:.4f} |")
        L.append("")
    tg = raw.get("targets", {})
    if tg:
        L += ["## Issue 6 targets for the default model (measured, not asserted)", "", "```",
              json.dumps(_finite_or_str(tg), indent=1, default=_json_default), "```", ""]
    L += ["## Ladders", "", "| spp | Cycles raw: time, PSNR | Cycles + OIDN: time (render + denoise), PSNR |", "|---|---|---|"]
    raw_l = {r["spp"]: r for r in raw.get("ladders", {}).get("cycles", [])}
    for r in raw.get("ladders", {}).get("cycles_oidn", []):
        a = raw_l.get(r["spp"])
        m = methods.get(f"cycles_oidn_{r['spp']}", {})
        L.append(f"| {r['spp']} | {_fmt_t(a['whole_s']) + ', ' + _f(a['psnr']) + ' dB' if a else ''} | "
                 f"{_fmt_t(r['whole_s'])} ({_parts(m) if m.get('summary') else ''}), {_f(r['psnr'])} dB |")
    L += ["", "## Settings", "", "```", json.dumps(_finite_or_str(st), indent=1, default=_json_default), "```", "",
          "## Machine and versions", "", "```", json.dumps(_finite_or_str(dict(machine=ma, versions=ve)), indent=1,
                                                           default=_json_default), "```", ""]
    if raw.get("notes"):
        L += ["## Notes", ""] + [f"- {n}" for n in raw["notes"]] + [""]
    return "\n".join(L)


def write_outputs(raw: dict, images: dict, out) -> dict:
    """Analyse ``raw`` and write report.json, report.md, pareto.png and examples.png into ``out``.

    ``images``: {scene: {method key: HxWx3 linear}} with the key "ref" for the reference. The example scene is
    the one where the default model's PSNR is the median (the first scene when there is no model)."""
    out = Path(out)
    out.mkdir(parents=True, exist_ok=True)
    analyse(raw)
    ex = example_scene(raw, images)
    written = {}
    if ex is not None:
        tiles, err = example_tiles(raw, images[ex])
        written["examples"] = str(examples_png(tiles, out / "examples.png", err=err,
                                             title=f"scene {ex}: each method; Cycles at equal time to the default model "
                                                   f"(tonemapped x/(1+x), sRGB; box = 2x crop below)"))
        raw["example_scene"] = ex
    written["pareto"] = str(pareto_png(raw, out / "pareto.png"))
    raw["files"] = dict(written, json=str(out / "report.json"), md=str(out / "report.md"))
    written["md"] = str(files.write_text(out / "report.md", report_md(raw)))
    written["json"] = str(write_json(out / "report.json", raw))
    return written


def example_scene(raw, images):
    if not images:
        return None
    k = raw.get("default_model_key")
    ps = raw["methods"].get(k, {}).get("per_scene", {}) if k else {}
    cands = [s for s in images if s in ps]
    if not cands:
        return sorted(images)[0]
    cands.sort(key=lambda s: ps[s]["psnr"])
    return cands[len(cands) // 2]


def example_tiles(raw, imgs: dict):
    """The example cells: reference, EEVEE, the learned methods, then Cycles raw / + OIDN at the rung closest in
    time to the default model (and OIDN at 1 spp). Returns (tiles, error map of the default model)."""
    methods = raw["methods"]
    ref = imgs["ref"]
    tiles = [("Cycles reference", ref)]
    k = raw.get("default_model_key")
    oidn = ladder(methods, "cycles_oidn")
    rung = closest_rung(oidn, methods[k]["summary"]["whole_s"]) if k in methods and methods[k].get("summary") else None
    want = [kk for kk, m in methods.items() if m["family"] in ("eevee_direct", "eevee_gi", "linear", "ssgi")]
    if rung is not None:
        want += [f"cycles_{rung[0]}", f"cycles_oidn_{rung[0]}"]
    if oidn and (rung is None or rung[0] != oidn[0][0]):
        want.append(f"cycles_oidn_{oidn[0][0]}")
    for kk in want:
        if kk in imgs and kk in methods:
            m = methods[kk]
            t = m["summary"]["whole_s"] if m.get("summary") else math.nan
            psnr = metrics.psnr(imgs[kk], ref)
            tiles.append((f"{m['label']}\n{_fmt_t(t)}, {psnr:.2f} dB", imgs[kk]))
    err = None
    if k in imgs:
        err = np.abs(metrics.tonemap(imgs[k]) - metrics.tonemap(ref)).mean(-1)
    return tiles, err


def check_models(paths) -> list[Path]:
    out = []
    for p in paths:
        p = Path(p)
        if not p.is_file():
            raise UserError(f"--models {p}: no such model file")
        out.append(p)
    return out


def now() -> str:
    return datetime.datetime.now().isoformat(timespec="seconds")
