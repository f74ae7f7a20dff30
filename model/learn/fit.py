"""Fit a model to ONE scene (bpy-free): size search smallest first, input-pass ablation, the decision table.

``fit(FitConfig(...), log=..., callback=..., should_stop=...)`` works on a dataset folder of *views* of one
scene (baked by ``cli.py bake --scenes``; ssgi_addon/blender/views.py makes the views) whose samples are split by the
caller into three disjoint sets of keys:

    train  the views the networks learn from
    val    held-out views that choose: the best epoch of each run, the size, the inputs
    test   held-out views that only judge: the final model against the generic one (never used to choose)

Method (one time budget, ``minutes``, shared by all phases; a run stops early when the budget says so):

1. **Generic.** The starting checkpoint (``init``: the shipped default model, or one given) is scored on the
   val and test views as it is. The target PSNR defaults to its val PSNR + ``TARGET_GAIN_DB`` (2 dB), or to
   ``DEFAULT_TARGET_PSNR`` without a starting checkpoint.
2. **Size search.** The candidates are the ``ladder`` of small architectures (overrides of
   ``network.arch_for``) trained from scratch on all ``INPUT_GROUPS`` and, when there is a starting
   checkpoint, that checkpoint fine-tuned (its own architecture and inputs), ordered by multiply-accumulates
   per pixel, smallest first. Each gets an equal share of ``SIZE_SHARE`` of the budget and stops as soon as
   its val PSNR reaches the target. The first candidate that reaches the target is kept; when none does,
   the one with the best val PSNR is kept (and the report says the target was missed). With other starting
   checkpoints (``also_init``), a *start probe* comes first: ``init`` and each of them are fine-tuned for
   ``PROBE_FRACTION`` of the size step, and the best on the val views is the fine-tune candidate, going on from
   its probe weights (``init`` stays the generic model the report compares with).
3. **Input selection** (learn/ablation.py). The kept network is fine-tuned briefly on its own inputs (the
   control) and, for each input group the head does not need (``channels.drop_order``: `world` first, a
   whole second EEVEE render), with that group removed: the first layers' weights for the removed channels
   are cut out (``drop_inputs``), the rest kept, and the same short fine-tune follows. A group that is 0 on
   every view (a pass the scene never lights) goes first without a run: cutting it changes no output. A group can go when
   the val PSNR without it is at most ``drop_tol`` dB below the control's. Every trial starts from the kept
   network and is compared with the control; when several can go, they are tried together, and dropped
   together only when that too costs at most ``drop_tol`` dB (else only the cheapest goes).
4. **Polish.** What is left of the budget trains the kept network on the kept inputs.
5. **Report** (evaluate/fit_report.py). The final model is scored on the test views beside the generic model; prediction time of
   both is measured (``bench.time_predictor`` at the views' size). The table of every run, the decisions and
   the verdict go into the checkpoint (key ``fit``) and into ``MODEL.fit_report.json`` / ``.md`` beside it.

Inputs are built the way the render path builds them (ssgi_addon/pipeline/render.py): from the stored groups the spec
needs plus the normals, which mark the no-geometry pixels for the depth normalisation even when the spec
drops normals (``normalize.to_inputs``), so a model that keeps depth but drops normals sees what it will see.
"""
from __future__ import annotations

import math
import sys
import time
from dataclasses import dataclass, field
from pathlib import Path

import torch

from .. import channels as ch, cliargs
from ..dataset import folder
from ..errors import UserError
from ..evaluate import fit_report
from ..evaluate.fit_report import arch_label, number, plain
from . import ablation, checkpoint, data, network
from .train import TrainConfig, Trainer
from .validation import evaluate

TARGET_GAIN_DB = 2.0
DEFAULT_TARGET_PSNR = 30.0
SIZE_SHARE = 0.5  # of the budget, for the size search
ABLATION_SHARE = 0.3  # ... for the input ablation (control + one run per droppable group)
MIN_RUN_S = 5.0  # a run shorter than this is not started
PROBE_FRACTION = 0.2  # of the size step, for each starting checkpoint's probe when there are several (``also_init``)

# smallest first: (name, variant, overrides of network.arch_for). Narrow full-resolution levels: at 960x540
# the full-resolution convolutions dominate the time (measured, docs/fit.md), so level 0 is 4-12 wide.
LADDER: tuple[tuple[str, str, dict], ...] = (
    ("xs", "unet", dict(widths=[4, 12, 24, 32], convs=[1, 1, 1, 2])),
    ("s", "unet", dict(widths=[6, 16, 32, 48], convs=[1, 1, 2, 2])),
    ("m", "unet", dict(widths=[12, 24, 32, 48], convs=[1, 1, 2, 2])),
)


@dataclass
class FitConfig:
    data: str
    out: str
    train_keys: list
    val_keys: list
    test_keys: list = field(default_factory=list)
    minutes: float = 10.0
    target_psnr: float | None = None
    init: str | None = None
    # other checkpoints a fit may start from (same architecture as ``init`` or not): each is fine-tuned briefly
    # beside ``init`` (the start probe, PROBE_FRACTION of the size step each) and the best on the val views goes on;
    # ``init`` stays "the generic model" of the report
    also_init: list = field(default_factory=list)
    ladder: list = field(default_factory=lambda: [list(x) for x in LADDER])
    # the inputs scratch candidates start from (None: every input group except "scene" that the views' samples
    # hold; "scene" is derived and the shipped model has it)
    inputs: str | None = None
    drop_tol: float = 0.1
    batch: int = 16
    crop: int = 64
    threads: int | None = None
    seed: int = 0
    bench_repeats: int = 5
    bench_size: str | None = "960x540"  # the final and the generic model are also timed at this size
    min_run_s: float = MIN_RUN_S  # a training run shorter than this is not started
    # what the networks learn (channels.TARGETS; None: the views' default, ref_diffuse; ref_combined: a one-render fit)
    target: str | None = None
    command: str | None = None

    def check(self) -> None:
        if not self.minutes > 0 or not math.isfinite(self.minutes):
            raise UserError(f"--minutes must be > 0 (got {self.minutes})")
        if self.target_psnr is not None and not math.isfinite(self.target_psnr):
            raise UserError(f"--target-psnr must be a number (got {self.target_psnr})")
        if not self.drop_tol >= 0 and self.drop_tol != -math.inf:
            raise UserError(f"--drop-tol must be >= 0 dB (got {self.drop_tol})")
        if not self.train_keys:
            raise UserError(f"{self.data}: no training views (every view is held out)")
        if not self.val_keys:
            raise UserError(f"{self.data}: no held-out validation views")
        sets = [set(map(str, k)) for k in (self.train_keys, self.val_keys, self.test_keys)]
        if sets[0] & sets[1] or sets[0] & sets[2] or sets[1] & sets[2]:
            raise UserError("train, validation and test views must be disjoint")
        if self.inputs is not None:
            ch.parse_spec(self.inputs)
        if self.target is not None and not ch.adds_part(self.target):
            raise UserError(f"fit target {self.target!r}: a fit learns ref_diffuse (the node adds EEVEE's rest to it) or "
                            "ref_combined (added to EEVEE's GI-off Combined image)")
        if not self.ladder and not self.init:
            raise UserError("the size ladder is empty and there is no checkpoint to fine-tune (--init): nothing to "
                            "train")
        for row in self.ladder:
            if len(row) != 3 or not isinstance(row[2], dict):
                raise UserError(f"size ladder entry {row!r} is not (name, variant, overrides)")


# ---------------------------------------------------------------------------------------------- the driver

REPORT_RESERVE = (0.05, 5.0)  # training ends this share of the budget + seconds early: scoring and timing follow


class Budget:
    def __init__(self, minutes: float):
        self.t0 = time.perf_counter()
        self.total = max(1.0, 60.0 * minutes - REPORT_RESERVE[0] * 60.0 * minutes - REPORT_RESERVE[1])

    @property
    def used(self) -> float:
        return time.perf_counter() - self.t0

    @property
    def left(self) -> float:
        return max(0.0, self.total - self.used)


class Cancelled(Exception):
    pass



class Fitter:
    def __init__(self, cfg: FitConfig, log=None, callback=None, should_stop=None):
        cfg.check()
        self.cfg = cfg
        self.log = log or (lambda m: print(m, file=sys.stderr, flush=True))
        self.cb = callback or (lambda d: None)
        self.stop = should_stop or (lambda: False)
        self.out = Path(cfg.out)
        self.work = self.out.with_name(self.out.stem + ".fit")
        self.rows: list[dict] = []
        self.runs = 0

    # -- progress ---------------------------------------------------------------------------------------
    def _report(self, phase: str, message: str, **kw):
        self.cb(dict(phase=phase, message=message, progress=min(1.0, self.budget.used / self.budget.total),
                     elapsed_s=self.budget.used, left_s=self.budget.left, **kw))

    def _check_stop(self):
        if self.stop():
            raise Cancelled()

    # -- one training run -------------------------------------------------------------------------------
    def _train(self, name: str, arch: dict, spec, seconds: float, init_state=None, target=None):
        """Train ``arch`` on ``spec`` for ``seconds`` (fine-tuning ``init_state`` when given); returns
        (net with the best val weights, summary). Stops early when the val PSNR reaches ``target``."""
        self._check_stop()
        spec = ch.parse_spec(spec)
        ds = self.views.dataset(spec, self.train_keys + self.val_keys)
        overrides = {k: v for k, v in arch.items() if k in network.BACKBONES[network.VARIANTS[arch["variant"]]["backbone"]][1]}
        self.runs += 1
        out = self.work / f"{self.runs:02d}_{name}.pt"
        tc = TrainConfig(data=str(self.views.root), out=str(out), variant=arch["variant"], inputs=ch.format_spec(spec),
                         arch=overrides, minutes=max(seconds, 1.0) / 60.0, batch=self.cfg.batch, crop=self.cfg.crop,
                         threads=self.cfg.threads, seed=self.cfg.seed,
                         lr=3e-4 if init_state is not None else None, command=self.cfg.command)
        reached = {"v": False}
        cancelled = {"v": False}

        def stop():
            if self.stop():
                cancelled["v"] = True
                return True
            if self.budget.left <= 0:
                return True
            return reached["v"]

        def cb(d):
            if target is not None and d.get("best_psnr") is not None and d["best_psnr"] >= target:
                reached["v"] = True
            self._report(self.phase, f"{name}: epoch {d['epoch']}"
                         + (f", val {d['val_psnr']:.2f} dB" if d.get("val_psnr") is not None else ""),
                         run=name, val_psnr=d.get("val_psnr"), best_psnr=d.get("best_psnr"))

        quiet = []
        tr = Trainer(tc, ds, split=(self.train_keys, self.val_keys), init_state=init_state, log=quiet.append)
        res = tr.run(callback=cb, should_stop=stop)
        if cancelled["v"]:
            raise Cancelled()
        best = res.get("best") or {}
        if best and out.is_file():
            net = checkpoint.build_net(checkpoint.load(out), out)
        else:  # no epoch completed: the weights as they are
            net = tr.net.eval()
            best = dict(evaluate(net, tr.val_set), epoch=0, minutes=res["minutes"])
        return net, dict(val_psnr=number(best.get("val_psnr")), val_tm_psnr=number(best.get("val_tm_psnr")),
                         epochs=int(res["epochs"]), minutes=number(res["minutes"]), reached=bool(reached["v"]))

    def _score(self, net, keys) -> dict:
        return fit_report.score(net, self.views.samples(tuple(net.arch["inputs"]), keys))

    def _score_node(self, net, keys) -> dict:
        return fit_report.score_node(net, self.views, keys)

    def _ms(self, net, size=None, repeats=None) -> float:
        return number(fit_report.time_ms(net, size or self.views.size, repeats or self.cfg.bench_repeats))

    # -- the fit --------------------------------------------------------------------------------------
    def run(self) -> dict:
        cfg = self.cfg
        self.budget = Budget(cfg.minutes)
        self.phase = "load"
        if cfg.threads:
            torch.set_num_threads(cfg.threads)
        self.work.mkdir(parents=True, exist_ok=True)
        self.views = data.StoredSamples(cfg.data, list(cfg.train_keys) + list(cfg.val_keys) + list(cfg.test_keys),
                                        log=self.log)
        if cfg.target:  # (a known target: cfg.check)
            lacking = [g for g in ch.target_groups(cfg.target) if g not in folder.stored_groups(self.views.manifest)]
            if lacking:
                raise UserError(f"{cfg.data}: the views lack {', '.join(lacking)}, which target {cfg.target} is made "
                                "of; bake them again with this version")
            self.views.target = cfg.target
        self.train_keys, self.val_keys = self.views.keys(cfg.train_keys), self.views.keys(cfg.val_keys)
        self.test_keys = self.views.keys(cfg.test_keys)
        if not self.train_keys or not self.val_keys:
            raise UserError(f"{cfg.data}: no usable training or validation views (left out: {self.views.skipped})")
        self.log(f"fit: {len(self.train_keys)} train / {len(self.val_keys)} val / {len(self.test_keys)} test views "
                 f"of {self.views.size[1]}x{self.views.size[0]}, budget {cfg.minutes:g} min")
        try:
            return self._run()
        except Cancelled:
            self.log("fit cancelled; no model written")
            self._report("cancelled", "cancelled")
            return dict(status="cancelled", model=None, rows=self.rows)

    def _run(self) -> dict:
        cfg = self.cfg
        generic = None
        if cfg.init:
            ck = checkpoint.load(cfg.init)
            gnet = checkpoint.build_net(ck, cfg.init)
            generic = dict(path=str(cfg.init), arch=dict(ck["arch"]), net=gnet, params=network.count_params(gnet),
                           macs=number(network.macs_per_pixel(gnet)), val=self._score(gnet, self.val_keys),
                           test=self._score(gnet, self.test_keys), ms=self._ms(gnet))
            self.log(f"generic {cfg.init}: val {generic['val']['psnr']:.2f} dB, {generic['ms']:.1f} ms per view")
        target = cfg.target_psnr
        if target is None:
            target = generic["val"]["psnr"] + TARGET_GAIN_DB if generic else DEFAULT_TARGET_PSNR
        self.target = float(target)
        self.log(f"target: {self.target:.2f} dB val PSNR")

        # ---- size search
        self.phase = "size"
        if cfg.inputs is not None:
            spec0 = ch.parse_spec(cfg.inputs)
        else:
            stored = folder.stored_groups(self.views.manifest)
            spec0 = tuple(g for g in ch.INPUT_GROUPS
                          if g != "scene" and all(r in stored for r in ch.required_groups((g,))))
        cands = []
        for name, variant, over in cfg.ladder:
            arch = network.arch_for(variant, spec0, **over)
            net = network.build(arch)
            cands.append(dict(name=name, arch=arch, start="scratch", init_state=None,
                              params=network.count_params(net), macs=number(network.macs_per_pixel(net))))
        if generic:
            cands.append(dict(name="generic-ft", arch=dict(generic["arch"]), start="fine-tune",
                              init_state=generic["net"].state_dict(), params=generic["params"], macs=generic["macs"]))
            alts = self._probe_starts(generic) if cfg.also_init else None
            if alts:
                cands[-1] = alts
        cands.sort(key=lambda c: (c["macs"], not c["start"].startswith("fine-tune")))
        chosen = None
        results = []
        size_end = self.budget.used + SIZE_SHARE * self.budget.left  # time a candidate leaves is shared by the next
        for i, c in enumerate(cands):
            secs = max(0.0, size_end - self.budget.used) / (len(cands) - i)
            if secs < cfg.min_run_s and i == 0 and self.budget.left > 4 * cfg.min_run_s:
                secs = cfg.min_run_s  # the smallest is always tried
            if secs < cfg.min_run_s:
                self.log(f"size {c['name']}: not tried (budget spent)")
                self.rows.append(dict(phase="size", name=c["name"], arch=arch_label(c["arch"]), start=c["start"],
                                      params=c["params"], macs_per_px=c["macs"], decision="not tried (budget spent)"))
                continue
            self.log(f"size {c['name']} ({arch_label(c['arch'])}, {c['params']:,} params, {c['start']}): {secs:.0f} s")
            net, r = self._train(c["name"], c["arch"], tuple(c["arch"]["inputs"]), secs, c["init_state"], self.target)
            r.update(name=c["name"], arch=arch_label(c["arch"]), start=c["start"], params=c["params"],
                     macs_per_px=c["macs"], ms=self._ms(net), net=net, spec=ch.format_spec(tuple(net.arch["inputs"])))
            results.append(r)
            self.log(f"size {c['name']}: val {r['val_psnr']:.2f} dB after {r['minutes']:.2f} min, {r['ms']:.1f} ms"
                     + ("  reaches the target" if r["val_psnr"] >= self.target else ""))
            if r["val_psnr"] is not None and r["val_psnr"] >= self.target:
                chosen = r
                for c2 in cands[i + 1:]:
                    self.rows.append(dict(phase="size", name=c2["name"], arch=arch_label(c2["arch"]), start=c2["start"],
                                          params=c2["params"], macs_per_px=c2["macs"],
                                          decision="not tried (a smaller one reached the target)"))
                break
        if not results:
            raise UserError(f"--minutes {cfg.minutes:g}: too short for even one training run")
        reached = chosen is not None
        if chosen is None:
            chosen = max(results, key=lambda r: (r["val_psnr"] if r["val_psnr"] is not None else -math.inf, -r["macs_per_px"]))
        for r in results:
            row = {k: v for k, v in r.items() if k != "net"}
            row["phase"] = "size"
            row["seconds"] = number(60 * row.pop("minutes"))
            row["decision"] = ("kept" if r is chosen else
                               ("below target" if r["macs_per_px"] < chosen["macs_per_px"] else "not kept"))
            self.rows.append(row)
        order = {c["name"]: i for i, c in enumerate(cands)}
        self.rows.sort(key=lambda r: order.get(r.get("name"), -1 if str(r.get("name")).startswith("probe ") else len(order))
                       if r["phase"] == "size" else len(order))  # the start probes first
        self.log(f"size: kept {chosen['name']} ({chosen['arch']}), val {chosen['val_psnr']:.2f} dB"
                 + ("" if reached else f"; no candidate reached the target {self.target:.2f} dB"))

        # ---- input selection
        self.phase = "inputs"
        net, spec, control = self._select_inputs(chosen["net"])

        # ---- polish
        self.phase = "polish"
        polish = None
        if self.budget.left >= cfg.min_run_s:
            pnet, rp = self._train("final", dict(net.arch), spec, self.budget.left, net.state_dict())
            pre = self._score(net, self.val_keys)["psnr"]
            polish = dict(before=pre, after=rp["val_psnr"], seconds=number(60 * rp["minutes"]))
            if rp["val_psnr"] is not None and rp["val_psnr"] >= pre:
                net = pnet
        return self._finish(net, generic, chosen, reached, control, polish)

    def _probe_starts(self, generic) -> dict | None:
        """The start probe (``also_init``): ``init`` and each other checkpoint are fine-tuned for PROBE_FRACTION of
        the size step; the one with the best val PSNR becomes the fine-tune candidate, which goes on from its probe
        weights. One row per probe. Returns that candidate (None when no other checkpoint can be loaded)."""
        starts = [("generic-ft", self.cfg.init, generic["net"], "fine-tune")]
        for i, path in enumerate(self.cfg.also_init):
            if str(path) == str(self.cfg.init):
                continue
            ck = checkpoint.load(path)
            starts.append((f"start{i + 2}-ft", str(path), checkpoint.build_net(ck, path), f"fine-tune ({Path(path).name})"))
        if len(starts) < 2:
            return None
        secs = max(self.cfg.min_run_s, PROBE_FRACTION * SIZE_SHARE * self.budget.left)
        probes = []
        for name, path, net0, start in starts:
            self.log(f"start probe {name} ({Path(path).name}): {secs:.0f} s")
            net, r = self._train(f"probe-{name}", dict(net0.arch), tuple(net0.arch["inputs"]), secs,
                                 net0.state_dict(), self.target)
            self.log(f"start probe {name}: val {r['val_psnr']:.2f} dB after {r['minutes']:.2f} min")
            probes.append((r["val_psnr"] if r["val_psnr"] is not None else -math.inf, name, path, net, start, r))
        best = max(probes, key=lambda p: p[0])
        for v, name, path, net, start, r in probes:
            self.rows.append(dict(phase="size", name=f"probe {name}", arch=arch_label(net.arch), start=start,
                                  params=network.count_params(net), macs_per_px=number(network.macs_per_pixel(net)),
                                  val_psnr=r["val_psnr"], seconds=number(60 * r["minutes"]), epochs=r["epochs"],
                                  decision=f"start probe: {'goes on' if name == best[1] else 'not kept'} ({path})"))
        v, name, path, net, start, r = best
        return dict(name=name, arch=dict(net.arch), start=start + ", after its probe", init_state=net.state_dict(),
                    params=network.count_params(net), macs=number(network.macs_per_pixel(net)))

    def _select_inputs(self, net):
        """Ablation (module doc, step 3; ablation.select_inputs): one equal share of ``ABLATION_SHARE`` of the
        budget per run (the control, each droppable group, their union), at least ``min_run_s`` each: the
        ablation always runs, at most (groups + 2) * min_run_s over budget. Returns (net, spec, control)."""
        spec = tuple(net.arch["inputs"])
        can = ablation.droppable(spec, net.arch.get("head", "log"))
        silent = [g for g in ablation.silent_groups(spec, self.views.samples(spec, self.train_keys + self.val_keys))
                  if g in can]
        n = len(can)  # runs as long as with every group tried: the time the silent groups save goes to the polish
        per = min(ABLATION_SHARE * self.budget.total, self.budget.left * 0.6) / (n + 2) if n > len(silent) else 0.0
        return ablation.select_inputs(net, self._train, max(per, self.cfg.min_run_s), self.cfg.drop_tol, self.rows,
                                      self.log, silent=silent)

    def _finish(self, net, generic, chosen, reached, control, polish) -> dict:
        cfg = self.cfg
        self.phase = "report"
        spec = tuple(net.arch["inputs"])
        ms = self._ms(net)
        big = None
        if cfg.bench_size:
            w, h = cliargs.parse_size(cfg.bench_size)
            big = (h, w)
        ms_big = self._ms(net, big, 2) if big else None
        if generic:  # time both again, alternating, so that both see the same load on the shared cores
            generic["ms_big"] = self._ms(generic["net"], big, 2) if big else None
            for _ in range(2):
                generic["ms"] = min(generic["ms"], self._ms(generic["net"]))
                ms = min(ms, self._ms(net))
                if big:
                    generic["ms_big"] = min(generic["ms_big"], self._ms(generic["net"], big, 2))
                    ms_big = min(ms_big, self._ms(net, big, 2))
        final = dict(arch=arch_label(net.arch), variant=net.arch["variant"], inputs=list(spec),
                     passes=list(ch.required_passes(spec)), params=network.count_params(net),
                     macs_per_px=number(network.macs_per_pixel(net)), ms=ms, ms_big=ms_big, bench_size=cfg.bench_size,
                     val=self._score(net, self.val_keys), test=self._score(net, self.test_keys),
                     test_node=self._score_node(net, self.test_keys))
        gen = None
        if generic:
            generic["test_node"] = self._score_node(generic["net"], self.test_keys)
            gen = {k: generic.get(k) for k in ("path", "params", "macs", "val", "test", "test_node", "ms", "ms_big")}
            gen["arch"] = arch_label(generic["arch"])
            gen["inputs"] = list(generic["arch"]["inputs"])
            gen["passes"] = list(ch.required_passes(tuple(generic["arch"]["inputs"])))
        verdict = fit_report.verdict(final, gen, self.views.size, TARGET_GAIN_DB)
        report = dict(target_psnr=self.target, target_reached=reached, minutes=number(self.budget.used / 60),
                      budget_minutes=cfg.minutes, views=dict(train=self.train_keys, val=self.val_keys, test=self.test_keys,
                                                              size=[self.views.size[1], self.views.size[0]],
                                                              skipped=dict(self.views.skipped)),
                      drop_tol=cfg.drop_tol, chosen_size=chosen["name"], control_val_psnr=control, polish=polish,
                      rows=[plain(r) for r in self.rows], final=plain(final), generic=plain(gen), verdict=verdict,
                      data=str(Path(cfg.data).resolve()), command=cfg.command)
        best = dict(val_psnr=final["val"].get("psnr"), val_tm_psnr=final["val"].get("tm_psnr"),
                    test_psnr=final["test"].get("psnr"), test_node_psnr=(final["test_node"] or {}).get("psnr"))
        ident = dict(path=str(self.views.root.resolve()), manifest_sha256=folder.manifest_sha256(self.views.root),
                     n_samples=len(self.views.raw), settings=self.views.manifest.get("settings", {}),
                     split=dict(by="view", train=self.train_keys, val=self.val_keys, test=self.test_keys))
        ck = checkpoint.make(net, "network", history=[], best=best, dataset=ident, command=cfg.command,
                             extra=dict(fit=report))
        ck["versions"] = {k: str(v) for k, v in ck["versions"].items()}
        checkpoint.save(self.out, ck)
        jpath, mpath = fit_report.write(report, self.out)
        self.log(f"wrote {self.out} (inputs {ch.format_spec(spec)}), {jpath.name}, {mpath.name}")
        self.log(verdict)
        self._report("done", verdict)
        return dict(status="done", model=str(self.out), report=str(jpath), report_md=str(mpath), inputs=list(spec),
                    passes=final["passes"], final=plain(final), generic=plain(gen), target_psnr=self.target,
                    target_reached=reached, verdict=verdict, minutes=report["minutes"], rows=report["rows"])



def fit(cfg: FitConfig, log=None, callback=None, should_stop=None) -> dict:
    return Fitter(cfg, log=log, callback=callback, should_stop=should_stop).run()


def split_views(keys_by_camera: dict[str, list[str]], test_cameras=(), val_cameras=()) -> tuple[list, list, list]:
    """(train, val, test) sample keys: the views of ``val_cameras`` / ``test_cameras`` are held out whole."""
    tr, va, te = [], [], []
    for cam, keys in keys_by_camera.items():
        (te if cam in test_cameras else va if cam in val_cameras else tr).extend(map(str, keys))
    return sorted(tr), sorted(va), sorted(te)
